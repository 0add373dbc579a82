//! Commissioning an EX-9053D / EX-9053D-M over DCON (EX-9053 manual §1.3, §1.4, §1.10, §2.1,
//! §2.4, §2.9), with the driver's own DCON encoder and answer parser.
//!
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

use anyhow::{bail, Context};
use softplc_io::devices::ex9053::{
    baud_of_code, check_line, code_of_baud, Answer, AnswerError, Command, BAUD_CODES, FF_CHECKSUM,
    INIT_ADDRESS, INIT_BAUD_CODE, LINE_FORMAT, TYPE_DIO,
};
use softplc_io::line::LineSettings;

use super::{Check, CommissionArgs, Expect, Plan, Session, Step};

/// `$AAM`, with the checksum if the module uses one.
pub(super) fn name_request(address: u8, checksum: bool) -> Vec<u8> {
    Command::ReadName { address }.encode(checksum)
}

/// The body of an answer line (CR removed), its checksum checked and removed when in use.
pub(super) fn body(reply: &str, checksum: bool) -> Option<String> {
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

pub(super) fn plan(
    session: &mut Session,
    args: &CommissionArgs,
    model: &'static str,
) -> anyhow::Result<Plan> {
    if let Some(f) = args.set_format {
        if f != LINE_FORMAT {
            bail!("refused: --set-format {f}: a DCON line is 8N1; the EX-9053's data format (FF, manual §1.10) holds only the counter edge and the checksum, no parity or stop bits (use --set-checksum for the checksum)");
        }
    }
    if args.set_reply_delay.is_some() {
        bail!("refused: --set-reply-delay: the EX-9053 manual gives no reply delay and no command that sets one (§2 lists every command); a host can set nothing here");
    }
    let new_code = match args.set_baud {
        None => None,
        Some(b) => Some(code_of_baud(b).with_context(|| {
            let rates: Vec<String> = BAUD_CODES.iter().map(|(_, b)| b.to_string()).collect();
            format!(
                "refused: --set-baud {b}: the EX-9053 runs at {} Bd (CC codes 03..0A, manual §1.10)",
                rates.join(", ")
            )
        })?),
    };
    let a = args.address;
    let ck = args.checksum;
    let read = Command::ReadConfig { address: a };
    let reply = session.ask("read the configuration ($AA2, §2.4)", &read.encode(ck))?;
    let (_, _, code, ff) = reply
        .as_deref()
        .ok_or_else(|| "no answer".to_string())
        .and_then(|r| config(&read, r, ck))
        .map_err(|why| anyhow::anyhow!("{model} at address {a}: $AA2: {why}"))?;
    let now_ck = ff & FF_CHECKSUM != 0;
    let new_code = new_code.unwrap_or(code);
    let new_ck = args.set_checksum.map_or(now_ck, |c| c.is_on());
    let new_ff = (ff & !FF_CHECKSUM) | if new_ck { FF_CHECKSUM } else { 0 };
    let n = args.set_address.unwrap_or(a);
    let new_baud = baud_of_code(new_code).unwrap_or(9600);
    let new_settings = LineSettings {
        baud: new_baud,
        format: LINE_FORMAT,
    };
    let after = format!(
        "address {n:02X}h ({n}), {new_settings}, checksum {}",
        checksum_text(new_ck)
    );
    crate::cli::out::outln(&format!(
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
            bail!("nothing to change: {model} at address {a} already has these settings");
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
