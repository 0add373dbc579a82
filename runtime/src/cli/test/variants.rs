//! A scenario's `programs:`: the program variants it is run with, once each, all to the same
//! trace (a ladder and a Rhai version of one machine).
//!
//! ```yaml
//! programs: [stairway.ladder.yaml, stairway.rhai]          # one task: one program each
//! programs: [[press.ladder.yaml, count.rhai], press.rhai]  # one task: several in order
//! programs:                                                # several tasks: by task name
//!   - { press: press.ladder.yaml, panel: panel.ladder.yaml }
//!   - { press: press.rhai, panel: [panel.rhai] }           # a task not named keeps its own
//! ```
//!
//! Every file is relative to the scenario file, its language told by its name; an unknown
//! task and a bare file for a project of several tasks are refused at their line.

use std::collections::BTreeMap;
use std::path::Path;

use schemars::JsonSchema;
use serde::Deserialize;

use super::scenario::{kind_of, ProgramSpec};
use crate::project::span::YPath;
use crate::project::Project;

/// One entry of `programs:`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(
    untagged,
    expecting = "a program file, a list of program files (run in this order), or a mapping of \
                 task names to those"
)]
pub(crate) enum RawVariant {
    /// The programs of the project's one task (`main`).
    Main(RawFiles),
    /// By task name, the programs of each task named; the others keep the project's.
    Tasks(BTreeMap<String, RawFiles>),
}

/// One program file, or several run in this order in one task.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(untagged, expecting = "a program file or a list of program files")]
pub(crate) enum RawFiles {
    /// One file: `stairway.rhai`.
    One(String),
    /// Several, in running order: `[press.ladder.yaml, count.rhai]`.
    Many(Vec<String>),
}

impl RawFiles {
    fn files(&self) -> Vec<&str> {
        match self {
            RawFiles::One(f) => vec![f.as_str()],
            RawFiles::Many(list) => list.iter().map(String::as_str).collect(),
        }
    }
}

/// A program variant: the programs that replace some tasks' programs for one run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramVariant {
    /// How the report names the run: `stairway.rhai`, `press.ladder.yaml + count.rhai`,
    /// `press: press.rhai, panel: panel.rhai`.
    pub label: String,
    /// Per task replaced (an index into the project's tasks, in task order), its programs
    /// in running order.
    pub tasks: Vec<(usize, Vec<ProgramSpec>)>,
}

impl ProgramVariant {
    /// `project` with this variant's programs.
    pub(crate) fn apply(&self, project: &mut Project) {
        for (task, programs) in &self.tasks {
            let configs = programs
                .iter()
                .map(|p| crate::project::ProgramConfig {
                    path: p.path.clone(),
                    kind: p.kind,
                })
                .collect();
            project.set_programs(*task, configs);
        }
    }
}

/// Reads `programs:` (at `at`) against `project`, files relative to `folder`: the variants,
/// and every error with its place.
pub(crate) fn read(
    raw: &[RawVariant],
    folder: &Path,
    project: &Project,
    at: &YPath,
) -> (Vec<ProgramVariant>, Vec<(YPath, String)>) {
    let mut errors = Vec::new();
    let mut variants = Vec::new();
    let task_names: Vec<&str> = project.tasks.iter().map(|t| t.name.as_str()).collect();
    for (i, variant) in raw.iter().enumerate() {
        let here = at.index(i);
        let mut tasks = Vec::new();
        match variant {
            RawVariant::Main(_) if project.multitask() => errors.push((
                here,
                format!(
                    "this project has several tasks ({}): name the task each program is for, \
                     `{{ {}: FILE, ... }}`",
                    task_names.join(", "),
                    task_names.first().copied().unwrap_or("TASK")
                ),
            )),
            RawVariant::Main(files) => {
                if let Some(specs) = specs(files, folder, &here, &mut errors) {
                    tasks.push((0, specs));
                }
            }
            RawVariant::Tasks(by_task) => {
                for (name, files) in by_task {
                    let Some(task) = task_names.iter().position(|t| t == name) else {
                        errors.push((
                            here.key_itself(name),
                            format!(
                                "unknown task `{name}` (the project's tasks: {}){}",
                                task_names.join(", "),
                                crate::suggest::did_you_mean(name, task_names.iter().copied())
                            ),
                        ));
                        continue;
                    };
                    if let Some(specs) = specs(files, folder, &here.key(name), &mut errors) {
                        tasks.push((task, specs));
                    }
                }
                if by_task.is_empty() {
                    errors.push((here, "an empty variant: name at least one task".into()));
                }
            }
        }
        tasks.sort_by_key(|(t, _)| *t);
        let label = label(&tasks, project);
        variants.push(ProgramVariant { label, tasks });
    }
    (variants, errors)
}

/// The files of one task's entry (at `at`), each checked: known language, existing file.
fn specs(
    files: &RawFiles,
    folder: &Path,
    at: &YPath,
    errors: &mut Vec<(YPath, String)>,
) -> Option<Vec<ProgramSpec>> {
    let names = files.files();
    if names.is_empty() {
        errors.push((
            at.clone(),
            "an empty list: give at least one program file".into(),
        ));
        return None;
    }
    let mut specs = Vec::with_capacity(names.len());
    for (j, name) in names.iter().enumerate() {
        let place = match files {
            RawFiles::One(_) => at.clone(),
            RawFiles::Many(_) => at.index(j),
        };
        let path = folder.join(name);
        match (kind_of(&path), path.is_file()) {
            (Some(kind), true) => specs.push(ProgramSpec { path, kind }),
            (None, _) => errors.push((
                place,
                format!(
                    "{name}: the language is told by the file name: .yaml (ladder), .rhai or .expr"
                ),
            )),
            (_, false) => errors.push((place, format!("no program file {}", path.display()))),
        }
    }
    (specs.len() == names.len()).then_some(specs)
}

/// How the report names a run with the project's own programs, as a variant's label would.
pub(crate) fn own_label(project: &Project) -> String {
    let tasks: Vec<(usize, Vec<ProgramSpec>)> = project
        .tasks
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let specs = t.programs.iter().map(|p| ProgramSpec {
                path: p.path.clone(),
                kind: p.kind,
            });
            (i, specs.collect())
        })
        .collect();
    label(&tasks, project)
}

/// The report's name of a variant.
fn label(tasks: &[(usize, Vec<ProgramSpec>)], project: &Project) -> String {
    let files = |specs: &[ProgramSpec]| {
        specs
            .iter()
            .map(|p| {
                p.path
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
            })
            .collect::<Vec<_>>()
            .join(" + ")
    };
    if !project.multitask() {
        return tasks.first().map_or_else(String::new, |(_, s)| files(s));
    }
    tasks
        .iter()
        .map(|(t, specs)| {
            let name = project.tasks.get(*t).map_or("", |t| t.name.as_str());
            format!("{name}: {}", files(specs))
        })
        .collect::<Vec<_>>()
        .join(", ")
}
