//! A request sent to several tasks: each task answers its part at its own cycle boundary, and
//! one reply merges theirs. The parts are not one transaction: each lands at its task's next
//! boundary, and one refused part does not undo another's.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use crossbeam_channel::{Receiver, Sender, TrySendError};

use crate::service::control::{Envelope, Request, Response, TaskPart};

/// Requests of several tasks waiting for their answers at once; past it a new one is refused
/// (each waits on a thread of its own until its tasks' boundaries answer).
const MAX_PENDING: usize = 16;

/// The requests being merged, shared by the router and the merging threads.
#[derive(Debug, Default, Clone)]
pub(super) struct Pending(Arc<AtomicUsize>);

impl Pending {
    fn enter(&self) -> bool {
        self.0
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
                (n < MAX_PENDING).then_some(n + 1)
            })
            .is_ok()
    }

    fn leave(&self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

/// Hands `env` to one task's queue; refused at once, with the reason, when it is full or gone.
pub(super) fn send(
    queue: Option<&Sender<Envelope>>,
    task: &str,
    env: Envelope,
) -> Result<(), String> {
    let Some(queue) = queue else {
        return Err(format!("no task {task}"));
    };
    match queue.try_send(env) {
        Ok(()) => Ok(()),
        Err(TrySendError::Full(_)) => Err(format!(
            "task {task} is busy with earlier requests; try again"
        )),
        Err(TrySendError::Disconnected(_)) => Err(format!("task {task} has stopped")),
    }
}

/// Sends each `(task, request)` of `parts` to its task with `env`'s deadline and origin, and
/// answers `env` with `merge` of the tasks' answers (in `parts`' order), on a thread of its
/// own so the router goes on routing meanwhile.
pub(super) fn fan_out(
    env: Envelope,
    parts: Vec<(usize, Request)>,
    tasks: &[Sender<Envelope>],
    names: &[String],
    pending: &Pending,
    merge: fn(Vec<TaskPart>) -> Response,
) {
    if !pending.enter() {
        drop(env.reply.send(Response::refused(
            "too many requests of several tasks are waiting for their tasks; try again",
        )));
        return;
    }
    let mut waiting: Vec<(String, Result<Receiver<Response>, String>)> = Vec::new();
    for (t, request) in parts {
        let name = names.get(t).cloned().unwrap_or_default();
        let (tx, rx) = crossbeam_channel::bounded(1);
        let part = Envelope {
            request,
            reply: tx,
            expires: env.expires,
            origin: env.origin.clone(),
        };
        let sent = send(tasks.get(t), &name, part).map(|()| rx);
        waiting.push((name, sent));
    }
    let (reply, expires) = (env.reply, env.expires);
    let merging = pending.clone();
    let spawned = std::thread::Builder::new()
        .name("task-merge".into())
        .spawn(move || {
            let answers = waiting
                .into_iter()
                .map(|(task, sent)| {
                    let answer = sent.and_then(|rx| {
                        rx.recv_deadline(expires)
                            .map_err(|_| format!("task {task} did not answer in time"))
                    });
                    TaskPart {
                        task,
                        answer: answer.unwrap_or_else(Response::refused),
                    }
                })
                .collect();
            // A client that gave up meanwhile has nobody left to tell.
            drop(reply.send(merge(answers)));
            merging.leave();
        });
    if let Err(e) = spawned {
        pending.leave();
        tracing::error!("cannot merge the tasks' answers: no thread for it: {e}");
    }
}

/// Joins the parts' words, each behind its task's name.
pub(super) fn joined(parts: &[TaskPart]) -> String {
    parts
        .iter()
        .map(|p| match (&p.answer.message, &p.answer.error) {
            // A refusal that says so in its head ("reload refused: ...") is not said again.
            (_, Some(e)) if e.split(':').next().is_some_and(|h| h.contains("refused")) => {
                format!("task {}: {e}", p.task)
            }
            (_, Some(e)) => format!("task {}: refused: {e}", p.task),
            (Some(m), None) => format!("task {}: {m}", p.task),
            (None, None) => format!("task {}: done", p.task),
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The merged answer of a request every part of which must succeed: done when all did, else
/// refused with every part's outcome (which ones were applied, which refused and why).
pub(super) fn all_or_report(parts: Vec<TaskPart>) -> Response {
    let text = joined(&parts);
    let locked = parts.iter().any(|p| p.answer.locked);
    let all = parts.iter().all(|p| p.answer.ok);
    let mut r = if all {
        Response::done(text)
    } else {
        Response::refused(text)
    };
    r.locked = locked;
    r.parts = Some(parts);
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(task: &str, answer: Response) -> TaskPart {
        TaskPart {
            task: task.into(),
            answer,
        }
    }

    #[test]
    fn each_tasks_refusal_is_said_once() {
        let text = joined(&[
            part("press", Response::done("program press.rhai unchanged")),
            part(
                "panel",
                Response::refused("reload refused:\npanel.rhai:1:9: error: unknown function"),
            ),
            part("oven", Response::refused("no tag `heater` in task oven")),
        ]);
        assert_eq!(
            text,
            "task press: program press.rhai unchanged; task panel: reload refused:\n\
             panel.rhai:1:9: error: unknown function; task oven: refused: no tag `heater` in \
             task oven"
        );
    }
}
