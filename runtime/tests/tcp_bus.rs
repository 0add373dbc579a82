//! A project on `port: tcp://…` against `softplc sim --tcp 127.0.0.1:0`: the simulator prints
//! the address it bound, `check` prints the bus as Modbus TCP with its budget, and `run`
//! drives the seed modules behind it (an input set on the simulator reaches an output through
//! the program). Loopback, a free port, bounded in time.

use std::io::Write;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

/// `softplc sim --tcp 127.0.0.1:0 …`: the child, its stdin, its stdout lines.
fn sim(args: &[&str]) -> (Child, ChildStdin, Receiver<String>) {
    crate::common::host::spawn_piped(Command::new(BIN).arg("sim").args(args))
}

fn line_with(rx: &Receiver<String>, needle: &str, within: Duration) -> Option<String> {
    let end = Instant::now() + within;
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(l) if l.contains(needle) => return Some(l),
            Ok(_) => {}
            Err(_) => return None,
        }
    }
    None
}

#[test]
fn a_project_runs_seed_modules_behind_a_simulated_modbus_tcp_gateway() {
    let (mut child, mut stdin, rx) = sim(&["--tcp", "127.0.0.1:0", "minimod@1", "resi-16di8ro@2"]);
    let first = line_with(&rx, "serving", Duration::from_secs(10)).expect("sim prints its address");
    let url = first
        .split_whitespace()
        .find(|w| w.starts_with("tcp://127.0.0.1:"))
        .unwrap_or_else(|| panic!("{first}"))
        .to_string();
    assert!(
        first.starts_with(&format!(
            "serving minimod@1, resi-16di8ro@2 on {url} (a Modbus TCP gateway"
        )),
        "{first}"
    );

    let dir = std::env::temp_dir().join(format!("softplc-tcp-bus-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("prog.expr"), "y1 = x1\nro1 = di1\n").unwrap();
    std::fs::write(
        dir.join("project.yaml"),
        format!(
            "project: tcp-bus
scan:
  period: 50ms
buses:
  - {{ name: gw, port: \"{url}\", response_timeout: 300ms }}
modules:
  - {{ name: mm1, bus: gw, model: minimod, address: 1 }}
  - {{ name: r2, bus: gw, model: resi-16di8ro, address: 2 }}
tags:
  - {{ name: x1, point: mm1.X1 }}
  - {{ name: y1, point: mm1.Y1, safe: false }}
  - {{ name: di1, point: r2.DI1 }}
  - {{ name: ro1, point: r2.RO1, safe: false }}
program: {{ file: prog.expr, kind: expr }}
"
        ),
    )
    .unwrap();

    let check = Command::new(BIN)
        .arg("check")
        .arg(dir.join("project.yaml"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&check.stdout);
    assert!(check.status.success(), "{text}");
    assert!(
        text.contains(&format!(
            "bus gw: {url} (Modbus TCP: one connection, shared by 2 unit id(s)), response \
             timeout 300.00ms, retries 1\n"
        )),
        "{text}"
    );
    assert!(
        text.contains("  budget: inputs 2 transaction(s), full output write 2; no wire-time floor"),
        "{text}"
    );
    assert!(
        text.contains("module watchdog: not armed: a MiniMod's watchdog is armed by name"),
        "{text}"
    );

    let mut run = Command::new(BIN)
        .args(["run", "--quiet", "--for", "20s", "--socket"])
        .arg(dir.join("ctl.sock"))
        .arg(dir.join("project.yaml"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    writeln!(stdin, "set minimod@1.X1 1").unwrap();
    writeln!(stdin, "set resi-16di8ro@2.DI1 1").unwrap();
    // The program copies each input to an output: ask the simulator until both are on.
    let end = Instant::now() + Duration::from_secs(15);
    let (mut y1, mut ro1) = (false, false);
    while Instant::now() < end && !(y1 && ro1) {
        writeln!(stdin, "get minimod@1.Y1").unwrap();
        writeln!(stdin, "get resi-16di8ro@2.RO1").unwrap();
        y1 |= line_with(&rx, "minimod@1.Y1=", Duration::from_secs(2))
            .is_some_and(|l| l.ends_with("=1") || l.ends_with("=true"));
        ro1 |= line_with(&rx, "resi-16di8ro@2.RO1=", Duration::from_secs(2))
            .is_some_and(|l| l.ends_with("=1") || l.ends_with("=true"));
        std::thread::sleep(Duration::from_millis(200));
    }
    drop(run.kill());
    drop(run.wait());
    writeln!(stdin, "quit").unwrap();
    drop(child.wait());
    assert!(y1 && ro1, "outputs through the gateway: Y1 {y1}, RO1 {ro1}");
}
