//! Push-down targets: a device family runs a rung in the module's own logic when the module
//! behaves as the rung does. The runtime's planner hands each family a rung's shape
//! ([`crate::rung::RungShape`]) and a [`Site`] (the project around the rung); the family
//! answers with a [`ModulePlacement`] (the feature, the tables it writes, a command the scan
//! sends instead of the output) or a [`Reason`] the rung stays central
//! ([`crate::devices::Family::push_down`]). The placements' tables go into the module's
//! [`crate::devices::PushDown`], which its driver writes and verifies at start-up.
//!
//! Stable API: the types here and the [`Site`] trait, which the runtime implements; a new
//! family with module logic implements `Family::push_down` and `Family::add_pushed`.

pub(crate) mod minimize;
mod placement;
mod site;

pub use placement::{Command, Feature, ModulePlacement, Pushed, Reason, TableEntry};
pub use site::Site;
