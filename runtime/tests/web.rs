//! The web page end to end, in headless Chromium (Debian's `chromium`, installed by
//! `scripts/test`), against a running `softplc run` whose two MiniMods are simulated by
//! `softplc sim` on a pty, exactly as a real line would be:
//!
//! - the page loads and shows every tag, the program and the plots;
//! - an input set in the simulator shows up on the page within a second;
//! - signing in with the project's token and clicking "Force 1" on the page turns the output on
//!   in the simulator (and `softplc status` shows the force); "Unforce" gives it back;
//! - "Write 1" on the page sets the motor once and the program's latch keeps it; "Write 0" drops
//!   it; a write through `POST /api/write` sets a tag once and the program takes it back; the
//!   overview's Audit panel lists the page's writes and forces with its client address;
//! - a write without the token, or with a wrong one, is refused with 403 and changes nothing;
//! - a rung the planner pushed down is marked with its module on the program view;
//! - a ladder program is drawn as ladders lit by its inputs and its blocks' live outputs (a
//!   timer's `ET` counting up, a `jam.Q` contact on a block that drives no coil);
//! - a call of a block of one's own is a box with its instance's live pins, and a click shows
//!   its body drawn over that instance's tags.
//!
//! Screenshots of each view are left in `target/web-screenshots/` (test artefacts).

mod cdp;
mod operator;
mod tasks;
use crate::common::sim;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::host::{free_port, repo};
use cdp::Browser;
use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
const TOKEN: &str = "e2e-token-0123456789";

/// The running PLC; killed when dropped (the test ends it earlier on success).
struct Plc(Child);

impl Drop for Plc {
    fn drop(&mut self) {
        // The child may have exited already; then there is nothing to stop.
        drop(self.0.kill());
        drop(self.0.wait());
    }
}

/// One HTTP request to the page: (status, body).
fn http(port: u16, request: &str) -> (u16, String) {
    let mut c = TcpStream::connect(("127.0.0.1", port)).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    c.write_all(request.as_bytes()).unwrap();
    let mut out = String::new();
    // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
    drop(c.read_to_string(&mut out));
    let status = out
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let body = out.split("\r\n\r\n").nth(1).unwrap_or("").to_string();
    (status, body)
}

/// The Audit panel's data once it holds `want` entries: the audit is written off the request's
/// thread, so a read right after a write may come before it (bounded wait, then what is there).
fn audit_entries(port: u16, want: usize) -> (String, Vec<serde_json::Value>) {
    let end = Instant::now() + Duration::from_secs(10);
    loop {
        let (code, text) = http(
            port,
            &format!("GET /api/audit HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n"),
        );
        assert_eq!(code, 200, "{text}");
        let audit: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        let entries = audit["entries"].as_array().cloned().unwrap_or_default();
        if entries.len() >= want || Instant::now() > end {
            return (text, entries);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn post(port: u16, path: &str, headers: &str, body: &str) -> (u16, String) {
    http(
        port,
        &format!(
            "POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n{headers}Content-Length: {}\r\n\r\n{body}",
            body.len()
        ),
    )
}

fn status(socket: &Path) -> String {
    let out = Command::new(BIN)
        .args(["status", "--socket"])
        .arg(socket)
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A tag's line in `softplc status`.
fn status_line(socket: &Path, tag: &str) -> String {
    status(socket)
        .lines()
        .find(|l| l.split_whitespace().next() == Some(tag))
        .unwrap_or_default()
        .to_string()
}

fn chromium_available() {
    let ok = Command::new("chromium")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "chromium is not installed: the web page's end-to-end test drives Debian's chromium \
         package headless; run scripts/test, which installs it"
    );
}

fn screenshots() -> PathBuf {
    let dir = repo().join("target/web-screenshots");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The quick start's tags and program, in a project file.
const CONVEYOR_TAGS: &str = "tags:\n\
  - { name: box_at_entry, point: mm1.X1 }\n\
  - { name: start,        point: mm1.X2 }\n\
  - { name: stop,         point: mm1.X3 }\n\
  - { name: motor,        point: mm1.Y1, safe: false }\n\
  - { name: box_at_exit,  point: mm2.X1 }\n\
  - { name: lamp,         point: mm2.Y1, safe: false }\n\
program: { file: conveyor.expr, kind: expr }\n";

/// A fresh scratch folder `NAME-PID` with the quick start's program in it.
fn conveyor_folder(name: &str) -> PathBuf {
    crate::common::host::conveyor_scratch("web", name)
}

/// Signs in on the page with the project's (engineer's) token, as a person types it.
fn sign_in(b: &mut Browser) {
    sign_in_with(b, TOKEN);
}

/// Signs in on the page with `token`, as a person types it.
fn sign_in_with(b: &mut Browser, token: &str) {
    b.eval(&format!(
        "document.getElementById('token').value = '{token}'; \
         document.getElementById('login').requestSubmit(); true"
    ));
    b.wait_for(
        "document.querySelector('#auth .who') !== null",
        Duration::from_secs(10),
    )
    .expect("signed in");
}

/// `softplc run` on `project`, once its page answers on `port`.
fn run_plc(project: &Path, socket: &Path, port: u16) -> Plc {
    let mut plc = Plc(Command::new(BIN)
        .args(["run", "--quiet", "--for", "120s", "--socket"])
        .arg(socket)
        .arg(project)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap());
    let up = Instant::now();
    // The page and the control socket open one after the other: a test talks to both.
    while TcpStream::connect(("127.0.0.1", port)).is_err() || !socket.exists() {
        if up.elapsed() > Duration::from_secs(30) || plc.0.try_wait().unwrap().is_some() {
            // The child may have exited already; then there is nothing to stop.
            drop(plc.0.kill());
            let mut err = String::new();
            // Best effort: the log only adds to the panic message.
            drop(plc.0.stderr.take().unwrap().read_to_string(&mut err));
            panic!("the web page never listened on port {port} or the control socket never opened:\n{err}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    plc
}

#[test]
fn the_page_shows_the_running_plc_and_forces_its_outputs() {
    chromium_available();
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = conveyor_folder("page");
    let port = free_port();
    // The quick start's machine on the pty; `offload: auto` lets the planner push the lamp's
    // rung (mm2.X1 → mm2.Y1) into mm2, so the program view has a rung to mark.
    let project = format!(
        "project: webtest\n\
         scan: {{ period: 100ms, watchdog: {{ time: 1s, sensitivity: 3 }} }}\n\
         offload: auto\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 200ms, retries: 1 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2 }}\n\
         {CONVEYOR_TAGS}\
         service:\n  web: {{ bind: \"127.0.0.1:{port}\", writes: true, token: {TOKEN}, trend: [start, stop, motor, box_at_exit, lamp] }}\n"
    );
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    let socket = dir.join("ctl.sock");
    let plc = run_plc(&dir.join("project.yaml"), &socket, port);

    // Without the token, or with a wrong one, a write is refused and changes nothing.
    let json = "Content-Type: application/json\r\n";
    let body = r#"{"tag":"motor","value":"1"}"#;
    let (code, text) = post(port, "/api/force", json, body);
    assert_eq!(code, 403, "{text}");
    assert!(text.contains("a token is needed"), "{text}");
    let wrong = format!("{json}Authorization: Bearer not-{TOKEN}\r\n");
    assert_eq!(post(port, "/api/force", &wrong, body).0, 403);
    let forged = format!("{json}Authorization: Bearer {TOKEN}\r\nOrigin: http://evil.example\r\n");
    assert_eq!(post(port, "/api/force", &forged, body).0, 403);

    let profile = dir.join("chromium");
    let mut b = Browser::start(&profile);
    let url = format!("http://127.0.0.1:{port}/");
    // The page draws the running PLC from its first requests, not from the event stream: with
    // no EventSource at all it still shows the state and the I/O values.
    let no_stream = b.page(
        "Page.addScriptToEvaluateOnNewDocument",
        serde_json::json!({ "source": "window.EventSource = undefined;" }),
    );
    b.open(&format!("{url}#io"));
    let drawn = b.wait_for(
        "['running', 'faulty'].includes(document.getElementById('state').dataset.state) && \
         document.getElementById('value-stop').dataset.value !== undefined",
        Duration::from_secs(30),
    );
    assert!(
        drawn.is_some(),
        "the page draws nothing without the event stream"
    );
    b.page(
        "Page.removeScriptToEvaluateOnNewDocument",
        serde_json::json!({ "identifier": no_stream["identifier"] }),
    );
    // Another URL, so the page loads again (the same one with a hash would not).
    b.open(&format!("{url}?live#io"));
    let live = b.wait_for(
        "document.getElementById('value-stop').dataset.value",
        Duration::from_secs(30),
    );
    assert!(live.is_some(), "no live value on the page within 30 s");

    // The page shows every tag, each with its module's row.
    let tags = b.eval("[...document.querySelectorAll('#io-tables tr[data-tag]')].map(r => r.dataset.tag).join(',')");
    assert_eq!(
        tags.as_str(),
        Some("box_at_entry,start,stop,motor,box_at_exit,lamp")
    );
    let (q, _) = b
        .wait_for(
            "document.querySelector('#io-tables tr[data-tag=stop] .q').textContent === 'good'",
            Duration::from_secs(20),
        )
        .expect("stop's quality is good");
    assert_eq!(q, true);

    // An input set in the simulator shows up on the page within a second, every time.
    let mut latencies = Vec::new();
    for want in ["1", "0", "1"] {
        sim.send(&format!("set minimod@1.X3 {want}"));
        let start = Instant::now();
        let seen = b.wait_for(
            &format!("document.getElementById('value-stop').dataset.value === '{want}'"),
            Duration::from_secs(10),
        );
        assert!(seen.is_some(), "stop={want} never reached the page");
        latencies.push(start.elapsed());
    }
    eprintln!("simulator input → page: {latencies:?}");
    latencies.sort();
    assert!(
        latencies[1] < Duration::from_secs(1),
        "an input takes more than a second to reach the page: {latencies:?}"
    );
    // The program view shows the same value beside the tag.
    assert_eq!(
        b.eval("document.querySelector('#program .tag[data-tag=stop] + .val').textContent")
            .as_str(),
        Some("1")
    );
    // stop is pressed: the program holds the motor off.
    assert!(sim
        .wait_for("minimod@1.Y1", "0", Duration::from_secs(5))
        .is_some());

    // Force buttons do nothing before signing in.
    let disabled =
        b.eval("document.querySelector('button[data-force=motor][data-value=\"1\"]').disabled");
    assert_eq!(disabled, true, "the force button is live before signing in");
    let anonymous = b.eval(
        "fetch('/api/force', {method: 'POST', headers: {'Content-Type': 'application/json'}, \
         body: JSON.stringify({tag: 'motor', value: '1'})}).then(r => r.status)",
    );
    assert_eq!(anonymous, 403);

    // Sign in with the token, click "Force 1" on motor: the simulator's Y1 turns on.
    sign_in(&mut b);
    b.wait_for(
        "!document.querySelector('button[data-force=motor][data-value=\"1\"]').disabled",
        Duration::from_secs(5),
    )
    .expect("the force button is live once signed in");
    b.eval("document.querySelector('button[data-force=motor][data-value=\"1\"]').click(); true");
    assert!(
        sim.wait_for("minimod@1.Y1", "1", Duration::from_secs(10))
            .is_some(),
        "forcing from the page did not turn the output on"
    );
    let line = status_line(&socket, "motor");
    assert!(line.contains("FORCED 1"), "softplc status: {line:?}");
    b.wait_for(
        "document.querySelector('#io-tables tr[data-tag=motor]').classList.contains('forced')",
        Duration::from_secs(5),
    )
    .expect("the page shows the force");
    let shots = screenshots();
    b.screenshot(&shots.join("io-forced.png"));

    // The pushed-down rung is marked with its module; the lamp cannot be forced from the scan.
    let pushed = b.eval("[...document.querySelectorAll('#program [data-pushed]')].map(e => e.dataset.pushed).join(',')");
    assert_eq!(pushed.as_str(), Some("mm2"), "the lamp's rung runs in mm2");
    // Its mark names the statement by its comment, the line above it in conveyor.expr.
    let mark = b.eval("document.querySelector('#program [data-pushed]').title");
    assert!(
        mark.as_str().is_some_and(|t| t.starts_with(
            "“The lamp is on while a box waits at the exit.”: lamp runs in module mm2"
        )),
        "{mark}"
    );
    assert_eq!(
        b.eval("document.querySelector('button[data-force=lamp]') === null"),
        true
    );

    // Unforce from the page: the program takes the motor back (stop is still pressed).
    b.eval("document.querySelector('button[data-unforce=motor]').click(); true");
    assert!(
        sim.wait_for("minimod@1.Y1", "0", Duration::from_secs(10))
            .is_some(),
        "unforcing from the page did not give the output back to the program"
    );
    assert!(!status_line(&socket, "motor").contains("FORCED"));
    sim.send("set minimod@1.X3 0");

    // "Write 1" on the page, once stop is released: the program's latch (motor holds itself)
    // keeps the motor on; "Write 0" drops it, and the latch keeps it off. No force is left.
    let released = Instant::now() + Duration::from_secs(10);
    while status_line(&socket, "stop").split_whitespace().nth(1) != Some("0") {
        assert!(
            Instant::now() < released,
            "stop was not released: {:?}",
            status_line(&socket, "stop")
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    b.eval("document.querySelector('button[data-write=motor][data-value=\"1\"]').click(); true");
    assert!(
        sim.wait_for("minimod@1.Y1", "1", Duration::from_secs(10))
            .is_some(),
        "a write from the page did not reach the program's latch"
    );
    b.eval("document.querySelector('button[data-write=motor][data-value=\"0\"]').click(); true");
    assert!(
        sim.wait_for("minimod@1.Y1", "0", Duration::from_secs(10))
            .is_some(),
        "a write of 0 from the page did not drop the latch"
    );
    assert!(!status_line(&socket, "motor").contains("FORCED"));
    // The overview's Audit panel lists the page's writes and forces with its client address.
    b.wait_for(
        "document.querySelector('#audit li[data-action=write]') !== null",
        Duration::from_secs(10),
    )
    .expect("the Audit panel shows the page's write");
    let sources = b.eval("[...document.querySelectorAll('#audit li[data-action]')].map(li => li.dataset.source.split(':')[0]).join(',')");
    assert_eq!(
        sources.as_str(),
        Some("web 127.0.0.1,web 127.0.0.1,web 127.0.0.1,web 127.0.0.1"),
        "write 0, write 1, unforce, force"
    );

    // Each view, with its plots drawn, as a screenshot.
    for (view, ready) in [
        ("overview", "document.querySelectorAll('#trend path.trace').length >= 3 && document.querySelector('#faults li') !== null && document.querySelector('#audit li') !== null"),
        ("io", "document.querySelector('#io-tables .led') !== null"),
        ("program", "document.querySelector('#program .tag.on, #program .tag.off') !== null"),
        ("timing", "document.querySelectorAll('#histograms svg rect.bar').length >= 5"),
        ("bus", "document.querySelectorAll('#bus-table tr[data-module]').length === 2"),
    ] {
        b.eval(&format!("location.hash = '#{view}'; true"));
        b.wait_for(
            &format!("document.getElementById('view-{view}').classList.contains('active') && ({ready})"),
            Duration::from_secs(15),
        )
        .unwrap_or_else(|| panic!("the {view} view did not render"));
        // The last write's notice would hide part of the view.
        b.eval("document.getElementById('toast').className = 'toast'; true");
        std::thread::sleep(Duration::from_millis(400));
        b.screenshot(&shots.join(format!("{view}.png")));
    }
    // The overview lists the services with their state (the page itself among them).
    b.eval("location.hash = '#overview'; true");
    b.wait_for(
        "[...document.querySelectorAll('#overview-cards .card')].some(c => \
         c.textContent.startsWith('Services') && c.textContent.includes('webrunning'))",
        Duration::from_secs(15),
    )
    .expect("a Services card with the web page running");
    // The Trace view: arm a trace from the page (signed in), watch it fill and complete, see
    // its plot in the trend's look, download its CSV.
    b.eval("location.hash = '#trace'; true");
    arm_from_page(
        &mut b,
        [
            "webtrace",
            "start, motor, phase.cycle",
            "phase.cycle >= 0",
            "0",
            "5",
        ],
    );
    let state = "(document.querySelector('#trace-table tr[data-trace=webtrace] .trace-state') || {}).textContent";
    let done = b.wait_for(&format!("{state} === 'complete'"), Duration::from_secs(30));
    assert!(
        done.is_some(),
        "the trace never completed: {}",
        b.eval(state)
    );
    assert_eq!(
        b.eval("document.querySelector('#trace-table tr[data-trace=webtrace] td.num').textContent"),
        "6 / 6"
    );
    let plotted = b.wait_for(
        "document.querySelectorAll('#trace-plot svg path.trace').length === 3 \
         && document.querySelectorAll('#trace-plot svg .trigger-mark').length === 1",
        Duration::from_secs(10),
    );
    assert!(
        plotted.is_some(),
        "no plot: {}",
        b.eval("document.getElementById('trace-plot').innerHTML")
    );
    b.eval("document.getElementById('toast').className = 'toast'; true");
    b.screenshot(&shots.join("trace.png"));
    let (code, csv) = http(
        port,
        "GET /api/trace/csv?name=webtrace HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n",
    );
    assert_eq!(code, 200, "{csv}");
    assert!(
        csv.starts_with("time_s,cycle,start [bool],motor [bool],phase.cycle [i32 us]\n"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 7, "{csv}");
    // Arming takes the token, as forcing does.
    let (code, text) = post(port, "/api/trace/arm", json, r#"{"name":"webtrace"}"#);
    assert_eq!(code, 403, "{text}");

    let requests = b.eval("+document.querySelector('#bus-table tr[data-module=mm1] td:nth-child(5)').textContent.replace(/,/g, '')");
    assert!(
        requests.as_f64().unwrap_or(0.0) > 10.0,
        "bus counters: {requests}"
    );
    for view in ["overview", "io", "io-forced", "program", "timing", "bus"] {
        let png = std::fs::read(shots.join(format!("{view}.png"))).unwrap();
        assert!(
            png.starts_with(b"\x89PNG") && png.len() > 10_000,
            "{view}.png"
        );
    }

    #[allow(unsafe_code)]
    // Stopping the PLC (SIGINT, as Ctrl-C): the page says so rather than "no connection".
    // SAFETY: a signal to the child this test started.
    unsafe {
        libc::kill(plc.0.id() as i32, libc::SIGINT)
    };
    b.wait_for(
        "document.getElementById('state').dataset.state === 'stopped' && \
         document.getElementById('state').textContent === 'stopped'",
        Duration::from_secs(15),
    )
    .expect("the page shows the PLC stopped");
    b.eval("location.hash = '#overview'; true");
    let why = b.wait_for(
        "document.getElementById('faults').textContent.includes('stopped on request')",
        Duration::from_secs(5),
    );
    assert!(why.is_some(), "the overview says why the run ended");
    drop(b);
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// The `data-kind:data-tag` of each element of rung `n`'s diagram, left to right.
const RUNG_ELEMENTS: &str = "n => [...document.querySelectorAll(`#ladder svg[data-rung=\"${n}\"] .lad-el`)].map(e => e.dataset.kind + ':' + (e.dataset.tag || e.dataset.instance)).join(',')";

#[test]
fn a_ladder_program_is_drawn_as_a_ladder_lit_by_its_inputs() {
    chromium_available();
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = std::env::temp_dir().join(format!("softplc-web-ladder-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("machine.ladder.yaml"),
        "description: the web page's ladder test\n\
         rungs:\n\
         \x20 - start /stop -> motor                  # two contacts, one NC, a coil\n\
         \x20 - rung: box_at_exit -> lamp             # pushed down into mm2\n\
         \x20   title: Take-away lamp\n\
         \x20   comment: \"Lit while a box waits at the exit;\\npushed down into mm2.\"\n\
         \x20 - motor -> TON run(300ms) -> running    # a block, its Q on a coil\n\
         \x20 - (start | box_at_exit) -> set seen\n\
         \x20 - start -> TON jam(3s)                  # a block driving no coil\n\
         \x20 - jam.Q -> jammed                       # its Q read by a contact\n\
         \x20 - stop -> BLINK flash(500ms, 500ms)     # BLINK's rung input is EN\n",
    )
    .unwrap();
    let port = free_port();
    let project = format!(
        "project: webladder\n\
         scan: {{ period: 50ms, watchdog: {{ time: 1s, sensitivity: 3 }} }}\n\
         offload: auto\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 200ms, retries: 1 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2, description: Exit station }}\n\
         tags:\n\
         \x20 - {{ name: start,        point: mm1.X2 }}\n\
         \x20 - {{ name: stop,         point: mm1.X3 }}\n\
         \x20 - {{ name: motor,        point: mm1.Y1, safe: false }}\n\
         \x20 - {{ name: running,      point: mm1.Y2, safe: false }}\n\
         \x20 - {{ name: box_at_exit,  point: mm2.X1, description: Photo eye at the exit }}\n\
         \x20 - {{ name: lamp,         point: mm2.Y1, safe: false }}\n\
         \x20 - {{ name: seen,         type: bool }}\n\
         \x20 - {{ name: jammed,       type: bool }}\n\
         program: {{ file: machine.ladder.yaml, kind: ladder }}\n\
         service:\n  web: {{ bind: \"127.0.0.1:{port}\", writes: true, token: {TOKEN} }}\n"
    );
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    let plc = run_plc(&dir.join("project.yaml"), &dir.join("ctl.sock"), port);

    let mut b = Browser::start(&dir.join("chromium"));
    b.open(&format!("http://127.0.0.1:{port}/#program"));
    b.wait_for(
        "document.querySelector('#ladder svg[data-rung=\"6\"]') !== null",
        Duration::from_secs(30),
    )
    .expect("the program view draws the rungs as ladders");
    // A rung's title in its head and its comment under it; a rung without them has none.
    assert_eq!(
        b.eval("[document.querySelector('#rung-2 .lad-title')?.textContent, document.querySelector('#rung-2 .lad-comment')?.textContent, document.querySelector('#rung-1 .lad-title'), document.querySelector('#rung-1 .lad-comment')]"),
        serde_json::json!(["Take-away lamp", "Lit while a box waits at the exit;\npushed down into mm2.", null, null])
    );
    // The descriptions of a module and a tag in the I/O tables.
    assert_eq!(
        b.eval("[[...document.querySelectorAll('.module-desc')].map(e => e.textContent), [...document.querySelectorAll('.tag-desc')].map(e => e.closest('tr').dataset.tag + ': ' + e.textContent)]"),
        serde_json::json!([["Exit station"], ["box_at_exit: Photo eye at the exit"]])
    );
    let elements = |b: &mut Browser, n: u32| {
        b.eval(&format!("({RUNG_ELEMENTS})({n})"))
            .as_str()
            .unwrap_or_default()
            .to_string()
    };
    assert_eq!(elements(&mut b, 1), "no:start,nc:stop,coil-normal:motor");
    assert_eq!(
        elements(&mut b, 3),
        "no:motor,block:run,coil-normal:running"
    );
    assert_eq!(elements(&mut b, 4), "no:start,no:box_at_exit,coil-set:seen");
    assert_eq!(elements(&mut b, 5), "no:start,block:jam");
    assert_eq!(elements(&mut b, 6), "no:jam.Q,coil-normal:jammed");
    // The block shows its kind, preset and live outputs (`b` in the state).
    let block = "document.querySelector('#ladder svg[data-rung=\"3\"] .lad-block').textContent";
    let drawn = b.wait_for(
        &format!("{block} === 'runTONINPT 300msQ 0ET 0ms'"),
        Duration::from_secs(10),
    );
    assert!(drawn.is_some(), "the TON box: {}", b.eval(block));
    // The pushed-down rungs keep their mark (rungs 1 and 2 are plain logic on one module's
    // points); the timer and the latch of a memory tag run in the scan.
    let pushed = b.eval("[...document.querySelectorAll('#ladder .lad-rung')].map(r => r.querySelector('[data-pushed]')?.dataset.pushed || '-').join(',')");
    assert_eq!(pushed.as_str(), Some("mm1,mm2,-,-,-,-,-"));
    // Each block's rung input by its name in the block table (docs/programming.md).
    let flash =
        "document.querySelector('#ladder svg[data-rung=\"7\"] .lad-block .lad-pin').textContent";
    assert_eq!(b.eval(flash), "EN", "BLINK's input");
    let run =
        "document.querySelector('#ladder svg[data-rung=\"3\"] .lad-block .lad-pin').textContent";
    assert_eq!(b.eval(run), "IN", "TON's input");
    // The contact on `jam.Q` is read from the live block outputs (no coil says what it is):
    // known and open, not grey.
    let jam_contact =
        "document.querySelector('#ladder svg[data-rung=\"6\"] .lad-el[data-tag=\"jam.Q\"]')";
    b.wait_for(
        &format!(
            "{jam_contact}.dataset.passes === '0' && !{jam_contact}.classList.contains('unknown')"
        ),
        Duration::from_secs(10),
    )
    .expect("the jam.Q contact is known and open");

    // Rung 1 with neither input: only the NC contact passes power, the coil is off.
    let lit = "(() => { const s = document.querySelector('#ladder svg[data-rung=\"1\"]'); \
               return [...s.querySelectorAll('.lad-el')].map(e => e.dataset.passes ?? e.dataset.energised).join(''); })()";
    let settled = |b: &mut Browser, want: &str| {
        b.wait_for(&format!("{lit} === '{want}'"), Duration::from_secs(10))
            .map(|_| ())
            .unwrap_or_else(|| panic!("rung 1 lit {} instead of {want}", b.eval(lit)))
    };
    settled(&mut b, "010");
    // start pressed: both contacts pass, power reaches the coil, the motor runs.
    sim.send("set minimod@1.X2 1");
    settled(&mut b, "111");
    assert!(sim
        .wait_for("minimod@1.Y1", "1", Duration::from_secs(5))
        .is_some());
    let wires = b.eval("[...document.querySelectorAll('#ladder svg[data-rung=\"1\"] .lad-wire')].every(w => w.classList.contains('lit'))");
    assert_eq!(wires, true, "every wire of rung 1 carries power");
    // The jam timer's ET counts up on its box while its Q is still off, then stops at the
    // preset as Q comes on; the contact reading jam.Q closes and powers its coil.
    let jam = "document.querySelector('#ladder svg[data-rung=\"5\"] .lad-block')";
    let et = format!("(() => {{ const t = [...{jam}.querySelectorAll('.lad-out')].find(e => e.textContent.startsWith('ET ')).textContent; return parseInt(t.slice(3)); }})()");
    let until_jam = |b: &mut Browser, cond: String, what: &str| {
        if b.wait_for(&cond, Duration::from_secs(10)).is_none() {
            panic!("{what}: {}", b.eval(&format!("{jam}.textContent")));
        }
    };
    until_jam(
        &mut b,
        format!("{jam}.dataset.q === '0' && {et} > 0 && {et} < 2000"),
        "jam's ET counting up",
    );
    let first = b.eval(&et).as_i64().unwrap();
    until_jam(
        &mut b,
        format!("{jam}.dataset.q === '0' && {et} > {first}"),
        &format!("jam's ET past {first}ms"),
    );
    until_jam(
        &mut b,
        format!(
            "{jam}.dataset.q === '1' && {et} === 3000 && {jam_contact}.dataset.passes === '1' && \
             document.querySelector('#ladder svg[data-rung=\"6\"] .lad-coil').dataset.energised === '1'"
        ),
        "jam's Q, its contact and coil",
    );
    // The TON's output comes on 300 ms later, lighting its coil.
    b.wait_for(
        "document.querySelector('#ladder svg[data-rung=\"3\"] .lad-block').dataset.q === '1' && \
         document.querySelector('#ladder svg[data-rung=\"3\"] .lad-coil').dataset.energised === '1'",
        Duration::from_secs(10),
    )
    .expect("the timer's Q and its coil light");
    // stop pressed: the NC contact opens and the coil drops, downstream wires go dark.
    sim.send("set minimod@1.X3 1");
    settled(&mut b, "100");
    let dark = b.eval("[...document.querySelectorAll('#ladder svg[data-rung=\"1\"] .lad-coil .lad-wire')].some(w => w.classList.contains('lit'))");
    assert_eq!(dark, false, "no power reaches the coil");
    assert!(sim
        .wait_for("minimod@1.Y1", "0", Duration::from_secs(5))
        .is_some());

    // A forced tag is marked where the diagram shows it, lit by the forced value.
    let auth = format!("Content-Type: application/json\r\nAuthorization: Bearer {TOKEN}\r\n");
    let (code, text) = post(port, "/api/force", &auth, r#"{"tag":"seen","value":"0"}"#);
    assert_eq!(code, 200, "{text}");
    b.wait_for(
        "(() => { const c = document.querySelector('#ladder svg[data-rung=\"4\"] .lad-coil'); \
         return c.classList.contains('forced') && c.querySelector('.lad-value').textContent === '0'; })()",
        Duration::from_secs(10),
    )
    .expect("the forced coil is marked, with its forced value");

    // The rung's source line is one click away.
    assert_eq!(
        b.eval("document.querySelector('#rung-1 .lad-src').hidden"),
        true
    );
    b.eval("document.querySelector('#rung-1 .lad-toggle').click(); true");
    assert_eq!(
        b.eval("[document.querySelector('#rung-1 .lad-src').hidden, document.querySelector('#rung-1 .lad-src').textContent]"),
        serde_json::json!([false, "start /stop -> motor"])
    );
    b.screenshot(&screenshots().join("program-ladder.png"));
    // And the whole text view, with its live values.
    b.eval("document.getElementById('ladder-switch').click(); true");
    b.wait_for(
        "document.getElementById('ladder').hidden && document.querySelector('#program .tag[data-tag=stop] + .val').textContent === '1'",
        Duration::from_secs(5),
    )
    .expect("the text view with live values");
    drop(b);
    drop(plc);
    sim.send("set minimod@1.X2 0");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// Fills the Trace view's form (name, signals, trigger, pre, post) and submits it.
fn arm_from_page(b: &mut Browser, [name, tags, trigger, pre, post]: [&str; 5]) {
    b.eval(&format!(
        "document.getElementById('trace-name').value = '{name}'; \
         document.getElementById('trace-tags').value = '{tags}'; \
         document.getElementById('trace-trigger').value = '{trigger}'; \
         document.getElementById('trace-pre').value = '{pre}'; \
         document.getElementById('trace-post').value = '{post}'; \
         document.getElementById('trace-form').requestSubmit(); true"
    ));
}

/// `softplc force TAG VALUE` on the instance at `socket`, which must succeed.
fn force_by_cli(socket: &Path, tag: &str, value: &str) {
    let forced = Command::new(BIN)
        .args(["force", "--socket"])
        .arg(socket)
        .args([tag, value])
        .output()
        .unwrap();
    assert!(forced.status.success(), "{forced:?}");
}

/// Whether an element is cut: its content wider than its box, or its box past `right`.
const CUT: &str = "(e, right) => e.scrollWidth > e.clientWidth + 1 || e.getBoundingClientRect().right > right + 0.5";

/// At 800 px the I/O view shows its headers and a FORCED badge whole; the Bus view's line rate
/// counts the Collect broadcasts of event mode; a trace armed from the page with no name is
/// `adhoc`, and before its trigger a trace's plot does not speak of one.
#[test]
fn the_page_at_800_px_and_its_bus_rate_and_trace_words() {
    chromium_available();
    let dir = conveyor_folder("page-800");
    let port = free_port();
    // The quick start's two MiniMods on the simulated line, event mode by default.
    let project = format!(
        "project: web800\n\
         scan: {{ period: 100ms, watchdog: {{ time: 1s, sensitivity: 3 }} }}\n\
         buses:\n  - {{ name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2 }}\n\
         {CONVEYOR_TAGS}\
         service:\n  web: {{ bind: \"127.0.0.1:{port}\", writes: true, token: {TOKEN} }}\n"
    );
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    let socket = dir.join("ctl.sock");
    let plc = run_plc(&dir.join("project.yaml"), &socket, port);
    force_by_cli(&socket, "motor", "1");

    let mut b = Browser::start(&dir.join("chromium"));
    b.page(
        "Emulation.setDeviceMetricsOverride",
        serde_json::json!({ "width": 800, "height": 900, "deviceScaleFactor": 1, "mobile": false }),
    );
    b.open(&format!("http://127.0.0.1:{port}/#io"));
    b.wait_for(
        "document.querySelector('#io-tables tr[data-tag=motor].forced') !== null",
        Duration::from_secs(30),
    )
    .expect("the I/O view shows the force");
    assert_eq!(b.eval("window.innerWidth"), 800);
    let cut_headers = b.eval(&format!(
        "[...document.querySelectorAll('#io-tables th')].filter(th => ({CUT})(th, 800)).map(th => th.textContent).join(',')"
    ));
    assert_eq!(cut_headers.as_str(), Some(""), "headers cut at 800 px");
    let badge = "document.querySelector('#io-tables tr[data-tag=motor] .badge.forced')";
    let badge_cut = b.eval(&format!(
        "(() => {{ const b = {badge}; const td = b.closest('td'); \
           return ({CUT})(td, 800) || b.getBoundingClientRect().right > td.getBoundingClientRect().right; }})()"
    ));
    assert_eq!(badge_cut, false, "the FORCED badge is cut at 800 px");
    let shown = b.eval(
        "[...document.querySelectorAll('#io-tables .badge.forced')].filter(b => b.offsetWidth > 0).map(b => b.closest('tr').dataset.tag).join(',')",
    );
    assert_eq!(
        shown.as_str(),
        Some("motor"),
        "only the forced tag says FORCED"
    );
    b.screenshot(&screenshots().join("io-800.png"));

    // The Bus view: the line's rate holds the Collect rounds its modules' rates do not.
    b.eval("location.hash = '#bus'; true");
    let rates = "(() => { const line = parseFloat(document.querySelector('#bus-lines .card .big').textContent); \
                 const mods = [...document.querySelectorAll('#bus-table tr[data-module] td:nth-child(6)')].map(td => parseFloat(td.textContent) || 0).reduce((a, x) => a + x, 0); \
                 return [line, mods]; })()";
    let settled = b.wait_for(
        &format!(
            "(() => {{ const [line, mods] = {rates}; return line > 0 && line >= mods + 5; }})()"
        ),
        Duration::from_secs(15),
    );
    assert!(
        settled.is_some(),
        "a round a cycle (10/s) is in the line's rate: [line, modules] = {}",
        b.eval(rates)
    );

    // Sign in, arm a continuous trace with no name: it is adhoc, and its plot's times count
    // from its first sample.
    b.eval("location.hash = '#trace'; true");
    sign_in(&mut b);
    assert_eq!(b.eval("document.getElementById('trace-name').value"), "");
    b.eval(
        "document.getElementById('trace-tags').value = 'start, motor'; \
         document.getElementById('trace-trigger').value = ''; \
         document.getElementById('trace-form').requestSubmit(); true",
    );
    b.wait_for(
        "document.querySelector('#trace-table tr[data-trace=adhoc]') !== null",
        Duration::from_secs(15),
    )
    .expect("the unnamed trace is adhoc");
    let hint = b.wait_for(
        "document.getElementById('trace-plot-hint').textContent",
        Duration::from_secs(15),
    );
    assert_eq!(
        hint.map(|h| h.0),
        Some(serde_json::json!("times from the first sample"))
    );
    // A trace whose trigger has not fired yet: its samples before the trigger are plotted
    // from the first one; once `stop` rises (forced), from the trigger.
    arm_from_page(&mut b, ["on_stop", "stop, motor", "stop rising", "20", "5"]);
    let waiting = "document.getElementById('trace-plot-title').textContent.startsWith('Trace on_stop') \
                   && !document.getElementById('trace-plot-title').textContent.includes(' 0 samples')";
    b.wait_for(waiting, Duration::from_secs(15))
        .expect("the armed trace plotted with its first samples");
    assert_eq!(
        b.eval("document.getElementById('trace-plot-hint').textContent"),
        "times from the first sample",
        "before its trigger"
    );
    force_by_cli(&socket, "stop", "1");
    let hint = b.wait_for(
        "document.getElementById('trace-plot-title').textContent.startsWith('Trace on_stop') \
         && document.getElementById('trace-plot-hint').textContent === 'times from the trigger'",
        Duration::from_secs(15),
    );
    assert!(
        hint.is_some(),
        "after its trigger: {}",
        b.eval("document.getElementById('trace-plot-hint').textContent")
    );
    drop(b);
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// A project in `dir` whose program latches `seen` when `cmd` is set, then clears `cmd`
/// itself; its page on `port` writes with `tokens` (the `service.web` token keys).
fn latch_project(dir: &Path, tokens: &str, port: u16) {
    std::fs::write(dir.join("p.expr"), "seen = seen | cmd\ncmd = false\n").unwrap();
    std::fs::write(
        dir.join("project.yaml"),
        format!(
            "project: webwrite\n\
             scan: {{ period: 20ms }}\n\
             buses:\n  - {{ name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n\
             tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: cmd, type: bool }}\n  - {{ name: seen, type: bool }}\n\
             program: {{ file: p.expr, kind: expr }}\n\
             service:\n  web: {{ bind: \"127.0.0.1:{port}\", writes: true, {tokens} }}\n"
        ),
    )
    .unwrap();
}

/// Arming from the page draws on the PLC's one trace budget, as the control socket does:
/// past it the page's arm is refused with what is left, and a disarm gives the room back.
#[test]
fn arming_from_the_page_past_the_trace_budget_is_refused_with_what_is_left() {
    let dir = crate::common::host::scratch_dir("web", "trace-budget");
    let port = free_port();
    latch_project(&dir, &format!("token: {TOKEN}"), port);
    let project = dir.join("project.yaml");
    let mut yaml = std::fs::read_to_string(&project).unwrap();
    yaml.push_str("trace_budget: { armed: 2, memory: 1MiB }\n");
    std::fs::write(&project, yaml).unwrap();
    let plc = run_plc(&project, &dir.join("ctl.sock"), port);
    let auth = format!("Content-Type: application/json\r\nAuthorization: Bearer {TOKEN}\r\n");
    // One signal: 8 bytes a value, 16 the time, 8 the cycle; 20,001 samples: 625 KiB.
    let arm = |name: &str| {
        let body =
            format!(r#"{{"spec":{{"name":"{name}","tags":["seen"],"pre":10000,"post":10000}}}}"#);
        post(port, "/api/trace/arm", &auth, &body)
    };
    let (code, text) = arm("big");
    assert_eq!(code, 200, "{text}");
    let (code, text) = arm("big2");
    assert_eq!(code, 409, "{text}");
    let answer: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        answer["error"],
        "trace big2 needs 625 KiB for its samples; 399 KiB of the 1 MiB trace budget is left: \
         disarm a trace, record fewer signals or samples, or raise trace_budget.memory",
        "{text}"
    );
    let (code, text) = post(port, "/api/trace/disarm", &auth, r#"{"name":"big"}"#);
    assert_eq!(code, 200, "{text}");
    let (code, text) = arm("big2");
    assert_eq!(code, 200, "the disarm gave the room back: {text}");
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// The page's write: with the token, `POST /api/write` sets a tag once at a cycle boundary and
/// the program takes it back in its next scan; refusals say why (an input, a value of another
/// type, a forced tag), and without the token nothing is written.
#[test]
fn a_write_from_the_page_sets_a_tag_once_and_refusals_say_why() {
    let dir = crate::common::host::scratch_dir("web", "write");
    let port = free_port();
    latch_project(&dir, &format!("token: {TOKEN}"), port);
    let socket = dir.join("ctl.sock");
    let plc = run_plc(&dir.join("project.yaml"), &socket, port);
    let json = "Content-Type: application/json\r\n";
    let auth = format!("{json}Authorization: Bearer {TOKEN}\r\n");
    let value = |tag: &str| {
        status_line(&socket, tag)
            .split_whitespace()
            .nth(1)
            .unwrap_or_default()
            .to_string()
    };

    let (code, text) = post(port, "/api/write", json, r#"{"tag":"cmd","value":true}"#);
    assert_eq!(code, 403, "{text}");
    assert_eq!(value("seen"), "0", "a refused write changes nothing");

    let (code, text) = post(port, "/api/write", &auth, r#"{"tag":"cmd","value":true}"#);
    assert_eq!(code, 200, "{text}");
    assert!(text.contains("cmd written: 1"), "{text}");
    let end = Instant::now() + Duration::from_secs(5);
    while value("seen") != "1" && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(value("seen"), "1", "the program saw the write");
    assert_eq!(value("cmd"), "0", "and took cmd back");

    let (code, text) = post(port, "/api/write", &auth, r#"{"tag":"button","value":1}"#);
    assert_eq!(code, 409, "{text}");
    assert!(text.contains("button is an input"), "{text}");
    let (code, text) = post(port, "/api/write", &auth, r#"{"tag":"cmd","value":"7"}"#);
    assert_eq!(code, 409, "{text}");
    assert!(text.contains("cmd is bool"), "{text}");
    assert_eq!(
        post(port, "/api/force", &auth, r#"{"tag":"seen","value":0}"#).0,
        200
    );
    let (code, text) = post(port, "/api/write", &auth, r#"{"tag":"seen","value":1}"#);
    assert_eq!(code, 409, "{text}");
    assert!(text.contains("seen is forced"), "{text}");
    // The Audit panel's data: the newest first, each with the page's client address.
    let (text, entries) = audit_entries(port, 5);
    let seen: Vec<(&str, &str, bool)> = entries
        .iter()
        .map(|e| {
            (
                e["action"].as_str().unwrap(),
                e["what"].as_str().unwrap(),
                e["ok"].as_bool().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        seen,
        [
            ("write", "seen=1", false),
            ("force", "seen=0", true),
            ("write", "cmd=7", false),
            ("write", "button=1", false),
            ("write", "cmd=1", true),
        ],
        "{text}"
    );
    assert!(
        entries
            .iter()
            .all(|e| e["source"].as_str().unwrap().starts_with("web 127.0.0.1:")),
        "{text}"
    );
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// Two roles: the operator's token (`operator_token_file`) writes values once and is refused
/// forcing and unforcing with a reason naming the role; the engineer's (`token_file`, as in a
/// project from before the roles) forces; the audit says which role did what.
#[test]
fn the_operator_writes_and_only_the_engineer_forces() {
    chromium_available();
    let dir = crate::common::host::scratch_dir("web", "roles");
    let port = free_port();
    std::fs::write(dir.join("engineer.token"), format!("{TOKEN}\n")).unwrap();
    std::fs::write(dir.join("operator.token"), "operator-token-0123456789\n").unwrap();
    latch_project(
        &dir,
        "token_file: engineer.token, operator_token_file: operator.token",
        port,
    );
    let socket = dir.join("ctl.sock");
    let plc = run_plc(&dir.join("project.yaml"), &socket, port);
    let json = "Content-Type: application/json\r\n";
    let operator = format!("{json}Authorization: Bearer operator-token-0123456789\r\n");
    let engineer = format!("{json}Authorization: Bearer {TOKEN}\r\n");

    let (code, text) = post(port, "/api/force", json, r#"{"tag":"seen","value":1}"#);
    assert_eq!(code, 403, "{text}");
    assert!(text.contains("a token is needed"), "{text}");
    let (code, text) = post(port, "/api/auth", &operator, "{}");
    assert_eq!(code, 200, "{text}");
    let signed: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(signed["role"], "operator", "{text}");
    let (code, text) = post(port, "/api/auth", &engineer, "{}");
    assert_eq!(code, 200, "{text}");
    assert!(text.contains(r#""role":"engineer""#), "{text}");

    let write_cmd = |auth: &str| post(port, "/api/write", auth, r#"{"tag":"cmd","value":true}"#);
    let (code, text) = write_cmd(&operator);
    assert_eq!(code, 200, "{text}");
    let seen = || {
        status_line(&socket, "seen")
            .split_whitespace()
            .nth(1)
            .map(str::to_owned)
    };
    let wait_seen = || {
        let end = Instant::now() + Duration::from_secs(5);
        while seen().as_deref() != Some("1") && Instant::now() < end {
            std::thread::sleep(Duration::from_millis(20));
        }
        seen()
    };
    assert_eq!(
        wait_seen().as_deref(),
        Some("1"),
        "the operator's write reached the program"
    );
    let (code, text) = post(port, "/api/force", &operator, r#"{"tag":"seen","value":0}"#);
    assert_eq!(code, 403, "{text}");
    assert!(
        text.contains("the operator token may write values and acknowledge alarms; forcing needs the engineer's"),
        "{text}"
    );
    let (code, text) = post(port, "/api/unforce", &operator, "{}");
    assert_eq!(code, 403, "{text}");
    assert!(text.contains("unforcing needs the engineer's"), "{text}");
    assert_eq!(
        seen().as_deref(),
        Some("1"),
        "a refused force changes nothing"
    );

    let (code, text) = post(port, "/api/force", &engineer, r#"{"tag":"seen","value":0}"#);
    assert_eq!(code, 200, "{text}");
    let (code, text) = write_cmd(&engineer);
    assert_eq!(code, 200, "the engineer writes too: {text}");

    let (text, entries) = audit_entries(port, 3);
    let seen: Vec<(String, String)> = entries
        .iter()
        .map(|e| {
            let source = e["source"].as_str().unwrap();
            assert!(source.starts_with("web 127.0.0.1:"), "{text}");
            let role = source.rsplit(' ').next().unwrap_or_default();
            (e["action"].as_str().unwrap().to_owned(), role.to_owned())
        })
        .collect();
    let pairs: Vec<(&str, &str)> = seen.iter().map(|(a, r)| (a.as_str(), r.as_str())).collect();
    assert_eq!(
        pairs,
        [
            ("write", "engineer"),
            ("force", "engineer"),
            ("write", "operator")
        ],
        "the refused requests never reached the scan: {text}"
    );

    // The page signed in with the operator's token says so, hides force and unforce, and
    // its "Write 1" is the operator's in the audit.
    let mut b = Browser::start(&dir.join("chromium"));
    b.open(&format!("http://127.0.0.1:{port}/#io"));
    b.wait_for(
        "document.getElementById('token') !== null && document.querySelector('button[data-write=cmd]') !== null",
        Duration::from_secs(30),
    )
    .expect("the page offers the sign-in and the write buttons");
    sign_in_with(&mut b, "operator-token-0123456789");
    let who = b.eval("document.querySelector('#auth .who').textContent");
    assert!(
        who.as_str()
            .is_some_and(|w| w.contains("signed in as operator")),
        "{who}"
    );
    b.wait_for(
        "document.querySelector('button[data-force=cmd]').hidden && \
         document.querySelector('button[data-unforce=seen]').hidden && \
         !document.querySelector('button[data-write=cmd]').disabled",
        Duration::from_secs(10),
    )
    .expect("the operator's page hides force and unforce, and writes");
    b.eval("document.querySelector('button[data-write=cmd][data-value=\"1\"]').click(); true");
    let newest = audit_entries(port, 4)
        .1
        .first()
        .cloned()
        .unwrap_or_default();
    assert_eq!(newest["action"], "write", "{newest}");
    assert!(
        newest["source"]
            .as_str()
            .is_some_and(|s| s.ends_with(" operator")),
        "{newest}"
    );
    drop(b);
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// A call of a block of one's own is drawn as a box with its instance's live pin values (its
/// tags `s1.start`, `s1.on`, `s1.presses`), and clicking it shows its body drawn over that
/// instance's tags: a second instance of the same block keeps its own values.
#[test]
fn a_block_of_ones_own_is_drawn_with_its_instance_and_its_body_on_demand() {
    chromium_available();
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1"]);
    let dir = std::env::temp_dir().join(format!("softplc-web-own-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("my.blocks.yaml"),
        "blocks:\n  - name: STARTER\n    inputs: [{ name: en, type: bool }, { name: start, type: bool }, { name: stop, type: bool }]\n    outputs: [{ name: on, type: bool }]\n    state: [{ name: presses, type: i32 }]\n    body: starter.ladder.yaml\n\
         \x20 - name: OUTER\n    inputs: [{ name: en, type: bool }, { name: a, type: bool }, { name: b, type: bool }]\n    outputs: [{ name: q, type: bool }]\n    instances: [{ name: st, block: STARTER }]\n    body: outer.ladder.yaml\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("outer.ladder.yaml"),
        "rungs:\n  - en -> STARTER st(a, b) -> q\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("starter.ladder.yaml"),
        "rungs:\n  - en (start | on) /stop -> on\n  - rising(start) -> ADD(presses, 1) => presses\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("machine.ladder.yaml"),
        "rungs:\n  - run -> STARTER s1(start, stop) -> motor\n  - run -> STARTER s2(stop, start) -> fan\n  - run -> OUTER s3(start, stop) -> lamp\n",
    )
    .unwrap();
    let port = free_port();
    let project = format!(
        "project: webown\n\
         scan: {{ period: 50ms, watchdog: {{ time: 1s, sensitivity: 3 }} }}\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 200ms, retries: 1 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n\
         tags:\n\
         \x20 - {{ name: start, point: mm1.X2 }}\n\
         \x20 - {{ name: stop,  point: mm1.X3 }}\n\
         \x20 - {{ name: motor, point: mm1.Y1, safe: false }}\n\
         \x20 - {{ name: fan,   point: mm1.Y2, safe: false }}\n\
         \x20 - {{ name: run,   type: bool, initial: true }}\n\
         \x20 - {{ name: lamp,  type: bool }}\n\
         blocks: [my.blocks.yaml]\n\
         instances: [{{ name: s1, block: STARTER }}, {{ name: s2, block: STARTER }}, {{ name: s3, block: OUTER }}]\n\
         program: {{ file: machine.ladder.yaml, kind: ladder }}\n\
         service:\n  web: {{ bind: \"127.0.0.1:{port}\" }}\n"
    );
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    let plc = run_plc(&dir.join("project.yaml"), &dir.join("ctl.sock"), port);

    let mut b = Browser::start(&dir.join("chromium"));
    b.open(&format!("http://127.0.0.1:{port}/#program"));
    let box1 = "document.querySelector('#ladder svg[data-rung=\"1\"] .lad-block')";
    b.wait_for(&format!("{box1} !== null"), Duration::from_secs(30))
        .expect("the call is drawn as a block");
    // The box: its instance, its block, its pins as the call gives them, its output live.
    let texts = format!("[...{box1}.querySelectorAll('text')].map(t => t.textContent).join(' ')");
    b.wait_for(
        &format!("{texts} === 's1 STARTER en start stop on 0'"),
        Duration::from_secs(10),
    )
    .unwrap_or_else(|| panic!("the STARTER box: {}", b.eval(&texts)));
    // start pressed: s1's output comes on in its box, s2 (start is its stop) stays off.
    sim.send("set minimod@1.X2 1");
    b.wait_for(
        &format!(
            "{box1}.dataset.q === '1' && document.querySelector('#ladder svg[data-rung=\"2\"] .lad-block').dataset.q === '0'"
        ),
        Duration::from_secs(10),
    )
    .expect("s1 on, s2 off");
    sim.send("set minimod@1.X2 0");
    // Its body, on demand, over s1's tags: the latch lit, one press counted.
    assert_eq!(
        b.eval("document.querySelector('#rung-1 .lad-body').hidden"),
        true
    );
    b.eval(&format!(
        "{box1}.dispatchEvent(new MouseEvent('click', {{ bubbles: true }})); true"
    ));
    let body = "document.querySelector('#rung-1 .lad-body')";
    b.wait_for(
        &format!(
            "!{body}.hidden && [...{body}.querySelectorAll('.lad-var')].map(e => e.textContent).join(',') === 'en 1,start 0,stop 0,on 1,presses 1'"
        ),
        Duration::from_secs(10),
    )
    .unwrap_or_else(|| panic!("s1's body: {}", b.eval(&format!("{body}.textContent"))));
    let coil = format!("{body}.querySelector('svg[data-rung=\"1\"] .lad-coil')");
    b.wait_for(
        &format!("{coil}.dataset.energised === '1'"),
        Duration::from_secs(10),
    )
    .expect("the body's latch coil is lit for s1");
    // s2's body (its own button) shows s2's values: off, no press.
    b.eval("document.querySelector('#rung-2 .lad-body-toggle').click(); true");
    b.wait_for(
        "[...document.querySelectorAll('#rung-2 .lad-body .lad-var')].map(e => e.textContent).join(',') === 'en 1,start 0,stop 0,on 0,presses 0'",
        Duration::from_secs(10),
    )
    .unwrap_or_else(|| panic!("s2's body: {}", b.eval("document.querySelector('#rung-2 .lad-body').textContent")));
    // s3's body calls an instance of its own (s3.st): the body shows it as a box named
    // s3.st with its pins, and a click on it shows its body over the tags s3.st.*.
    b.eval("document.querySelector('#rung-3 .lad-body-toggle').click(); true");
    let outer = "document.querySelector('#rung-3 .lad-body')";
    let inner_box = format!("{outer}.querySelector('svg[data-rung=\"1\"] .lad-block')");
    b.wait_for(
        &format!(
            "!{outer}.hidden && {inner_box} !== null && {inner_box}.dataset.instance === 's3.st'"
        ),
        Duration::from_secs(10),
    )
    .unwrap_or_else(|| panic!("s3's body: {}", b.eval(&format!("{outer}.innerHTML"))));
    let outer_vars = format!("[...{outer}.querySelectorAll(':scope > .lad-vars > .lad-var')].map(e => e.textContent).join(',')");
    b.wait_for(
        &format!(
            "{outer_vars} === 'en 1,a 0,b 0,q 1,st.en 1,st.start 0,st.stop 0,st.on 1,st.presses 1'"
        ),
        Duration::from_secs(10),
    )
    .unwrap_or_else(|| panic!("s3's variables: {}", b.eval(&outer_vars)));
    b.eval(&format!(
        "{inner_box}.dispatchEvent(new MouseEvent('click', {{ bubbles: true }})); true"
    ));
    let inner = format!("{outer}.querySelector('.lad-body[data-instance=\"s3.st\"]')");
    b.wait_for(
        &format!(
            "!{inner}.hidden && [...{inner}.querySelectorAll('.lad-var')].map(e => e.textContent).join(',') === 'en 1,start 0,stop 0,on 1,presses 1'"
        ),
        Duration::from_secs(10),
    )
    .unwrap_or_else(|| panic!("s3.st's body: {}", b.eval(&format!("{inner}.textContent"))));
    b.screenshot(&screenshots().join("program-own-block.png"));
    drop(b);
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// A task of two ladder programs: the page draws each under its file's name, and each
/// program's block shows its own instance's live outputs (the second program's instances are
/// numbered after the first's in the state).
#[test]
fn a_tasks_two_ladder_programs_are_each_drawn_with_their_own_blocks() {
    chromium_available();
    let dir = std::env::temp_dir().join(format!("softplc-web-two-programs-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("a.ladder.yaml"),
        "rungs:\n  - go -> TON t1(100ms) -> busy\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("b.ladder.yaml"),
        "rungs:\n  - go -> TON t2(600s) -> valve\n",
    )
    .unwrap();
    let port = free_port();
    let project = format!(
        "project: twoprograms\n\
         scan: {{ period: 50ms }}\n\
         buses: []\n\
         modules: []\n\
         tags:\n\
         \x20 - {{ name: go,    type: bool, initial: true }}\n\
         \x20 - {{ name: busy,  type: bool }}\n\
         \x20 - {{ name: valve, type: bool }}\n\
         programs:\n\
         \x20 - {{ file: a.ladder.yaml, kind: ladder }}\n\
         \x20 - {{ file: b.ladder.yaml, kind: ladder }}\n\
         service:\n  web: {{ bind: \"127.0.0.1:{port}\" }}\n"
    );
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    let plc = run_plc(&dir.join("project.yaml"), &dir.join("ctl.sock"), port);
    let mut b = Browser::start(&dir.join("chromium"));
    b.open(&format!("http://127.0.0.1:{port}/#program"));
    b.wait_for(
        "document.querySelector('#p2-ladder .lad-block') !== null",
        Duration::from_secs(30),
    )
    .expect("the second program drawn as a ladder");
    assert_eq!(
        b.eval("[...document.querySelectorAll('#program .program-file')].map(e => e.textContent)"),
        serde_json::json!(["1. a.ladder.yaml · ladder", "2. b.ladder.yaml · ladder"])
    );
    assert_eq!(
        b.eval("document.getElementById('program-title').textContent"),
        "a.ladder.yaml + b.ladder.yaml"
    );
    // The first program's timer is done; the second's (600 s) runs: each box shows its own.
    let first = "document.querySelector('#ladder .lad-block').textContent";
    let second = "document.querySelector('#p2-ladder .lad-block').textContent";
    let drawn = b.wait_for(
        &format!("{first} === 't1TONINPT 100msQ 1ET 100ms' && {second}.startsWith('t2TONIN') && {second}.includes('Q 0ET ') && !{second}.endsWith('ET 0ms')"),
        Duration::from_secs(10),
    );
    assert!(
        drawn.is_some(),
        "the boxes: {} | {}",
        b.eval(first),
        b.eval(second)
    );
    drop(b);
    drop(plc);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
