//! Control requests of a PLC of several tasks, each handed to the task it concerns.
//!
//! Every task's scan answers requests at its own cycle boundary, on its own image: a force,
//! an unforce or a write goes to the task owning the tag (the one that publishes it; a value
//! set in another task's image would be overwritten by its next copy-in), the status to the
//! first task, which adds every task's figures. A write naming tags of several tasks is split
//! into one write per owning task, and `unforce` of every tag and `reload` go to every task
//! (`fan_out`): each part lands at its own task's next boundary, and the reply merges the
//! tasks' answers (a reload: each task's reloaded, unchanged or refused). A trace samples one
//! task's cycles (`traces`).

mod fan_out;
mod traces;

pub(crate) use traces::{home as trace_home, TraceRoutes};

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender};

use super::control::{Envelope, Request, Response, TagValue, TaskPart};
use fan_out::{all_or_report, fan_out, Pending};

/// Who a tag named in a request belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TagOwner {
    /// No tag of that name: the first task refuses the request, naming it.
    Unknown,
    /// A memory tag no program writes: the first task holds it.
    Nobody,
    /// The task (an index) that publishes it.
    Task(usize),
}

impl TagOwner {
    /// The task a request about the tag goes to.
    fn task(self) -> usize {
        match self {
            TagOwner::Task(t) => t,
            TagOwner::Unknown | TagOwner::Nobody => 0,
        }
    }
}

/// Hands requests from `requests` to the tasks' boundaries (`tasks[i]` is task `i`'s queue);
/// `owner(tag)` is who owns a tag. Runs on a thread of its own until `stop` is set.
pub(crate) fn start(
    requests: Receiver<Envelope>,
    tasks: Vec<Sender<Envelope>>,
    names: Vec<String>,
    owner: impl Fn(&str) -> TagOwner + Send + 'static,
    traces: TraceRoutes,
    stop: Arc<AtomicBool>,
) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("task-router".into())
        .spawn(move || {
            let pending = Pending::default();
            while !stop.load(Ordering::Relaxed) {
                let env = match requests.recv_timeout(Duration::from_millis(100)) {
                    Ok(env) => env,
                    Err(RecvTimeoutError::Timeout) => continue,
                    Err(RecvTimeoutError::Disconnected) => break,
                };
                route(env, &tasks, &names, &owner, &traces, &pending);
            }
        })
}

/// Where a request goes.
enum Route {
    /// To one task.
    One(usize),
    /// To one task, as this request (the trace's task filled in).
    Rewritten(usize, Request),
    /// A part to each of several tasks, every part to succeed, the answers merged.
    Split(Vec<(usize, Request)>),
    /// A part to each of several tasks, the answers merged by the function.
    Merged(Vec<(usize, Request)>, fn(Vec<TaskPart>) -> Response),
    /// Nowhere: refused, with the reason.
    Refused(String),
}

fn route(
    env: Envelope,
    tasks: &[Sender<Envelope>],
    names: &[String],
    owner: &impl Fn(&str) -> TagOwner,
    traces: &TraceRoutes,
    pending: &Pending,
) {
    let to = match &env.request {
        Request::Status | Request::Alarms(_) => Route::One(0),
        Request::Force { tag, .. } | Request::Unforce { tag: Some(tag) } => {
            Route::One(owner(tag).task())
        }
        Request::Unforce { tag: None } => Route::Split(
            (0..tasks.len())
                .map(|t| (t, Request::Unforce { tag: None }))
                .collect(),
        ),
        Request::Write { values } => split_write(values, owner),
        Request::Reload { task: None } => Route::Split(
            (0..tasks.len())
                .map(|t| (t, Request::Reload { task: None }))
                .collect(),
        ),
        Request::Reload { task: Some(task) } => match names.iter().position(|n| n == task) {
            Some(t) => Route::Split(vec![(t, Request::Reload { task: None })]),
            None => Route::Refused(no_task(task, names)),
        },
        Request::Trace(t) => traces.route(t, names),
    };
    match to {
        Route::One(t) => to_one(env, t, tasks, names),
        Route::Rewritten(t, request) => to_one(Envelope { request, ..env }, t, tasks, names),
        Route::Split(parts) => fan_out(env, parts, tasks, names, pending, all_or_report),
        Route::Merged(parts, merge) => fan_out(env, parts, tasks, names, pending, merge),
        Route::Refused(why) => drop(env.reply.send(Response::refused(why))),
    }
}

/// Hands `env` to task `t`; refused at once when its queue is full or gone.
fn to_one(env: Envelope, t: usize, tasks: &[Sender<Envelope>], names: &[String]) {
    let name = names.get(t).map_or("?", String::as_str).to_owned();
    let reply = env.reply.clone();
    if let Err(why) = fan_out::send(tasks.get(t), &name, env) {
        drop(reply.send(Response::refused(why)));
    }
}

/// The refusal of a task name no task has.
fn no_task(task: &str, names: &[String]) -> String {
    format!("no task {task}: the tasks are {}", names.join(", "))
}

/// A write to the task owning its tags, or one write per owning task (in task order, each
/// with its tags in the order given). A write naming an unknown tag goes whole to the first
/// task, which refuses it naming the tag: nothing of it is applied anywhere.
fn split_write(values: &[TagValue], owner: &impl Fn(&str) -> TagOwner) -> Route {
    if values.iter().any(|v| owner(&v.tag) == TagOwner::Unknown) {
        return Route::One(0);
    }
    let mut parts: Vec<(usize, Vec<TagValue>)> = Vec::new();
    for v in values {
        let t = owner(&v.tag).task();
        match parts.iter_mut().find(|(p, _)| *p == t) {
            Some((_, part)) => part.push(v.clone()),
            None => parts.push((t, vec![v.clone()])),
        }
    }
    match parts.as_slice() {
        [] => Route::One(0),
        [(one, _)] => Route::One(*one),
        _ => {
            parts.sort_by_key(|(t, _)| *t);
            Route::Split(
                parts
                    .into_iter()
                    .map(|(t, values)| (t, Request::Write { values }))
                    .collect(),
            )
        }
    }
}
