//! `softplc commission PORT --address A ...`: sets a module's address, baud/format and reply
//! delay and makes them permanent by the module's own means, then reads it back at the new
//! settings.
//!
//! - MiniMod (manual, "Configuration of Minimod"): `>RDELAYT=n` ("Setting the reply delay",
//!   hundredths of a second, 0..=200), `>SERLINE=19200E` ("Setting the communication
//!   parameters": 4800..57600, E/O/N/X; the module replies with the old settings, the new
//!   ones apply after the `OK`), `>ADDRESS=N` ("Setting the slave address", 1..=247 for
//!   Modbus), then `>WCONF=1` ("Saving setting permanently"). Read back: `@N?DEVICE` at the
//!   new settings (SERLINE and RDELAYT are write-only, "Read commands table").
//! - RESI: baud and parity are DIP switches (resi-spec §1.3): refused, with that reason.
//! - EX-9053: a new baud needs the INIT* terminal on GND (manual §1.4, §2.1): refused here.
//!
//! Nothing is written without `--yes` or a "yes" typed at a terminal.

use std::io::{BufRead, IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context};
use softplc_io::devices::minimod::serial_config::{LineMode, BAUD_RATES, MAX_RDELAY};
use softplc_io::devices::minimod::text::{write_command, TextId, WriteValue};
use softplc_io::line::transport::SerialTransport;
use softplc_io::line::{LineSettings, SerialFormat};
use softplc_io::time::{Clock, MonotonicClock};

use super::discover::{ask, Family};
use super::out::outln;

/// Arguments of `softplc commission`.
#[derive(Debug, clap::Args)]
pub struct CommissionArgs {
    /// The serial device the module is on.
    port: PathBuf,
    /// The module's address now.
    #[arg(long)]
    address: u8,
    /// The module's baud rate now.
    #[arg(long, default_value_t = 19200)]
    baud: u32,
    /// The module's character format now (8E1, 8N1, 8O1, 8N2).
    #[arg(long, default_value = "8E1")]
    format: SerialFormat,
    /// The new address (MiniMod: 1..=247).
    #[arg(long)]
    set_address: Option<u8>,
    /// The new baud rate (MiniMod: 4800, 9600, 19200, 38400, 57600).
    #[arg(long)]
    set_baud: Option<u32>,
    /// The new character format (MiniMod: 8E1, 8O1, 8N2, 8N1).
    #[arg(long)]
    set_format: Option<SerialFormat>,
    /// The new reply delay (MiniMod: 0..=2s in steps of 10ms).
    #[arg(long, value_parser = super::args::parse_duration)]
    set_reply_delay: Option<Duration>,
    /// Make the changes without asking.
    #[arg(long)]
    yes: bool,
    /// How long to wait for each answer.
    #[arg(long, default_value = "200ms", value_parser = super::args::parse_duration)]
    timeout: Duration,
}

/// One write: what it is, the frame.
struct Step {
    what: String,
    frame: Vec<u8>,
}

/// An answer as printed: the text, or that none came.
fn heard(reply: &Option<String>) -> String {
    match reply {
        Some(r) => format!("<- {r:?}"),
        None => "<- (no answer)".into(),
    }
}

fn show(frame: &[u8]) -> String {
    format!("{:?}", String::from_utf8_lossy(frame))
}

pub(super) fn commission(args: CommissionArgs) -> anyhow::Result<ExitCode> {
    if args.set_address.is_none()
        && args.set_baud.is_none()
        && args.set_format.is_none()
        && args.set_reply_delay.is_none()
    {
        bail!(
            "nothing to change: give --set-address, --set-baud, --set-format or --set-reply-delay"
        );
    }
    let now = LineSettings {
        baud: args.baud,
        format: args.format,
    };
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let mut t = SerialTransport::open(&args.port, now, clock.clone())
        .with_context(|| format!("at {now}"))?;
    // Who is it? Each family by its own identification.
    let mut model = None;
    for fam in Family::ALL {
        if !fam.supports(now, args.address) {
            continue;
        }
        let req = fam.request(args.address);
        outln(&format!("-> {} (who are you? {})", show(&req), fam.name()))?;
        if let Some(reply) = ask(&mut t, &req, args.timeout)? {
            outln(&format!("<- {reply:?}"))?;
            if let Some(Ok(m)) = fam.identify(args.address, &reply) {
                model = Some((fam, m));
                break;
            }
        }
    }
    let Some((family, name)) = model else {
        bail!(
            "no module answers at address {} at {now} on {}",
            args.address,
            args.port.display()
        );
    };
    outln(&format!("{name} at address {} at {now}", args.address))?;
    let (steps, after) = match family {
        Family::MiniMod => minimod_plan(&args, now)?,
        Family::Resi => {
            if args.set_baud.is_some() || args.set_format.is_some() {
                bail!("refused: a RESI module's baud rate and parity are set by its DIP switches (BR0..BR2, PARITY; resi-spec §1.3), not by a command");
            }
            bail!("refused: RESI addresses are set with the DIP switches, or SMBADR + RST when they are at 0 (resi-spec §1.4); softplc commission does not do that yet");
        }
        Family::Dcon => {
            if args.set_baud.is_some() {
                bail!("refused: an EX-9053 takes a new baud rate only with its INIT* terminal on GND, and uses it after the next power-on (manual §1.4, §2.1 %AANNTTCCFF); softplc commission does not do that yet");
            }
            bail!("refused: softplc commission does not change EX-9053 settings yet (%AANNTTCCFF, manual §2.1)");
        }
    };
    outln("plan:")?;
    for s in &steps {
        outln(&format!("  {}: {}", s.what, show(&s.frame)))?;
    }
    if !args.yes && !confirm()? {
        outln("nothing changed")?;
        return Ok(ExitCode::from(1));
    }
    let (new_address, new_settings) = after;
    for s in &steps {
        outln(&format!("-> {} ({})", show(&s.frame), s.what))?;
        let reply = ask(&mut t, &s.frame, args.timeout)?;
        outln(&heard(&reply))?;
        if reply.as_deref().map(str::trim) != Some("OK") {
            bail!(
                "{}: the module did not answer OK ({reply:?}); stopped here",
                s.what
            );
        }
        // "The module replies with the old settings; the new ones apply after the OK".
        if s.what.starts_with("SERLINE") && new_settings != now {
            drop(t);
            t = SerialTransport::open(&args.port, new_settings, clock.clone())
                .with_context(|| format!("at {new_settings}"))?;
            outln(&format!("   now talking at {new_settings}"))?;
        }
    }
    // Read back at the new settings.
    let req = family.request(new_address);
    outln(&format!("-> {} (read back at {new_settings})", show(&req)))?;
    let reply = ask(&mut t, &req, args.timeout)?;
    outln(&heard(&reply))?;
    match reply
        .as_deref()
        .and_then(|r| family.identify(new_address, r))
    {
        Some(Ok(_)) => {
            outln(&format!(
                "{name} answers at address {new_address}, {new_settings}; saved (WCONF)"
            ))?;
            Ok(ExitCode::SUCCESS)
        }
        _ => bail!("no answer at address {new_address}, {new_settings} after the change"),
    }
}

type Plan = (Vec<Step>, (u8, LineSettings));

fn minimod_plan(args: &CommissionArgs, now: LineSettings) -> anyhow::Result<Plan> {
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
        steps.push(Step {
            what: format!("RDELAYT={n} (reply delay {ms}ms)"),
            frame: frame(a, TextId::RdelayT, WriteValue::Number(n))?,
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
        steps.push(Step {
            what: format!("SERLINE={baud}{} ({new_settings})", mode.letter()),
            frame: frame(
                a,
                TextId::Serline,
                WriteValue::Serline {
                    baud,
                    mode: Some(mode),
                },
            )?,
        });
    }
    let mut new_address = a;
    if let Some(n) = args.set_address {
        if !(1..=247).contains(&n) {
            bail!("refused: --set-address {n}: Modbus accepts only 1..=247 (MiniMod manual, \"Setting the slave address\")");
        }
        new_address = n;
        steps.push(Step {
            what: format!("ADDRESS={n}"),
            frame: frame(a, TextId::Address, WriteValue::Number(u16::from(n)))?,
        });
    }
    steps.push(Step {
        what: "WCONF=1 (save to flash)".into(),
        frame: frame(new_address, TextId::Wconf, WriteValue::Number(1))?,
    });
    Ok((steps, (new_address, new_settings)))
}

/// Asks at a terminal; anything but a terminal answering "yes" is a no.
fn confirm() -> anyhow::Result<bool> {
    if !std::io::stdin().is_terminal() {
        outln("not a terminal: give --yes to make these changes")?;
        return Ok(false);
    }
    print!("make these changes? type yes: ");
    std::io::stdout().flush()?;
    let mut line = String::new();
    std::io::stdin().lock().read_line(&mut line)?;
    Ok(line.trim() == "yes")
}
