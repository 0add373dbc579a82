//! A task's share of the plant services in a PLC of several tasks: the tags it owns and its
//! modules. Each task's cycle boundary publishes its share into the services' one snapshot
//! and feeds its share's changes into their one change stream, at its own cycle end and with
//! its own timestamps, so a fast task's changes are not held to a slow task's period.

use crate::image::TagId;
use crate::logic::Ownership;
use crate::project::Project;

/// What one task publishes and feeds (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TaskShare {
    /// The task: its index in `Project::tasks`.
    task: usize,
    /// How many tasks the project runs.
    tasks: usize,
    /// Per tag (project order): whether this task publishes it. A memory tag nobody writes
    /// is the first task's, which answers the writes of it.
    owned: Vec<bool>,
    /// Each of the task's modules' index in the project, in the task's order (the project's
    /// order, as its view lists them).
    modules: Vec<usize>,
    /// The project's module count.
    all_modules: usize,
}

impl TaskShare {
    /// Task `task`'s share of `project` whose tags `ownership` assigns.
    pub(crate) fn of(project: &Project, ownership: &Ownership, task: usize) -> Self {
        let owned = (0..project.tags.len())
            .map(|t| match ownership.owner(TagId(t as u32)) {
                Some(owner) => owner == task,
                None => task == 0,
            })
            .collect();
        let modules = project
            .modules
            .iter()
            .enumerate()
            .filter(|(_, m)| project.task_of_bus(m.bus) == task)
            .map(|(i, _)| i)
            .collect();
        Self {
            task,
            tasks: project.tasks.len(),
            owned,
            modules,
            all_modules: project.modules.len(),
        }
    }

    /// Every task's share of `project`, in task order: what each task's boundary feeds the
    /// services in `softplc run`, and the alarm book of a scenario.
    pub(crate) fn all(project: &Project, ownership: &Ownership) -> Vec<Self> {
        (0..project.tasks.len())
            .map(|i| Self::of(project, ownership, i))
            .collect()
    }

    /// The task's index.
    pub(crate) fn task(&self) -> usize {
        self.task
    }

    /// How many tasks the project runs.
    pub(crate) fn tasks(&self) -> usize {
        self.tasks
    }

    /// Whether this task publishes tag `tag` (its index in the project).
    pub(crate) fn owns(&self, tag: usize) -> bool {
        self.owned.get(tag).copied().unwrap_or(false)
    }

    /// The tags this task publishes, in tag order.
    pub(crate) fn tags(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.owned.len()).filter(|&t| self.owned[t])
    }

    /// The project's index of the task's module `local` (its index in the task's PLC).
    pub(crate) fn module(&self, local: usize) -> Option<usize> {
        self.modules.get(local).copied()
    }

    /// The project's index of each of the task's modules, in the task's order.
    pub(crate) fn modules(&self) -> &[usize] {
        &self.modules
    }

    /// The project's module count.
    pub(crate) fn all_modules(&self) -> usize {
        self.all_modules
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_share_holds_its_tasks_tags_and_modules_at_their_project_places() {
        let project = crate::project::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../examples/two-tasks/project.yaml"),
        )
        .expect("the example loads");
        let builder = crate::plc::TaskBuilder::new(&project, None, None).expect("it compiles");
        let ownership = builder.ownership();
        let panel = TaskShare::of(&project, ownership, 1);
        let names: Vec<&str> = panel
            .tags()
            .map(|t| project.tags[t].name.as_str())
            .collect();
        assert_eq!(names, ["key_on", "running_lamp", "guard_lamp", "enabled"]);
        // Its first module is the project's fifth (keys), its last the twelfth.
        assert_eq!(panel.module(0), Some(4));
        assert_eq!(panel.module(7), Some(11));
        assert_eq!(panel.module(8), None);
        assert_eq!(
            (panel.task(), panel.tasks(), panel.all_modules()),
            (1, 2, 12)
        );
        let press = TaskShare::of(&project, ownership, 0);
        assert!(
            press.owns(5) && !press.owns(6),
            "strokes is the press's, key_on not"
        );
        assert_eq!(press.module(3), Some(3));
    }
}

#[cfg(test)]
#[path = "task_share_tests.rs"]
mod run_tests;
