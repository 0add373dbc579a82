//! Alarms end to end on the real binary, the real clock and `softplc sim` on a pty: a tag's
//! alarm raised and cleared as the input moves, listed and acknowledged with `softplc alarms`
//! (the audit file names the CLI), counted in `status --json`; the line dies and the list
//! holds one "module lost" alarm per module, not one per signal; the history file keeps the
//! events across a restart without raising again what was still raised.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::host::{free_port, softplc};
use crate::common::scratch::Scratch;
use crate::common::sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

fn start(project: &Path, socket: &Path) -> Child {
    Command::new(BIN)
        .args(["run", "--quiet", "--for", "60s", "--socket"])
        .arg(socket)
        .arg(project)
        .env("SOFTPLC_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn stop(mut plc: Child) {
    #[allow(unsafe_code)]
    // SAFETY: kill with a valid pid and signal.
    unsafe {
        libc::kill(plc.id() as i32, libc::SIGINT)
    };
    assert!(plc.wait().unwrap().success());
}

/// The metrics endpoint's text.
fn scrape(port: u16) -> String {
    use std::io::{Read, Write};
    let mut c = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    c.write_all(format!("GET /metrics HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n").as_bytes())
        .unwrap();
    let mut out = String::new();
    // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
    drop(c.read_to_string(&mut out));
    out
}

/// `softplc alarms --json` as JSON, or what it said instead.
fn list(socket: &Path) -> Result<serde_json::Value, String> {
    let s = socket.to_str().unwrap();
    let (ok, text) = softplc(&["alarms", "--socket", s, "--json", "--history", "50"]);
    if !ok {
        return Err(text);
    }
    Ok(serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}")))
}

/// The current list's `(name, active, acknowledged)`, by name (the order is the unit tests'
/// subject; two modules lost on one line may be seen a cycle apart).
fn current(l: &serde_json::Value) -> Vec<(String, bool, bool)> {
    l["current"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            (
                a["name"].as_str().unwrap().to_string(),
                a["active"].as_bool().unwrap(),
                a["acknowledged"].as_bool().unwrap(),
            )
        })
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect()
}

/// Waits (bounded) until the current list is `want` (by name).
fn wait_current(socket: &Path, want: &[(&str, bool, bool)]) -> serde_json::Value {
    let want: Vec<(String, bool, bool)> = want
        .iter()
        .map(|&(n, a, k)| (n.to_string(), a, k))
        .collect();
    let end = Instant::now() + Duration::from_secs(15);
    loop {
        // Until the instance has opened its socket.
        let l = match list(socket) {
            Ok(l) => l,
            Err(e) if Instant::now() > end => panic!("{e}"),
            Err(_) => {
                std::thread::sleep(Duration::from_millis(100));
                continue;
            }
        };
        if current(&l) == want || Instant::now() > end {
            assert_eq!(current(&l), want, "{l:#}");
            return l;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn alarms_are_raised_acknowledged_folded_on_a_dead_line_and_kept_across_a_restart() {
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let metrics = free_port();
    let dir = Scratch::new("alarms", "end_to_end");
    dir.write("follow.expr", "lamp = jam\n");
    let project = dir.write(
        "plant.yaml",
        &format!(
            "project: alarms{pid}\n\
             scan: {{ period: 50ms }}\n\
             buses:\n  - {{ name: line1, port: {pty}, response_timeout: 50ms, retries: 1 }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1, settings: {{ events: false }} }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2, settings: {{ events: false }} }}\n\
             tags:\n\
             \x20 - {{ name: jam, point: mm1.X1, alarm: {{ text: Door jammed, priority: high }} }}\n\
             \x20 - {{ name: air_ok, point: mm1.X2, alarm: {{ text: No air pressure, when: false }} }}\n\
             \x20 - {{ name: oil_ok, point: mm1.X3, alarm: {{ text: No oil, when: false, priority: low }} }}\n\
             \x20 - {{ name: lamp, point: mm2.Y1, safe: false }}\n\
             program: {{ file: follow.expr, kind: expr }}\n\
             service: {{ metrics: \"127.0.0.1:{metrics}\" }}\n",
            pid = std::process::id()
        ),
    );
    let socket = dir.dir.join("plc.sock");
    let sock = socket.to_str().unwrap();
    // Air and oil are there before the PLC starts: nothing is raised.
    sim.send("set minimod@1.X2 1");
    sim.send("set minimod@1.X3 1");
    let plc = start(&project, &socket);
    wait_current(&socket, &[]);

    // The door jams, and frees: raised, cleared, waiting for the operator.
    sim.send("set minimod@1.X1 1");
    let l = wait_current(&socket, &[("jam", true, false)]);
    let jam = &l["current"][0];
    assert_eq!(jam["text"], "Door jammed");
    assert_eq!(
        (jam["priority"].as_u64(), jam["level"].as_str()),
        (Some(750), Some("high"))
    );
    assert!(jam["raised"]["utc"].as_str().unwrap().ends_with('Z'));
    let raised_at = jam["raised"]["cycle"].as_u64().unwrap();
    assert!(raised_at > 1);
    let (ok, text) = softplc(&["status", "--socket", sock, "--json"]);
    assert!(ok, "{text}");
    let status: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        status["alarms"]["active"],
        serde_json::json!([0, 0, 1, 0]),
        "{status:#}"
    );
    assert_eq!(status["alarms"]["unacknowledged"], 1);
    sim.send("set minimod@1.X1 0");
    wait_current(&socket, &[("jam", false, false)]);

    // Acknowledged from the CLI: gone from the list, in the audit file as the CLI's.
    let (ok, text) = softplc(&["alarms", "--socket", sock, "ack", "jam"]);
    assert!(ok && text.contains("acknowledged: jam"), "{text}");
    let (ok, text) = softplc(&["alarms", "--socket", sock, "ack", "jam"]);
    assert!(
        !ok && text.contains("alarm jam is not waiting for an acknowledgement"),
        "{text}"
    );
    wait_current(&socket, &[]);

    // The line dies with air and oil gone: one alarm per module, the signals' held.
    sim.send("line dead");
    sim.send("set minimod@1.X2 0");
    sim.send("set minimod@1.X3 0");
    let l = wait_current(
        &socket,
        &[("lost.mm1", true, false), ("lost.mm2", true, false)],
    );
    let texts: Vec<&str> = l["current"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|a| a["text"].as_str())
        .collect();
    assert!(texts.contains(&"module lost: mm1"), "{texts:?}");
    assert_eq!(l["counts"]["active"], serde_json::json!([0, 0, 2, 0]));
    let scrape = scrape(metrics);
    assert!(
        scrape.contains("softplc_alarms_active{priority=\"high\"} 2\n")
            && scrape.contains("softplc_alarms_unacknowledged 2\n"),
        "{scrape}"
    );
    // Back: the modules' alarms clear, and what the line now says is raised.
    sim.send("line alive");
    let l = wait_current(
        &socket,
        &[
            ("air_ok", true, false),
            ("lost.mm1", false, false),
            ("lost.mm2", false, false),
            ("oil_ok", true, false),
        ],
    );
    let (ok, text) = softplc(&["alarms", "--socket", sock, "ack", "all"]);
    assert!(
        ok && text.contains("lost.mm1") && text.contains("oil_ok"),
        "{text}"
    );
    let events: Vec<(String, String)> = l["history"]
        .as_array()
        .unwrap()
        .iter()
        .rev()
        .map(|e| {
            (
                e["alarm"].as_str().unwrap().into(),
                e["event"].as_str().unwrap().into(),
            )
        })
        .collect();
    let pair = |a: &str, e: &str| (a.to_string(), e.to_string());
    assert_eq!(
        events[..3],
        [
            pair("jam", "raised"),
            pair("jam", "cleared"),
            pair("jam", "acknowledged"),
        ],
        "{events:?}"
    );
    // While lost, nothing but the modules' alarms: no air_ok or oil_ok until the line is back.
    let back = events
        .iter()
        .position(|e| *e == pair("lost.mm1", "cleared"))
        .unwrap();
    assert!(
        events[3..back].iter().all(|(a, _)| a.starts_with("lost.")),
        "{events:?}"
    );
    assert!(
        events[back..].contains(&pair("air_ok", "raised")),
        "{events:?}"
    );
    stop(plc);

    let audit = std::fs::read_to_string(dir.dir.join("plant.yaml.audit.jsonl")).unwrap();
    let acks: Vec<serde_json::Value> = audit
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .filter(|e: &serde_json::Value| e["action"] == "acknowledge")
        .collect();
    assert_eq!(acks.len(), 3, "{audit}");
    assert_eq!(
        (acks[0]["source"].as_str(), acks[0]["what"].as_str()),
        (Some("cli"), Some("jam"))
    );
    assert_eq!(acks[0]["ok"], true);
    assert_eq!(
        acks[1]["ok"], false,
        "the refused second one is audited too"
    );

    // A restart: the history is there, and air and oil, still gone, are not raised twice.
    let file = dir.dir.join("plant.yaml.alarms.jsonl");
    let before = std::fs::read_to_string(&file).unwrap();
    let plc = start(&project, &socket);
    let l = wait_current(&socket, &[("air_ok", true, true), ("oil_ok", true, true)]);
    stop(plc);
    let after = std::fs::read_to_string(&file).unwrap();
    assert_eq!(after, before, "nothing new: {l:#}");
}
