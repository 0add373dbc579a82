//! The quick start on the virtual clock: the same project gives the same trace twice, the trace
//! is the expected one (a golden file), and every input phase is exactly the line's wire time.
//!
//! Regenerate the golden file after an intended change of behaviour with
//! `UPDATE_GOLDEN=1 cargo test -p softplc-tests --test system determinism::`, and review its diff.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::clock::{Clock, VirtualClock};
use softplc::image::TagId;
use softplc::plc::Plc;
use softplc::project::{self, Project};
use softplc::scan::{RunOutcome, ScanEngine, StopReason};
use softplc_io::line::{line_budget, LineBudget};
use softplc_io::point::{Quality, Value};
use softplc_tests::workspace_root;

const RUN_FOR: Duration = Duration::from_secs(60);
/// The tags of the quick start, in the trace's column order.
const TAGS: [&str; 6] = [
    "box_at_entry",
    "start",
    "stop",
    "motor",
    "box_at_exit",
    "lamp",
];

fn project_path() -> PathBuf {
    workspace_root().join("examples/quickstart/project.yaml")
}

fn golden_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("golden/quickstart_trace.txt")
}

fn load() -> Project {
    project::load(&project_path()).unwrap_or_else(|e| panic!("the quick start is valid:\n{e}"))
}

/// One cycle as the hook saw it.
#[derive(Debug, Clone, PartialEq)]
struct Cycle {
    /// Its start (deadline) on the virtual clock.
    start: Duration,
    /// The input phase: start to the time the inputs were written into the image.
    read: Duration,
    /// The whole cycle: start to the end of the output phase.
    total: Duration,
    /// The tags' values after the cycle, in [`TAGS`] order.
    values: Vec<bool>,
}

struct Run {
    cycles: Vec<Cycle>,
    outcome: RunOutcome,
}

/// The quick start with its modules polled (`events: false`), whose input phase is the poll
/// plan's floor to the nanosecond; by default its line runs Collect.
fn load_polled() -> Project {
    let mut project = load();
    for module in &mut project.modules {
        if let softplc_io::devices::ModuleSettings::MiniMod(s) = &mut module.device.settings {
            s.push(softplc_io::devices::minimod::Setting::Events(false));
        }
    }
    project
}

fn run() -> Run {
    run_on(load())
}

fn run_on(project: Project) -> Run {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project, clock).expect("the quick start builds");
    let ids: Vec<TagId> = TAGS
        .iter()
        .map(|t| plc.image().id(t).unwrap_or_else(|| panic!("tag {t}")))
        .collect();
    let exit = ids[4];
    let cycles = Arc::new(Mutex::new(Vec::new()));
    let sink = cycles.clone();
    let mut engine = ScanEngine::new(plc)
        .run_for(RUN_FOR)
        .on_cycle(Box::new(move |plc, ctx| {
            let image = plc.image();
            // Inputs are stamped with the time the input phase ended (on a virtual clock).
            let slot = image.slot(exit);
            assert_eq!(slot.quality, Quality::Good, "cycle {}", ctx.cycle);
            let values = ids
                .iter()
                .map(|&id| match image.get(id) {
                    Value::Bool(b) => b,
                    v => panic!("{} is not a bool: {v:?}", image.name(id)),
                })
                .collect();
            sink.lock().unwrap().push(Cycle {
                start: ctx.now.since_origin(),
                read: slot.timestamp - ctx.now,
                total: plc.clock().now() - ctx.now,
                values,
            });
        }));
    let outcome = engine.run();
    let cycles = cycles.lock().unwrap().clone();
    Run { cycles, outcome }
}

fn ms(d: Duration) -> String {
    format!("{}.{:03}", d.as_millis(), d.as_micros() % 1000)
}

/// The golden trace: the initial values, then every change with its cycle's time, then the
/// run's totals.
fn trace(run: &Run) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# softplc-tests determinism: examples/quickstart/project.yaml, {} s on the virtual \
         clock",
        RUN_FOR.as_secs()
    );
    let _ = writeln!(out, "# time (ms)  tag  value");
    let mut previous: Option<&[bool]> = None;
    for c in &run.cycles {
        for (i, v) in c.values.iter().enumerate() {
            if previous.is_none_or(|p| p[i] != *v) {
                let _ = writeln!(out, "{:>10}  {} {}", ms(c.start), TAGS[i], u8::from(*v));
            }
        }
        previous = Some(&c.values);
    }
    let s = &run.outcome.stats;
    let _ = writeln!(
        out,
        "scans {} overruns {} bus errors {}",
        s.cycles, s.overruns, s.bus_errors
    );
    for m in &run.outcome.modules {
        let c = &m.counters;
        let _ = writeln!(
            out,
            "module {}: {} requests {} errors {}",
            m.name,
            m.quality,
            c.requests,
            c.errors()
        );
    }
    out
}

#[test]
fn the_quick_start_replays_bit_for_bit_and_matches_its_golden_trace() {
    let first = run();
    let second = run();
    assert_eq!(first.outcome.reason, StopReason::TimeUp);
    assert_eq!(
        first.cycles, second.cycles,
        "same inputs, same times: same cycles"
    );
    let text = trace(&first);
    assert_eq!(text, trace(&second));

    let golden = golden_path();
    if std::env::var_os("UPDATE_GOLDEN").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(golden.parent().unwrap()).unwrap();
        std::fs::write(&golden, &text).unwrap();
        eprintln!("wrote {}", golden.display());
    }
    let expected = std::fs::read_to_string(&golden).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; create it with UPDATE_GOLDEN=1 cargo test -p softplc-tests --test \
             system determinism::",
            golden.display()
        )
    });
    if text != expected {
        let (n, (got, want)) = text
            .lines()
            .chain(std::iter::repeat("(end)"))
            .zip(expected.lines().chain(std::iter::repeat("(end)")))
            .enumerate()
            .find(|(_, (a, b))| a != b)
            .unwrap_or((0, ("", "")));
        panic!(
            "the trace differs from {} at line {}:\n  got:      {got}\n  expected: {want}\nif \
             the change is intended, regenerate it with UPDATE_GOLDEN=1 and review the diff",
            golden.display(),
            n + 1
        );
    }
}

/// Indexes of the cycles where tag `i` became `to`.
fn edges(cycles: &[Cycle], i: usize, to: bool) -> Vec<usize> {
    cycles
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0].values[i] != to && w[1].values[i] == to)
        .map(|(k, _)| k + 1)
        .collect()
}

#[test]
fn the_trace_is_the_conveyors_story() {
    let run = run();
    let c = &run.cycles;
    let [_entry, start, stop, motor, exit, lamp] = [0, 1, 2, 3, 4, 5];
    assert_eq!(c.len(), 600, "60 s at 100 ms");
    assert!(c[0].values.iter().all(|v| !v), "everything off at first");
    assert!(c.iter().all(|k| !k.values[stop]), "nobody presses stop");

    let starts = edges(c, start, true);
    let motor_on = edges(c, motor, true);
    let motor_off = edges(c, motor, false);
    let arrivals = edges(c, exit, true);
    assert!(
        motor_on.len() >= 2,
        "several boxes in a minute: {motor_on:?}"
    );
    // The motor starts in the very cycle the press of start is seen (rising(start)).
    assert_eq!(motor_on, starts, "one motor start per press, at the press");
    // It stops in the cycle the box is seen at the exit, and only then.
    assert_eq!(motor_off.len(), motor_on.len());
    for &off in &motor_off {
        assert!(
            arrivals.contains(&off),
            "motor off at cycle {off} without a box at the exit"
        );
    }
    for (on, off) in motor_on.iter().zip(&motor_off) {
        assert!(on < off);
        // The belt is 1 m at 0.5 m/s: the box needs 1.8 s from the entry to the exit sensor.
        let travel = c[*off].start - c[*on].start;
        assert!(
            travel >= Duration::from_millis(1700) && travel <= Duration::from_millis(2100),
            "travel {travel:?}"
        );
    }
    // The lamp is on exactly while a box waits at the exit, and the motor is then off.
    for k in c {
        assert_eq!(k.values[lamp], k.values[exit], "lamp at {:?}", k.start);
        if k.values[exit] {
            assert!(
                !k.values[motor],
                "motor running into the end stop at {:?}",
                k.start
            );
        }
    }
    // The operator takes the box away 1.5 s after it reaches the exit: the lamp goes off.
    let lamp_on = edges(c, lamp, true);
    let lamp_off = edges(c, lamp, false);
    assert!(!lamp_off.is_empty(), "the box is never taken away");
    for (on, off) in lamp_on.iter().zip(&lamp_off) {
        let wait = c[*off].start - c[*on].start;
        assert!(
            wait >= Duration::from_millis(1400) && wait <= Duration::from_millis(1700),
            "lamp on for {wait:?} from {:?}",
            c[*on].start
        );
    }
}

/// The budget `softplc check` prints for the quick start's line.
fn budget(project: &Project) -> LineBudget {
    assert_eq!(project.buses.len(), 1);
    let mut drivers: Vec<_> = project
        .modules
        .iter()
        .map(|m| {
            (
                m.name.clone(),
                (m.model.driver)(&m.device),
                m.model.points.iter().map(|p| p.access).collect::<Vec<_>>(),
            )
        })
        .collect();
    line_budget(project.buses[0].settings, &mut drivers)
}

#[test]
fn every_input_phase_is_the_wire_time_floor_without_its_last_gap() {
    let project = load_polled();
    let settings = project.buses[0].settings;
    let t35 = settings.t3_5();
    let b = budget(&project);
    // Two MiniMods, one FC 2 read each (8 + 7 bytes, 10 ms reply delay, t3.5).
    assert_eq!(b.modules.len(), 2);
    for m in &b.modules {
        assert_eq!(m.read_transactions, 1);
        assert_eq!(
            m.read_time,
            settings.transaction(8, Duration::from_millis(10), 7)
        );
    }

    let run = run_on(load_polled());
    assert_eq!(run.outcome.stats.bus_errors, 0);
    assert_eq!(run.outcome.stats.overruns, 0);
    for m in &run.outcome.modules {
        assert_eq!(m.quality, Quality::Good, "{}", m.name);
        assert_eq!(m.counters.errors(), 0, "{}", m.name);
    }

    // The input phase runs the two transactions back to back: it starts on an idle line and
    // ends with the last reply's last character, before the t3.5 that closes that
    // transaction in the budget.
    let read = b.read_floor - t35;
    for k in &run.cycles {
        assert_eq!(k.read, read, "input phase of the cycle at {:?}", k.start);
    }
    // The output phase writes the modules whose output changed (motor on mm1, lamp on mm2),
    // both on the first cycle, and a module's periodic rewrite (output_refresh, 1 s) from
    // three quarters of its period on, one module a cycle (`line/housekeeping.rs`): a cycle
    // carries its changes and at most one rewrite more. Each write first waits the t3.5 after
    // the previous traffic, so a full write is exactly the budget's write floor; logic takes
    // no virtual time.
    let one = settings.transaction(8, Duration::from_millis(10), 8);
    assert_eq!(b.write_floor, one * 2);
    let [motor, lamp] = [3, 5];
    let mut rewrites = 0u32;
    for (k, c) in run.cycles.iter().enumerate() {
        let output = c.total - c.read;
        let writes = (output.as_nanos() / one.as_nanos()) as u32;
        assert_eq!(
            output,
            one * writes,
            "output phase of the cycle at {:?}",
            c.start
        );
        if k == 0 {
            assert_eq!(writes, 2, "the first cycle writes every output");
            continue;
        }
        let p = &run.cycles[k - 1].values;
        let changes = u32::from(p[motor] != c.values[motor]) + u32::from(p[lamp] != c.values[lamp]);
        assert!(
            writes == changes || writes == changes + 1,
            "cycle at {:?}: {writes} writes for {changes} changes",
            c.start
        );
        rewrites += writes - changes;
    }
    // 600 cycles of 100 ms: each module rewritten about every 800 ms (less where its own
    // writes covered every output it owns).
    assert!(rewrites <= 2 * 60_000 / 750, "{rewrites} periodic rewrites");
    // The longest cycle is the budget's cycle floor without the last t3.5.
    let longest = run.cycles.iter().map(|k| k.total).max().unwrap();
    assert_eq!(longest, b.cycle_floor() - t35);
    // The scan's own histogram agrees, to its 3 significant digits.
    let p = run.outcome.stats.read.percentiles();
    assert_eq!(p.count, 600);
    let max = p.max.as_nanos() as f64;
    let exact = read.as_nanos() as f64;
    assert!((max - exact).abs() / exact < 1e-3, "{p:?} vs {read:?}");
}
