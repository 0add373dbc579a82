//! Control requests of a PLC of several tasks, each handed to the task it concerns.
//!
//! Every task's scan answers requests at its own cycle boundary, on its own image: a force,
//! an unforce or a write goes to the task owning the tag (the one that publishes it; a value
//! set in another task's image would be overwritten by its next copy-in), the status to the
//! first task, which adds every task's figures. A write naming tags of several tasks is
//! refused (each task applies its part at its own boundary, so no single cycle would see
//! them together); so are a reload and traces, which act on one program.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError, Sender, TrySendError};

use super::control::{Envelope, Request, Response};

/// Hands requests from `requests` to the tasks' boundaries (`tasks[i]` is task `i`'s queue);
/// `owner(tag)` is the task owning a tag. Runs on a thread of its own until `stop` is set;
/// `reload` (SIGHUP's flag) is answered in the log, since a reload is not offered.
pub(crate) fn start(
    requests: Receiver<Envelope>,
    tasks: Vec<Sender<Envelope>>,
    names: Vec<String>,
    owner: impl Fn(&str) -> Option<usize> + Send + 'static,
    stop: Arc<AtomicBool>,
    reload: Arc<AtomicBool>,
) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("task-router".into())
        .spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                if reload.swap(false, Ordering::Relaxed) {
                    tracing::warn!(
                        "SIGHUP: this PLC runs several tasks and a reload swaps one program; the \
                         programs running stay; restart the PLC to load changed programs"
                    );
                }
                let env = match requests.recv_timeout(Duration::from_millis(100)) {
                    Ok(env) => env,
                    Err(RecvTimeoutError::Timeout) => continue,
                    Err(RecvTimeoutError::Disconnected) => break,
                };
                route(env, &tasks, &names, &owner);
            }
        })
}

fn route(
    env: Envelope,
    tasks: &[Sender<Envelope>],
    names: &[String],
    owner: &impl Fn(&str) -> Option<usize>,
) {
    let to = match &env.request {
        Request::Status | Request::Alarms(_) => Ok(0),
        Request::Force { tag, .. } | Request::Unforce { tag: Some(tag) } => {
            Ok(owner(tag).unwrap_or(0))
        }
        Request::Unforce { tag: None } => Err(
            "this PLC runs several tasks: unforce each forced tag by name (`softplc status` lists \
             them)"
                .to_owned(),
        ),
        Request::Write { values } => {
            let mut owners: Vec<usize> =
                values.iter().map(|v| owner(&v.tag).unwrap_or(0)).collect();
            owners.sort_unstable();
            owners.dedup();
            match owners.as_slice() {
                [] => Ok(0),
                [one] => Ok(*one),
                several => Err(format!(
                    "the tags of this write belong to tasks {}; each task applies writes at its \
                     own cycle boundary, so write each task's tags in a request of its own",
                    several
                        .iter()
                        .filter_map(|&t| names.get(t).map(String::as_str))
                        .collect::<Vec<_>>()
                        .join(", ")
                )),
            }
        }
        Request::Reload => Err(
            "this PLC runs several tasks: a reload swaps one program; restart the PLC to load \
             changed programs"
                .to_owned(),
        ),
        Request::Trace(_) => Err(
            "this PLC runs several tasks: traces sample one task's cycles and are not offered \
             for several tasks"
                .to_owned(),
        ),
    };
    match to {
        Ok(t) => {
            let Some(queue) = tasks.get(t) else {
                drop(env.reply.send(Response::refused("no such task")));
                return;
            };
            let reply = env.reply.clone();
            match queue.try_send(env) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) => {
                    drop(reply.send(Response::refused(format!(
                        "task {} is busy with earlier requests; try again",
                        names.get(t).map_or("?", String::as_str)
                    ))));
                }
                Err(TrySendError::Disconnected(_)) => {
                    drop(reply.send(Response::refused("the task has stopped")));
                }
            }
        }
        Err(why) => drop(env.reply.send(Response::refused(why))),
    }
}
