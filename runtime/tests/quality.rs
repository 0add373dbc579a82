//! Programs read a point's quality (issue #9): a project on a simulated line, a sensor on one
//! MiniMod and an alarm lamp on another, `alarm = !good(sensor)` and `lost = bad(sensor)`, in
//! each of the three languages. The sensor's module is silenced for a while on a virtual
//! clock: the alarm comes on with the first missed cycle, `lost` once the module is lost (after
//! the line's fail limit), the rest of the line keeps being scanned (the alarm reaches the
//! other module), and both go off again once the fault is cleared and the module is back.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::clock::{Clock, VirtualClock};
use softplc::plc::Plc;
use softplc::project::parse_str;
use softplc::scan::{ScanEngine, StopReason};
use softplc_io::point::{Quality, Value};
use softplc_io::sim::{Fault, FaultRule, Frequency};

const PERIOD: Duration = Duration::from_millis(200);
const FAULT_FROM: Duration = Duration::from_secs(2);
const FAULT_UNTIL: Duration = Duration::from_secs(8);
const RUN_FOR: Duration = Duration::from_secs(14);

/// The program in each language: file name, `kind:`, text.
const PROGRAMS: [(&str, &str, &str); 3] = [
    (
        "quality.expr",
        "expr",
        "alarm = !good(sensor)\nlost = bad(sensor)\n",
    ),
    (
        "quality.ladder.yaml",
        "ladder",
        "rungs:\n  - /good(sensor) -> alarm\n  - bad(sensor) -> lost\n",
    ),
    (
        "quality.rhai",
        "rhai",
        "alarm = !good(sensor);\nlost = bad(sensor);\n",
    ),
];

/// The project text, for a program file and kind.
fn project_text(file: &str, kind: &str) -> String {
    format!(
        "project: quality
scan:
  period: {period}ms
  watchdog: {{ time: 2s, sensitivity: 3 }}
buses:
  - {{ name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}
modules:
  # Polled, pinned: a silent module is seen in the next cycle's poll (in event mode, the
  # default here, only at its next refresh: an idle Collect round is silence either way).
  - {{ name: mm1, bus: line1, model: minimod, address: 1, settings: {{ events: false }} }}
  - {{ name: mm2, bus: line1, model: minimod, address: 2, settings: {{ events: false }} }}
tags:
  - {{ name: sensor, point: mm1.X1 }}
  - {{ name: alarm, point: mm2.Y1, safe: false }}
  - {{ name: lost, point: mm2.Y2, safe: false }}
program: {{ file: {file}, kind: {kind} }}
",
        period = PERIOD.as_millis()
    )
}

/// A fresh folder for one run.
fn folder(kind: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("softplc-quality-it-{}-{kind}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// One cycle as the hook saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cycle {
    /// The cycle's start on the virtual clock.
    now: Duration,
    /// The sensor tag's quality after the input phase.
    sensor: Quality,
    /// The alarm and lost tags, as the program wrote them.
    alarm: bool,
    lost: bool,
    /// The alarm output on the second module's Y1 terminal, after the output phase.
    alarm_terminal: bool,
}

/// Runs the project with program `(file, kind, text)`; the sensor's module is silent from
/// [`FAULT_FROM`] to [`FAULT_UNTIL`].
fn run(dir: &Path, (file, kind, text): (&str, &str, &str)) -> Vec<Cycle> {
    std::fs::write(dir.join(file), text).unwrap();
    let path = dir.join("project.yaml");
    let project = parse_str(&project_text(file, kind), &path)
        .unwrap_or_else(|e| panic!("the {kind} project is valid:\n{e}"));
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project, clock).unwrap_or_else(|e| panic!("{kind}: builds: {e}"));
    let image = plc.image();
    let ids = ["sensor", "alarm", "lost"].map(|t| image.id(t).expect("a tag"));
    let world = plc.world().expect("a simulated line").clone();
    let (mm1, mm2) = {
        let w = world.lock().unwrap();
        (w.find("mm1").expect("mm1"), w.find("mm2").expect("mm2"))
    };
    let cycles = Arc::new(Mutex::new(Vec::new()));
    let sink = cycles.clone();
    let mut silenced = false;
    let mut engine = ScanEngine::new(plc)
        .run_for(RUN_FOR)
        .on_cycle(Box::new(move |plc, ctx| {
            let image = plc.image();
            let mut w = world.lock().unwrap();
            let alarm_terminal = w.get(mm2, "Y1").map(|v| v.as_bool()).unwrap_or(false);
            sink.lock().unwrap().push(Cycle {
                now: ctx.now.since_origin(),
                sensor: image.slot(ids[0]).quality,
                alarm: image.get(ids[1]) == Value::Bool(true),
                lost: image.get(ids[2]) == Value::Bool(true),
                alarm_terminal,
            });
            // Faults take effect from the next cycle on.
            let next = ctx.now.since_origin() + PERIOD;
            if !silenced && next >= FAULT_FROM && next < FAULT_UNTIL {
                silenced = true;
                w.faults_mut().add(FaultRule {
                    device: Some(mm1),
                    fault: Fault::Silent,
                    frequency: Frequency::Always,
                });
            } else if silenced && next >= FAULT_UNTIL {
                silenced = false;
                w.faults_mut().clear(Some(mm1));
            }
        }));
    let outcome = engine.run();
    assert!(
        matches!(outcome.reason, StopReason::TimeUp),
        "{kind}: {:?}",
        outcome.reason
    );
    let cycles = cycles.lock().unwrap().clone();
    cycles
}

/// The checks every language must pass.
fn check(kind: &str, cycles: &[Cycle]) {
    // A cycle with a silent module takes longer than the period (timeouts): it overruns, and
    // the scan goes on at the next deadline.
    assert!(
        cycles.last().is_some_and(|c| c.now + 2 * PERIOD >= RUN_FOR),
        "{kind}: the scan ran to the end: {:?}",
        cycles.last()
    );
    let before: Vec<&Cycle> = cycles.iter().filter(|c| c.now < FAULT_FROM).collect();
    assert!(!before.is_empty());
    for c in &before {
        assert_eq!(c.sensor, Quality::Good, "{kind}: {c:?}");
        assert!(!c.alarm && !c.lost && !c.alarm_terminal, "{kind}: {c:?}");
    }

    // During the fault: every cycle is Stale or Bad, the alarm is on from the first one; the
    // module is lost (Bad) after its fail limit, and `lost` follows.
    let during: Vec<&Cycle> = cycles
        .iter()
        .filter(|c| c.now >= FAULT_FROM && c.now < FAULT_UNTIL)
        .collect();
    assert!(!during.is_empty());
    for c in &during {
        assert_ne!(c.sensor, Quality::Good, "{kind}: {c:?}");
        assert!(
            c.alarm,
            "{kind}: the alarm is on while the sensor is not good: {c:?}"
        );
        assert!(
            c.alarm_terminal,
            "{kind}: the rest of the line is scanned and mm2 gets the alarm: {c:?}"
        );
        assert_eq!(c.lost, c.sensor == Quality::Bad, "{kind}: {c:?}");
    }
    let first_bad = during
        .iter()
        .position(|c| c.sensor == Quality::Bad)
        .unwrap_or_else(|| panic!("{kind}: the module is lost: {during:#?}"));
    // Lost at the third consecutive failed read (the default fail limit). A read with a silent
    // module (two attempts of 50 ms + a 25 ms guard, then mm2) takes longer than the scan's
    // input budget (nine tenths of the 200 ms period): the scan does not wait for it, and sees
    // each failed read one cycle later, so the third arrives in the fourth cycle.
    assert_eq!(
        first_bad, 3,
        "{kind}: lost at the third consecutive failed read (the default fail limit): {during:#?}"
    );
    assert_eq!(
        during[0].sensor,
        Quality::Stale,
        "{kind}: the first failed cycle is stale"
    );
    assert!(
        during[first_bad..].iter().all(|c| c.lost),
        "{kind}: lost stays on while the module is"
    );

    // After the fault is cleared: the module is back at its next reconnect attempt (the backoff
    // starts at 1 s and doubles while it stays lost), and the alarm goes off for good.
    let after: Vec<&Cycle> = cycles.iter().filter(|c| c.now >= FAULT_UNTIL).collect();
    let back = after
        .iter()
        .position(|c| c.sensor == Quality::Good)
        .unwrap_or_else(|| panic!("{kind}: the module comes back: {after:#?}"));
    for c in &after[back..] {
        assert_eq!(c.sensor, Quality::Good, "{kind}: {c:?}");
        assert!(!c.alarm && !c.lost && !c.alarm_terminal, "{kind}: {c:?}");
    }
    for c in &after[..back] {
        assert!(c.alarm && c.lost, "{kind}: still lost: {c:?}");
    }
}

#[test]
fn alarm_follows_the_sensor_modules_loss_and_return_in_every_language() {
    let mut traces = Vec::new();
    for program in PROGRAMS {
        let dir = folder(program.1);
        let cycles = run(&dir, program);
        check(program.1, &cycles);
        traces.push((program.1, cycles));
        // Best effort: the test's scratch folder (it may not exist).
        drop(std::fs::remove_dir_all(&dir));
    }
    // Same project, same faults, same virtual clock: the three programs give the same trace.
    let (first, reference) = &traces[0];
    for (kind, trace) in &traces[1..] {
        assert_eq!(trace, reference, "{kind} and {first} differ");
    }
}
