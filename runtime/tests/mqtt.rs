//! The MQTT Sparkplug B edge node against a real broker (Debian's `mosquitto`, started here on
//! 127.0.0.1 on a free port) and a third-party host application (Python paho-mqtt with the
//! protobuf generated from Eclipse Tahu's `sparkplug_b.proto`, `runtime/tests/mqtt/consumer.py`).
//!
//! The consumer drives the scenario: births (datatypes, aliases, bdSeq, seq, a tag's
//! `description` property), a DDATA after the
//! plant changes an input, a write applied, writes refused (read-only tag, forced tag), a
//! rebirth on command, a broker restart in the middle of the run (the scan keeps its cycles
//! while the broker is away), NDEATH with the matching bdSeq when softplc is killed, and a
//! clean stop. A broker that wants a password takes the
//! project's user and refuses a wrong password; TLS to a broker signed by the project's CA
//! connects, and by another CA is refused. `scripts/test` installs mosquitto and the
//! Python environment (`target/py-venv`, pinned in `runtime/tests/mqtt/requirements.txt`);
//! without them this test fails and says so.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::broker;
use crate::common::host;
use broker::{sparkplug_pb2, Broker};
use host::{free_port, lines_of, repo as workspace, wait_in_log};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

fn python() -> PathBuf {
    let py = workspace().join("target/py-venv/bin/python");
    assert!(
        py.exists(),
        "{} is missing: run scripts/test, which creates it (paho-mqtt, protobuf, grpcio-tools \
         from runtime/tests/mqtt/requirements.txt)",
        py.display()
    );
    py
}

fn project(dir: &Path, port: u16) -> PathBuf {
    let programs = workspace().join("programs");
    let text = format!(
        r#"project: mqtt_test
scan:
  period: 50ms
buses:
  - {{ name: line1, port: sim, baud: 57600, format: 8E1, response_timeout: 30ms, retries: 1 }}
modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
  - {{ name: mm2, bus: line1, model: minimod, address: 2 }}
tags:
  - {{ name: box_at_entry, point: mm1.X1 }}
  - {{ name: start,        point: mm1.X2, description: "Start button, green" }}
  - {{ name: stop,         point: mm1.X3 }}
  - {{ name: motor,        point: mm1.Y1, safe: false }}
  - {{ name: box_at_exit,  point: mm2.X1 }}
  - {{ name: lamp,         point: mm2.Y1, safe: false }}
  - {{ name: setpoint, type: u16, scada: write, description: "Belt speed, mm/s" }}
  - {{ name: limit, type: i32, initial: -40 }}
  - {{ name: gain, type: f32, initial: 1.5 }}
program:
  file: {}
  kind: expr
plant:
  model: conveyor
  wiring: {{ motor: mm1.Y1, start_button: mm1.X2, sensor_entry: mm1.X1, sensor_exit: mm2.X1 }}
service:
  mqtt:
    host: 127.0.0.1
    port: {port}
    group: plant1
    node: line1
    writes: true
    buffer: 1000
"#,
        programs.join("conveyor.expr").display()
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

fn softplc(project: &Path, socket: &Path, run_for: &str, log: &Path) -> Child {
    Command::new(BIN)
        .args(["run", "--quiet", "--for", run_for, "--socket"])
        .arg(socket)
        .arg(project)
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .unwrap()
}

#[test]
fn a_sparkplug_host_sees_births_data_commands_a_broker_restart_and_death() {
    let dir = tempfile_dir("host");
    let port = free_port();
    let mut broker = Broker::start(&dir, port);
    let pb2 = sparkplug_pb2(&python(), &dir);

    let project = project(&dir, port);
    let socket = dir.join("control.sock");
    let mut consumer = Command::new(python())
        .arg(workspace().join("runtime/tests/mqtt/consumer.py"))
        .arg(port.to_string())
        .args(["plant1", "line1"])
        .arg(&pb2)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut to_consumer = consumer.stdin.take().unwrap();
    let from_consumer = lines_of(consumer.stdout.take().unwrap());
    let mut plc: Option<Child> = None;
    let mut runs = 0;
    let mut passed = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(150);
    let log = |n: i32| dir.join(format!("softplc-{n}.log"));
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let Ok(line) = from_consumer.recv_timeout(left) else {
            // The child may have exited already; then there is nothing to stop.
            drop(consumer.kill());
            if let Some(mut p) = plc.take() {
                // The child may have exited already; then there is nothing to stop.
                drop(p.kill());
            }
            panic!(
                "the consumer stopped or timed out after {passed:?}; softplc's log:\n{}",
                std::fs::read_to_string(log(runs)).unwrap_or_default()
            );
        };
        eprintln!("consumer: {line}");
        if let Some(step) = line.strip_prefix("PASS ") {
            passed.push(step.to_string());
            continue;
        }
        if let Some(why) = line.strip_prefix("FAIL ") {
            if let Some(mut p) = plc.take() {
                // The child may have exited already; then there is nothing to stop.
                drop(p.kill());
            }
            panic!(
                "consumer: {why} (after {passed:?}); softplc's log:\n{}",
                std::fs::read_to_string(log(runs)).unwrap_or_default()
            );
        }
        if line == "DONE" {
            break;
        }
        let Some(action) = line.strip_prefix("NEED ") else {
            continue;
        };
        match action {
            "start" => {
                runs += 1;
                plc = Some(softplc(&project, &socket, "120s", &log(runs)));
            }
            "force setpoint 7" => {
                let out = Command::new(BIN)
                    .args(["force", "--socket"])
                    .arg(&socket)
                    .args(["setpoint", "7"])
                    .output()
                    .unwrap();
                assert!(out.status.success(), "force: {out:?}");
            }
            "restart broker" => broker.restart_after(|| scans_go_on(&socket)),
            "kill" => {
                let mut p = plc.take().expect("softplc runs");
                p.kill().unwrap();
                p.wait().unwrap();
            }
            "start short" => {
                runs += 1;
                plc = Some(softplc(
                    &project,
                    &dir.join("control2.sock"),
                    "3s",
                    &log(runs),
                ));
            }
            other => panic!("unknown action {other}"),
        }
        writeln!(to_consumer, "done").unwrap();
    }
    assert!(consumer.wait().unwrap().success());
    let mut last = plc.take().expect("the short run");
    let end = Instant::now() + Duration::from_secs(20);
    while last.try_wait().unwrap().is_none() {
        assert!(Instant::now() < end, "the short run did not stop");
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(last.wait().unwrap().success());

    // What the first run logged: the refusals, with the tag and why, and the reconnect.
    let first = std::fs::read_to_string(log(1)).unwrap();
    assert!(
        first.contains("write to limit refused: the tag is not writable (scada: write)"),
        "{first}"
    );
    assert!(
        first.contains("write to setpoint refused: setpoint is forced"),
        "{first}"
    );
    assert!(first.contains("connection to 127.0.0.1"), "{first}");
    assert_eq!(
        passed.len(),
        8,
        "every step of the consumer passed: {passed:?}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// `softplc status --json` of the run behind `socket`: (scans, overruns).
fn scan_counts(socket: &Path) -> (u64, u64) {
    let out = Command::new(BIN)
        .args(["status", "--json", "--socket"])
        .arg(socket)
        .output()
        .unwrap();
    assert!(out.status.success(), "status: {out:?}");
    let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let count = |key: &str| {
        status[key]
            .as_u64()
            .unwrap_or_else(|| panic!("{key} in {status}"))
    };
    (count("scans"), count("overruns"))
}

/// While the broker is away the scan keeps its cycles: 20 more scans (one second at 50 ms)
/// arrive, counted by the PLC itself, within a bound far above that second, so a loaded machine
/// cannot fail it but a scan that waited on the MQTT client (a blocking publish, a reconnect
/// in the scan thread) would. Overruns are counted alongside, for the log.
fn scans_go_on(socket: &Path) {
    let (scans, overruns) = scan_counts(socket);
    let end = Instant::now() + Duration::from_secs(15);
    loop {
        let (now, late) = scan_counts(socket);
        if now >= scans + 20 {
            eprintln!("broker away: scans {scans} -> {now}, overruns {overruns} -> {late}");
            return;
        }
        assert!(
            Instant::now() < end,
            "the scan stalled while the broker was away: scans {scans} -> {now}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A 2 s run of the test project with `mqtt_keys` added to its `mqtt:` section, named `case`
/// in `dir`; what it logged.
fn short_run(dir: &Path, port: u16, case: &str, mqtt_keys: &str) -> String {
    let text = std::fs::read_to_string(project(dir, port)).unwrap();
    let path = dir.join(format!("{case}.yaml"));
    let keys = format!("    buffer: 1000\n{mqtt_keys}");
    std::fs::write(&path, text.replace("    buffer: 1000\n", &keys)).unwrap();
    let log = dir.join(format!("{case}.log"));
    let mut plc = softplc(&path, &dir.join(format!("{case}.sock")), "2s", &log);
    let end = Instant::now() + Duration::from_secs(20);
    while plc.try_wait().unwrap().is_none() {
        assert!(Instant::now() < end, "softplc did not stop");
        std::thread::sleep(Duration::from_millis(50));
    }
    std::fs::read_to_string(&log).unwrap()
}

/// A fresh folder of this test.
/// A scratch folder of this test's own: tests run in parallel, and one that cleared a shared
/// folder would take another's files (its log) from under it.
fn tempfile_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-mqtt-{test}-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn check_names_each_bad_mqtt_setting_at_its_place() {
    let dir = std::env::temp_dir().join(format!("softplc-mqtt-check-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let program = workspace().join("programs/conveyor.expr");
    let path = dir.join("p.yaml");
    std::fs::write(
        &path,
        format!(
            r#"project: bad
scan: {{ period: 50ms }}
buses:
  - {{ name: line1, port: sim, baud: 19200, format: 8E1 }}
modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
tags:
  - {{ name: pump, point: mm1.Y1 }}
  - {{ name: speed, type: u16 }}
program: {{ file: {}, kind: expr }}
service:
  mqtt:
    host: 127.0.0.1
    port: 70000
    group: "plant/1"
    buffer: 0
    password: secret
    deadband: {{ pump: 1, nope: 2, speed: -1 }}
    tls: {{ ca_file: missing-ca.pem }}
"#,
            program.display()
        ),
    )
    .unwrap();
    let out = Command::new(BIN).arg("check").arg(&path).output().unwrap();
    assert!(!out.status.success());
    let text =
        String::from_utf8_lossy(&out.stderr).to_string() + &*String::from_utf8_lossy(&out.stdout);
    let f = path.display();
    for want in [
        format!("{f}:13:5: error: service.mqtt.node is required"),
        format!("{f}:14:11: error: service.mqtt.port 70000 is outside 1..=65535"),
        format!(
            "{f}:15:12: error: service.mqtt.group \"plant/1\" cannot be a Sparkplug id: it must \
             be non-empty, without '+', '/' or '#'"
        ),
        format!("{f}:16:13: error: service.mqtt.buffer 0 is outside 1..=1000000"),
        format!("{f}:17:15: error: service.mqtt: a password needs a username"),
        format!("{f}:18:17: error: service.mqtt.deadband: tag pump is a bool; a deadband needs a number"),
        format!("{f}:18:26: error: service.mqtt.deadband: no tag named nope"),
        format!("{f}:18:42: error: service.mqtt.deadband: speed: -1 is not a deadband (a number ≥ 0)"),
        format!(
            "{f}:19:21: error: service.mqtt.tls.ca_file {}: cannot read it: No such file or \
             directory (os error 2)",
            dir.join("missing-ca.pem").display()
        ),
    ] {
        assert!(text.contains(&want), "missing {want:?} in:\n{text}");
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// Runs `openssl` in `dir` (the certificates of the TLS test).
fn openssl(dir: &Path, args: &[&str]) {
    let out = Command::new("openssl")
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot run openssl ({e}): scripts/test installs it"));
    assert!(out.status.success(), "openssl {args:?}: {out:?}");
}

#[test]
fn tls_to_a_broker_signed_by_the_projects_ca_and_a_refusal_by_another_ca() {
    let dir = std::env::temp_dir().join(format!("softplc-mqtt-tls-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    for ca in ["ca", "other-ca"] {
        openssl(
            &dir,
            &[
                "req",
                "-x509",
                "-newkey",
                "rsa:2048",
                "-nodes",
                "-days",
                "2",
                "-subj",
                &format!("/CN={ca}"),
                "-keyout",
                &format!("{ca}.key"),
                "-out",
                &format!("{ca}.pem"),
            ],
        );
    }
    openssl(
        &dir,
        &[
            "req",
            "-newkey",
            "rsa:2048",
            "-nodes",
            "-subj",
            "/CN=127.0.0.1",
            "-keyout",
            "server.key",
            "-out",
            "server.csr",
        ],
    );
    std::fs::write(
        dir.join("ext"),
        "subjectAltName=IP:127.0.0.1\nbasicConstraints=CA:FALSE\nextendedKeyUsage=serverAuth\n",
    )
    .unwrap();
    openssl(
        &dir,
        &[
            "x509",
            "-req",
            "-in",
            "server.csr",
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-days",
            "2",
            "-extfile",
            "ext",
            "-out",
            "server.pem",
        ],
    );
    // mosquitto started as root reads its files as the user `mosquitto`: a key of this test only.
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(
        dir.join("server.key"),
        std::fs::Permissions::from_mode(0o644),
    )
    .unwrap();
    let port = free_port();
    let d = dir.display();
    let _broker = Broker::start_with(
        &dir,
        port,
        &format!("cafile {d}/ca.pem\ncertfile {d}/server.pem\nkeyfile {d}/server.key\n"),
    );
    for (ca, connects) in [("ca.pem", true), ("other-ca.pem", false)] {
        let text = short_run(
            &dir,
            port,
            &format!("tls-{ca}"),
            &format!("    tls: {{ ca_file: {ca} }}\n"),
        );
        assert_eq!(
            text.contains(&format!("MQTT: connected to 127.0.0.1:{port}")),
            connects,
            "{ca}: {text}"
        );
        assert_eq!(
            text.contains("MQTT: NDEATH (bdSeq 0) published"),
            connects,
            "{ca}: {text}"
        );
        assert!(text.contains("(TLS)"), "{text}");
        if !connects {
            assert!(
                text.contains(&format!("MQTT: cannot connect to 127.0.0.1:{port}: "))
                    && text.contains("UnknownIssuer"),
                "{text}"
            );
        }
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn a_broker_that_wants_a_password_takes_the_projects_user_and_refuses_a_wrong_password() {
    let dir = std::env::temp_dir().join(format!("softplc-mqtt-user-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    let passwords = dir.join("passwords");
    let out = Command::new("mosquitto_passwd")
        .args(["-b", "-c"])
        .arg(&passwords)
        .args(["plc", "right-pass"])
        .output()
        .expect("mosquitto_passwd (Debian's mosquitto) is installed by scripts/test");
    assert!(out.status.success(), "mosquitto_passwd: {out:?}");
    let port = free_port();
    let _broker = Broker::start_with(
        &dir,
        port,
        &format!("password_file {}\n", passwords.display()),
    );
    for (case, password, connects) in [
        ("right", "right-pass", true),
        ("wrong", "wrong-pass", false),
    ] {
        let text = short_run(
            &dir,
            port,
            &format!("user-{case}"),
            &format!("    username: plc\n    password: {password}\n"),
        );
        assert_eq!(
            text.contains("MQTT: NBIRTH (bdSeq 0)"),
            connects,
            "{case} password: {text}"
        );
        if !connects {
            assert!(
                text.contains(&format!("MQTT: cannot connect to 127.0.0.1:{port}: ")),
                "{text}"
            );
        }
        assert!(
            !text.contains(password),
            "the log shows no password: {text}"
        );
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

use crate::common::sim;

#[test]
fn a_flood_of_bad_commands_is_summarized_and_a_module_loss_still_logged() {
    let (mut sim, pty) = sim::Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = tempfile_dir("flood");
    let port = free_port();
    let _broker = Broker::start(&dir, port);
    std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
    let project = dir.join("project.yaml");
    std::fs::write(
        &project,
        format!(
            "project: flood\n\
             scan: {{ period: 50ms }}\n\
             buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1, settings: {{ events: false }} }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2, settings: {{ events: false }} }}\n\
             tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: lamp, point: mm2.Y1, safe: false }}\n\
             program: {{ file: follow.expr, kind: expr }}\n\
             service:\n  mqtt: {{ host: 127.0.0.1, port: {port}, group: plant1, node: line1 }}\n"
        ),
    )
    .unwrap();
    let log = dir.join("softplc.log");
    let mut plc = softplc(&project, &dir.join("ctl.sock"), "60s", &log);
    wait_in_log(&log, "MQTT: connected", Duration::from_secs(30));
    sim.send("set minimod@1.X1 1");
    assert!(
        sim.wait_for("minimod@2.Y1", "1", Duration::from_secs(10))
            .is_some(),
        "the PLC runs and drives mm2"
    );
    // 20,000 commands that are not Sparkplug payloads, as fast as the broker takes them, and
    // the line dies meanwhile.
    let mut flood = Command::new("mosquitto_pub")
        .args(["-h", "127.0.0.1", "-p", &port.to_string()])
        .args(["-t", "spBv1.0/plant1/NCMD/line1", "-l"])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("mosquitto_pub (Debian's mosquitto-clients)");
    let mut input = flood.stdin.take().unwrap();
    for i in 0..20_000 {
        if i == 10_000 {
            sim.send("line dead");
        }
        writeln!(input, "not a sparkplug payload {i}").unwrap();
    }
    drop(input);
    assert!(flood.wait().unwrap().success());
    let lost = wait_in_log(&log, "module mm1 lost", Duration::from_secs(10));
    let summary = wait_in_log(&log, "MQTT: ignored commands: … ", Duration::from_secs(15));
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    let text = std::fs::read_to_string(&log).unwrap();
    let lines = text
        .lines()
        .filter(|l| l.contains("MQTT: command ignored"))
        .count();
    assert!(
        (1..=10).contains(&lines),
        "{lines} lines of ignored commands"
    );
    assert!(
        summary.ends_with(" more in the last 10 s (on spBv1.0/plant1/NCMD/line1)"),
        "{summary}"
    );
    let held_back = crate::common::host::held_back(&summary);
    assert!(held_back >= 10_000, "{held_back} held back: {summary}");
    assert!(!lost.is_empty());
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// A Sparkplug host (`runtime/tests/mqtt/alarms_consumer.py`) sees each alarm as node metrics
/// under `Alarms/` in NBIRTH, then the raise and the acknowledgement in NDATA by alias.
#[test]
fn a_sparkplug_host_sees_the_alarms_as_node_metrics() {
    let dir = tempfile_dir("alarms");
    let port = free_port();
    let _broker = Broker::start(&dir, port);
    let pb2 = sparkplug_pb2(&python(), &dir);
    let project = crate::common::alarm_project::jam_project(
        &dir,
        "mqtt_alarms",
        &format!("mqtt: {{ host: 127.0.0.1, port: {port}, group: plant1, node: line9 }}"),
    );
    let socket = dir.join("control.sock");
    let mut consumer = Command::new(python())
        .arg(workspace().join("runtime/tests/mqtt/alarms_consumer.py"))
        .arg(port.to_string())
        .args(["plant1", "line9"])
        .arg(&pb2)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut to_consumer = consumer.stdin.take().unwrap();
    let from_consumer = lines_of(consumer.stdout.take().unwrap());
    let log = dir.join("softplc.log");
    let mut plc: Option<Child> = None;
    let mut passed = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(60);
    let ctl = |args: &[&str]| {
        let out = Command::new(BIN)
            .args(args)
            .arg("--socket")
            .arg(&socket)
            .output()
            .unwrap();
        assert!(out.status.success(), "{args:?}: {out:?}");
    };
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let line = from_consumer.recv_timeout(left).unwrap_or_else(|_| {
            // The child may have exited already; then there is nothing to stop.
            drop(consumer.kill());
            "FAIL the consumer stopped or timed out".into()
        });
        if let Some(step) = line.strip_prefix("PASS ") {
            passed.push(step.to_string());
            continue;
        }
        if let Some(why) = line.strip_prefix("FAIL ") {
            if let Some(mut p) = plc.take() {
                // The child may have exited already; then there is nothing to stop.
                drop(p.kill());
            }
            panic!(
                "consumer: {why} (after {passed:?}); softplc's log:\n{}",
                std::fs::read_to_string(&log).unwrap_or_default()
            );
        }
        if line == "DONE" {
            break;
        }
        match line.strip_prefix("NEED ") {
            Some("start") => plc = Some(softplc(&project, &socket, "60s", &log)),
            Some("raise") => ctl(&["write", "jam", "1"]),
            Some("ack") => ctl(&["alarms", "ack", "jam"]),
            _ => continue,
        }
        writeln!(to_consumer, "done").unwrap();
    }
    assert!(consumer.wait().unwrap().success());
    assert_eq!(passed, ["birth", "raised", "acknowledged"]);
    if let Some(mut p) = plc.take() {
        // The child may have exited already; then there is nothing to stop.
        drop(p.kill());
        drop(p.wait());
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
