//! Blocks of one's own: the project's [`UserBlock`]s joined to the built-in library as one
//! registry the languages look names up in ([`OwnBlocks`]), and their instances, each a body
//! program of its own ([`UserInstance`]).
//!
//! A body is compiled once per instance, by its own language's compiler, against a table of
//! the block's variables only (inputs read-only, outputs and state writable), so a body that
//! writes an undeclared output, writes an input or reads a project tag is refused at its own
//! file:line:col, and the same body runs the same way whoever calls it. Each instance keeps
//! its variables in a small image of its own; a call writes the inputs there, runs the body
//! with the scan's time and copies every variable into the project's tags `INSTANCE.VAR`, so
//! what a caller reads after the call (`s1.done`), the trace, the recorder, `softplc test`,
//! status and the services all see one value. A block's body may call blocks of one's own
//! through the instances its block declares (`instances:`): each is compiled against the
//! body's table, publishes into the body's image, and so reaches the project's tags as
//! `INSTANCE.NESTED.VARIABLE` with its outer instance's; validation refuses recursion.

mod build;
mod instance;
mod shape;

use crate::logic::blocks::Kind;
use crate::project::UserBlock;

pub use build::OwnBlockError;
pub(crate) use build::{build, default_of};
pub(crate) use instance::UserInstance;
pub(crate) use shape::substitute;

/// What a program may call: the built-in blocks (`Kind`) and the project's own blocks, with
/// the instances the project declares.
#[derive(Debug, Default)]
pub struct OwnBlocks {
    pub(crate) blocks: Vec<UserBlock>,
    /// The declared instances: name and block (an index into `blocks`).
    pub(crate) declared: Vec<(String, usize)>,
    /// The instances compiled, in `declared` order (none for a drawing).
    pub(crate) instances: Vec<UserInstance>,
    /// Set when the program is a block's body (the block's name): the instances it may
    /// call are the block's `instances:`, which a refusal names.
    pub(crate) in_body: Option<String>,
}

/// A name as the registry finds it.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Found<'a> {
    /// A built-in block.
    Builtin,
    /// A block of one's own.
    Own(&'a UserBlock),
}

impl OwnBlocks {
    /// No block of one's own: what a project without `blocks:` calls.
    pub fn none() -> Self {
        Self::default()
    }

    /// The registry for a body of `block`: every block, and the instances the block
    /// declares (`instances:`), none compiled.
    pub(crate) fn for_body(blocks: &[UserBlock], block: &UserBlock) -> Self {
        Self {
            blocks: blocks.to_vec(),
            declared: block
                .instances
                .iter()
                .filter_map(|n| {
                    Some((
                        n.name.clone(),
                        blocks.iter().position(|b| b.name == n.block)?,
                    ))
                })
                .collect(),
            instances: Vec::new(),
            in_body: Some(block.name.clone()),
        }
    }

    /// The project's blocks and declared instances, none compiled: what a drawing checks
    /// the program against.
    pub fn declared(project: &crate::project::Project) -> Self {
        Self {
            blocks: project.blocks.clone(),
            declared: project
                .instances
                .iter()
                .map(|i| (i.name.clone(), i.block))
                .collect(),
            instances: Vec::new(),
            in_body: None,
        }
    }

    /// The block named `name` (ladder's spelling, `TON`, `STATION`).
    pub(crate) fn find(&self, name: &str) -> Option<Found<'_>> {
        if Kind::parse(name).is_some() {
            return Some(Found::Builtin);
        }
        self.blocks.iter().find(|b| b.name == name).map(Found::Own)
    }

    /// The declared instance `name`: its index and block.
    pub(crate) fn instance(&self, name: &str) -> Option<(u32, &UserBlock)> {
        let (i, (_, block)) = (0u32..).zip(&self.declared).find(|(_, (n, _))| n == name)?;
        Some((i, self.blocks.get(*block)?))
    }

    /// Every block name, built-ins first (for "did you mean").
    pub(crate) fn names(&self) -> impl Iterator<Item = &str> {
        Kind::ALL
            .iter()
            .map(|k| k.name())
            .chain(self.blocks.iter().map(|b| b.name.as_str()))
    }

    /// Whether there is no block of one's own.
    pub(crate) fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// Each declared instance's main output as its body describes it (see `shape.rs`), by
    /// instance index; empty when none is compiled.
    pub(crate) fn shapes(&self) -> Vec<Result<softplc_io::rung::RungShape, String>> {
        self.instances
            .iter()
            .map(UserInstance::main_shape)
            .collect()
    }

    /// The instances, moved into the program that calls them.
    pub(crate) fn take_instances(&mut self) -> Vec<UserInstance> {
        std::mem::take(&mut self.instances)
    }
}

pub(crate) use crate::project::user_blocks::a_type;
