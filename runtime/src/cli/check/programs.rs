//! `check`'s lines about a task's programs: each program with its language, in running
//! order, and a warning for every tag two programs of one task write.

use std::fmt::Write;

use crate::logic::LogicEngine;
use crate::project::{ProgramConfig, Project};

/// One line per program, `{indent}program FILE (Kind)`, in running order.
pub(super) fn lines(programs: &[ProgramConfig], indent: &str) -> String {
    let mut out = String::new();
    for p in programs {
        let _ = writeln!(out, "{indent}program {} ({:?})", p.path.display(), p.kind);
    }
    out
}

/// A warning for every tag two programs of one task write (`engines[i]` is task `i`'s): it
/// runs, the later program's value standing at the cycle's end, but it is rarely meant.
pub(super) fn shared_write_warnings(project: &Project, engines: &[Box<dyn LogicEngine>]) -> String {
    let mut out = String::new();
    for (task, engine) in project.tasks.iter().zip(engines) {
        for w in engine.shared_writes() {
            let tag = project
                .tags
                .get(w.tag.index())
                .map_or_else(|| format!("#{}", w.tag.index()), |t| t.name.clone());
            let _ = writeln!(
                out,
                "{}: warning: tag `{tag}` is also written by an earlier program of task `{}` \
                 at {}; both run in every cycle of the task, one after the other: the value \
                 this later program writes is the one that stands at the cycle's end",
                w.then, task.name, w.first
            );
        }
    }
    out
}
