//! The control socket's trace requests, answered at the cycle boundary.
//!
//! ```text
//! {"cmd":"trace","action":"arm","name":"jam"}
//! {"cmd":"trace","action":"arm","spec":{"name":"adhoc","tags":["x1","y1"],"trigger":"x1 rising","pre":100,"post":400}}
//! {"cmd":"trace","action":"arm","name":"jam","task":"fast"}   (several tasks: whose cycles)
//! {"cmd":"trace","action":"status"}          {"cmd":"trace","action":"status","name":"jam"}
//! {"cmd":"trace","action":"save","name":"jam"}   (the samples; a repeating trace re-arms)
//! {"cmd":"trace","action":"read","name":"jam"}   (the samples so far; nothing re-arms)
//! {"cmd":"trace","action":"disarm","name":"jam"}
//! ```
//!
//! The samples come back in the response ([`crate::trace::TraceData`]) and the client writes
//! the file: the service never writes where a client says.

use serde::{Deserialize, Serialize};

use crate::plc::Plc;
use crate::project::trace::RawTrace;
use crate::service::control::Response;
use crate::trace::TraceSet;

/// A trace request.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "action", rename_all = "lowercase", deny_unknown_fields)]
pub enum TraceRequest {
    /// Arm the project's trace `name`, or the trace `spec`.
    Arm {
        /// A trace of the project.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
        /// A trace given here, checked as the project's are.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        spec: Option<RawTrace>,
        /// The task whose cycles it samples (a project of several tasks); absent: the task
        /// owning the trigger's signal, or the first signal's.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        task: Option<String>,
    },
    /// The state of one trace, or of all.
    Status {
        /// The trace; absent: all.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        name: Option<String>,
    },
    /// The samples, to keep: a complete repeating trace arms itself again.
    Save {
        /// The trace.
        name: String,
    },
    /// The samples so far (to watch a trace fill).
    Read {
        /// The trace.
        name: String,
    },
    /// Stop a trace and forget its samples.
    Disarm {
        /// The trace.
        name: String,
    },
}

/// Carries out `request` on `traces` at a cycle boundary.
pub(crate) fn answer(traces: &mut TraceSet, plc: &Plc, request: TraceRequest) -> Response {
    let project = plc.project();
    match request {
        TraceRequest::Arm {
            task: Some(task), ..
        } if project.tasks.first().is_none_or(|t| t.name != task) => Response::refused(format!(
            "no task {task}: this PLC runs task {}",
            project.tasks.first().map_or("main", |t| t.name.as_str())
        )),
        TraceRequest::Arm { name, spec, .. } => {
            match traces.arm(project, name.as_deref(), spec.as_ref()) {
                Ok(s) => {
                    let message = match &s.task {
                        Some(t) => format!("trace {} armed in task {t}, on its cycles", s.name),
                        None => format!("trace {} armed", s.name),
                    };
                    Response {
                        traces: Some(vec![s.clone()]),
                        ..Response::done(message)
                    }
                }
                Err(e) => Response::refused(e.to_string()),
            }
        }
        TraceRequest::Status { name } => match traces.status(project, name.as_deref()) {
            Ok(list) => Response {
                ok: true,
                traces: Some(list),
                ..Response::default()
            },
            Err(e) => Response::refused(e.to_string()),
        },
        TraceRequest::Save { name } => data(traces, plc, &name, true),
        TraceRequest::Read { name } => data(traces, plc, &name, false),
        TraceRequest::Disarm { name } => match traces.disarm(project, &name) {
            Ok(()) => Response::done(format!("trace {name} disarmed")),
            Err(e) => Response::refused(e.to_string()),
        },
    }
}

fn data(traces: &mut TraceSet, plc: &Plc, name: &str, save: bool) -> Response {
    match traces.read(plc.project(), name, save) {
        Ok(d) => Response {
            ok: true,
            trace: Some(d),
            ..Response::default()
        },
        Err(e) => Response::refused(e.to_string()),
    }
}
