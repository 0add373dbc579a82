//! RESI RS-485 I/O modules (the "RESI-IO Manual" of 22.07.2016, `seeds/resi-catalog.txt`,
//! digested in `seeds/resi-spec.md`): the RESI-16DI8RO with its internal logic (chapter 10)
//! and every other model with a documented register map: 2RI (5), 1RO (6), 2RTD (7), 1LED
//! (8), 4LED (9), 32DI (11), 14RI (12), 8CO (13).
//!
//! One mechanism serves every model; a model is a table (`models`):
//! - `map`: the register map as blocks of like values, written with the manual's 1-based
//!   references; `value`: 16/32/64-bit encodings, both word orders, scaling.
//! - [`ascii`]: the RESI ASCII protocol (`#[addr,]CMD[:p1,p2]` + CR), the command table type
//!   and the commands every model has.
//! - `state`: the module's inside, protocol-free, on its own clock (10 ms input sampling);
//!   `logic`: the 16DI8RO logic functions; `options`: the simulator's switches where the
//!   manual is silent.
//! - `sim`: the simulator (Modbus and ASCII on one port); `driver`: the sans-IO driver
//!   (Modbus or ASCII, start-up settings verified by read-back).
//!
//! # Where the manual is silent: the choices made
//!
//! Each is an option of the simulator (`DEVICE options` on `softplc sim`'s standard input)
//! where a real module might differ.
//!
//! 16DI8RO logic (resi-spec §4.4):
//! - Several functions on one relay act in the order of the register blocks, SWITCH, TOGGLE,
//!   SWITCH ON, SWITCH OFF, PULSE: the later wins within one 10 ms sample.
//! - SWITCH forces the relay to the input level at every sample, so a host write to a relay
//!   held by SWITCH lasts until the next sample (option `switch change`: only when the input
//!   changes). Several inputs in one SWITCH mask: the highest-numbered one decides (option
//!   `switch-combine any`: OR).
//! - TOGGLE acts once per sample, however many mapped inputs rise together.
//! - Host writes act at once, "side by side" with the logic (L16437); a host write of 0 ends a
//!   running PULSE (option `host-off-ends-pulse`), a write of 1 leaves it running.
//! - PULSE TIME 0 starts no pulse. Logic runs only while ENABLE LOGIC FUNCTIONS is exactly 1
//!   (L22516; option `enable nonzero` for the 0x8000 of erratum 3); writing anything else ends
//!   running pulses and leaves the relays as they are.
//! - CLEAR ALL LOGIC FUNCTIONS (any value written) and `RSTSPCMODE` clear the masks, ENABLE
//!   and PULSE TIME (option `clear-pulse-times`) and end running pulses.
//! - A switching cycle is any change of a relay, on or off, by whatever cause.
//! - Power cycle: relay states, masks, PULSE TIME, ENABLE, switching counters kept; edge
//!   counters 0; an input already high at power-on is not a rising edge; a PULSE running at
//!   the power loss is lost and its bistable relay stays on (option `pulse-at-boot off`).
//!
//! Protocols (resi-spec §2.4, §7):
//! - Modbus exceptions: 01 for FCs other than 1, 2, 3, 4, 5, 6, 15, 16; 02 for undocumented
//!   addresses (option `undocumented zero`) and writes to R/O addresses; 03 for bad values
//!   and quantities. Unit 0 is a broadcast: executed, never answered. A non-zero write to
//!   RESET COUNTER resets (0 does nothing). 32-bit values may be written one half at a time.
//!   RESET SYSTEM and MODBUS UNIT ADDRESS only where the chapter lists them (option
//!   `system-registers`).
//! - ASCII: requests to address 0 or without address are executed and answered, as the
//!   manual's samples show (option `ascii-broadcast silent`); set commands answer
//!   `#<addr>,OK` (`#OK` without address); anything not understood gets no answer; upper case
//!   and single spaces only (option `lenient`). A frame is ASCII when it starts with `#` and
//!   is printable up to its CR; Modbus otherwise.
//! - Reply delay 2 ms (option `reply-delay`). DIP switches at power-on: 19200 Bd, even parity,
//!   address from FLASH (the `MODEL@ADDR` address); the manual states no factory setting.
//!
//! Other models (register level): 8CO — a write to `PULSE ROn` switches the relay on for
//! value × 100 ms, 0 ends it, a host write to the relay ends its pulse, `PULSE ROn` reads the
//! remaining time in 100 ms; 1RO — `GNDOS` bit 1 is the negated relay state; 1LED/4LED —
//! RANDOM and SEQUENCE show the set points, mode ON after reset, set points kept; 2RTD —
//! temperatures are set on the simulator, the average is the valid value once the first
//! interval has passed, configuration takes effect after a reboot.

pub mod ascii;
pub(crate) mod commission;
pub(crate) mod driver;
pub(crate) mod family;
pub(crate) mod item;
pub(crate) mod logic;
pub(crate) mod map;
pub(crate) mod model;
pub(crate) mod models;
pub(crate) mod options;
pub(crate) mod placement;
pub(crate) mod push_down;
pub(crate) mod sim;
pub(crate) mod state;
pub(crate) mod value;

pub use commission::ResiRefusal;
pub use driver::LOGIC_CLEARED_AT_STARTUP;
pub use driver::{
    ascii::BadAnswer,
    settings::{Setting, Settings},
};
pub use family::ResiFamily;
pub use item::{Func, Item, Kind, Temp};
pub use map::{Acc, Block, Entry, Map, Table};
pub use model::{Hardware, Model, RelayKind, Series};
pub use models::{by_name, m16di8ro};
pub use push_down::{Inputs, LogicRow, LogicTable, PulseTime, Relay, RelayFunction, RowRegister};
pub use value::{Enc, Num, WordOrder};

#[cfg(test)]
#[path = "tests/line.rs"]
mod line_tests;
#[cfg(test)]
#[path = "tests/noisy_read_back.rs"]
mod noisy_read_back_tests;
#[cfg(test)]
mod tests;

/// The catalog entries of every RESI model.
pub static MODELS: [&crate::devices::ModelSpec; 9] = [
    &models::m16di8ro::SPEC,
    &models::m32di::SPEC,
    &models::m14ri::SPEC,
    &models::m8co::SPEC,
    &models::m2ri::SPEC,
    &models::m1ro::SPEC,
    &models::m2rtd::SPEC,
    &models::m1led::SPEC,
    &models::m4led::SPEC,
];

/// Makes a model file's catalog entry `SPEC` from its `MODEL`: the driver, the simulator and
/// the settings check are the shared ones.
macro_rules! catalog_entry {
    ($summary:expr) => {
        fn build_driver(config: &$crate::devices::DeviceConfig) -> Box<dyn $crate::driver::Driver> {
            $crate::devices::resi::driver::build(&MODEL, config)
        }

        fn build_sim(address: u8) -> Box<dyn $crate::sim::SimDevice> {
            Box::new($crate::devices::resi::sim::ResiSim::new(&MODEL, address))
        }

        fn setting_keys() -> Vec<&'static str> {
            $crate::devices::resi::driver::settings::keys(&MODEL)
        }

        fn parse_settings(
            pairs: &[(String, String)],
        ) -> Result<$crate::devices::ModuleSettings, Vec<$crate::devices::KeyError>> {
            $crate::devices::resi::driver::settings::Settings::parse(&MODEL, pairs)
                .map($crate::devices::ModuleSettings::Resi)
        }

        /// The catalog entry: Modbus RTU (default) and RESI ASCII, unit addresses 1..=247,
        /// the series' highest baud rate, 2 ms reply delay (undocumented).
        pub(crate) static SPEC: $crate::devices::ModelSpec = $crate::devices::ModelSpec {
            name: MODEL.name,
            summary: $summary,
            points: MODEL.points,
            protocols: &[
                $crate::devices::Protocol::Modbus,
                $crate::devices::Protocol::Text,
            ],
            addresses: 1..=247,
            max_baud: MODEL.series.max_baud(),
            default_reply_delay: std::time::Duration::from_millis(2),
            driver: build_driver,
            simulator: build_sim,
            parse_settings,
            setting_keys,
            profile: None,
            family: &$crate::devices::resi::ResiFamily,
        };
    };
}
pub(crate) use catalog_entry;
