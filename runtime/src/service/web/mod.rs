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
//! publishes without waiting ([`crate::service::snapshot`]) and the control channel that
//! applies forces at cycle boundaries ([`crate::service::control`]).
//!
//! Bounds: [`MAX_CLIENTS`] connections at once (a 503 beyond), a request head of 8 KiB and a
//! body of 4 KiB, [`REQUEST_DEADLINE`] to send a request, [`WRITE_TIMEOUT`] for a client to take
//! each write, event streams that end after 10 minutes (the browser reconnects). Every asset
//! is embedded in the binary: the page works without internet.
//!
//! Files: [`http`] (parsing, responses), [`routes`] (what each path answers, writes),
//! [`auth`] (who may write), [`sse`] (the event stream), [`info`] and [`program`] (what does
//! not change), [`view`] (the live JSON), [`trend`] (the trend's history), `assets/` (the page).

pub mod auth;
pub mod http;
pub mod info;
pub mod program;
pub mod routes;
pub mod sse;
pub mod trend;
pub mod view;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::Sender;

use self::auth::WriteAuth;
use self::http::{HttpError, Method, Request, Response};
use self::info::WebInfo;
use self::routes::Route;
use self::trend::Trend;
use super::control::Envelope;
use super::snapshot::SnapshotCell;
use crate::project::WebConfig;

/// Connections served at once; more are answered 503 at once.
pub const MAX_CLIENTS: usize = 16;
/// How long a client may take to send its request.
pub const REQUEST_DEADLINE: Duration = Duration::from_secs(5);
/// How long one write to a client may block.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(5);

/// What every connection thread shares.
#[derive(Debug)]
struct Shared {
    info_json: String,
    snapshot: SnapshotCell,
    scan: Sender<Envelope>,
    auth: WriteAuth,
    trend: Arc<Mutex<Trend>>,
    bind: SocketAddr,
    port: u16,
    clients: AtomicUsize,
}

/// A running page; it lives as long as the process.
#[derive(Debug)]
pub struct WebServer {
    addr: SocketAddr,
    writes: bool,
}

impl WebServer {
    /// Binds `config.bind` and serves `info` and the live `snapshot` on threads; writes go to
    /// `scan`. `period` is the scan period (the trend samples at most once per cycle).
    pub fn start(
        config: &WebConfig,
        info: &WebInfo,
        snapshot: SnapshotCell,
        scan: Sender<Envelope>,
        period: Duration,
    ) -> std::io::Result<Self> {
        let listener = TcpListener::bind(config.bind)?;
        let addr = listener.local_addr()?;
        let trend = Arc::new(Mutex::new(Trend::new(config.trend.clone())));
        trend::spawn_sampler(snapshot.clone(), trend.clone(), period)?;
        let auth = WriteAuth::new(config.writes, config.token.clone());
        let writes = auth.enabled();
        let shared = Arc::new(Shared {
            info_json: serde_json::to_string(info).map_err(std::io::Error::other)?,
            snapshot,
            scan,
            auth,
            trend,
            bind: config.bind,
            port: addr.port(),
            clients: AtomicUsize::new(0),
        });
        std::thread::Builder::new()
            .name("web".into())
            .spawn(move || accept(listener, shared))?;
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

/// Gives the client's slot back when its thread ends, however it ends.
struct Slot(Arc<Shared>);

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.clients.fetch_sub(1, Ordering::AcqRel);
    }
}

fn accept(listener: TcpListener, shared: Arc<Shared>) {
    for stream in listener.incoming() {
        let Ok(mut stream) = stream else {
            // Out of file descriptors and the like: do not spin.
            std::thread::sleep(Duration::from_millis(10));
            continue;
        };
        if shared.clients.fetch_add(1, Ordering::AcqRel) >= MAX_CLIENTS {
            shared.clients.fetch_sub(1, Ordering::AcqRel);
            let _ = stream.set_write_timeout(Some(Duration::from_millis(200)));
            let busy = Response::error(503, "too many connections; try again");
            let _ = stream.write_all(&busy.with("Retry-After", "1").to_bytes(true));
            // Drop what already arrived (see `close`) without ever waiting in this thread.
            let _ = stream.set_nonblocking(true);
            let mut sink = [0u8; 4096];
            for _ in 0..16 {
                if !matches!(stream.read(&mut sink), Ok(n) if n > 0) {
                    break;
                }
            }
            let _ = stream.shutdown(std::net::Shutdown::Write);
            continue;
        }
        let slot = Slot(shared.clone());
        let spawned = std::thread::Builder::new()
            .name("web-client".into())
            .spawn(move || {
                let slot = slot;
                if let Err(e) = serve(stream, &slot.0) {
                    tracing::debug!("web client: {e}");
                }
            });
        // On failure the closure, and with it the slot, is dropped: the count is right.
        if let Err(e) = spawned {
            tracing::debug!("web: cannot start a client thread: {e}");
        }
    }
}

/// Reads one request within [`REQUEST_DEADLINE`]: `Ok(None)` when the client closed first.
fn read_request(stream: &mut TcpStream) -> std::io::Result<Option<Result<Request, HttpError>>> {
    let deadline = Instant::now() + REQUEST_DEADLINE;
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 2048];
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(std::io::ErrorKind::TimedOut.into());
        }
        stream.set_read_timeout(Some(left))?;
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Ok(None);
        }
        buf.extend_from_slice(chunk.get(..n).unwrap_or_default());
        match http::parse(&buf) {
            Ok(None) if buf.len() > http::MAX_HEAD + http::MAX_BODY => {
                return Ok(Some(Err(HttpError::BodyTooLarge)))
            }
            Ok(None) => {}
            Ok(Some(req)) => return Ok(Some(Ok(req))),
            Err(e) => return Ok(Some(Err(e))),
        }
    }
}

/// Ends a connection after its response: closing a socket with unread input resets it, and a
/// reset can overtake the response (a refused upload would see no 413). So the sending side is
/// shut first and what the client still sends is read and dropped, briefly and boundedly.
fn close(mut stream: TcpStream) {
    let _ = stream.flush();
    let _ = stream.shutdown(std::net::Shutdown::Write);
    let _ = stream.set_read_timeout(Some(Duration::from_millis(200)));
    let mut sink = [0u8; 4096];
    for _ in 0..16 {
        match stream.read(&mut sink) {
            Ok(n) if n > 0 => {}
            _ => break,
        }
    }
}

fn serve(mut stream: TcpStream, shared: &Shared) -> std::io::Result<()> {
    let result = answer(&mut stream, shared);
    close(stream);
    result
}

fn answer(stream: &mut TcpStream, shared: &Shared) -> std::io::Result<()> {
    stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
    let req = match read_request(stream) {
        Ok(Some(Ok(req))) => req,
        Ok(Some(Err(e))) => {
            let mut r = Response::error(e.status(), &e.to_string());
            if e == HttpError::MethodNotAllowed {
                r = r.with("Allow", "GET, HEAD, POST");
            }
            return stream.write_all(&r.to_bytes(true));
        }
        Ok(None) => return Ok(()),
        // A read timeout is WouldBlock on Unix, TimedOut elsewhere.
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
            ) =>
        {
            let r = Response::error(408, "the request took too long");
            return stream.write_all(&r.to_bytes(true));
        }
        Err(e) => return Err(e),
    };
    let with_body = req.method != Method::Head;
    let response = respond(&req, shared);
    match response {
        Reply::Full(r) => stream.write_all(&r.to_bytes(with_body)),
        Reply::Events if !with_body => stream.write_all(sse::head().as_bytes()),
        Reply::Events => sse::stream(stream, &shared.snapshot),
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
        Route::Script => text("text/javascript; charset=utf-8", routes::APP_JS),
        Route::Style => text("text/css; charset=utf-8", routes::STYLE_CSS),
        Route::Info => Reply::Full(Response::json(200, shared.info_json.clone())),
        Route::State => {
            let s = shared.snapshot.get();
            let body = serde_json::json!({ "state": view::state(&s), "stats": view::stats(&s) });
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
        Route::Force | Route::Unforce | Route::Auth => {
            Reply::Full(routes::write(&shared.auth, &shared.scan, route, req))
        }
    }
}
