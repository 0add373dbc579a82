//! The web page of a PLC of several tasks: it draws every task's programs, each with its own
//! task's push-down plan and block numbering, planned before any line starts, and it starts
//! once the first task's PLC is built (on that task's thread), as a single task's page starts
//! once its PLC is: a slow line's start-up does not keep the page away.

use std::sync::{Mutex, MutexGuard};

use crate::image::TagId;
use crate::logic::Ownership;
use crate::plc::TaskBuilder;
use crate::project::Project;
use crate::service::web::{TaskPart, WebServer};

use super::plant_services::WebStarter;

/// The page's start, once, from the first task built.
pub(super) struct TaskWeb {
    project: Project,
    ownership: Ownership,
    /// Taken by the start; `None` also when there is no page.
    pending: Mutex<Option<(WebStarter, Vec<TaskPart>)>>,
    server: Mutex<Option<WebServer>>,
}

impl TaskWeb {
    /// The page of `builder`'s tasks (of `project`), started by `starter`; no page when
    /// `starter` is `None`, or when a task's program does not compile (its build then says
    /// why and stops the PLC).
    pub(super) fn new(
        project: &Project,
        builder: &TaskBuilder,
        starter: Option<WebStarter>,
    ) -> Self {
        let pending = starter.and_then(|starter| {
            let parts = (project.tasks.iter().enumerate())
                .map(|(i, t)| {
                    let planned = builder.planned(i).ok()?;
                    Some(TaskPart::of(&planned, &t.name, t.scan.period))
                })
                .collect::<Option<Vec<_>>>()?;
            Some((starter, parts))
        });
        Self {
            project: project.clone(),
            ownership: builder.ownership().clone(),
            pending: Mutex::new(pending),
            server: Mutex::new(None),
        }
    }

    /// A task's PLC is built: the first call starts the page.
    pub(super) fn built(&self) {
        let Some((starter, parts)) = lock(&self.pending).take() else {
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

/// A lock whose holder panicked still guards valid data here (the parts, a server handle).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
