//! The compiled ladder program: the VM's program ([`crate::logic::vm`]) with the tags its rungs
//! write and their description for the push-down planner.

use std::path::PathBuf;

use softplc_io::point::ValueType;

use super::lower::Lowered;
use crate::image::{ProcessImage, TagId};
use crate::logic::blocks::Instance;
use crate::logic::vm::{self, Instr};
use crate::logic::{InstanceOutput, LogicEngine, LogicFault, ScanContext, SourcePos};

/// A compiled ladder program, ready to scan. Build it with [`super::compile`].
#[derive(Debug)]
pub struct LadderProgram {
    vm: vm::Program,
    /// Every tag the program writes, with the rung first writing it.
    writes: Vec<(TagId, SourcePos)>,
    /// The coils as rungs, for the push-down planner.
    rungs: Vec<crate::logic::Rung>,
}

impl LadderProgram {
    /// The program from its lowered rungs, its fresh instances, the tags' types
    /// ([`vm::tag_types`]) and where each rung starts.
    pub(crate) fn new(
        lowered: Lowered,
        own: Vec<crate::logic::user_blocks::UserInstance>,
        instances: Vec<Instance>,
        types: Vec<ValueType>,
        rung_pos: Vec<SourcePos>,
        file: PathBuf,
    ) -> Self {
        let at = |rung: usize| {
            rung_pos.get(rung).cloned().unwrap_or_else(|| SourcePos {
                file: file.clone(),
                line: 1,
                column: 1,
            })
        };
        let highest_tag = lowered.highest_tag.map(|(id, rung)| (id, at(rung)));
        let writes = lowered
            .writes
            .iter()
            .map(|&(id, rung)| (id, at(rung)))
            .collect();
        let parts = vm::Parts {
            code: lowered.code,
            calls: lowered.calls,
            boxes: lowered.boxes,
            own_sites: lowered.own_sites,
            own,
            edges: lowered.edges,
            max_depth: lowered.max_depth,
            instances,
            types,
            highest_tag,
            rung_pos,
            file,
        };
        Self {
            vm: vm::Program::new(parts),
            writes,
            rungs: Vec::new(),
        }
    }

    /// The program with its coils described as rungs.
    pub(crate) fn with_rungs(mut self, rungs: Vec<crate::logic::Rung>) -> Self {
        self.rungs = rungs;
        self
    }

    /// The lowered instructions, rungs in file order.
    pub fn instructions(&self) -> &[Instr] {
        self.vm.instructions()
    }

    /// The tags the program writes (coils, set/reset coils, box results), in rung order.
    pub fn outputs(&self) -> impl Iterator<Item = TagId> + '_ {
        self.writes.iter().map(|(id, _)| *id)
    }

    /// Forgets every edge and block state, as on a fresh start.
    pub fn reset(&mut self) {
        self.vm.reset();
    }
}

impl LogicEngine for LadderProgram {
    fn scan(&mut self, image: &mut ProcessImage, ctx: &ScanContext) -> Result<(), LogicFault> {
        self.vm.scan(image, ctx)
    }

    fn rungs(&self) -> Option<Vec<crate::logic::Rung>> {
        Some(self.rungs.clone())
    }

    fn writes(&self) -> Vec<(TagId, SourcePos)> {
        self.writes.clone()
    }

    fn release(&mut self, coil: TagId) {
        self.vm.release(coil);
    }

    fn instance_counts(&self) -> Vec<u32> {
        vec![self.vm.instances().len() as u32]
    }

    fn instance_outputs(&self, out: &mut Vec<InstanceOutput>) {
        out.clear();
        for (inst, b) in (0u32..).zip(self.vm.instances()) {
            out.extend(b.kind().outputs().iter().map(|&member| InstanceOutput {
                inst,
                member,
                value: b.output(member),
            }));
        }
    }
}
