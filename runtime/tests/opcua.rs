//! The OPC UA server against a third-party client (Python asyncua,
//! `runtime/tests/opcua/client.py`), on 127.0.0.1 at a free port.
//!
//! The client browses the address space, reads the Description of a described tag and module
//! (and none of a tag without one), reads each tag type's exact Variant type and the
//! status of a tag whose module does not answer (its line is a pty nobody serves), reads the
//! PLC's and the modules' diagnostics, subscribes, writes a writable tag and sees the change
//! within two cycles of the write's answer, sees a forced input within two cycles, and is
//! refused for a read-only tag, a value of the wrong type, a forced tag, and any write when
//! the server's writes are off. `scripts/test` installs the Python environment
//! (`target/py-venv`, pinned in `runtime/tests/opcua/requirements.txt`).
//!
//! On a Basic256Sha256 Sign & Encrypt endpoint with a user, the client is refused with
//! SecurityPolicy None, with an untrusted certificate (until the test moves it out of the
//! server's `rejected/` folder, as an operator would), and with a wrong password or user; with
//! the right ones it reads over the encrypted channel; the server's certificate, made in the
//! state folder at first start, is the same after a second start. A pair torn at first start
//! (an empty certificate, a key cut to 300 bytes) is kept aside, a new one made and logged,
//! and the secure client reads all the same; `status --json` says the server runs.
//!
//! `check` refuses a server beyond loopback without security, at the key to fix.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::host;
use host::{free_port, lines_of, repo as workspace};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
const PERIOD_MS: u64 = 100;

fn python() -> PathBuf {
    let py = workspace().join("target/py-venv/bin/python");
    assert!(
        py.exists(),
        "{} is missing: run scripts/test, which creates it (asyncua from \
         runtime/tests/opcua/requirements.txt)",
        py.display()
    );
    py
}

/// A fresh folder of this test.
fn scratch(name: &str) -> PathBuf {
    crate::common::host::scratch_dir("opcua", name)
}

/// A pseudo-terminal nobody answers on, held open by a child; its path.
struct DeadLine {
    child: Child,
    path: String,
}

impl DeadLine {
    fn open() -> Self {
        let mut child = Command::new(python())
            .args([
                "-c",
                "import os,sys,time\nm,s=os.openpty()\nprint(os.ttyname(s),flush=True)\n\
                 sys.stdin.read()",
            ])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let lines = lines_of(child.stdout.take().unwrap());
        let path = lines.recv_timeout(Duration::from_secs(10)).unwrap();
        Self { child, path }
    }
}

impl Drop for DeadLine {
    fn drop(&mut self) {
        // The child may have exited already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

/// The secure case's user and password.
const USER: &str = "operator";
const PASSWORD: &str = "s3cret-pass";

fn project(dir: &Path, port: u16, writes: bool, secure: bool, dead: &str) -> PathBuf {
    let security = if secure {
        format!("    security: basic256sha256\n    username: {USER}\n    password: {PASSWORD}\n")
    } else {
        String::new()
    };
    let programs = workspace().join("programs");
    let text = format!(
        r#"project: opcua_test
scan:
  period: {PERIOD_MS}ms
buses:
  - {{ name: line1, port: sim, baud: 57600, format: 8E1, response_timeout: 30ms, retries: 1 }}
  - {{ name: line2, port: {dead}, baud: 57600, format: 8E1, response_timeout: 20ms, retries: 0 }}
modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1, description: "Conveyor entry, cabinet 1" }}
  - {{ name: mm2, bus: line1, model: minimod, address: 2 }}
  - {{ name: mm3, bus: line2, model: minimod, address: 3 }}
tags:
  - {{ name: box_at_entry, point: mm1.X1 }}
  - {{ name: start,        point: mm1.X2, description: "Start button, green" }}
  - {{ name: stop,         point: mm1.X3, scada: none }}
  - {{ name: motor,        point: mm1.Y1, safe: false }}
  - {{ name: box_at_exit,  point: mm2.X1, scada: none }}
  - {{ name: lamp,         point: mm2.Y1, safe: false, scada: none }}
  - {{ name: far,          point: mm3.X1 }}
  - {{ name: setpoint, type: u16, scada: write }}
  - {{ name: held, type: u16, scada: write }}
  - {{ name: limit, type: i32, initial: -40 }}
  - {{ name: gain, type: f32, initial: 1.5 }}
program:
  file: {}
  kind: expr
service:
  opcua:
    port: {port}
    writes: {writes}
{security}"#,
        programs.join("conveyor.expr").display()
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

fn softplc(project: &Path, socket: &Path, log: &Path) -> Child {
    Command::new(BIN)
        .args(["run", "--quiet", "--for", "90s", "--socket"])
        .arg(socket)
        .arg(project)
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap()
}

/// What a power cut at first start leaves of the server's pair: an empty certificate and a key
/// torn to 300 bytes.
fn tear_the_servers_pair(dir: &Path) {
    let pki = dir.join("opcua-pki");
    std::fs::create_dir_all(pki.join("own")).unwrap();
    std::fs::create_dir_all(pki.join("private")).unwrap();
    std::fs::write(pki.join("own/cert.der"), b"").unwrap();
    let torn = format!("-----BEGIN PRIVATE KEY-----\n{}", "M".repeat(300 - 28));
    std::fs::write(pki.join("private/private.pem"), torn).unwrap();
}

/// Runs the client in `mode` against a softplc serving `writes` (on Basic256Sha256 with a
/// user when `mode` is "secure"), its certificate and key torn before the start when `torn`;
/// the steps it passed.
fn run_client(name: &str, writes: bool, mode: &str, torn: bool) -> Vec<String> {
    let secure = mode == "secure";
    let dir = scratch(name);
    if torn {
        tear_the_servers_pair(&dir);
    }
    let dead = DeadLine::open();
    let port = free_port();
    let project = project(&dir, port, writes, secure, &dead.path);
    let socket = dir.join("control.sock");
    let log = dir.join("softplc.log");
    let mut plc = softplc(&project, &socket, &log);
    let mut cmd = Command::new(python());
    cmd.arg(workspace().join("runtime/tests/opcua/client.py"))
        .arg(format!("opc.tcp://127.0.0.1:{port}/"))
        .arg("urn:softplc:opcua_test")
        .arg(PERIOD_MS.to_string())
        .arg(mode);
    if secure {
        cmd.arg(&dir).args([USER, PASSWORD]);
    }
    let mut client = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut to_client = client.stdin.take().unwrap();
    let from_client = lines_of(client.stdout.take().unwrap());
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut passed = Vec::new();
    let fail = |why: String, plc: &mut Child, client: &mut Child| -> ! {
        // The children may have exited already; then there is nothing to stop.
        drop(client.kill());
        drop(plc.kill());
        panic!(
            "{why}; softplc's log:\n{}",
            std::fs::read_to_string(&log).unwrap_or_default()
        );
    };
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let Ok(line) = from_client.recv_timeout(left) else {
            fail(
                format!("the client stopped or timed out after {passed:?}"),
                &mut plc,
                &mut client,
            );
        };
        eprintln!("client: {line}");
        if let Some(step) = line.strip_prefix("PASS ") {
            passed.push(step.to_string());
        } else if let Some(why) = line.strip_prefix("FAIL ") {
            fail(
                format!("client: {why} (after {passed:?})"),
                &mut plc,
                &mut client,
            );
        } else if line == "DONE" {
            break;
        } else if let Some(action) = line.strip_prefix("NEED force ") {
            let mut words = action.split(' ');
            let out = Command::new(BIN)
                .args(["force", "--socket"])
                .arg(&socket)
                .args([words.next().unwrap(), words.next().unwrap()])
                .output()
                .unwrap();
            assert!(out.status.success(), "force: {out:?}");
            writeln!(to_client, "done").unwrap();
        } else if line == "NEED trust" {
            // What an operator does: trust the client's certificate the server rejected.
            let pki = dir.join("opcua-pki");
            let rejected: Vec<_> = std::fs::read_dir(pki.join("rejected"))
                .unwrap()
                .map(|e| e.unwrap().path())
                .collect();
            assert_eq!(rejected.len(), 1, "one rejected client certificate");
            for cert in rejected {
                std::fs::rename(&cert, pki.join("trusted").join(cert.file_name().unwrap()))
                    .unwrap();
            }
            writeln!(to_client, "done").unwrap();
        }
    }
    assert!(client.wait().unwrap().success());
    let status = Command::new(BIN)
        .args(["status", "--json", "--socket"])
        .arg(&socket)
        .output()
        .unwrap();
    let status: serde_json::Value = serde_json::from_slice(&status.stdout).unwrap();
    let opcua = status["services"]
        .as_array()
        .and_then(|s| s.iter().find(|s| s["service"] == "opcua"))
        .cloned();
    assert_eq!(
        opcua,
        Some(serde_json::json!({"service": "opcua", "state": "running"})),
        "{status}"
    );
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    let text = std::fs::read_to_string(&log).unwrap();
    if torn {
        assert!(
            text.contains(
                "OPC UA server: its certificate or private key was damaged (the \
                           certificate does not read"
            ) && text.contains("a new pair was made (certificate thumbprint ")
                && text.contains("clients must trust the new certificate"),
            "{text}"
        );
        let kept: Vec<String> = ["own", "private"]
            .iter()
            .flat_map(|d| std::fs::read_dir(dir.join("opcua-pki").join(d)).unwrap())
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".damaged-"))
            .collect();
        assert_eq!(kept.len(), 2, "both damaged files kept aside: {kept:?}");
    }
    let security = if secure {
        format!("SecurityPolicy Basic256Sha256, Sign & Encrypt, user {USER} with password")
    } else {
        "SecurityPolicy None, anonymous".into()
    };
    let started = format!("OPC UA server at opc.tcp://127.0.0.1:{port}/ ({security})");
    assert!(text.contains(&started), "{text}");
    assert!(
        !text.contains(PASSWORD),
        "the log shows no password: {text}"
    );
    let cert = dir.join("opcua-pki/own/cert.der");
    assert!(
        cert.exists() && dir.join("opcua-pki/private/private.pem").exists(),
        "the server's certificate is made in the state folder at first start"
    );
    if secure {
        // A second start keeps the certificate the clients trust.
        let first = std::fs::read(&cert).unwrap();
        let mut again = softplc(&project, &socket, &log);
        let deadline = Instant::now() + Duration::from_secs(30);
        while !std::fs::read_to_string(&log)
            .unwrap_or_default()
            .contains(&started)
        {
            assert!(Instant::now() < deadline, "no second start within 30 s");
            std::thread::sleep(Duration::from_millis(50));
        }
        // The child may have exited already; then there is nothing to stop.
        drop(again.kill());
        drop(again.wait());
        assert_eq!(
            std::fs::read(&cert).unwrap(),
            first,
            "the second start reuses the certificate"
        );
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    passed
}

#[test]
fn an_asyncua_client_browses_reads_subscribes_writes_and_is_refused_where_it_must_be() {
    let passed = run_client("full", true, "full", false);
    assert_eq!(passed.len(), 7, "every step passed: {passed:?}");
    assert_eq!(passed[1], "descriptions");
}

#[test]
fn on_basic256sha256_only_a_trusted_client_with_the_right_password_reads() {
    let passed = run_client("secure", false, "secure", false);
    assert_eq!(
        passed,
        ["none refused", "encrypted read", "wrong password refused"]
    );
}

#[test]
fn a_torn_server_key_is_kept_aside_a_new_pair_made_and_a_secure_client_reads() {
    let passed = run_client("torn", false, "secure", true);
    assert_eq!(
        passed,
        ["none refused", "encrypted read", "wrong password refused"]
    );
}

#[test]
fn with_writes_off_an_asyncua_client_cannot_write() {
    let passed = run_client("off", false, "writes-off", false);
    assert_eq!(passed, ["writes off"]);
}

fn check(text: &str) -> std::process::Output {
    let dir = scratch("check");
    let program = dir.join("p.expr");
    std::fs::write(&program, "flag = !flag\n").unwrap();
    let path = dir.join("p.yaml");
    std::fs::write(
        &path,
        format!(
            "project: c\nscan: {{ period: 50ms }}\nbuses:\n  - {{ name: line1, port: sim }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n\
             tags:\n  - {{ name: speed, type: u16, scada: write }}\n  - {{ name: flag, type: bool }}\n\
             program: {{ file: {}, kind: expr }}\nservice:\n  opcua:\n{text}",
            program.display()
        ),
    )
    .unwrap();
    let out = Command::new(BIN).arg("check").arg(&path).output().unwrap();
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    out
}

#[test]
fn check_refuses_a_server_beyond_loopback_without_security() {
    let out = check("    bind: 0.0.0.0\n    port: 4840\n");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains(
            "p.yaml:13:11: error: service.opcua: bind 0.0.0.0 reaches beyond loopback, where \
             SecurityPolicy None and anonymous access are not allowed: set security: \
             basic256sha256 (Sign & Encrypt) and username with password or password_env"
        ),
        "{err}"
    );
    // Security without a user is still refused beyond loopback, at the security key.
    let out = check("    bind: 192.0.2.7\n    security: basic256sha256\n");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("p.yaml:14:15: error: service.opcua: bind 192.0.2.7"),
        "{err}"
    );
    // A user on an endpoint without security would send its password in clear.
    let out = check("    username: op\n    password: x\n");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("p.yaml:13:15: error: service.opcua.username needs security"),
        "{err}"
    );
    // Basic256Sha256 with a user beyond loopback is accepted, and check says how to reach it.
    let out = check(
        "    bind: 0.0.0.0\n    port: 4841\n    security: basic256sha256\n    username: op\n    \
         password: secret\n    writes: true\n",
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains(
            ":4841/ (SecurityPolicy Basic256Sha256, Sign & Encrypt, user op with \
                       password): 2 tags, writes on (1 writable tags)"
        ),
        "{text}"
    );
    assert!(!text.contains("secret"), "{text}");
    // A limit outside its range, at its key.
    let out = check("    port: 4843\n    max_sessions: 0\n");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("p.yaml:14:19: error: service.opcua.max_sessions 0 is outside 1..=1000"),
        "{err}"
    );
    // On loopback, None and anonymous.
    let out = check("    port: 4842\n");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(
            "OPC UA server at opc.tcp://127.0.0.1:4842/ (SecurityPolicy None, anonymous): 2 tags, \
             writes off"
        ),
        "{text}"
    );
}

/// The server's certificate folder cannot be made (a file stands where it goes, as a
/// read-only or damaged state folder leaves it), in a project of two tasks: the PLC starts and
/// scans on both tasks; the OPC UA server is stopped and says why in the log, in `status
/// --json`, in the metrics and on the web page's overview, while the other services run.
#[test]
fn a_server_without_a_usable_certificate_folder_is_stopped_with_the_reason_and_the_plc_runs() {
    let dir = scratch("no-pki");
    let example = workspace().join("examples/two-tasks");
    for file in ["project.yaml", "press.ladder.yaml", "panel.ladder.yaml"] {
        std::fs::copy(example.join(file), dir.join(file)).unwrap();
    }
    let port = free_port();
    let mut yaml = std::fs::read_to_string(dir.join("project.yaml")).unwrap();
    yaml.push_str(&format!(
        "service:\n  opcua: {{ port: {port} }}\n  metrics: 127.0.0.1:0\n  web: {{ bind: 127.0.0.1:0 }}\n"
    ));
    let project = dir.join("project.yaml");
    std::fs::write(&project, yaml).unwrap();
    std::fs::write(dir.join("opcua-pki"), "in the way").unwrap();
    let socket = dir.join("control.sock");
    let log = dir.join("softplc.log");
    let mut plc = softplc(&project, &socket, &log);
    let metrics = host::log_value(&log, "metrics at http://");
    let web = host::log_value(&log, "web page: http://");
    let status = host::status_once_scanned(&socket, &[5, 2]);
    let reason = format!(
        "OPC UA server: cannot make its certificate folder {}: ",
        dir.join("opcua-pki").display()
    );
    let services = status["services"].as_array().unwrap();
    let state = |name: &str| {
        services
            .iter()
            .find(|s| s["service"] == name)
            .cloned()
            .unwrap_or_default()
    };
    assert_eq!(state("opcua")["state"], "stopped", "{status}");
    assert!(
        state("opcua")["reason"]
            .as_str()
            .is_some_and(|r| r.starts_with(&reason)),
        "{status}"
    );
    for running in ["web", "metrics", "trace", "audit", "alarms"] {
        assert_eq!(state(running)["state"], "running", "{status}");
    }
    let body = |addr: &str, path: &str| {
        use std::io::Read;
        let mut s = std::net::TcpStream::connect(addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        write!(
            s,
            "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let mut text = String::new();
        s.read_to_string(&mut text).unwrap();
        text
    };
    let scraped = body(&metrics, "/metrics");
    assert!(
        scraped.contains("softplc_service_state{service=\"opcua\",state=\"stopped\"} 1")
            && scraped.contains("softplc_service_state{service=\"opcua\",state=\"running\"} 0"),
        "{scraped}"
    );
    let page = body(&web, "/api/state");
    let json = page.split("\r\n\r\n").nth(1).unwrap_or_default();
    let page: serde_json::Value = serde_json::from_str(json).unwrap();
    let opcua = page["stats"]["services"]
        .as_array()
        .and_then(|s| s.iter().find(|s| s["service"] == "opcua"))
        .cloned()
        .unwrap_or_default();
    assert_eq!(opcua["state"], "stopped", "{page}");
    assert!(
        opcua["reason"]
            .as_str()
            .is_some_and(|r| r.starts_with(&reason)),
        "{page}"
    );
    // Still scanning, both tasks.
    let later = host::status_once_scanned(
        &socket,
        &[
            status["tasks"][0]["scans"].as_u64().unwrap() + 5,
            status["tasks"][1]["scans"].as_u64().unwrap() + 1,
        ],
    );
    assert!(later["tasks"][0]["scans"].as_u64() > status["tasks"][0]["scans"].as_u64());
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.lines()
            .any(|l| l.contains(&reason) && l.ends_with("; the PLC runs without it")),
        "{text}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}
