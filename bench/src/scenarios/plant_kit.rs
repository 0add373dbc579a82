//! What the plant-services scenarios (11 and 14) share: a mosquitto of the harness, `softplc
//! run` as a child process, the CPU time of a process from `/proc/PID/stat`.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};

use super::Ctx;

/// A mosquitto of the harness: loopback only, anonymous, no persistence.
pub(super) struct Broker {
    pub(super) child: Child,
    pub(super) port: u16,
}

impl Broker {
    pub(super) fn start(dir: &Path) -> anyhow::Result<Self> {
        Self::start_with(dir, "")
    }

    /// As [`Broker::start`], with `extra` lines in its configuration file.
    pub(super) fn start_with(dir: &Path, extra: &str) -> anyhow::Result<Self> {
        let port = free_port()?;
        let conf = dir.join("mosquitto.conf");
        std::fs::write(
            &conf,
            format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n{extra}"),
        )?;
        let child = Command::new("mosquitto")
            .arg("-c")
            .arg(&conf)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .context("cannot start mosquitto")?;
        let broker = Self { child, port };
        let deadline = Instant::now() + Duration::from_secs(10);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            if Instant::now() > deadline {
                bail!("mosquitto did not listen on 127.0.0.1:{port} within 10 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        Ok(broker)
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        // The broker may have exited already; the wait reaps it either way.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

pub(super) fn free_port() -> anyhow::Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(l.local_addr()?.port())
}

/// `softplc run` of `project` for `run_for`, killed when dropped; its standard error goes to
/// `softplc.log` beside the project, so a run that stops early can say why.
pub(super) struct Running {
    pub(super) child: Child,
    log: PathBuf,
}

impl Running {
    pub(super) fn start(binary: &Path, project: &Path, run_for: Duration) -> anyhow::Result<Self> {
        Self::start_with(binary, project, run_for, None)
    }

    /// As [`Running::start`], with the control socket at `socket` when given.
    pub(super) fn start_with(
        binary: &Path,
        project: &Path,
        run_for: Duration,
        socket: Option<&Path>,
    ) -> anyhow::Result<Self> {
        Self::start_in_env(binary, project, run_for, socket, &[])
    }

    /// As [`Running::start_with`], with `env` added to its environment (`NOTIFY_SOCKET`, as
    /// systemd gives it).
    pub(super) fn start_in_env(
        binary: &Path,
        project: &Path,
        run_for: Duration,
        socket: Option<&Path>,
        env: &[(&str, &std::ffi::OsStr)],
    ) -> anyhow::Result<Self> {
        let log = project.with_file_name("softplc.log");
        let mut cmd = Command::new(binary);
        cmd.envs(env.iter().copied());
        cmd.args(["run", "--quiet"]);
        match socket {
            Some(path) => cmd.arg("--socket").arg(path),
            None => cmd.arg("--no-socket"),
        };
        let child = cmd
            .arg("--for")
            .arg(format!("{}ms", run_for.as_millis()))
            .arg(project)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).context("cannot create softplc.log")?)
            .spawn()
            .context("cannot start softplc run")?;
        Ok(Self { child, log })
    }

    /// The last lines softplc wrote to its standard error.
    pub(super) fn said(&self) -> String {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        let tail = lines[lines.len().saturating_sub(3)..].join(" | ");
        if tail.is_empty() {
            "nothing".into()
        } else {
            tail
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        // It may have stopped at the end of its run time; the wait reaps it either way.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

/// The CPU samples' window, s: `/proc/PID/stat` counts in clock ticks (10 ms at 100 Hz), so
/// one second would resolve only 1 % of a CPU.
pub(super) const WINDOW_S: u32 = 4;

/// utime + stime of process `pid`, in clock ticks.
pub(super) fn cpu_ticks(pid: u32) -> anyhow::Result<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .with_context(|| format!("softplc (pid {pid}) stopped early"))?;
    // Fields after the command name in parentheses, which may hold spaces.
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let num = |i: usize| -> anyhow::Result<u64> {
        fields
            .get(i)
            .and_then(|f| f.parse().ok())
            .context("unreadable /proc/PID/stat")
    };
    // utime and stime are fields 14 and 15 of stat(5); 12 and 13 after the state.
    Ok(num(11)? + num(12)?)
}

/// The length of one clock tick of `/proc/PID/stat` (`getconf CLK_TCK`, 100 Hz on Linux).
pub(super) fn clock_tick() -> Duration {
    let hz = Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.trim().parse::<u32>().ok())
        .filter(|hz| *hz > 0)
        .unwrap_or(100);
    Duration::from_secs(1) / hz
}

/// A folder of the scenario's own under the run's scratch folder.
pub(super) fn scratch(ctx: &Ctx, name: &str) -> anyhow::Result<PathBuf> {
    let dir = ctx.scratch.join(name);
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// The scan's figures as `softplc status --json` gives them (whole microseconds), as
/// percentiles of the harness's own rows.
pub(super) fn from_micros(m: &softplc::service::MicrosPercentiles) -> softplc::scan::Percentiles {
    let us = Duration::from_micros;
    softplc::scan::Percentiles {
        count: m.count,
        p50: us(m.p50_us),
        p99: us(m.p99_us),
        p999: us(m.p999_us),
        max: us(m.max_us),
    }
}
