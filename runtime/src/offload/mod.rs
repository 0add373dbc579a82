//! Push-down: fast rungs compiled into the modules' own logic, when it gives the same
//! behaviour (DESIGN.md principle 6).
//!
//! A MiniMod reacts to its inputs within a millisecond and a RESI-16DI8RO within 10 ms; a
//! central scan over RS-485 reacts within a scan period plus the bus time. The planner moves a
//! rung into its module only when the module's function is the rung's own, and says why for
//! every rung it keeps:
//!
//! 1. the engine describes each coil it writes as a [`Rung`] (an engine-neutral shape,
//!    `softplc_io::rung`:
//!    combinational, latch, pulse, staircase, toggle, edge set/reset, blinker, or opaque);
//! 2. [`planner::plan`] maps each rung with the project's bindings and `offload:` switches to
//!    module tables through the coil's module's family (`Family::push_down` in softplc-io:
//!    the MiniMod's and the RESI-16DI8RO's mappings live with their drivers) or keeps it
//!    central with a [`planner::Reason`]; conditions are minimised exactly
//!    (`softplc_io::push_down`);
//! 3. `runtime::Offloaded` runs the plan in the PLC: the tables are settings the drivers
//!    write and verify at start-up, the pushed-down outputs are no longer written by the scan
//!    but read back into the image, pulse triggers become pulser writes, and at stop the
//!    tables are cleared (or kept). Every start-up (and every restart of a module that comes
//!    back) first clears all the module's logic registers, whatever the plan, so tables a
//!    crashed run left behind never drive the outputs; an output whose rung keeps a state then
//!    gets the central rung's start value (`planner::ModulePlacement::initial`) before its
//!    tables are armed;
//! 4. [`report`] is what `softplc check` prints: placement, tables, reaction times.
//!
//! # Declarations rather than rungs
//!
//! Two module features have no rung to move: input conditioning (`debounce` / `stretch` on a
//! MiniMod input tag, written as XLATUPn / XLATDNn whatever the mode, since the scan and the
//! module then see the same cooked input) and edge counting: a tag bound to `mmX.XCOUNTn`
//! reads the module's own counter of rising edges (with the module's `counters: every`
//! setting), so a counter of fast pulses needs no CTU at all.
//!
//! # Blinkers
//!
//! A MiniMod's blinker (YLAMPn, "Automatic continuous blinking") plays a 16-step mask on
//! steps of 100 ms that run freely from the module's power-on. A LAMP block means exactly
//! that (its central engine counts the steps from the PLC's start), so it is pushed down
//! whenever its mask is a constant: the scan keeps the enable and writes the mask when it
//! rises, 0 when it falls. A BLINK means "on when enabled": it goes down only where its
//! period is 1, 2, 4, 8 or 16 steps and the engineer freed its phase (`blink_phase: free` on
//! the tag); `check` says why any other stays central and which on/off times nearby would go
//! down. The pattern then starts wherever the module's steps are: its first on-step comes
//! within the mask's longest run of off-steps plus one step after the write.
//!
//! # Equivalence
//!
//! Each form's proof is in its mapping's module docs; the tests
//! (`tests/tests/offload_equivalence.rs`) run the same program centrally and pushed down
//! against the simulators with the same random inputs and compare the output traces at the
//! module terminals: the same edges in the same order, each pushed-down edge no later than the
//! central one and earlier by at most the central reaction time (scan period + bus time),
//! provided every input state lasts longer than that (a central scan cannot see shorter ones;
//! the module can, which is the point).

pub(crate) mod planner;
pub(crate) mod report;
pub(crate) mod runtime;
#[cfg(test)]
mod tests;

pub use crate::logic::Rung;
pub use planner::{
    plan, Command, Conditioning, Feature, ModulePlacement, Placement, Plan, Pushed, Reason,
    RequireFailure, RungPlan, TableEntry,
};
pub use report::{central_bound, report, task_report};
pub use softplc_io::rung::{BoolExpr, RungShape};

use crate::logic::LogicEngine;
use crate::project::{ProgramKind, Project};

/// The engine's name for reports.
pub fn engine_name(kind: ProgramKind) -> &'static str {
    match kind {
        ProgramKind::Expr => "expr",
        ProgramKind::Ladder => "ladder",
        ProgramKind::Rhai => "rhai",
    }
}

/// The plan of `project` with its compiled program `engine` (its first task's programs).
pub fn plan_program(project: &Project, engine: &dyn LogicEngine) -> Plan {
    // Named only when no program describes its rungs: the first one's language says which.
    let kind = project
        .programs
        .first()
        .map_or(ProgramKind::Expr, |p| p.kind);
    plan(project, engine.rungs(), engine_name(kind))
}
