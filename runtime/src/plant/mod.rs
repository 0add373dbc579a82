//! Plant models written in the project: the machine around the simulated modules, described
//! in Rhai, so a project closes the loop from its outputs to its inputs with no hardware.
//!
//! A model file declares itself in `fn plant()` (its step, the terminals it reads and drives,
//! its states with initial values and limits, its faults); its top-level statements are the
//! step, run every `step` of the simulated world's time against the declared names, with
//! `dt` and `time` and the plant API ([`api`]): rates, lags, delays, edges, periodic events, a
//! seeded random source, faults. The engine is the programs' sandbox (no I/O, no clock, an
//! operation limit per step), so a model is deterministic on the virtual clock.
//!
//! [`compile`] checks a model before the first scan (every error at its line:col); a model
//! that fails while it runs stops, its terminals hold, and the PLC runs on
//! ([`softplc_io::sim::plant::PlantHealth`]). docs/plant.md teaches it.

pub(crate) mod api;
mod attach;
mod catalog;
mod decl;
mod error;
mod model;
mod run;

pub use attach::{attach, NotInWorld};
pub use catalog::{builtin, Builtin, CATALOG};
pub use decl::{Declarations, FaultDecl, StateDecl, DEFAULT_STEP};
pub use error::{ModelError, RunError};
pub use model::{compile, ModelErrorAt, PlantModel};
pub use run::RhaiPlant;

#[cfg(test)]
mod tests;
