//! Loading a project's program: read the file, compile it against the project's tags.

use std::fmt;
use std::path::PathBuf;

use softplc_io::point::Access;

use crate::image::{ProcessImage, TagId};
use crate::logic::expr;
use crate::logic::LogicEngine;
use crate::project::{Binding, ProgramKind, Project};

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
    /// The program has errors; every one is listed.
    #[error("{}", CompileErrors(.0))]
    Compile(Vec<expr::CompileError>),
}

struct CompileErrors<'a>(&'a [expr::CompileError]);

impl fmt::Display for CompileErrors<'_> {
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
pub fn writable(project: &Project, tag: usize) -> bool {
    match project.tags[tag].binding {
        Binding::Memory => true,
        Binding::Point { module, point } => {
            project.modules[module].model.points[point].access == Access::Output
        }
    }
}

/// Compiles the project's program against its tags (ids as in `image`).
pub fn load_program(
    project: &Project,
    image: &ProcessImage,
) -> Result<Box<dyn LogicEngine>, ProgramError> {
    let path = &project.program.path;
    let source = std::fs::read_to_string(path).map_err(|source| ProgramError::Read {
        path: path.clone(),
        source,
    })?;
    match project.program.kind {
        ProgramKind::Expr => {
            let table = expr::TagTable::new(project.tags.iter().enumerate().map(|(i, t)| {
                let id = TagId(i as u32);
                debug_assert_eq!(image.name(id), t.name);
                (t.name.clone(), id, t.ty, writable(project, i))
            }));
            let program = expr::compile(&source, path, &table).map_err(ProgramError::Compile)?;
            Ok(Box::new(program))
        }
    }
}
