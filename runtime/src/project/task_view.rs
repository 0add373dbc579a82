//! One task's view of a project: the project as that task runs it on its own thread.
//!
//! A task's view has the task's timing and program, only the buses it owns with their
//! modules, and every tag at its place (tag ids are the same in every view, so the tasks'
//! images and the exchange between them index tags alike). A tag bound to a point of another
//! task's bus is a memory tag in the view: the owning task does its I/O and publishes it.
//! Retained tags are kept by the task that owns them, each task in a file of its own. A
//! project trace is in the view of every task that can sample it (all its module counters on
//! the task's buses).

use std::path::PathBuf;

use super::model::{Binding, CopiedIo, Project, TaskConfig};
use super::trace::{Probe, TraceConfig};

impl Project {
    /// The view of task `task` (an index into [`Project::tasks`]); `owned(tag)`: whether the
    /// task owns the tag (it keeps it retained). A project with one task is its own view.
    pub fn task_view(&self, task: usize, owned: impl Fn(usize) -> bool) -> Project {
        if !self.multitask() {
            return self.clone();
        }
        let Some(config) = self.tasks.get(task) else {
            return self.clone();
        };
        let mut buses: Vec<usize> = config.buses.clone();
        buses.sort_unstable();
        // Project module index → the view's, for the modules on the task's buses.
        let mut module_index: Vec<Option<usize>> = vec![None; self.modules.len()];
        let mut modules = Vec::new();
        for (m, module) in self.modules.iter().enumerate() {
            if let Some(b) = buses.iter().position(|&b| b == module.bus) {
                module_index[m] = Some(modules.len());
                let mut module = module.clone();
                module.bus = b;
                modules.push(module);
            }
        }
        let mut copied_io = Vec::new();
        let tags = self
            .tags
            .iter()
            .enumerate()
            .map(|(i, tag)| {
                let mut tag = tag.clone();
                match tag.binding {
                    Binding::Point { module, point } => match module_index[module] {
                        Some(module) => tag.binding = Binding::Point { module, point },
                        None => {
                            // Another task's I/O: a value this task copies in, never writes.
                            tag.binding = Binding::Memory;
                            tag.safe = None;
                            let bus = self.modules[module].bus;
                            copied_io.push(CopiedIo {
                                tag: i,
                                task: self.tasks[self.task_of_bus(bus)].name.clone(),
                                bus: self.buses[bus].name.clone(),
                            });
                        }
                    },
                    Binding::Memory => tag.retain &= owned(i),
                }
                tag
            })
            .collect();
        let mut retain = self.retain.clone();
        retain.file = task_file(&retain.file, &config.name);
        Project {
            name: self.name.clone(),
            source: self.source.clone(),
            scan: config.scan.clone(),
            tasks: vec![TaskConfig {
                buses: (0..buses.len()).collect(),
                copied_io,
                ..config.clone()
            }],
            buses: buses.iter().map(|&b| self.buses[b].clone()).collect(),
            modules,
            tags,
            programs: config.programs.clone(),
            blocks: self.blocks.clone(),
            instances: self.instances.clone(),
            alarms: self.alarms.clone(),
            // The plant runs in the world all tasks share, attached once (plc::tasks).
            plant: None,
            service: self.service.clone(),
            retain,
            offload: self.offload.clone(),
            recorder: self.recorder.clone(),
            traces: self
                .traces
                .iter()
                .filter_map(|t| traced_in(t, &module_index))
                .collect(),
            trace_budget: self.trace_budget,
        }
    }
}

/// Trace `t` as a task samples it, its module counters at the view's module indexes; `None`
/// when it reads a counter of a module another task polls (its counters are that task's).
fn traced_in(t: &TraceConfig, module_index: &[Option<usize>]) -> Option<TraceConfig> {
    let probe = |p: Probe| match p {
        Probe::Counter { module, counter } => Some(Probe::Counter {
            module: (*module_index.get(module)?)?,
            counter,
        }),
        other => Some(other),
    };
    let mut t = t.clone();
    for p in &mut t.probes {
        *p = probe(*p)?;
    }
    if let Some(trigger) = &mut t.trigger {
        trigger.probe = probe(trigger.probe)?;
    }
    Some(t)
}

/// `pump.retain.json` → `pump.retain.fast.json` for task `fast`: each task writes its own
/// retained tags, so two task threads never write one file.
pub(crate) fn task_file(file: &std::path::Path, task: &str) -> PathBuf {
    let name = file
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let named = match name.rsplit_once('.') {
        Some((stem, ext)) => format!("{stem}.{task}.{ext}"),
        None => format!("{name}.{task}"),
    };
    file.with_file_name(named)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retain_files_are_named_by_task() {
        assert_eq!(
            task_file(std::path::Path::new("/s/p.retain.json"), "fast"),
            PathBuf::from("/s/p.retain.fast.json")
        );
        assert_eq!(
            task_file(std::path::Path::new("retain"), "slow"),
            PathBuf::from("retain.slow")
        );
    }
}
