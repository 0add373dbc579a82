//! XON Electronics MiniMod: 3 inputs (X1..X3) with latencies and counters, 4 PNP outputs
//! (Y1..Y4) with pulsers, blinkers and automatic ON/OFF conditions, output feedbacks (FB1/FB2,
//! mirrored as X9/X10), an internal watchdog, an event queue for FC 70 Collect, on RS-485
//! with Modbus RTU and a text protocol on the same line.
//!
//! Specification: `seeds/minimod-manual.txt` (every chapter; the register map tables for
//! Modbus, the text tables for the text protocol).
//!
//! - `map`: the register map (every address of both tables, 0-based protocol address and
//!   1-based manual reference), the condition masks, and the point table [`map::POINTS`].
//! - `state`: the module's inside on its own 1 ms tick (latencies, counters, pulsers,
//!   blinkers, automatic outputs, feedbacks), protocol-free, with
//!   `watchdog` (WDTTIME, WDTFB1..2, WDTYMASK, WDTFIRED), `events` (the Collect queue) and
//!   `serial_config` (SERLINE, ADDRESS/MBADD, RDELAYT, RDELAYM, WCONF, dip-switch 3).
//! - `text`: the text protocol's grammar, both sides (`?X1`, `>Y1=1`, `@25?DEVICE`).
//! - `sim`: the simulator ([`crate::sim::SimDevice`]): frames in, replies out; Modbus through
//!   `crate::modbus::server::RegisterBank`, text through `sim_text`.
//! - `settings`: the project entry's settings, parsed once; `push_down`: the tables the
//!   push-down planner hands the driver.
//! - `driver`: the sans-IO driver ([`crate::driver::Driver`]), Modbus or
//!   text, polled or in event mode (with `crate::line::collect` on the bus owner's side).

pub(crate) mod commission;
pub(crate) mod driver;
pub(crate) mod events;
pub(crate) mod family;
pub(crate) mod lamp;
pub(crate) mod map;
pub(crate) mod placement;
pub(crate) mod push_down;
pub(crate) mod serial_config;
pub(crate) mod settings;
pub(crate) mod sim;
pub(crate) mod sim_text;
pub(crate) mod state;
pub(crate) mod text;
pub(crate) mod watchdog;

#[cfg(test)]
#[path = "tests/framing.rs"]
mod framing_tests;
#[cfg(test)]
#[path = "tests/line.rs"]
pub(crate) mod line_tests;
#[cfg(test)]
#[path = "tests/noisy_read_back.rs"]
mod noisy_read_back_tests;

use std::time::Duration;

use super::{ModelSpec, Protocol};

pub use commission::MiniModRefusal;
pub use driver::{MiniModDriver, LOGIC_CLEARED_AT_STARTUP};
pub use events::{Event, Events};
pub use family::MiniModFamily;
pub use lamp::first_on_within;
pub use map::{parse_condition, point_index, ConditionError, Item, WatchdogRegisters, POINTS};
pub use push_down::{AutoOutput, Condition, Input, Latency, Output, PulseWidth, PushDown};
pub use push_down::{CONDITIONS, MAX_PULSE_MS};
pub use serial_config::{
    FlashError, LineMode, Preferences, SerialConfig, SerialError, SerialParams, BAUD_RATES,
    FACTORY_RDELAYT, MAX_RDELAY,
};
pub use settings::{Readback, Setting, SettingError, Settings};
pub use sim::MiniModSim;
pub use state::{Fault, MiniModState, WriteError};
pub use text::{
    read_command, write_command, Command, Op, Refusal, TextId, TextReply, Unwritable, WriteKind,
    WriteValue,
};
pub use watchdog::{Cause, Watchdog};

/// The MiniMod in the catalog: unit addresses 1..=247 (selector + MBADD, "Setting the slave
/// address"), at most 57600 Bd ("Setting the communication parameters"), 10 ms reply delay at
/// power-on (RDELAYT = 1, "Setting the reply delay"), Modbus RTU or the text protocol ("Text
/// commands protocol").
pub static MODEL: ModelSpec = ModelSpec {
    name: "minimod",
    summary: "XON MiniMod: inputs X1..X3 (latency, counters), PNP outputs Y1..Y4 (pulsers, \
              blinkers, automatic conditions), feedbacks X9/X10, watchdog, Collect events; \
              Modbus RTU or text",
    points: map::POINTS,
    protocols: &[Protocol::Modbus, Protocol::Text],
    addresses: 1..=247,
    max_baud: 57600,
    default_reply_delay: Duration::from_millis(10),
    driver: driver::build,
    simulator: sim::build,
    parse_settings: Settings::parse_module,
    setting_keys: settings::keys,
    profile: None,
    family: &MiniModFamily,
};
