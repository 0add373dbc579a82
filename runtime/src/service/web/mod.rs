//! The web page of a running instance: an overview (state, scan figures, faults), the I/O
//! table per line and module with live values, quality and age, forcing where the project
//! allows it, the program with live values beside each rung or tag and the pushed-down rungs
//! marked, histograms of the cycle and phase times, a scrolling trend, the bus counters.
//!
//! # Why a small std server and not axum
//!
//! The page needs a handful of fixed routes, one request per connection and one long-lived
//! response (server-sent events), for a few people at a time. A std server on threads does
//! that in a few hundred lines that can be read whole and fuzzed ([`http::parse`] is a total
//! function over bytes), adds no dependency (axum would bring hyper, tower and their
//! transitive crates into a PLC runtime), and shares nothing with the scan but the snapshot it
//! publishes without waiting (`crate::service::snapshot`) and the control channel that
//! applies forces at cycle boundaries ([`crate::service::control`]).
//!
//! Bounds: [`MAX_CLIENTS`] connections at once (a 503 beyond), a request head of 8 KiB and a
//! body of 4 KiB, [`REQUEST_DEADLINE`] to send a request, [`WRITE_TIMEOUT`] for a client to take
//! each write, event streams that end after 10 minutes (the browser reconnects). Every asset
//! is embedded in the binary: the page works without internet.
//!
//! The operator's page (`/operator`, `assets/operator.*`) is a page of its own for a panel PC
//! at 800 × 480: the alarms and the tags marked `operator: true`, touch-sized, no horizontal
//! scrolling; the operator's token suffices for everything on it.
//!
//! Files: `http` (parsing, responses), `routes` (what each path answers, writes),
//! `auth` (who may write), `sse` (the event stream), `info` and `program` (what does
//! not change), `view` (the live JSON), `trend` (the trend's history), `assets/` (the page).

pub(crate) mod auth;
pub(crate) mod http;
pub(crate) mod info;
pub(crate) mod program;
pub(crate) mod routes;
pub(crate) mod sse;
pub(crate) mod trace;
pub(crate) mod trend;
pub(crate) mod view;

pub use http::{parse as parse_http, HttpError, Method, Request};
pub use info::{BusInfo, ModuleInfo, TagInfo, TaskInfo, TaskPart, WebInfo};
pub use program::{Line, Part, ProgramView, RungMark};

use crate::service::accepting::Accepting;
use crate::service::health::{Health, Service};
use std::io::Write;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::Sender;

use self::auth::WriteAuth;
use self::http::{Limits, Response, ServerConfig};
use self::routes::Route;
use self::trend::Trend;
use super::control::Envelope;
use super::snapshot::SnapshotCell;
use crate::project::WebConfig;

/// Connections served at once; past it the client waiting longest for its request gives way,
/// and 503 is the answer only when every connection is being served.
pub const MAX_CLIENTS: usize = 16;
/// Of the connections, event streams at once: the other half stays for the page's requests.
pub const MAX_STREAMS: usize = 8;
/// How long a client may take to send its request.
pub const REQUEST_DEADLINE: Duration = Duration::from_secs(5);
/// How long one write to a client may block.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(5);

/// How many of the audit file's entries the page shows (the newest).
const AUDIT_SHOWN: usize = 50;
/// How many of the alarm events the page shows (the newest).
const ALARM_EVENTS_SHOWN: usize = 50;

/// What every connection thread shares.
#[derive(Debug)]
struct Shared {
    info_json: String,
    /// The services' states, for the overview.
    health: Health,
    snapshot: SnapshotCell,
    scan: Sender<Envelope>,
    auth: WriteAuth,
    trend: Arc<Mutex<Trend>>,
    bind: SocketAddr,
    port: u16,
    /// The audit file's latest entries and the alarms.
    records: WebRecords,
}

/// What the page shows beside the snapshot: the audit file's latest entries (the Audit panel)
/// and the alarms (the Alarms panel and the operator's page).
#[derive(Debug, Clone, Default)]
pub struct WebRecords {
    /// The audit file.
    pub audit: Option<crate::service::audit::AuditLog>,
    /// The alarms.
    pub alarms: Option<crate::service::alarms::Alarms>,
}

/// A running page; it lives as long as the process.
#[derive(Debug)]
pub struct WebServer {
    addr: SocketAddr,
    writes: bool,
}

impl WebServer {
    /// Binds `config.bind` and serves `info`, the live `snapshot` and the services' states
    /// `health` on threads; writes go to `scan`. `period` is the scan period (the trend
    /// samples at most once per cycle; with several tasks, the fastest task's period). `records` feed the Audit and Alarms panels.
    pub fn start(
        config: &WebConfig,
        info: &WebInfo,
        snapshot: SnapshotCell,
        scan: Sender<Envelope>,
        period: Duration,
        health: &Health,
        records: WebRecords,
    ) -> std::io::Result<Self> {
        let listener = TcpListener::bind(config.bind)?;
        let addr = listener.local_addr()?;
        // With several tasks each trend tag is sampled at the cycles of the task publishing it.
        let owners = match info.tasks.is_empty() {
            true => Vec::new(),
            false => (config.trend.iter())
                .map(|&t| info.tags.get(t).and_then(|t| t.task).unwrap_or(0))
                .collect(),
        };
        let trend = Arc::new(Mutex::new(
            Trend::new(config.trend.clone()).sampled_by(owners),
        ));
        trend::spawn_sampler(snapshot.clone(), trend.clone(), period)?;
        let auth = WriteAuth::new(
            config.writes,
            config.token.clone(),
            config.operator_token.clone(),
        );
        let writes = auth.enabled();
        let shared = Arc::new(Shared {
            info_json: serde_json::to_string(info).map_err(std::io::Error::other)?,
            health: health.clone(),
            snapshot,
            scan,
            auth,
            trend,
            bind: config.bind,
            port: addr.port(),
            records,
        });
        let server = ServerConfig {
            name: "web",
            limits: Limits {
                clients: MAX_CLIENTS,
                request: REQUEST_DEADLINE,
                write: WRITE_TIMEOUT,
                streams: MAX_STREAMS,
            },
            allow: "GET, HEAD, POST",
        };
        let accepting = Accepting::new(health, Service::Web);
        http::spawn(listener, server, accepting, move |req, stream, held| {
            answer(req, stream, &shared, held)
        })?;
        Ok(Self { addr, writes })
    }

    /// The address it listens on (the bound port when the configured one was 0).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Whether the page may force tags.
    pub fn writes(&self) -> bool {
        self.writes
    }
}

/// Answers one request (read and checked by [`http::spawn`]) on its connection.
fn answer(
    req: &Request,
    stream: &mut TcpStream,
    shared: &Shared,
    held: &http::Held,
) -> std::io::Result<()> {
    let with_body = req.method != Method::Head;
    match respond(req, shared) {
        Reply::Full(r) => stream.write_all(&r.to_bytes(with_body)),
        Reply::Events if !with_body => stream.write_all(sse::head().as_bytes()),
        Reply::Events if !held.stream() => {
            // The browser retries after `Retry-After`; the slots stay for requests.
            let busy =
                Response::error(503, "too many event streams; try again").with("Retry-After", "1");
            stream.write_all(&busy.to_bytes(true))
        }
        Reply::Events => {
            crate::service::socket::bound_send_buffer(stream, sse::SEND_BUFFER);
            sse::stream(stream, &shared.snapshot, &shared.health)
        }
    }
}

/// What a request gets.
#[derive(Debug)]
enum Reply {
    /// A whole response.
    Full(Response),
    /// The event stream.
    Events,
}

fn respond(req: &Request, shared: &Shared) -> Reply {
    if !auth::host_allowed(shared.bind, shared.port, req.header("host")) {
        return Reply::Full(Response::error(
            403,
            "this page answers to 127.0.0.1, localhost and [::1] only",
        ));
    }
    let route = match routes::route(req.method, &req.path) {
        Ok(r) => r,
        Err(405) => {
            let allow = routes::allowed(&req.path);
            return Reply::Full(Response::error(405, "wrong method").with("Allow", allow));
        }
        Err(status) => return Reply::Full(Response::error(status, "no such page")),
    };
    let text = |ct: &'static str, body: &'static str| Reply::Full(Response::new(200, ct, body));
    match route {
        Route::Index => text("text/html; charset=utf-8", routes::INDEX_HTML),
        Route::Operator => text("text/html; charset=utf-8", routes::OPERATOR_HTML),
        Route::OperatorScript => text("text/javascript; charset=utf-8", routes::OPERATOR_JS),
        Route::OperatorStyle => text("text/css; charset=utf-8", routes::OPERATOR_CSS),
        Route::Alarms => Reply::Full(match &shared.records.alarms {
            Some(a) => Response::json(
                200,
                serde_json::to_string(&a.list(ALARM_EVENTS_SHOWN)).unwrap_or_default(),
            ),
            None => Response::error(503, "this instance runs no alarm service"),
        }),
        Route::Script => text("text/javascript; charset=utf-8", routes::APP_JS),
        Route::LadderScript => text("text/javascript; charset=utf-8", routes::LADDER_JS),
        Route::SharedScript => text("text/javascript; charset=utf-8", routes::SHARED_JS),
        Route::Style => text("text/css; charset=utf-8", routes::STYLE_CSS),
        Route::Info => Reply::Full(Response::json(200, shared.info_json.clone())),
        Route::State => {
            let s = shared.snapshot.get();
            let body = serde_json::json!({ "state": view::state(&s), "stats": view::stats(&s, &shared.health) });
            Reply::Full(Response::json(200, body.to_string()))
        }
        Route::Trend => {
            let t = shared
                .trend
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .clone();
            Reply::Full(Response::json(200, view::trend(&t).to_string()))
        }
        Route::Events => Reply::Events,
        Route::Audit => {
            let latest = shared
                .records
                .audit
                .as_ref()
                .map(|a| a.latest(AUDIT_SHOWN))
                .unwrap_or_default();
            Reply::Full(Response::json(
                200,
                serde_json::json!({ "entries": latest }).to_string(),
            ))
        }
        Route::Trace(t) => Reply::Full(trace::answer(&shared.auth, &shared.scan, t, req)),
        Route::Force | Route::Write | Route::Unforce | Route::Auth | Route::AlarmAck => {
            Reply::Full(routes::write(&shared.auth, &shared.scan, route, req))
        }
    }
}
