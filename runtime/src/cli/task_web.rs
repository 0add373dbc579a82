//! The web page of a PLC of several tasks: it draws every task's programs, each with its own
//! task's push-down plan and block numbering, so it starts once every task's PLC is built
//! (each on its own thread), on the thread of the task built last.

use std::sync::{Mutex, MutexGuard};

use crate::image::TagId;
use crate::logic::Ownership;
use crate::plc::TaskPlc;
use crate::project::Project;
use crate::service::web::{TaskPart, WebServer};

use super::plant_services::WebStarter;

/// Gathers each task's part of the page and starts it with the last one.
pub(super) struct TaskWeb {
    project: Project,
    ownership: Ownership,
    gathered: Mutex<Gathered>,
    server: Mutex<Option<WebServer>>,
}

/// What the tasks built so far gave.
struct Gathered {
    /// Taken by the start; `None` also when there is no page.
    starter: Option<WebStarter>,
    /// Each task's part, in task order, once its PLC is built.
    parts: Vec<Option<TaskPart>>,
}

impl TaskWeb {
    /// The page of `project`'s tasks (`ownership`: each tag's owner), started by `starter`;
    /// no page when `starter` is `None`.
    pub(super) fn new(
        project: &Project,
        ownership: &Ownership,
        starter: Option<WebStarter>,
    ) -> Self {
        Self {
            project: project.clone(),
            ownership: ownership.clone(),
            gathered: Mutex::new(Gathered {
                starter,
                parts: vec![None; project.tasks.len()],
            }),
            server: Mutex::new(None),
        }
    }

    /// Task `i`'s PLC `plc` is built: its part of the page; the last part starts the page.
    pub(super) fn built(&self, i: usize, plc: &TaskPlc) {
        let mut gathered = lock(&self.gathered);
        if gathered.starter.is_none() {
            return;
        }
        let period = self
            .project
            .tasks
            .get(i)
            .map_or(self.project.scan.period, |t| t.scan.period);
        if let Some(slot) = gathered.parts.get_mut(i) {
            *slot = Some(TaskPart::of(&plc.plc, &plc.name, period));
        }
        if gathered.parts.iter().any(Option::is_none) {
            return;
        }
        let parts = gathered.parts.iter_mut().filter_map(Option::take).collect();
        let Some(starter) = gathered.starter.take() else {
            return;
        };
        let owner = |t: usize| self.ownership.owner(TagId(t as u32));
        *lock(&self.server) = starter.start_tasks(&self.project, &owner, parts);
    }

    /// The page, once started (it then lives with the services until the end).
    pub(super) fn take_server(&self) -> Option<WebServer> {
        lock(&self.server).take()
    }
}

/// A lock whose holder panicked still guards valid data here (parts, a server handle).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
