//! The RESI simulator's own commands on `softplc sim`'s standard input: DIP switches, power
//! cycle, status, the options of [`crate::devices::resi::options`], and the 2RTD sensors.

use crate::devices::resi::model::Series;
use crate::devices::resi::options::NAMES;
use crate::devices::resi::state::rtd::STATUS_HARD_FAULT;
use crate::devices::resi::state::Module;
use crate::line::Parity;
use crate::sim::SimError;

/// Help text.
pub(crate) const HELP: &str = "\
resi commands (DEVICE COMMAND ...):
  dip VALUE               set all DIP switches at once, bit n = DIP(n+1) (0x.., 0b.. or
                          decimal); the module restarts, as after any DIP change
  dip N on|off            set DIP switch N
  address N|flash         compact modules: ADR switches DIP1..4 = N (1..15), or `flash` (0:
                          the address stored in FLASH); slim modules: `255` (DIP4 FD) or `flash`
  baud B                  the baud-rate switches (compact: 4800..256000, slim: 9600..57600)
  parity none|even|odd    DIP8 (compact: none or even); slim: the stored parity
  power-cycle             power off and on: FRAM/FLASH contents kept, edge counters 0
  status                  time, address, switches, inputs, relays, logic
  options                 the simulator's choices where the manual is silent
  option NAME VALUE       change one (see `options`)
  temp CH DEGREES         2RTD: temperature at sensor CH (1..2), °C
  sensor CH ok|fault      2RTD: a sensor fault (STATUS 0x80, REAL_TEMP -999.0) or none
points: `set DEV.DI3 1` sets the level at terminal DI3 (sampled every 10 ms); `set DEV.DIP1 1`
and `set DEV.DIP 0x0A` flip DIP switches; `set DEV.CH1_REAL_TEMP 21.5` sets a 2RTD sensor;
other points are written as the host would write them (e.g. `set DEV.RO1 1`).
The module's UART runs at the DIP baud rate and parity: on `softplc sim` a master at other
settings is not heard (MODEL@ADDR:BAUD:FORMAT sets the switches; a pty carries the baud only).
The FLASH unit address (SMBADR) and the FRAM contents survive `power-cycle`.";

fn number(text: &str) -> Option<u64> {
    let t = text.trim();
    if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        u64::from_str_radix(h, 16).ok()
    } else if let Some(b) = t.strip_prefix("0b").or_else(|| t.strip_prefix("0B")) {
        u64::from_str_radix(&b.replace(['_', '.'], ""), 2).ok()
    } else {
        t.parse().ok()
    }
}

fn bad(point: &str, value: &str) -> SimError {
    SimError::BadValue {
        point: point.to_string(),
        value: value.to_string(),
    }
}

fn bits(v: u32, n: u8) -> String {
    (0..n)
        .map(|i| if v & (1 << i) != 0 { '1' } else { '0' })
        .collect()
}

/// Runs one command; the text to print.
pub(crate) fn command(m: &mut Module, words: &[&str]) -> Result<String, SimError> {
    let series = m.model().series;
    match words {
        ["dip", value] => {
            let v = number(value)
                .and_then(|v| u8::try_from(v).ok())
                .ok_or_else(|| bad("dip", value))?;
            m.set_dip(v);
            Ok(switches(m))
        }
        ["dip", n, state] => {
            let n = n
                .parse::<u8>()
                .ok()
                .filter(|n| (1..=series.dips()).contains(n))
                .ok_or_else(|| bad("dip", n))?;
            let on = match *state {
                "on" | "1" => true,
                "off" | "0" => false,
                _ => return Err(bad("dip", state)),
            };
            let bit = 1u8 << (n - 1);
            let dip = m.system().dip();
            m.set_dip(if on { dip | bit } else { dip & !bit });
            Ok(switches(m))
        }
        ["address", value] => {
            let a = match *value {
                "flash" => Some(0),
                v => v.parse::<u8>().ok().filter(|a| *a != 0),
            };
            let ok = a.is_some_and(|a| m.change_switches(|s| s.set_address_switches(a)));
            if ok {
                Ok(switches(m))
            } else {
                Err(bad("address", value))
            }
        }
        ["baud", value] => {
            let ok = value.parse::<u32>().ok().is_some_and(|b| {
                m.change_switches(|s| match s.baud_bits(b) {
                    Some(bits) => {
                        let mask = s.baud_mask();
                        s.set_dip((s.dip() & !mask) | bits);
                        true
                    }
                    None => false,
                })
            });
            if ok {
                Ok(switches(m))
            } else {
                Err(bad("baud", value))
            }
        }
        ["parity", value] => {
            let p = match *value {
                "none" => Parity::None,
                "even" => Parity::Even,
                "odd" => Parity::Odd,
                _ => return Err(bad("parity", value)),
            };
            if m.change_switches(|s| s.set_parity(p)) {
                Ok(switches(m))
            } else {
                Err(bad("parity", value))
            }
        }
        ["power-cycle"] => {
            m.power_cycle();
            Ok(format!("power cycled; {}", switches(m)))
        }
        ["status"] => Ok(status(m)),
        ["options"] => Ok(m.opts.describe()),
        ["option", name, value] => {
            m.opts
                .set(name, value)
                .map_err(|e| SimError::UnknownCommand(format!("option {name} {value}: {e}")))?;
            Ok(format!("option {name} = {value}"))
        }
        ["option", ..] => Err(SimError::UnknownCommand(format!(
            "option NAME VALUE; names: {}",
            NAMES.join(", ")
        ))),
        ["temp", ch, degrees] => {
            let c = channel(ch)?;
            let t = degrees
                .parse::<f64>()
                .ok()
                .filter(|t| t.is_finite())
                .ok_or_else(|| bad("temp", degrees))?;
            m.set_temperature(c, t).map_err(|_| bad("temp", ch))?;
            Ok(format!("sensor {ch}: {t} °C"))
        }
        ["sensor", ch, state] => {
            let c = channel(ch)?;
            let bits = match *state {
                "ok" => 0,
                "fault" => STATUS_HARD_FAULT,
                _ => return Err(bad("sensor", state)),
            };
            m.set_sensor_fault(c, bits).map_err(|_| bad("sensor", ch))?;
            Ok(format!("sensor {ch}: {state}"))
        }
        ["help"] => Ok(HELP.to_string()),
        _ => Err(SimError::UnknownCommand(words.join(" "))),
    }
}

fn channel(ch: &str) -> Result<u8, SimError> {
    ch.parse::<u8>()
        .ok()
        .filter(|c| (1..=2).contains(c))
        .map(|c| c - 1)
        .ok_or_else(|| bad("channel", ch))
}

/// The switches and what they select.
pub(crate) fn switches(m: &Module) -> String {
    let s = m.system();
    let parity = match s.parity() {
        Parity::None => 'N',
        Parity::Even => 'E',
        Parity::Odd => 'O',
    };
    let n = m.model().series.dips();
    let source = match m.model().series {
        Series::Compact if s.dip() & 0x0F != 0 => "ADR switches",
        Series::Slim if s.dip() & 0x08 != 0 => "FD switch",
        _ => "FLASH",
    };
    format!(
        "DIP1..{n}={} (0x{:02X}) address={} from {source} (FLASH {}) {} Bd 8{parity}1",
        bits(u32::from(s.dip()), n),
        s.dip(),
        s.address(),
        s.flash(),
        s.baud(),
    )
}

fn status(m: &Module) -> String {
    use crate::devices::resi::item::{Item, Kind};
    let hw = m.model().hw;
    let read = |kind: Kind| m.read(Item::new(kind, 0)).map(|n| n.int()).unwrap_or(0);
    let mut out = format!("t={} ms {}", m.now(), switches(m));
    if hw.inputs > 0 {
        let dis = read(Kind::Dis) as u32;
        out += &format!(" DI1..{}={}", hw.inputs, bits(dis, hw.inputs));
    }
    if hw.relays > 0 {
        out += &format!(
            " RO1..{}={}",
            hw.relays,
            bits(read(Kind::Ros) as u32, hw.relays)
        );
    }
    if hw.logic {
        out += &format!(" ENABLE_LOGIC_FUNCTIONS={}", read(Kind::EnableLogic));
    }
    if hw.one_relay {
        out += &format!(
            " DO1={} TDO1={} OFFDLY={} ms",
            read(Kind::Do),
            read(Kind::TrueDo),
            read(Kind::OffDelay)
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::resi::models::{m16di8ro, m2rtd};

    #[test]
    fn switches_change_address_and_line() {
        let mut m = Module::new(&m16di8ro::MODEL, 20);
        assert!(switches(&m).contains("address=20 from FLASH (FLASH 20) 19200 Bd 8E1"));
        command(&mut m, &["address", "5"]).unwrap();
        assert_eq!(m.address(), 5);
        command(&mut m, &["baud", "115200"]).unwrap();
        command(&mut m, &["parity", "none"]).unwrap();
        let s = switches(&m);
        assert!(s.contains("address=5 from ADR switches"), "{s}");
        assert!(s.contains("115200 Bd 8N1"), "{s}");
        command(&mut m, &["dip", "1", "off"]).unwrap();
        assert_eq!(m.address(), 4);
        command(&mut m, &["address", "flash"]).unwrap();
        assert_eq!(m.address(), 20);
        command(&mut m, &["dip", "0b1010_0011"]).unwrap();
        assert_eq!(m.address(), 3);
        assert!(command(&mut m, &["baud", "57601"]).is_err());
        assert!(command(&mut m, &["address", "16"]).is_err());
        assert!(command(&mut m, &["parity", "odd"]).is_err());
        assert!(command(&mut m, &["dip", "9", "on"]).is_err());
        assert!(command(&mut m, &["dip", "256"]).is_err());
        assert!(command(&mut m, &["temp", "1", "20"]).is_err(), "no sensor");
        assert!(command(&mut m, &["frobnicate"]).is_err());
        assert!(command(&mut m, &["status"])
            .unwrap()
            .contains("RO1..8=00000000"));
        command(&mut m, &["option", "switch", "change"]).unwrap();
        assert!(command(&mut m, &["options"]).unwrap().contains("change"));
        assert!(command(&mut m, &["option", "switch", "sideways"]).is_err());
    }

    #[test]
    fn rtd_sensors() {
        let mut m = Module::new(&m2rtd::MODEL, 1);
        command(&mut m, &["temp", "2", "-12.5"]).unwrap();
        command(&mut m, &["sensor", "1", "fault"]).unwrap();
        assert!(command(&mut m, &["temp", "3", "1"]).is_err());
        assert!(command(&mut m, &["temp", "1", "NaN"]).is_err());
    }
}
