//! A reload in one task of several: what it checks beyond a single task's reload.
//!
//! The task's new program is compiled against its view of the project as read now, like at
//! start. The tags shared between tasks were settled at start (each task publishes the tags
//! it owns, copies in the others'), so a reload may not change who writes a tag: a tag the new
//! program writes must be one its task owns already. And a reload of every task (`softplc
//! reload`, SIGHUP) swaps only the programs whose files changed: the others say so and run on
//! untouched.

use std::sync::Arc;

use crate::image::TagId;
use crate::logic::{LogicEngine, Ownership, SourcePos};
use crate::project::Project;
use crate::recorder::format::{digest, Digest};

use super::error::ReloadError;

/// Who owns each tag among the tasks of one PLC, and the tasks' names.
#[derive(Debug)]
pub(crate) struct TaskOwners {
    /// The owner of every tag, as settled at start.
    pub(crate) ownership: Ownership,
    /// The tasks' names, in project order.
    pub(crate) names: Vec<String>,
    /// The tags' names, by id.
    pub(crate) tag_names: Vec<String>,
}

/// A tag a task's new program writes that its task does not own.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ForeignWrite {
    /// Another task writes it.
    #[error(
        "{at}: error: tag `{tag}` is written by task `{owner}`; task `{task}`'s new program \
         writes it here: every tag has one writing task (write it in one, read it in the other)"
    )]
    Owned {
        /// The tag.
        tag: String,
        /// The task reloaded.
        task: String,
        /// The task writing it.
        owner: String,
        /// Where the new program writes it.
        at: SourcePos,
    },
    /// No task's running program writes it: the others do not copy it in, so its new value
    /// would stay in this task.
    #[error(
        "{at}: error: tag `{tag}` is written by no task's running program; task `{task}`'s new \
         program writes it here, but the tasks' shared tags were settled at start: restart to \
         make `{task}` its writer"
    )]
    Unowned {
        /// The tag.
        tag: String,
        /// The task reloaded.
        task: String,
        /// Where the new program writes it.
        at: SourcePos,
    },
}

/// What a task's PLC keeps for its reloads.
#[derive(Debug, Clone)]
pub(crate) struct TaskReload {
    /// The task (an index into the project's tasks).
    task: usize,
    owners: Arc<TaskOwners>,
    /// The running program's sources, as last compiled.
    sources: Digest,
}

impl TaskReload {
    /// Task `task`'s, running the program of `view` (its view of the project).
    pub(crate) fn new(task: usize, owners: Arc<TaskOwners>, view: &Project) -> Self {
        Self {
            task,
            owners,
            sources: sources(view),
        }
    }

    fn name(&self) -> &str {
        self.owners.names.get(self.task).map_or("?", String::as_str)
    }

    /// The task's view of `fresh` (the project file as read now); refused when the task is no
    /// longer in it.
    pub(crate) fn view(&self, fresh: &Project) -> Result<Project, ReloadError> {
        let name = self.name();
        let Some(i) = fresh.tasks.iter().position(|t| t.name == name) else {
            return Err(ReloadError::TaskGone { task: name.into() });
        };
        let ownership = &self.owners.ownership;
        Ok(fresh.task_view(i, |t| ownership.owner(TagId(t as u32)) == Some(self.task)))
    }

    /// Whether `view`'s program and block bodies are the ones running (`current`'s).
    pub(crate) fn unchanged(&self, view: &Project, current: &Project) -> bool {
        view.blocks == current.blocks
            && view.instances == current.instances
            && sources(view) == self.sources
    }

    /// Refuses a new program that writes a tag its task does not own.
    pub(crate) fn check_writes(&self, engine: &dyn LogicEngine) -> Result<(), ReloadError> {
        let ownership = &self.owners.ownership;
        let foreign: Vec<ForeignWrite> = engine
            .writes()
            .into_iter()
            .filter_map(|(tag, at)| {
                let task = self.name().to_owned();
                let tag_name = self
                    .owners
                    .tag_names
                    .get(tag.index())
                    .cloned()
                    .unwrap_or_default();
                match ownership.owner(tag) {
                    Some(t) if t == self.task => None,
                    Some(t) => Some(ForeignWrite::Owned {
                        tag: tag_name,
                        task,
                        owner: self.owners.names.get(t).cloned().unwrap_or_default(),
                        at,
                    }),
                    None => Some(ForeignWrite::Unowned {
                        tag: tag_name,
                        task,
                        at,
                    }),
                }
            })
            .collect();
        if foreign.is_empty() {
            Ok(())
        } else {
            Err(ReloadError::ForeignWrites(foreign))
        }
    }

    /// After a swap: the program now running is `view`'s.
    pub(crate) fn swapped(&mut self, sources: Digest) {
        self.sources = sources;
    }
}

/// One identity of the files a task's program is compiled from: the program file and every
/// block body it may call (a file that cannot be read counts as empty: compiling it says why).
pub(crate) fn sources(project: &Project) -> Digest {
    let mut bytes = project.program_source().unwrap_or_default();
    for block in &project.blocks {
        bytes.extend_from_slice(block.body.to_string_lossy().as_bytes());
        bytes.push(0);
        bytes.extend(std::fs::read(&block.body).unwrap_or_default());
    }
    digest(&bytes)
}
