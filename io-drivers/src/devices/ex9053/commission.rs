//! Identifying and commissioning an EX-9053D / EX-9053D-M over DCON (EX-9053 manual §1.3,
//! §1.4, §1.10, §2.1, §2.4, §2.9, §2.13), with the driver's own DCON encoder and answer
//! parser.
//!
//! - Who it is: `$AAM` (read name), answered `!AA<name>` (§2.13); the factory setting is
//!   9600 8N1 (§1.3); DCON addresses are two hex digits.
//! - `%AANNTTCCFF` sets address NN, type TT (40), baud code CC and data format FF; the module
//!   answers `!NN`, or `?AA` when it refuses (§2.1). The settings are saved in EEPROM.
//! - **Address only** (CC and FF as `$AA2` reads them now): no INIT* needed; the module answers
//!   from the new address at once (§2.1 example `%0102240600` → `!02`). Read back: `$NNM`.
//! - **Baud or checksum** (FF bit 6, §1.10): "it is needed to short the INIT* to ground …
//!   The new setting is saved in the EEPROM and will be effective after the next power-on
//!   reset" (§2.1). Commissioning prints the steps of §1.4 (power off, INIT* to GND or the
//!   switch to Init, power on) and waits until the module answers `$002` at 9600 Bd without
//!   checksum ("INIT* mode is setting as Address=00, Baudrate=9600bps, no Checksum", §1.4);
//!   sends `%00NN40CCFF`; prints the way back (power off, INIT* off GND, power on) and waits
//!   until `$NNM` answers at the new baud, with the new checksum; reads `$NN2` back.
//! - FF keeps its counter-edge bit 7 as read; its other bits are sent as read.
//! - **Format**: a DCON line is 8N1; §1.10 has no parity or stop-bit setting, so only 8N1 is
//!   accepted. **Reply delay**: the manual gives none and no command sets one: refused.

use super::{
    baud_of_code, check_line, code_of_baud, Answer, AnswerError, Command, BAUD_CODES, FF_CHECKSUM,
    INIT_ADDRESS, INIT_BAUD_CODE, LINE_FORMAT, TYPE_DIO,
};
use crate::devices::family::{
    Check, CommissionError, CommissionRequest, Conversation, Expect, Plan, Step,
};
use crate::line::{LineSettings, Parity, SerialFormat};

/// What the EX-9053's manual does not allow a host to set, or what its answer forbids.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Ex9053Refusal {
    /// A DCON line is 8N1.
    #[error("refused: --set-format {format}: a DCON line is 8N1; the EX-9053's data format (FF, manual §1.10) holds only the counter edge and the checksum, no parity or stop bits (use --set-checksum for the checksum)")]
    Format {
        /// The format asked.
        format: SerialFormat,
    },
    /// No reply delay exists.
    #[error("refused: --set-reply-delay: the EX-9053 manual gives no reply delay and no command that sets one (§2 lists every command); a host can set nothing here")]
    ReplyDelay,
    /// A baud rate with no CC code.
    #[error(
        "refused: --set-baud {baud}: the EX-9053 runs at {} Bd (CC codes 03..0A, manual §1.10)",
        rates()
    )]
    Baud {
        /// The rate asked.
        baud: u32,
    },
    /// `$AA2` gave no configuration to start from.
    #[error("{model} at address {address}: $AA2: {why}")]
    Config {
        /// The model.
        model: &'static str,
        /// Its address now.
        address: u8,
        /// What came back instead, in words.
        why: String,
    },
    /// The module has the settings asked for already.
    #[error("nothing to change: {model} at address {address} already has these settings")]
    NothingToChange {
        /// The model.
        model: &'static str,
        /// Its address.
        address: u8,
    },
}

/// Every baud rate of the CC codes, as text.
fn rates() -> String {
    let rates: Vec<String> = BAUD_CODES.iter().map(|(_, b)| b.to_string()).collect();
    rates.join(", ")
}

/// Whether an EX-9053 can run at these settings (§1.3 / %AANNTTCCFF baud codes
/// 1200..115200, 8N1: no parity in the DCON frame); any address.
pub(crate) fn supports(s: LineSettings) -> bool {
    [1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200].contains(&s.baud)
        && s.format
            == SerialFormat {
                data_bits: 8,
                parity: Parity::None,
                stop_bits: 1,
            }
}

/// The model a `!AA<name>` answer from `address` names, if it is a DCON answer.
pub(crate) fn identify(address: u8, reply: &str) -> Option<Result<&'static str, String>> {
    let reply = reply.trim_matches(|c: char| c == '\r' || c == '\n' || c == ' ');
    let name = reply.strip_prefix(&format!("!{address:02X}"))?;
    Some(if name.starts_with("9053") {
        Ok(super::MODEL_D.name)
    } else {
        Err(format!(
            "DCON module named {name:?} is not a model softplc knows"
        ))
    })
}

/// `$AAM`, with the checksum if the module uses one.
pub(crate) fn name_request(address: u8, checksum: bool) -> Vec<u8> {
    Command::ReadName { address }.encode(checksum)
}

/// The body of an answer line (CR removed), its checksum checked and removed when in use.
pub(crate) fn body(reply: &str, checksum: bool) -> Option<String> {
    let b = check_line(reply.as_bytes(), checksum).ok()?;
    String::from_utf8(b.to_vec()).ok()
}

/// The answer to `cmd`, from the module's line.
fn parse(cmd: &Command, reply: &str, checksum: bool) -> Result<Answer, String> {
    let b = body(reply, checksum).ok_or_else(|| {
        if checksum {
            "not a DCON line with a good checksum".to_string()
        } else {
            "not a DCON line".to_string()
        }
    })?;
    Answer::parse(cmd, b.as_bytes()).map_err(|e| e.to_string())
}

/// An answer that must be `!AA` (the module took a command), not `?AA` (refused).
fn acked(cmd: Command, checksum: bool) -> Check {
    Box::new(move |r: &str| match parse(&cmd, r, checksum)? {
        Answer::Ack => Ok(()),
        Answer::Invalid => Err("the module refused it (?AA)".into()),
        other => Err(format!("unexpected answer {other:?}")),
    })
}

/// An answer to `$AAM` naming a 9053.
fn named(address: u8, checksum: bool) -> Check {
    Box::new(
        move |r: &str| match parse(&Command::ReadName { address }, r, checksum)? {
            Answer::Text(name) if name.starts_with("9053") => Ok(()),
            other => Err(format!("not an EX-9053's name: {other:?}")),
        },
    )
}

/// TT, CC, FF of a `$AA2` answer, from whichever address answered: in INIT* the module
/// answers `$002` with its stored address (§1.4 step 4 reads "the Configuration stored").
fn config(cmd: &Command, reply: &str, checksum: bool) -> Result<(u8, u8, u8, u8), String> {
    let b = body(reply, checksum).ok_or("not a DCON line")?;
    let (from, answer) = match Answer::parse(cmd, b.as_bytes()) {
        Ok(a) => (cmd.reply_address().unwrap_or(0), a),
        Err(AnswerError::WrongAddress { found, .. }) => (
            found,
            Answer::parse(&Command::ReadConfig { address: found }, b.as_bytes())
                .map_err(|e| e.to_string())?,
        ),
        Err(e) => return Err(e.to_string()),
    };
    match answer {
        Answer::Config {
            type_code,
            baud_code,
            format,
        } => Ok((from, type_code, baud_code, format)),
        Answer::Invalid => Err("the module refused it (?AA)".into()),
        other => Err(format!("not a configuration: {other:?}")),
    }
}

/// The engineer powers the module off, does `wiring`, powers it on (`why`); then it must
/// answer `frame` at `settings`.
fn power_cycle(
    what: String,
    wiring: &str,
    why: &str,
    settings: LineSettings,
    frame: Vec<u8>,
    check: Check,
) -> Step {
    Step::Await {
        what,
        instructions: vec![
            "power the module off".into(),
            wiring.into(),
            format!("power it on: {why}"),
        ],
        settings,
        frame,
        check,
        within: None,
    }
}

fn checksum_text(on: bool) -> &'static str {
    if on {
        "on"
    } else {
        "off"
    }
}

/// The plan for `req` to the EX-9053 `model`, reading its configuration first.
pub(crate) fn plan(
    conversation: &mut dyn Conversation,
    req: &CommissionRequest,
    model: &'static str,
) -> Result<Plan, CommissionError> {
    if let Some(format) = req.set_format {
        if format != LINE_FORMAT {
            return Err(CommissionError::refused(Ex9053Refusal::Format { format }));
        }
    }
    if req.set_reply_delay.is_some() {
        return Err(CommissionError::refused(Ex9053Refusal::ReplyDelay));
    }
    let new_code = match req.set_baud {
        None => None,
        Some(baud) => {
            Some(code_of_baud(baud).ok_or(CommissionError::refused(Ex9053Refusal::Baud { baud }))?)
        }
    };
    let a = req.address;
    let ck = req.checksum;
    let read = Command::ReadConfig { address: a };
    let reply = conversation.ask("read the configuration ($AA2, §2.4)", &read.encode(ck))?;
    let (_, _, code, ff) = reply
        .as_deref()
        .ok_or_else(|| "no answer".to_string())
        .and_then(|r| config(&read, r, ck))
        .map_err(|why| {
            CommissionError::refused(Ex9053Refusal::Config {
                model,
                address: a,
                why,
            })
        })?;
    let now_ck = ff & FF_CHECKSUM != 0;
    let new_code = new_code.unwrap_or(code);
    let new_ck = req.set_checksum.unwrap_or(now_ck);
    let new_ff = (ff & !FF_CHECKSUM) | if new_ck { FF_CHECKSUM } else { 0 };
    let n = req.set_address.unwrap_or(a);
    let new_baud = baud_of_code(new_code).unwrap_or(9600);
    let new_settings = LineSettings {
        baud: new_baud,
        format: LINE_FORMAT,
    };
    let after = format!(
        "address {n:02X}h ({n}), {new_settings}, checksum {}",
        checksum_text(new_ck)
    );
    conversation.note(&format!(
        "   now: baud code {code:02X}h ({} Bd), data format {ff:02X}h (checksum {})",
        baud_of_code(code).unwrap_or(0),
        checksum_text(now_ck)
    ))?;
    let serial_change = new_code != code || new_ck != now_ck;
    let set = |from: u8| Command::SetConfig {
        address: from,
        new_address: n,
        type_code: TYPE_DIO,
        baud_code: new_code,
        format: new_ff,
    };
    let set_what = format!(
        "%AANNTTCCFF: address {n:02X}h, type {TYPE_DIO:02X}, baud code {new_code:02X}h ({new_baud} Bd), data format {new_ff:02X}h (checksum {}), saved in EEPROM (§2.1)",
        checksum_text(new_ck)
    );
    let read_back = Command::ReadConfig { address: n };
    let asked_back = read_back.clone();
    let check_back: Check = Box::new(move |r: &str| {
        let (_, _, c, f) = config(&asked_back, r, new_ck)?;
        if (c, f) == (new_code, new_ff) {
            Ok(())
        } else {
            Err(format!("baud code {c:02X}h, data format {f:02X}h stored"))
        }
    });
    let steps = if !serial_change {
        if n == a {
            return Err(CommissionError::refused(Ex9053Refusal::NothingToChange {
                model,
                address: a,
            }));
        }
        vec![
            Step::Send {
                what: set_what,
                frame: set(a).encode(ck),
                expect: Expect::Answer(acked(set(a), ck)),
            },
            Step::Send {
                what: format!("read back at address {n:02X}h"),
                frame: Command::ReadName { address: n }.encode(ck),
                expect: Expect::Answer(named(n, ck)),
            },
            Step::Send {
                what: "read back the configuration".into(),
                frame: read_back.encode(ck),
                expect: Expect::Answer(check_back),
            },
        ]
    } else {
        let init = LineSettings {
            baud: baud_of_code(INIT_BAUD_CODE).unwrap_or(9600),
            format: LINE_FORMAT,
        };
        let probe_init = Command::ReadConfig {
            address: INIT_ADDRESS,
        };
        vec![
            power_cycle(
                format!("the module in INIT* mode (address 00, {init}, no checksum; §1.4)"),
                "connect its INIT* terminal to GND (or slide the INIT* switch to Init)",
                "a new baud rate or checksum is accepted only in INIT* mode (§1.4, §2.1)",
                init,
                probe_init.encode(false),
                Box::new(move |r: &str| config(&probe_init, r, false).map(|_| ())),
            ),
            Step::Send {
                what: set_what,
                frame: set(INIT_ADDRESS).encode(false),
                expect: Expect::Answer(acked(set(INIT_ADDRESS), false)),
            },
            power_cycle(
                format!("the module at its new settings ({after})"),
                "disconnect INIT* from GND (or slide the INIT* switch back to Normal)",
                "the new settings take effect at this power-on (§2.1)",
                new_settings,
                Command::ReadName { address: n }.encode(new_ck),
                named(n, new_ck),
            ),
            Step::Send {
                what: "read back the configuration".into(),
                frame: read_back.encode(new_ck),
                expect: Expect::Answer(check_back),
            },
        ]
    };
    Ok(Plan {
        steps,
        done: format!("{model} answers at {after}; stored in EEPROM"),
    })
}
