//! Which task owns each tag: the one rule that makes tags shared between tasks predictable.
//!
//! A tag bound to a module's point belongs to the task owning the module's bus (its input is
//! published by that task, its output written by it); a memory tag belongs to the task whose
//! program writes it. Every tag has at most one writing task: a second writer, or a task
//! writing an output of a bus another task owns, is refused with the place it writes it.
//! A tag nobody writes (a memory constant) belongs to no task: every task keeps its initial
//! value.

use crate::image::TagId;
use crate::logic::{LogicEngine, SourcePos};
use crate::project::{Binding, Project};

/// Why a tag cannot have the writers the programs give it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OwnershipError {
    /// Two tasks' programs write one tag.
    #[error(
        "{at}: error: tag `{tag}` is written by task `{task}` here and by task `{first}` at \
         {first_at}; every tag has one writing task: write it in one and read it in the other"
    )]
    TwoWriters {
        /// The tag.
        tag: String,
        /// The second writing task (in task order).
        task: String,
        /// Where it writes the tag.
        at: SourcePos,
        /// The first writing task.
        first: String,
        /// Where that one writes it.
        first_at: SourcePos,
    },
    /// A task writes an output of a bus another task owns.
    #[error(
        "{at}: error: tag `{tag}` is an output of bus `{bus}`, which task `{owner}` owns; \
         task `{task}` writes it here: only the task owning a bus writes its outputs (compute \
         the value in `{task}` into a memory tag and copy it in `{owner}`)"
    )]
    ForeignOutput {
        /// The tag.
        tag: String,
        /// Its bus.
        bus: String,
        /// The task owning the bus.
        owner: String,
        /// The task writing it.
        task: String,
        /// Where it writes the tag.
        at: SourcePos,
    },
}

/// The owning task of every tag (index into `Project::tasks`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ownership {
    /// Per tag: its owning task, `None` for a memory tag nobody writes.
    owner: Vec<Option<usize>>,
}

impl Ownership {
    /// Every tag owned by task 0: a project with one task.
    pub fn single(project: &Project) -> Self {
        Self {
            owner: vec![Some(0); project.tags.len()],
        }
    }

    /// The owners given the tasks' compiled programs (`engines[i]` is task `i`'s); every
    /// conflict, in task then program order.
    pub fn find(
        project: &Project,
        engines: &[Box<dyn LogicEngine>],
    ) -> Result<Self, Vec<OwnershipError>> {
        let mut owner: Vec<Option<usize>> = project
            .tags
            .iter()
            .map(|t| match t.binding {
                Binding::Point { module, .. } => {
                    Some(project.task_of_bus(project.modules[module].bus))
                }
                Binding::Memory => None,
            })
            .collect();
        // A memory tag's first writer, where it writes it.
        let mut first: Vec<Option<(usize, SourcePos)>> = vec![None; project.tags.len()];
        let mut errors = Vec::new();
        for (task, engine) in engines.iter().enumerate() {
            for (tag, at) in engine.writes() {
                let i = tag.index();
                let Some(config) = project.tags.get(i) else {
                    continue;
                };
                let name = |t: usize| project.tasks[t].name.clone();
                match config.binding {
                    Binding::Point { module, .. } => {
                        let bus = project.modules[module].bus;
                        let owning = project.task_of_bus(bus);
                        if owning != task {
                            errors.push(OwnershipError::ForeignOutput {
                                tag: config.name.clone(),
                                bus: project.buses[bus].name.clone(),
                                owner: name(owning),
                                task: name(task),
                                at,
                            });
                        }
                    }
                    Binding::Memory => match &first[i] {
                        Some((t, first_at)) if *t != task => {
                            errors.push(OwnershipError::TwoWriters {
                                tag: config.name.clone(),
                                task: name(task),
                                at,
                                first: name(*t),
                                first_at: first_at.clone(),
                            });
                        }
                        Some(_) => {}
                        None => {
                            first[i] = Some((task, at));
                            owner[i] = Some(task);
                        }
                    },
                }
            }
        }
        if errors.is_empty() {
            Ok(Self { owner })
        } else {
            Err(errors)
        }
    }

    /// The task owning `tag` (`None`: a memory tag no program writes).
    pub fn owner(&self, tag: TagId) -> Option<usize> {
        self.owner.get(tag.index()).copied().flatten()
    }

    /// The tags task `task` owns, in tag order.
    pub fn owned_by(&self, task: usize) -> Vec<TagId> {
        self.tags_where(|o| o == Some(task))
    }

    /// The tags another task owns, which task `task` copies in at its cycle's start.
    pub fn foreign_to(&self, task: usize) -> Vec<TagId> {
        self.tags_where(|o| o.is_some_and(|o| o != task))
    }

    fn tags_where(&self, keep: impl Fn(Option<usize>) -> bool) -> Vec<TagId> {
        (0u32..)
            .zip(&self.owner)
            .filter(|(_, o)| keep(**o))
            .map(|(i, _)| TagId(i))
            .collect()
    }
}
