//! `softplc sim --pty ...` as a child process: the simulator a third-party master can talk to.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::time::Duration;

use anyhow::{bail, Context};

/// The `softplc` binary of this workspace, built now if cargo runs the harness (so the
/// simulator is the code under test, not a stale build).
pub(crate) fn softplc_binary() -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe().context("cannot locate the harness's own binary")?;
    let dir = exe.parent().context("the harness's binary has no folder")?;
    let bin = dir.join("softplc");
    if let Some(cargo) = std::env::var_os("CARGO") {
        let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let mut cmd = Command::new(cargo);
        cmd.current_dir(&workspace)
            .args(["build", "--quiet", "-p", "softplc", "--bin", "softplc"]);
        if !cfg!(debug_assertions) {
            cmd.arg("--release");
        }
        let status = cmd.status().context("cannot run cargo to build softplc")?;
        if !status.success() {
            bail!("cargo build -p softplc failed ({status})");
        }
    }
    if !bin.exists() {
        bail!(
            "{} not found: build it with `cargo build --release -p softplc`",
            bin.display()
        );
    }
    Ok(bin)
}

/// A running `softplc sim` serving on a pty.
#[derive(Debug)]
pub(crate) struct ServedSim {
    child: Child,
    stdin: Option<ChildStdin>,
    /// The pty path a master opens.
    pub path: PathBuf,
}

impl ServedSim {
    /// Starts `softplc sim --pty DEVICES...` and waits for the path it prints.
    pub(crate) fn start(binary: &Path, devices: &[&str]) -> anyhow::Result<Self> {
        let mut child = Command::new(binary)
            .arg("sim")
            .arg("--pty")
            .args(devices)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .with_context(|| format!("cannot start {}", binary.display()))?;
        let stdin = child.stdin.take();
        let stdout = child.stdout.take().context("no stdout from softplc sim")?;
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut served = Self {
            child,
            stdin,
            path: PathBuf::new(),
        };
        // "serving minimod@5 on /dev/pts/7 at 19200 8E1"
        loop {
            let line = rx
                .recv_timeout(Duration::from_secs(10))
                .context("softplc sim printed no pty path within 10 s")?;
            if let Some(rest) = line.strip_prefix("serving ") {
                if let Some(path) = rest.split(" on ").nth(1).and_then(|s| s.split(' ').next()) {
                    served.path = PathBuf::from(path);
                    return Ok(served);
                }
            }
        }
    }
}

impl ServedSim {
    /// One line on the simulator's console (`set minimod@1.X1 1`).
    pub(crate) fn command(&mut self, line: &str) -> anyhow::Result<()> {
        let stdin = self
            .stdin
            .as_mut()
            .context("the simulator's console is closed")?;
        stdin.write_all(format!("{line}\n").as_bytes())?;
        stdin.flush()?;
        Ok(())
    }
}

impl Drop for ServedSim {
    fn drop(&mut self) {
        // `quit` on standard input stops the server cleanly; kill it if it does not.
        if let Some(mut stdin) = self.stdin.take() {
            // The server may have exited already (a broken pipe); the kill below covers it.
            drop(stdin.write_all(b"quit\n"));
        }
        for _ in 0..50 {
            if matches!(self.child.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        // Best effort on the way out: the child may have exited between the last poll and
        // the kill; the wait reaps it either way.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}
