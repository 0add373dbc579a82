//! Logic engines: what runs between the input read and the output write.
//!
//! An engine sees only the [`ProcessImage`] and the scan's time ([`ScanContext`]): no I/O, no
//! wall clock. Same image + same times ⇒ same outputs (DESIGN.md principle 2).

pub(crate) mod blocks;
pub mod expr;
pub mod ladder;
pub(crate) mod load;
pub(crate) mod ownership;
mod programs;
#[cfg(test)]
mod registry_tests;
pub mod rhai;
mod undeclared;
pub(crate) mod user_blocks;
mod vm;

pub use blocks::{BlockDef, Form, Kind, Member, OutputValue, Pattern, PatternError, Pin, PinType};
pub use load::{load_program, load_tasks, tag_table, ProgramError};
pub use ownership::{Ownership, OwnershipError};
pub(crate) use programs::Programs;
pub use programs::SharedWrite;
pub use user_blocks::{OwnBlockError, OwnBlocks};

use std::fmt::Debug;
use std::path::PathBuf;
use std::time::Duration;

use crate::image::ProcessImage;
use softplc_io::time::ScanInstant;

/// The scan's view of time, handed to logic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanContext {
    /// The cycle's start (its deadline), on the PLC's clock.
    pub now: ScanInstant,
    /// Time since the previous cycle's start (the period on the first cycle).
    pub delta: Duration,
    /// The cycle's number: the N-th scan is N, the first is 1 (the scan count once it is
    /// done), as status, trace, record and replay number it.
    pub cycle: u64,
}

/// A place in a program file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourcePos {
    /// The file.
    pub file: PathBuf,
    /// 1-based line.
    pub line: u32,
    /// 1-based column.
    pub column: u32,
}

impl std::fmt::Display for SourcePos {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
    }
}

/// One coil as an engine describes it for the push-down planner: its shape
/// (`softplc_io::rung`) at a place in the program file.
pub type Rung = softplc_io::rung::Rung<SourcePos>;

/// A fault raised by logic during a scan; the PLC goes to its safe state.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message} at {pos}")]
pub struct LogicFault {
    /// What went wrong.
    pub message: String,
    /// Where in the program.
    pub pos: SourcePos,
}

/// One output of one block instance, as the running program holds it: what the web page's
/// ladder view shows on a block's pins and on a contact reading `t.Q`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InstanceOutput {
    /// The instance's index among the program's instances (the diagram's `inst`).
    pub inst: u32,
    /// Which output.
    pub member: blocks::Member,
    /// Its value.
    pub value: blocks::OutputValue,
}

/// A control program ready to scan.
pub trait LogicEngine: Send + Debug {
    /// Runs the program once: reads and writes the image.
    fn scan(&mut self, image: &mut ProcessImage, ctx: &ScanContext) -> Result<(), LogicFault>;

    /// Every coil the program writes, described for the push-down planner
    /// ([`crate::offload`]), in program order; `None` when the engine does not describe its
    /// rungs (then nothing is pushed down, and `check` says so).
    fn rungs(&self) -> Option<Vec<Rung>> {
        None
    }

    /// Every tag the program may write, once each, with the place of its first writing
    /// statement or rung, in program order: what `check` holds against the other tasks'
    /// programs (every tag has one writing task). By default the coils of [`Self::rungs`].
    fn writes(&self) -> Vec<(crate::image::TagId, SourcePos)> {
        let mut out: Vec<(crate::image::TagId, SourcePos)> = Vec::new();
        for r in self.rungs().unwrap_or_default() {
            if !out.iter().any(|(t, _)| *t == r.coil) {
                out.push((r.coil, r.pos));
            }
        }
        out
    }

    /// The module now runs the rung writing `coil`: stop writing it (the PLC reads the
    /// module's value into the image instead). Engines that describe rungs must honour it.
    fn release(&mut self, coil: crate::image::TagId) {
        let _ = coil;
    }

    /// How the program runs, in one line for `check`, when the engine has more than one way
    /// (a Rhai script on the logic VM or in the interpreter); `None` otherwise.
    fn execution(&self) -> Option<String> {
        None
    }

    /// Tags this task's several programs both write (see [`SharedWrite`]); empty for one
    /// program.
    fn shared_writes(&self) -> Vec<SharedWrite> {
        Vec::new()
    }

    /// Per program this engine runs (one, or a task's several in running order), how many
    /// block instances [`Self::instance_outputs`] numbers: a later program's instances are
    /// numbered after an earlier one's. Engines without numbered instances say `[0]`.
    fn instance_counts(&self) -> Vec<u32> {
        vec![0]
    }

    /// Replaces `out` with every output of every block instance, by instance index then in
    /// `blocks::Kind::outputs` order. Engines without numbered instances (expr, Rhai) leave
    /// it empty. Called when the service snapshot is published, not by the scan; it reuses
    /// `out`'s capacity, so it allocates nothing once warm.
    fn instance_outputs(&self, out: &mut Vec<InstanceOutput>) {
        out.clear();
    }
}
