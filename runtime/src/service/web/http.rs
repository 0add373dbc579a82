//! HTTP/1.1 as far as the web page and the metrics endpoint need it: one request per
//! connection, a bounded head and body, `Connection: close` on every response, and the server
//! that runs them ([`spawn`]): a thread per connection, at most [`Limits::clients`] at once,
//! [`Limits::request`] for a client to send its request (a 408 after), a timeout on every write
//! to it. When every slot is taken, the client that has waited longest without sending its
//! request gives its slot to the newcomer (a 503 only when every slot is being served), and
//! streams take at most [`Limits::streams`] of them (see [`crate::service::slots`]): slow or
//! silent clients never lock out the page or a scrape.
//!
//! Parsing is a total function over bytes ([`parse`]): it never panics, never allocates beyond
//! [`MAX_HEAD`] + [`MAX_BODY`], and refuses what it does not understand (chunked bodies, folded
//! headers, bare CR or LF, two different `Content-Length`s) instead of guessing, so a proxy in
//! front cannot read a request otherwise than this server does.

use std::fmt::Write as _;
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::service::accepting::Accepting;
pub(crate) use crate::service::slots::Held;
use crate::service::slots::{Caps, Evict, Slots};

/// Longest request head (request line and headers), in bytes.
pub(crate) const MAX_HEAD: usize = 8 * 1024;
/// Longest request body, in bytes (a force request is a few dozen).
pub(crate) const MAX_BODY: usize = 4 * 1024;
/// Most header lines.
pub(crate) const MAX_HEADERS: usize = 64;
/// Longest request target.
pub(crate) const MAX_TARGET: usize = 2048;

/// The methods served.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// `GET`.
    Get,
    /// `HEAD`: a `GET` without the body.
    Head,
    /// `POST`: the write actions.
    Post,
}

/// A parsed request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Request {
    /// The method.
    pub method: Method,
    /// The path, without the query.
    pub path: String,
    /// The query, without `?` (empty when absent).
    pub query: String,
    /// Headers, names in lower case, in order.
    pub headers: Vec<(String, String)>,
    /// The body (empty without `Content-Length`).
    pub body: Vec<u8>,
    /// The client's address (for the audit file), when the socket tells it.
    pub peer: Option<std::net::SocketAddr>,
}

impl Request {
    /// The value of the first header named `name` (lower case).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// A request this server refuses before routing it, as an HTTP status.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum HttpError {
    /// Malformed: not HTTP/1.x, bad characters, folded or malformed headers.
    #[error("400 Bad Request")]
    BadRequest,
    /// A method other than GET, HEAD and POST.
    #[error("405 Method Not Allowed")]
    MethodNotAllowed,
    /// A body larger than `MAX_BODY`.
    #[error("413 Content Too Large")]
    BodyTooLarge,
    /// A target longer than `MAX_TARGET`.
    #[error("414 URI Too Long")]
    TargetTooLong,
    /// A head longer than `MAX_HEAD` or with more than `MAX_HEADERS` lines.
    #[error("431 Request Header Fields Too Large")]
    HeadTooLarge,
    /// `Transfer-Encoding` (chunked bodies are not accepted).
    #[error("501 Not Implemented")]
    NotImplemented,
}

impl HttpError {
    /// The status code.
    pub fn status(self) -> u16 {
        match self {
            HttpError::BadRequest => 400,
            HttpError::MethodNotAllowed => 405,
            HttpError::BodyTooLarge => 413,
            HttpError::TargetTooLong => 414,
            HttpError::HeadTooLarge => 431,
            HttpError::NotImplemented => 501,
        }
    }
}

/// Parses the start of `buf`: `Ok(None)` while the request is incomplete (read more),
/// `Ok(Some(request))` once the head and its whole body are there, `Err` as soon as the
/// bytes cannot become an acceptable request.
pub fn parse(buf: &[u8]) -> Result<Option<Request>, HttpError> {
    let Some(head_end) = find(buf, b"\r\n\r\n") else {
        if buf.len() > MAX_HEAD {
            return Err(HttpError::HeadTooLarge);
        }
        // The request line alone can already be judged: refuse early what will never do.
        if let Some(line_end) = find(buf, b"\r\n") {
            request_line(buf.get(..line_end).unwrap_or_default())?;
        }
        return Ok(None);
    };
    if head_end + 4 > MAX_HEAD {
        return Err(HttpError::HeadTooLarge);
    }
    let head = buf.get(..head_end).unwrap_or_default();
    let head = std::str::from_utf8(head).map_err(|_| HttpError::BadRequest)?;
    let mut lines = head.split("\r\n");
    let (method, target) = request_line(lines.next().unwrap_or("").as_bytes())?;
    let mut headers = Vec::new();
    for line in lines {
        if headers.len() >= MAX_HEADERS {
            return Err(HttpError::HeadTooLarge);
        }
        headers.push(header_line(line)?);
    }
    if headers.iter().any(|(n, _)| n == "transfer-encoding") {
        return Err(HttpError::NotImplemented);
    }
    let mut length: Option<usize> = None;
    for (_, v) in headers.iter().filter(|(n, _)| n == "content-length") {
        if v.is_empty() || !v.bytes().all(|b| b.is_ascii_digit()) || v.len() > 9 {
            return Err(if v.len() > 9 && v.bytes().all(|b| b.is_ascii_digit()) {
                HttpError::BodyTooLarge
            } else {
                HttpError::BadRequest
            });
        }
        let n: usize = v.parse().map_err(|_| HttpError::BadRequest)?;
        if length.is_some_and(|l| l != n) {
            return Err(HttpError::BadRequest);
        }
        length = Some(n);
    }
    let length = length.unwrap_or(0);
    if length > MAX_BODY {
        return Err(HttpError::BodyTooLarge);
    }
    let body_start = head_end + 4;
    let Some(body) = buf.get(body_start..body_start + length) else {
        return Ok(None);
    };
    let (path, query) = match target.split_once('?') {
        Some((p, q)) => (p, q),
        None => (target, ""),
    };
    Ok(Some(Request {
        method,
        path: path.to_owned(),
        query: query.to_owned(),
        headers,
        body: body.to_vec(),
        peer: None,
    }))
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// `METHOD SP TARGET SP HTTP/1.x`.
fn request_line(line: &[u8]) -> Result<(Method, &str), HttpError> {
    let line = std::str::from_utf8(line).map_err(|_| HttpError::BadRequest)?;
    let mut parts = line.split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(HttpError::BadRequest);
    };
    if !matches!(version, "HTTP/1.0" | "HTTP/1.1") {
        return Err(HttpError::BadRequest);
    }
    if method.is_empty() || !method.bytes().all(|b| b.is_ascii_uppercase()) {
        return Err(HttpError::BadRequest);
    }
    if target.len() > MAX_TARGET {
        return Err(HttpError::TargetTooLong);
    }
    if !target.starts_with('/') || !target.bytes().all(|b| b.is_ascii_graphic()) {
        return Err(HttpError::BadRequest);
    }
    let method = match method {
        "GET" => Method::Get,
        "HEAD" => Method::Head,
        "POST" => Method::Post,
        _ => return Err(HttpError::MethodNotAllowed),
    };
    Ok((method, target))
}

/// `name: value`, the name lower-cased, the value without surrounding spaces.
fn header_line(line: &str) -> Result<(String, String), HttpError> {
    let (name, value) = line.split_once(':').ok_or(HttpError::BadRequest)?;
    let token = |b: u8| b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b);
    if name.is_empty() || !name.bytes().all(token) {
        // Also refuses obsolete line folding (a line starting with a space).
        return Err(HttpError::BadRequest);
    }
    let value = value.trim_matches([' ', '\t']);
    if !value
        .bytes()
        .all(|b| b == b'\t' || (b' '..=b'~').contains(&b))
    {
        return Err(HttpError::BadRequest);
    }
    Ok((name.to_ascii_lowercase(), value.to_owned()))
}

/// A response; every one closes the connection.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Response {
    /// Status code.
    pub status: u16,
    /// `Content-Type`.
    pub content_type: &'static str,
    /// Further headers.
    pub headers: Vec<(&'static str, String)>,
    /// The body.
    pub body: Vec<u8>,
}

impl Response {
    /// A response with a body.
    pub(crate) fn new(status: u16, content_type: &'static str, body: impl Into<Vec<u8>>) -> Self {
        Self {
            status,
            content_type,
            headers: Vec::new(),
            body: body.into(),
        }
    }

    /// A JSON response.
    pub(crate) fn json(status: u16, body: impl Into<Vec<u8>>) -> Self {
        Self::new(status, "application/json", body)
    }

    /// A plain-text error response for `status`, saying `why`.
    pub(crate) fn error(status: u16, why: &str) -> Self {
        Self::new(
            status,
            "text/plain; charset=utf-8",
            format!("{} {}: {why}\n", status, reason(status)),
        )
    }

    /// Adds a header.
    pub(crate) fn with(mut self, name: &'static str, value: impl Into<String>) -> Self {
        self.headers.push((name, value.into()));
        self
    }

    /// The bytes to send; the body only when `with_body` (not for HEAD).
    pub(crate) fn to_bytes(&self, with_body: bool) -> Vec<u8> {
        let mut head = String::with_capacity(512);
        let _ = write!(
            head,
            "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n",
            self.status,
            reason(self.status),
            self.content_type,
            self.body.len()
        );
        head.push_str(SECURITY_HEADERS);
        for (name, value) in &self.headers {
            // Values are ours, but a newline in one would split the head: drop such a header.
            if !value.contains(['\r', '\n']) {
                let _ = write!(head, "{name}: {value}\r\n");
            }
        }
        head.push_str("Connection: close\r\n\r\n");
        let mut out = head.into_bytes();
        if with_body {
            out.extend_from_slice(&self.body);
        }
        out
    }
}

/// Sent with every response: the page loads nothing from elsewhere and may not be framed
/// (clickjacking of the force buttons), nothing is sniffed, no referrer leaves.
pub(crate) const SECURITY_HEADERS: &str = "Content-Security-Policy: default-src 'self'; \
    img-src 'self' data:; style-src 'self'; script-src 'self'; connect-src 'self'; \
    frame-ancestors 'none'; base-uri 'none'; form-action 'none'\r\n\
    X-Content-Type-Options: nosniff\r\n\
    X-Frame-Options: DENY\r\n\
    Referrer-Policy: no-referrer\r\n\
    Cache-Control: no-store\r\n";

/// The reason phrase of a status code.
pub(crate) fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        409 => "Conflict",
        413 => "Content Too Large",
        414 => "URI Too Long",
        415 => "Unsupported Media Type",
        421 => "Misdirected Request",
        431 => "Request Header Fields Too Large",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        504 => "Gateway Timeout",
        _ => "Status",
    }
}

/// The bounds of a server.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Limits {
    /// Connections served at once; more are answered 503 at once.
    pub clients: usize,
    /// How long a client may take to send its whole request, from its connection.
    pub request: Duration,
    /// How long one write to a client may block.
    pub write: Duration,
    /// Of the clients, streams at once (see [`crate::service::slots`]).
    pub streams: usize,
}

/// A server's name (its threads' and its log lines'), bounds and the methods it serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ServerConfig {
    /// Thread name of the accepting thread; client threads get `-client` appended.
    pub name: &'static str,
    /// Its bounds.
    pub limits: Limits,
    /// The `Allow` header of a 405 for a method the parser refuses (not GET, HEAD, POST).
    pub allow: &'static str,
}

/// Serves `listener` on a thread of its own: every connection gets a thread, its request is
/// read and parsed within the limits (errors answered here: 400, 405, 408, 413, 414, 431,
/// 501, 503), and `handler` answers the request on the connection (a whole [`Response`], or a
/// stream); the connection is then closed.
pub(crate) fn spawn<H>(
    listener: TcpListener,
    config: ServerConfig,
    accepting: Accepting,
    handler: H,
) -> std::io::Result<()>
where
    H: Fn(&Request, &mut TcpStream, &Held) -> std::io::Result<()> + Send + Sync + 'static,
{
    let shared = Arc::new(Served {
        config,
        handler,
        slots: Slots::new(Caps {
            clients: config.limits.clients,
            streams: config.limits.streams,
        }),
    });
    std::thread::Builder::new()
        .name(config.name.into())
        .spawn(move || accept(&listener, &shared, &accepting))?;
    Ok(())
}

/// What every connection thread of one server shares.
struct Served<H> {
    config: ServerConfig,
    handler: H,
    slots: Slots,
}

/// Shuts `stream` when called: its thread's next read or write fails, and it ends.
fn evict_of(stream: &TcpStream) -> Evict {
    let handle = stream.try_clone();
    Box::new(move || {
        if let Ok(s) = &handle {
            // Best effort: the client may be gone already.
            drop(s.shutdown(std::net::Shutdown::Both));
        }
    })
}

fn accept<H>(listener: &TcpListener, shared: &Arc<Served<H>>, accepting: &Accepting)
where
    H: Fn(&Request, &mut TcpStream, &Held) -> std::io::Result<()> + Send + Sync + 'static,
{
    let name = shared.config.name;
    for stream in listener.incoming() {
        let stream = match stream {
            Ok(stream) => stream,
            Err(e) => {
                // Out of file descriptors and the like: said, and retried without spinning.
                accepting.failed(&e);
                std::thread::sleep(Duration::from_millis(10));
                continue;
            }
        };
        accepting.taken();
        let Some(held) = shared.slots.admit_patiently(|| evict_of(&stream)) else {
            busy(stream);
            continue;
        };
        let served = shared.clone();
        let spawned = std::thread::Builder::new()
            .name(format!("{name}-client"))
            .spawn(move || {
                if let Err(e) = serve(stream, &served, &held) {
                    tracing::debug!("{name} client: {e}");
                }
            });
        // On failure the closure, and with it the slot, is dropped: the count is right.
        if let Err(e) = spawned {
            tracing::debug!("{name}: cannot start a client thread: {e}");
        }
    }
}

/// Answers 503 on the accepting thread, without ever waiting there.
fn busy(mut stream: TcpStream) {
    // Best effort throughout: a client that is gone or slow gets no answer, and the
    // accepting thread must not wait on it.
    drop(stream.set_write_timeout(Some(Duration::from_millis(200))));
    let busy = Response::error(503, "too many connections; try again");
    drop(stream.write_all(&busy.with("Retry-After", "1").to_bytes(true)));
    // Drop what already arrived (see `close`) without waiting.
    drop(stream.set_nonblocking(true));
    let mut sink = [0u8; 4096];
    for _ in 0..16 {
        if !matches!(stream.read(&mut sink), Ok(n) if n > 0) {
            break;
        }
    }
    drop(stream.shutdown(std::net::Shutdown::Write));
}

/// Reads one request within `within`: `Ok(None)` when the client closed first.
fn read_request(
    stream: &mut TcpStream,
    within: Duration,
) -> std::io::Result<Option<Result<Request, HttpError>>> {
    let deadline = Instant::now() + within;
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
        match parse(&buf) {
            Ok(None) if buf.len() > MAX_HEAD + MAX_BODY => {
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
    // Best effort throughout: the client may be gone already.
    drop(stream.flush());
    drop(stream.shutdown(std::net::Shutdown::Write));
    drop(stream.set_read_timeout(Some(Duration::from_millis(200))));
    let mut sink = [0u8; 4096];
    for _ in 0..16 {
        match stream.read(&mut sink) {
            Ok(n) if n > 0 => {}
            _ => break,
        }
    }
}

fn serve<H>(mut stream: TcpStream, shared: &Served<H>, held: &Held) -> std::io::Result<()>
where
    H: Fn(&Request, &mut TcpStream, &Held) -> std::io::Result<()>,
{
    let result = answer(&mut stream, shared, held);
    close(stream);
    result
}

fn answer<H>(stream: &mut TcpStream, shared: &Served<H>, held: &Held) -> std::io::Result<()>
where
    H: Fn(&Request, &mut TcpStream, &Held) -> std::io::Result<()>,
{
    let limits = shared.config.limits;
    stream.set_write_timeout(Some(limits.write))?;
    let request = read_request(stream, limits.request);
    held.busy();
    match request {
        Ok(Some(Ok(mut req))) => {
            req.peer = stream.peer_addr().ok();
            (shared.handler)(&req, stream, held)
        }
        Ok(Some(Err(e))) => {
            let mut r = Response::error(e.status(), &e.to_string());
            if e == HttpError::MethodNotAllowed {
                r = r.with("Allow", shared.config.allow);
            }
            stream.write_all(&r.to_bytes(true))
        }
        Ok(None) => Ok(()),
        // A read timeout is WouldBlock on Unix, TimedOut elsewhere.
        Err(e)
            if matches!(
                e.kind(),
                std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
            ) =>
        {
            let r = Response::error(408, "the request took too long");
            stream.write_all(&r.to_bytes(true))
        }
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_get_and_a_post_with_its_body() {
        let r = parse(b"GET /api/state?x=1 HTTP/1.1\r\nHost: a\r\nX-Y:  z \r\n\r\n")
            .unwrap()
            .unwrap();
        assert_eq!(r.method, Method::Get);
        assert_eq!((r.path.as_str(), r.query.as_str()), ("/api/state", "x=1"));
        assert_eq!(r.header("x-y"), Some("z"));
        assert_eq!(r.header("host"), Some("a"));
        let post = b"POST /api/force HTTP/1.1\r\nContent-Length: 5\r\n\r\nhello";
        for cut in 0..post.len() {
            assert_eq!(parse(&post[..cut]), Ok(None), "{cut}");
        }
        assert_eq!(parse(post).unwrap().unwrap().body, b"hello");
    }

    #[test]
    fn refusals() {
        for (bytes, e) in [
            (&b"PUT / HTTP/1.1\r\n\r\n"[..], HttpError::MethodNotAllowed),
            (b"get / HTTP/1.1\r\n\r\n", HttpError::BadRequest),
            (b"GET / HTTP/2\r\n\r\n", HttpError::BadRequest),
            (b"GET  / HTTP/1.1\r\n\r\n", HttpError::BadRequest),
            (b"GET x HTTP/1.1\r\n\r\n", HttpError::BadRequest),
            (b"GET / HTTP/1.1\r\n folded\r\n\r\n", HttpError::BadRequest),
            (b"GET / HTTP/1.1\r\nA\nB: c\r\n\r\n", HttpError::BadRequest),
            (b"GET / HTTP/1.1\r\nNoColon\r\n\r\n", HttpError::BadRequest),
            (b"GET / HTTP/1.1\r\nX: \xff\r\n\r\n", HttpError::BadRequest),
            (
                b"POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n",
                HttpError::NotImplemented,
            ),
            (
                b"POST / HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\nab",
                HttpError::BadRequest,
            ),
            (
                b"POST / HTTP/1.1\r\nContent-Length: -1\r\n\r\n",
                HttpError::BadRequest,
            ),
            (
                b"POST / HTTP/1.1\r\nContent-Length: 4097\r\n\r\n",
                HttpError::BodyTooLarge,
            ),
            (
                b"POST / HTTP/1.1\r\nContent-Length: 99999999999999999999\r\n\r\n",
                HttpError::BodyTooLarge,
            ),
        ] {
            assert_eq!(parse(bytes), Err(e), "{}", String::from_utf8_lossy(bytes));
        }
        // Judged on the request line, before the head is complete.
        assert_eq!(
            parse(b"BREW /pot HTTP/1.1\r\n"),
            Err(HttpError::MethodNotAllowed)
        );
        assert_eq!(parse(&[b'a'; MAX_HEAD + 1]), Err(HttpError::HeadTooLarge));
        let long = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(MAX_TARGET));
        assert_eq!(parse(long.as_bytes()), Err(HttpError::TargetTooLong));
        let many = format!(
            "GET / HTTP/1.1\r\n{}\r\n",
            "A: b\r\n".repeat(MAX_HEADERS + 1)
        );
        assert_eq!(parse(many.as_bytes()), Err(HttpError::HeadTooLarge));
    }

    #[test]
    fn arbitrary_bytes_never_panic() {
        // A small deterministic fuzz: every prefix of mutated requests.
        let seeds: [&[u8]; 3] = [
            b"POST /api/force HTTP/1.1\r\nContent-Length: 3\r\nAuthorization: Bearer x\r\n\r\nabc",
            b"GET /api/events HTTP/1.0\r\n\r\n",
            b"\r\n\r\n\r\n:::\x00\xff",
        ];
        let mut state = 0x2545_f491_u32;
        for seed in seeds {
            for _ in 0..300 {
                let mut bytes = seed.to_vec();
                for _ in 0..3 {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    let at = state as usize % bytes.len();
                    bytes[at] = (state >> 8) as u8;
                }
                for cut in 0..=bytes.len() {
                    // Any answer will do; the test is that it comes without a panic.
                    drop(parse(&bytes[..cut]));
                }
            }
        }
    }

    #[test]
    fn responses_close_and_carry_the_security_headers() {
        let r = Response::json(200, "{}")
            .with("X-A", "1")
            .with("X-Bad", "a\r\nb");
        let text = String::from_utf8(r.to_bytes(true)).unwrap();
        assert!(text.starts_with(
            "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: 2\r\n"
        ));
        assert!(text.contains("\r\nX-A: 1\r\n") && !text.contains("X-Bad"));
        assert!(text.contains("frame-ancestors 'none'"));
        assert!(text.ends_with("Connection: close\r\n\r\n{}"));
        let head = String::from_utf8(r.to_bytes(false)).unwrap();
        assert!(head.ends_with("\r\n\r\n"));
        assert!(Response::error(404, "no")
            .to_bytes(true)
            .starts_with(b"HTTP/1.1 404 Not Found"));
    }
}
