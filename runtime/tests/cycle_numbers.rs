//! One numbering of cycles everywhere: cycle N is the N-th scan (the first is 1), equal to the
//! scan count once it is done. One event, the cycle in which a counter of scans reaches 40, is
//! followed through a running instance's status and a trace (one run on the virtual clock,
//! through its control socket), then through the flight record of the same project and
//! `softplc replay` of it (the virtual clock replays the same cycles): each names it cycle 40,
//! at 390 ms. The web page, the metrics, OPC UA's `PLC.Scans` and Sparkplug's `PLC/Scans`
//! publish the scan count of the same snapshot status reads (`service/snapshot.rs`).

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

fn json(text: &str) -> serde_json::Value {
    serde_json::from_str(text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

#[test]
fn one_event_has_one_cycle_number_in_status_web_trace_record_and_replay() {
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
    let csv = dir.join("marked.csv");
    let (ok, text) = softplc(&[
        "trace",
        "save",
        "marked",
        "--wait",
        "30s",
        "--csv",
        csv.to_str().unwrap(),
        "--socket",
        s,
    ]);
    assert!(ok, "{text}");
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
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
