//! The host side of the ASCII protocol: request lines from the command table, answers checked
//! and read. The driver sends the short names (no spaces, shortest frames, resi-spec §2.8) and
//! always its decimal address; it accepts `OK` with or without the address (the 16DI8RO
//! table prints `#OK` for `SROS`, L18812) and spaces after the `:` (L11470).

use super::super::ascii::command::{Action, Command, Op, COMMON};
use super::super::ascii::frame::{self, parse_number, Frame};
use super::super::item::Item;
use super::super::model::Model;
use super::super::value::Num;
use crate::driver::{Integrity, Outgoing};

/// The request line `#<addr>,<CMD><x>[:<params>]` + CR.
pub fn request(address: u8, command: &Command, x: u8, params: &[Num]) -> Outgoing {
    let mut body = command.short.to_string();
    if command.x.is_some() {
        body += &x.to_string();
    }
    if !params.is_empty() {
        let p: Vec<String> = params
            .iter()
            .map(|n| match n {
                Num::Int(v) => v.to_string(),
                Num::Real(r) => frame::real(*r),
            })
            .collect();
        body += ":";
        body += &p.join(",");
    }
    Outgoing::Text {
        line: frame::frame(Some(&address.to_string()), &body),
        terminator: b'\r',
        // "No LF, no checksum, no escapes" (resi-spec §2.1).
        integrity: Integrity::Unchecked,
    }
}

/// Why an answer is not the expected one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BadAnswer;

/// The values of an answer to `command` for channel `x`, as text.
pub fn answer_values(
    answer: &[u8],
    address: u8,
    command: &Command,
    x: u8,
) -> Result<Vec<String>, BadAnswer> {
    let f = Frame::parse_answer(answer).map_err(|_| BadAnswer)?;
    if f.address.is_some_and(|a| a.value != u32::from(address)) {
        return Err(BadAnswer);
    }
    if f.keyword != command.reply_keyword(x) {
        return Err(BadAnswer);
    }
    Ok(f.values().into_iter().map(str::to_string).collect())
}

/// Whether an answer is `OK` from this module.
pub fn is_ok(answer: &[u8], address: u8) -> bool {
    Frame::parse_answer(answer).is_ok_and(|f| {
        f.keyword == "OK"
            && f.params.is_none()
            && f.address.is_none_or(|a| a.value == u32::from(address))
    })
}

/// The number at `at` of an answer's values, or a part of it (first bit, width).
pub(crate) fn value(values: &[String], at: usize, part: Option<(u8, u8)>) -> Option<Num> {
    let n = parse_number(values.get(at)?)?;
    Some(match part {
        None => n,
        Some((shift, width)) => {
            let mask = (1i64 << width.min(62)) - 1;
            Num::Int((n.int() >> shift.min(62)) & mask)
        }
    })
}

/// The set command that writes `item` alone: (command, x).
pub(crate) fn ascii_set(model: &'static Model, item: Item) -> Option<(&'static Command, u8)> {
    model
        .commands
        .iter()
        .chain(COMMON.iter())
        .filter_map(|c| match c.action {
            Action::Set { fields: [f] } => Some((c, f)),
            _ => None,
        })
        .find_map(|(c, f)| {
            let (first, last) = c.x.unwrap_or((1, 1));
            (first..=last)
                .find(|&x| Item::new(f.kind, f.index(x)) == item)
                .map(|x| (c, x))
        })
}

/// The command that performs `op`.
pub(crate) fn ascii_op(model: &'static Model, op: Op) -> Option<&'static Command> {
    model
        .commands
        .iter()
        .chain(COMMON.iter())
        .find(|c| c.action == Action::Do(op))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::resi::item::{Func, Kind};
    use crate::devices::resi::models::m16di8ro::MODEL;

    #[test]
    fn lines_and_answers() {
        let (c, x) = ascii_set(&MODEL, Item::new(Kind::Mask(Func::SwitchOn), 0)).unwrap();
        let Outgoing::Text {
            line, terminator, ..
        } = request(5, c, x, &[Num::Int(15)])
        else {
            panic!()
        };
        assert_eq!(
            (line.as_slice(), terminator),
            (&b"#5,SSON1:15\r"[..], b'\r')
        );
        assert!(is_ok(b"#5,OK", 5));
        assert!(is_ok(b"#OK", 5));
        assert!(!is_ok(b"#6,OK", 5));
        assert!(!is_ok(b"#5,GDIS:1,0x1", 5));
        let (get, x, _) = super::super::plan::ascii_get(&MODEL, Item::new(Kind::Dis, 0)).unwrap();
        let v = answer_values(b"#5,GDIS:32769,0x8001", 5, get, x).unwrap();
        assert_eq!(value(&v, 0, Some((15, 1))), Some(Num::Int(1)));
        assert_eq!(value(&v, 0, Some((1, 1))), Some(Num::Int(0)));
        assert_eq!(value(&v, 1, None), Some(Num::Int(0x8001)));
        assert_eq!(value(&v, 2, None), None);
        assert!(answer_values(b"#5,GROS:1,0x1", 5, get, x).is_err());
        assert!(answer_values(b"#7,GDIS:1,0x1", 5, get, x).is_err());
        assert!(ascii_op(&MODEL, Op::ClearLogic).is_some_and(|c| c.short == "RSTSPCMODE"));
    }
}
