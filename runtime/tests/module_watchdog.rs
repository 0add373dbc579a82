//! The modules' own watchdogs are armed by default (issue 14, item 5): a project without
//! WDTTIME gets the MiniMod's watchdog armed, with WDTYMASK from the tags' safe values and a
//! time derived from the scan and the line; `softplc check` prints it; `watchdog: off` turns it
//! off and `check` warns. On the virtual clock, a PLC that stops scanning without its clean
//! shutdown (as `kill -9` leaves it) has its outputs set to their safe values by the module
//! itself, within the printed time. Both hold on a module that keeps WDTTIME/WDTYMASK where
//! the manual's register table says (holding registers 128/144) and on one that follows its
//! coil/register aliasing rule (8/9): the driver arms the watchdog by name.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;
use std::time::Duration;

use softplc::clock::{Clock, VirtualClock};
use softplc::logic::ScanContext;
use softplc::plc::Plc;
use softplc::project::{self, Armed, Origin, Project};
use softplc_io::devices::minimod::{MiniModSim, WatchdogRegisters};
use softplc_io::point::Value;
use softplc_io::sim::SimWorld;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
const PERIOD: Duration = Duration::from_millis(50);

/// A project folder with `run.expr` (Y1 on, Y2 off while the PLC runs) and `project.yaml`
/// whose module entry ends with `module_extra` (lines indented as the entry's keys).
fn folder(case: &str, module_extra: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "softplc-module-watchdog-{}-{case}",
        std::process::id()
    ));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("run.expr"), "motor = 1\nlamp = 0\n").unwrap();
    let text = format!(
        "project: watchdog
scan: {{ period: 50ms }}
buses:
  - {{ name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}
modules:
  - name: mm1
    bus: line1
    model: minimod
    address: 1
{module_extra}tags:
  - {{ name: motor, point: mm1.Y1, safe: false }}
  - {{ name: lamp, point: mm1.Y2, safe: true }}
program: {{ file: run.expr, kind: expr }}
"
    );
    std::fs::write(dir.join("project.yaml"), text).unwrap();
    dir
}

fn load(dir: &Path) -> Project {
    project::load(&dir.join("project.yaml")).unwrap_or_else(|e| panic!("valid:\n{e}"))
}

fn check(dir: &Path) -> (bool, String) {
    let out = Command::new(BIN)
        .arg("check")
        .arg(dir.join("project.yaml"))
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

/// Builds the PLC on a virtual clock and scans `cycles` times, as the scan engine does.
fn run(project: Project, cycles: u64) -> (Plc, Arc<VirtualClock>) {
    run_on(WatchdogRegisters::Table, project, cycles)
}

/// As [`run`], on a simulated MiniMod that keeps WDTTIME/WDTYMASK where `registers` says.
fn run_on(registers: WatchdogRegisters, project: Project, cycles: u64) -> (Plc, Arc<VirtualClock>) {
    let mut world = SimWorld::new(project.buses.iter().map(|b| b.settings).collect());
    let mm1 =
        MiniModSim::with_watchdog_registers(project.modules[0].device.address.get(), registers);
    world.add_device(project.modules[0].bus, "mm1", Box::new(mm1));
    let clock = Arc::new(VirtualClock::new());
    let mut plc = Plc::build_on(project, clock.clone(), Some(world.shared()))
        .unwrap_or_else(|e| panic!("builds ({registers:?}): {e}"));
    let mut next = clock.now();
    for cycle in 0..cycles {
        clock.advance_to(next);
        plc.read_inputs();
        let ctx = ScanContext {
            now: next,
            delta: PERIOD,
            cycle,
        };
        plc.run_logic(&ctx).unwrap();
        plc.write_outputs();
        next += PERIOD;
    }
    (plc, clock)
}

fn sim(plc: &Plc, point: &str) -> Value {
    let world = plc.world().unwrap();
    let w = world.lock().unwrap();
    let mm1 = w.find("mm1").unwrap();
    w.get(mm1, point).unwrap()
}

/// Drops the PLC without its safe state, as `kill -9` would, and lets the module's world run
/// on by itself: the time from the last frame on the line to the first millisecond at which
/// Y1 is off, and the outputs then.
fn kill_and_wait(plc: Plc, for_at_most: Duration) -> (Option<Duration>, Value, Value) {
    let world = plc.world().unwrap().clone();
    drop(plc);
    let mut w = world.lock().unwrap();
    let mm1 = w.find("mm1").unwrap();
    let last_frame = w.now();
    let mut t = last_frame;
    while t < last_frame + for_at_most {
        t += Duration::from_millis(1);
        w.advance_to(t);
        if w.get(mm1, "Y1").unwrap() == Value::Bool(false) {
            return (
                Some(t - last_frame),
                w.get(mm1, "Y1").unwrap(),
                w.get(mm1, "Y2").unwrap(),
            );
        }
    }
    (None, w.get(mm1, "Y1").unwrap(), w.get(mm1, "Y2").unwrap())
}

#[test]
fn without_wdttime_the_watchdog_is_armed_and_takes_the_outputs_safe_after_a_kill() {
    let dir = folder("default", "");
    let project = load(&dir);
    let Armed::MiniMod {
        time,
        time_from,
        mask,
        mask_from,
        ref no_safe,
        ..
    } = project.modules[0].watchdog.armed
    else {
        panic!("armed: {:?}", project.modules[0].watchdog.armed)
    };
    assert_eq!((time_from, mask_from), (Origin::Derived, Origin::Derived));
    assert_eq!(mask, 0b0010, "Y1 safe off, Y2 safe on");
    assert_eq!(no_safe, &["Y3", "Y4"]);
    // No less than what a healthy line needs between two exchanges: three periods at least.
    assert!(time >= 15, "{time}");

    let (ok, text) = check(&dir);
    assert!(ok, "{text}");
    assert!(
        text.contains(&format!(
            "    module watchdog: WDTTIME {time} ({:.2}s ≥ 3 × period 0.05s + line floor ",
            f64::from(time) / 100.0
        )),
        "{text}"
    );
    assert!(
        text.contains("WDTYMASK 0b0010 (Y1 off, Y2 on; no safe value, so off: Y3, Y4)"),
        "{text}"
    );
    assert!(!text.contains("watchdog is off"), "{text}");

    for registers in WatchdogRegisters::ALL {
        let (plc, _clock) = run_on(registers, project.clone(), 40);
        // Armed in the module by the start-up, whichever register the module has.
        assert_eq!(sim(&plc, "WDTTIME"), Value::U16(time), "{registers:?}");
        assert_eq!(sim(&plc, "WDTYMASK"), Value::U16(0b0010), "{registers:?}");
        assert_eq!(sim(&plc, "Y1"), Value::Bool(true), "the program runs Y1");
        assert_eq!(sim(&plc, "Y2"), Value::Bool(false));

        let printed = Duration::from_millis(u64::from(time) * 10);
        let (off_after, y1, y2) = kill_and_wait(plc, printed * 2);
        let off_after = off_after.expect("Y1 goes off by itself");
        assert!(
            off_after <= printed,
            "{registers:?}: within the printed {printed:?}: {off_after:?}"
        );
        assert!(
            off_after + Duration::from_millis(10) >= printed,
            "{registers:?}: and not before it: {off_after:?}"
        );
        assert_eq!(
            (y1, y2),
            (Value::Bool(false), Value::Bool(true)),
            "{registers:?}: WDTYMASK"
        );
    }
}

#[test]
fn watchdog_off_disarms_it_and_check_warns() {
    let dir = folder("off", "    watchdog: off\n");
    let project = load(&dir);
    assert_eq!(project.modules[0].watchdog.armed, Armed::Off);
    let (ok, text) = check(&dir);
    assert!(ok, "{text}");
    assert!(text.contains("    module watchdog: OFF\n"), "{text}");
    assert!(
        text.contains(
            "warning: module mm1: its watchdog is off: if this process dies or the line breaks, \
             its outputs keep their last state"
        ),
        "{text}"
    );
    let (plc, _clock) = run(project, 20);
    assert_eq!(sim(&plc, "WDTTIME"), Value::U16(0), "disarmed at start-up");
    let (off_after, y1, _) = kill_and_wait(plc, Duration::from_secs(10));
    assert_eq!(
        (off_after, y1),
        (None, Value::Bool(true)),
        "Y1 stays on: what the warning says"
    );
}

#[test]
fn an_explicit_wdttime_wins_and_contradicting_it_is_refused() {
    let dir = folder("explicit", "    settings: { WDTTIME: 50 }\n");
    let project = load(&dir);
    assert!(matches!(
        project.modules[0].watchdog.armed,
        Armed::MiniMod {
            time: 50,
            time_from: Origin::Project,
            mask: 0b0010,
            mask_from: Origin::Derived,
            ..
        }
    ));
    let (_, text) = check(&dir);
    assert!(
        text.contains("module watchdog: WDTTIME 50 (0.50s, from the settings); WDTYMASK 0b0010"),
        "{text}"
    );
    // WDTTIME: 0 is the register's own way of saying off.
    let dir = folder("zero", "    settings: { WDTTIME: 0 }\n");
    assert_eq!(load(&dir).modules[0].watchdog.armed, Armed::Off);

    let dir = folder("both", "    settings: { WDTTIME: 50 }\n    watchdog: off\n");
    let errors = project::load(&dir.join("project.yaml"))
        .unwrap_err()
        .to_string();
    assert!(
        errors.contains(
            "project.yaml:11:15: error: module mm1: setting `watchdog`: off contradicts the \
             setting WDTTIME: 50; remove one of them"
        ),
        "{errors}"
    );
    let dir = folder("bad", "    watchdog: sometimes\n");
    let errors = project::load(&dir.join("project.yaml"))
        .unwrap_err()
        .to_string();
    assert!(
        errors.contains("setting `watchdog`: takes auto (the default"),
        "{errors}"
    );
}

#[test]
fn event_mode_covers_the_refresh_and_an_idle_line_does_not_fire_it() {
    let dir = folder(
        "events",
        "    settings: { events: true, event_refresh: 2s }\n",
    );
    let project = load(&dir);
    let Armed::MiniMod {
        time, derivation, ..
    } = project.modules[0].watchdog.armed
    else {
        panic!("armed")
    };
    let d = derivation.expect("derived");
    assert_eq!(d.event_refresh, Some(Duration::from_secs(2)));
    assert!(u64::from(time) * 10 >= 2_000 + 150, "{time}");
    // Nothing changes on the inputs for 10 s: Collect rounds only, a full read every 2 s.
    for registers in WatchdogRegisters::ALL {
        let (plc, _clock) = run_on(registers, project.clone(), 200);
        assert_eq!(sim(&plc, "WDTTIME"), Value::U16(time), "{registers:?}");
        assert_eq!(sim(&plc, "WDTFIRED"), Value::Bool(false));
        assert_eq!(sim(&plc, "Y1"), Value::Bool(true));
        // And a dead host still takes the outputs safe: WDTYMASK 0b0010, Y1 off.
        let printed = Duration::from_millis(u64::from(time) * 10);
        let (off_after, y1, y2) = kill_and_wait(plc, printed * 2);
        assert!(
            off_after.is_some_and(|t| t <= printed),
            "{registers:?}: {off_after:?}"
        );
        assert_eq!((y1, y2), (Value::Bool(false), Value::Bool(true)));
    }
}

#[test]
fn a_simulator_option_that_does_not_fit_is_refused_naming_it() {
    let sim = |option: &str| {
        let out = Command::new(BIN)
            .args(["sim", "--pty", "minimod@1", "--option", option])
            .stdin(std::process::Stdio::null())
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    for (option, error) in [
        (
            "minimod@1:watchdog-registers=both",
            "error: --option \"minimod@1:watchdog-registers=both\": watchdog-registers does \
             not take both (takes table or aliased)",
        ),
        (
            "minimod@2:watchdog-registers=aliased",
            "error: --option \"minimod@2:watchdog-registers=aliased\": no device \
             \"minimod@2\" (devices: minimod@1)",
        ),
        (
            "minimod@1-aliased",
            "error: --option \"minimod@1-aliased\": expected DEVICE:NAME=VALUE, e.g. \
             minimod@5:watchdog-registers=aliased",
        ),
        (
            "minimod@1:colour=red",
            "error: --option \"minimod@1:colour=red\": unknown command \"option colour red\"",
        ),
    ] {
        let (ok, stderr) = sim(option);
        assert!(!ok, "{option}");
        assert!(stderr.contains(error), "{option}: {stderr}");
    }
}

#[test]
fn a_minimod_whose_text_commands_an_ex9053_would_answer_is_refused_naming_both() {
    let dir = std::env::temp_dir().join(format!(
        "softplc-module-watchdog-{}-dcon",
        std::process::id()
    ));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("run.expr"), "motor = 1\n").unwrap();
    let project = |minimod: u8, ex9053: u8, checksum: &str| {
        format!(
            "project: neighbours
scan: {{ period: 50ms }}
buses:
  - {{ name: line1, port: sim, baud: 9600, format: 8N1 }}
modules:
  - {{ name: mm1, bus: line1, model: minimod, address: {minimod} }}
  - {{ name: ex1, bus: line1, model: ex9053d, address: {ex9053}{checksum} }}
tags:
  - {{ name: motor, point: mm1.Y1, safe: false }}
program: {{ file: run.expr, kind: expr }}
"
        )
    };
    let load = |text: String| {
        std::fs::write(dir.join("project.yaml"), text).unwrap();
        project::load(&dir.join("project.yaml")).map_err(|e| e.to_string())
    };
    // MiniMod 18 is `@18>...`: DCON address 18 (hexadecimal), the EX-9053 at 24.
    let errors = load(project(18, 24, "")).unwrap_err();
    assert!(
        errors.contains(
            "project.yaml:6:55: error: module mm1 (minimod, address 18) gets text commands \
             (`@18>WDTTIME=` at start-up) that module ex1 (DCON address 18, line 7) on bus line1 \
             takes for its own and answers `?18` over the MiniMod's reply; give one of them \
             another address (or turn the EX-9053's checksum on)"
        ),
        "{errors}"
    );
    // Other addresses, or the EX-9053's checksum on: nothing heard.
    assert!(load(project(18, 18 + 1, "")).is_ok());
    assert!(load(project(5, 5 + 0x10, "")).is_ok());
    assert!(load(project(18, 24, ", settings: { checksum: true }")).is_ok());
}
