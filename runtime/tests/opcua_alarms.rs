//! The alarms as a third-party OPC UA client sees them (Python asyncua,
//! `runtime/tests/opcua/alarms_client.py`): a folder per alarm under `Objects/Alarms` with
//! Active, Acknowledged, Severity, Text, RaisedAt, ClearedAt, AckedAt and a writable
//! Acknowledge; the alarm raised by a write, acknowledged by the client, refused for `false`
//! and a second time, and the acknowledgement in the audit file as `opcua`.

use std::io::Write;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::host::{free_port, lines_of, repo, scratch_dir};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

#[test]
fn an_asyncua_client_reads_an_alarm_and_acknowledges_it() {
    let python = repo().join("target/py-venv/bin/python");
    assert!(
        python.exists(),
        "{} is missing: run scripts/test, which creates it",
        python.display()
    );
    let dir = scratch_dir("opcua_alarms", "ack");
    let port = free_port();
    let project = crate::common::alarm_project::jam_project(
        &dir,
        "alarms_opcua",
        &format!("opcua: {{ port: {port}, writes: true }}"),
    );
    let socket = dir.join("ctl.sock");
    let mut plc = Command::new(BIN)
        .args(["run", "--quiet", "--for", "90s", "--socket"])
        .arg(&socket)
        .arg(&project)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut client = Command::new(&python)
        .arg(repo().join("runtime/tests/opcua/alarms_client.py"))
        .arg(format!("opc.tcp://127.0.0.1:{port}/"))
        .arg("urn:softplc:alarms_opcua")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut to_client = client.stdin.take().unwrap();
    let from_client = lines_of(client.stdout.take().unwrap());
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut passed = Vec::new();
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let Ok(line) = from_client.recv_timeout(left) else {
            // The children may have exited already; then there is nothing to stop.
            drop(client.kill());
            drop(plc.kill());
            panic!("the client stopped or timed out after {passed:?}");
        };
        if let Some(step) = line.strip_prefix("PASS ") {
            passed.push(step.to_string());
        } else if line == "DONE" {
            break;
        } else if line == "NEED raise" {
            let out = Command::new(BIN)
                .args(["write", "--socket"])
                .arg(&socket)
                .args(["jam", "1"])
                .output()
                .unwrap();
            assert!(out.status.success(), "{out:?}");
            writeln!(to_client, "done").unwrap();
        } else {
            // The children may have exited already; then there is nothing to stop.
            drop(client.kill());
            drop(plc.kill());
            panic!("client: {line} (after {passed:?})");
        }
    }
    assert!(client.wait().unwrap().success());
    assert_eq!(passed, ["browse", "raised", "acknowledged"]);
    let (ok, text) =
        crate::common::host::softplc(&["alarms", "--socket", socket.to_str().unwrap(), "--json"]);
    assert!(ok, "{text}");
    let list: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(list["current"][0]["acked_by"], "opcua", "{list:#}");
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    let audit = std::fs::read_to_string(dir.join("project.yaml.audit.jsonl")).unwrap_or_default();
    let acks: Vec<serde_json::Value> = audit
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .filter(|e: &serde_json::Value| e["action"] == "acknowledge")
        .collect();
    assert_eq!(acks.len(), 2, "the refused second one too: {audit}");
    assert_eq!(
        (
            acks[0]["source"].as_str(),
            acks[0]["what"].as_str(),
            acks[0]["ok"].as_bool()
        ),
        (Some("opcua"), Some("jam"), Some(true))
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
