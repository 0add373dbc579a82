//! A flood does not drown the log: 16 clients hold every slot of the Modbus TCP server while
//! another peer reconnects as fast as it can, each connection refused, and meanwhile the line
//! of two MiniMods dies. The log has a few of the refusals, then one summary naming the peer
//! and counting what was held back, and the modules' loss, as it came.

use std::io::Read;
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::host;
use crate::common::sim;

use host::wait_in_log;
use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

#[test]
fn a_flood_of_refused_connections_is_summarized_and_a_module_loss_still_logged() {
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = crate::common::host::scratch_dir("log-flood", "refused");
    std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
    let project = format!(
        "project: flood\n\
         scan: {{ period: 50ms }}\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1, settings: {{ events: false }} }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2, settings: {{ events: false }} }}\n\
         tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: lamp, point: mm2.Y1, safe: false }}\n\
         program: {{ file: follow.expr, kind: expr }}\n\
         service:\n  modbus_tcp: {{ bind: 127.0.0.1:0 }}\n"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
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
    sim.send("set minimod@1.X1 1");
    assert!(
        sim.wait_for("minimod@2.Y1", "1", Duration::from_secs(10))
            .is_some(),
        "the PLC runs and drives mm2"
    );

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
    let held_back: u64 = summary
        .split("… ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .map(|n| n.replace(',', "").parse().unwrap())
        .unwrap();
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
