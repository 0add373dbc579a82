//! `softplc discover PORT`: finds the modules on a line and prints a project skeleton.
//!
//! Each family is identified by its own means, with the drivers' encoders, as the family
//! says (`softplc_io::devices::Family::who_are_you`, `identify`; asked in the order of
//! `softplc_io::devices::families`):
//! - MiniMod: `@N?DEVICE`, answered `DEVICE=MINIMOD 1.1` (manual, "Text commands protocol",
//!   "Slave addressing", "Read commands table (text mode)"); bauds 4800..57600 ("SERLINE").
//! - RESI: `#A,TYP`, answered `#A,TYPE:RESI-<model>-ASCII` (resi-spec §2.1, §2.5); bauds
//!   4800..256000 by DIP switch, parity none or even only, one stop bit (§1.3).
//! - EX-9053D: `$AAM` (read name), answered `!AA<name>` (manual §2.13); the factory setting
//!   is 9600 8N1 (§1.3); DCON addresses are two hex digits.
//!
//! The probe plan is every (baud, format) × address × family the family supports; its worst
//! case (every probe timing out) is printed before the first probe, from the line timing model.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use softplc_io::devices::{families, Family};
use softplc_io::line::{LineSettings, SerialFormat, SerialTransport, Transport};
use softplc_io::time::{Clock, MonotonicClock};

use super::out::outln;

/// Arguments of `softplc discover`.
#[derive(Debug, clap::Args)]
pub(crate) struct DiscoverArgs {
    /// The serial device the modules are on (/dev/ttyUSB0, or a pty of `softplc sim --pty`).
    port: PathBuf,
    /// Baud rates to try, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [9600, 19200, 38400, 57600, 4800, 115200])]
    bauds: Vec<u32>,
    /// Character formats to try, comma-separated (8E1, 8N1, 8O1, 8N2).
    #[arg(long, value_delimiter = ',', default_values_t = ["8N1".to_string(), "8E1".to_string()])]
    formats: Vec<String>,
    /// Addresses to probe: a range (1-247), a list (1,2,5) or both (1-4,9).
    #[arg(long, default_value = "1-247")]
    addresses: String,
    /// How long to wait for each module's answer.
    #[arg(long, default_value = "50ms", value_parser = super::args::parse_duration)]
    timeout: Duration,
    /// Also write the project skeleton to this file.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Parses `1-247`, `1,2,5` or `1-4,9` (unit addresses 0..=255 as the families allow).
pub(crate) fn parse_addresses(text: &str) -> anyhow::Result<Vec<u8>> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let num = |s: &str| -> anyhow::Result<u8> {
            s.trim()
                .parse()
                .with_context(|| format!("--addresses {text:?}: {s:?} is not an address 0..=255"))
        };
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (num(a)?, num(b)?);
                if a > b {
                    bail!("--addresses {text:?}: range {part:?} runs backwards");
                }
                out.extend(a..=b);
            }
            None => out.push(num(part)?),
        }
    }
    if out.is_empty() {
        bail!("--addresses {text:?}: no address given");
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

/// One probe: settings, address, family.
type Probe = (LineSettings, u8, &'static dyn Family);

/// The question a probe asks.
fn question(p: &Probe) -> Vec<u8> {
    let (_, a, f) = *p;
    f.who_are_you(a, false).unwrap_or_default()
}

/// The longest a probe can take: the request on the wire, the whole timeout, t3.5 after.
fn probe_bound(p: &Probe, timeout: Duration) -> Duration {
    let (s, _, _) = *p;
    s.chars(question(p).len()) + timeout + s.t3_5()
}

/// A module found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Found {
    settings: LineSettings,
    address: u8,
    model: &'static str,
    reply: String,
}

pub(super) fn discover(args: DiscoverArgs) -> anyhow::Result<ExitCode> {
    let addresses = parse_addresses(&args.addresses)?;
    let mut lines = Vec::new();
    for &baud in &args.bauds {
        if baud == 0 {
            bail!("--bauds: 0 is not a baud rate");
        }
        for f in &args.formats {
            let format: SerialFormat = f.parse().with_context(|| format!("--formats: {f:?}"))?;
            lines.push(LineSettings { baud, format });
        }
    }
    let mut plan: Vec<Probe> = Vec::new();
    for &s in &lines {
        for &a in &addresses {
            for &fam in families() {
                if fam.supports(s, a) && fam.who_are_you(a, false).is_some() {
                    plan.push((s, a, fam));
                }
            }
        }
    }
    let bound: Duration = plan.iter().map(|p| probe_bound(p, args.timeout)).sum();
    outln(&format!(
        "probing {} on {} settings x {} addresses: {} probes, at most {} (every probe timing out at {})",
        args.port.display(),
        lines.len(),
        addresses.len(),
        plan.len(),
        crate::scan::fmt_duration(bound),
        crate::scan::fmt_duration(args.timeout),
    ))?;
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let started = Instant::now();
    let mut found: Vec<Found> = Vec::new();
    let mut transport: Option<SerialTransport> = None;
    for p in &plan {
        let (s, a, fam) = *p;
        // A module found at this address and baud is not asked again in another format or
        // as another family (on a pty, parity does not reach the other end: it would answer
        // in every format).
        if found
            .iter()
            .any(|f| f.settings.baud == s.baud && f.address == a)
        {
            continue;
        }
        if transport.as_ref().map(|t| t.settings()) != Some(s) {
            drop(transport.take());
            transport = Some(
                SerialTransport::open(&args.port, s, clock.clone())
                    .with_context(|| format!("at {s}"))?,
            );
        }
        let Some(t) = transport.as_mut() else {
            continue;
        };
        if let Some(reply) = ask(t, &question(p), args.timeout)? {
            match fam.identify(a, &reply) {
                Some(Ok(model)) => {
                    outln(&format!(
                        "  found {model} at address {a}, {s} ({}: {:?})",
                        fam.name(),
                        reply.trim_end()
                    ))?;
                    found.push(Found {
                        settings: s,
                        address: a,
                        model,
                        reply,
                    });
                }
                Some(Err(why)) => outln(&format!("  address {a}, {s}: {why}"))?,
                None => {}
            }
        }
    }
    outln(&format!(
        "{} module(s) found in {}",
        found.len(),
        crate::scan::fmt_duration(started.elapsed())
    ))?;
    let port = args.port.display().to_string();
    for line in odd_report(&port, &found) {
        outln(&line)?;
    }
    let yaml = skeleton(&port, &found);
    outln("")?;
    outln(&yaml)?;
    if let Some(path) = &args.out {
        std::fs::write(path, &yaml).with_context(|| format!("cannot write {}", path.display()))?;
        let program = path
            .parent()
            .unwrap_or_else(|| std::path::Path::new("."))
            .join(PROGRAM_FILE);
        if !program.exists() {
            std::fs::write(&program, "# the control program: one assignment per line\n")
                .with_context(|| format!("cannot write {}", program.display()))?;
        }
        outln(&format!("# written to {}", path.display()))?;
    }
    Ok(if found.is_empty() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// Sends `request` and reads one CR-ended answer until `timeout` after the request has left;
/// keeps the line quiet for t3.5 after and drops whatever else came.
pub(super) fn ask(
    t: &mut SerialTransport,
    request: &[u8],
    timeout: Duration,
) -> anyhow::Result<Option<String>> {
    t.flush_input().context("cannot flush the port's input")?;
    t.write_frame(request).context("cannot write to the port")?;
    let deadline = t.now() + timeout;
    let mut buf = Vec::new();
    while !buf.contains(&b'\r') {
        if t.read_until(&mut buf, deadline)
            .context("cannot read the port")?
            == 0
        {
            break;
        }
    }
    let quiet = t.now() + t.settings().t3_5();
    t.wait_until(quiet);
    // Best effort: a line that cannot be flushed fails the next probe's read, which reports it.
    drop(t.flush_input());
    let Some(end) = buf.iter().position(|b| *b == b'\r') else {
        return Ok(None);
    };
    Ok(std::str::from_utf8(&buf[..end]).ok().map(str::to_string))
}

/// The program file the skeleton names.
const PROGRAM_FILE: &str = "program.expr";

/// The settings of the line a skeleton makes: those most of the modules found have (the
/// faster baud between equals), since one line has one baud and format.
fn line_settings(found: &[Found]) -> Option<LineSettings> {
    let mut count: Vec<(LineSettings, usize)> = Vec::new();
    for f in found {
        match count.iter_mut().find(|(s, _)| *s == f.settings) {
            Some((_, n)) => *n += 1,
            None => count.push((f.settings, 1)),
        }
    }
    count
        .into_iter()
        .max_by_key(|(s, n)| (*n, s.baud))
        .map(|(s, _)| s)
}

/// The modules found at other settings than `line`'s.
fn odd_modules(found: &[Found], line: LineSettings) -> Vec<&Found> {
    found.iter().filter(|f| f.settings != line).collect()
}

/// The command that moves `f` to `line`'s baud and format.
fn commission_command(port: &str, f: &Found, line: LineSettings) -> String {
    format!(
        "softplc commission {port} --address {} --baud {} --format {} --set-baud {} --set-format {}",
        f.address, f.settings.baud, f.settings.format, line.baud, line.format
    )
}

/// What discover says of the modules that cannot share the line: one line each, with the
/// command that would put it on the line's settings.
fn odd_report(port: &str, found: &[Found]) -> Vec<String> {
    let Some(line) = line_settings(found) else {
        return Vec::new();
    };
    let odd = odd_modules(found, line);
    if odd.is_empty() {
        return Vec::new();
    }
    let mut out = vec![format!(
        "{} module(s) answer at other settings than the line's {} {}: one line has one baud \
         and format, so commission each to the line's (then add it to the project's modules):",
        odd.len(),
        line.baud,
        line.format
    )];
    for f in odd {
        out.push(format!(
            "  {} at address {} ({} {}): {}",
            f.model,
            f.address,
            f.settings.baud,
            f.settings.format,
            commission_command(port, f, line)
        ));
    }
    out
}

/// A project file with one bus on the port, at the settings most modules have, and those
/// modules on it; the others are listed with the command that commissions them to the line.
pub(crate) fn skeleton(port: &str, found: &[Found]) -> String {
    let mut y = String::new();
    let _ = writeln!(
        y,
        "# Found by `softplc discover {port}`: edit names, add tags and a program."
    );
    for line in odd_report(port, found) {
        let _ = writeln!(y, "# {line}");
    }
    let _ = writeln!(y, "project: discovered\n");
    let _ = writeln!(y, "scan:\n  period: 100ms\n");
    let _ = writeln!(
        y,
        "program:            # --out writes an empty one next to the project\n  file: {PROGRAM_FILE}\n  kind: expr\n"
    );
    let line = line_settings(found).unwrap_or(LineSettings::DEFAULT);
    let _ = writeln!(y, "buses:");
    let _ = writeln!(y, "  - name: line1");
    let _ = writeln!(y, "    port: {port}");
    let _ = writeln!(y, "    baud: {}", line.baud);
    let _ = writeln!(y, "    format: {}", line.format);
    let _ = writeln!(y, "    response_timeout: 50ms");
    let _ = writeln!(y, "\nmodules:");
    let on_line: Vec<&Found> = found.iter().filter(|f| f.settings == line).collect();
    if on_line.is_empty() {
        let _ = writeln!(y, "  []");
    }
    for f in on_line {
        let short = f.model.replace('-', "_");
        let _ = writeln!(
            y,
            "  - {{ name: {short}_{}, bus: line1, model: {}, address: {} }}",
            f.address, f.model, f.address
        );
    }
    y
}

#[cfg(test)]
mod tests {
    use super::*;
    use softplc_io::devices::ex9053::Ex9053Family;
    use softplc_io::devices::minimod::MiniModFamily;
    use softplc_io::devices::resi::ResiFamily;

    #[test]
    fn parses_address_ranges_and_refuses_nonsense() {
        assert_eq!(parse_addresses("1-3,7").unwrap(), vec![1, 2, 3, 7]);
        assert!(parse_addresses("5-2")
            .unwrap_err()
            .to_string()
            .contains("backwards"));
        assert!(parse_addresses("1-300")
            .unwrap_err()
            .to_string()
            .contains("300"));
    }

    #[test]
    fn identifies_each_family_by_its_own_answer() {
        assert_eq!(
            MiniModFamily.identify(5, "DEVICE=MINIMOD 1.1"),
            Some(Ok("minimod"))
        );
        assert_eq!(
            ResiFamily.identify(3, "#3,TYPE:RESI-16DI8RO-ASCII"),
            Some(Ok("resi-16di8ro"))
        );
        assert_eq!(Ex9053Family.identify(2, "!029053"), Some(Ok("ex9053d")));
        assert_eq!(Ex9053Family.identify(2, "?02"), None);
        assert_eq!(
            Ex9053Family.who_are_you(0x2A, false),
            Some(b"$2AM\r".to_vec()),
            "the DCON address is hex"
        );
    }
}
