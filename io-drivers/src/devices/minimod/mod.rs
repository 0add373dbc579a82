//! XON Electronics MiniMod: 3 inputs (X1..X3) with latencies and counters, 4 PNP outputs
//! (Y1..Y4) with pulsers, blinkers and automatic ON/OFF conditions, output feedbacks (FB1/FB2,
//! mirrored as X9/X10), on RS-485 with Modbus RTU (and a text protocol, not yet here).
//!
//! Specification: `seeds/minimod-manual.txt` (chapter "Modbus interface" and the two register
//! map tables).
//!
//! - [`map`]: the register map (every address of both tables, 0-based protocol address and
//!   1-based manual reference) and the point table [`map::POINTS`].
//! - [`state`]: the module's inside on its own 1 ms tick (latencies, counters, pulsers,
//!   blinkers, automatic outputs, feedbacks); protocol-free.
//! - [`sim`]: the simulator ([`crate::sim::SimDevice`]): frames in, replies out, over
//!   [`state`] through [`crate::modbus::server::RegisterBank`].
//! - [`driver`]: the sans-IO driver ([`crate::driver::Driver`]).
//!
//! Later issues add, in files of their own: the text protocol (`?X1`, `>Y1=1`, `@25?DEVICE`;
//! [`sim::FrameKind::Text`] already tells its lines apart), FC 70 Collect with its event queue
//! (XEVMASK/YEVMASK, EVENTSPRS), the watchdog (WDTTIME, WDTFB1..2, what sets WDTFIRED) and the
//! serial configuration (SERLINE, ADDRESS/MBADD, RDELAYT, RDELAYM, WCONF).

pub mod driver;
pub mod map;
pub mod sim;
pub mod state;

use std::time::Duration;

use super::{ModelSpec, Protocol};

pub use driver::{MiniModDriver, Readback, Setting, SettingError};
pub use sim::MiniModSim;
pub use state::{Fault, MiniModState};

/// The MiniMod in the catalog: unit addresses 1..=247 (selector + MBADD, "Setting the slave
/// address"), at most 57600 Bd ("Setting the communication parameters"), 10 ms reply delay at
/// power-on (RDELAYT = 1, "Setting the reply delay").
pub static MODEL: ModelSpec = ModelSpec {
    name: "minimod",
    summary: "XON MiniMod: inputs X1..X3 (latency, counters), PNP outputs Y1..Y4 (pulsers, \
              blinkers, automatic conditions), feedbacks X9/X10; Modbus RTU",
    points: map::POINTS,
    protocols: &[Protocol::Modbus],
    addresses: 1..=247,
    max_baud: 57600,
    default_reply_delay: Duration::from_millis(10),
    driver: driver::build,
    simulator: sim::build,
    check_setting: driver::check_setting,
};
