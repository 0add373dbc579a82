//! The issue an operator met first, end to end on the real binary and the real clock: the
//! quick start's scan settings (period 100 ms, task watchdog 500 ms × 3) with
//! `response_timeout: 100ms, retries: 1` and two MiniMods served by `softplc sim` on a pty.
//! The line dies for two seconds while the PLC runs: the PLC must keep running (no task
//! watchdog fault), lose the modules, get them back, and end on request with exit 0.

use std::process::{Command, Stdio};
use std::time::Duration;

use crate::common::sim;

use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

#[test]
fn a_dead_line_does_not_stop_the_plc_and_its_modules_come_back() {
    let (mut sim, pty) = Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = std::env::temp_dir().join(format!("softplc-dead-line-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
    // Polled, pinned: a dead line is seen at the next cycle's polls (in event mode, the default
    // for these modules, an idle Collect round is silence either way: only at the refresh).
    let project = format!(
        "project: deadline\n\
         scan: {{ period: 100ms, watchdog: {{ time: 500ms, sensitivity: 3 }} }}\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 100ms, retries: 1 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1, settings: {{ events: false }} }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2, settings: {{ events: false }} }}\n\
         tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: lamp, point: mm2.Y1, safe: false }}\n\
         program: {{ file: follow.expr, kind: expr }}\n"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
    let plc = Command::new(BIN)
        .args(["run", "--quiet", "--no-socket", "--for", "12s"])
        .arg(&path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();

    sim.send("set minimod@1.X1 1");
    assert!(
        sim.wait_for("minimod@2.Y1", "1", Duration::from_secs(10))
            .is_some(),
        "the PLC runs and drives mm2"
    );
    sim.send("line dead");
    sim.send("set minimod@1.X1 0");
    std::thread::sleep(Duration::from_secs(2));
    sim.send("line alive");
    let back = sim.wait_for("minimod@2.Y1", "0", Duration::from_secs(8));

    let out = plc.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "exit {:?}\nstdout:\n{stdout}\nstderr:\n{stderr}",
        out.status
    );
    assert!(
        !stderr.contains("FAULT") && !stdout.contains("FAULT"),
        "{stderr}{stdout}"
    );
    assert!(stderr.contains("module mm1 lost"), "{stderr}");
    assert!(stderr.contains("module mm1 is back"), "{stderr}");
    assert!(
        back.is_some(),
        "the output follows the program again once the line is back:\n{stderr}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}
