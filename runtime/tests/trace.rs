//! Trace on the virtual clock: trigger semantics (edges, levels, comparisons, `every`), pre-
//! and post-trigger counts, repeating and continuous traces, as the scan samples them at its
//! cycle boundaries; and a golden CSV/VCD of the quick start, byte for byte.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use softplc::clock::VirtualClock;
use softplc::plc::Plc;
use softplc::project::RawTrace;
use softplc::scan::{CycleBoundary, ScanEngine, ScanStats};
use softplc::trace::{TraceData, TraceSet, TraceState};

/// What a test does at a cycle boundary (after the trace has sampled it).
type Script = Box<dyn FnMut(u64, &mut TraceSet, &Plc, &mut Vec<Seen>) + Send>;

/// What the test saw: the traces' states per cycle, and what it read.
#[derive(Debug, Clone, PartialEq)]
enum Seen {
    State(u64, TraceState, usize),
    Data(TraceData),
}

/// The scan's boundary as the service runs it: the traces sample first, then requests.
struct Traced {
    traces: TraceSet,
    script: Script,
    seen: Arc<Mutex<Vec<Seen>>>,
}

impl CycleBoundary for Traced {
    fn between_cycles(
        &mut self,
        plc: &mut Plc,
        stats: &ScanStats,
        _now: softplc_io::time::ScanInstant,
    ) {
        self.traces.sample(plc, stats);
        let mut seen = self.seen.lock().unwrap();
        (self.script)(stats.cycles, &mut self.traces, plc, &mut seen);
    }
}

/// A folder of its own per call: tests run in parallel, and a program file being written
/// while another run reads it would be read empty.
fn folder(name: &str) -> PathBuf {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("softplc-trace-{}-{name}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A memory-only project: `n` counts the cycles (1 at the first), `pulse` is true on every
/// fourth, `level` is a number that climbs by 0.5.
fn counter_project(name: &str) -> PathBuf {
    let dir = folder(name);
    std::fs::write(
        dir.join("count.rhai"),
        "n = n + 1;\npulse = n % 4 == 0;\nlevel = level + 0.5;\n",
    )
    .unwrap();
    let yaml = "project: count
scan: { period: 10ms }
tags:
  - { name: n, type: i32 }
  - { name: pulse, type: bool }
  - { name: level, type: f32 }
program: { file: count.rhai, kind: rhai }
";
    std::fs::write(dir.join("project.yaml"), yaml).unwrap();
    dir.join("project.yaml")
}

/// Runs `project` for `cycles` on the virtual clock with `script` at each boundary.
fn run(project: &Path, cycles: u64, script: Script) -> Vec<Seen> {
    let project = softplc::project::load(project).unwrap_or_else(|e| panic!("{e}"));
    let plc = Plc::build(project, Arc::new(VirtualClock::new())).unwrap();
    let seen = Arc::new(Mutex::new(Vec::new()));
    ScanEngine::new(plc)
        .max_cycles(cycles)
        .with_boundary(Traced {
            traces: TraceSet::new(),
            script,
            seen: seen.clone(),
        })
        .run();
    let out = seen.lock().unwrap().clone();
    out
}

fn spec(tags: &[&str], trigger: Option<&str>, pre: i64, post: i64) -> RawTrace {
    RawTrace {
        name: "t".into(),
        tags: tags.iter().map(|t| t.to_string()).collect(),
        trigger: trigger.map(str::to_owned),
        pre: Some(pre),
        post: Some(post),
        ..RawTrace::default()
    }
}

/// Arms `raw` after cycle `arm_at`, reads it after `cycles`; the cycles of its samples and
/// where the trigger sample is.
fn cycles_of(raw: RawTrace, arm_at: u64, cycles: u64) -> (Vec<u64>, Option<usize>, TraceData) {
    let path = counter_project("cycles");
    let seen = run(
        &path,
        cycles,
        Box::new(move |c, traces, plc, seen| {
            if c == arm_at {
                traces.arm(plc.project(), None, Some(&raw)).unwrap();
            }
            if c == cycles {
                seen.push(Seen::Data(traces.read(plc.project(), "t", true).unwrap()));
            }
        }),
    );
    let Some(Seen::Data(d)) = seen.last() else {
        panic!("no data: {seen:?}")
    };
    (d.cycle.clone(), d.trigger, d.clone())
}

#[test]
fn a_rising_edge_keeps_pre_samples_before_it_and_post_samples_after() {
    // Armed after cycle 1: samples from cycle 2; pulse rises at 4 (false at 3).
    let (cycles, trigger, d) = cycles_of(spec(&["n", "pulse"], Some("pulse rising"), 2, 3), 1, 20);
    assert_eq!(cycles, [2, 3, 4, 5, 6, 7]);
    assert_eq!(trigger, Some(2));
    assert_eq!(d.state, TraceState::Complete);
    // The values are those the cycle's logic left; the time is the cycle's own (10 ms grid).
    assert_eq!(d.values[2], [4.0, 1.0]);
    assert_eq!(d.time_ns[2], 30_000_000);
}

#[test]
fn an_edge_needs_the_value_before_it_but_a_level_does_not() {
    // Armed after cycle 3, pulse is true at 4: a level fires there; the first rise the
    // trace can see from a value before it is at 4 too (it saw 3 false).
    let (c, t, _) = cycles_of(spec(&["n"], Some("pulse high"), 1, 1), 3, 20);
    assert_eq!((c, t), (vec![4, 5], Some(0)));
    // Armed after cycle 4: 4's value is not seen, so 5 (pulse falls) is a falling edge and
    // the next rise is at 8.
    let (c, t, _) = cycles_of(spec(&["n"], Some("pulse rising"), 1, 1), 4, 20);
    assert_eq!((c, t), (vec![7, 8, 9], Some(1)));
    let (c, _, _) = cycles_of(spec(&["n"], Some("pulse falling"), 0, 0), 4, 20);
    assert_eq!(
        c,
        [9],
        "the first sample only gives the edge its previous value"
    );
    let (c, _, _) = cycles_of(spec(&["n"], Some("pulse low"), 0, 0), 3, 20);
    assert_eq!(c, [5]);
}

#[test]
fn comparisons_fire_on_numbers_and_phase_times() {
    let (c, t, d) = cycles_of(spec(&["n", "level"], Some("level >= 3.5"), 2, 1), 1, 20);
    assert_eq!((c, t), (vec![5, 6, 7, 8], Some(2)));
    assert_eq!(d.values[2], [7.0, 3.5]);
    let (c, _, _) = cycles_of(spec(&["n"], Some("n == 10"), 0, 0), 1, 20);
    assert_eq!(c, [10]);
    let (c, _, _) = cycles_of(spec(&["n"], Some("n != 2"), 0, 0), 1, 20);
    assert_eq!(
        c,
        [3],
        "armed after cycle 1, the first cycle watched is 2, where n is 2"
    );
}

#[test]
fn every_n_cycles_samples_less_but_never_misses_the_trigger() {
    let mut raw = spec(&["n"], Some("pulse rising"), 2, 2);
    raw.every = Some(3);
    // Sampled from 2 every 3 cycles (2, 5, 8, ...); pulse rises at 4, off the grid: sampled
    // there, and every 3 cycles after it.
    let (c, t, _) = cycles_of(raw, 1, 30);
    assert_eq!((c, t), (vec![2, 4, 7, 10], Some(1)));
}

#[test]
fn states_go_filling_armed_triggered_complete() {
    let path = counter_project("states");
    let raw = spec(&["n"], Some("n == 8"), 3, 2);
    let seen = run(
        &path,
        12,
        Box::new(move |c, traces, plc, seen| {
            if c == 1 {
                traces.arm(plc.project(), None, Some(&raw)).unwrap();
            }
            let s = &traces.status(plc.project(), Some("t")).unwrap()[0];
            seen.push(Seen::State(c, s.state.unwrap(), s.samples));
        }),
    );
    use TraceState::*;
    let expected = [
        (1, Filling, 0),
        (2, Filling, 1),
        (3, Filling, 2),
        (4, Armed, 3),
        (5, Armed, 3),
        (6, Armed, 3),
        (7, Armed, 3),
        (8, Triggered, 4),
        (9, Triggered, 5),
        (10, Complete, 6),
        (11, Complete, 6),
        (12, Complete, 6),
    ];
    let expected: Vec<Seen> = expected
        .into_iter()
        .map(|(c, s, n)| Seen::State(c, s, n))
        .collect();
    assert_eq!(seen, expected);
}

#[test]
fn a_repeating_trace_arms_again_once_saved_and_a_single_one_keeps_its_samples() {
    let path = counter_project("repeat");
    let mut raw = spec(&["n"], Some("pulse rising"), 0, 1);
    raw.mode = Some("repeat".into());
    let mut single = raw.clone();
    single.name = "once".into();
    single.mode = None;
    let seen = run(
        &path,
        30,
        Box::new(move |c, traces, plc, seen| {
            let p = plc.project();
            if c == 1 {
                traces.arm(p, None, Some(&raw)).unwrap();
                traces.arm(p, None, Some(&single)).unwrap();
            }
            // Saved at 10 and 14: the repeating trace re-arms and catches the next rise.
            if c == 10 || c == 14 || c == 30 {
                seen.push(Seen::Data(traces.read(p, "t", true).unwrap()));
                seen.push(Seen::Data(traces.read(p, "once", true).unwrap()));
            }
        }),
    );
    let cycles: Vec<(String, Vec<u64>, TraceState)> = seen
        .iter()
        .map(|s| match s {
            Seen::Data(d) => (d.name.clone(), d.cycle.clone(), d.state),
            Seen::State(..) => panic!(),
        })
        .collect();
    use TraceState::*;
    assert_eq!(
        cycles,
        [
            ("t".into(), vec![4, 5], Complete),
            ("once".into(), vec![4, 5], Complete),
            ("t".into(), vec![12, 13], Complete),
            ("once".into(), vec![4, 5], Complete),
            ("t".into(), vec![16, 17], Complete),
            ("once".into(), vec![4, 5], Complete),
        ]
    );
}

#[test]
fn without_a_trigger_a_trace_keeps_the_newest_samples() {
    let raw = spec(&["n"], None, 3, 1);
    let (c, t, d) = cycles_of(raw, 1, 20);
    assert_eq!((c, t), (vec![17, 18, 19, 20], None));
    assert_eq!(d.state, TraceState::Recording);
}

#[test]
fn arming_refuses_what_the_project_file_would_with_the_same_words() {
    let path = counter_project("refuse");
    let seen = run(
        &path,
        1,
        Box::new(|_, traces, plc, seen| {
            let p = plc.project();
            for (raw, name) in [
                (spec(&["n", "pulze"], Some("n rising"), 1, 1), None),
                (RawTrace::default(), Some("jam")),
            ] {
                let e = traces.arm(p, name, Some(&raw).filter(|_| name.is_none()));
                seen.push(Seen::State(0, TraceState::Filling, 0));
                let text = e.unwrap_err().to_string();
                match name {
                    None => assert_eq!(
                        text,
                        "trace signal \"pulze\" is no tag, module counter or phase time; did you \
                         mean pulse?; trigger \"n rising\": n is i32, and an edge or level needs \
                         a bool; compare it instead (`n > 0`)"
                    ),
                    Some(_) => assert_eq!(
                        text,
                        "no trace jam (the project defines none; arm one with --tags)"
                    ),
                }
            }
        }),
    );
    assert_eq!(seen.len(), 2);
}

/// The quick start for 12 s with its plant: the operator presses start, the motor runs the
/// box to the exit. Its golden CSV and VCD, byte for byte.
#[test]
fn the_quick_start_traced_around_the_motor_start_matches_its_golden_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let quickstart = root.join("examples/quickstart/project.yaml");
    let raw = RawTrace {
        name: "motor_start".into(),
        tags: [
            "start",
            "motor",
            "box_at_exit",
            "lamp",
            "mm1.requests",
            "phase.read",
        ]
        .map(String::from)
        .to_vec(),
        trigger: Some("motor rising".into()),
        pre: Some(3),
        post: Some(6),
        ..RawTrace::default()
    };
    let seen = run(
        &quickstart,
        120,
        Box::new(move |c, traces, plc, seen| {
            if c == 1 {
                traces.arm(plc.project(), None, Some(&raw)).unwrap();
            }
            if c == 120 {
                seen.push(Seen::Data(
                    traces.read(plc.project(), "motor_start", true).unwrap(),
                ));
            }
        }),
    );
    let Some(Seen::Data(d)) = seen.last() else {
        panic!("{seen:?}")
    };
    let csv = String::from_utf8(d.write_csv(Vec::new()).unwrap()).unwrap();
    let vcd = String::from_utf8(d.write_vcd(Vec::new()).unwrap()).unwrap();
    let golden = root.join("runtime/tests/fixtures/trace");
    if std::env::var_os("SOFTPLC_BLESS").is_some() {
        std::fs::write(golden.join("quickstart_motor_start.csv"), &csv).unwrap();
        std::fs::write(golden.join("quickstart_motor_start.vcd"), &vcd).unwrap();
    }
    assert_eq!(
        csv,
        std::fs::read_to_string(golden.join("quickstart_motor_start.csv")).unwrap()
    );
    assert_eq!(
        vcd,
        std::fs::read_to_string(golden.join("quickstart_motor_start.vcd")).unwrap()
    );
}
