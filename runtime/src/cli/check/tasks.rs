//! `check`'s tasks section: each task's timing, program, buses and the tags it owns (writes
//! and publishes to the others), then the tags no task writes.

use std::fmt::Write;

use crate::logic::{LogicEngine, Ownership};
use crate::project::Project;

/// The section, for a project with several tasks.
pub(super) fn report(
    project: &Project,
    engines: &[Box<dyn LogicEngine>],
    ownership: &Ownership,
) -> String {
    let mut out = String::from(
        "\ntasks (each copies the tags it does not own at its cycle's start and publishes the \
         tags it owns at its cycle's end):\n",
    );
    for (i, task) in project.tasks.iter().enumerate() {
        let scan = &task.scan;
        let priority = scan
            .realtime
            .priority
            .map_or(String::new(), |p| format!(", SCHED_FIFO priority {p}"));
        let _ = writeln!(
            out,
            "  task {}: {}{priority}",
            task.name,
            super::timing(scan)
        );
        out.push_str(&super::programs::lines(&task.programs, "    "));
        if let Some(line) = engines.get(i).and_then(|e| e.execution()) {
            let _ = writeln!(out, "      {line}");
        }
        let buses: Vec<&str> = task
            .buses
            .iter()
            .map(|&b| project.buses[b].name.as_str())
            .collect();
        let _ = writeln!(out, "    buses: {}", list(&buses));
        let owned = names(project, &ownership.owned_by(i));
        let _ = writeln!(out, "    owns: {}", list(&owned));
    }
    let constants: Vec<&str> = project
        .tags
        .iter()
        .enumerate()
        .filter(|(i, _)| ownership.owner(crate::image::TagId(*i as u32)).is_none())
        .map(|(_, t)| t.name.as_str())
        .collect();
    if !constants.is_empty() {
        let _ = writeln!(
            out,
            "  written by no task (each task keeps its initial value): {}",
            constants.join(", ")
        );
    }
    out
}

fn names<'p>(project: &'p Project, tags: &[crate::image::TagId]) -> Vec<&'p str> {
    tags.iter()
        .map(|t| project.tags[t.index()].name.as_str())
        .collect()
}

fn list(items: &[&str]) -> String {
    if items.is_empty() {
        "none".to_owned()
    } else {
        items.join(", ")
    }
}
