//! The modules' text protocols, decoded with the families' own parsers:
//! - MiniMod, manual "Text commands protocol" and "Slave addressing": `@N?ID`, `@N>ID=V`,
//!   answered `ID=value`, `OK` or `Error` ([`crate::devices::minimod::text`]);
//! - RESI ASCII, resi-spec §2.1 "Framing" and §2.4 "Answers": `#[ADR,]CMD[:P,...]`, answered
//!   `#[ADR,]ANSWER[:V,...]` ([`crate::devices::resi::ascii::frame`]);
//! - DCON, EX-9053D manual chapter 2 "Command Sets": `%AANNTTCCFF`, `#AAN`, `$AAx`, `@AA`,
//!   `~AAx`, answered `!...`, `?AA` or `>...`, with or without the checksum of §1.10
//!   ([`crate::devices::ex9053::dcon`]).
//!
//! Where the protocols overlap, content decides (the manuals are silent, since each assumes
//! its own line): `#` followed by `**` or by exactly three hexadecimal digits (and perhaps a
//! two-digit checksum) is DCON `#AAN`, any other `#` line is RESI; `?AA` and `>XXXX` are DCON
//! answers when they follow a DCON command, MiniMod text otherwise.

use std::fmt;

use super::dcon::{Described, Told};
use crate::devices::ex9053::dcon::{self, Answer, Command as DconCommand};
use crate::devices::minimod::text::{
    self as minimod, format_condition, Command as MiniCommand, Op, TextReply, WriteValue,
};
use crate::devices::resi::ascii::frame::Frame as ResiFrame;

/// A MiniMod text packet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum MiniMod {
    /// A command (perhaps one the module answers `Error`).
    Command(MiniCommand),
    /// A reply.
    Reply(TextReply),
}

/// A RESI ASCII frame, its parts as they came.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Resi {
    /// Whether it answers the request before it.
    pub answer: bool,
    /// The bus address as spelled (`43`, `0x2B`); `None` without one.
    pub address: Option<String>,
    /// The command or the answer's keyword.
    pub keyword: String,
    /// The parameters or values after `:`.
    pub params: Vec<String>,
}

/// A DCON line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Dcon {
    /// A command.
    Command {
        /// What it asks.
        command: DconCommand,
        /// Whether it carried a (correct) checksum.
        checksum: bool,
    },
    /// The answer to the command before it.
    Answer {
        /// What it says.
        answer: Answer,
        /// The address it came from.
        address: Option<u8>,
        /// Whether it carried a (correct) checksum.
        checksum: bool,
    },
}

/// A MiniMod command or reply, if `line` is one the module would act on or a master read.
pub(crate) fn minimod_command(line: &[u8]) -> Option<MiniMod> {
    // DCON's `?AA` and `>XXXX` answers parse as MiniMod commands with an unknown identifier:
    // those are taken as MiniMod only when addressed with `@N`.
    match minimod::parse_command(line) {
        Ok(command)
            if command.to.is_some()
                || !matches!(command.op, Err(minimod::Refusal::UnknownIdentifier)) =>
        {
            Some(MiniMod::Command(command))
        }
        _ => None,
    }
}

/// A MiniMod reply.
pub(crate) fn minimod_reply(line: &[u8]) -> Option<MiniMod> {
    minimod::parse_reply(strip_cr(line))
        .ok()
        .map(MiniMod::Reply)
}

/// A RESI request frame (`answer: false`).
pub(crate) fn resi(line: &[u8]) -> Option<Resi> {
    let frame = ResiFrame::parse(line).ok()?;
    Some(Resi {
        answer: false,
        address: frame.address.map(|a| a.text.to_string()),
        keyword: frame.keyword.to_string(),
        params: frame.values().into_iter().map(str::to_string).collect(),
    })
}

/// `line` as the answer to the RESI `request`: same address spelling, and `OK` or values to a
/// request without parameters (resi-spec §2.4: a get answers with values, a set `OK`).
pub(crate) fn resi_answer(line: &[u8], request: &Resi) -> Option<Resi> {
    let mut answer = resi(line)?;
    let fits = answer.address == request.address
        && (answer.keyword == "OK" || (request.params.is_empty() && !answer.params.is_empty()));
    fits.then(|| {
        answer.answer = true;
        answer
    })
}

/// A DCON command, without or with its checksum.
pub(crate) fn dcon_command(line: &[u8]) -> Option<Dcon> {
    let line = strip_cr(line);
    [false, true].into_iter().find_map(|checksum| {
        let body = dcon::check_line(line, checksum).ok()?;
        let command = DconCommand::parse(body).ok()?;
        Some(Dcon::Command { command, checksum })
    })
}

/// `line` as the answer to the DCON `command` (same checksum setting, §1.10).
pub(crate) fn dcon_answer(line: &[u8], command: &DconCommand, checksum: bool) -> Option<Dcon> {
    let body = dcon::check_line(strip_cr(line), checksum).ok()?;
    let answer = Answer::parse(command, body).ok()?;
    Some(Dcon::Answer {
        answer,
        address: command.reply_address(),
        checksum,
    })
}

/// Whether `#...` is DCON's `#AAN` or `#**` rather than a RESI frame.
pub(crate) fn is_dcon_hash(line: &[u8]) -> bool {
    let line = strip_cr(line);
    match line.strip_prefix(b"#") {
        Some(b"**") => true,
        Some(rest) => {
            (rest.len() == 3 || rest.len() == 5) && rest.iter().all(u8::is_ascii_hexdigit)
        }
        None => false,
    }
}

fn strip_cr(line: &[u8]) -> &[u8] {
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    line.strip_suffix(b"\r").unwrap_or(line)
}

impl fmt::Display for MiniMod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MiniMod::Command(c) => {
                f.write_str("minimod command ")?;
                match c.to {
                    Some(n) => write!(f, "to module {n}: ")?,
                    None => f.write_str("to every module: ")?,
                }
                match &c.op {
                    Ok(Op::Read(id)) => write!(f, "read {id}"),
                    Ok(Op::Write(id, value)) => {
                        write!(f, "write {id} = ")?;
                        match value {
                            WriteValue::Number(n) => write!(f, "{n}"),
                            WriteValue::Serline { baud, mode } => match mode {
                                Some(m) => write!(f, "{baud} Bd, mode {}", m.letter()),
                                None => write!(f, "{baud} Bd"),
                            },
                            WriteValue::Condition(mask) => match format_condition(*mask) {
                                Some(text) if text.is_empty() => f.write_str("(cleared)"),
                                Some(text) => f.write_str(&text),
                                None => write!(f, "{mask:#06X}"),
                            },
                        }
                    }
                    Err(refusal) => write!(f, "answered Error ({refusal})"),
                }
            }
            MiniMod::Reply(r) => match r {
                TextReply::Ok => f.write_str("minimod reply: OK (written)"),
                TextReply::Error => f.write_str("minimod reply: Error (refused)"),
                TextReply::Value(id, v) => write!(f, "minimod reply: {id} = {v}"),
                TextReply::Device(name) => write!(f, "minimod reply: DEVICE = {name}"),
            },
        }
    }
}

impl fmt::Display for Resi {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.answer {
            "resi answer "
        } else {
            "resi command "
        })?;
        match &self.address {
            Some(a) => write!(f, "address {a}: ")?,
            None => f.write_str("no address: ")?,
        }
        f.write_str(&self.keyword)?;
        if !self.params.is_empty() {
            write!(f, " [{}]", self.params.join(", "))?;
        }
        Ok(())
    }
}

impl fmt::Display for Dcon {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let chk = |checksum: bool| if checksum { ", checksum ok" } else { "" };
        match self {
            Dcon::Command { command, checksum } => {
                f.write_str("dcon command ")?;
                match command.address() {
                    Some(a) => write!(f, "to {a:02X}: ")?,
                    None => f.write_str("to every module: ")?,
                }
                write!(f, "{}{}", Described(command), chk(*checksum))
            }
            Dcon::Answer {
                answer,
                address,
                checksum,
            } => {
                f.write_str("dcon answer ")?;
                if let Some(a) = address {
                    write!(f, "from {a:02X}: ")?;
                }
                write!(f, "{}{}", Told(answer), chk(*checksum))
            }
        }
    }
}
