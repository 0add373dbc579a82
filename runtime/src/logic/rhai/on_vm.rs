//! A plain script running on the logic VM (lowered by `lower.rs`), with the interpreter's
//! way of writing tags.
//!
//! The interpreter copies a tag out after the script only when its value changed, so an
//! assignment of the value the tag already holds leaves its slot (quality, timestamp) as it
//! was; the VM's store stamps every write. The scan keeps each assigned tag's slot from before
//! and puts it back where the value came out the same.

use crate::image::{ProcessImage, Slot, TagId};
#[cfg(test)]
use crate::logic::blocks::Instance;
use crate::logic::vm;
use crate::logic::{LogicFault, ScanContext};

use super::lower::Lowered;

/// The lowered script and its state.
#[derive(Debug)]
pub(crate) struct OnVm {
    program: vm::Program,
    coils: Vec<TagId>,
    /// The coils' slots at the start of the scan (its capacity kept from scan to scan).
    before: Vec<Slot>,
    /// Instance indexes by name: what the tests compare with the interpreter's instances.
    #[cfg_attr(not(test), allow(dead_code))]
    instances: Vec<(String, u32)>,
}

impl OnVm {
    pub(crate) fn new(lowered: Lowered) -> Self {
        Self {
            program: vm::Program::new(lowered.parts),
            before: Vec::with_capacity(lowered.coils.len()),
            coils: lowered.coils,
            instances: lowered.instances,
        }
    }

    /// A module now drives `coil`: the VM computes its rung but does not write it.
    pub(crate) fn release(&mut self, coil: TagId) {
        self.program.release(coil);
    }

    /// One scan; the image holds every tag the script names (checked by the caller).
    pub(crate) fn scan(
        &mut self,
        image: &mut ProcessImage,
        ctx: &ScanContext,
    ) -> Result<(), LogicFault> {
        self.before.clear();
        self.before
            .extend(self.coils.iter().map(|&coil| *image.slot(coil)));
        self.program.scan(image, ctx)?;
        for (before, &coil) in self.before.iter().zip(&self.coils) {
            if before.value == image.get(coil) {
                image.restore(coil, *before);
            }
        }
        Ok(())
    }

    /// The instance called `name`, with its state now.
    #[cfg(test)]
    pub(crate) fn instance(&self, name: &str) -> Option<&Instance> {
        let &(_, i) = self.instances.iter().find(|(n, _)| n == name)?;
        self.program.instances().get(i as usize)
    }

    /// The instructions (for tests).
    #[cfg(test)]
    pub(crate) fn instructions(&self) -> &[vm::Instr] {
        self.program.instructions()
    }
}
