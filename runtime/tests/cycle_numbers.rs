//! One numbering of cycles everywhere: cycle N is the N-th scan (the first is 1), equal to the
//! scan count once it is done. One event, the cycle in which a counter of scans reaches 40, is
//! followed through a running instance's status and a trace (one run on the virtual clock,
//! through its control socket), then through the flight record of the same project and
//! `softplc replay` of it (the virtual clock replays the same cycles): each names it cycle 40,
//! at 390 ms.
//!
//! The services say the same number of a live PLC of two tasks, each counting its own scans
//! in a tag (real clock: a slow first task and a fast one): the web page's `/api/state` (the
//! PLC's and each task's cycles, the tags, each task's figures, one snapshot), `softplc status`
//! and a third-party OPC UA client reading `PLC.Scans`, `PLC/Tasks/NAME/Scans` and the tags
//! (`runtime/tests/opcua/scans_client.py`): after the first task's cycle N, its count is N
//! and its tag says N in all of them; the fast task's count is the cycle its tag comes from
//! (one apart at most where status or OPC UA is asked while a cycle of it ends); a trace in
//! each task samples its cycles, each numbered as its count. A Sparkplug host
//! (`runtime/tests/mqtt/scans_host.py`) sees the same in the NBIRTH and in every NDATA:
//! `PLC/Scans`, `Tasks/main/Scans` and `Tasks/other/Scans` equal `n` and `m`, at their
//! timestamps.

use crate::common::host;

use std::path::{Path, PathBuf};

use host::{run_virtual, softplc};

fn folder() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-cycle-numbers-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `n` counts the scans; `mark` is true in the scan where it reaches `at`.
fn project(dir: &Path, name: &str, at: u32) -> PathBuf {
    let program = format!("{name}.rhai");
    std::fs::write(
        dir.join(&program),
        format!("n = n + 1;\nmark = n == {at};\n"),
    )
    .unwrap();
    let text = format!(
        "project: numbers
scan: {{ period: 10ms }}
tags:
  - {{ name: n, type: i32 }}
  - {{ name: mark, type: bool }}
program: {{ file: {program}, kind: rhai }}
traces:
  - name: marked
    tags: [n, mark]
    trigger: mark rising
    pre: 1
    post: 1
"
    );
    let path = dir.join(format!("{name}.yaml"));
    std::fs::write(&path, text).unwrap();
    path
}

/// Trace `name` of the instance on `socket` once complete (within 30 s), saved as CSV into
/// `dir`: the file's text.
fn saved_csv(dir: &Path, name: &str, socket: &str) -> String {
    let csv = dir.join(format!("{name}.csv"));
    let (ok, text) = softplc(&[
        "trace",
        "save",
        name,
        "--wait",
        "30s",
        "--csv",
        csv.to_str().unwrap(),
        "--socket",
        socket,
    ]);
    assert!(ok, "{text}");
    std::fs::read_to_string(&csv).unwrap()
}

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

#[test]
fn one_event_has_one_cycle_number_in_status_trace_record_and_replay() {
    let dir = folder();
    let live = project(&dir, "live", 40);
    let socket = dir.join("ctl.sock");
    let _running = run_virtual(&live, &socket);
    let s = socket.to_str().unwrap();

    // Status: the scan count and the counter, from one snapshot, are the same number.
    let (ok, text) = softplc(&["status", "--json", "--socket", s]);
    assert!(ok, "{text}");
    let status = json(&text);
    let scans = status["scans"].as_u64().unwrap();
    assert!(scans >= 40, "{status}");
    assert_eq!(
        status["tags"][0]["value"].as_str().unwrap(),
        scans.to_string(),
        "n after scan N is N: {status}"
    );

    // The trace: the rise is sampled in cycle 40, at 390 ms (the first cycle starts at 0).
    assert_eq!(
        saved_csv(&dir, "marked", s),
        "time_s,cycle,n [i32],mark [bool]\n\
         0.380000000,39,39,0\n\
         0.390000000,40,40,1\n\
         0.400000000,41,41,0\n"
    );
    let (_, text) = softplc(&["trace", "status", "marked", "--socket", s]);
    assert!(text.contains("triggered at cycle 40"), "{text}");

    // The record of the same project for a second, replayed by a program whose mark comes a
    // scan later: the first difference is cycle 40, at 390 ms, and the run had 100 scans.
    let recorded = project(&dir, "recorded", 40);
    let (ok, text) = softplc(&[
        "run",
        recorded.to_str().unwrap(),
        "--virtual",
        "--for",
        "1s",
        "--no-socket",
        "--record",
        "10m",
    ]);
    assert!(ok, "{text}");
    assert!(text.contains("scans 100 "), "{text}");
    let record = dir.join("recorded.yaml.record");
    let later = project(&dir, "later", 41);
    let (_, text) = softplc(&["replay", record.to_str().unwrap(), later.to_str().unwrap()]);
    assert!(
        text.contains("first difference at cycle 40 (t=390.00ms):"),
        "{text}"
    );
    assert!(text.contains("100 cycles, 1.00s of plant time"), "{text}");
}

/// Two tasks counting their own scans on the real clock: `main` (the first task, every
/// 400 ms) counts `n`, `other` (every 50 ms) counts `m`; `project.yaml` in `dir`, ending in
/// its `service:` section with the lines `service`.
fn counting_tasks(dir: &Path, service: &str) -> PathBuf {
    std::fs::write(dir.join("main.rhai"), "n = n + 1;\n").unwrap();
    std::fs::write(dir.join("other.rhai"), "m = m + 1;\n").unwrap();
    let path = dir.join("project.yaml");
    std::fs::write(
        &path,
        format!(
            "project: numbers
tasks:
  - {{ name: main, period: 400ms, program: {{ file: main.rhai, kind: rhai }} }}
  - {{ name: other, period: 50ms, program: {{ file: other.rhai, kind: rhai }} }}
tags:
  - {{ name: n, type: i32 }}
  - {{ name: m, type: i32 }}
service:
{service}"
        ),
    )
    .unwrap();
    path
}

/// A third-party OPC UA client (`runtime/tests/opcua/scans_client.py`) that reads the scan
/// counts and the tags `n` and `m` in one Read request each time it is asked.
struct ScansClient {
    child: std::process::Child,
    stdin: std::process::ChildStdin,
    lines: std::sync::mpsc::Receiver<String>,
}

impl ScansClient {
    fn start(url: &str) -> Self {
        let python = host::repo().join("target/py-venv/bin/python");
        assert!(
            python.exists(),
            "{} is missing: run scripts/test, which creates it",
            python.display()
        );
        let (child, stdin, lines) = host::spawn_piped(
            std::process::Command::new(python)
                .arg(host::repo().join("runtime/tests/opcua/scans_client.py"))
                .args([url, "urn:softplc:numbers", "main,other", "n,m"]),
        );
        let mut client = Self {
            child,
            stdin,
            lines,
        };
        let ready = client.line();
        assert_eq!(ready, "READY", "the OPC UA client did not connect");
        client
    }

    fn line(&mut self) -> String {
        self.lines
            .recv_timeout(std::time::Duration::from_secs(30))
            .expect("the OPC UA client answers within 30 s")
    }

    /// `{"PLC.Scans": …, "PLC.Tasks.main.Scans": …, "Tags.n": …, …}` now.
    fn read(&mut self) -> serde_json::Value {
        use std::io::Write;
        writeln!(self.stdin, "read").unwrap();
        json(&self.line())
    }
}

impl Drop for ScansClient {
    fn drop(&mut self) {
        // The client may have ended already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

/// `softplc status --json` of the instance on `socket`.
fn status(socket: &Path) -> serde_json::Value {
    let (ok, text) = softplc(&["status", "--json", "--socket", socket.to_str().unwrap()]);
    assert!(ok, "{text}");
    json(&text)
}

/// A counter's value as `status --json` says it (text) or a service does (a number).
fn count(v: &serde_json::Value) -> u64 {
    v.as_u64()
        .or_else(|| v.as_str().and_then(|s| s.parse().ok()))
        .unwrap_or_else(|| panic!("not a count: {v}"))
}

#[test]
fn each_tasks_cycle_is_its_scan_count_in_status_the_web_page_and_opcua() {
    let dir = host::scratch_dir("cycle_numbers", "tasks");
    // The web page and OPC UA on loopback port 0.
    let project = counting_tasks(&dir, "  web: { bind: 127.0.0.1:0 }\n  opcua: { port: 0 }\n");
    let socket = dir.join("ctl.sock");
    let log = dir.join("log");
    let _running = host::Running(
        std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
            .arg("run")
            .arg(&project)
            .args(["--for", "90s", "--quiet", "--socket"])
            .arg(&socket)
            .env("RUST_LOG", "info")
            .stdout(std::process::Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap(),
    );
    let web = host::log_value(&log, "web page: http://");
    let ua = host::log_value(&log, "OPC UA server at opc.tcp://");
    host::status_once_scanned(&socket, &[3, 20]);
    let mut client = ScansClient::start(&format!("opc.tcp://{ua}/"));

    // The page: one snapshot holds each task's count, the cycle its tags come from and its
    // figures, so every answer agrees within itself, for the fast task too.
    for _ in 0..10 {
        let page = json(&crate::task_services::get(&web, "/api/state"));
        let (state, stats) = (&page["state"], &page["stats"]);
        let main = count(&state["cycles"]);
        assert_eq!(count(&state["task_cycles"][0]), main, "{page}");
        assert_eq!(
            count(&state["v"][0]),
            main,
            "n after main's scan N is N: {page}"
        );
        assert_eq!(count(&stats["tasks"][0]["scans"]), main, "{page}");
        let other = count(&state["task_cycles"][1]);
        assert_eq!(
            count(&state["v"][1]),
            other,
            "m after other's scan N is N: {page}"
        );
        assert_eq!(count(&stats["tasks"][1]["scans"]), other, "{page}");
        std::thread::sleep(std::time::Duration::from_millis(70));
    }

    // Status and OPC UA between two of main's cycles: status is answered at the end of one
    // of main's cycles, and the page read after OPC UA shows no later one. The scan count,
    // main's own count and `n` are then one number everywhere. `other` runs on while they
    // are asked: its count and `m` are the same number, or one apart where a cycle of it
    // ended between the two (its tags are published before its count).
    let mut quiet = 0;
    let mut other_equal = 0;
    let begin = std::time::Instant::now();
    while quiet < 5 {
        assert!(
            begin.elapsed() < std::time::Duration::from_secs(40),
            "{quiet} quiet moments in 40 s"
        );
        let status = status(&socket);
        // What the scan offered at its cycle's end reaches OPC UA's address space.
        std::thread::sleep(std::time::Duration::from_millis(40));
        let opc = client.read();
        let page = json(&crate::task_services::get(&web, "/api/state"));
        let near = count(&status["tasks"][1]["scans"]).abs_diff(count(&status["tags"][1]["value"]));
        assert!(near <= 1, "other's count against m: {status}");
        let near = count(&opc["PLC.Tasks.other.Scans"]).abs_diff(count(&opc["Tags.m"]));
        assert!(near <= 1, "OPC UA other's Scans against m: {opc}");
        other_equal += usize::from(near == 0);
        let n = count(&status["scans"]);
        if count(&page["state"]["cycles"]) != n {
            continue;
        }
        quiet += 1;
        assert_eq!(count(&status["tasks"][0]["scans"]), n, "{status}");
        assert_eq!(count(&status["tags"][0]["value"]), n, "{status}");
        for id in ["PLC.Scans", "PLC.Tasks.main.Scans", "Tags.n"] {
            assert_eq!(count(&opc[id]), n, "{id} in {opc} against status {status}");
        }
    }
    // A trace in each task samples that task's cycles: each row's cycle is its counter.
    let s = socket.to_str().unwrap();
    for (task, tag) in [("main", "n"), ("other", "m")] {
        let trigger = format!("{tag} >= 1");
        let (ok, text) = softplc(&[
            "trace",
            "arm",
            task,
            "--tags",
            tag,
            "--task",
            task,
            "--trigger",
            &trigger,
            "--pre",
            "0",
            "--post",
            "3",
            "--socket",
            s,
        ]);
        assert!(ok, "{text}");
        let csv = saved_csv(&dir, task, s);
        let mut rows = csv.lines();
        assert_eq!(
            rows.next(),
            Some(format!("time_s,cycle [task {task}],{tag} [i32]").as_str()),
            "{csv}"
        );
        let rows: Vec<Vec<&str>> = rows.map(|r| r.split(',').collect()).collect();
        assert_eq!(rows.len(), 4, "{csv}");
        for row in rows {
            assert_eq!(row[1], row[2], "task {task}'s cycle is its count: {csv}");
        }
    }
    assert!(
        other_equal > 0,
        "OPC UA never showed other's Scans equal to m"
    );
}

/// A Sparkplug host (`runtime/tests/mqtt/scans_host.py`, through a mosquitto of this test)
/// watching the same two tasks for 4 s: in the NBIRTH and in every NDATA that carries a scan
/// count, `PLC/Scans` and `Tasks/main/Scans` are `n` as the host holds it after that message,
/// and `Tasks/other/Scans` is `m`, each with its counter's timestamp (the cycle's end). The
/// edge node takes the counts and the tags from one thread's view of the scan, so no cycle
/// ends between them: they are one number, not one apart. The counts go out once a second,
/// so 4 s checks each of them at least twice.
#[test]
fn a_sparkplug_hosts_scan_counts_are_the_cycles_its_counters_come_from() {
    let s = crate::common::scratch::Scratch::new("cycle_numbers", "mqtt");
    counting_tasks(&s.dir, "");
    let (_broker, port, pb2) = crate::task_services::with_broker(&s, "numbers1");
    let _running = crate::task_services::start(&s);
    let passed = crate::task_services::run_python(
        "mqtt/scans_host.py",
        &[
            &port.to_string(),
            "plant1",
            "numbers1",
            &pb2,
            "4",
            "main:n,other:m",
        ],
    );
    assert_eq!(passed.len(), 2, "{passed:?}");
    assert_eq!(passed[0], "births", "{passed:?}");
    let checked: Vec<(&str, u64)> = passed[1]
        .strip_prefix("ndata ")
        .unwrap_or_else(|| panic!("{passed:?}"))
        .split(' ')
        .filter_map(|w| w.split_once('='))
        .map(|(name, k)| (name, k.parse().unwrap()))
        .collect();
    assert_eq!(checked.len(), 3, "{passed:?}");
    for (name, k) in checked {
        assert!(k >= 2, "{name} checked {k} times in 4 s: {passed:?}");
    }
}
