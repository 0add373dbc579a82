//! Device profiles: any Modbus RTU device described in a file (its points, how it is polled,
//! the timing it needs), driven and simulated from that description.
//!
//! The file format and its file:line:col errors belong to the runtime (`project/profile/`),
//! which reads a profile file into a [`Profile`] once; this module holds the typed value, the
//! driver that plans from it (`driver`), the simulator that serves it (`sim`) and its entry
//! among the models ([`model_of`]): a profile becomes a [`ModelSpec`](crate::devices::ModelSpec) like a built-in model,
//! so the project's validation, the bus owner, the line's budget and `softplc check` treat it
//! as any module.
//!
//! Addresses are Modbus protocol addresses, 0-based (the manual's 40001 is holding register
//! 0). A point's engineering value is `raw × scale + offset`.

pub(crate) mod catalog;
pub(crate) mod driver;
pub(crate) mod family;
pub(crate) mod plan;
pub(crate) mod sim;
pub(crate) mod value;

#[cfg(test)]
mod tests;

use std::time::Duration;

pub use catalog::model_of;
pub use catalog::{describe, ProfileSettings};
pub use family::ProfileFamily;
pub use value::{DataType, WordOrder};

use crate::point::ValueType;

/// Which of the four Modbus tables a point lives in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Table {
    /// Coils (0x, FC 1 read, FC 5/15 write).
    Coil,
    /// Discrete inputs (1x, FC 2).
    Discrete,
    /// Input registers (3x, FC 4).
    Input,
    /// Holding registers (4x, FC 3 read, FC 6/16 write).
    Holding,
}

impl Table {
    /// The profile-file name.
    pub fn name(self) -> &'static str {
        match self {
            Table::Coil => "coil",
            Table::Discrete => "discrete",
            Table::Input => "input",
            Table::Holding => "holding",
        }
    }

    /// Whether the table holds bits (coils, discrete inputs) rather than registers.
    pub fn is_bits(self) -> bool {
        matches!(self, Table::Coil | Table::Discrete)
    }

    /// Whether the master may write it (coils, holding registers).
    pub fn is_writable(self) -> bool {
        matches!(self, Table::Coil | Table::Holding)
    }
}

/// Who reads and writes a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointAccess {
    /// Read from the device every time its poll group is due.
    Read,
    /// Written by the program, never read (a command register).
    Write,
    /// Written by the program and read back in its poll group.
    ReadWrite,
}

impl PointAccess {
    /// The profile-file name.
    pub fn name(self) -> &'static str {
        match self {
            PointAccess::Read => "read",
            PointAccess::Write => "write",
            PointAccess::ReadWrite => "read/write",
        }
    }

    /// Whether the point is read.
    pub fn reads(self) -> bool {
        self != PointAccess::Write
    }

    /// Whether the program writes the point.
    pub fn writes(self) -> bool {
        self != PointAccess::Read
    }
}

/// When a written point goes on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WriteMode {
    /// When the program's value changes (and at the line's output refresh).
    #[default]
    OnChange,
    /// Every cycle, changed or not (a setpoint a drive expects to be refreshed).
    Cyclic,
}

/// `engineering = raw × scale + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scaling {
    /// Factor on the raw value (never 0).
    pub scale: f64,
    /// Added after scaling.
    pub offset: f64,
}

/// A field of bits inside a register point, read as its own point.
#[derive(Debug, Clone, PartialEq)]
pub struct BitField {
    /// Its point name.
    pub name: String,
    /// Lowest bit (0 = least significant).
    pub bit: u8,
    /// Number of bits (1: a bool point; more: a u16 point).
    pub width: u8,
    /// The manual's name or description.
    pub manual: Option<String>,
}

impl BitField {
    /// The point's type: bool for one bit, u16 for a wider field.
    pub fn value_type(&self) -> ValueType {
        if self.width == 1 {
            ValueType::Bool
        } else {
            ValueType::U16
        }
    }

    /// The field's value in `word`.
    pub fn extract(&self, word: u32) -> u32 {
        let mask = if self.width >= 32 {
            u32::MAX
        } else {
            (1u32 << self.width) - 1
        };
        (word >> self.bit) & mask
    }
}

/// One point of a profile.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfilePoint {
    /// Its name in the project (`voltage`).
    pub name: String,
    /// Its table.
    pub table: Table,
    /// First protocol address, 0-based.
    pub address: u16,
    /// How the raw value is encoded.
    pub data: DataType,
    /// Order of the words (and bytes) of a 32-bit value.
    pub order: WordOrder,
    /// Scale and offset to engineering units, if any (the point is then an f32).
    pub scaling: Option<Scaling>,
    /// Engineering unit (`V`, `Hz`, `kWh`).
    pub unit: Option<String>,
    /// The measuring range in engineering units, low to high, when the profile gives it.
    pub range: Option<(f64, f64)>,
    /// Read, write or both.
    pub access: PointAccess,
    /// The manual's name or description (`Voltage`, `30001`).
    pub manual: Option<String>,
    /// Index of its poll group in [`Profile::groups`].
    pub group: usize,
    /// When a write goes out.
    pub write: WriteMode,
    /// Bit fields inside the register.
    pub bits: Vec<BitField>,
    /// The simulator's value at power-on (engineering units).
    pub initial: f64,
}

impl ProfilePoint {
    /// The type programs see: bool for bits, f32 when scaled, else the raw type's
    /// (i16 and u32 as i32; a u32 above i32's range saturates).
    pub fn value_type(&self) -> ValueType {
        if self.scaling.is_some() {
            return ValueType::F32;
        }
        match self.data {
            DataType::Bool => ValueType::Bool,
            DataType::U16 => ValueType::U16,
            DataType::I16 | DataType::U32 | DataType::I32 => ValueType::I32,
            DataType::F32 => ValueType::F32,
        }
    }

    /// Registers (or bits) it spans.
    pub fn width(&self) -> u16 {
        self.data.words()
    }

    /// One past its last address.
    pub fn end(&self) -> u32 {
        u32::from(self.address) + u32::from(self.width())
    }
}

/// A poll group: points read together, at their own period.
#[derive(Debug, Clone, PartialEq)]
pub struct PollGroup {
    /// Its name in the profile.
    pub name: String,
    /// How often it is read; `None`: every cycle.
    pub period: Option<Duration>,
}

/// What one request may hold, as the device allows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RequestLimits {
    /// Registers per FC 3/4 read (1..=125).
    pub max_registers: u16,
    /// Coils or inputs per FC 1/2 read (1..=2000).
    pub max_bits: u16,
    /// Whether addresses no point names may be read to join two reads (some devices answer
    /// exception 02 for them).
    pub read_gaps: bool,
    /// Whether one-register and one-coil writes use FC 16/15 (devices without FC 6/5).
    pub write_multiple: bool,
}

impl Default for RequestLimits {
    fn default() -> Self {
        Self {
            max_registers: 125,
            max_bits: 2000,
            read_gaps: false,
            write_multiple: false,
        }
    }
}

/// The timing the device needs on the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceTiming {
    /// How long to wait for its reply (`None`: the line's `response_timeout`).
    pub reply_timeout: Option<Duration>,
    /// Silence it needs before a request, from the end of the previous frame on the line
    /// (`None`: the line's t3.5).
    pub frame_gap: Option<Duration>,
    /// How long it takes to answer (the line's budget, and the simulator's reply delay).
    pub reply_delay: Duration,
}

/// Simple behaviour of the simulator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Behaviour {
    /// `point` follows `source` with a first-order lag: after a step, it covers 63 % of the
    /// way in `time_constant` (a drive's actual speed following its setpoint).
    Follow {
        /// The point that moves (index into [`Profile::points`]).
        point: usize,
        /// The point it follows.
        source: usize,
        /// The lag's time constant.
        time_constant: Duration,
    },
}

/// A device described by a profile file.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// The device model's name (`sdm120`), as `softplc sim` and check name it.
    pub model: String,
    /// One line on what it is.
    pub summary: String,
    /// The manual or register map the profile is written from.
    pub source: String,
    /// Unit addresses it accepts.
    pub addresses: std::ops::RangeInclusive<u8>,
    /// Its highest baud rate.
    pub max_baud: u32,
    /// Its points, in file order.
    pub points: Vec<ProfilePoint>,
    /// Its poll groups (at least one).
    pub groups: Vec<PollGroup>,
    /// What a request may hold.
    pub limits: RequestLimits,
    /// Its timing.
    pub timing: DeviceTiming,
    /// The simulator's behaviour.
    pub behaviours: Vec<Behaviour>,
}

/// One point as the driver and the project see it: a profile point or one of its bit fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// The profile point.
    pub point: usize,
    /// The bit field, if the entry is one.
    pub bits: Option<usize>,
}

impl Profile {
    /// Every point the project can name, in order: each profile point followed by its bit
    /// fields (indexes of [`crate::devices::ModelSpec::points`]).
    pub fn entries(&self) -> Vec<Entry> {
        let mut out = Vec::new();
        for (point, p) in self.points.iter().enumerate() {
            out.push(Entry { point, bits: None });
            for b in 0..p.bits.len() {
                out.push(Entry {
                    point,
                    bits: Some(b),
                });
            }
        }
        out
    }

    /// A point by its name.
    pub fn point(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }
}
