//! Trace requests of a PLC of several tasks: a trace samples one task's cycles, at that
//! task's boundary, from its image. Arming it picks the task: the one named, else the task
//! already holding a trace of that name (arming again restarts it there), else the task owning
//! the trigger's signal, or the first signal's (a tag's writer, a module's poller). The other
//! requests go to the task holding the trace; `status` of every trace asks every task.

use crate::logic::Ownership;
use crate::project::trace::{Probe, TraceConfig};
use crate::project::Project;
use crate::service::control::{Request, Response, TaskPart};
use crate::service::trace::TraceRequest;
use crate::trace::{TraceLedger, TraceRefusal, TraceStatus};

use super::{no_task, Route};

/// What routing a trace request needs to know of the PLC.
#[derive(Debug)]
pub(crate) struct TraceRoutes {
    /// The whole project (every task's tags and modules).
    pub(crate) project: Project,
    /// The owner of every tag.
    pub(crate) ownership: Ownership,
    /// The traces armed, and in which task.
    pub(crate) ledger: TraceLedger,
}

impl TraceRoutes {
    /// Where `request` goes; `names` are the tasks'.
    pub(super) fn route(&self, request: &TraceRequest, names: &[String]) -> Route {
        match request {
            TraceRequest::Arm { name, spec, task } => {
                let config = match (spec, name) {
                    (Some(raw), _) => crate::trace::set::spec_config(&self.project, raw),
                    (None, Some(name)) => self.project_trace(name),
                    (None, None) => Err(TraceRefusal::Nothing),
                };
                let config = match config {
                    Ok(c) => c,
                    Err(e) => return Route::Refused(e.to_string()),
                };
                let chosen = match task {
                    Some(t) => match names.iter().position(|n| n == t) {
                        Some(i) => i,
                        None => return Route::Refused(no_task(t, names)),
                    },
                    None => self
                        .held_by(&config.name, names)
                        .unwrap_or_else(|| home(&self.project, &self.ownership, &config)),
                };
                if let Some(why) = self.not_sampled_in(&config, chosen, names) {
                    return Route::Refused(why);
                }
                let mut request = request.clone();
                if let TraceRequest::Arm { task, .. } = &mut request {
                    *task = names.get(chosen).cloned();
                }
                Route::Rewritten(chosen, Request::Trace(request))
            }
            TraceRequest::Status { name: None } => Route::Merged(
                (0..names.len())
                    .map(|t| (t, Request::Trace(request.clone())))
                    .collect(),
                merge_status,
            ),
            TraceRequest::Status { name: Some(name) }
            | TraceRequest::Save { name }
            | TraceRequest::Read { name }
            | TraceRequest::Disarm { name } => match self.held_by(name, names) {
                Some(t) => Route::One(t),
                // A trace of the project not armed: its task says so (or lists it).
                None => match self.project_trace(name) {
                    Ok(config) => Route::One(home(&self.project, &self.ownership, &config)),
                    Err(e) => Route::Refused(e.to_string()),
                },
            },
        }
    }

    /// The task holding the armed trace `name`.
    fn held_by(&self, name: &str, names: &[String]) -> Option<usize> {
        let task = self.ledger.holder(name)??;
        names.iter().position(|n| *n == task)
    }

    /// The project's trace `name`, or why not (the traces there are).
    fn project_trace(&self, name: &str) -> Result<TraceConfig, TraceRefusal> {
        if let Some(t) = self.project.traces.iter().find(|t| t.name == name) {
            return Ok(t.clone());
        }
        let mut defined: Vec<String> = self.project.traces.iter().map(|t| t.name.clone()).collect();
        for n in self.ledger.names() {
            if !defined.contains(&n) {
                defined.push(n);
            }
        }
        Err(TraceRefusal::Unknown {
            name: name.to_owned(),
            defined,
        })
    }

    /// Why task `task` cannot sample `config`: a module counter it records is another task's
    /// (that task polls the module, its cycles count the requests).
    fn not_sampled_in(
        &self,
        config: &TraceConfig,
        task: usize,
        names: &[String],
    ) -> Option<String> {
        let project = &self.project;
        let name = |t: usize| names.get(t).map_or("?", String::as_str);
        probes(config).find_map(|p| {
            let Probe::Counter { module, .. } = p else {
                return None;
            };
            let m = project.modules.get(module)?;
            let poller = project.task_of_bus(m.bus);
            (poller != task).then(|| {
                format!(
                    "trace {}: module {} is polled by task {}, and the trace samples task {}'s \
                     cycles: arm it in task {} (--task {}), or record no counter of {}",
                    config.name,
                    m.name,
                    name(poller),
                    name(task),
                    name(poller),
                    name(poller),
                    m.name
                )
            })
        })
    }
}

/// Every signal of `config`, the trigger's first.
fn probes(config: &TraceConfig) -> impl Iterator<Item = Probe> + '_ {
    config
        .trigger
        .iter()
        .map(|t| t.probe)
        .chain(config.probes.iter().copied())
}

/// The task a trace samples by default: the one owning its trigger's signal, else its first
/// signal's with an owner (a tag's writer, a module's poller); the first task when none has
/// (phase times, tags nobody writes).
pub(crate) fn home(project: &Project, ownership: &Ownership, config: &TraceConfig) -> usize {
    probes(config)
        .find_map(|p| match p {
            Probe::Tag(i) => ownership.owner(crate::image::TagId(i as u32)),
            Probe::Counter { module, .. } => project
                .modules
                .get(module)
                .map(|m| project.task_of_bus(m.bus)),
            Probe::Phase(_) => None,
        })
        .unwrap_or(0)
}

/// Every task's traces in one list: the armed ones, task by task, then the project's not
/// armed in any task, once each.
fn merge_status(parts: Vec<TaskPart>) -> Response {
    let mut armed: Vec<TraceStatus> = Vec::new();
    let mut idle: Vec<TraceStatus> = Vec::new();
    let mut errors = Vec::new();
    for p in parts {
        if let Some(e) = p.answer.error {
            errors.push(format!("task {}: {e}", p.task));
        }
        for s in p.answer.traces.into_iter().flatten() {
            match s.state {
                Some(_) => armed.push(s),
                None if !idle.iter().any(|i| i.name == s.name) => idle.push(s),
                None => {}
            }
        }
    }
    idle.retain(|i| !armed.iter().any(|a| a.name == i.name));
    armed.extend(idle);
    Response {
        ok: errors.is_empty(),
        error: (!errors.is_empty()).then(|| errors.join("; ")),
        traces: Some(armed),
        ..Response::default()
    }
}
