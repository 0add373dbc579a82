//! Loading a project's program: read the file, compile it against the project's tags.

use std::fmt;
use std::path::PathBuf;
use std::time::Duration;

use softplc_io::point::Access;

use crate::image::{ProcessImage, TagId};
use crate::logic::ownership::{Ownership, OwnershipError};
use crate::logic::{expr, ladder, rhai, user_blocks};
use crate::logic::{LogicEngine, Programs};
use crate::project::{Binding, ProgramConfig, ProgramKind, Project, ScanConfig};

/// Why a program could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ProgramError {
    /// The file could not be read.
    #[error("{}: cannot read the program: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The `expr` program has errors; every one is listed.
    #[error("{}", Lines(.0))]
    Compile(Vec<expr::CompileError>),
    /// The ladder program has errors; every one is listed.
    #[error("{}", Lines(.0))]
    Ladder(Vec<ladder::CompileError>),
    /// The Rhai script has errors.
    #[error("{}", Lines(.0))]
    Rhai(Vec<rhai::CompileError>),
    /// Blocks of one's own that cannot join the block registry.
    #[error("{}", Lines(.0))]
    OwnBlock(Vec<crate::logic::OwnBlockError>),
    /// Tags written by two tasks, or a bus's output written by a task not owning the bus;
    /// every one is listed.
    #[error("{}", Lines(.0))]
    Ownership(Vec<OwnershipError>),
    /// Several programs (of one task or of several) have errors.
    #[error("{}", Lines(.0))]
    Several(Vec<ProgramError>),
}

/// One error per line.
struct Lines<'a, T>(&'a [T]);

impl<T: fmt::Display> fmt::Display for Lines<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

/// Whether the program may write a tag: memory tags and tags bound to module outputs.
pub(crate) fn writable(project: &Project, tag: usize) -> bool {
    match project.tags[tag].binding {
        Binding::Memory => true,
        Binding::Point { module, point } => {
            project.modules[module].model.points[point].access == Access::Output
        }
    }
}

/// The project's tags as programs see them (ids as in `image`).
pub fn tag_table(project: &Project, image: &ProcessImage) -> expr::TagTable {
    expr::TagTable::new(project.tags.iter().enumerate().map(|(i, t)| {
        let id = TagId(i as u32);
        debug_assert_eq!(image.name(id), t.name);
        // An instance's tags are its own: a program reads them, only its calls write them.
        let own = project
            .instances
            .first()
            .is_some_and(|inst| i >= inst.first_tag);
        (t.name.clone(), id, t.ty, writable(project, i) && !own)
    }))
}

/// The time one scan of a script may take before it is stopped: the task watchdog's time (at
/// least half a period), so a runaway script faults the PLC before the watchdog's limit while a
/// script that was merely preempted on a busy machine is not a fault. The operation limit stops
/// runaway loops deterministically on any clock; this wall-clock guard is the backstop.
pub(crate) fn script_budget(scan: &ScanConfig) -> Duration {
    // The guard against a runaway script: the task watchdog's time, not a share of the period,
    // so a script preempted once on a busy machine is not a fault (the watchdog decides that).
    scan.watchdog.time.max(scan.period / 2)
}

/// Compiles the project's (first task's) programs against its tags (ids as in `image`):
/// one engine running them in order. The one loader of a task's programs: the build, a
/// reload and replay all come through here.
pub fn load_program(
    project: &Project,
    image: &ProcessImage,
) -> Result<Box<dyn LogicEngine>, ProgramError> {
    load_task_programs(project, &project.programs, &project.scan, image)
}

/// Compiles every task's program against the project's tags (ids as in `image`), in task
/// order, and finds which task owns each tag; every compile error of every task, or every
/// tag with two writing tasks, is reported.
pub fn load_tasks(
    project: &Project,
    image: &ProcessImage,
) -> Result<(Vec<Box<dyn LogicEngine>>, Ownership), ProgramError> {
    let mut engines = Vec::with_capacity(project.tasks.len());
    let mut failed: Option<ProgramError> = None;
    for task in &project.tasks {
        match load_task_programs(project, &task.programs, &task.scan, image) {
            Ok(engine) => engines.push(engine),
            Err(e) => {
                failed = Some(match failed {
                    None => e,
                    Some(before) => ProgramError::Several(vec![before, e]),
                })
            }
        }
    }
    if let Some(e) = failed {
        return Err(e);
    }
    let ownership = Ownership::find(project, &engines).map_err(ProgramError::Ownership)?;
    Ok((engines, ownership))
}

/// Compiles one task's programs (timed by `scan`) against the project's tags: every
/// program's errors, each naming its file; one engine running them in order.
fn load_task_programs(
    project: &Project,
    programs: &[ProgramConfig],
    scan: &ScanConfig,
    image: &ProcessImage,
) -> Result<Box<dyn LogicEngine>, ProgramError> {
    if let [one] = programs {
        return load_one(project, one, scan, image);
    }
    let mut parts = Vec::with_capacity(programs.len());
    let mut errors = Vec::new();
    for program in programs {
        match load_one(project, program, scan, image) {
            Ok(engine) => parts.push(engine),
            Err(e) => errors.push(e),
        }
    }
    match errors.len() {
        0 => Ok(Box::new(Programs::new(parts))),
        1 => Err(errors.remove(0)),
        _ => Err(ProgramError::Several(errors)),
    }
}

/// Compiles one program (`program`, timed by `scan`) against the project's tags.
fn load_one(
    project: &Project,
    program: &ProgramConfig,
    scan: &ScanConfig,
    image: &ProcessImage,
) -> Result<Box<dyn LogicEngine>, ProgramError> {
    let path = &program.path;
    let source = std::fs::read_to_string(path).map_err(|source| ProgramError::Read {
        path: path.clone(),
        source,
    })?;
    let table = tag_table(project, image);
    let own = user_blocks::build(project, &table, script_budget(scan))?;
    Ok(match program.kind {
        ProgramKind::Expr => {
            Box::new(expr::compile(&source, path, &table).map_err(ProgramError::Compile)?)
        }
        ProgramKind::Ladder => Box::new(
            ladder::compile_with(&source, path, &table, own).map_err(ProgramError::Ladder)?,
        ),
        ProgramKind::Rhai => Box::new(
            rhai::compile_calling(&source, path, &table, script_budget(scan), own)
                .map_err(ProgramError::Rhai)?,
        ),
    })
}
