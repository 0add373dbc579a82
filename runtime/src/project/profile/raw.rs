//! A profile file as written: serde structs that mirror the YAML, before validation.
//!
//! ```yaml
//! model: sdm120                   # the device model's name (an identifier, `-` allowed)
//! summary: Eastron SDM120 single-phase energy meter
//! source: "Eastron SDM120-Modbus protocol V2.1, input register table"   # where it comes from
//! addresses: { min: 1, max: 247 } # unit addresses it accepts; default 1..=247
//! max_baud: 9600                  # default 115200
//! timing:
//!   reply_timeout: 200ms          # default: the line's response_timeout
//!   frame_gap: 10ms               # silence it needs before a request; default: t3.5
//!   reply_delay: 20ms             # how long it takes to answer (budget, simulator); default 5ms
//! requests:
//!   max_registers: 40             # per FC 3/4 read, 1..=125; default 125
//!   max_bits: 2000                # per FC 1/2 read, 1..=2000; default 2000
//!   read_gaps: false              # may unnamed addresses be read to join reads; default false
//!   write_multiple: false         # FC 16/15 even for one register/coil; default false
//! poll:                           # poll groups; default one group `cycle` read every cycle
//!   - { name: fast, period: cycle }
//!   - { name: energy, period: 10s }
//! points:
//!   - name: voltage               # the point's name in the project (an identifier)
//!     table: input                # coil | discrete | input | holding
//!     address: 0                  # protocol address, 0-based (30001 is input register 0)
//!     type: f32                   # bool (bits) | u16 | i16 | u32 | i32 | f32; default bool
//!                                 # for coil and discrete, u16 for registers
//!     order: ABCD                 # 32-bit word order: ABCD | CDAB | BADC | DCBA; default ABCD
//!     scale: 0.1                  # engineering = raw × scale + offset; the point is then f32
//!     offset: 0
//!     unit: V                     # engineering unit (Sparkplug's engUnit)
//!     range: [0, 500]             # the measuring range, low to high (engLow, engHigh)
//!     access: read                # read | write | read/write; default read
//!     manual: "Voltage, 30001"    # the manual's name
//!     poll: fast                  # its poll group; default the first
//!     write: on_change            # on_change | cyclic; default on_change
//!     initial: 230                # the simulator's power-on value; default 0
//!     bits:                       # fields of a register, read as points of their own
//!       - { name: running, bit: 0 }
//!       - { name: mode, bit: 4, width: 3 }
//! simulate:                       # the simulator's behaviour
//!   - { point: speed, follows: speed_ref, time_constant: 2s }
//! ```

use schemars::JsonSchema;
use serde::Deserialize;

use crate::project::raw::{DurationText, Int};

/// A device profile: one Modbus device's points, polling and timing, written from its manual
/// (docs/devices.md).
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a device profile: a mapping with model, summary, source, addresses, max_baud, \
                 timing, requests, poll, points and simulate"
)]
pub(crate) struct RawProfile {
    /// The device model's name (`sdm120`).
    pub model: String,
    /// One line on what the device is.
    #[serde(default)]
    pub summary: Option<String>,
    /// The manual or public register map the profile is written from.
    pub source: String,
    /// Unit addresses the device accepts (default 1..=247).
    #[serde(default)]
    pub addresses: Option<RawAddresses>,
    /// Its highest baud rate (default 115200).
    #[serde(default)]
    pub max_baud: Option<Int>,
    /// The timing it needs on the line.
    #[serde(default)]
    pub timing: Option<RawTiming>,
    /// What one request may hold.
    #[serde(default)]
    pub requests: Option<RawRequests>,
    /// Poll groups (default: one group, `cycle`, read every cycle).
    #[serde(default)]
    pub poll: Option<Vec<RawGroup>>,
    /// The points.
    pub points: Vec<RawPoint>,
    /// The simulator's behaviour.
    #[serde(default)]
    pub simulate: Option<Vec<RawBehaviour>>,
}

/// `addresses:`.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, expecting = "a mapping with min and max")]
pub(crate) struct RawAddresses {
    /// Lowest unit address (1..=247).
    pub min: Int,
    /// Highest unit address (1..=247).
    pub max: Int,
}

/// `timing:`.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a mapping with reply_timeout, frame_gap and reply_delay"
)]
pub(crate) struct RawTiming {
    /// How long to wait for its reply (default: the line's response_timeout).
    #[serde(default)]
    pub reply_timeout: Option<DurationText>,
    /// Silence it needs before a request (default: the line's t3.5).
    #[serde(default)]
    pub frame_gap: Option<DurationText>,
    /// How long it takes to answer (default 5ms).
    #[serde(default)]
    pub reply_delay: Option<DurationText>,
}

/// `requests:`.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a mapping with max_registers, max_bits, read_gaps and write_multiple"
)]
pub(crate) struct RawRequests {
    /// Registers per FC 3/4 read, 1..=125 (default 125).
    #[serde(default)]
    pub max_registers: Option<Int>,
    /// Coils or inputs per FC 1/2 read, 1..=2000 (default 2000).
    #[serde(default)]
    pub max_bits: Option<Int>,
    /// Whether addresses no point names may be read to join two reads (default false).
    #[serde(default)]
    pub read_gaps: Option<bool>,
    /// Whether one-register and one-coil writes use FC 16/15 (default false).
    #[serde(default)]
    pub write_multiple: Option<bool>,
}

/// One `poll:` group.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a poll group: a mapping with name and period"
)]
pub(crate) struct RawGroup {
    /// Its name.
    pub name: String,
    /// `cycle` (every scan) or a duration (`10s`).
    pub period: String,
}

/// One point.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a point: a mapping with name, table, address, type, order, scale, offset, \
                 unit, range, access, manual, poll, write, initial and bits"
)]
pub(crate) struct RawPoint {
    /// Its name in the project.
    pub name: String,
    /// `coil`, `discrete`, `input` or `holding`.
    #[schemars(schema_with = "super::schema::table")]
    pub table: String,
    /// Protocol address, 0-based.
    pub address: Int,
    /// `bool`, `u16`, `i16`, `u32`, `i32` or `f32`.
    #[serde(default, rename = "type")]
    #[schemars(schema_with = "super::schema::data_type")]
    pub ty: Option<String>,
    /// Word order of a 32-bit value: `ABCD`, `CDAB`, `BADC` or `DCBA`.
    #[serde(default)]
    #[schemars(schema_with = "super::schema::order")]
    pub order: Option<String>,
    /// Factor on the raw value.
    #[serde(default)]
    pub scale: Option<f64>,
    /// Added after scaling.
    #[serde(default)]
    pub offset: Option<f64>,
    /// Engineering unit.
    #[serde(default)]
    pub unit: Option<String>,
    /// The measuring range in engineering units: `[low, high]`.
    #[serde(default)]
    pub range: Option<[f64; 2]>,
    /// `read`, `write` or `read/write`.
    #[serde(default)]
    #[schemars(schema_with = "super::schema::access")]
    pub access: Option<String>,
    /// The manual's name.
    #[serde(default)]
    pub manual: Option<String>,
    /// Its poll group.
    #[serde(default)]
    pub poll: Option<String>,
    /// `on_change` or `cyclic`.
    #[serde(default)]
    #[schemars(schema_with = "super::schema::write")]
    pub write: Option<String>,
    /// The simulator's power-on value, in engineering units.
    #[serde(default)]
    pub initial: Option<f64>,
    /// Bit fields of the register.
    #[serde(default)]
    pub bits: Option<Vec<RawBits>>,
}

/// One bit field.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a bit field: a mapping with name, bit, width and manual"
)]
pub(crate) struct RawBits {
    /// Its point name.
    pub name: String,
    /// Lowest bit, 0 = least significant.
    pub bit: Int,
    /// Number of bits (default 1: a bool point).
    #[serde(default)]
    pub width: Option<Int>,
    /// The manual's name.
    #[serde(default)]
    pub manual: Option<String>,
}

/// One `simulate:` behaviour.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a behaviour: a mapping with point, follows and time_constant"
)]
pub(crate) struct RawBehaviour {
    /// The point that moves.
    pub point: String,
    /// The point it follows.
    pub follows: String,
    /// The first-order lag's time constant.
    pub time_constant: DurationText,
}
