//! The page's routes and what each answers.
//!
//! | route | answer |
//! |---|---|
//! | `GET /` | the page (`assets/index.html`); its views are `#overview`, `#io`, `#program`, `#timing`, `#bus` |
//! | `GET /app.js`, `GET /ladder.js`, `GET /shared.js`, `GET /style.css` | its scripts (the ladder diagrams in their own, the helpers it shares with the operator's page in `shared.js`) and style, embedded in the binary |
//! | `GET /api/info` | what does not change: project, lines, modules, tags, program ([`super::info`]) |
//! | `GET /api/state` | `{"state": …, "stats": …}` now ([`super::view`]) |
//! | `GET /api/trend` | the trend's history |
//! | `GET /operator`, `GET /operator.js`, `GET /operator.css` | the operator's page for a panel PC (800 × 480): the alarms with their acknowledge buttons, the tags marked `operator: true` with a write-once control where writable |
//! | `GET /api/audit` | the audit file's latest 50 entries, the newest first (`{"entries": [...]}`) |
//! | `GET /api/alarms` | the current alarms (waiting first, then by priority), the counts and the latest 50 events (`{"current": [...], "counts": {...}, "history": [...]}`) |
//! | `POST /api/alarms/ack` | `{"alarm": "jam"}` (or `"all"`): acknowledged by the alarm thread at the next cycle boundary; the operator's token may |
//! | `GET /api/events` | server-sent events `state` and `stats` ([`super::sse`]) |
//! | `POST /api/force` | `{"tag": "motor", "value": "1"}` (value: text, number or boolean) |
//! | `POST /api/write` | `{"tag": "speed", "value": 42}`: set once at the next cycle boundary; the program may overwrite it from its next scan |
//! | `POST /api/unforce` | `{"tag": "motor"}`, or `{}` for every tag |
//! | `POST /api/auth` | `{}`: whether the token would be accepted and its role (`{"ok": true, "role": "operator"}`; the page's sign-in); changes nothing |
//! | `/api/trace…` | the Trace view: states, samples, CSV/VCD, arm, disarm ([`super::trace`]) |
//!
//! A write answers 200 `{"ok": true, "message": …}` once the scan applied it at a cycle
//! boundary, 409 `{"ok": false, "error": …}` when the scan refused it (no such tag, a value
//! not of the tag's type, a pushed-down output; for a write also a forced tag or an input), 403 when [`super::auth`] refuses it (no or a wrong token, or the operator's token on what needs the engineer's), 400 for
//! a body that is not the JSON above, 503/504 when the scan is gone or does not answer.

use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};
use serde::Deserialize;

use super::auth::{Act, WriteAuth};
use super::http::{Method, Request, Response};
use crate::service::alarms::AlarmRequest;
use crate::service::control::{
    Envelope, Request as Control, Response as ControlResponse, TagValue,
};

/// The page's script.
pub(crate) const APP_JS: &str = include_str!("assets/app.js");
/// The page's ladder diagrams.
pub(crate) const LADDER_JS: &str = include_str!("assets/ladder.js");
/// The helpers both pages' scripts use.
pub(crate) const SHARED_JS: &str = include_str!("assets/shared.js");
/// The page's style.
pub(crate) const STYLE_CSS: &str = include_str!("assets/style.css");
/// The page.
pub(crate) const INDEX_HTML: &str = include_str!("assets/index.html");
/// The operator's page.
pub(crate) const OPERATOR_HTML: &str = include_str!("assets/operator.html");
/// The operator's page's script.
pub(crate) const OPERATOR_JS: &str = include_str!("assets/operator.js");
/// The operator's page's style.
pub(crate) const OPERATOR_CSS: &str = include_str!("assets/operator.css");

/// How long a write waits for room in the scan's request queue.
const QUEUE_WAIT: Duration = Duration::from_secs(1);
/// How long a write waits for the scan's answer.
const SCAN_ANSWER: Duration = Duration::from_secs(3);
/// The longest tag name or value text a write may carry.
const MAX_FIELD: usize = 256;

/// What a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Route {
    /// The page.
    Index,
    /// Its script.
    Script,
    /// Its ladder diagrams' script.
    LadderScript,
    /// The helpers both pages use.
    SharedScript,
    /// Its style.
    Style,
    /// `/api/info`.
    Info,
    /// `/api/state`.
    State,
    /// `/api/trend`.
    Trend,
    /// `/api/events`.
    Events,
    /// `/api/audit`.
    Audit,
    /// The operator's page.
    Operator,
    /// Its script.
    OperatorScript,
    /// Its style.
    OperatorStyle,
    /// `/api/alarms`.
    Alarms,
    /// `/api/alarms/ack`.
    AlarmAck,
    /// `/api/force`.
    Force,
    /// `/api/write`.
    Write,
    /// `/api/unforce`.
    Unforce,
    /// `/api/auth`.
    Auth,
    /// `/api/trace…` (see [`super::trace`]).
    Trace(super::trace::TraceRoute),
}

/// The route of `method` on `path`: `Err(404)` for an unknown path, `Err(405)` for a known
/// path with the wrong method.
pub(crate) fn route(method: Method, path: &str) -> Result<Route, u16> {
    let (route, write) = match path {
        "/" | "/index.html" => (Route::Index, false),
        "/app.js" => (Route::Script, false),
        "/ladder.js" => (Route::LadderScript, false),
        "/shared.js" => (Route::SharedScript, false),
        "/style.css" => (Route::Style, false),
        "/api/info" => (Route::Info, false),
        "/api/state" => (Route::State, false),
        "/api/trend" => (Route::Trend, false),
        "/api/events" => (Route::Events, false),
        "/api/audit" => (Route::Audit, false),
        "/operator" => (Route::Operator, false),
        "/operator.js" => (Route::OperatorScript, false),
        "/operator.css" => (Route::OperatorStyle, false),
        "/api/alarms" => (Route::Alarms, false),
        "/api/alarms/ack" => (Route::AlarmAck, true),
        "/api/force" => (Route::Force, true),
        "/api/write" => (Route::Write, true),
        "/api/unforce" => (Route::Unforce, true),
        "/api/auth" => (Route::Auth, true),
        p => match super::trace::TraceRoute::of(p) {
            Some((t, write)) => (Route::Trace(t), write),
            None => return Err(404),
        },
    };
    match (method, write) {
        (Method::Post, true) | (Method::Get | Method::Head, false) => Ok(route),
        _ => Err(405),
    }
}

/// The methods `path` answers to (for a 405's `Allow`).
pub(crate) fn allowed(path: &str) -> &'static str {
    match route(Method::Post, path) {
        Ok(_) => "POST",
        Err(_) => "GET, HEAD",
    }
}

/// `POST /api/force`'s and `POST /api/write`'s body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TagValueBody {
    tag: String,
    value: serde_json::Value,
}

/// `POST /api/alarms/ack`'s body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AckBody {
    alarm: String,
}

/// `POST /api/unforce`'s body.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct UnforceBody {
    #[serde(default)]
    tag: Option<String>,
}

fn refused(status: u16, error: &str) -> Response {
    Response::json(
        status,
        serde_json::json!({ "ok": false, "error": error }).to_string(),
    )
}

/// The control request a write body asks for, or the response refusing it.
pub(crate) fn write_request(route: Route, body: &[u8]) -> Result<Control, Response> {
    let bad = |e: String| refused(400, &format!("bad request body: {e}"));
    let long = |what: &str| refused(400, &format!("the {what} is longer than {MAX_FIELD}"));
    match route {
        Route::Force | Route::Write => {
            let b: TagValueBody = serde_json::from_slice(body).map_err(|e| bad(e.to_string()))?;
            let value = match b.value {
                serde_json::Value::Bool(v) => u8::from(v).to_string(),
                serde_json::Value::Number(n) => n.to_string(),
                serde_json::Value::String(s) => s,
                _ => return Err(bad("value must be a string, a number or a boolean".into())),
            };
            if b.tag.len() > MAX_FIELD {
                return Err(long("tag name"));
            }
            if value.len() > MAX_FIELD {
                return Err(long("value"));
            }
            Ok(if route == Route::Write {
                Control::Write {
                    values: vec![TagValue { tag: b.tag, value }],
                }
            } else {
                Control::Force { tag: b.tag, value }
            })
        }
        Route::Unforce => {
            let b: UnforceBody = if body.iter().all(u8::is_ascii_whitespace) {
                UnforceBody { tag: None }
            } else {
                serde_json::from_slice(body).map_err(|e| bad(e.to_string()))?
            };
            if b.tag.as_ref().is_some_and(|t| t.len() > MAX_FIELD) {
                return Err(long("tag name"));
            }
            Ok(Control::Unforce { tag: b.tag })
        }
        Route::AlarmAck => {
            let b: AckBody = serde_json::from_slice(body).map_err(|e| bad(e.to_string()))?;
            if b.alarm.len() > MAX_FIELD {
                return Err(long("alarm name"));
            }
            Ok(Control::Alarms(AlarmRequest::Ack { alarm: b.alarm }))
        }
        _ => Err(refused(400, "not a write")),
    }
}

/// Checks and carries out a write: authorisation, body, then the scan.
pub(crate) fn write(
    auth: &WriteAuth,
    scan: &Sender<Envelope>,
    route: Route,
    req: &Request,
) -> Response {
    let act = match route {
        Route::Write => Act::Write,
        Route::Force => Act::Force,
        Route::Unforce => Act::Unforce,
        Route::AlarmAck => Act::Acknowledge,
        _ => Act::SignIn,
    };
    let role = match auth.authorize(req, act) {
        Ok(role) => role,
        Err(why) => return refused(403, &why.to_string()),
    };
    if route == Route::Auth {
        return Response::json(
            200,
            serde_json::json!({
                "ok": true,
                "message": format!("the token is valid: signed in as the {role}"),
                "role": role.to_string(),
            })
            .to_string(),
        );
    }
    let request = match write_request(route, &req.body) {
        Ok(r) => r,
        Err(response) => return response,
    };
    let (reply, answer): (Sender<ControlResponse>, Receiver<ControlResponse>) =
        crossbeam_channel::bounded(1);
    if scan
        .send_timeout(
            Envelope::new(
                request,
                reply,
                SCAN_ANSWER,
                crate::service::audit::Origin::Web(req.peer, Some(role)),
            ),
            QUEUE_WAIT,
        )
        .is_err()
    {
        return refused(503, "the scan is not taking requests (stopped or busy)");
    }
    match answer.recv_timeout(SCAN_ANSWER) {
        Ok(r) if r.ok => Response::json(
            200,
            serde_json::json!({ "ok": true, "message": r.message.unwrap_or_default() }).to_string(),
        ),
        Ok(r) => refused(409, &r.error.unwrap_or_else(|| "refused".into())),
        Err(_) => refused(504, "the scan did not answer within 3 s"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn routes_and_methods() {
        assert_eq!(route(Method::Get, "/"), Ok(Route::Index));
        assert_eq!(route(Method::Head, "/app.js"), Ok(Route::Script));
        assert_eq!(route(Method::Get, "/ladder.js"), Ok(Route::LadderScript));
        assert_eq!(route(Method::Get, "/api/events"), Ok(Route::Events));
        assert_eq!(route(Method::Post, "/api/force"), Ok(Route::Force));
        assert_eq!(route(Method::Get, "/api/force"), Err(405));
        assert_eq!(route(Method::Post, "/api/state"), Err(405));
        assert_eq!(route(Method::Post, "/api/auth"), Ok(Route::Auth));
        assert_eq!(route(Method::Post, "/api/write"), Ok(Route::Write));
        assert_eq!(route(Method::Get, "/api/write"), Err(405));
        assert_eq!(allowed("/api/unforce"), "POST");
        assert_eq!(allowed("/api/info"), "GET, HEAD");
        assert_eq!(route(Method::Get, "/../etc/passwd"), Err(404));
        assert_eq!(route(Method::Get, "/api/state/"), Err(404));
    }

    #[test]
    fn write_bodies() {
        let force = |b: &str| write_request(Route::Force, b.as_bytes());
        assert_eq!(
            force(r#"{"tag":"motor","value":true}"#).unwrap(),
            Control::Force {
                tag: "motor".into(),
                value: "1".into()
            }
        );
        assert_eq!(
            force(r#"{"tag":"speed","value":42}"#).unwrap(),
            Control::Force {
                tag: "speed".into(),
                value: "42".into()
            }
        );
        assert_eq!(
            force(r#"{"tag":"speed","value":"0x10"}"#).unwrap(),
            Control::Force {
                tag: "speed".into(),
                value: "0x10".into()
            }
        );
        for bad in [
            "",
            "{}",
            r#"{"tag":"m"}"#,
            r#"{"tag":"m","value":[1]}"#,
            r#"{"tag":"m","value":1,"x":2}"#,
            "\u{0}",
        ] {
            assert_eq!(force(bad).unwrap_err().status, 400, "{bad}");
        }
        let long = format!(r#"{{"tag":"{}","value":1}}"#, "a".repeat(MAX_FIELD + 1));
        assert_eq!(force(&long).unwrap_err().status, 400);
        assert_eq!(
            write_request(Route::Write, br#"{"tag":"speed","value":42}"#).unwrap(),
            Control::Write {
                values: vec![TagValue {
                    tag: "speed".into(),
                    value: "42".into()
                }]
            }
        );
        assert_eq!(
            write_request(Route::Write, br#"{"tag":"speed"}"#)
                .unwrap_err()
                .status,
            400
        );
        let unforce = |b: &str| write_request(Route::Unforce, b.as_bytes());
        assert_eq!(unforce("").unwrap(), Control::Unforce { tag: None });
        assert_eq!(unforce("{}").unwrap(), Control::Unforce { tag: None });
        assert_eq!(
            unforce(r#"{"tag":"motor"}"#).unwrap(),
            Control::Unforce {
                tag: Some("motor".into())
            }
        );
        assert_eq!(unforce(r#"{"tagg":"motor"}"#).unwrap_err().status, 400);
        assert_eq!(
            write_request(Route::AlarmAck, br#"{"alarm":"all"}"#).unwrap(),
            Control::Alarms(AlarmRequest::Ack {
                alarm: "all".into()
            })
        );
        assert_eq!(
            write_request(Route::AlarmAck, br#"{"tag":"jam"}"#)
                .unwrap_err()
                .status,
            400
        );
        assert_eq!(route(Method::Post, "/api/alarms/ack"), Ok(Route::AlarmAck));
        assert_eq!(route(Method::Get, "/api/alarms"), Ok(Route::Alarms));
        assert_eq!(route(Method::Get, "/operator"), Ok(Route::Operator));
    }
}
