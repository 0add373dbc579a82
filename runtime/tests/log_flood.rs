//! A flood does not drown the log. Three floods, each while the line of two MiniMods dies:
//! 16 clients hold every slot of the Modbus TCP server while another peer reconnects as fast
//! as it can, each connection refused; the retained values' folder on a full disk, every save
//! failing; a peer opening OPC UA connections without pause (lines the OPC UA library writes).
//! The log has a few lines of each, then one summary per site and cause counting what was held
//! back (naming the peer where there is one), and the modules' loss, as it came. (The MQTT
//! command flood is in `mqtt.rs`.)

use std::io::Read;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::host;
use crate::common::sim;

use host::wait_in_log;
use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

/// A project of two MiniMods on `pty` (mm1.X1 `button` copied to mm2.Y1 `lamp` every 50 ms
/// cycle by the program `program`, a file of `dir`), with `more` appended (more tags, the
/// services), written into `dir`; its path.
fn flood_project(dir: &Path, pty: &str, program: (&str, &str), more: &str) -> PathBuf {
    let (file, text) = program;
    std::fs::write(dir.join(file), text).unwrap();
    let kind = file.rsplit('.').next().unwrap();
    let project = format!(
        "project: flood\n\
         scan: {{ period: 50ms }}\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1, settings: {{ events: false }} }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2, settings: {{ events: false }} }}\n\
         program: {{ file: {file}, kind: {kind} }}\n\
         tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: lamp, point: mm2.Y1, safe: false }}\n\
         {more}"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
    path
}

/// Waits until the PLC copies mm1.X1 to mm2.Y1 on the simulated modules.
fn the_plc_drives_the_modules(sim: &mut Sim) {
    sim.send("set minimod@1.X1 1");
    assert!(
        sim.wait_for("minimod@2.Y1", "1", Duration::from_secs(10))
            .is_some(),
        "the PLC runs and drives mm2"
    );
}

#[test]
fn a_flood_of_refused_connections_is_summarized_and_a_module_loss_still_logged() {
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = host::scratch_dir("log-flood", "refused");
    let path = flood_project(
        &dir,
        &pty,
        ("follow.expr", "lamp = button\n"),
        "service:\n  modbus_tcp: { bind: 127.0.0.1:0 }\n",
    );
    let log = dir.join("log");
    let mut plc = Command::new(BIN)
        .args(["run", "--quiet", "--no-control", "--for", "40s"])
        .arg(&path)
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let started = wait_in_log(&log, "Modbus TCP server on ", Duration::from_secs(30));
    let addr = started
        .split("Modbus TCP server on ")
        .nth(1)
        .and_then(|r| r.split(',').next())
        .unwrap()
        .to_owned();
    the_plc_drives_the_modules(&mut sim);

    // Every slot taken (the server's cap is 16), then a peer that reconnects without pause.
    let held: Vec<TcpStream> = (0..16)
        .map(|_| TcpStream::connect(&addr).unwrap())
        .collect();
    std::thread::sleep(Duration::from_millis(300));
    let mut refused = 0u64;
    let flood_start = Instant::now();
    let mut line_dead = false;
    while flood_start.elapsed() < Duration::from_secs(5) {
        if !line_dead && flood_start.elapsed() > Duration::from_secs(1) {
            sim.send("line dead");
            line_dead = true;
        }
        let Ok(mut s) = TcpStream::connect(&addr) else {
            continue;
        };
        // A refused connection is closed by the server at once: the read sees its end.
        s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        let mut byte = [0u8; 1];
        if matches!(s.read(&mut byte), Ok(0) | Err(_)) {
            refused += 1;
        }
    }
    let lost = wait_in_log(&log, "module mm1 lost", Duration::from_secs(10));
    // The summary of the window the flood started comes within its 10 s and a second.
    let summary = wait_in_log(
        &log,
        "Modbus TCP: refused connections: … ",
        Duration::from_secs(15),
    );
    drop(held);
    drop(plc.kill());
    drop(plc.wait());
    let text = std::fs::read_to_string(&log).unwrap();
    let lines = text
        .lines()
        .filter(|l| l.contains("refused: 16 clients connected"))
        .count() as u64;
    assert!(refused >= 200, "only {refused} refused connections in 5 s");
    // Five a window, and the flood spans at most two windows.
    assert!((1..=10).contains(&lines), "{lines} refusal lines:\n{text}");
    let held_back = host::held_back(&summary);
    assert!(
        summary.ends_with(" more in the last 10 s (from 127.0.0.1)"),
        "{summary}"
    );
    assert!(
        held_back + lines <= refused && held_back >= refused / 2,
        "{held_back} held back of {refused}: {summary}"
    );
    assert!(!lost.is_empty());
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// The retained values' folder on a full disk: every save fails (every 100 ms), and meanwhile
/// the line of two MiniMods dies. The log has a few of the failed saves, then one summary
/// counting what was held back, and the modules' loss, as it came; `status` says the retained
/// values are degraded and why, and once there is room again that they are saved again. The
/// disk is a real tmpfs filled to the last block (under `unshare -rm`) where the machine
/// allows it, else a file standing where the folder goes, so the case never goes untested.
#[test]
fn retain_saves_failing_on_a_full_disk_are_summarized_and_a_module_loss_still_logged() {
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = host::scratch_dir("log-flood", "retain");
    flood_project(
        &dir,
        &pty,
        ("follow.rhai", "lamp = button;\ncount += 1;\n"),
        "  - { name: count, type: i32, retain: true }\n\
         retain: { file: disk/count.json, period: 100ms }\n",
    );
    let (d, log, socket) = (dir.display(), dir.join("log"), dir.join("ctl.sock"));
    let tmpfs = host::tmpfs_allowed();
    let run = format!(
        "{BIN} run {d}/project.yaml --quiet --socket {d}/ctl.sock --for 30s >/dev/null 2>{d}/log"
    );
    let mut plc = if tmpfs {
        // The run, the filler and the room made again all inside the namespace, where the
        // tmpfs is; the test says when to make room by creating `free`.
        std::fs::create_dir_all(dir.join("disk")).unwrap();
        let script = format!(
            "set -e
mount -t tmpfs -o size=64k tmpfs {d}/disk
dd if=/dev/zero of={d}/disk/filler bs=4k 2>/dev/null || true
{run} &
pid=$!
while [ ! -e {d}/free ]; do sleep 0.1; done
rm {d}/disk/filler
wait $pid
cp {d}/disk/count.json {d}/saved.json"
        );
        Command::new("unshare")
            .args(["-rm", "sh", "-c", &script])
            .spawn()
            .unwrap()
    } else {
        eprintln!(
            "no tmpfs in a mount namespace on this machine: a file stands where the folder goes"
        );
        std::fs::write(dir.join("disk"), "in the way").unwrap();
        Command::new("sh").args(["-c", &run]).spawn().unwrap()
    };
    let retain_state = || host::service_state(&socket, "retain");
    wait_in_log(&log, "retain: cannot save", Duration::from_secs(30));
    sim.send("set minimod@1.X1 1");
    assert!(
        sim.wait_for("minimod@2.Y1", "1", Duration::from_secs(10))
            .is_some(),
        "the PLC runs and drives mm2 while its saves fail"
    );
    sim.send("line dead");
    let lost = wait_in_log(&log, "module mm1 lost", Duration::from_secs(10));
    let failing = retain_state();
    assert_eq!(failing["state"], "degraded", "{failing}");
    let reason = failing["reason"].as_str().unwrap_or_default().to_owned();
    assert!(reason.starts_with("cannot save: "), "{failing}");
    if tmpfs {
        assert!(reason.contains("No space left on device"), "{failing}");
    }
    // The window the flood started in ends within 10 s, and its summary is written within
    // a second of that.
    let summary = wait_in_log(&log, "retain: failed saves: … ", Duration::from_secs(15));
    // Room again: the saves go through, and say so.
    if tmpfs {
        std::fs::write(dir.join("free"), "").unwrap();
    } else {
        std::fs::remove_file(dir.join("disk")).unwrap();
        std::fs::create_dir_all(dir.join("disk")).unwrap();
    }
    let begin = Instant::now();
    while retain_state()["state"] != "running" {
        assert!(
            begin.elapsed() < Duration::from_secs(5),
            "retain never recovered"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    sim.send("line alive");
    assert!(plc.wait().unwrap().success());
    let text = std::fs::read_to_string(&log).unwrap();
    let failed: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("retain: cannot save"))
        .collect();
    // Five a window; the flood spans at most two windows.
    assert!((5..=10).contains(&failed.len()), "{text}");
    let held_back = host::held_back(&summary);
    // A save every 100 ms for the window's 10 s, five of them written.
    assert!(held_back >= 40, "{summary}");
    assert!(summary.contains(" more in the last 10 s ("), "{summary}");
    // The loss is in the log between the flood's first line and the saves going through.
    let at = |line: &str| text.lines().position(|l| l == line).unwrap();
    let again = text
        .lines()
        .position(|l| l.contains("retain: saving to "))
        .unwrap_or_else(|| panic!("no recovery line:\n{text}"));
    assert!(at(failed[0]) < at(&lost) && at(&lost) < again, "{text}");
    let saved = if tmpfs {
        dir.join("saved.json")
    } else {
        dir.join("disk/count.json")
    };
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(saved).unwrap()).unwrap();
    assert!(
        saved["values"]["count"].as_i64().is_some_and(|n| n > 0),
        "{saved}"
    );
    eprintln!(
        "retain flood ({}): {} lines of failed saves, then {summary:?}; {} log lines in all",
        if tmpfs {
            "a full tmpfs"
        } else {
            "a file in the way"
        },
        failed.len(),
        text.lines().count()
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// A peer that opens OPC UA connections without pause and sends garbage: async-opcua logs
/// three lines for each (accepted, failed, terminated); each of its sites passes five lines
/// per peer every 10 s and counts the rest, so the log keeps the modules' loss on a line
/// killed during the flood.
#[test]
fn a_flood_of_opcua_connections_is_summarized_and_a_module_loss_still_logged() {
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = host::scratch_dir("log-flood", "opcua");
    let port = host::free_port();
    let path = flood_project(
        &dir,
        &pty,
        ("follow.expr", "lamp = button\n"),
        &format!("service:\n  opcua: {{ port: {port} }}\n"),
    );
    let log = dir.join("log");
    let mut plc = Command::new(BIN)
        .args(["run", "--quiet", "--no-control", "--for", "40s"])
        .arg(&path)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    wait_in_log(&log, "OPC UA server at ", Duration::from_secs(30));
    the_plc_drives_the_modules(&mut sim);
    let before = std::fs::read_to_string(&log).unwrap().lines().count();
    let addr = format!("127.0.0.1:{port}");
    let mut opened = 0u64;
    let flood_start = Instant::now();
    let mut line_dead = false;
    while flood_start.elapsed() < Duration::from_secs(4) {
        if !line_dead && flood_start.elapsed() > Duration::from_secs(1) {
            sim.send("line dead");
            line_dead = true;
        }
        if let Ok(mut s) = TcpStream::connect(&addr) {
            use std::io::Write;
            drop(s.write_all(b"HELxxxx not a hello"));
            opened += 1;
        }
    }
    let lost = wait_in_log(&log, "module mm1 lost", Duration::from_secs(10));
    // The summaries of the window the flood started come within its 10 s and a second.
    let summary = wait_in_log(&log, ", from 127.0.0.1)", Duration::from_secs(15));
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    let text = std::fs::read_to_string(&log).unwrap();
    let flood_lines = text.lines().count() - before;
    eprintln!(
        "OPC UA flood: {opened} connections in 4 s, {flood_lines} log lines from then on; \
         {summary:?}"
    );
    assert!(opened >= 200, "only {opened} connections in 4 s");
    // Three sites, five lines each a window (the flood spans at most two), their summaries,
    // the loss and what else the run logs: far fewer than three lines a connection.
    assert!(flood_lines <= 60, "{flood_lines} lines:\n{text}");
    assert!(
        summary.contains(" more in the last 10 s (at ") && !summary.contains("… 0 more"),
        "{summary}"
    );
    assert!(!lost.is_empty());
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}
