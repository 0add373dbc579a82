//! The module side of the ASCII protocol: a request frame in, the answer frame out, over the
//! model's command table and the module state.
//!
//! - "The module answers, if it feels addressed" (L2032): a request with the module's address,
//!   with address 0 ("All modules react to the broadcast bus address 0", L2015) or without an
//!   address (L2021). The last two are answered too, as the manual's samples show
//!   (`#0,VERSION` → `#0,VERSION:3.0.0`, L2073), unless the option `ascii-broadcast silent`.
//! - The address is echoed as it arrived; set commands answer `OK`, `#<addr>,OK` when the
//!   request had an address (resi-spec §2.8 point 2; the 16DI8RO table prints `#OK` for
//!   `SROS`/`SROx`, L18812, which our driver accepts as well).
//! - Anything the module does not understand (unknown command, wrong channel, missing,
//!   surplus or malformed parameters, a value out of range) gets no answer: the manual
//!   documents no error answer (resi-spec §2.4).

use super::command::{self, Action, Command, Field, Fmt, Op, Text};
use super::frame::{frame, hex, parse_number, real, Frame};
use super::sensor_config;
use crate::devices::resi::item::Item;
use crate::devices::resi::state::Module;
use crate::devices::resi::value::Num;

/// The answer to `request` (a whole frame, CR included), if the module gives one.
pub(crate) fn answer(m: &mut Module, request: &[u8]) -> Option<Vec<u8>> {
    let f = Frame::parse(request).ok()?;
    let broadcast = match f.address {
        None => true,
        Some(a) if a.value == 0 => true,
        Some(a) if a.value == u32::from(m.address()) => false,
        Some(_) => return None,
    };
    let (cmd, x) = command::find(m.model().commands, f.keyword, m.opts.lenient)?;
    let body = execute(m, cmd, x, f.params)?;
    if broadcast && !m.opts.ascii_broadcast_answer {
        return None;
    }
    Some(frame(f.address.map(|a| a.text), &body))
}

fn item(field: &Field, x: u8) -> Item {
    Item::new(field.kind, field.index(x))
}

/// Runs a command; the answer's body, or `None` for silence.
fn execute(m: &mut Module, cmd: &Command, x: u8, params: Option<&str>) -> Option<String> {
    match cmd.action {
        Action::Text(t) => {
            params.is_none().then_some(())?;
            let model = m.model();
            let text = match t {
                Text::Version => model.version,
                Text::Type => model.type_name,
                Text::Owner => "RESI",
                Text::Creator => "DI HC SIGL,MSC",
                Text::Copyright => model.copyright,
            };
            Some(format!("{}:{text}", t.keyword()))
        }
        Action::Get { fields, fmt, .. } => {
            params.is_none().then_some(())?;
            let values = fields
                .iter()
                .map(|f| m.read(item(f, x)).ok())
                .collect::<Option<Vec<Num>>>()?;
            if fmt == Fmt::SensorConfig {
                let words: Vec<u16> = values.iter().map(|v| v.int() as u16).collect();
                let body = match words.as_slice() {
                    [one] => sensor_config::format(*one),
                    both => sensor_config::format_both(both),
                };
                return Some(format!("{}:{body}", cmd.reply_keyword(x)));
            }
            Some(format!(
                "{}:{}",
                cmd.reply_keyword(x),
                format_values(&values, fmt)
            ))
        }
        Action::Set { fields } => {
            let texts: Vec<&str> = params?.split(',').collect();
            if texts.len() != fields.len() {
                return None;
            }
            let mut values = Vec::with_capacity(fields.len());
            for (f, t) in fields.iter().zip(&texts) {
                let v = parse_number(t)?;
                if matches!(v, Num::Real(_)) && !f.kind.is_real() {
                    return None;
                }
                values.push(v);
            }
            for (f, v) in fields.iter().zip(values) {
                m.write(item(f, x), v).ok()?;
            }
            Some("OK".to_string())
        }
        Action::SetSensorConfig { fields } => {
            let parts: Vec<&str> = params?.split(',').collect();
            let words: Vec<u16> = match fields.len() {
                1 => vec![sensor_config::parse(&parts)?],
                2 => sensor_config::parse_both(&parts)?.to_vec(),
                _ => return None,
            };
            for (f, w) in fields.iter().zip(words) {
                m.write(item(f, x), Num::Int(w.into())).ok()?;
            }
            Some("OK".to_string())
        }
        Action::Do(op) => {
            params.is_none().then_some(())?;
            match op {
                Op::ResetCounters => m.reset_counters().ok()?,
                Op::ClearLogic => m.clear_logic().ok()?,
                Op::Reset => {
                    m.reset();
                    return None;
                }
            }
            Some("OK".to_string())
        }
    }
}

/// The numbers of a get answer.
pub(crate) fn format_values(values: &[Num], fmt: Fmt) -> String {
    let dec = |v: &Num| v.int().to_string();
    let hx = |v: &Num| hex(v.int());
    let parts: Vec<String> = match fmt {
        Fmt::Pairs => values.iter().flat_map(|v| [dec(v), hx(v)]).collect(),
        Fmt::DecsThenHexes => values
            .iter()
            .map(dec)
            .chain(values.iter().map(hx))
            .collect(),
        Fmt::Reals => values.iter().map(|v| real(v.real())).collect(),
        Fmt::SensorConfig => values
            .iter()
            .map(|v| sensor_config::format(v.int() as u16))
            .collect(),
    };
    parts.join(",")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::resi::models::m16di8ro::MODEL;

    fn ask(m: &mut Module, req: &str) -> Option<String> {
        answer(m, req.as_bytes()).map(|b| String::from_utf8(b).unwrap())
    }

    #[test]
    fn identity_and_addressing() {
        let mut m = Module::new(&MODEL, 43);
        assert_eq!(ask(&mut m, "#VER\r").as_deref(), Some("#VERSION:3.0.0\r"));
        assert_eq!(
            ask(&mut m, "#0x2B,VER\r").as_deref(),
            Some("#0x2B,VERSION:3.0.0\r")
        );
        assert_eq!(
            ask(&mut m, "#43,TYPE\r").as_deref(),
            Some("#43,TYPE:RESI-16DI8RO-ASCII\r")
        );
        assert_eq!(
            ask(&mut m, "#0,VERSION\r").as_deref(),
            Some("#0,VERSION:3.0.0\r")
        );
        assert_eq!(ask(&mut m, "#44,VER\r"), None, "another module");
        assert_eq!(
            ask(&mut m, "#43,CRE\r").as_deref(),
            Some("#43,CREATOR:DI HC SIGL,MSC\r")
        );
        assert_eq!(
            ask(&mut m, "#43,GMBADR\r").as_deref(),
            Some("#43,GMBADR:43,43,0x2B,0x2B\r")
        );
        m.opts.ascii_broadcast_answer = false;
        assert_eq!(ask(&mut m, "#0,VER\r"), None);
        assert_eq!(
            ask(&mut m, "#43,VER\r").as_deref(),
            Some("#43,VERSION:3.0.0\r")
        );
    }

    #[test]
    fn silence_on_what_is_not_understood() {
        let mut m = Module::new(&MODEL, 1);
        for req in [
            "#NOPE\r",
            "#GDI17\r",
            "#SRO1\r",
            "#SRO1:1,2\r",
            "#SRO1:x\r",
            "#SRO1:1.5\r",
            "#SSWITCH1:70000\r",
            "#GDIS:1\r",
            "#VER:1\r",
            "#RC:1\r",
            "#gdis\r",
            "#1,GDIS",
        ] {
            assert_eq!(ask(&mut m, req), None, "{req:?}");
        }
        assert_eq!(ask(&mut m, "#RST\r"), None, "RST answers nothing");
        m.opts.lenient = true;
        assert_eq!(ask(&mut m, "#gdis\r").as_deref(), Some("#GDIS:0,0x0\r"));
    }

    #[test]
    fn the_2rtd_sensor_configuration_by_name() {
        use crate::devices::resi::item::Kind;
        let mut m = Module::new(&crate::devices::resi::models::m2rtd::MODEL, 7);
        assert_eq!(
            ask(&mut m, "#7,GSCS\r").as_deref(),
            Some("#7,CSCS:S1,PT100,500MYA,EUROPE,CELSIUS,S2,PT100,500MYA,EUROPE,CELSIUS\r")
        );
        assert_eq!(
            ask(&mut m, "#7,SSC2:NI120,1MA,ITS90,KELVIN\r").as_deref(),
            Some("#7,OK\r")
        );
        assert_eq!(
            ask(&mut m, "#7,GETSENSORCONFIG2\r").as_deref(),
            Some("#7,CSC2:NI120,1MA,ITS90,KELVIN\r")
        );
        // The same word as the register holds (4x06041: TYPE 7, CURRENT 1, LIN 3, UNIT 2).
        assert_eq!(
            m.read(Item::new(Kind::SensorType, 1)).map(|v| v.int()),
            Ok(0x2317)
        );
        assert_eq!(
            ask(
                &mut m,
                "#7,SSCS:S1,PT1000,5MYA,JAPAN,FAHRENHEIT,S2,PT10,250MYA,DONT_CARE,CELSIUS\r"
            )
            .as_deref(),
            Some("#7,OK\r")
        );
        assert_eq!(
            ask(&mut m, "#7,GSC1\r").as_deref(),
            Some("#7,CSC1:PT1000,5MYA,JAPAN,FAHRENHEIT\r")
        );
        // Malformed: no answer, nothing changed (resi-spec §2.4).
        for bad in [
            "#7,SSC1:PT99,1MA,EUROPE,CELSIUS\r",
            "#7,SSC1:PT100,1MA,EUROPE\r",
            "#7,SSCS:S2,PT100,1MA,EUROPE,CELSIUS,S1,PT100,1MA,EUROPE,CELSIUS\r",
            "#7,GSC1:1\r",
        ] {
            assert_eq!(ask(&mut m, bad), None, "{bad:?}");
        }
        assert_eq!(
            ask(&mut m, "#7,GSC1\r").as_deref(),
            Some("#7,CSC1:PT1000,5MYA,JAPAN,FAHRENHEIT\r")
        );
    }

    #[test]
    fn formats() {
        let v = [Num::Int(43), Num::Int(5)];
        assert_eq!(format_values(&v, Fmt::Pairs), "43,0x2B,5,0x5");
        assert_eq!(format_values(&v, Fmt::DecsThenHexes), "43,5,0x2B,0x5");
        assert_eq!(format_values(&[Num::Real(21.5)], Fmt::Reals), "21.5");
    }
}
