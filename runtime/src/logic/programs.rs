//! A task's several programs run as one engine: in the task's order, each in its own
//! language, one after the other on the task's image within the cycle (as CODESYS runs the
//! programs a task calls). A later program sees what an earlier one wrote in the same cycle.
//!
//! Two programs of one task may write one tag (CODESYS allows it too): the later one's value
//! is the one the outputs get at the cycle's end. That is legal but rarely meant, so
//! [`Programs::shared_writes`] lists every such tag with both places, and `check` warns.

use crate::image::{ProcessImage, TagId};
use crate::logic::{InstanceOutput, LogicEngine, LogicFault, Rung, ScanContext, SourcePos};

/// A tag two programs of one task write.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SharedWrite {
    /// The tag.
    pub tag: TagId,
    /// Where the earlier program writes it first.
    pub first: SourcePos,
    /// Where a later program writes it first.
    pub then: SourcePos,
}

/// Several programs of one task, scanned in order.
#[derive(Debug)]
pub(crate) struct Programs {
    parts: Vec<Box<dyn LogicEngine>>,
    /// One program's block outputs while they are renumbered: kept, so that publishing the
    /// snapshot allocates nothing once warm, as with one program.
    scratch: std::cell::RefCell<Vec<InstanceOutput>>,
}

impl Programs {
    /// The programs `parts`, in running order.
    pub(crate) fn new(parts: Vec<Box<dyn LogicEngine>>) -> Self {
        Self {
            parts,
            scratch: std::cell::RefCell::default(),
        }
    }
}

impl LogicEngine for Programs {
    fn scan(&mut self, image: &mut ProcessImage, ctx: &ScanContext) -> Result<(), LogicFault> {
        // A fault stops the cycle where it is, as within one program: the PLC goes safe.
        self.parts.iter_mut().try_for_each(|p| p.scan(image, ctx))
    }

    /// Every program's rungs, in running order. A program that does not describe its rungs
    /// adds none (its outputs are never planned, so they stay in the scan); when none
    /// describes its rungs, nothing does.
    fn rungs(&self) -> Option<Vec<Rung>> {
        let described: Vec<Vec<Rung>> = self.parts.iter().filter_map(|p| p.rungs()).collect();
        match described.is_empty() {
            true => None,
            false => Some(described.into_iter().flatten().collect()),
        }
    }

    /// Every tag any program writes, once, at its first writing place in running order.
    fn writes(&self) -> Vec<(TagId, SourcePos)> {
        let mut out: Vec<(TagId, SourcePos)> = Vec::new();
        for (tag, at) in self.parts.iter().flat_map(|p| p.writes()) {
            if !out.iter().any(|(t, _)| *t == tag) {
                out.push((tag, at));
            }
        }
        out
    }

    fn shared_writes(&self) -> Vec<SharedWrite> {
        let mut seen: Vec<(TagId, SourcePos)> = Vec::new();
        let mut shared = Vec::new();
        for part in &self.parts {
            let writes = part.writes();
            for (tag, at) in &writes {
                if let Some((_, first)) = seen.iter().find(|(t, _)| t == tag) {
                    shared.push(SharedWrite {
                        tag: *tag,
                        first: first.clone(),
                        then: at.clone(),
                    });
                }
            }
            for (tag, at) in writes {
                if !seen.iter().any(|(t, _)| *t == tag) {
                    seen.push((tag, at));
                }
            }
        }
        shared
    }

    fn release(&mut self, coil: TagId) {
        // A coil the planner pushed is written by one rung of one program; the others
        // ignore a coil they do not write.
        for p in &mut self.parts {
            p.release(coil);
        }
    }

    fn execution(&self) -> Option<String> {
        let lines: Vec<String> = self.parts.iter().filter_map(|p| p.execution()).collect();
        (!lines.is_empty()).then(|| lines.join("; "))
    }

    /// Each program's instances numbered after the earlier programs' (see
    /// [`LogicEngine::instance_counts`]).
    fn instance_outputs(&self, out: &mut Vec<InstanceOutput>) {
        out.clear();
        let mut part_out = self.scratch.borrow_mut();
        let mut base = 0u32;
        for p in &self.parts {
            p.instance_outputs(&mut part_out);
            out.extend(part_out.iter().map(|o| InstanceOutput {
                inst: base + o.inst,
                ..*o
            }));
            base += p.instance_counts().iter().sum::<u32>();
        }
    }

    fn instance_counts(&self) -> Vec<u32> {
        self.parts
            .iter()
            .flat_map(|p| p.instance_counts())
            .collect()
    }
}
