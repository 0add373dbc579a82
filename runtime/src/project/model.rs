//! The validated project: what the runtime builds from. Every index in it is valid and every
//! reference resolved; nothing here can fail later because of the file.

use std::path::PathBuf;
use std::time::Duration;

use softplc_io::devices::{DeviceConfig, ModelSpec};
use softplc_io::line::LineSettings;
use softplc_io::point::{Value, ValueType};

/// A validated project.
#[derive(Debug, Clone)]
pub struct Project {
    /// The project's name.
    pub name: String,
    /// The project file it came from.
    pub source: PathBuf,
    /// The first task's timing (the one task's, for a project with `scan:`): what every
    /// part of the runtime that drives one task reads; see [`Project::tasks`].
    pub scan: ScanConfig,
    /// The cyclic tasks, in file order; one (`main`) for a project with `scan:` and
    /// `program:`. Every bus belongs to exactly one of them.
    pub tasks: Vec<TaskConfig>,
    /// RS-485 lines, in file order.
    pub buses: Vec<BusConfig>,
    /// Modules, in file order.
    pub modules: Vec<ModuleConfig>,
    /// Tags, in file order.
    pub tags: Vec<TagConfig>,
    /// The first task's programs (the one task's, for a project with `program:` or
    /// `programs:`), in the order they run within its cycle; never empty.
    pub programs: Vec<ProgramConfig>,
    /// The blocks of one's own the `blocks:` files define, in file order.
    pub blocks: Vec<super::UserBlock>,
    /// The instances of those blocks (`instances:`); their variables are memory tags at the
    /// end of [`Project::tags`].
    pub instances: Vec<super::BlockInstance>,
    /// The simulated plant, when the project has one.
    pub plant: Option<PlantConfig>,
    /// Metrics endpoint, Modbus TCP server and the SCADA map.
    pub service: super::service::ServiceConfig,
    /// Where retained tags are saved (used when a tag has `retain: true`).
    pub retain: super::retain::RetainConfig,
    /// Push-down of rungs into the modules.
    pub offload: super::offload::OffloadConfig,
    /// The flight recorder, when the project turns it on (see `super::recorder`).
    pub recorder: Option<super::recorder::RecorderConfig>,
    /// Trace definitions, in file order (see `super::trace`).
    pub traces: Vec<super::trace::TraceConfig>,
    /// How many traces may be armed at once and how much memory they take.
    pub trace_budget: super::trace_budget::TraceBudget,
    /// The tags' alarms, the operator's tags and the alarm history's bound.
    pub alarms: super::alarm::AlarmsConfig,
}

/// The name of the one task a project with `scan:` and `program:` has.
pub const MAIN_TASK: &str = "main";

/// One cyclic task: its timing, its program and the buses it does the I/O of.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskConfig {
    /// Its name (`main` for a project with `scan:`).
    pub name: String,
    /// Its period, watchdog and real-time options.
    pub scan: ScanConfig,
    /// Its programs, in the order they run within its cycle (each on the task's image, in
    /// its own language); never empty.
    pub programs: Vec<ProgramConfig>,
    /// Indexes into [`Project::buses`] of the buses it owns, in its `buses:` order.
    pub buses: Vec<usize>,
    /// In a task's view ([`Project::task_view`]): the tags bound to another task's I/O,
    /// which this task copies in (memory tags in the view). Empty in a project as read.
    pub copied_io: Vec<CopiedIo>,
}

/// A tag bound to a point of another task's bus, as a task's view sees it: a value the task
/// copies in at its cycle's start, never one of its own modules' points (what push-down says
/// of a rung reading it).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CopiedIo {
    /// The tag (an index into [`Project::tags`]).
    pub tag: usize,
    /// The task owning its bus.
    pub task: String,
    /// The bus.
    pub bus: String,
}

impl Project {
    /// The index into [`Project::tasks`] of the task owning bus `bus` (validation made every
    /// bus belong to one).
    pub fn task_of_bus(&self, bus: usize) -> usize {
        self.tasks
            .iter()
            .position(|t| t.buses.contains(&bus))
            .unwrap_or(0)
    }

    /// The period of the task owning bus `bus`: what the line's budget, its input wait and
    /// its modules' watchdogs count against.
    pub fn bus_period(&self, bus: usize) -> Duration {
        self.tasks
            .get(self.task_of_bus(bus))
            .map_or(self.scan.period, |t| t.scan.period)
    }

    /// Whether the project runs several tasks (`tasks:` with more than one entry).
    pub fn multitask(&self) -> bool {
        self.tasks.len() > 1
    }
}

/// A task's timing: its period, its watchdog and its thread's real-time options.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanConfig {
    /// Cycle period (non-zero).
    pub period: Duration,
    /// Task watchdog.
    pub watchdog: WatchdogConfig,
    /// Best-effort real-time options.
    pub realtime: RealtimeConfig,
}

/// Task watchdog, as CODESYS defines it: a cycle longer than `time` is an overrun; the watchdog
/// fires after `sensitivity` consecutive overruns, or at once when one cycle takes longer than
/// `time × sensitivity`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WatchdogConfig {
    /// Longest acceptable cycle.
    pub time: Duration,
    /// Consecutive overruns tolerated (≥ 1).
    pub sensitivity: u32,
}

/// Real-time options; each is best effort and logged when the OS refuses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RealtimeConfig {
    /// SCHED_FIFO priority 1..=99 for the scan thread.
    pub priority: Option<u8>,
    /// CPU to pin the scan thread to.
    pub cpu: Option<usize>,
    /// `mlockall(MCL_CURRENT | MCL_FUTURE)`.
    pub lock_memory: bool,
}

/// Where a line's bytes go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortConfig {
    /// The simulated line, with a simulator for each module on it.
    Sim,
    /// A serial device path (`/dev/ttyUSB0`, or one end of a pty).
    Serial(PathBuf),
    /// A network endpoint: Modbus TCP (`tcp://HOST:PORT`) or RTU over TCP
    /// (`rtu+tcp://HOST:PORT`).
    Tcp(softplc_io::line::TcpEndpoint),
}

impl PortConfig {
    /// Whether the bus carries Modbus TCP (no serial line, no RTU framing).
    pub fn is_modbus_tcp(&self) -> bool {
        matches!(self, PortConfig::Tcp(e) if e.framing == softplc_io::line::NetFraming::ModbusTcp)
    }

    /// The URL scheme of a network bus.
    pub fn scheme(&self) -> Option<&'static str> {
        match self {
            PortConfig::Tcp(e) => Some(e.framing.scheme()),
            _ => None,
        }
    }
}

/// One RS-485 line.
#[derive(Debug, Clone, PartialEq)]
pub struct BusConfig {
    /// The line's name.
    pub name: String,
    /// Its port.
    pub port: PortConfig,
    /// Baud and format.
    pub settings: LineSettings,
    /// How long to wait for the first byte of a reply.
    pub response_timeout: Duration,
    /// Attempts after a failed one, per transaction (0 = no retry).
    pub retries: u8,
    /// Period of the full output refresh (outputs are otherwise written on change).
    pub output_refresh: Duration,
    /// Kernel RS-485 mode to set when the port is opened (`rs485:`).
    pub rs485: Option<softplc_io::line::Rs485Mode>,
    /// Whether the adapter's echo of every request is read back and verified (`echo:`).
    pub echo: softplc_io::line::EchoMode,
    /// The USB adapter's latency timer (`adapter_latency:`).
    pub adapter_latency: softplc_io::line::AdapterLatency,
    /// Who turns the transceiver round (`direction:`).
    pub direction: super::line_plan::Direction,
    /// `tune: reply_delay`.
    pub tune_reply_delay: bool,
    /// What softplc planned for the line and why (filled in at the end of validation).
    pub plan: super::line_plan::LinePlan,
}

/// One module.
#[derive(Debug, Clone)]
pub struct ModuleConfig {
    /// The module's name (`mm1`).
    pub name: String,
    /// What it is and where it sits, in the engineer's words (`description:`).
    pub description: Option<super::DocText>,
    /// Index into [`Project::buses`].
    pub bus: usize,
    /// Its model.
    pub model: &'static ModelSpec,
    /// What its driver is built from.
    pub device: DeviceConfig,
    /// Its own watchdog: the entry's `watchdog:`, what it is armed with and the settings that
    /// arm it, added to `device`'s by [`ModuleConfig::device_with_watchdog`] (see
    /// `super::watchdog`).
    pub watchdog: super::watchdog::ModuleWatchdog,
}

/// One tag.
#[derive(Debug, Clone, PartialEq)]
pub struct TagConfig {
    /// The tag's name, as programs use it.
    pub name: String,
    /// What it is, in the engineer's words (`description:`).
    pub description: Option<super::DocText>,
    /// Its type.
    pub ty: ValueType,
    /// What it is bound to.
    pub binding: Binding,
    /// The value written when the PLC goes to its safe state (outputs only; `None`: leave).
    pub safe: Option<Value>,
    /// Initial value of a memory tag (zero of its type unless given).
    pub initial: Value,
    /// Kept across a restart and a program reload (memory tags only; see `retain.rs`).
    pub retain: bool,
}

/// What a tag is bound to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Binding {
    /// A module point: indexes into [`Project::modules`] and the model's points.
    Point {
        /// The module.
        module: usize,
        /// The point.
        point: usize,
    },
    /// A memory variable.
    Memory,
}

/// The control program.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramConfig {
    /// The program file, resolved against the project file's folder.
    pub path: PathBuf,
    /// Its language.
    pub kind: ProgramKind,
}

/// Program languages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgramKind {
    /// Boolean coil assignments, one per line: `motor = (start | motor) & !stop`.
    Expr,
    /// Ladder rungs in YAML: `(start | motor) /stop -> motor` (see `logic::ladder`).
    Ladder,
    /// A Rhai script run once per scan (see `logic::rhai`).
    Rhai,
}

/// The simulated plant that closes the loop from outputs to inputs on `port: sim` lines.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlantConfig {
    /// The plant model, compiled (a built-in or the project's file).
    pub model: crate::plant::PlantModel,
    /// Terminal → `(module index, point name)`, in the model's terminal order.
    pub wiring: Vec<(String, usize, String)>,
    /// The seed of its random source.
    pub seed: u64,
}
