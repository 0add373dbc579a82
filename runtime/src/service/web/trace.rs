//! The Trace view's routes: the traces' states, a trace's samples for the plot, its CSV and
//! VCD for download, and arming / disarming.
//!
//! | route | answer |
//! |---|---|
//! | `GET /api/trace` | `{"ok": true, "traces": [TraceStatus…]}` |
//! | `GET /api/trace/data?name=N` | `{"ok": true, "trace": TraceData}`: the samples so far |
//! | `GET /api/trace/csv?name=N`, `/api/trace/vcd?name=N` | the file, as an attachment |
//! | `POST /api/trace/arm` | `{"name": "jam"}`, or `{"spec": {"name", "tags", "trigger", "pre", "post", "mode", "every"}}`; `"task"`: whose cycles (several tasks) |
//! | `POST /api/trace/disarm` | `{"name": "jam"}` |
//!
//! Reading changes nothing (a download does not re-arm a repeating trace: `softplc trace save`
//! does, the page's Arm button does). Arming and disarming are writes: they take the token, as
//! forcing does, since an armed trace holds up to 8 MB and arming allocates at a cycle
//! boundary.

use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};
use serde::Deserialize;

use super::auth::WriteAuth;
use super::http::{Request, Response};
use crate::project::trace::RawTrace;
use crate::service::control::{Envelope, Request as Control, Response as ControlResponse};
use crate::service::trace::TraceRequest;

/// How long a request waits for room in the scan's queue, and for its answer.
const QUEUE_WAIT: Duration = Duration::from_secs(1);
const SCAN_ANSWER: Duration = Duration::from_secs(3);

/// The trace routes, by path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TraceRoute {
    /// `GET /api/trace`.
    List,
    /// `GET /api/trace/data`.
    Data,
    /// `GET /api/trace/csv`.
    Csv,
    /// `GET /api/trace/vcd`.
    Vcd,
    /// `POST /api/trace/arm`.
    Arm,
    /// `POST /api/trace/disarm`.
    Disarm,
}

impl TraceRoute {
    /// The route of `path`, and whether it is a write.
    pub(crate) fn of(path: &str) -> Option<(Self, bool)> {
        Some(match path {
            "/api/trace" => (Self::List, false),
            "/api/trace/data" => (Self::Data, false),
            "/api/trace/csv" => (Self::Csv, false),
            "/api/trace/vcd" => (Self::Vcd, false),
            "/api/trace/arm" => (Self::Arm, true),
            "/api/trace/disarm" => (Self::Disarm, true),
            _ => return None,
        })
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ArmBody {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    spec: Option<RawTrace>,
    #[serde(default)]
    task: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct NameBody {
    name: String,
}

/// The request a `POST /api/trace/arm` body makes. A trace armed from the page without a name
/// gets the one the command line gives it ([`crate::project::trace::UNNAMED`]).
fn arm_request(body: &[u8]) -> Result<TraceRequest, serde_json::Error> {
    let b = serde_json::from_slice::<ArmBody>(body)?;
    Ok(TraceRequest::Arm {
        name: b.name,
        spec: b.spec.map(|s| RawTrace {
            name: crate::project::trace::name_or_default(Some(s.name)),
            ..s
        }),
        task: b.task,
    })
}

fn refused(status: u16, error: &str) -> Response {
    Response::json(
        status,
        serde_json::json!({ "ok": false, "error": error }).to_string(),
    )
}

/// `name=` of a query (percent-decoded).
fn name_of(query: &str) -> Option<String> {
    let raw = query.split('&').find_map(|kv| kv.strip_prefix("name="))?;
    let bytes = raw.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'%' if i + 2 < bytes.len() => {
                let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).ok()?;
                out.push(u8::from_str_radix(hex, 16).ok()?);
                i += 3;
            }
            b'+' => {
                out.push(b' ');
                i += 1;
            }
            b => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok().filter(|n| !n.is_empty())
}

/// Answers a trace route.
pub(crate) fn answer(
    auth: &WriteAuth,
    scan: &Sender<Envelope>,
    route: TraceRoute,
    req: &Request,
) -> Response {
    let request = match route {
        TraceRoute::List => TraceRequest::Status { name: None },
        TraceRoute::Data | TraceRoute::Csv | TraceRoute::Vcd => match name_of(&req.query) {
            Some(name) => TraceRequest::Read { name },
            None => return refused(400, "name the trace: ?name=NAME"),
        },
        TraceRoute::Arm | TraceRoute::Disarm => {
            if let Err(why) = auth.authorize(req, super::auth::Act::Trace) {
                return refused(403, &why.to_string());
            }
            let bad = |e: serde_json::Error| refused(400, &format!("bad request body: {e}"));
            if route == TraceRoute::Arm {
                match arm_request(&req.body) {
                    Ok(request) => request,
                    Err(e) => return bad(e),
                }
            } else {
                match serde_json::from_slice::<NameBody>(&req.body) {
                    Ok(b) => TraceRequest::Disarm { name: b.name },
                    Err(e) => return bad(e),
                }
            }
        }
    };
    let r = match ask(scan, request) {
        Ok(r) => r,
        Err(response) => return response,
    };
    if !r.ok {
        return refused(409, &r.error.unwrap_or_else(|| "refused".into()));
    }
    match (route, r.trace) {
        (TraceRoute::Csv, Some(d)) => file(d.write_csv(Vec::new()), &d.name, "csv", "text/csv"),
        (TraceRoute::Vcd, Some(d)) => file(d.write_vcd(Vec::new()), &d.name, "vcd", "text/plain"),
        (_, trace) => Response::json(
            200,
            serde_json::json!({
                "ok": true,
                "message": r.message,
                "traces": r.traces,
                "trace": trace,
            })
            .to_string(),
        ),
    }
}

fn file(
    body: Result<Vec<u8>, crate::trace::export::ExportError>,
    name: &str,
    ext: &str,
    content_type: &'static str,
) -> Response {
    match body {
        Ok(b) => {
            // A trace name is the user's; keep the file name to safe characters.
            let safe: String = name
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            Response::new(200, content_type, b).with(
                "Content-Disposition",
                format!("attachment; filename=\"{safe}.{ext}\""),
            )
        }
        Err(e) => refused(500, &e.to_string()),
    }
}

fn ask(scan: &Sender<Envelope>, t: TraceRequest) -> Result<ControlResponse, Response> {
    let (reply, answer): (Sender<ControlResponse>, Receiver<ControlResponse>) =
        crossbeam_channel::bounded(1);
    if scan
        .send_timeout(
            Envelope::new(
                Control::Trace(t),
                reply,
                SCAN_ANSWER,
                crate::service::audit::Origin::Web(None, None),
            ),
            QUEUE_WAIT,
        )
        .is_err()
    {
        return Err(refused(
            503,
            "the scan is not taking requests (stopped or busy)",
        ));
    }
    answer
        .recv_timeout(SCAN_ANSWER)
        .map_err(|_| refused(504, "the scan did not answer within 3 s"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trace_armed_without_a_name_is_named_as_the_command_line_names_it() {
        let name = |body: &str| match arm_request(body.as_bytes()) {
            Ok(TraceRequest::Arm {
                spec: Some(spec), ..
            }) => spec.name,
            other => panic!("{other:?}"),
        };
        assert_eq!(name(r#"{"spec": {"name": "", "tags": ["x1"]}}"#), "adhoc");
        assert_eq!(name(r#"{"spec": {"name": "  ", "tags": ["x1"]}}"#), "adhoc");
        assert_eq!(name(r#"{"spec": {"name": "jam", "tags": ["x1"]}}"#), "jam");
        assert_eq!(
            crate::project::trace::name_or_default(None),
            "adhoc",
            "the CLI's"
        );
    }

    #[test]
    fn the_page_names_the_task_a_trace_samples() {
        assert_eq!(
            arm_request(br#"{"name": "jam", "task": "press"}"#).ok(),
            Some(TraceRequest::Arm {
                name: Some("jam".into()),
                spec: None,
                task: Some("press".into()),
            })
        );
        assert!(arm_request(br#"{"name": "jam", "tasks": "press"}"#).is_err());
    }

    #[test]
    fn names_come_from_the_query_decoded() {
        assert_eq!(name_of("name=jam"), Some("jam".into()));
        assert_eq!(name_of("x=1&name=a%2Db"), Some("a-b".into()));
        assert_eq!(name_of("name="), None);
        assert_eq!(name_of("name=%zz"), None);
        assert_eq!(name_of("name=%4"), Some("%4".into()));
        assert_eq!(
            TraceRoute::of("/api/trace/arm"),
            Some((TraceRoute::Arm, true))
        );
        assert_eq!(TraceRoute::of("/api/trace/x"), None);
    }
}
