//! mbpoll (Debian package `mbpoll`, libmodbus underneath): the third-party Modbus master.
//!
//! mbpoll prints no timings, so its time per transaction is measured from outside: one process
//! polls the same unit K times back to back (`-a 5,5,...,5 -1`), another once, and the
//! difference of their wall times divided by K − 1 is the time per transaction without the
//! process start and the port opening.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};

/// `mbpoll <version>` (the Debian package's version when dpkg knows it: mbpoll's own `-V`
/// prints an old internal number), or `None` when mbpoll is not installed.
pub(crate) fn version() -> Option<String> {
    let out = Command::new("mbpoll")
        .arg("-V")
        .stderr(Stdio::null())
        .output()
        .ok()?;
    let own = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let package = Command::new("dpkg-query")
        .args(["-W", "-f", "${Version}", "mbpoll"])
        .stderr(Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .filter(|v| !v.is_empty());
    Some(format!("mbpoll {}", package.unwrap_or(own)))
}

/// One mbpoll run reading discrete inputs 0..10 of `unit` (FC 2, what the runtime's MiniMod
/// driver reads) `polls` times back to back at 19200 8E1; returns its wall time.
pub(crate) fn timed_run(path: &Path, unit: u8, polls: usize) -> anyhow::Result<Duration> {
    let units = vec![unit.to_string(); polls].join(",");
    let start = Instant::now();
    let out = Command::new("mbpoll")
        .args([
            "-m", "rtu", "-b", "19200", "-P", "even", "-d", "8", "-s", "1",
        ])
        .args(["-a", &units, "-0", "-t", "1", "-r", "0", "-c", "10", "-1"])
        .arg(path)
        .stdin(Stdio::null())
        .output()
        .context("cannot run mbpoll")?;
    let took = start.elapsed();
    let text = String::from_utf8_lossy(&out.stdout);
    let polled = text.matches("Polling slave").count();
    let failed = text
        .lines()
        .filter(|l| l.contains("Read") && l.contains("failed"))
        .count()
        + String::from_utf8_lossy(&out.stderr)
            .matches("failed")
            .count();
    if polled != polls || failed > 0 {
        bail!("mbpoll polled {polled} of {polls} times, {failed} failures");
    }
    Ok(took)
}

/// Time per transaction of one measurement: (`polls` in one process − 1 poll) / (polls − 1).
pub(crate) fn per_transaction(path: &Path, unit: u8, polls: usize) -> anyhow::Result<Duration> {
    let one = timed_run(path, unit, 1)?;
    let many = timed_run(path, unit, polls)?;
    Ok(many.saturating_sub(one) / (polls.max(2) as u32 - 1))
}
