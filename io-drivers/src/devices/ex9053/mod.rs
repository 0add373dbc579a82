//! EX-9053D / EX-9053D-M: 16 digital inputs DI0..DI15 with latches, counters, synchronized
//! sampling and a dual watchdog, on RS-485 with DCON ASCII (both) and Modbus RTU (-M only).
//!
//! Specification: `seeds/ex9053d-manual.md` (chapter 1 for the behaviour, chapter 2 for DCON,
//! the "9053-M Modbus mapping" for Modbus). Section numbers in the docs are the manual's.
//!
//! - `tables`: the configuration tables (§1.10), defaults, identity.
//! - `dcon`: DCON framing with the optional checksum, every command and answer, parsed and
//!   formatted both ways (driver and simulator share it).
//! - `map`: the Modbus map of the -M.
//! - `points`: the point table by the manual's names.
//! - `state`: the module's inside (EEPROM, power-on, latches, counters, sync sample, host
//!   watchdog), protocol-free.
//! - `sim_dcon`, `sim_modbus`, `sim`: the simulator.
//! - `settings`, `sync`, `driver`: the sans-IO driver and its project-file settings.
//!
//! Addresses: a project file's or `softplc sim`'s numeric address is the module address as a
//! number (`address: 18` is DCON `12`, Modbus unit 18). The EX-9053D takes 0..=255 (DCON
//! 00..FF); the EX-9053D-M 1..=247, the Modbus range, also when it is run with DCON.

pub(crate) mod commission;
pub(crate) mod dcon;
pub(crate) mod driver;
pub(crate) mod family;
pub(crate) mod map;
pub(crate) mod points;
pub(crate) mod settings;
pub(crate) mod sim;
pub(crate) mod sim_dcon;
pub(crate) mod sim_modbus;
pub(crate) mod state;
pub(crate) mod sync;
pub(crate) mod tables;

#[cfg(test)]
mod tests;

use super::{ModelSpec, Protocol};

pub use commission::Ex9053Refusal;
pub use dcon::{check_line, Answer, AnswerError, Command, FrameError, ParseError};
pub use driver::Ex9053Driver;
pub use family::{address_hearing, Ex9053Family};
pub use settings::{LatchMode, Settings};
pub use sim::Ex9053Sim;
pub use state::{ConfigError, Eeprom, Ex9053State, Running, Variant, WireProtocol};
pub use sync::SyncRole;
pub use tables::{
    baud_of_code, code_of_baud, BAUD_CODES, FF_CHECKSUM, INIT_ADDRESS, INIT_BAUD_CODE, LINE_FORMAT,
    TYPE_DIO,
};

/// The EX-9053D in the catalog: DCON only, addresses 00..FF, up to 115200 Bd (§1
/// "Specifications").
pub static MODEL_D: ModelSpec = ModelSpec {
    name: "ex9053d",
    summary: "EX-9053D: 16 digital inputs DI0..DI15 with latches, counters, synchronized \
              sampling, host watchdog; DCON ASCII",
    points: points::POINTS,
    protocols: &[Protocol::Text],
    addresses: 0..=255,
    max_baud: 115_200,
    default_reply_delay: tables::REPLY_DELAY,
    driver: driver::build,
    simulator: sim::build_d,
    parse_settings: settings::parse_module,
    setting_keys: settings::keys,
    profile: None,
    family: &Ex9053Family,
};

/// The EX-9053D-M in the catalog: Modbus RTU by default, DCON too (`protocol: text`), unit
/// addresses 1..=247, up to 115200 Bd.
pub static MODEL_M: ModelSpec = ModelSpec {
    name: "ex9053d-m",
    summary: "EX-9053D-M: 16 digital inputs DI0..DI15 with latches, counters, host watchdog; \
              Modbus RTU (default) or DCON ASCII",
    points: points::POINTS,
    protocols: &[Protocol::Modbus, Protocol::Text],
    addresses: 1..=247,
    max_baud: 115_200,
    default_reply_delay: tables::REPLY_DELAY,
    driver: driver::build,
    simulator: sim::build_m,
    parse_settings: settings::parse_module,
    setting_keys: settings::keys,
    profile: None,
    family: &Ex9053Family,
};
