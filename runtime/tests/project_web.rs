//! The web page: its `service.web:` settings (defaults, tokens from the file, a file or the
//! environment, every error at its `line:column`) and its HTTP side on a live server in this
//! process (routes, the security headers, the `Host` check, writes refused without the token
//! or forwarded to the scan with it, the event stream's framing, the bounds).

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use softplc::project::{
    parse_str, ErrorKind, Project, ServiceError, WebConfig, WebError, WebToken,
};
use softplc::service::control::{Envelope, Request, Response};
use softplc::service::web::{ProgramView, WebInfo, WebServer};
use softplc::service::{ServiceSnapshot, SnapshotCell};

use softplc_io::point::{Quality, Value};
use softplc_io::time::ScanInstant;

/// Lines 1..=10: a program, one simulated bus, one MiniMod; `tags:` is line 11, then three
/// tags (lines 12..=14); the text after `HEAD` starts on line 15.
const HEAD: &str = "\
project: t
scan:
  period: 20ms
program:
  file: conveyor.expr
  kind: expr
buses:
  - { name: line1, port: sim }
modules:
  - { name: mm1, bus: line1, model: minimod, address: 1 }
tags:
  - { name: count, type: u16 }
  - { name: start, point: mm1.X1 }
  - { name: motor, point: mm1.Y1 }
";

/// A scratch folder with the program (and room for a token file); the project pretends to
/// be `project.yaml` in it.
fn folder(case: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-web-{}-{case}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    std::fs::copy(
        repo.join("programs/conveyor.expr"),
        dir.join("conveyor.expr"),
    )
    .unwrap();
    dir
}

fn parse_in(dir: &Path, web: &str) -> Result<Project, Vec<softplc::project::ProjectError>> {
    parse_str(&format!("{HEAD}{web}"), &dir.join("project.yaml")).map_err(|e| e.errors)
}

fn web(dir: &Path, text: &str) -> WebConfig {
    match parse_in(dir, text) {
        Ok(p) => p.service.web.expect("a web page"),
        Err(e) => panic!("{e:#?}"),
    }
}

/// The single error: position, web error and the printed line.
fn one(dir: &Path, text: &str) -> ((usize, usize), WebError, String) {
    let mut e = parse_in(dir, text).expect_err("an error");
    assert_eq!(e.len(), 1, "expected one error, got {e:#?}");
    let e = e.remove(0);
    match e.kind.clone() {
        ErrorKind::Service(ServiceError::Web(w)) => ((e.line, e.column), w, e.to_string()),
        other => panic!("not a web error: {other:?} ({e})"),
    }
}

#[test]
fn defaults_are_loopback_8080_read_only_and_the_module_tags_in_the_trend() {
    let dir = folder("defaults");
    let p = parse_in(&dir, "").unwrap();
    assert_eq!(p.service.web, None, "no page unless the project asks");
    let w = web(&dir, "service:\n  web: {}\n");
    assert_eq!(w.bind, "127.0.0.1:8080".parse::<SocketAddr>().unwrap());
    assert!(!w.writes);
    assert_eq!(w.token, None);
    assert_eq!(w.trend, vec![1, 2], "the tags on module points");
    let w = web(
        &dir,
        "service:\n  web: { bind: \"[::1]:0\", trend: [motor, count] }\n",
    );
    assert_eq!(w.bind.port(), 0);
    assert_eq!(w.trend, vec![2, 0]);
}

/// The operator's token is read like the engineer's (same file rules, errors at the key's
/// place); a project with only `token_file` has no operator; one token for both roles is refused.
#[test]
fn the_operator_token_is_read_like_the_engineers_and_must_differ() {
    let dir = folder("roles");
    std::fs::write(dir.join("eng.token"), "engineer-token-1\n").unwrap();
    std::fs::write(dir.join("op.token"), "operator-token-1\n").unwrap();
    std::fs::write(dir.join("same.token"), "engineer-token-1\n").unwrap();
    let only = web(
        &dir,
        "service:\n  web: { writes: true, token_file: eng.token }\n",
    );
    assert!(only.token.unwrap().matches(b"engineer-token-1"));
    assert_eq!(
        only.operator_token, None,
        "as before: the one token is the engineer's"
    );

    let both = web(
        &dir,
        "service:\n  web: { writes: true, token_file: eng.token, operator_token_file: op.token }\n",
    );
    assert!(both.token.unwrap().matches(b"engineer-token-1"));
    assert!(both.operator_token.unwrap().matches(b"operator-token-1"));
    let operator_only = web(
        &dir,
        "service:\n  web: { writes: true, operator_token_file: op.token }\n",
    );
    assert_eq!(operator_only.token, None);
    assert!(operator_only.operator_token.is_some());

    let (at, e, shown) = one(
        &dir,
        "service:\n  web: { writes: true, token_file: eng.token, operator_token_file: missing.token }\n",
    );
    assert_eq!(at, (16, 68), "the value of operator_token_file");
    assert!(
        shown.contains("service.web.operator_token_file ") && shown.contains("cannot read it"),
        "{shown}"
    );
    assert!(
        matches!(e, WebError::TokenFile { ref path, .. } if path.ends_with("missing.token")),
        "{e:?}"
    );
    let (at, e, shown) = one(
        &dir,
        "service:\n  web: { writes: true, token_file: eng.token, operator_token_file: same.token }\n",
    );
    assert_eq!(at, (16, 68), "the value of operator_token_file");
    assert!(matches!(e, WebError::SameTokenForBothRoles { .. }), "{e:?}");
    assert!(
        shown.ends_with("service.web.operator_token_file: the operator's token is the engineer's token; give the operator a token of their own, or the operator could force"),
        "{shown}"
    );
    let (_, e, _) = one(
        &dir,
        "service:\n  web: { writes: true, operator_token: operator-token-1, operator_token_file: op.token }\n",
    );
    assert!(matches!(e, WebError::TwoTokenSources { .. }), "{e:?}");
    let (_, e, _) = one(
        &dir,
        "service:\n  web: { writes: true, token_file: eng.token, operator_token: short }\n",
    );
    assert!(matches!(e, WebError::TokenLength { .. }), "{e:?}");
    // Best effort: the test's scratch folder.
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn writes_need_a_token_from_the_file_a_file_or_the_environment() {
    let dir = folder("tokens");
    let (at, e, shown) = one(&dir, "service:\n  web:\n    writes: true\n");
    assert_eq!((at, e), ((17, 13), WebError::WritesNeedToken));
    assert!(
        shown.ends_with("project.yaml:17:13: error: service.web: writes need a token (token_file, token_env or token): without one, anyone who opens the page could move the machine"),
        "{shown}"
    );

    let w = web(
        &dir,
        "service:\n  web: { writes: true, token: correct-horse }\n",
    );
    assert!(w.writes);
    let token = w.token.expect("a token");
    assert!(token.matches(b"correct-horse") && !token.matches(b"correct-hors"));

    std::fs::write(dir.join("web.token"), "from-a-file-123\n").unwrap();
    let w = web(
        &dir,
        "service:\n  web: { writes: true, token_file: web.token }\n",
    );
    assert!(
        w.token.unwrap().matches(b"from-a-file-123"),
        "newline trimmed"
    );
    let (at, e, _) = one(
        &dir,
        "service:\n  web: { writes: true, token_file: missing.token }\n",
    );
    assert_eq!(at, (16, 36));
    assert!(
        matches!(e, WebError::TokenFile { ref path, .. } if path.ends_with("missing.token")),
        "{e:?}"
    );

    let var = format!("SOFTPLC_TEST_WEB_TOKEN_{}", std::process::id());
    std::env::set_var(&var, "from-the-environment");
    let w = web(
        &dir,
        &format!("service:\n  web: {{ writes: true, token_env: {var} }}\n"),
    );
    assert!(w.token.unwrap().matches(b"from-the-environment"));
    std::env::remove_var(&var);
    let (_, e, _) = one(
        &dir,
        &format!("service:\n  web: {{ writes: true, token_env: {var} }}\n"),
    );
    assert_eq!(
        e,
        WebError::TokenEnv {
            from: softplc::project::TokenSource::Env,
            var
        }
    );

    let (at, e, _) = one(
        &dir,
        "service:\n  web:\n    token: correct-horse\n    token_file: web.token\n",
    );
    assert_eq!(at, (18, 17));
    assert!(matches!(e, WebError::TwoTokenSources { .. }), "{e:?}");
}

#[test]
fn tokens_are_long_enough_and_printable() {
    let dir = folder("strength");
    let (at, e, shown) = one(&dir, "service:\n  web: { token: short }\n");
    assert_eq!(at, (16, 17));
    assert!(
        matches!(
            e,
            WebError::TokenLength {
                len: 5,
                min: 8,
                remote: false,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        shown.contains("the token has 5 characters; it needs 8..=256"),
        "{shown}"
    );
    // Beyond loopback anyone on the network may guess: 16 characters at least.
    let (_, e, shown) = one(
        &dir,
        "service:\n  web: { bind: 0.0.0.0:8080, writes: true, token: twelve-chars }\n",
    );
    assert!(
        matches!(
            e,
            WebError::TokenLength {
                len: 12,
                min: 16,
                remote: true,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(shown.contains("on an address beyond loopback"), "{shown}");
    web(
        &dir,
        "service:\n  web: { bind: 0.0.0.0:8080, writes: true, token: sixteen-chars-ok }\n",
    );
    let (_, e, _) = one(&dir, "service:\n  web: { token: \"with space\" }\n");
    assert!(matches!(e, WebError::TokenCharacters { .. }), "{e:?}");
    // The token never shows in a printed project.
    let p = parse_in(
        &dir,
        "service:\n  web: { writes: true, token: never-printed-secret }\n",
    )
    .unwrap();
    assert!(!format!("{p:?}").contains("never-printed-secret"));
}

#[test]
fn trend_tags_and_addresses() {
    let dir = folder("trend");
    let (at, e, shown) = one(&dir, "service:\n  web: { trend: [motor, strat] }\n");
    assert_eq!(at, (16, 25));
    assert_eq!(
        e,
        WebError::UnknownTrendTag {
            tag: "strat".into(),
            hint: Some("start".into())
        }
    );
    assert!(
        shown.ends_with("error: service.web.trend: no tag strat; did you mean start?"),
        "{shown}"
    );
    let (_, e, _) = one(&dir, "service:\n  web: { trend: [motor, motor] }\n");
    assert_eq!(
        e,
        WebError::TrendTwice {
            tag: "motor".into()
        }
    );
    let nine = ["motor"; 9].join(", ");
    let errors = parse_in(&dir, &format!("service:\n  web: {{ trend: [{nine}] }}\n")).unwrap_err();
    assert!(errors.iter().any(|e| matches!(
        e.kind,
        ErrorKind::Service(ServiceError::Web(WebError::TooManyTrendTags { count: 9 }))
    )));

    let mut errors = parse_in(&dir, "service:\n  web: { bind: localhost:8080 }\n").unwrap_err();
    let e = errors.remove(0);
    assert_eq!((e.line, e.column), (16, 16));
    assert!(matches!(
        e.kind,
        ErrorKind::Service(ServiceError::BadAddress {
            key: "service.web.bind",
            ..
        })
    ));
    let (at, e, _) = one(
        &dir,
        "service:\n  metrics: 127.0.0.1:9000\n  web: { bind: 127.0.0.1:9000 }\n",
    );
    assert_eq!(at, (17, 16));
    assert_eq!(
        e,
        WebError::SameAddress {
            addr: "127.0.0.1:9000".parse().unwrap(),
            other: "service.metrics"
        }
    );
}

// ---- the server ----

const TOKEN: &str = "test-token-123";

fn info(writes: bool) -> WebInfo {
    WebInfo {
        project: "demo".into(),
        version: "0",
        period_us: 100_000,
        writes,
        buses: Vec::new(),
        modules: Vec::new(),
        tags: Vec::new(),
        trend: vec![0],
        operator: Vec::new(),
        programs: vec![ProgramView {
            file: "p.expr".into(),
            task: None,
            inst_base: 0,
            kind: "expr",
            lines: Vec::new(),
            diagram: None,
            no_diagram: None,
            error: None,
        }],
        tasks: Vec::new(),
    }
}

/// A page on a free loopback port whose "scan" answers forces with `ok` (or refuses them);
/// the requests it got are in the returned list.
fn server(writes: bool, ok: bool) -> (WebServer, SnapshotCell, Arc<Mutex<Vec<Request>>>) {
    let config = WebConfig {
        bind: "127.0.0.1:0".parse().unwrap(),
        writes,
        token: Some(WebToken::new(TOKEN)),
        operator_token: None,
        trend: vec![0],
    };
    let cell = SnapshotCell::new();
    cell.set(ServiceSnapshot {
        published: true,
        cycles: 5,
        now: ScanInstant::after_origin(Duration::from_millis(500)),
        values: vec![Value::Bool(true)],
        qualities: vec![Quality::Good],
        timestamps: vec![ScanInstant::after_origin(Duration::from_millis(400))],
        forced: vec![false],
        ..ServiceSnapshot::default()
    });
    let (tx, rx): (_, Receiver<Envelope>) = crossbeam_channel::bounded(4);
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    std::thread::spawn(move || {
        for env in rx {
            log.lock().unwrap().push(env.request.clone());
            let r = if ok {
                Response::done("motor forced to 1")
            } else {
                Response::refused("motor is driven by its module's own logic")
            };
            // The receiver is gone once the test has what it needs.
            drop(env.reply.send(r));
        }
    });
    let s = WebServer::start(
        &config,
        &info(writes),
        cell.clone(),
        tx,
        Duration::from_millis(100),
        &softplc::service::Health::new(),
        softplc::service::web::WebRecords::default(),
    )
    .unwrap();
    (s, cell, seen)
}

/// Sends raw bytes, returns the whole answer.
fn raw(addr: SocketAddr, bytes: &[u8]) -> String {
    let mut c = TcpStream::connect(addr).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    c.write_all(bytes).unwrap();
    let mut out = String::new();
    // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
    drop(c.read_to_string(&mut out));
    out
}

fn get(addr: SocketAddr, path: &str) -> String {
    raw(
        addr,
        format!(
            "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
            addr.port()
        )
        .as_bytes(),
    )
}

fn post(addr: SocketAddr, path: &str, headers: &str, body: &str) -> String {
    raw(
        addr,
        format!(
            "POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n{headers}Content-Length: {}\r\n\r\n{body}",
            addr.port(),
            body.len()
        )
        .as_bytes(),
    )
}

#[test]
fn the_page_and_its_data_are_served_with_the_security_headers() {
    let (s, _, _) = server(false, true);
    let a = s.local_addr();
    assert_eq!(s.url(), format!("http://127.0.0.1:{}/", a.port()));
    let page = get(a, "/");
    assert!(
        page.starts_with("HTTP/1.1 200 OK\r\nContent-Type: text/html"),
        "{page}"
    );
    assert!(
        page.contains("Content-Security-Policy: default-src 'self'"),
        "{page}"
    );
    assert!(page.contains("<script src=\"/app.js\""), "{page}");
    assert!(
        !page.contains("http://") && !page.contains("https://"),
        "no asset from elsewhere"
    );
    assert!(get(a, "/app.js").contains("Content-Type: text/javascript"));
    assert!(get(a, "/style.css").contains("Content-Type: text/css"));
    let info = get(a, "/api/info");
    assert!(info.contains("\"project\":\"demo\""), "{info}");
    let state = get(a, "/api/state");
    assert!(state.contains("\"v\":[true]"), "{state}");
    assert!(state.contains("\"age\":[100.0]"), "{state}");
    let head = raw(
        a,
        format!("HEAD / HTTP/1.1\r\nHost: localhost:{}\r\n\r\n", a.port()).as_bytes(),
    );
    assert!(
        head.starts_with("HTTP/1.1 200") && head.ends_with("\r\n\r\n"),
        "{head}"
    );
    assert!(get(a, "/nope").starts_with("HTTP/1.1 404"));
    let wrong = post(a, "/api/state", "", "");
    assert!(
        wrong.starts_with("HTTP/1.1 405") && wrong.contains("Allow: GET, HEAD"),
        "{wrong}"
    );
    // DNS rebinding: another name for 127.0.0.1 is not answered.
    let rebound = raw(a, b"GET /api/state HTTP/1.1\r\nHost: evil.example\r\n\r\n");
    assert!(rebound.starts_with("HTTP/1.1 403"), "{rebound}");
    // Malformed and oversized requests.
    assert!(raw(a, b"GET / SPDY/3\r\n\r\n").starts_with("HTTP/1.1 400"));
    assert!(raw(a, &vec![b'a'; 9000]).starts_with("HTTP/1.1 431"));
    let big = format!(
        "POST /api/force HTTP/1.1\r\nContent-Length: 5000\r\n\r\n{}",
        "x".repeat(5000)
    );
    assert!(raw(a, big.as_bytes()).starts_with("HTTP/1.1 413"));
}

#[test]
fn writes_are_refused_without_the_token_and_forwarded_with_it() {
    let (s, _, seen) = server(true, true);
    let a = s.local_addr();
    assert!(s.writes());
    let json = "Content-Type: application/json\r\n";
    let bearer = format!("{json}Authorization: Bearer {TOKEN}\r\n");
    let body = r#"{"tag":"motor","value":true}"#;
    for (headers, why) in [
        (json.to_string(), "a token is needed"),
        (
            format!("{json}Authorization: Bearer wrong-token\r\n"),
            "the token is not valid",
        ),
        (
            format!("{bearer}Origin: http://evil.example\r\n"),
            "another site",
        ),
        (
            format!("{bearer}Sec-Fetch-Site: cross-site\r\n"),
            "another site",
        ),
        (
            format!("Authorization: Bearer {TOKEN}\r\nContent-Type: text/plain\r\n"),
            "application/json",
        ),
    ] {
        let r = post(a, "/api/force", &headers, body);
        assert!(r.starts_with("HTTP/1.1 403"), "{headers:?}: {r}");
        assert!(r.contains(why), "{headers:?}: {r}");
    }
    assert!(seen.lock().unwrap().is_empty(), "nothing reached the scan");

    let r = post(a, "/api/auth", &bearer, "{}");
    assert!(
        r.starts_with("HTTP/1.1 200") && r.contains("the token is valid"),
        "{r}"
    );
    let r = post(a, "/api/force", &bearer, body);
    assert!(r.starts_with("HTTP/1.1 200"), "{r}");
    assert!(
        r.contains("\"ok\":true") && r.contains("motor forced to 1"),
        "{r}"
    );
    let r = post(a, "/api/unforce", &bearer, "{}");
    assert!(r.starts_with("HTTP/1.1 200"), "{r}");
    let r = post(a, "/api/force", &bearer, r#"{"tag":"motor"}"#);
    assert!(r.starts_with("HTTP/1.1 400"), "{r}");
    assert_eq!(
        *seen.lock().unwrap(),
        [
            Request::Force {
                tag: "motor".into(),
                value: "1".into()
            },
            Request::Unforce { tag: None }
        ]
    );

    // The scan's refusal comes back as a conflict.
    let (s, _, _) = server(true, false);
    let r = post(s.local_addr(), "/api/force", &bearer, body);
    assert!(
        r.starts_with("HTTP/1.1 409") && r.contains("own logic"),
        "{r}"
    );
    // `writes: false`: the token alone does not open anything.
    let (s, _, seen) = server(false, true);
    let r = post(s.local_addr(), "/api/force", &bearer, body);
    assert!(
        r.starts_with("HTTP/1.1 403") && r.contains("writes are off"),
        "{r}"
    );
    assert!(seen.lock().unwrap().is_empty());
}

#[test]
fn the_event_stream_sends_state_and_stats_and_ends_with_the_run() {
    let (s, cell, _) = server(false, true);
    let a = s.local_addr();
    let mut c = TcpStream::connect(a).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        c,
        "GET /api/events HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
        a.port()
    )
    .unwrap();
    let mut text = String::new();
    let mut buf = [0u8; 4096];
    let start = Instant::now();
    while !(text.contains("event: state\n") && text.contains("event: stats\n")) {
        assert!(start.elapsed() < Duration::from_secs(10), "{text}");
        let n = c.read(&mut buf).unwrap();
        text.push_str(&String::from_utf8_lossy(&buf[..n]));
    }
    assert!(
        text.starts_with("HTTP/1.1 200 OK\r\nContent-Type: text/event-stream"),
        "{text}"
    );
    assert!(text.contains("\r\n\r\nretry: 1000\n\n"), "{text}");
    assert!(text.contains("event: state\ndata: {"), "{text}");
    // The end of the run is the end of the stream.
    cell.set(ServiceSnapshot {
        published: true,
        cycles: 6,
        stopped: true,
        ..ServiceSnapshot::default()
    });
    let mut rest = String::new();
    // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
    drop(c.read_to_string(&mut rest));
    assert!(rest.contains("\"stopped\":true"), "{rest}");
}

#[test]
fn connections_are_bounded_and_shared_fairly() {
    let (s, _, _) = server(false, true);
    let a = s.local_addr();
    // A client that sends half a request is dropped at the deadline, with a 408.
    let slow = std::thread::spawn(move || raw(a, b"GET / HTTP/1.1\r\n"));
    // Fifteen streams asked for: half the slots at most are streams, the others are told to
    // come back, and the page still answers.
    let mut streams: Vec<TcpStream> = (0..softplc::service::web::MAX_CLIENTS - 1)
        .map(|_| {
            let mut c = TcpStream::connect(a).unwrap();
            write!(
                c,
                "GET /api/events HTTP/1.1\r\nHost: 127.0.0.1:{}\r\n\r\n",
                a.port()
            )
            .unwrap();
            c
        })
        .collect();
    std::thread::sleep(Duration::from_millis(500));
    let mut refused = 0;
    for c in &mut streams {
        // Each stream's answer starts at once (a stream's head, or the 503); the bound is for
        // a loaded machine, not a timing this test measures.
        c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut head = [0u8; 12];
        if c.read_exact(&mut head).is_ok() && &head == b"HTTP/1.1 503" {
            refused += 1;
        }
    }
    assert_eq!(
        refused,
        softplc::service::web::MAX_CLIENTS - 1 - softplc::service::web::MAX_STREAMS
    );
    let page = get(a, "/");
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    let timed_out = slow.join().unwrap();
    assert!(timed_out.starts_with("HTTP/1.1 408"), "{timed_out}");
    // Every slot taken by clients that say nothing: a newcomer takes the slot of the one
    // waiting longest.
    let silent: Vec<TcpStream> = (0..softplc::service::web::MAX_CLIENTS)
        .map(|_| TcpStream::connect(a).unwrap())
        .collect();
    std::thread::sleep(Duration::from_millis(300));
    let page = get(a, "/");
    assert!(page.starts_with("HTTP/1.1 200"), "{page}");
    drop((streams, silent));
}
