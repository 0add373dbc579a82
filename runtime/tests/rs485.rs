//! Kernel RS-485 mode on a port that has none: `softplc run` on a pty served by
//! `softplc sim` with `rs485:` on the bus must refuse to start, naming the bus, the port and
//! the setting (a pty, like most USB adapters, answers the RS-485 ioctl with ENOTTY).

use std::process::Command;

use crate::common::sim;

use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

#[test]
fn run_refuses_rs485_mode_on_a_pty_by_name() {
    let (_sim, pty) = Sim::start(BIN, &["minimod@1"]);
    let dir = std::env::temp_dir().join(format!("softplc-rs485-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
    let project = format!(
        "project: rs485\n\
         scan: {{ period: 100ms }}\n\
         buses:\n  - {{ name: line1, port: {pty}, rs485: {{ rts_on_send: true, delay_before_send: 0ms, delay_after_send: 0ms }} }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n\
         tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: lamp, point: mm1.Y1, safe: false }}\n\
         program: {{ file: follow.expr, kind: expr }}\n"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
    let out = Command::new(BIN)
        .args(["run", "--quiet", "--no-socket", "--for", "5s"])
        .arg(&path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "started anyway:\n{stderr}");
    let want = format!(
        "bus line1: {pty} does not support kernel RS-485 mode (rs485.rts_on_send): Inappropriate ioctl for device"
    );
    assert!(stderr.contains(&want), "want {want:?} in:\n{stderr}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn check_refuses_rs485_on_a_sim_bus_and_a_long_delay_with_positions() {
    let dir = std::env::temp_dir().join(format!("softplc-rs485-check-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
    let project = "project: rs485\n\
         scan: { period: 100ms }\n\
         buses:\n  - name: line1\n    port: sim\n    rs485: { rts_on_send: false }\n  - name: line2\n    port: /dev/ttyS9\n    rs485: { delay_after_send: 150ms }\n\
         modules:\n  - { name: mm1, bus: line1, model: minimod, address: 1 }\n\
         tags:\n  - { name: button, point: mm1.X1 }\n  - { name: lamp, point: mm1.Y1, safe: false }\n\
         program: { file: follow.expr, kind: expr }\n";
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
    let out = Command::new(BIN).arg("check").arg(&path).output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!out.status.success(), "{text}");
    assert!(text.contains("project.yaml:6:12"), "{text}");
    assert!(text.contains("not port: sim"), "{text}");
    assert!(text.contains("project.yaml:9:32"), "{text}");
    assert!(
        text.contains("rs485.delay_after_send must be whole milliseconds"),
        "{text}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
