//! What a family's push-down target sees of the project around one rung: the coil's module and
//! point, and where each tag of the rung's conditions comes from. The runtime's planner
//! implements it over the validated project.

use std::collections::BTreeSet;

use super::Reason;
use crate::devices::{ModelSpec, ModuleSettings, Protocol};
use crate::point::PointSpec;
use crate::rung::TagId;

/// The project around one rung, as a push-down target asks it.
pub trait Site {
    /// The coil's module: its index among the project's modules.
    fn module(&self) -> usize;
    /// The coil's module's name.
    fn module_name(&self) -> &str;
    /// The coil's module's model (its catalogue entry).
    fn model(&self) -> &'static ModelSpec;
    /// The coil's module's settings as the project gives them.
    fn settings(&self) -> &ModuleSettings;
    /// The protocol the module is driven with.
    fn protocol(&self) -> Protocol;
    /// Whether the module's own settings already set `register` (the map's name), which the
    /// planner must then not write.
    fn setting_taken(&self, register: &str) -> bool;
    /// The coil's point, among the model's points: its index.
    fn point(&self) -> usize;
    /// The coil's point.
    fn coil_point(&self) -> &'static PointSpec;
    /// A tag's name, for reports.
    fn name(&self, tag: TagId) -> String;
    /// The point of the coil's module a condition tag reads, or why the module's logic
    /// cannot read it there. `checks` says what the module's logic checks, for the reason.
    fn input(&self, tag: TagId, checks: &'static str) -> Result<&'static PointSpec, Reason>;
    /// Whether the engineer freed the phase of a BLINK writing the coil (`blink_phase: free`
    /// on its tag): it may then start anywhere in its period when its enable rises.
    fn blink_phase_free(&self) -> bool;
    /// Coils of this rung and of the rungs after it (what a trigger evaluated after the logic
    /// must not read).
    fn later(&self) -> &BTreeSet<TagId>;
}
