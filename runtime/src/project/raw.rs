//! The project file as written: serde structs that mirror the YAML, before validation.
//!
//! # Schema
//!
//! ```yaml
//! project: quickstart          # free text, not empty
//! scan:
//!   period: 20ms               # cycle period, > 0
//!   watchdog: { time: 100ms, sensitivity: 3 }   # optional; default time 5 × period, sensitivity 3
//!   realtime: { priority: 50, cpu: 1, lock_memory: true }   # optional, best effort
//! buses:
//!   - name: line1
//!     port: sim                # `sim`, a device path: /dev/ttyUSB0, /dev/pts/3, or a
//!                              # network endpoint: tcp://HOST:PORT (Modbus TCP; no baud,
//!                              # format, rs485, echo or adapter_latency) or
//!                              # rtu+tcp://HOST:PORT (RTU through a serial server whose
//!                              # line is baud/format; no rs485, echo or adapter_latency).
//!                              # One bus per endpoint: its modules share one connection.
//!     baud: 19200              # default 19200
//!     format: 8E1              # data bits 7|8, parity N|E|O, stop bits 1|2; default 8E1
//!     rs485: { rts_on_send: true, delay_before_send: 0ms, delay_after_send: 0ms }
//!                              # optional, device ports only: kernel RS-485 mode (TIOCSRS485)
//!                              # for a UART whose RTS drives the transceiver (Pi HATs); set at
//!                              # open and read back, a port that refuses it stops the start.
//!                              # rts_on_send: RTS high while sending (false: inverted);
//!                              # delays in whole ms, 0..=100ms. USB adapters need none.
//!     echo: discard            # none | discard; default none. discard: the adapter hears its
//!                              # own transmission; each request is read back and verified
//!                              # before the reply is awaited (a bad echo is a line error).
//!     adapter_latency: auto    # auto | a duration, whole ms 0ms..=255ms; default auto.
//!                              # auto: a USB adapter's latency timer is read from sysfs (and
//!                              # lowered to 1 ms) when the port opens, 0 without one; a
//!                              # duration: what `check` counts, and the most the port may
//!                              # keep (the start fails if it stays higher).
//!     direction: host          # host | auto; default host. Who turns the transceiver round
//!                              # after a request: host (RTS from the driver, or unknown) or
//!                              # auto: an adapter that switches by itself within a
//!                              # character (with `rs485:` the kernel does it: also fast).
//!     tune: reply_delay        # optional, opt-in: at every start-up of its MiniMods, their
//!                              # reply delay is set to the least the line's direction
//!                              # control allows (RDELAYT=0: `port: sim`, `rs485:` with
//!                              # delay_after_send within a character, or direction: auto;
//!                              # refused otherwise), never saved (no WCONF); a module's own
//!                              # RDELAYT wins. See `line_plan/tune.rs`.
//!     response_timeout: 50ms   # default 100ms
//!     retries: 1               # attempts after a failed one, 0..=255; default 1
//!     output_refresh: 1s       # period of the full output rewrite; default 1s
//! modules:
//!   - name: mm1
//!     bus: line1
//!     model: minimod           # a model of the catalog (`softplc_io::devices::catalog`)
//!     address: 1               # unit address, within the model's range
//!     protocol: modbus         # modbus | text; default: the model's first protocol
//!     settings: { RDELAYT: 5 } # optional, model-specific, checked by the model
//!     watchdog: off            # optional; auto (default) | off: the module's own watchdog
//!                              # (see `watchdog.rs`)
//!     description: Cabinet 1, left rail   # optional, one line, at most 256 characters
//! tags:
//!   - { name: start, point: mm1.X2 }           # bound to a point; its type is the point's
//!   - { name: stop, point: mm1.X3, description: Stop button, red }   # optional words, one
//!                                              # line, at most 256 characters (`doc_text.rs`)
//!   - { name: motor, point: mm1.Y1, safe: false }   # `safe`: written in the safe state
//!   - { name: count, type: u16, initial: 0 }   # a memory variable
//!   - { name: hours, type: i32, retain: true } # kept across restarts (memory tags only)
//!   - { name: lamp, point: mm2.Y1, offload: require }   # push-down of its rung: never|auto|require
//!   - { name: button, point: mm1.X1, debounce: 20ms }   # MiniMod input conditioning (also stretch)
//!   - { name: speed, type: u16, scada: write } # SCADA access: read (default) | write | none,
//!                                              # or { access: write, address: 12 } (pinned)
//!   - { name: jam, point: mm1.X4, alarm: { text: Door jammed, priority: high } }
//!                                              # an alarm: text, priority low|medium|high|
//!                                              # urgent or 1..=1000, when (see `alarm.rs`)
//!   - { name: setpoint, type: u16, operator: true }   # on the operator's page
//! program:
//!   file: conveyor.expr        # relative to the project file's folder; must exist
//!   kind: expr                 # the program language: expr | ladder | rhai
//! # Or several programs, run in this order within each cycle on one image (not beside
//! # `program:`):
//! # programs:
//! #   - { file: conveyor.ladder.yaml, kind: ladder }
//! #   - { file: counters.rhai, kind: rhai }
//! # Or, instead of `scan:` and `program:` (one task, named `main`), several cyclic tasks,
//! # each on a thread of its own (docs/programming.md, "Tasks"):
//! tasks:
//!   - name: press              # an identifier, unique among the tasks
//!     period: 30ms             # as scan.period; watchdog and realtime as in `scan:`
//!     watchdog: { time: 60ms, sensitivity: 3 }
//!     realtime: { priority: 60 }   # the task thread's SCHED_FIFO priority, best effort
//!     program: { file: press.ladder.yaml, kind: ladder }   # as `program:`, or
//!     # programs: [ { file: ..., kind: ... }, ... ]        # as `programs:`
//!     buses: [press_line]      # the buses whose I/O this task does; each bus in one task
//! retain: { file: p.retain.json, period: 10s }   # optional; see `retain.rs`
//! plant:                       # optional; only on `port: sim` buses
//!   model: conveyor
//!   wiring: { motor: mm1.Y1, sensor_entry: mm1.X1, sensor_exit: mm1.X2 }
//! offload: auto                # optional; never (default) | auto | require; see `offload.rs`
//! recorder: { keep: 10m, size: 256MiB, folder: records }   # optional; see `recorder.rs`
//! trace_budget: { armed: 16, memory: 64MiB }   # optional; see `trace_budget.rs`
//! alarms: { history: 1000 }    # optional; events the alarm history keeps (see `alarm.rs`)
//! service:                     # optional; see `service.rs` (schema) and `scada.rs` (the map)
//!   metrics: 127.0.0.1:9464    # Prometheus text endpoint; off when absent
//!   modbus_tcp: { bind: 127.0.0.1:5020, unit: 1, writes: false, allow_remote_writes: false,
//!                 idle_timeout: 60s, send_timeout: 10s }   # disconnect silent / non-reading clients
//!   web: { bind: 127.0.0.1:8080, writes: false, token_file: web.token, trend: [motor] }
//! ```
//!
//! Rules the validation enforces (see [`super::parse_str`]):
//! - Lists and mappings nest at most 64 deep (checked before the YAML reader, whose time grows
//!   with the square of the nesting; see `nesting.rs`).
//! - Bus, module and tag names are identifiers (`[A-Za-z_][A-Za-z0-9_]*`), unique among their
//!   kind. Unknown keys are errors everywhere except in a module's `settings`.
//! - **Durations** are strings with a unit: a decimal number (`20`, `1.5`, `.5`) followed by
//!   `ns`, `us` (or `µs`), `ms`, `s`, `m` (minutes) or `h`, optionally separated by one space
//!   (`20ms`, `1.5s`, `250us`, `2m`, `10 ms`). A bare number (`period: 20`) is refused: whether
//!   it means milliseconds or seconds is a guess a PLC should not make. Durations must be a
//!   whole number of nanoseconds.
//! - A tag has `point` (`module.POINT`, the manual's spelling) or `type` (`bool`, `u16`, `i32`,
//!   `f32`), not neither; a point-bound tag may repeat `type` only if it is the point's.
//!   `safe` is allowed only on tags bound to an output point, `initial` only on memory tags;
//!   both must be values of the tag's type (`true`/`false`/`1`/`0` for bools; integers may be
//!   written in hex, `0x1F`). An output point may be bound to one tag only.
//! - A bus's baud rate may not exceed the `max_baud` of a model on it (reported at the
//!   module's `bus`). Unit addresses are unique per bus.
//! - **Module watchdogs** are armed by default where the model has one that makes outputs
//!   safe (MiniMod: WDTTIME derived from the scan period and the line, WDTYMASK from the tags'
//!   safe values; see `watchdog.rs` for the formula and the other models). `watchdog: off` on
//!   a module entry turns it off (MiniMod: WDTTIME = 0 written at start-up), and `check` warns;
//!   an explicit `WDTTIME` / `WDTYMASK` in the settings wins; `watchdog: off` together with a
//!   `WDTTIME` other than 0 is refused.
//! - Program kinds: `expr`, `ladder`, `rhai`. The program file must exist. A task (and the
//!   top level) has `program:` or `programs:` (a list of at least one), not both; two
//!   programs of one task writing one tag are allowed (the later one's value stands at the
//!   cycle's end) and `check` warns, naming both places.
//! - A project has `scan:` and `program:` (one task, `main`, owning every bus) or `tasks:`
//!   (not both, not an empty list). Task names are identifiers, unique; with `tasks:` every
//!   bus is named by exactly one task's `buses:` (a second naming and a bus named by none
//!   are refused). Which task writes each tag is checked once the programs are compiled
//!   (`logic/ownership.rs`).
//! - `retain: true` only on memory tags; `retain.period` > 0, `retain.file` not empty.
//! - A plant must wire every one of its roles, each to a point of the right direction (a role
//!   the plant drives → a module input; a role it reads → a module output), on `port: sim`
//!   buses only; an input is driven by one role at most.
//! - `service`: addresses are `IP:PORT`; Modbus unit 1..=247; writes on a non-loopback bind
//!   need `allow_remote_writes: true`; the Modbus `idle_timeout` and `send_timeout` are
//!   durations above zero. The web page's writes need a token (see `web.rs`).
//!   `scada: write` only on memory tags and outputs; pinned
//!   addresses must not overlap within their space (bits: bool tags; registers: u16 = 1,
//!   i32/f32 = 2).

use std::fmt;
use std::time::Duration;

use schemars::JsonSchema;
use serde::de::{self, Deserializer, MapAccess, Unexpected, Visitor};
use serde::Deserialize;

/// A softplc project file: the scan, the RS-485 lines and their modules, the tags, the
/// program, and optionally a simulated plant, services, retain, push-down, recorder, traces.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a project: a mapping with project, scan, tasks, buses, modules, tags, program (or programs) and plant"
)]
pub(crate) struct RawProject {
    /// The project's name.
    pub project: String,
    /// The scan task, when the project has one task (`main`); refused beside `tasks:`.
    #[serde(default)]
    #[schemars(with = "RawScan")]
    pub scan: Option<RawScan>,
    /// Several cyclic tasks, each with its own period, program and buses; refused beside
    /// `scan:` and `program:`.
    #[serde(default)]
    #[schemars(with = "Vec<RawTask>")]
    pub tasks: Option<Vec<RawTask>>,
    /// RS-485 lines.
    #[serde(default)]
    pub buses: Vec<RawBus>,
    /// I/O modules.
    #[serde(default)]
    pub modules: Vec<RawModule>,
    /// Tags.
    #[serde(default)]
    pub tags: Vec<RawTag>,
    /// The control program of the one task `scan:` describes; refused beside `tasks:` and
    /// beside `programs:`.
    #[serde(default)]
    #[schemars(with = "RawProgram")]
    pub program: Option<RawProgram>,
    /// The control programs of the one task `scan:` describes, run in this order within
    /// each cycle on one process image; refused beside `tasks:` and beside `program:`.
    #[serde(default)]
    #[schemars(with = "Vec<RawProgram>")]
    pub programs: Option<Vec<RawProgram>>,
    /// Files of blocks of one's own the program may call (see `user_blocks`), relative to
    /// the project file's folder; several projects may include one file.
    #[serde(default)]
    pub blocks: Vec<String>,
    /// Instances of those blocks: each instance's inputs, outputs and state are the memory
    /// tags `NAME.VARIABLE`.
    #[serde(default)]
    pub instances: Vec<super::user_blocks::raw::RawInstance>,
    /// The simulated plant.
    #[serde(default)]
    pub plant: Option<RawPlant>,
    /// Metrics and SCADA access (see [`super::service`]).
    #[serde(default)]
    pub service: Option<super::service::RawService>,
    /// Where and how often retained tags are saved (see [`super::retain`]).
    #[serde(default)]
    pub retain: Option<super::retain::RawRetain>,
    /// Push-down of rungs into the modules (see [`super::offload`]).
    #[serde(default)]
    pub offload: Option<super::offload::RawOffload>,
    /// The flight recorder (see [`super::recorder`]).
    #[serde(default)]
    pub recorder: Option<super::recorder::RawRecorder>,
    /// Traces that can be armed at run time (see [`super::trace`]).
    #[serde(default)]
    pub traces: Vec<super::trace::RawTrace>,
    /// How many traces may be armed and how much memory they take (see
    /// [`super::trace_budget`]).
    #[serde(default)]
    pub trace_budget: Option<super::trace_budget::RawTraceBudget>,
    /// Alarm settings: how many events the alarm history file keeps (see
    /// [`super::alarm`] and docs/alarms.md).
    #[serde(default)]
    pub alarms: Option<super::alarm::RawAlarms>,
}

/// `scan:`.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "scan settings: a mapping with period, watchdog and realtime"
)]
pub(crate) struct RawScan {
    /// Cycle period, above zero: `20ms`.
    pub period: DurationText,
    /// Task watchdog.
    #[serde(default)]
    pub watchdog: Option<RawWatchdog>,
    /// Real-time options.
    #[serde(default)]
    pub realtime: Option<RawRealtime>,
}

/// One `tasks:` entry: a cyclic task with its own period, watchdog, real-time priority,
/// program and the buses whose I/O it does.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a task: a mapping with name, period, watchdog, realtime, program (or programs) and buses"
)]
pub(crate) struct RawTask {
    /// The task's name (an identifier, unique among the tasks).
    pub name: String,
    /// Cycle period, above zero: `20ms`.
    pub period: DurationText,
    /// The task's watchdog (default time 5 × period, sensitivity 3).
    #[serde(default)]
    pub watchdog: Option<RawWatchdog>,
    /// The task thread's real-time options, as `scan.realtime` (its SCHED_FIFO priority,
    /// its CPU); best effort.
    #[serde(default)]
    pub realtime: Option<RawRealtime>,
    /// The task's program, as the top-level `program:`; refused beside `programs:`.
    #[serde(default)]
    #[schemars(with = "RawProgram")]
    pub program: Option<RawProgram>,
    /// The task's programs, run in this order within each of its cycles on its image (a
    /// ladder program and a Rhai one may share a task); refused beside `program:`.
    #[serde(default)]
    #[schemars(with = "Vec<RawProgram>")]
    pub programs: Option<Vec<RawProgram>>,
    /// The buses whose modules this task reads and writes; each bus belongs to one task.
    #[serde(default)]
    pub buses: Vec<String>,
}

impl RawTask {
    /// The task's timing as a `scan:` section says it.
    pub(crate) fn scan(&self) -> RawScan {
        RawScan {
            period: self.period,
            watchdog: self.watchdog.clone(),
            realtime: self.realtime.clone(),
        }
    }
}

/// `scan.watchdog:`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "watchdog settings: a mapping with time and sensitivity"
)]
pub(crate) struct RawWatchdog {
    /// Longest acceptable cycle (default 5 × period).
    #[serde(default)]
    pub time: Option<DurationText>,
    /// Consecutive overruns tolerated (default 3).
    #[serde(default)]
    pub sensitivity: Option<Int>,
}

/// `scan.realtime:`.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "real-time settings: a mapping with priority, cpu and lock_memory"
)]
pub(crate) struct RawRealtime {
    /// SCHED_FIFO priority 1..=99.
    #[serde(default)]
    pub priority: Option<Int>,
    /// CPU to pin the scan thread to.
    #[serde(default)]
    pub cpu: Option<Int>,
    /// Lock the process's memory.
    #[serde(default)]
    pub lock_memory: Option<bool>,
}

/// One `buses:` entry.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a bus: a mapping with name, port, baud, format, response_timeout, retries, output_refresh, rs485, echo, adapter_latency, direction, tune"
)]
pub(crate) struct RawBus {
    /// The line's name.
    pub name: String,
    /// `sim` (simulated modules, no hardware), a serial device path (`/dev/ttyUSB0`), a Modbus
    /// TCP endpoint (`tcp://HOST:PORT`: a TCP device or a TCP-to-RTU gateway, each module's
    /// address its unit id) or a serial server passing RTU frames through
    /// (`rtu+tcp://HOST:PORT`, its line at `baud`/`format`).
    pub port: String,
    /// Baud rate (default 19200); at most the `max_baud` of every model on the bus.
    #[serde(default)]
    pub baud: Option<Int>,
    /// Character format: data bits 7|8, parity N|E|O, stop bits 1|2 (default `8E1`).
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::serial_format")]
    pub format: Option<String>,
    /// Response timeout (default 100 ms).
    #[serde(default)]
    pub response_timeout: Option<DurationText>,
    /// Attempts after a failed one, 0..=255 (default 1).
    #[serde(default)]
    pub retries: Option<Int>,
    /// Full output refresh period (default 1 s).
    #[serde(default)]
    pub output_refresh: Option<DurationText>,
    /// Kernel RS-485 mode (`TIOCSRS485`) for a UART whose RTS drives the transceiver.
    #[serde(default)]
    pub rs485: Option<RawRs485>,
    /// `none` or `discard`: whether the adapter's echo of every request is read back.
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::echo")]
    pub echo: Option<String>,
    /// `auto` or a duration: the USB adapter's latency timer.
    #[serde(default)]
    pub adapter_latency: Option<RawAdapterLatency>,
    /// `host` (default) or `auto`: who turns the transceiver round after a request; `auto`
    /// declares an adapter that does it by itself, within a character.
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::direction")]
    pub direction: Option<String>,
    /// `reply_delay`: opt-in tuning of the line's modules at start-up (not saved in them).
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::tune")]
    pub tune: Option<String>,
}

/// A bus's `adapter_latency:`: `auto`, or a duration (whole ms, checked by the validator).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RawAdapterLatency {
    /// `auto`.
    Auto,
    /// A duration.
    Given(Duration),
}

impl<'de> Deserialize<'de> for RawAdapterLatency {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = RawAdapterLatency;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "auto, or {DURATION_EXPECTED}")
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawAdapterLatency, E> {
                if v == "auto" {
                    return Ok(RawAdapterLatency::Auto);
                }
                parse_duration(v).map(RawAdapterLatency::Given).map_err(|why| {
                    E::custom(format_args!(
                        "invalid value: adapter_latency \"{v}\": {why}; expected auto, or {DURATION_EXPECTED}"
                    ))
                })
            }
        }
        d.deserialize_str(V)
    }
}

/// A bus's `rs485:` mapping.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "rs485: a mapping with rts_on_send, delay_before_send, delay_after_send"
)]
pub(crate) struct RawRs485 {
    /// RTS high while sending (default true); `false` inverts it.
    #[serde(default)]
    pub rts_on_send: Option<bool>,
    /// RTS raised before the first character (default 0ms, whole ms, at most 100ms).
    #[serde(default)]
    pub delay_before_send: Option<DurationText>,
    /// RTS held after the last character (default 0ms, whole ms, at most 100ms).
    #[serde(default)]
    pub delay_after_send: Option<DurationText>,
}

/// One `modules:` entry.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a module: a mapping with name, bus, model, address, protocol, settings, watchdog and description"
)]
#[schemars(extend("allOf" = super::raw_schema::field::settings_hints()))]
pub(crate) struct RawModule {
    /// The module's name.
    pub name: String,
    /// The bus it is on.
    pub bus: String,
    /// Its model.
    #[schemars(schema_with = "super::raw_schema::field::module_model")]
    pub model: String,
    /// Its unit address, within the model's range (`softplc models`), unique on the bus.
    pub address: Int,
    /// `modbus` or `text` (default: the model's first protocol).
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::protocol")]
    pub protocol: Option<String>,
    /// Model-specific settings, checked by the model: `{ RDELAYT: 5 }`.
    #[serde(default)]
    pub settings: Option<Settings>,
    /// The module's own watchdog: `auto` (default) or `off` (see [`super::watchdog`]).
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::module_watchdog")]
    pub watchdog: Option<ScalarText>,
    /// What the module is and where it sits, in words (one line, at most 256 characters):
    /// shown in `check`'s I/O map, on the web page and as its OPC UA folder's Description.
    #[serde(default)]
    #[schemars(length(max = 256))]
    pub description: Option<String>,
}

/// One `tags:` entry.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a tag: a mapping with name and point or type, safe, initial, description"
)]
#[schemars(extend("anyOf" = [{ "required": ["point"] }, { "required": ["type"] }]))]
pub(crate) struct RawTag {
    /// The tag's name.
    pub name: String,
    /// The point it is bound to, `module.POINT` in the manual's spelling (`softplc points
    /// MODEL`); the tag takes the point's type.
    #[serde(default)]
    pub point: Option<String>,
    /// The type of a memory tag: bool, u16, i32 or f32.
    #[serde(default, rename = "type")]
    #[schemars(schema_with = "super::raw_schema::field::tag_type")]
    pub ty: Option<String>,
    /// Value written in the safe state (tags bound to outputs).
    #[serde(default)]
    pub safe: Option<ScalarText>,
    /// Initial value (memory tags); integers may be written in hex, `0x1F`.
    #[serde(default)]
    pub initial: Option<ScalarText>,
    /// SCADA access and address (see [`super::service`]).
    #[serde(default)]
    pub scada: Option<super::service::RawScada>,
    /// Keep the value across a restart (memory tags; see [`super::retain`]).
    #[serde(default)]
    pub retain: Option<bool>,
    /// Push-down of the rung writing this output (see [`super::offload`]).
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::tag_offload")]
    pub offload: Option<ScalarText>,
    /// MiniMod input debounce in the module (see [`super::offload`]).
    #[serde(default)]
    pub debounce: Option<DurationText>,
    /// MiniMod input pulse stretching in the module (see [`super::offload`]).
    #[serde(default)]
    pub stretch: Option<DurationText>,
    /// What the tag is, in words (one line, at most 256 characters): shown in `check`'s I/O
    /// map, on the web page, as the OPC UA node's Description and the Sparkplug metric's
    /// `description` property.
    #[serde(default)]
    #[schemars(length(max = 256))]
    pub description: Option<String>,
    /// Where a BLINK writing this output may start its period: `enable` (on when enabled,
    /// the default) or `free` (anywhere: it may then be pushed down as a MiniMod blinker;
    /// see [`super::offload`]).
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::blink_phase")]
    pub blink_phase: Option<ScalarText>,
    /// Makes the tag an alarm: `{ text, priority, when }`, raised while `when` holds (see
    /// [`super::alarm`] and docs/alarms.md).
    #[serde(default)]
    pub alarm: Option<super::alarm::RawAlarm>,
    /// Shown on the operator's page (`/operator`), with a write-once control where the tag
    /// is writable (default false).
    #[serde(default)]
    pub operator: Option<bool>,
}

/// `program:`.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a program: a mapping with file and kind"
)]
pub(crate) struct RawProgram {
    /// The program file, relative to the project file's folder; must exist.
    pub file: String,
    /// Its language: expr, ladder or rhai.
    #[schemars(schema_with = "super::raw_schema::field::program_kind")]
    pub kind: String,
}

/// `plant:`.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a plant: a mapping with model or file, wiring and optionally seed"
)]
pub(crate) struct RawPlant {
    /// A built-in plant model (or give `file`).
    #[serde(default)]
    #[schemars(schema_with = "super::raw_schema::field::plant_model")]
    pub model: Option<String>,
    /// A plant model file written in Rhai (`door.plant.rhai`), relative to the project file's
    /// folder (docs/plant.md).
    #[serde(default)]
    pub file: Option<String>,
    /// Terminal → `module.POINT`: every terminal the model reads (module outputs) and drives
    /// (module inputs).
    #[serde(default)]
    pub wiring: Settings,
    /// The seed of the model's random source: the same seed, the same trace (default 0).
    #[serde(default)]
    pub seed: Option<u64>,
}

/// A duration written with a unit (`20ms`, `1.5s`); see the module docs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct DurationText(pub Duration);

/// The duration syntax the module docs describe.
const DURATION_EXPECTED: &str =
    "a duration with a unit, like 20ms, 1.5s, 250us or 2m (a bare number is ambiguous)";

impl<'de> Deserialize<'de> for DurationText {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = DurationText;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(DURATION_EXPECTED)
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<DurationText, E> {
                parse_duration(v).map(DurationText).map_err(|why| {
                    E::custom(format_args!(
                        "invalid value: duration \"{v}\": {why}; expected {DURATION_EXPECTED}"
                    ))
                })
            }
        }
        d.deserialize_str(V)
    }
}

/// Why a duration text was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DurationError {
    /// No number before the unit.
    #[error("no number")]
    NoNumber,
    /// No unit after the number.
    #[error("no unit (ns, us, ms, s, m or h)")]
    NoUnit,
    /// A unit that is not known.
    #[error("unknown unit \"{0}\" (ns, us, ms, s, m or h)")]
    UnknownUnit(String),
    /// Not a whole number of nanoseconds.
    #[error("finer than a nanosecond")]
    TooFine,
    /// Longer than a `Duration` holds.
    #[error("too long")]
    TooLong,
}

/// Parses a duration with a unit: `20ms`, `1.5s`, `250us`, `2m`, `10 ms` (see the module
/// docs). Exact: no floating point is involved.
pub fn parse_duration(text: &str) -> Result<Duration, DurationError> {
    let t = text.trim();
    let num_end = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(num_end);
    let unit = unit.strip_prefix(' ').unwrap_or(unit);
    let (int_part, frac_part) = match num.split_once('.') {
        Some((i, f)) => (i, f),
        None => (num, ""),
    };
    if int_part.is_empty() && frac_part.is_empty() {
        return Err(DurationError::NoNumber);
    }
    if frac_part.contains('.') {
        return Err(DurationError::NoNumber);
    }
    let scale: u128 = match unit {
        "" => return Err(DurationError::NoUnit),
        "ns" => 1,
        "us" | "µs" => 1_000,
        "ms" => 1_000_000,
        "s" => 1_000_000_000,
        "m" => 60_000_000_000,
        "h" => 3_600_000_000_000,
        other => return Err(DurationError::UnknownUnit(other.to_owned())),
    };
    // value = (int_part.frac_part) × scale, computed as digits / 10^len(frac) × scale.
    let digits = format!("{int_part}{frac_part}");
    if digits.len() > 30 {
        return Err(DurationError::TooLong);
    }
    let mantissa: u128 = digits.parse().map_err(|_| DurationError::NoNumber)?;
    let exp = u32::try_from(frac_part.len()).map_err(|_| DurationError::TooFine)?;
    let divisor = 10u128.checked_pow(exp).ok_or(DurationError::TooFine)?;
    let scaled = mantissa.checked_mul(scale).ok_or(DurationError::TooLong)?;
    if scaled % divisor != 0 {
        return Err(DurationError::TooFine);
    }
    let nanos = u64::try_from(scaled / divisor).map_err(|_| DurationError::TooLong)?;
    Ok(Duration::from_nanos(nanos))
}

/// A whole number; range checks are the validation's, so they can name the key's meaning.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Int(pub i64);

impl<'de> Deserialize<'de> for Int {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Int;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a whole number")
            }

            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Int, E> {
                Ok(Int(v))
            }

            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Int, E> {
                i64::try_from(v)
                    .map(Int)
                    .map_err(|_| E::invalid_value(Unexpected::Unsigned(v), &"a smaller number"))
            }
        }
        d.deserialize_i64(V)
    }
}

/// Any scalar (string, number, bool), as its text; for values typed later (`safe`, settings).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ScalarText(pub String);

impl<'de> Deserialize<'de> for ScalarText {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = ScalarText;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a single value (a number, true/false or text)")
            }

            fn visit_bool<E: de::Error>(self, v: bool) -> Result<ScalarText, E> {
                Ok(ScalarText(v.to_string()))
            }

            fn visit_i64<E: de::Error>(self, v: i64) -> Result<ScalarText, E> {
                Ok(ScalarText(v.to_string()))
            }

            fn visit_u64<E: de::Error>(self, v: u64) -> Result<ScalarText, E> {
                Ok(ScalarText(v.to_string()))
            }

            fn visit_f64<E: de::Error>(self, v: f64) -> Result<ScalarText, E> {
                Ok(ScalarText(v.to_string()))
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<ScalarText, E> {
                Ok(ScalarText(v.to_owned()))
            }
        }
        d.deserialize_any(V)
    }
}

/// A mapping of text keys to scalar values, in file order; a key given twice is an error.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Settings(pub Vec<(String, String)>);

impl<'de> Deserialize<'de> for Settings {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Settings;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a mapping of key: value")
            }

            fn visit_unit<E: de::Error>(self) -> Result<Settings, E> {
                Ok(Settings::default())
            }

            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Settings, A::Error> {
                let mut out: Vec<(String, String)> = Vec::new();
                while let Some(key) = map.next_key::<ScalarText>()? {
                    if out.iter().any(|(k, _)| *k == key.0) {
                        return Err(de::Error::custom(format_args!(
                            "duplicate field `{}`",
                            key.0
                        )));
                    }
                    let value = map.next_value::<ScalarText>()?;
                    out.push((key.0, value.0));
                }
                Ok(Settings(out))
            }
        }
        d.deserialize_map(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_with_units() {
        let ms = Duration::from_millis;
        assert_eq!(parse_duration("20ms"), Ok(ms(20)));
        assert_eq!(parse_duration("1.5s"), Ok(ms(1500)));
        assert_eq!(parse_duration("250us"), Ok(Duration::from_micros(250)));
        assert_eq!(parse_duration("250µs"), Ok(Duration::from_micros(250)));
        assert_eq!(parse_duration("2m"), Ok(Duration::from_secs(120)));
        assert_eq!(parse_duration("1h"), Ok(Duration::from_secs(3600)));
        assert_eq!(parse_duration("10 ms"), Ok(ms(10)));
        assert_eq!(parse_duration(".5s"), Ok(ms(500)));
        assert_eq!(parse_duration("0ms"), Ok(Duration::ZERO));
        assert_eq!(parse_duration("7ns"), Ok(Duration::from_nanos(7)));
    }

    #[test]
    fn bad_durations() {
        assert_eq!(parse_duration("20"), Err(DurationError::NoUnit));
        assert_eq!(parse_duration("ms"), Err(DurationError::NoNumber));
        assert_eq!(parse_duration("-5ms"), Err(DurationError::NoNumber));
        assert_eq!(parse_duration("1.2.3s"), Err(DurationError::NoNumber));
        assert_eq!(
            parse_duration("5 parsecs"),
            Err(DurationError::UnknownUnit("parsecs".into()))
        );
        assert_eq!(parse_duration("1.5ns"), Err(DurationError::TooFine));
        assert_eq!(
            parse_duration("99999999999999h"),
            Err(DurationError::TooLong)
        );
        assert_eq!(
            parse_duration("1234567890123456789012345678901s"),
            Err(DurationError::TooLong)
        );
    }
}
