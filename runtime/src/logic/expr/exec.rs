//! The compiled `.expr` program: the VM's program ([`crate::logic::vm`]) with the statements'
//! coils and their description for the push-down planner.

use std::path::PathBuf;

use softplc_io::point::ValueType;

use super::lower::Lowered;
use crate::image::{ProcessImage, TagId};
use crate::logic::vm::{self, Instr};
use crate::logic::Rung;
use crate::logic::{LogicEngine, LogicFault, ScanContext, SourcePos};

/// A compiled `.expr` program, ready to scan. Build it with [`super::compile`].
#[derive(Debug)]
pub struct ExprProgram {
    vm: vm::Program,
    coils: Vec<TagId>,
    /// The statements as rungs, for the push-down planner.
    rungs: Vec<Rung>,
}

impl ExprProgram {
    /// The program from its lowered statements; `types` are the tags' ([`vm::tag_types`]).
    pub(crate) fn new(lowered: Lowered, types: Vec<ValueType>, file: PathBuf) -> Self {
        let highest_tag = lowered.highest_tag.map(|(id, pos)| {
            let at = SourcePos {
                file: file.clone(),
                line: pos.line,
                column: pos.col,
            };
            (id, at)
        });
        let parts = vm::Parts {
            code: lowered.code,
            calls: Vec::new(),
            boxes: Vec::new(),
            own_sites: Vec::new(),
            own: Vec::new(),
            edges: lowered.edges,
            max_depth: lowered.max_depth,
            instances: lowered.instances,
            types,
            highest_tag,
            rung_pos: Vec::new(),
            file,
        };
        Self {
            vm: vm::Program::new(parts),
            coils: lowered.coils,
            rungs: Vec::new(),
        }
    }

    /// The program with its statements described as rungs.
    pub(crate) fn with_rungs(mut self, rungs: Vec<Rung>) -> Self {
        self.rungs = rungs;
        self
    }

    /// The coils the program writes (the outputs and memory tags it owns), in file order.
    pub fn outputs(&self) -> impl Iterator<Item = TagId> + '_ {
        self.coils.iter().copied()
    }

    /// The lowered instructions, statements in file order.
    pub fn instructions(&self) -> &[Instr] {
        self.vm.instructions()
    }

    /// Forgets all edge and timer state, as on a fresh start.
    pub fn reset(&mut self) {
        self.vm.reset();
    }
}

impl LogicEngine for ExprProgram {
    fn scan(&mut self, image: &mut ProcessImage, ctx: &ScanContext) -> Result<(), LogicFault> {
        self.vm.scan(image, ctx)
    }

    fn rungs(&self) -> Option<Vec<Rung>> {
        Some(self.rungs.clone())
    }

    fn release(&mut self, coil: TagId) {
        // A released coil is the module's: the statement still runs (its timers and edges see
        // every scan) but its result is not written.
        self.vm.release(coil);
    }
}
