//! Commissioning a MiniMod (manual, "Configuration of Minimod"):
//! - `>RDELAYT=n` ("Setting the reply delay": hundredths of a second, 0..=200);
//! - `>SERLINE=19200E` ("Setting the communication parameters": 4800..57600, E/O/N/X); the
//!   module answers `OK` at the old settings and switches after it;
//! - `>ADDRESS=N` ("Setting the slave address": 1..=247 for Modbus);
//! - `>WCONF=1` ("Saving setting permanently"), at the new address; without it the module
//!   powers up with what its flash held before.
//!
//! Read back: `@N?DEVICE` at the new address and settings (SERLINE and RDELAYT are
//! write-only, "Read commands table").

use anyhow::bail;
use softplc_io::devices::minimod::{
    write_command, LineMode, TextId, WriteValue, BAUD_RATES, MAX_RDELAY,
};
use softplc_io::line::LineSettings;

use super::{CommissionArgs, Expect, Plan, Step};
use crate::cli::discover::Family;

/// The answer of every MiniMod write.
fn ok() -> Expect {
    Expect::Answer(Box::new(|r: &str| {
        if r.trim() == "OK" {
            Ok(())
        } else {
            Err(format!("the module answered {r:?}, not OK"))
        }
    }))
}

pub(super) fn plan(
    args: &CommissionArgs,
    now: LineSettings,
    model: &'static str,
) -> anyhow::Result<Plan> {
    let a = args.address;
    let mut steps = Vec::new();
    let frame = |to: u8, id: TextId, v: WriteValue| {
        write_command(to, id, v).map_err(|e| anyhow::anyhow!("cannot encode {id}: {e:?}"))
    };
    if let Some(d) = args.set_reply_delay {
        // "Setting the reply delay": RDELAYT=nnn, hundredths of a second, 0..=200.
        let ms = d.as_millis();
        if ms % 10 != 0 || ms / 10 > u128::from(MAX_RDELAY) {
            bail!("refused: --set-reply-delay {ms}ms: the MiniMod's RDELAYT counts hundredths of a second, 0..=200 (manual, \"Setting the reply delay\"): give 0ms..2s in steps of 10ms");
        }
        let n = u16::try_from(ms / 10).unwrap_or(0);
        steps.push(Step::Send {
            what: format!("RDELAYT={n} (reply delay {ms}ms)"),
            frame: frame(a, TextId::RdelayT, WriteValue::Number(n))?,
            expect: ok(),
        });
    }
    let mut new_settings = now;
    if args.set_baud.is_some() || args.set_format.is_some() {
        let baud = args.set_baud.unwrap_or(now.baud);
        if !BAUD_RATES.contains(&baud) {
            bail!("refused: --set-baud {baud}: the MiniMod runs at 4800, 9600, 19200, 38400 or 57600 Bd (manual, \"Setting the communication parameters\")");
        }
        let format = args.set_format.unwrap_or(now.format);
        let Some(mode) = [
            LineMode::Even,
            LineMode::Odd,
            LineMode::NoneTwoStops,
            LineMode::NoneOneStop,
        ]
        .into_iter()
        .find(|m| m.format() == format) else {
            bail!("refused: --set-format {format}: the MiniMod has 8E1, 8O1, 8N2 and 8N1 only (SERLINE E, O, N, X; manual, \"Setting the communication parameters\")");
        };
        new_settings = LineSettings { baud, format };
        steps.push(Step::Send {
            what: format!("SERLINE={baud}{} ({new_settings})", mode.letter()),
            frame: frame(
                a,
                TextId::Serline,
                WriteValue::Serline {
                    baud,
                    mode: Some(mode),
                },
            )?,
            expect: ok(),
        });
        // "The module replies with the old settings; the new ones apply after the OK".
        if new_settings != now {
            steps.push(Step::Switch(new_settings));
        }
    }
    let mut new_address = a;
    if let Some(n) = args.set_address {
        if !(1..=247).contains(&n) {
            bail!("refused: --set-address {n}: Modbus accepts only 1..=247 (MiniMod manual, \"Setting the slave address\")");
        }
        new_address = n;
        steps.push(Step::Send {
            what: format!("ADDRESS={n}"),
            frame: frame(a, TextId::Address, WriteValue::Number(u16::from(n)))?,
            expect: ok(),
        });
    }
    steps.push(Step::Send {
        what: "WCONF=1 (save to flash)".into(),
        frame: frame(new_address, TextId::Wconf, WriteValue::Number(1))?,
        expect: ok(),
    });
    steps.push(Step::Send {
        what: format!("read back at {new_settings}"),
        frame: Family::MiniMod.request(new_address),
        expect: Expect::Answer(Box::new(move |r: &str| {
            match Family::MiniMod.identify(new_address, r) {
                Some(Ok(_)) => Ok(()),
                _ => Err(format!("{r:?} is not a MiniMod's DEVICE answer")),
            }
        })),
    });
    Ok(Plan {
        steps,
        done: format!("{model} answers at address {new_address}, {new_settings}; saved (WCONF)"),
    })
}
