//! The project's blocks of one's own checked against the built-ins, their bodies compiled,
//! and one [`UserInstance`] per declared instance.

use std::time::Duration;

use softplc_io::point::Value;

use super::{OwnBlocks, UserInstance};
use crate::image::{ProcessImage, TagId};
use crate::logic::expr::TagTable;
use crate::logic::load::ProgramError;
use crate::logic::{ladder, rhai, LogicEngine, SourcePos};
use crate::project::{ProgramKind, Project, UserBlock, VarRole};

/// A block of one's own that cannot join the registry.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{pos}: error: block {name} has the name of a built-in {what}; name yours otherwise (built-in blocks: {builtins})")]
pub struct OwnBlockError {
    /// Where the block's `name:` is.
    pub pos: SourcePos,
    /// The name.
    pub name: String,
    /// `block` or `Rhai function`.
    pub what: &'static str,
    /// The built-in blocks, for the message.
    pub builtins: String,
}

/// The table a body compiles against: the block's variables and its nested instances' (see
/// [`UserBlock::tree`]), ids as in its own image; writable are its own outputs and state
/// only (a nested instance's pins are its calls' to write).
fn body_table(block: &UserBlock, blocks: &[UserBlock]) -> (TagTable, ProcessImage) {
    let tree = block.tree(blocks);
    let table = TagTable::new((0u32..).zip(&tree).map(|(i, v)| {
        (
            v.name.clone(),
            TagId(i),
            v.var.ty,
            v.own && v.role != VarRole::Input,
        )
    }));
    let image = ProcessImage::new(tree.iter().map(|v| (v.name.clone(), v.var.initial)));
    (table, image)
}

/// Compiles `block`'s body against its variables, with an instance of its own for each of
/// its nested instances, publishing into the body's image.
fn compile_body(
    block: &UserBlock,
    blocks: &[UserBlock],
    budget: Duration,
) -> Result<(Box<dyn LogicEngine>, ProcessImage), ProgramError> {
    let path = &block.body;
    let source = std::fs::read_to_string(path).map_err(|source| ProgramError::Read {
        path: path.clone(),
        source,
    })?;
    let (table, image) = body_table(block, blocks);
    let mut own = OwnBlocks::for_body(blocks, block);
    for nested in &block.instances {
        let Some(of) = blocks.iter().find(|b| b.name == nested.block) else {
            continue;
        };
        own.instances
            .push(instance(&nested.name, of, blocks, &table, budget)?);
    }
    let engine: Box<dyn LogicEngine> = match block.body_kind {
        ProgramKind::Ladder => Box::new(
            ladder::compile_with(&source, path, &table, own)
                .map_err(|errors| ProgramError::Ladder(in_body(errors, block)))?,
        ),
        ProgramKind::Rhai => Box::new(
            rhai::compile_calling(&source, path, &table, budget, own)
                .map_err(ProgramError::Rhai)?,
        ),
        // The block file's validation takes `.yaml` and `.rhai` only.
        ProgramKind::Expr => {
            return Err(ProgramError::Read {
                path: path.clone(),
                source: std::io::Error::other("a block's body is a ladder file or a Rhai script"),
            })
        }
    };
    Ok((engine, image))
}

/// Instance `name` of `block`, its tags found in `table` as `NAME.VARIABLE` (the project's
/// table, or for a nested instance its outer body's).
fn instance(
    name: &str,
    block: &UserBlock,
    blocks: &[UserBlock],
    table: &TagTable,
    budget: Duration,
) -> Result<UserInstance, ProgramError> {
    let (body, vars) = compile_body(block, blocks, budget)?;
    let tree = block.tree(blocks);
    let tags = tree
        .iter()
        .map(|v| table.get(&format!("{name}.{}", v.name)).map(|e| e.id))
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| ProgramError::Read {
            path: block.file.clone(),
            source: std::io::Error::other(format!("the tags of instance {name} are not declared")),
        })?;
    Ok(UserInstance::new(
        name.to_owned(),
        vars,
        tree.iter().map(|v| v.name.clone()).collect(),
        tree.iter().map(|v| v.var.ty).collect(),
        block.inputs.len(),
        body,
        tags,
    ))
}

/// A body's errors in the block's words: what the program's checker calls a tag is a
/// variable of the block there.
fn in_body(errors: Vec<ladder::CompileError>, block: &UserBlock) -> Vec<ladder::CompileError> {
    use ladder::CompileErrorKind as K;
    let vars: Vec<&str> = block.vars().map(|(_, v)| v.name.as_str()).collect();
    errors
        .into_iter()
        .map(|mut e| {
            e.kind = match e.kind {
                K::WriteToInput { name } => K::OwnBodyWritesInput {
                    name,
                    block: block.name.clone(),
                },
                K::UnknownTag { name, .. } => K::OwnBodyUndeclared {
                    name,
                    block: block.name.clone(),
                    vars: vars.join(", "),
                },
                other => other,
            };
            e
        })
        .collect()
}

/// Names that would shadow the built-in library: a block's, or a Rhai function's.
fn clashes(project: &Project) -> Vec<OwnBlockError> {
    let builtins = crate::logic::blocks::names();
    let mut out = Vec::new();
    for b in &project.blocks {
        let pos = SourcePos {
            file: b.file.clone(),
            line: b.name_at.0 as u32,
            column: b.name_at.1 as u32,
        };
        let what = if crate::logic::Kind::parse(&b.name).is_some() {
            Some("block")
        } else if rhai::signatures::is_library(&b.function()) || b.function() == rhai::OWN_OUTPUT {
            Some("Rhai function")
        } else {
            None
        };
        if let Some(what) = what {
            out.push(OwnBlockError {
                pos,
                name: b.name.clone(),
                what,
                builtins: builtins.clone(),
            });
        }
    }
    out
}

/// Checks every block of the project: its name against the built-ins, its body compiled
/// (whether or not an instance calls it), each error once.
pub(crate) fn check_bodies(project: &Project, budget: Duration) -> Result<(), ProgramError> {
    let clashes = clashes(project);
    if !clashes.is_empty() {
        return Err(ProgramError::OwnBlock(clashes));
    }
    for block in &project.blocks {
        compile_body(block, &project.blocks, budget)?;
    }
    Ok(())
}

/// The registry of the project's blocks with one instance per `instances:` entry; `table` is
/// the project's (each instance's tags are found in it by name).
pub(crate) fn build(
    project: &Project,
    table: &TagTable,
    budget: Duration,
) -> Result<OwnBlocks, ProgramError> {
    check_bodies(project, budget)?;
    let mut instances = Vec::with_capacity(project.instances.len());
    for inst in &project.instances {
        let Some(block) = project.blocks.get(inst.block) else {
            return Err(ProgramError::Read {
                path: project.source.clone(),
                source: std::io::Error::other(format!("instance {} has no block", inst.name)),
            });
        };
        instances.push(instance(&inst.name, block, &project.blocks, table, budget)?);
    }
    let mut own = OwnBlocks::declared(project);
    own.instances = instances;
    Ok(own)
}

/// The value an input takes when a call leaves it out.
pub(crate) fn default_of(block: &UserBlock, input: usize) -> f64 {
    block.inputs.get(input).map_or(0.0, |v| match v.initial {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(x) => f64::from(x),
        Value::I32(x) => f64::from(x),
        Value::F32(x) => f64::from(x),
    })
}
