//! One instance of a block of one's own: its variables in an image of its own, its body
//! compiled against them, and the project's tags it copies them into.

use softplc_io::point::{Value, ValueType};

use crate::image::{ProcessImage, TagId};
use crate::logic::{LogicEngine, LogicFault, ScanContext};

/// An instance, ready to be called.
#[derive(Debug)]
pub(crate) struct UserInstance {
    name: String,
    /// Inputs, outputs, state, in that order (`UserBlock::vars`).
    vars: ProcessImage,
    /// Their names, same order.
    names: Vec<String>,
    types: Vec<ValueType>,
    inputs: usize,
    body: Box<dyn LogicEngine>,
    /// The project's tag of each variable, same order.
    tags: Vec<TagId>,
    /// Not run yet: its outputs and state are still to be taken from its tags.
    fresh: bool,
}

impl UserInstance {
    pub(crate) fn new(
        name: String,
        vars: ProcessImage,
        names: Vec<String>,
        types: Vec<ValueType>,
        inputs: usize,
        body: Box<dyn LogicEngine>,
        tags: Vec<TagId>,
    ) -> Self {
        Self {
            name,
            vars,
            names,
            types,
            inputs,
            body,
            tags,
            fresh: true,
        }
    }

    /// Before its first run: its outputs and state from its tags, which hold their initial
    /// values at a start, the retained ones where the block retains them, and what the
    /// instance left at a reload (so a reload keeps an instance's state, as a tag's).
    pub(crate) fn adopt(&mut self, image: &ProcessImage, ctx: &ScanContext) {
        if !self.fresh {
            return;
        }
        self.fresh = false;
        for (i, &tag) in self.tags.iter().enumerate().skip(self.inputs) {
            if tag.index() < image.len() {
                self.vars.set(TagId(i as u32), image.get(tag), ctx.now);
            }
        }
    }

    /// Takes the forces the project's image holds on its tags, and holds its variables at
    /// them at once. Forces live in one place, the image (`softplc force s1.start 1`); the
    /// image applies them to the tags before and after the logic, but the body runs on an
    /// image of its own in between, so without this a forced input pin would not be what the
    /// body reads, and a forced output would be what the body computed until the logic ended.
    /// The forces go into its own image as forces, so a nested instance's call in the body
    /// takes them from there the same way (`s1.v.start` forced reaches `v`'s body).
    pub(crate) fn follow_forces(&mut self, image: &ProcessImage, ctx: &ScanContext) {
        for (i, &tag) in self.tags.iter().enumerate() {
            let id = TagId(i as u32);
            match (tag.index() < image.len())
                .then(|| image.forced(tag))
                .flatten()
            {
                Some(v) => self.vars.force(id, v),
                None => drop(self.vars.unforce(id)),
            }
        }
        self.hold_forces(ctx);
    }

    /// Sets every forced variable to its forced value.
    fn hold_forces(&mut self, ctx: &ScanContext) {
        self.vars.apply_forces(ctx.now);
    }

    /// Its main output as its body describes it, over the block's variables.
    pub(crate) fn main_shape(&self) -> Result<softplc_io::rung::RungShape, String> {
        super::shape::main_output_shape(self.body.as_ref(), self.inputs)
    }

    /// Its name (`s1`).
    pub(crate) fn name(&self) -> &str {
        &self.name
    }

    /// Input `i`'s type.
    pub(crate) fn input_type(&self, i: usize) -> ValueType {
        self.types.get(i).copied().unwrap_or(ValueType::Bool)
    }

    /// Sets input `i` for the next run, converted to its type as a box stores a number
    /// (integers truncate toward zero and saturate).
    pub(crate) fn set_input(&mut self, i: usize, value: f64, ctx: &ScanContext) {
        if i < self.inputs {
            let v = crate::logic::vm::number_as(self.input_type(i), value);
            self.vars.set(TagId(i as u32), v, ctx.now);
        }
    }

    /// Runs the body once with the inputs set, then copies every variable into the
    /// project's tags; returns the main output.
    pub(crate) fn run(
        &mut self,
        image: &mut ProcessImage,
        ctx: &ScanContext,
    ) -> Result<bool, LogicFault> {
        self.adopt(image, ctx);
        self.follow_forces(image, ctx);
        let q = self.run_body(ctx)?;
        self.publish(image, ctx);
        Ok(q)
    }

    /// Runs the body once with the inputs set; returns the main output. A forced input is
    /// what the body reads, whatever the call gave; a forced output or state variable keeps
    /// its forced value, whatever the body computed, so the call returns it and the rest of
    /// the program reads it (the forces taken by [`UserInstance::follow_forces`]). The
    /// project's tags are the caller's to update ([`UserInstance::publish`]).
    pub(crate) fn run_body(&mut self, ctx: &ScanContext) -> Result<bool, LogicFault> {
        self.hold_forces(ctx);
        self.body.scan(&mut self.vars, ctx)?;
        self.hold_forces(ctx);
        Ok(self.output(0).as_bool())
    }

    /// Copies every variable into the project's tags.
    pub(crate) fn publish(&self, image: &mut ProcessImage, ctx: &ScanContext) {
        for (i, &tag) in self.tags.iter().enumerate() {
            let v = self.vars.get(TagId(i as u32));
            if tag.index() < image.len() && image.get(tag) != v {
                image.set(tag, v, ctx.now);
            }
        }
    }

    /// The variable called `name` (input, output or state) now.
    pub(crate) fn var(&self, name: &str) -> Option<Value> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(self.vars.get(TagId(i as u32)))
    }

    /// Output `i`'s value now.
    pub(crate) fn output(&self, i: usize) -> Value {
        self.vars.get(TagId((self.inputs + i) as u32))
    }
}
