//! Blocks of one's own: files of block definitions (`raw` gives the format) that projects
//! include (`blocks: [FILE, ...]`), and the instances a project declares (`instances:`).
//!
//! A block has typed inputs, outputs and state, and a body written as a program of its own
//! (ladder or Rhai) that sees only those variables. Every instance's variables are memory
//! tags of the project named `INSTANCE.VARIABLE` (`s1.start`, `s1.done`): the trace, the
//! recorder, `softplc test`, status and the services see them as any tag. A name that clashes
//! with a built-in block or with a block of another included file is refused, naming both
//! places.

pub(crate) mod raw;
mod validate;

use std::path::PathBuf;

use softplc_io::point::{Value, ValueType};

use super::{DocText, ProgramKind};

pub use validate::UserBlockError;
pub(crate) use validate::{instances, load_all};

/// A type with its article, for messages: `a bool`, `an i32`.
pub(crate) fn a_type(ty: ValueType) -> &'static str {
    match ty {
        ValueType::Bool => "a bool",
        ValueType::U16 => "a u16",
        ValueType::I32 => "an i32",
        ValueType::F32 => "an f32",
    }
}

/// A block defined by the engineer, read from a block file.
#[derive(Debug, Clone, PartialEq)]
pub struct UserBlock {
    /// The name programs call it by (`STATION`); Rhai calls it in lower case.
    pub name: String,
    /// What it does.
    pub description: Option<DocText>,
    /// The block file it is defined in.
    pub file: PathBuf,
    /// Where its `name:` is in that file (1-based line and column).
    pub name_at: (usize, usize),
    /// Its inputs, in call order; the first is the power flow (a bool).
    pub inputs: Vec<BlockVar>,
    /// Its outputs; the first is the main output (a bool).
    pub outputs: Vec<BlockVar>,
    /// What it keeps from scan to scan.
    pub state: Vec<BlockVar>,
    /// The instances of other blocks of one's own its body calls.
    pub instances: Vec<NestedInstance>,
    /// The body's program file.
    pub body: PathBuf,
    /// The body's language (ladder or Rhai).
    pub body_kind: ProgramKind,
}

/// Which part of a block a variable is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarRole {
    /// An input: the call writes it, the body reads it.
    Input,
    /// An output: the body writes it, the caller reads it.
    Output,
    /// State: the body's own.
    State,
}

impl VarRole {
    /// The word the docs and messages use.
    pub fn word(self) -> &'static str {
        match self {
            VarRole::Input => "input",
            VarRole::Output => "output",
            VarRole::State => "state variable",
        }
    }
}

/// An input, output or state variable of a block.
#[derive(Debug, Clone, PartialEq)]
pub struct BlockVar {
    /// Its name.
    pub name: String,
    /// Its type.
    pub ty: ValueType,
    /// Its value at start-up (a state's `initial`, an input's `default`; zero otherwise).
    pub initial: Value,
    /// Whether a call may leave it out (an input with a `default:`).
    pub optional: bool,
    /// A state variable kept across a restart (`retain: true`).
    pub retain: bool,
    /// What it is.
    pub description: Option<DocText>,
}

impl UserBlock {
    /// Every variable with its role, in the order of an instance's tags: inputs, outputs,
    /// state.
    pub fn vars(&self) -> impl Iterator<Item = (VarRole, &BlockVar)> {
        fn with(role: VarRole, v: &[BlockVar]) -> impl Iterator<Item = (VarRole, &BlockVar)> {
            v.iter().map(move |x| (role, x))
        }
        with(VarRole::Input, &self.inputs)
            .chain(with(VarRole::Output, &self.outputs))
            .chain(with(VarRole::State, &self.state))
    }

    /// The function Rhai calls it by: its name in lower case.
    pub fn function(&self) -> String {
        self.name.to_ascii_lowercase()
    }
}

/// An instance declared inside a block (its `instances:`), which the block's body calls.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NestedInstance {
    /// Its name: the body reads its pins as `NAME.PIN`.
    pub name: String,
    /// The block it is an instance of, by name (a block of the project's files).
    pub block: String,
    /// Where its `block:` is in the block file (1-based line and column).
    pub block_at: (usize, usize),
}

/// A variable of an instance's whole tree: its block's own variables, then each nested
/// instance's, named `NESTED.VARIABLE` (and deeper `NESTED.INNER.VARIABLE`).
#[derive(Debug, Clone, PartialEq)]
pub struct TreeVar<'a> {
    /// Its name as the block's body reads it (`done`, `v.open`).
    pub name: String,
    /// Its role in the block that declares it.
    pub role: VarRole,
    /// Whether it is the block's own (not a nested instance's).
    pub own: bool,
    /// The variable.
    pub var: &'a BlockVar,
}

impl UserBlock {
    /// Every variable of an instance of this block with its nested instances' (found by
    /// name in `blocks`), in the order of the instance's tags and image. Validation refuses
    /// recursion, so the tree is finite; a nested block not found contributes nothing.
    pub fn tree<'a>(&'a self, blocks: &'a [UserBlock]) -> Vec<TreeVar<'a>> {
        let mut out: Vec<TreeVar<'a>> = self
            .vars()
            .map(|(role, var)| TreeVar {
                name: var.name.clone(),
                role,
                own: true,
                var,
            })
            .collect();
        for nested in &self.instances {
            if let Some(block) = blocks.iter().find(|b| b.name == nested.block) {
                out.extend(block.tree(blocks).into_iter().map(|v| TreeVar {
                    name: format!("{}.{}", nested.name, v.name),
                    own: false,
                    ..v
                }));
            }
        }
        out
    }
}

/// An instance of a block of one's own, declared by the project (`instances:`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlockInstance {
    /// Its name: its variables are the tags `NAME.VARIABLE`.
    pub name: String,
    /// Its block, an index into [`super::Project::blocks`].
    pub block: usize,
    /// The project's tag of its first variable; the others follow in [`UserBlock::vars`]
    /// order.
    pub first_tag: usize,
}
