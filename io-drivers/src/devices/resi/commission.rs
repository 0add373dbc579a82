//! Identifying and commissioning a RESI module by its ASCII protocol (resi-spec §1.3, §1.4,
//! §2.1, §2.5), with the driver's own ASCII encoder and answer reader.
//!
//! Who it is: `#A,TYP`, answered `#A,TYPE:RESI-<model>-ASCII` (§2.1, §2.5); bauds
//! 4800..256000 by DIP switch, parity none or even only, one stop bit (§1.3).
//!
//! What a host can set, and how:
//! - **Address**: `SMBADR:<n>` "Writes the unit address into the FLASH memory … only used
//!   immediately, if the DIP switch setting of the bus address is 0" (compact, L19908; slim
//!   modules use it at once, L2383, unless DIP4 "FD" forces 255). So commissioning first reads
//!   the switches (`GDIP`) and refuses when they, not the FLASH, give the address; otherwise it
//!   sends `SMBADR`, then `RST` at the new address (no answer, L19937) so the module boots from
//!   FLASH, and reads `GMBADR` back: the address in use and the FLASH one must both be the new
//!   one. The FLASH keeps it across a power cycle.
//! - **Baud and parity**: DIP switches only (§1.3: BR0..BR2 = DIP5..7 and PARITY = DIP8 on
//!   compact modules; DIP1+2 on slim ones, whose parity "is defined by the PC software" by a
//!   mechanism the manual does not give, §2.5). "No ASCII command for baud rate or parity
//!   exists on any module" (§2.5): refused, naming the switches to set.
//! - **Reply delay**: none is documented, and no command or register sets one (§0, §6):
//!   refused, saying so.
//!
//! Address range: `SMBADR` takes 0..255, but 0 is the ASCII and Modbus broadcast (§2.2, §7)
//! and project files take RESI units 1..=247 (Modbus), so commissioning does too.

use super::ascii::{answer_values, find, frame, is_ok, parse_number, request, Command, COMMON};
use super::{by_name, Model, Num, Series};
use crate::devices::family::{
    CommissionError, CommissionRequest, Conversation, Expect, Plan, Step,
};
use crate::driver::Outgoing;
use crate::line::{LineSettings, Parity, SerialFormat};

/// Baud rates by BR2..BR0 (compact, L17742–L17750) and by DIP2, DIP1 (slim, L1771–L1774).
const COMPACT_BAUDS: [u32; 8] = [4800, 9600, 19200, 38400, 57600, 115_200, 230_400, 256_000];
const SLIM_BAUDS: [u32; 4] = [9600, 19200, 38400, 57600];

/// How long a module may take to boot after `RST`: the manual gives no figure; the compact
/// modules' LED shows about 2 s after a restart (L17759).
const REBOOT_WITHIN: std::time::Duration = std::time::Duration::from_secs(10);

/// What the RESI manual does not allow a host to set, or what the module's answers forbid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ResiRefusal {
    /// The baud rate is the switches'.
    #[error("refused: --set-baud {baud}: a {model}'s baud rate is set by its DIP switches, not by a command: the manual has no ASCII command or register for it (resi-spec §1.3, §2.5); {}", baud_how(*.series, *.baud))]
    Baud {
        /// The model.
        model: &'static str,
        /// Its series.
        series: Series,
        /// The rate asked.
        baud: u32,
    },
    /// A compact module's parity is DIP8.
    #[error("refused: --set-format {format}: a {model}'s parity is DIP8 (PARITY: off = none, on = even) and it has 8 data bits and 1 stop bit only: 8N1 or 8E1, set by the switch, not by a command (resi-spec §1.3, §2.5)")]
    CompactFormat {
        /// The model.
        model: &'static str,
        /// The format asked.
        format: SerialFormat,
    },
    /// A slim module's parity is set by a means the manual does not give.
    #[error("refused: --set-format {format}: a {model}'s parity \"is defined by the PC software\" (L1775) by a mechanism the manual does not document: it gives a host no command or register for it (resi-spec §1.2, §2.5)")]
    SlimFormat {
        /// The model.
        model: &'static str,
        /// The format asked.
        format: SerialFormat,
    },
    /// No reply delay exists.
    #[error("refused: --set-reply-delay: the RESI manual documents no reply delay and no command or register that sets one (resi-spec §0, §6); a host can set nothing here")]
    ReplyDelay,
    /// Only the address can be set, and it was not asked for.
    #[error("nothing to change: a {model} takes only a new address from a host (--set-address)")]
    NothingToChange {
        /// The model.
        model: &'static str,
    },
    /// An address outside Modbus units.
    #[error("refused: --set-address {address}: SMBADR takes 0..255, but 0 is the broadcast every RESI module answers (resi-spec §2.2) and Modbus units are 1..=247 (§7); give 1..=247")]
    Address {
        /// The address asked.
        address: u8,
    },
    /// GDIP gave no answer to read.
    #[error("{model} at address {address}: no readable GDIP answer")]
    NoSwitches {
        /// The model.
        model: &'static str,
        /// Its address now.
        address: u8,
    },
    /// A compact module's address comes from its ADR switches.
    #[error("refused: --set-address {address}: this {model}'s address {switches} comes from its ADR switches (DIP1..DIP4), which SMBADR does not override: it \"is only used immediately, if the DIP switch setting of the bus address is 0\" (resi-spec §1.4, L19908). Set DIP1..DIP4 {}, or all off to use the FLASH address, and run commission again", switches_for(*.address))]
    AddressBySwitches {
        /// The model.
        model: &'static str,
        /// The address asked.
        address: u8,
        /// The address the switches give.
        switches: i64,
    },
    /// A slim module's DIP4 forces unit 255.
    #[error("refused: --set-address {address}: DIP4 \"FD\" is on, so this {model} \"uses always the unit ID 255\" (resi-spec §1.3, L1842); switch DIP4 off to use the FLASH address and run commission again")]
    ForcedDefault {
        /// The model.
        model: &'static str,
        /// The address asked.
        address: u8,
    },
    /// A command the plan needs is not in the command table.
    #[error("the RESI command table has no {short}")]
    NoCommand {
        /// The command.
        short: &'static str,
    },
    /// The model answering is not one of the series'.
    #[error("{model} is not a RESI model")]
    NotResi {
        /// The model.
        model: &'static str,
    },
}

/// How the switches select `baud`, or which rates they select.
fn baud_how(series: Series, baud: u32) -> String {
    match (series, baud_switches(series, baud)) {
        (_, Some(switches)) => format!("for {baud} Bd set {switches}; the module restarts at the new rate when a switch changes (L17759, L1845)"),
        (Series::Compact, None) => "the switches select 4800, 9600, 19200, 38400, 57600, 115200, 230400 or 256000 Bd".into(),
        (Series::Slim, None) => "the switches select 9600, 19200, 38400 or 57600 Bd".into(),
    }
}

/// How to set the ADR switches for `address`.
fn switches_for(address: u8) -> String {
    if address <= 15 {
        format!("to {address} (DIP1 = 1, DIP2 = 2, DIP3 = 4, DIP4 = 8)")
    } else {
        "all off (the switches give 1..15 only)".to_string()
    }
}

/// Whether a RESI module can run at these settings and answer at this address (§1.3: DIP baud
/// table; "Odd parity and 2 stop bits are not available").
pub(crate) fn supports(s: LineSettings, address: u8) -> bool {
    COMPACT_BAUDS.contains(&s.baud)
        && s.format.data_bits == 8
        && s.format.parity != Parity::Odd
        && s.format.stop_bits == 1
        && address >= 1
}

/// `#A,TYP`.
pub(crate) fn who_are_you(address: u8) -> Vec<u8> {
    frame(Some(&address.to_string()), "TYP")
}

/// The model a `TYPE:` answer from `address` names, if it is a RESI module's.
pub(crate) fn identify(address: u8, reply: &str) -> Option<Result<&'static str, String>> {
    let reply = reply.trim_matches(|c: char| c == '\r' || c == '\n' || c == ' ');
    let rest = reply.strip_prefix(&format!("#{address},TYPE:"))?;
    let model = rest
        .strip_suffix("-ASCII")
        .unwrap_or(rest)
        .to_ascii_lowercase();
    Some(
        crate::devices::model(&model)
            .map(|m| m.name)
            .ok_or_else(|| format!("RESI type {rest:?} is not a model softplc knows")),
    )
}

fn common(short: &'static str) -> Result<&'static Command, CommissionError> {
    find(COMMON, short, false)
        .map(|(c, _)| c)
        .ok_or(CommissionError::refused(ResiRefusal::NoCommand { short }))
}

/// The request line for a common command, with the driver's encoder.
fn line(address: u8, cmd: &Command, params: &[Num]) -> Vec<u8> {
    match request(address, cmd, 0, params) {
        Outgoing::Text { line, .. } => line,
        // The encoder makes text lines only.
        _ => Vec::new(),
    }
}

/// The numbers of an answer to `cmd` from `address`.
fn numbers(reply: &str, address: u8, cmd: &Command) -> Option<Vec<i64>> {
    let values = answer_values(reply.as_bytes(), address, cmd, 0).ok()?;
    values
        .iter()
        .map(|v| parse_number(v).map(|n| n.int()))
        .collect()
}

fn on_off(bit: bool) -> &'static str {
    if bit {
        "on"
    } else {
        "off"
    }
}

/// Which switches select `baud` on this series, as "DIP5 on, DIP6 off, DIP7 on".
fn baud_switches(series: Series, baud: u32) -> Option<String> {
    match series {
        Series::Compact => {
            let i = COMPACT_BAUDS.iter().position(|b| *b == baud)?;
            Some(format!(
                "DIP5 (BR0) {}, DIP6 (BR1) {}, DIP7 (BR2) {}",
                on_off(i & 1 != 0),
                on_off(i & 2 != 0),
                on_off(i & 4 != 0)
            ))
        }
        Series::Slim => {
            let i = SLIM_BAUDS.iter().position(|b| *b == baud)?;
            Some(format!(
                "DIP1 {}, DIP2 {}",
                on_off(i & 1 != 0),
                on_off(i & 2 != 0)
            ))
        }
    }
}

/// Refuses what only the switches or nothing at all can set, before anything is asked.
fn refuse_switch_settings(model: &Model, req: &CommissionRequest) -> Result<(), ResiRefusal> {
    let name = model.name;
    if let Some(baud) = req.set_baud {
        return Err(ResiRefusal::Baud {
            model: name,
            series: model.series,
            baud,
        });
    }
    if let Some(format) = req.set_format {
        return Err(match model.series {
            Series::Compact => ResiRefusal::CompactFormat {
                model: name,
                format,
            },
            Series::Slim => ResiRefusal::SlimFormat {
                model: name,
                format,
            },
        });
    }
    if req.set_reply_delay.is_some() {
        return Err(ResiRefusal::ReplyDelay);
    }
    Ok(())
}

/// The plan for `req` to the RESI module `model_name`, reading its switches first.
pub(crate) fn plan(
    conversation: &mut dyn Conversation,
    req: &CommissionRequest,
    model_name: &'static str,
) -> Result<Plan, CommissionError> {
    let model = by_name(model_name).ok_or(CommissionError::refused(ResiRefusal::NotResi {
        model: model_name,
    }))?;
    refuse_switch_settings(model, req).map_err(CommissionError::refused)?;
    let Some(n) = req.set_address else {
        return Err(CommissionError::refused(ResiRefusal::NothingToChange {
            model: model_name,
        }));
    };
    if !(1..=247).contains(&n) {
        return Err(CommissionError::refused(ResiRefusal::Address {
            address: n,
        }));
    }
    let a = req.address;
    // Where does the address come from now? "GDIP", bit n = DIP n+1 (L18731).
    let gdip = common("GDIP")?;
    let reply = conversation.ask("read the DIP switches", &line(a, gdip, &[]))?;
    let dip = reply
        .as_deref()
        .and_then(|r| numbers(r, a, gdip))
        .and_then(|v| v.first().copied())
        .ok_or(CommissionError::refused(ResiRefusal::NoSwitches {
            model: model_name,
            address: a,
        }))?;
    conversation.note(&switches_line(model.series, dip))?;
    match model.series {
        Series::Compact if dip & 0x0F != 0 => {
            return Err(CommissionError::refused(ResiRefusal::AddressBySwitches {
                model: model_name,
                address: n,
                switches: dip & 0x0F,
            }))
        }
        Series::Slim if dip & 0x08 != 0 => {
            return Err(CommissionError::refused(ResiRefusal::ForcedDefault {
                model: model_name,
                address: n,
            }))
        }
        _ => {}
    }
    let smbadr = common("SMBADR")?;
    let rst = common("RST")?;
    let gmbadr = common("GMBADR")?;
    let settings = conversation.settings();
    let steps = vec![
        Step::Send {
            what: format!("SMBADR:{n} (address {n} into FLASH, in use at once with the ADR switches at 0, resi-spec §1.4)"),
            frame: line(a, smbadr, &[Num::Int(i64::from(n))]),
            expect: Expect::Answer(Box::new(move |r: &str| {
                if is_ok(r.as_bytes(), a) {
                    Ok(())
                } else {
                    Err(format!("the module answered {r:?}, not OK"))
                }
            })),
        },
        Step::Send {
            what: format!("RST at address {n} (reboot from FLASH; the module answers nothing, L19937)"),
            frame: line(n, rst, &[]),
            expect: Expect::Silence,
        },
        Step::Await {
            what: format!("the module back from its reboot at address {n}, in use and in FLASH"),
            instructions: Vec::new(),
            settings,
            frame: line(n, gmbadr, &[]),
            check: Box::new(move |r: &str| match numbers(r, n, gmbadr).as_deref() {
                Some([unit, flash, ..]) if *unit == i64::from(n) && *flash == i64::from(n) => Ok(()),
                Some([unit, flash, ..]) => Err(format!("address in use {unit}, in FLASH {flash}")),
                _ => Err("not a GMBADR answer".into()),
            }),
            within: Some(REBOOT_WITHIN),
        },
    ];
    Ok(Plan {
        steps,
        done: format!("{model_name} answers at address {n}, {settings}; stored in FLASH (SMBADR), kept at power-off"),
    })
}

/// `   DIP1..8 = 00000000`.
fn switches_line(series: Series, dip: i64) -> String {
    let n = series.dips();
    let bits: String = (0..n)
        .map(|i| if dip & (1 << i) != 0 { '1' } else { '0' })
        .collect();
    format!("   DIP1..{n} = {bits}")
}
