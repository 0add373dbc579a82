//! Scenario 16: the footprint on the target machine (issue 30's goals). The release binary's
//! size stripped as the package ships it, with the default features and without OPC UA and
//! MQTT, and cross-built for arm64; the quick start's resident memory and CPU share as a
//! service runs it; the time from start to the first completed scan.
//!
//! The binaries are built here through cargo, in the release profile the package uses
//! (`cargo build --release -p softplc`, then with `--no-default-features`, then with
//! `--target aarch64-unknown-linux-gnu`): on a first run each is a fat-LTO build (about ten
//! minutes on two cores), later runs rebuild what cargo finds changed. The build without
//! the services comes first and is copied aside, so `target/release/softplc` is the default
//! build again when the scenario ends. `--quick` builds only the default binary (the other
//! rows say so). Stripping is `strip --strip-all` on a copy (the arm64 binary with the cross
//! binutils' strip), as the package's binary is stripped.
//!
//! The quick start runs as its README command does (`softplc run`, the web page on loopback,
//! here on a free port), with `NOTIFY_SOCKET` set as systemd sets it for the unit's
//! `Type=notify`: `READY=1` comes after the first completed scan, so the time from the spawn to
//! that datagram is the start to the first scan a service manager sees. After READY the
//! process's utime + stime (`/proc/PID/stat`) over a fixed window is its CPU share, and its
//! `VmRSS` at the window's end its resident memory (`VmHWM`, the peak, in the JSON).

use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};

use super::plant_kit::{clock_tick, cpu_ticks, scratch, Running};
use super::{Ctx, Scenario};
use crate::report::{Goal, Outcome, Quantity, Row};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 16,
    name: "footprint",
    title: "Footprint: binary size, the quick start's memory and CPU, start to first scan",
    summary: "Release binaries (`cargo build --release -p softplc`, fat LTO) stripped with \
              `strip --strip-all`: default features, `--no-default-features` (no OPC UA, no \
              MQTT), and the default build cross-built for aarch64 (its size only: it runs here \
              only under qemu emulation). The quick start (`examples/quickstart`, web page on \
              loopback) run by each x86-64 build with `NOTIFY_SOCKET` set as systemd does: \
              `VmRSS` after the window, utime + stime over the window after READY=1 (60 s), and \
              the time from the spawn to READY=1 (sent after the first completed scan), the \
              median of 5 starts. Goals of issue 30, as ratios. MB = 10⁶ bytes.",
    run,
};

/// The default build's stripped size goal.
const DEFAULT_SIZE_GOAL: u64 = 15_000_000;
/// The stripped size goal of the build without OPC UA and MQTT.
const SLIM_SIZE_GOAL: u64 = 8_000_000;
/// The quick start's resident memory goal.
const RSS_GOAL: u64 = 10_000_000;
/// The quick start's CPU goal, percent of one core.
const CPU_GOAL: f64 = 1.0;
/// Starts measured for the time to the first scan.
const STARTS: usize = 5;
/// The cross target whose size is reported.
const ARM64: &str = "aarch64-unknown-linux-gnu";

/// A release build of softplc the scenario measures.
struct Build {
    /// The row's case.
    case: &'static str,
    /// `--no-default-features`.
    slim: bool,
    /// A cross target, if any.
    target: Option<&'static str>,
}

const SLIM: Build = Build {
    case: "without OPC UA and MQTT (x86-64)",
    slim: true,
    target: None,
};
const DEFAULT: Build = Build {
    case: "default features (x86-64)",
    slim: false,
    target: None,
};
const ARM64_DEFAULT: Build = Build {
    case: "default features (aarch64, cross-built)",
    slim: false,
    target: Some(ARM64),
};

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let dir = scratch(ctx, "footprint")?;
    let size_goal = |limit| {
        Some(Goal {
            name: "goal".into(),
            limit: Quantity::Bytes(limit),
        })
    };
    let mut rows = Vec::new();
    // The build without services first, copied aside: the default build is then the one
    // `target/release/softplc` holds, as the other scenarios expect.
    let slim = if ctx.quick {
        Err(anyhow::anyhow!(
            "--quick builds no further release binary (a first build takes minutes)"
        ))
    } else {
        release_binary(&SLIM).and_then(|bin| {
            let aside = dir.join("softplc-no-services");
            std::fs::copy(&bin, &aside)
                .with_context(|| format!("cannot copy {}", bin.display()))?;
            Ok(aside)
        })
    };
    let default = release_binary(&DEFAULT);
    let arm64 = if ctx.quick {
        Err(anyhow::anyhow!(
            "--quick builds no further release binary (a first build takes minutes)"
        ))
    } else {
        release_binary(&ARM64_DEFAULT)
    };

    rows.push(size_row(
        &DEFAULT,
        &default,
        size_goal(DEFAULT_SIZE_GOAL),
        &dir,
    ));
    rows.push(size_row(&SLIM, &slim, size_goal(SLIM_SIZE_GOAL), &dir));
    rows.push(
        size_row(&ARM64_DEFAULT, &arm64, size_goal(DEFAULT_SIZE_GOAL), &dir).note(
            "cross-built; on this machine it runs only under qemu-aarch64 emulation \
             (scripts/arm64-check), where memory and CPU mean nothing for a Pi: size only",
        ),
    );

    let window = ctx.pick(Duration::from_secs(60), Duration::from_secs(5));
    for (build, bin) in [(&DEFAULT, &default), (&SLIM, &slim)] {
        let case = format!("quick start, {}", build.case);
        match bin {
            Ok(bin) => match quick_start(bin, &dir, window) {
                Ok(m) => rows.extend(m.rows(&case, window, build.slim)),
                Err(e) => rows.push(Row::unavailable(case, "quick start", format!("{e:#}"))),
            },
            Err(e) => rows.push(Row::unavailable(case, "quick start", format!("{e:#}"))),
        }
    }
    Ok(Outcome {
        rows,
        plots: Vec::new(),
    })
}

/// The size row of `build`: its stripped size against `goal`, the unstripped size beside.
fn size_row(build: &Build, bin: &anyhow::Result<PathBuf>, goal: Option<Goal>, dir: &Path) -> Row {
    let metric = "stripped binary";
    let bin = match bin {
        Ok(bin) => bin,
        Err(e) => return Row::unavailable(build.case, metric, format!("{e:#}")),
    };
    match stripped_size(bin, build.target, dir) {
        Ok((stripped, unstripped)) => {
            Row::scalar(build.case, metric, Quantity::Bytes(stripped), goal)
                .value("unstripped_bytes", unstripped as f64)
        }
        Err(e) => Row::unavailable(build.case, metric, format!("{e:#}")),
    }
}

/// The workspace's target folder: the harness's own binary is in `target/PROFILE/`.
fn target_dir() -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe().context("cannot locate the harness's own binary")?;
    exe.parent()
        .and_then(Path::parent)
        .map(Path::to_path_buf)
        .context("the harness's binary is not in a cargo target folder")
}

/// Builds `build` with cargo (when the harness runs through cargo) and returns its binary.
fn release_binary(build: &Build) -> anyhow::Result<PathBuf> {
    let mut bin = target_dir()?;
    if let Some(t) = build.target {
        bin.push(t);
    }
    bin.push("release/softplc");
    let Some(cargo) = std::env::var_os("CARGO") else {
        if bin.exists() {
            return Ok(bin);
        }
        bail!(
            "{} not found, and the harness was not run through cargo to build it",
            bin.display()
        );
    };
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut cmd = Command::new(cargo);
    cmd.current_dir(&workspace).args([
        "build",
        "--quiet",
        "--release",
        "-p",
        "softplc",
        "--bin",
        "softplc",
    ]);
    if build.slim {
        cmd.arg("--no-default-features");
    }
    if let Some(t) = build.target {
        cross_env(&mut cmd, t)?;
        cmd.args(["--target", t]);
    }
    eprintln!("  building {} (release)", build.case);
    let status = cmd.status().context("cannot run cargo")?;
    if !status.success() {
        bail!("cargo build --release for {} failed ({status})", build.case);
    }
    Ok(bin)
}

/// The GNU triple of a Rust target's Debian cross tools.
fn gnu_triple(target: &str) -> anyhow::Result<&'static str> {
    match target {
        ARM64 => Ok("aarch64-linux-gnu"),
        other => bail!("no cross tools known for {other}"),
    }
}

/// What `scripts/cross-env` sets for a cross build, checked first: the Rust target and
/// Debian's cross gcc (this scenario installs nothing).
fn cross_env(cmd: &mut Command, target: &str) -> anyhow::Result<()> {
    let gnu = gnu_triple(target)?;
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .ok()
        .map(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .any(|l| l == target)
        })
        .unwrap_or(false);
    if !installed {
        bail!("the Rust target {target} is not installed (rustup target add {target})");
    }
    let gcc = format!("{gnu}-gcc");
    if !tool_exists(&gcc) {
        bail!(
            "{gcc} missing (apt-get install gcc-{gnu}, or run scripts/deb --target {target} once)"
        );
    }
    let upper = target.to_uppercase().replace('-', "_");
    let lower = target.replace('-', "_");
    cmd.env(format!("CARGO_TARGET_{upper}_LINKER"), &gcc)
        .env(format!("CC_{lower}"), &gcc)
        .env(format!("AR_{lower}"), format!("{gnu}-ar"));
    Ok(())
}

fn tool_exists(name: &str) -> bool {
    Command::new(name)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// `(stripped, unstripped)` sizes of `bin`, stripped on a copy in `dir`.
fn stripped_size(bin: &Path, target: Option<&str>, dir: &Path) -> anyhow::Result<(u64, u64)> {
    let strip = match target {
        Some(t) => format!("{}-strip", gnu_triple(t)?),
        None => "strip".to_string(),
    };
    let unstripped = std::fs::metadata(bin)
        .with_context(|| format!("cannot read {}", bin.display()))?
        .len();
    let out = dir.join(format!("stripped-{}", target.unwrap_or("host")));
    let status = Command::new(&strip)
        .arg("--strip-all")
        .arg("-o")
        .arg(&out)
        .arg(bin)
        .status()
        .with_context(|| format!("cannot run {strip} (binutils)"))?;
    if !status.success() {
        bail!("{strip} --strip-all {} failed ({status})", bin.display());
    }
    let stripped = std::fs::metadata(&out)?.len();
    // Best effort: the scratch folder goes at the end of the run anyway.
    drop(std::fs::remove_file(&out));
    Ok((stripped, unstripped))
}

/// The quick start's figures of one build.
struct QuickStart {
    /// Spawn to READY=1, one per start.
    first_scan: Vec<Duration>,
    /// utime + stime over the window after READY.
    cpu: Duration,
    /// VmRSS at the window's end, bytes.
    rss: u64,
    /// VmHWM at the window's end, bytes.
    peak: u64,
    /// Threads at the window's end.
    threads: u64,
}

impl QuickStart {
    fn rows(&self, case: &str, window: Duration, slim: bool) -> Vec<Row> {
        let secs = window.as_secs_f64();
        let percent = self.cpu.as_secs_f64() / secs * 100.0;
        let mut times = self.first_scan.clone();
        times.sort();
        let median = times[times.len() / 2];
        let goal = |limit| {
            Some(Goal {
                name: "goal".into(),
                limit,
            })
        };
        let mut rows = vec![
            Row::scalar(
                case,
                format!("resident memory after {secs:.0} s"),
                Quantity::Bytes(self.rss),
                goal(Quantity::Bytes(RSS_GOAL)),
            )
            .value("peak_bytes", self.peak as f64)
            .note(format!("peak (VmHWM) {:.2} MB", self.peak as f64 / 1e6)),
            Row::scalar(
                case,
                format!("CPU over {secs:.0} s"),
                Quantity::PercentOfCore(percent),
                goal(Quantity::PercentOfCore(CPU_GOAL)),
            )
            .value("cpu_s", self.cpu.as_secs_f64())
            .value("window_s", secs)
            .note(format!(
                "{:.2} s of CPU in {secs:.0} s (utime + stime, clock ticks of {} ms)",
                self.cpu.as_secs_f64(),
                clock_tick().as_millis()
            )),
        ];
        rows.push(
            Row::scalar(case, "threads", Quantity::Count(self.threads), None)
                .note("the process's threads at the window's end (/proc/PID/status)"),
        );
        // The time to the first scan of both builds: a build without services has less to
        // start, and says how much of the time they take.
        let first = times[0];
        let last = times[times.len() - 1];
        rows.push(
            Row::scalar(case, "start to first scan", Quantity::Time(median), None)
                .value("starts", times.len() as f64)
                .value("min_us", first.as_secs_f64() * 1e6)
                .value("max_us", last.as_secs_f64() * 1e6)
                .note(format!(
                    "median of {} starts (spawn to READY=1), {} to {}{}",
                    times.len(),
                    crate::table::fmt_time(first),
                    crate::table::fmt_time(last),
                    if slim {
                        ""
                    } else {
                        "; no OPC UA in the quick start"
                    }
                )),
        );
        rows
    }
}

/// The quick start project in `dir`, its program named by absolute path and its web page on a
/// free loopback port (never the README's fixed 8080, which another process may hold).
fn quick_start_project(dir: &Path) -> anyhow::Result<PathBuf> {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(repo.join("examples/quickstart/project.yaml"))
        .context("cannot read examples/quickstart/project.yaml")?;
    let program = repo.join("programs/conveyor.expr").canonicalize()?;
    let from_program = "file: ../../programs/conveyor.expr";
    let from_web = "bind: 127.0.0.1:8080";
    if !text.contains(from_program) || !text.contains(from_web) {
        bail!("examples/quickstart/project.yaml changed its program or web lines: update the footprint scenario");
    }
    let plant = repo
        .join("examples/quickstart/conveyor.plant.rhai")
        .canonicalize()?;
    let text = text
        .replace(from_program, &format!("file: {}", program.display()))
        .replace(
            "file: conveyor.plant.rhai",
            &format!("file: {}", plant.display()),
        )
        .replace(from_web, "bind: 127.0.0.1:0");
    let path = dir.join("quickstart.yaml");
    std::fs::write(&path, text)?;
    Ok(path)
}

/// Runs the quick start with `bin`: [`STARTS`] starts timed to READY=1, the last one kept for
/// `window` of CPU and memory.
fn quick_start(bin: &Path, dir: &Path, window: Duration) -> anyhow::Result<QuickStart> {
    let project = quick_start_project(dir)?;
    let mut first_scan = Vec::new();
    for i in 0..STARTS {
        let last = i + 1 == STARTS;
        let run_for = if last {
            window + Duration::from_secs(30)
        } else {
            Duration::from_secs(2)
        };
        let notify_path = dir.join(format!("notify-{i}.sock"));
        drop(std::fs::remove_file(&notify_path));
        let notify = UnixDatagram::bind(&notify_path)
            .with_context(|| format!("cannot bind {}", notify_path.display()))?;
        let socket = dir.join(format!("control-{i}.sock"));
        let started = Instant::now();
        let running = Running::start_in_env(
            bin,
            &project,
            run_for,
            Some(&socket),
            &[("NOTIFY_SOCKET", notify_path.as_os_str())],
        )?;
        first_scan.push(wait_ready(&notify, started, &running)?);
        if last {
            let pid = running.child.id();
            let before = cpu_ticks(pid)?;
            std::thread::sleep(window);
            let after = cpu_ticks(pid)?;
            let m = memory(pid)?;
            return Ok(QuickStart {
                first_scan,
                cpu: clock_tick() * u32::try_from(after.saturating_sub(before))?,
                rss: m.rss,
                peak: m.peak,
                threads: m.threads,
            });
        }
        // Dropping it kills the run; the next start is a fresh process.
        drop(running);
    }
    bail!("no start measured")
}

/// Waits for `READY=1` on `notify` (30 s at most) and returns the time since `started`.
fn wait_ready(
    notify: &UnixDatagram,
    started: Instant,
    running: &Running,
) -> anyhow::Result<Duration> {
    let limit = Duration::from_secs(30);
    let mut buf = [0u8; 512];
    loop {
        let left = limit.saturating_sub(started.elapsed());
        if left.is_zero() {
            bail!(
                "no READY=1 within {} s of the start; softplc said: {}",
                limit.as_secs(),
                running.said()
            );
        }
        notify.set_read_timeout(Some(left))?;
        match notify.recv(&mut buf) {
            Ok(n) => {
                let text = String::from_utf8_lossy(&buf[..n]);
                if text.lines().any(|l| l == "READY=1") {
                    return Ok(started.elapsed());
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(e) => return Err(e).context("cannot read the notify socket"),
        }
    }
}

/// What `/proc/PID/status` says of a process's memory and threads.
struct Memory {
    /// VmRSS, bytes.
    rss: u64,
    /// VmHWM, bytes.
    peak: u64,
    /// Threads.
    threads: u64,
}

/// The memory and threads of process `pid`.
fn memory(pid: u32) -> anyhow::Result<Memory> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status"))
        .with_context(|| format!("softplc (pid {pid}) stopped early"))?;
    let field = |key: &str| -> anyhow::Result<u64> {
        status
            .lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|r| r.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            .with_context(|| format!("no {key} in /proc/{pid}/status"))
    };
    Ok(Memory {
        rss: field("VmRSS:")? * 1024,
        peak: field("VmHWM:")? * 1024,
        threads: field("Threads:")?,
    })
}
