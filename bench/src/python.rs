//! The Python masters of the peer scenario (`py/poll_master.py`): pymodbus and minimalmodbus in
//! the virtual environment `bench/setup` builds from `py/requirements.txt` (pinned versions) at
//! `target/bench-venv`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use anyhow::{bail, Context};
use softplc::scan::DurationHistogram;

/// The harness's Python masters: the interpreter of the virtual environment, the script, and
/// the pinned versions it was built with.
#[derive(Debug, Clone)]
pub(crate) struct Masters {
    python: PathBuf,
    script: PathBuf,
    /// `requirements.txt` as installed: `name==version` per line.
    pinned: String,
}

/// A library the script drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Library {
    /// pymodbus's synchronous serial client, as OpenPLC v4's Modbus master plugin uses it.
    Pymodbus,
    /// minimalmodbus, one instrument per unit.
    Minimalmodbus,
}

impl Library {
    fn arg(self) -> &'static str {
        match self {
            Self::Pymodbus => "pymodbus",
            Self::Minimalmodbus => "minimalmodbus",
        }
    }
}

/// What the script does with the outputs each cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Writes {
    /// The one output that changed (FC 5).
    Changed,
    /// Every unit's output, changed or not (one FC 5 per unit).
    All,
}

impl Masters {
    /// The masters, or why they cannot run (`bench/setup` builds the environment).
    pub(crate) fn find() -> anyhow::Result<Self> {
        let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let venv = workspace.join("target/bench-venv");
        let python = venv.join("bin/python");
        if !python.exists() {
            bail!("no Python environment at target/bench-venv: run bench/setup, which builds it");
        }
        let pinned = std::fs::read_to_string(venv.join("requirements.txt"))
            .context("target/bench-venv has no requirements.txt: run bench/setup")?;
        Ok(Self {
            python,
            script: Path::new(env!("CARGO_MANIFEST_DIR")).join("py/poll_master.py"),
            pinned,
        })
    }

    /// `library VERSION` as pinned.
    pub(crate) fn version(&self, library: Library) -> String {
        let name = library.arg();
        self.pinned
            .lines()
            .find_map(|l| l.trim().strip_prefix(name)?.strip_prefix("=="))
            .map_or_else(|| name.to_string(), |v| format!("{name} {v}"))
    }

    /// Runs `cycles` cycles of `library` on the line at `port` (`units`, 19200 8E1); the time
    /// of each cycle as the script measured it.
    pub(crate) fn cycles(
        &self,
        library: Library,
        writes: Writes,
        port: &Path,
        units: &[u8],
        cycles: usize,
    ) -> anyhow::Result<DurationHistogram> {
        let units: Vec<String> = units.iter().map(u8::to_string).collect();
        let mut cmd = Command::new(&self.python);
        cmd.arg(&self.script)
            .args(["--lib", library.arg(), "--port"])
            .arg(port)
            .args(["--units", &units.join(","), "--cycles", &cycles.to_string()]);
        if writes == Writes::All {
            cmd.arg("--write-all");
        }
        let out = cmd
            .stdin(Stdio::null())
            .output()
            .with_context(|| format!("cannot run {}", self.python.display()))?;
        let errors = String::from_utf8_lossy(&out.stderr);
        if !out.status.success() {
            let first = errors.lines().find(|l| !l.trim().is_empty()).unwrap_or("");
            bail!("{} failed ({}): {first}", library.arg(), out.status);
        }
        let mut hist = DurationHistogram::new();
        for line in String::from_utf8_lossy(&out.stdout).lines() {
            let micros: f64 = line
                .trim()
                .parse()
                .with_context(|| format!("{}: not a cycle time: {line:?}", library.arg()))?;
            hist.record(Duration::from_secs_f64(micros / 1e6));
        }
        if hist.percentiles().count == 0 {
            bail!("{} printed no cycle time", library.arg());
        }
        Ok(hist)
    }
}
