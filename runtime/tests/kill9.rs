//! `kill -9` of a running PLC: the modules' own watchdogs, armed from the project file, take
//! the outputs to their safe mask with no help from the dead process. Simulated MiniMods are
//! served on a pty by `softplc sim`, exactly as a real line would be: one that keeps WDTTIME /
//! WDTYMASK where the manual's register table says, and one that follows its coil/register
//! aliasing rule (`--option minimod@1:watchdog-registers=aliased`).

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::sim;

use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

#[test]
fn kill_9_leaves_the_outputs_to_the_module_watchdog() {
    kill_9_with(&[], "table");
}

#[test]
fn kill_9_leaves_the_outputs_to_the_module_watchdog_under_the_aliasing_reading() {
    kill_9_with(
        &["--option", "minimod@1:watchdog-registers=aliased"],
        "aliased",
    );
}

/// A PLC on `softplc sim … minimod@1 SIM_ARGS` is killed; the module must take Y1 off by
/// itself. `case` names the run (its project folder).
fn kill_9_with(sim_args: &[&str], case: &str) {
    let mut args = vec!["minimod@1"];
    args.extend_from_slice(sim_args);
    let (mut sim, pty) = Sim::start(BIN, &args);
    sim.send("minimod@1 options");
    let options = sim.wait_line("watchdog-registers", Duration::from_secs(10));
    assert!(
        options.is_some_and(|l| l.starts_with(&format!("watchdog-registers {case}:"))),
        "the simulator serves the {case} reading"
    );
    let dir = std::env::temp_dir().join(format!("softplc-kill9-{}-{case}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("run.expr"),
        "# run the motor whenever the PLC is alive\nmotor = 1\n",
    )
    .unwrap();
    let project = format!(
        "project: kill9\n\
         scan: {{ period: 50ms }}\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 200ms }}\n\
         modules:\n  - name: mm1\n    bus: line1\n    model: minimod\n    address: 1\n    settings:\n      WDTTIME: 50      # 0.5 s without a valid command fires the module watchdog\n      WDTYMASK: 0      # and then every output is off\n\
         tags:\n  - {{ name: motor, point: mm1.Y1, safe: false }}\n\
         program: {{ file: run.expr, kind: expr }}\n"
    );
    let project_path: PathBuf = dir.join("project.yaml");
    std::fs::write(&project_path, project).unwrap();

    let mut plc = Command::new(BIN)
        .args(["run", "--quiet", "--no-socket"])
        .arg(&project_path)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let on = sim.wait_for("minimod@1.Y1", "1", Duration::from_secs(20));
    if on.is_none() {
        // The child may have exited already; then there is nothing to stop.
        drop(plc.kill());
        let out = plc.wait_with_output().unwrap();
        panic!(
            "the PLC never turned Y1 on: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert_eq!(
        sim.get("minimod@1.WDTTIME"),
        "minimod@1.WDTTIME=50",
        "armed from the project"
    );

    #[allow(unsafe_code)]
    // SAFETY: kill with a valid pid and signal.
    unsafe {
        libc::kill(plc.id() as i32, libc::SIGKILL)
    };
    // Only reaps the child: its exit status is not what this test checks.
    drop(plc.wait());
    let killed = Instant::now();
    let off = sim.wait_for("minimod@1.Y1", "0", Duration::from_secs(10));
    assert!(
        off.is_some(),
        "the module watchdog must switch Y1 off after WDTTIME"
    );
    assert_eq!(sim.get("minimod@1.WDTFIRED"), "minimod@1.WDTFIRED=1");
    assert_eq!(
        sim.get("minimod@1.WDTCOMM"),
        "minimod@1.WDTCOMM=1",
        "fired for lost communication"
    );
    // The module, not the dead process, did it: no sooner than WDTTIME after the kill (minus
    // the time since the PLC's last command, at most one 50 ms cycle plus the bus).
    assert!(
        killed.elapsed() >= Duration::from_millis(300),
        "{:?}",
        killed.elapsed()
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}
