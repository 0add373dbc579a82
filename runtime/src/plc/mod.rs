//! A project wired into a runnable PLC: one bus owner per line, one driver per module, the
//! simulated world behind `port: sim` lines, the process image and the program.
//!
//! The scan ([`crate::scan`]) calls the three phases in order. On a real clock every line has
//! its own thread and the phases wait for all lines in parallel; on a virtual clock the scan
//! runs each line itself, each from the cycle's start, so the whole project replays
//! deterministically and still models the lines as parallel.
//!
//! - [`build`](Plc::build): wiring a validated project (`build.rs`);
//! - the phases the scan calls and the safe state (`cycle.rs`);
//! - the control interface's actions: force, write, reload (`control.rs`), and why they are
//!   refused (`error.rs`);
//! - the flight recorder's tap: what every cycle saw and did (`record.rs`).
//!
//! Nothing here depends on the scan or the service: the scan ([`crate::scan`]) drives a `Plc`,
//! the service ([`crate::service`]) reads it and asks it for changes at cycle boundaries.

mod build;
mod control;
mod cycle;
mod error;
mod exchange;
mod forces;
mod record;
mod task_reload;
mod tasks;

pub use control::{Prepared, PreparedReload, ReloadJob};
pub use error::{ReloadError, TagError};
pub use exchange::{Exchange, TaskLink};
pub use forces::forces_path;
pub use record::RecordError;
pub use task_reload::ForeignWrite;
pub use tasks::{TaskBuilder, TaskPlan, TaskPlc};

use std::sync::Arc;
use std::time::Duration;

use softplc_io::time::ScanInstant;

use softplc_io::line::{Counters, LineError, LineLink, OutputFrame, StartupError, TxError};
use softplc_io::point::{Quality, Value};
use softplc_io::sim::SharedWorld;

use crate::clock::Clock;
use crate::image::{ProcessImage, TagId};
use crate::logic::{load, LogicEngine};
use crate::offload::{self, runtime::Offloaded, Plan, RequireFailure};
use crate::project::Project;

/// Why a PLC could not be built or started.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The program did not compile.
    #[error("{0}")]
    Program(#[from] load::ProgramError),
    /// Rungs with `offload: require` cannot be pushed down (one line each).
    #[error("{}", offload::runtime::lines(.0))]
    Offload(Vec<RequireFailure>),
    /// A port could not be opened.
    #[error("bus {bus}: {source}")]
    Port {
        /// The bus.
        bus: String,
        /// The failure.
        source: LineError,
    },
    /// A bus thread could not be started.
    #[error("bus {bus}: cannot start its thread: {source}")]
    Thread {
        /// The bus.
        bus: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A module in event mode (FC 70 Collect) on a Modbus TCP bus: Collect answers in time
    /// slots of an RS-485 line, which a TCP connection does not have.
    #[error(
        "bus {bus}: module {module} is in event mode (FC 70 Collect), which needs the RS-485 \
         line's reply slots; a Modbus TCP bus cannot carry it: poll it (no event settings), \
         or put it on an rtu+tcp:// bus"
    )]
    EventsOnModbusTcp {
        /// The bus.
        bus: String,
        /// The module.
        module: String,
    },
    /// A project of several tasks given where one task's PLC is built: each task is a PLC of
    /// its own, built from its view of the project (`Project::task_view`).
    #[error(
        "the project has {tasks} tasks; one PLC runs one task: build each task from its view \
         of the project"
    )]
    SeveralTasks {
        /// How many tasks the project has.
        tasks: usize,
    },
    /// A module refused its start-up configuration.
    #[error("bus {bus}: {source}")]
    Startup {
        /// The bus.
        bus: String,
        /// The failure.
        source: StartupError,
    },
}

/// A tag fed from a module point.
#[derive(Debug, Clone, Copy)]
struct InputBinding {
    tag: TagId,
    bus: usize,
    module: usize,
    point: usize,
}

/// A tag that drives a module output.
#[derive(Debug, Clone, Copy)]
struct OutputBinding {
    tag: TagId,
    bus: usize,
    module: usize,
    point: usize,
    safe: Value,
}

/// A module's state as the scan last saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModuleStatus {
    /// Project name of the module.
    pub name: String,
    /// Its bus.
    pub bus: String,
    /// Quality of the last read.
    pub quality: Quality,
    /// Whether the module holds what the program last asked of its outputs (bad while a
    /// write is refused or fails, while it restarts, and while it is lost).
    pub outputs: Quality,
    /// Its counters.
    pub counters: Counters,
    /// Last failure, if the last read failed.
    pub last_error: Option<TxError>,
    /// Whether its line has reported on it yet: before, its quality is bad because it was
    /// never read, not because it was lost (the alarms tell the two apart).
    pub reported: bool,
}

/// A PLC ready to scan.
#[derive(Debug)]
pub struct Plc {
    project: Project,
    clock: Arc<dyn Clock>,
    image: ProcessImage,
    logic: Box<dyn LogicEngine>,
    lines: Vec<LineLink>,
    /// Per bus: project module indexes, in the bus owner's order.
    bus_modules: Vec<Vec<usize>>,
    inputs: Vec<InputBinding>,
    outputs: Vec<OutputBinding>,
    frames: Vec<OutputFrame>,
    status: Vec<ModuleStatus>,
    world: Option<SharedWorld>,
    /// The longest time the scan waits for a line to write the safe state (stop, fault).
    line_wait: Duration,
    /// How long after a cycle's start the scan waits for the lines' inputs (see
    /// [`Plc::read_budget`]).
    read_budget: Duration,
    /// When the current cycle's input phase started.
    cycle_start: ScanInstant,
    /// The current cycle's deadline on the scan's grid ([`Plc::begin_cycle`]), when the scan
    /// gave one: its phases' deadlines count from it, not from when the scan woke.
    cycle_grid: Option<ScanInstant>,
    /// Time the last cycle spent waiting for lines (not counted by the task watchdog).
    io_wait: Duration,
    /// The last cycle's writes still running when the scan stopped waiting for them.
    unfinished: Unfinished,
    /// Cycles whose work ends with a line's answer still to come ([`CycleWork::Later`]).
    open_work: std::collections::VecDeque<Unfinished>,
    /// Per line: when its lateness was last logged.
    late_logged: Vec<Option<ScanInstant>>,
    /// Retained tags and their writer, when the project retains any.
    retain: Option<crate::retain::Retainer>,
    /// Where every rung runs (see [`crate::offload`]).
    plan: Plan,
    /// The outputs the modules drive.
    offload: Offloaded,
    /// Lines whose bus thread has ended (logged once).
    dead_lines: Vec<usize>,
    /// Where forces are kept across restarts, when asked.
    kept_forces: Option<forces::ForcesWriter>,
    /// The flight recorder's tap, when the run is recorded.
    recorder: Option<crate::recorder::Tap>,
    /// This PLC's task among several: the tags it copies in and publishes.
    task: Option<exchange::TaskLink>,
}

impl Plc {
    /// Where every rung runs: in a module or in the scan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The project.
    pub fn project(&self) -> &Project {
        &self.project
    }

    /// The clock.
    pub fn clock(&self) -> &Arc<dyn Clock> {
        &self.clock
    }

    /// The retained tags' store, when the project retains any.
    pub fn retainer(&self) -> Option<&crate::retain::Retainer> {
        self.retain.as_ref()
    }

    /// The process image.
    pub fn image(&self) -> &ProcessImage {
        &self.image
    }

    /// Per-module status, in project order.
    pub fn module_status(&self) -> &[ModuleStatus] {
        &self.status
    }

    /// Replaces `out` with the program's block outputs now (`ET`, `CV`, `Q`, ... by instance
    /// index; empty for expr and Rhai), for the web page's ladder view.
    pub fn instance_outputs(&self, out: &mut Vec<crate::logic::InstanceOutput>) {
        self.logic.instance_outputs(out);
    }

    /// Per program of the task, how many block instances [`Plc::instance_outputs`] numbers
    /// (a later program's after an earlier one's).
    pub fn instance_counts(&self) -> Vec<u32> {
        self.logic.instance_counts()
    }

    /// The simulated world, when the project has `port: sim` lines.
    pub fn world(&self) -> Option<&SharedWorld> {
        self.world.as_ref()
    }

    /// How long after a cycle's start the scan waits for its lines' inputs: nine tenths of the
    /// period, so a dead line leaves the logic a tenth of it. Writes are handed to the lines at
    /// once (behind a read still running) and waited for until the next cycle's deadline.
    pub fn read_budget(&self) -> Duration {
        self.read_budget
    }

    /// Time the last cycle spent waiting for its lines (input and output phases). The task
    /// watchdog measures the rest: what the scan itself does.
    pub fn io_wait(&self) -> Duration {
        self.io_wait
    }

    /// Starts a cycle whose deadline on the scan's grid is `grid`: the lines' deadlines in it
    /// (inputs by nine tenths of the period, writes by its end) count from there, so a scan
    /// that woke late does not also wait later.
    pub fn begin_cycle(&mut self, grid: ScanInstant) {
        self.cycle_grid = Some(grid);
    }

    /// Whether the last cycle's writes were all answered by its end, or when its work (the
    /// lines' included) ended past it: see [`CycleWork`].
    pub fn cycle_work(&self) -> CycleWork {
        self.unfinished.work()
    }

    /// The ends of the work of earlier cycles that ended [`CycleWork::Later`], oldest first,
    /// as far as they are known at `now`: each once every line still writing then has
    /// answered that write. One still open after the longest wait for a line's safe state
    /// (the watchdog's time × sensitivity), or when more than 16 are open, ends as "at least
    /// until `now`", and so does every one when `all` (the run ends). Never waits.
    pub fn late_work_ends(&mut self, now: ScanInstant, all: bool, out: &mut Vec<ScanInstant>) {
        while let Some(open) = self.open_work.front() {
            let mut end = open.known;
            let mut answered = true;
            for &(b, seq) in &open.later {
                match self.lines[b].late_write_end(seq) {
                    Some(t) => end = Some(end.map_or(t, |k| k.max(t))),
                    None => answered = false,
                }
            }
            let give_up =
                all || self.open_work.len() > MAX_OPEN_CYCLES || now - open.since > self.line_wait;
            if !answered && !give_up {
                break;
            }
            let end = if answered { end.unwrap_or(now) } else { now };
            out.push(end);
            self.open_work.pop_front();
        }
    }

    /// Total bus errors over all modules.
    pub fn bus_errors(&self) -> u64 {
        self.status.iter().map(|s| s.counters.errors()).sum()
    }
}

/// Where a cycle's work stood when the scan stopped waiting for its lines' writes (the end
/// of its period).
///
/// A cycle's time runs from its start to the end of all its work, its outputs acknowledged
/// by the lines included, on either clock: the scan stops waiting for a write at the period's
/// end (a dead line must not hold it), but the cycle did not fit its period, and counts as
/// an overrun, whether the scan woke at the deadline (virtual clock) or just after (real).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CycleWork {
    /// Every write was answered by the time the scan went on.
    Done,
    /// The last write ends at this time, known now (lines the scan runs itself).
    At(ScanInstant),
    /// A line's thread is still writing; [`Plc::late_work_ends`] gives its end later.
    Later,
}

/// How many cycles whose work is still running the PLC follows at once: a line that falls
/// further behind than this has its cycles' ends taken as "at least until now".
pub(crate) const MAX_OPEN_CYCLES: usize = 16;

/// The lines whose writes were unfinished at a cycle's end.
#[derive(Debug, Clone, Default)]
pub(crate) struct Unfinished {
    /// The latest known end (lines run inline).
    known: Option<ScanInstant>,
    /// Lines whose end comes with their answer: the line and the write's sequence number.
    later: Vec<(usize, u64)>,
    /// When the scan stopped waiting for them.
    since: ScanInstant,
}

impl Unfinished {
    pub(crate) fn work(&self) -> CycleWork {
        match (self.known, self.later.is_empty()) {
            (_, false) => CycleWork::Later,
            (Some(t), true) => CycleWork::At(t),
            (None, true) => CycleWork::Done,
        }
    }
}

impl Drop for Plc {
    fn drop(&mut self) {
        for line in &mut self.lines {
            line.stop(Duration::from_millis(100));
        }
    }
}
