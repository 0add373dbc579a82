//! The flight recorder of a run of several tasks: each task records its own cycles (numbered
//! as it counts them), with what it copied in from the others, into a folder of its own in
//! the record's folder (`PROJECT.record/TASK/`), so each task's record replays on its own.
//! Each task's recorder starts on the task's thread once its PLC is built, and every task's
//! writer is watched as the one recorder service, naming the task that fails.

use std::sync::{Arc, Mutex, PoisonError};

use anyhow::Context;

use crate::plc::TaskPlc;
use crate::project::Project;
use crate::recorder::{RecorderHandle, Settings, WriterState};
use crate::scan::fmt_duration;
use crate::service::PerTask;

use super::run::RunArgs;

/// A task's name and its recorder's handle.
type TaskHandle = (String, RecorderHandle);

/// The recorders of a run of several tasks, started one per task.
#[derive(Debug, Clone)]
pub(super) struct TaskRecording {
    /// The project's record settings, each task's derived from them.
    settings: Settings,
    /// How many tasks share the record's bounds.
    tasks: usize,
    /// Every task's writer, for the recorder service's state.
    pub(super) recorders: PerTask,
    /// Each task's handle once its recorder started (by task, in project order).
    handles: Arc<Mutex<Vec<Option<TaskHandle>>>>,
}

impl TaskRecording {
    /// The recording the project (`recorder:`) or `--record` asks for, `None` when the run is
    /// not recorded. Every task's folder is made now, so a record that cannot be kept stops
    /// the run before it starts, naming the task, as a run of one task stops.
    pub(super) fn prepare(project: &Project, args: &RunArgs) -> anyhow::Result<Option<Self>> {
        let Some(settings) = Settings::for_run(project, args.record) else {
            return Ok(None);
        };
        let tasks = project.tasks.len();
        for task in &project.tasks {
            let folder = settings.for_task(&task.name, tasks).folder;
            std::fs::create_dir_all(&folder).with_context(|| {
                format!(
                    "flight recorder: task {}: cannot create {}",
                    task.name,
                    folder.display()
                )
            })?;
        }
        tracing::info!(
            "flight recorder: {} (a folder per task; each keeps {}, the tasks at most {} MiB \
             together)",
            settings.folder.display(),
            fmt_duration(settings.keep),
            settings.max_bytes >> 20
        );
        Ok(Some(Self {
            settings,
            tasks,
            recorders: PerTask::new(),
            handles: Arc::new(Mutex::new((0..tasks).map(|_| None).collect())),
        }))
    }

    /// Records task `i` from its next cycle on. A recorder that cannot start is said in the
    /// log and in the recorder service's state (naming the task); the task runs on, and the
    /// other tasks' recorders are not touched.
    pub(super) fn start(&self, i: usize, task: &mut TaskPlc) {
        let settings = self.settings.for_task(&task.name, self.tasks);
        let writer = match task.plc.record(settings) {
            Ok(handle) => {
                let state = handle.state_cell();
                let mut handles = self.handles.lock().unwrap_or_else(PoisonError::into_inner);
                if let Some(slot) = handles.get_mut(i) {
                    *slot = Some((task.name.clone(), handle));
                }
                state
            }
            Err(e) => {
                tracing::error!("task {}: {e}; its cycles are not recorded", task.name);
                Arc::new(Mutex::new(WriterState::Stopped {
                    reason: e.source.to_string(),
                }))
            }
        };
        self.recorders.add_recorder(&task.name, writer);
    }

    /// Waits for every task's writer once the tasks' PLCs are gone; what each record misses,
    /// naming its task.
    pub(super) fn finish(self) -> Vec<String> {
        let handles =
            std::mem::take(&mut *self.handles.lock().unwrap_or_else(PoisonError::into_inner));
        handles
            .into_iter()
            .flatten()
            .flat_map(|(task, handle)| super::run::recorder_end(Some(&task), handle))
            .collect()
    }
}
