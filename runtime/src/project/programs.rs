//! A task's programs as one: the identity the flight recorder and a reload give them, and
//! the name reports call them by. A task runs one program or several (`programs:`); every
//! place that stands for "the program" (the record's header, a reload's note, replay's
//! comparison) reads them through here, so a second program is never left out.

use std::io;

use super::model::{ProgramConfig, Project};

impl Project {
    /// The bytes that identify the programs of the project's (first) task: one program's
    /// file as it is (so a record of one program keeps the identity it always had); several
    /// programs' files each preceded by its name and length, in running order, so moving a
    /// line from one file to the next changes the identity.
    pub fn program_source(&self) -> io::Result<Vec<u8>> {
        program_source(&self.programs)
    }

    /// Replaces task `task`'s programs (a scenario's variant runs the project with other
    /// programs): the task's list and, for the first task, [`Project::programs`], kept
    /// alike. An index past the tasks changes nothing.
    pub fn set_programs(&mut self, task: usize, programs: Vec<ProgramConfig>) {
        let Some(t) = self.tasks.get_mut(task) else {
            return;
        };
        t.programs = programs.clone();
        if task == 0 {
            self.programs = programs;
        }
    }

    /// The programs' files as reports name them: `press.ladder.yaml` or
    /// `press.ladder.yaml + guard.rhai`, each as the project resolved it.
    pub fn program_files(&self) -> String {
        program_files(&self.programs)
    }
}

/// [`Project::program_source`] of `programs`.
pub(crate) fn program_source(programs: &[ProgramConfig]) -> io::Result<Vec<u8>> {
    if let [one] = programs {
        return std::fs::read(&one.path);
    }
    let mut out = Vec::new();
    for p in programs {
        let text = std::fs::read(&p.path)?;
        out.extend_from_slice(p.path.display().to_string().as_bytes());
        out.push(0);
        out.extend_from_slice(&(text.len() as u64).to_le_bytes());
        out.extend_from_slice(&text);
    }
    Ok(out)
}

/// [`Project::program_files`] of `programs`.
pub(crate) fn program_files(programs: &[ProgramConfig]) -> String {
    programs
        .iter()
        .map(|p| p.path.display().to_string())
        .collect::<Vec<_>>()
        .join(" + ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::project::ProgramKind;

    fn program(dir: &std::path::Path, name: &str, text: &str) -> ProgramConfig {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        ProgramConfig {
            path,
            kind: ProgramKind::Expr,
        }
    }

    #[test]
    fn one_program_is_its_file_and_several_are_told_apart_by_their_boundaries() {
        let dir = std::env::temp_dir().join(format!("softplc-programs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let a = program(&dir, "a.expr", "x = y\n");
        assert_eq!(
            program_source(std::slice::from_ref(&a)).unwrap(),
            b"x = y\n"
        );
        let b = program(&dir, "b.expr", "z = x\n");
        let both = program_source(&[a.clone(), b.clone()]).unwrap();
        // The same text cut elsewhere between the two files is another identity.
        let a2 = program(&dir, "a.expr", "x = y\nz = x\n");
        let b2 = program(&dir, "b.expr", "");
        assert_ne!(both, program_source(&[a2, b2]).unwrap());
        assert!(program_files(&[a, b]).ends_with("b.expr"));
        let gone = ProgramConfig {
            path: dir.join("gone.expr"),
            kind: ProgramKind::Expr,
        };
        assert!(program_source(&[gone]).is_err());
        drop(std::fs::remove_dir_all(&dir));
    }
}
