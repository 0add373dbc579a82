//! A RESI model as data: its register map, its ASCII commands beyond the common ones, its
//! points and its hardware. The simulator, the driver and the catalog entry are built from it,
//! so adding a model is writing one of these (see `models/`).

use super::ascii::command::Command;
use super::map::Map;
use crate::point::PointSpec;

/// The two series of the catalogue (chapter 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Series {
    /// "Ultra slim IO modules", 17.5 mm (L737): 2RI, 1RO, 2RTD, 1LED. Four DIP switches:
    /// DIP1+2 baud 9600..57600, DIP3 RS232/RS485, DIP4 "FD" forces unit 255 (L1765–L1849).
    Slim,
    /// "compact IO modules" (L1488): 4LED, 16DI8RO, 32DI, 14RI, 8CO. Eight DIP switches:
    /// ADR0..3 address 1..15 (0 = FLASH), BR0..2 baud 4800..256000, PARITY none/even
    /// (L17705–L17761).
    Compact,
}

impl Series {
    /// The highest baud rate the DIP switches select.
    pub const fn max_baud(self) -> u32 {
        match self {
            Series::Slim => 57600,
            Series::Compact => 256_000,
        }
    }

    /// Number of DIP switches.
    pub const fn dips(self) -> u8 {
        match self {
            Series::Slim => 4,
            Series::Compact => 8,
        }
    }
}

/// What the relays do without power.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RelayKind {
    /// No relays.
    None,
    /// Bistable: the contact stays where it is; the 16DI8RO keeps the state in FRAM and
    /// restores it after a power loss (L15764–L15768, L16788).
    Bistable,
    /// Monostable: off without power (8CO, L29043; 1RO).
    Monostable,
}

/// The hardware a model has; the state is sized and behaves by it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Hardware {
    /// Digital inputs (DI1..DIn), sampled every 10 ms.
    pub inputs: u8,
    /// Relay outputs (RO1..ROn); the 1RO's single relay is DO1, not counted here.
    pub relays: u8,
    /// What the relays do without power.
    pub relay: RelayKind,
    /// Switching-cycle counters per relay, in FRAM (16DI8RO).
    pub relay_counters: bool,
    /// Timed relay pulses `PULSE ROn` (8CO).
    pub relay_pulses: bool,
    /// The 16DI8RO internal logic (10.1.1).
    pub logic: bool,
    /// The 1RO output DO1 with its off-delay.
    pub one_relay: bool,
    /// RTD channels (2RTD).
    pub rtd: u8,
    /// LED groups of three channels (1LED: 1, 4LED: 4).
    pub led_groups: u8,
}

impl Hardware {
    /// Nothing; models fill in what they have.
    pub const NONE: Self = Self {
        inputs: 0,
        relays: 0,
        relay: RelayKind::None,
        relay_counters: false,
        relay_pulses: false,
        logic: false,
        one_relay: false,
        rtd: 0,
        led_groups: 0,
    };
}

/// A RESI model.
#[derive(Debug)]
pub struct Model {
    /// The catalog name (`resi-16di8ro`).
    pub name: &'static str,
    /// The answer to `TYP` (`RESI-16DI8RO-ASCII`, L18688).
    pub type_name: &'static str,
    /// The answer to `COPY` (L18717 for the compact series).
    pub copyright: &'static str,
    /// The answer to `VER`; the manual's samples show `3.0.0` (L2069).
    pub version: &'static str,
    /// The series.
    pub series: Series,
    /// The register map.
    pub map: Map,
    /// ASCII commands beyond the common ones ([`super::ascii::command::COMMON`]).
    pub commands: &'static [Command],
    /// The points, named as in [`Model::map`].
    pub points: &'static [PointSpec],
    /// Points the driver reads every cycle unless the `poll` setting says otherwise
    /// (patterns as in that setting).
    pub poll: &'static [&'static str],
    /// Outputs written only when they change, never by the periodic refresh, because writing
    /// them starts something (8CO `PULSE ROn`).
    pub one_shot: &'static [&'static str],
    /// The hardware.
    pub hw: Hardware,
    /// Whether the manual documents RESET SYSTEM (4x06001) and MODBUS UNIT ADDRESS
    /// (4x65222) for this model (resi-spec §1.4).
    pub system_registers: bool,
}

impl Model {
    /// Index of a point by name.
    pub fn point_index(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }
}
