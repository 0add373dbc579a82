//! Commissioning a RESI module (resi-spec §1.3, §1.4, §2.5), with the driver's own ASCII
//! encoder and answer reader.
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

use anyhow::{bail, Context};
use softplc_io::devices::resi::ascii::{answer_values, find, is_ok, request, Command, COMMON};
use softplc_io::devices::resi::{by_name, Model, Num, Series};
use softplc_io::driver::Outgoing;

use super::{CommissionArgs, Expect, Plan, Session, Step};

/// Baud rates by BR2..BR0 (compact, L17742–L17750) and by DIP2, DIP1 (slim, L1771–L1774).
const COMPACT_BAUDS: [u32; 8] = [4800, 9600, 19200, 38400, 57600, 115_200, 230_400, 256_000];
const SLIM_BAUDS: [u32; 4] = [9600, 19200, 38400, 57600];

/// How long a module may take to boot after `RST`: the manual gives no figure; the compact
/// modules' LED shows about 2 s after a restart (L17759).
const REBOOT_WITHIN: std::time::Duration = std::time::Duration::from_secs(10);

fn common(short: &str) -> anyhow::Result<&'static Command> {
    find(COMMON, short, false)
        .map(|(c, _)| c)
        .with_context(|| format!("the RESI command table has no {short}"))
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
        .map(|v| softplc_io::devices::resi::ascii::parse_number(v).map(|n| n.int()))
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
fn refuse_switch_settings(model: &Model, args: &CommissionArgs) -> anyhow::Result<()> {
    let name = model.name;
    if let Some(baud) = args.set_baud {
        let how = match (model.series, baud_switches(model.series, baud)) {
            (_, Some(switches)) => format!("for {baud} Bd set {switches}; the module restarts at the new rate when a switch changes (L17759, L1845)"),
            (Series::Compact, None) => "the switches select 4800, 9600, 19200, 38400, 57600, 115200, 230400 or 256000 Bd".into(),
            (Series::Slim, None) => "the switches select 9600, 19200, 38400 or 57600 Bd".into(),
        };
        bail!("refused: --set-baud {baud}: a {name}'s baud rate is set by its DIP switches, not by a command: the manual has no ASCII command or register for it (resi-spec §1.3, §2.5); {how}");
    }
    if let Some(f) = args.set_format {
        match model.series {
            Series::Compact => bail!("refused: --set-format {f}: a {name}'s parity is DIP8 (PARITY: off = none, on = even) and it has 8 data bits and 1 stop bit only: 8N1 or 8E1, set by the switch, not by a command (resi-spec §1.3, §2.5)"),
            Series::Slim => bail!("refused: --set-format {f}: a {name}'s parity \"is defined by the PC software\" (L1775) by a mechanism the manual does not document: it gives a host no command or register for it (resi-spec §1.2, §2.5)"),
        }
    }
    if args.set_reply_delay.is_some() {
        bail!("refused: --set-reply-delay: the RESI manual documents no reply delay and no command or register that sets one (resi-spec §0, §6); a host can set nothing here");
    }
    Ok(())
}

pub(super) fn plan(
    session: &mut Session,
    args: &CommissionArgs,
    model_name: &'static str,
) -> anyhow::Result<Plan> {
    let model = by_name(model_name).with_context(|| format!("{model_name} is not a RESI model"))?;
    refuse_switch_settings(model, args)?;
    let Some(n) = args.set_address else {
        bail!("nothing to change: a {model_name} takes only a new address from a host (--set-address)");
    };
    if !(1..=247).contains(&n) {
        bail!("refused: --set-address {n}: SMBADR takes 0..255, but 0 is the broadcast every RESI module answers (resi-spec §2.2) and Modbus units are 1..=247 (§7); give 1..=247");
    }
    let a = args.address;
    // Where does the address come from now? "GDIP", bit n = DIP n+1 (L18731).
    let gdip = common("GDIP")?;
    let reply = session.ask("read the DIP switches", &line(a, gdip, &[]))?;
    let dip = reply
        .as_deref()
        .and_then(|r| numbers(r, a, gdip))
        .and_then(|v| v.first().copied())
        .with_context(|| format!("{model_name} at address {a}: no readable GDIP answer"))?;
    outln_switches(model.series, dip)?;
    match model.series {
        Series::Compact if dip & 0x0F != 0 => bail!(
            "refused: --set-address {n}: this {model_name}'s address {} comes from its ADR switches (DIP1..DIP4), which SMBADR does not override: it \"is only used immediately, if the DIP switch setting of the bus address is 0\" (resi-spec §1.4, L19908). Set DIP1..DIP4 {}, or all off to use the FLASH address, and run commission again",
            dip & 0x0F,
            if n <= 15 {
                format!("to {n} (DIP1 = 1, DIP2 = 2, DIP3 = 4, DIP4 = 8)")
            } else {
                "all off (the switches give 1..15 only)".to_string()
            }
        ),
        Series::Slim if dip & 0x08 != 0 => bail!(
            "refused: --set-address {n}: DIP4 \"FD\" is on, so this {model_name} \"uses always the unit ID 255\" (resi-spec §1.3, L1842); switch DIP4 off to use the FLASH address and run commission again"
        ),
        _ => {}
    }
    let smbadr = common("SMBADR")?;
    let rst = common("RST")?;
    let gmbadr = common("GMBADR")?;
    let settings = session.settings();
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

fn outln_switches(series: Series, dip: i64) -> anyhow::Result<()> {
    let n = series.dips();
    let bits: String = (0..n)
        .map(|i| if dip & (1 << i) != 0 { '1' } else { '0' })
        .collect();
    crate::cli::out::outln(&format!("   DIP1..{n} = {bits}"))
}
