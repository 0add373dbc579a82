//! A serial port that is not there when the PLC starts (a USB adapter that enumerates late at
//! boot) is a lost line, not a failed start: the PLC runs, the line's modules are lost and their
//! tags bad, the port is tried with the bus owner's backoff, and it is taken when it appears.
//! Here the port is a link to a pty served by `softplc sim`, made two seconds after the start.

use std::process::{Command, Stdio};
use std::time::Duration;

use crate::common::host::scratch_dir;
use crate::common::sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

#[test]
fn a_serial_port_that_appears_after_the_start_is_taken_and_its_module_counted_good() {
    let dir = scratch_dir("late-port", "appears");
    let (_sim, pty) = Sim::start(BIN, &["minimod@1"]);
    let late = dir.join("ttyLATE");
    std::fs::write(dir.join("p.expr"), "y1 = x1\n").unwrap();
    std::fs::write(
        dir.join("project.yaml"),
        format!(
            "project: late\nscan: {{ period: 50ms }}\nbuses:\n  - {{ name: line1, port: {}, \
             response_timeout: 50ms }}\nmodules:\n  - {{ name: mm1, bus: line1, model: minimod, \
             address: 1 }}\ntags:\n  - {{ name: x1, point: mm1.X1 }}\n  - {{ name: y1, point: \
             mm1.Y1, safe: false }}\nprogram: {{ file: p.expr, kind: expr }}\n",
            late.display()
        ),
    )
    .unwrap();
    let plc = Command::new(BIN)
        .args(["run", "--no-control", "--for", "15s"])
        .arg(dir.join("project.yaml"))
        .env("SOFTPLC_LOG", "info")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(2));
    std::os::unix::fs::symlink(&pty, &late).unwrap();
    let out = plc.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}{stderr}");
    // Said once, with its cause once.
    let said = format!(
        "line line1: cannot open {}: No such file or directory; its modules are lost until the \
         port opens",
        late.display()
    );
    assert_eq!(stderr.matches(&said).count(), 1, "{stderr}");
    assert_eq!(
        stderr.matches("No such file or directory").count(),
        1,
        "{stderr}"
    );
    assert!(
        stderr.contains("line line1: port reopened after"),
        "{stderr}"
    );
    assert!(
        stderr.contains("line line1: module mm1 is back after"),
        "{stderr}"
    );
    assert!(stdout.contains("module mm1 (line1): good"), "{stdout}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn a_port_that_never_appears_leaves_the_plc_running_with_its_tags_bad() {
    let dir = scratch_dir("late-port", "never");
    std::fs::write(dir.join("p.expr"), "y1 = x1\n").unwrap();
    std::fs::write(
        dir.join("project.yaml"),
        "project: never\nscan: { period: 50ms }\nbuses:\n  - { name: line1, port: \
         /dev/ttyUSB-softplc-absent }\nmodules:\n  - { name: mm1, bus: line1, model: minimod, \
         address: 1 }\ntags:\n  - { name: x1, point: mm1.X1 }\n  - { name: y1, point: mm1.Y1, \
         safe: false }\nprogram: { file: p.expr, kind: expr }\n",
    )
    .unwrap();
    let out = Command::new(BIN)
        .args(["run", "--no-control", "--for", "3s"])
        .arg(dir.join("project.yaml"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The run ends at its time, not at the missing port; the module is bad, said once.
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("stopped after its run time"), "{stdout}");
    assert!(stdout.contains("module mm1 (line1): bad"), "{stdout}");
    assert_eq!(
        stderr
            .matches("cannot open /dev/ttyUSB-softplc-absent: No such file or directory")
            .count(),
        1,
        "{stderr}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
