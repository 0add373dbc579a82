//! A project on simulated lines scanned in real time on its own thread, with module
//! `line1_m1` open to a probe at its terminal: what the terminal-timing scenarios (pulse,
//! reaction) start the same way.

use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::Context;
use softplc::clock::MonotonicClock;
use softplc::plc::Plc;
use softplc::project::Project;
use softplc::scan::{RunOutcome, ScanEngine};
use softplc_io::sim::SharedWorld;
use softplc_io::time::{Clock, ScanInstant};

/// A scan running on its thread.
pub(crate) struct Scanning {
    /// The PLC's clock (monotonic, real time).
    pub clock: Arc<dyn Clock>,
    /// The simulated world the project's lines run in.
    pub world: SharedWorld,
    /// Module `line1_m1` in `world`.
    pub device: usize,
    /// The clock's reading just before the scan started.
    pub begin: ScanInstant,
    scan: JoinHandle<RunOutcome>,
}

impl Scanning {
    /// Builds `project` on the monotonic clock and scans it for `run_for` on a thread named
    /// `thread`.
    pub(crate) fn start(
        project: Project,
        thread: String,
        run_for: Duration,
    ) -> anyhow::Result<Self> {
        let plc = Plc::build(project, Arc::new(MonotonicClock::new()))?;
        let clock = plc.clock().clone();
        let world = plc
            .world()
            .cloned()
            .context("the project has no simulated world")?;
        let device = world
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .find("line1_m1")
            .context("module line1_m1 is not in the world")?;
        let begin = clock.now();
        let scan = std::thread::Builder::new()
            .name(thread)
            .spawn(move || ScanEngine::new(plc).run_for(run_for).run())?;
        Ok(Self {
            clock,
            world,
            device,
            begin,
            scan,
        })
    }

    /// Waits for the scan to end.
    pub(crate) fn join(self) -> anyhow::Result<RunOutcome> {
        self.scan
            .join()
            .map_err(|_| anyhow::anyhow!("the scan thread panicked"))
    }
}
