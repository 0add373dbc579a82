//! A block file as written: serde structs that mirror the YAML, before validation.
//!
//! ```yaml
//! blocks:
//!   - name: STATION                 # upper case: letters, digits, _; not a built-in's name
//!     description: A filling station: start, fill for a time, done until taken away
//!     inputs:                       # the first is the power flow (a bool)
//!       - { name: start, type: bool }
//!       - { name: full, type: bool }
//!       - { name: fill_ms, type: i32, default: 3000 }   # may be left out of a call
//!     outputs:                      # the first is the main output (a bool)
//!       - { name: filling, type: bool }
//!       - { name: done, type: bool }
//!     state:                        # kept from scan to scan, per instance
//!       - { name: fills, type: i32, initial: 0, retain: true }   # kept across restarts
//!     instances:                    # blocks of one's own the body calls (pins v.open, ...)
//!       - { name: v, block: VALVE }
//!     body: station.ladder.yaml     # ladder (.yaml) or Rhai (.rhai), relative to this file
//! ```

use schemars::JsonSchema;
use serde::Deserialize;

use crate::project::raw::ScalarText;

/// A file of blocks of one's own, included by projects (`blocks: [FILE, ...]`).
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a block file: a mapping with `blocks:` (a list of block definitions)"
)]
pub(crate) struct RawBlockFile {
    /// The blocks the file defines.
    pub blocks: Vec<RawBlock>,
}

/// One block definition.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a block: a mapping with name, inputs, outputs, state and body"
)]
pub(crate) struct RawBlock {
    /// The name programs call it by: upper case letters, digits and `_` (`STATION`); Rhai
    /// calls it in lower case (`station(name, ...)`).
    pub name: String,
    /// What it does, in words (one line, at most 256 characters).
    #[serde(default)]
    #[schemars(length(max = 256))]
    pub description: Option<String>,
    /// Its inputs, in the order a Rhai call and a ladder call by position give them; the
    /// first is the power flow a ladder rung feeds (a bool).
    pub inputs: Vec<RawVar>,
    /// Its outputs; the first is the main output (a bool): what a rung passes on to its coils
    /// and a Rhai call returns.
    pub outputs: Vec<RawVar>,
    /// Variables the body keeps from one scan to the next, per instance.
    #[serde(default)]
    pub state: Vec<RawVar>,
    /// Instances of other blocks of one's own that the body calls (nesting): their pins are
    /// the body's read-only variables `NAME.PIN`, and an instance of this block has them as
    /// the tags `INSTANCE.NAME.PIN`. A block may not reach itself through them.
    #[serde(default)]
    pub instances: Vec<RawInstance>,
    /// The body: a ladder file (`.yaml`) or a Rhai script (`.rhai`), relative to the block
    /// file's folder. It sees the block's inputs (read-only), outputs and state, nothing else.
    pub body: String,
}

/// An input, output or state variable of a block.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a block variable: a mapping with name and type"
)]
pub(crate) struct RawVar {
    /// Its name: letters, digits and `_`, not first a digit.
    pub name: String,
    /// Its type: bool, u16, i32 or f32.
    #[serde(rename = "type")]
    #[schemars(schema_with = "crate::project::raw_schema::field::tag_type")]
    pub ty: String,
    /// A state variable's value at start-up (zero of its type unless given).
    #[serde(default)]
    pub initial: Option<ScalarText>,
    /// An input's value when a call leaves it out; an input without one must be given.
    #[serde(default)]
    pub default: Option<ScalarText>,
    /// A state variable kept across a restart, as a retained tag is (see the project's
    /// `retain:`).
    #[serde(default)]
    pub retain: Option<bool>,
    /// What it is, in words (one line, at most 256 characters).
    #[serde(default)]
    #[schemars(length(max = 256))]
    pub description: Option<String>,
}

/// One `instances:` entry of a project: an instance of a block of one's own.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "an instance: a mapping with name and block"
)]
pub(crate) struct RawInstance {
    /// The instance's name (an identifier): its pins are the tags `NAME.PIN`.
    pub name: String,
    /// The block it is an instance of (a block of the project's `blocks:` files).
    pub block: String,
}
