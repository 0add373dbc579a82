//! Push-down equivalence (DESIGN.md principle 6): for every form a module can run, the same
//! program is built twice, `offload: never` (every rung in the scan) and `offload: auto` (the
//! planner's placement), on the virtual clock against the simulated modules. The same seeded
//! random input sequence is played at the module terminals and the output terminals are
//! recorded every millisecond. The traces must match up to the documented reaction-time
//! difference:
//!
//! - **Levels** (combinational rungs, latches, edge functions): the same edges, in the same
//!   order and direction; each pushed-down edge comes no later than the central one (with one
//!   module tick of tolerance) and earlier by at most the central reaction bound (the scan
//!   period plus the slowest line's read floor plus the output line's write floor,
//!   `offload::report::central_bound`). The input sequence holds every input state for at
//!   least two scan periods, so the scan sees every state the module sees.
//! - **Pulses** (TP on a MiniMod output): the trigger stays in the scan, so both pulses start
//!   in the same cycle's write phase (within the write floor of each other); the pushed-down
//!   pulse lasts exactly the preset (± one module tick at each end: the pulser counts whole
//!   milliseconds from a write that falls between two), the central one a whole number of
//!   scans, never shorter.
//!
//! Before the first input change the outputs must agree in level (start-up differs: a module
//! applies its tables before the first scan).

mod blinkers;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::clock::{Clock, VirtualClock};
use softplc::offload::{Placement, Reason};
use softplc::plc::CycleWork;
use softplc::plc::Plc;
use softplc::project::{self, Project};
use softplc::scan::ScanEngine;
use softplc_io::sim::plant::{Plant, PlantIo};

/// An edge: when, and the new level.
type Edge = (Duration, bool);

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// SplitMix64: a small deterministic generator (no dependency, same sequence everywhere).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `lo..=hi`.
    fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }
}

/// Plays input schedules at module terminals and records output terminals, every 1 ms step.
/// Times are counted from `origin`: the first scan's start, so that the central and the
/// pushed-down builds, whose start-ups take different times on the line (the pushed-down one
/// writes its tables), scan on the same grid.
#[derive(Debug)]
struct Recorder {
    origin: LineInstant,
    /// Per input role: level changes, in time order.
    schedule: Vec<Vec<Edge>>,
    next: Vec<usize>,
    outputs: usize,
    last: Vec<bool>,
    trace: Arc<Mutex<Vec<Vec<Edge>>>>,
}

impl Plant for Recorder {
    fn step(&mut self, t: LineInstant, io: &mut dyn PlantIo) {
        let Some(t) = t.checked_duration_since(self.origin) else {
            return;
        };
        for (i, sched) in self.schedule.iter().enumerate() {
            while let Some(&(at, level)) = sched.get(self.next[i]) {
                if at > t {
                    break;
                }
                io.write(i, level);
                self.next[i] += 1;
            }
        }
        let n_in = self.schedule.len();
        let mut trace = self.trace.lock().unwrap();
        for j in 0..self.outputs {
            let v = io.read(n_in + j);
            if v != self.last[j] {
                self.last[j] = v;
                trace[j].push((t, v));
            }
        }
    }
}

/// The language of a case's program.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Lang {
    Expr,
    Ladder,
    Rhai,
}

/// A test case: modules on one simulated line, tags, a program, inputs and outputs to watch.
struct Case {
    name: &'static str,
    period_ms: u64,
    /// The module's tick: how much later than the scan its edge may come (it samples its
    /// inputs on its own clock; the scan may read a terminal between two samples).
    tick_ms: u64,
    /// `modules:` entries (YAML flow mappings without the bus).
    modules: &'static [&'static str],
    /// `tags:` entries.
    tags: &'static [&'static str],
    /// The program: `expr` text, ladder rungs (one per line) or a Rhai script, per `lang`.
    program: &'static str,
    lang: Lang,
    /// Terminals driven: `module.point`.
    inputs: &'static [&'static str],
    /// Terminals recorded: `module.point`.
    outputs: &'static [&'static str],
}

impl Case {
    fn dir(&self) -> PathBuf {
        // Cargo's scratch folder for integration tests (under target/), one per case.
        let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("offload-{}", self.name));
        std::fs::create_dir_all(&dir).unwrap();
        let text = if self.lang == Lang::Ladder {
            let mut t = String::from("rungs:\n");
            for rung in self.program.lines() {
                let _ = writeln!(t, "  - \"{rung}\"");
            }
            t
        } else {
            self.program.to_string()
        };
        std::fs::write(dir.join(self.file()), text).unwrap();
        dir
    }

    fn file(&self) -> &'static str {
        match self.lang {
            Lang::Expr => "program.expr",
            Lang::Ladder => "program.yaml",
            Lang::Rhai => "program.rhai",
        }
    }

    fn text(&self, mode: &str) -> String {
        let mut t = String::new();
        let _ = writeln!(
            t,
            "project: {}\nscan: {{ period: {}ms }}",
            self.name, self.period_ms
        );
        let _ = writeln!(t, "offload: {mode}");
        let _ = writeln!(
            t,
            "buses:\n  - {{ name: line1, port: sim, baud: 57600, response_timeout: 50ms }}"
        );
        let _ = writeln!(t, "modules:");
        for m in self.modules {
            let _ = writeln!(t, "  - {{ bus: line1, {m} }}");
        }
        let _ = writeln!(t, "tags:");
        for tag in self.tags {
            let _ = writeln!(t, "  - {{ {tag} }}");
        }
        let kind = match self.lang {
            Lang::Expr => "expr",
            Lang::Ladder => "ladder",
            Lang::Rhai => "rhai",
        };
        let _ = writeln!(t, "program: {{ file: {}, kind: {kind} }}", self.file());
        t
    }

    fn project(&self, mode: &str) -> Project {
        let dir = self.dir();
        let path = dir.join("project.yaml");
        std::fs::write(&path, self.text(mode)).unwrap();
        project::parse_str(&self.text(mode), &path)
            .unwrap_or_else(|e| panic!("{}: the project is valid:\n{e}", self.name))
    }
}

/// Three inputs and four outputs of one MiniMod.
const ABC_Y1_Y4: [&str; 7] = [
    "name: a, point: mm1.X1",
    "name: b, point: mm1.X2",
    "name: c, point: mm1.X3",
    "name: y1, point: mm1.Y1",
    "name: y2, point: mm1.Y2",
    "name: y3, point: mm1.Y3",
    "name: y4, point: mm1.Y4",
];

/// A random input sequence: from 1 s on, every `gap` (random in `min_gap..=3 × min_gap`) one
/// or more inputs flip.
fn schedule(inputs: usize, seed: u64, min_gap: Duration, until: Duration) -> Vec<Vec<Edge>> {
    let mut rng = Rng(seed);
    let mut out = vec![Vec::new(); inputs];
    let mut levels = vec![false; inputs];
    let mut t = ms(1000);
    let gap = min_gap.as_millis() as u64;
    while t < until {
        let flips = rng.range(1, (1u64 << inputs) - 1);
        for (i, level) in levels.iter_mut().enumerate() {
            if flips & (1 << i) != 0 {
                *level = !*level;
                out[i].push((t, *level));
            }
        }
        t += ms(rng.range(gap, 3 * gap));
    }
    out
}

/// Runs `project` for `run_for` with the inputs played; the output traces.
fn run(case: &Case, project: Project, inputs: &[Vec<Edge>], run_for: Duration) -> Vec<Vec<Edge>> {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project, clock).unwrap_or_else(|e| panic!("{}: builds: {e}", case.name));
    let trace = Arc::new(Mutex::new(vec![Vec::new(); case.outputs.len()]));
    {
        let world = plc.world().expect("a simulated line");
        let mut world = world.lock().unwrap();
        let wires = case
            .inputs
            .iter()
            .chain(case.outputs)
            .map(|t| {
                let (module, point) = t.split_once('.').unwrap();
                (world.find(module).unwrap(), point.to_string())
            })
            .collect();
        world.set_plant(
            Box::new(Recorder {
                origin: plc.clock().now().on_line_clock(),
                schedule: inputs.to_vec(),
                next: vec![0; inputs.len()],
                outputs: case.outputs.len(),
                last: vec![false; case.outputs.len()],
                trace: trace.clone(),
            }),
            wires,
        );
    }
    // Which cycles ended with a line still writing past their period (the overruns).
    let late = Arc::new(Mutex::new(Vec::new()));
    let late_sink = late.clone();
    let period = ms(case.period_ms);
    let mut engine = ScanEngine::new(plc)
        .run_for(run_for)
        .on_cycle(Box::new(move |plc, ctx| {
            let overran = match plc.cycle_work() {
                CycleWork::Done => false,
                CycleWork::At(t) => t > ctx.now + period,
                CycleWork::Later => true,
            };
            if overran {
                late_sink.lock().unwrap().push(ctx.cycle);
            }
        }));
    let outcome = engine.run();
    // The first cycle reads every module in full and writes every output (the start-up's
    // refresh), longer than a 50 ms period on one line; no other cycle may overrun.
    let late = late.lock().unwrap().clone();
    assert!(
        late.iter().all(|&c| c == 1),
        "{}: only the first cycle overruns: {late:?}",
        case.name
    );
    assert_eq!(
        outcome.stats.overruns,
        late.len() as u64,
        "{}: no other overrun",
        case.name
    );
    let trace = trace.lock().unwrap().clone();
    // The shutdown's safe state is not part of the comparison: the inputs stop changing 1 s
    // before the end, and every reaction is over within half a second.
    let end = run_for.saturating_sub(ms(500));
    trace
        .into_iter()
        .map(|t| t.into_iter().filter(|(at, _)| *at < end).collect())
        .collect()
}

/// The level of a trace just before `t`.
fn level_before(trace: &[Edge], t: Duration) -> bool {
    trace
        .iter()
        .take_while(|(at, _)| *at < t)
        .last()
        .is_some_and(|(_, v)| *v)
}

/// The plans of both builds and the central reaction bound of the line.
fn plans(case: &Case) -> (Project, Project, Duration) {
    let never = case.project("never");
    let auto = case.project("auto");
    let image =
        softplc::image::ProcessImage::new(never.tags.iter().map(|t| (t.name.clone(), t.initial)));
    let engine = softplc::logic::load_program(&never, &image).unwrap();
    let plan = softplc::offload::plan_program(&never, engine.as_ref());
    let bound = softplc::offload::central_bound(&never, &plan, 0);
    (never, auto, bound)
}

/// Which outputs the auto build pushes down, by coil name.
fn pushed(project: &Project) -> Vec<(String, bool)> {
    let image =
        softplc::image::ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
    let engine = softplc::logic::load_program(project, &image).unwrap();
    let plan = softplc::offload::plan_program(project, engine.as_ref());
    plan.rungs
        .iter()
        .map(|r| (r.coil.clone(), matches!(r.placement, Placement::Module(_))))
        .collect()
}

/// Level equivalence of two traces (see the module docs). When the rung stayed central in the
/// auto build too (`in_module` false), only the timing of the two scans differs (the auto
/// build reads its pushed-down outputs back), in either direction.
fn same_levels(
    name: &str,
    central: &[Edge],
    pushed: &[Edge],
    from: Duration,
    bound: Duration,
    in_module: bool,
    tick: Duration,
) {
    assert_eq!(
        level_before(central, from),
        level_before(pushed, from),
        "{name}: level before the first input change"
    );
    let c: Vec<Edge> = central.iter().copied().filter(|e| e.0 >= from).collect();
    let p: Vec<Edge> = pushed.iter().copied().filter(|e| e.0 >= from).collect();
    assert_eq!(
        c.len(),
        p.len(),
        "{name}: edge count\ncentral {c:?}\npushed  {p:?}"
    );
    assert!(!c.is_empty(), "{name}: the inputs exercise the output");
    if in_module {
        // The module really drives it: on average it leads the scan by much more than a tick
        // (half a period, plus the bus).
        let lead: Duration = c
            .iter()
            .zip(&p)
            .map(|(ce, pe)| ce.0.saturating_sub(pe.0))
            .sum();
        let mean = lead / c.len() as u32;
        assert!(
            mean > bound / 4,
            "{name}: mean lead {mean:?} (bound {bound:?})"
        );
    }
    for (i, (ce, pe)) in c.iter().zip(&p).enumerate() {
        assert_eq!(ce.1, pe.1, "{name}: edge {i} direction");
        let early = if in_module { tick } else { bound };
        assert!(
            pe.0 <= ce.0 + early && ce.0 <= pe.0 + bound + tick,
            "{name}: edge {i}: central at {:?}, pushed at {:?}, bound {bound:?}",
            ce.0,
            pe.0
        );
    }
}

/// Runs a level case for three seeds; `expect_pushed` lists the coils in the order of
/// `case.outputs`, with whether the auto build places them in the module.
fn level_case(case: &Case, expect_pushed: &[(&str, bool)]) {
    let (never, auto, bound) = plans(case);
    let placed = pushed(&auto);
    for (coil, want) in expect_pushed {
        let got = placed.iter().find(|(c, _)| c == coil).map(|(_, p)| *p);
        assert_eq!(
            got,
            Some(*want),
            "{}: placement of {coil}: {placed:?}",
            case.name
        );
    }
    let period = ms(case.period_ms);
    let run_for = ms(30_000);
    for seed in [1u64, 2, 3] {
        let inputs = schedule(
            case.inputs.len(),
            seed,
            period * 2 + bound,
            run_for - ms(1000),
        );
        let central = run(case, never.clone(), &inputs, run_for);
        let pushed_traces = run(case, auto.clone(), &inputs, run_for);
        for (j, out) in case.outputs.iter().enumerate() {
            same_levels(
                &format!("{} seed {seed} {out}", case.name),
                &central[j],
                &pushed_traces[j],
                ms(1000),
                bound,
                expect_pushed[j].1,
                ms(case.tick_ms),
            );
        }
    }
}

#[test]
fn combinational_rungs_run_in_the_minimod() {
    let case = Case {
        name: "combinational",
        period_ms: 50,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: &ABC_Y1_Y4,
        program: "y1 = a & !b | c\ny2 = a ^ b\ny3 = a ^ b ^ c\ny4 = !c & (a | b)\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm1.X2", "mm1.X3"],
        outputs: &["mm1.Y1", "mm1.Y2", "mm1.Y3", "mm1.Y4"],
    };
    // Three-input parity needs four terms: it stays central (and must still match).
    level_case(
        &case,
        &[("y1", true), ("y2", true), ("y3", false), ("y4", true)],
    );
}

#[test]
fn latches_run_in_the_minimod() {
    let case = Case {
        name: "latches",
        period_ms: 50,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: &[
            "name: s, point: mm1.X1",
            "name: r, point: mm1.X2",
            "name: k, point: mm1.X3",
            "name: reset_wins, point: mm1.Y1",
            "name: set_wins, point: mm1.Y2",
            "name: keep_while, point: mm1.Y3",
        ],
        program: "reset_wins = (s | reset_wins) & !r\n\
                  set_wins = s | (set_wins & !r)\n\
                  keep_while = keep_while & k | s & k & !r\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm1.X2", "mm1.X3"],
        outputs: &["mm1.Y1", "mm1.Y2", "mm1.Y3"],
    };
    level_case(
        &case,
        &[
            ("reset_wins", true),
            ("set_wins", true),
            ("keep_while", true),
        ],
    );
}

/// The plain Rhai forms (`c = E;` at the top level, once, over bool inputs) are the expr
/// statements of the same text: pushed down, they behave the same.
#[test]
fn rhai_plain_conditions_and_latches_run_in_the_minimod() {
    let case = Case {
        name: "rhai-plain",
        period_ms: 50,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: &ABC_Y1_Y4,
        program: "y1 = a && !b || c;\n\
                  y2 = a ^ b;\n\
                  y3 = (a || y3) && !b;\n\
                  if true { y4 = !c && (a || b); }\n",
        lang: Lang::Rhai,
        inputs: &["mm1.X1", "mm1.X2", "mm1.X3"],
        outputs: &["mm1.Y1", "mm1.Y2", "mm1.Y3", "mm1.Y4"],
    };
    // y4 is assigned inside `if`: central, and it must still match.
    level_case(
        &case,
        &[("y1", true), ("y2", true), ("y3", true), ("y4", false)],
    );
}

#[test]
fn debounced_inputs_are_the_same_for_both() {
    // Input conditioning is a module setting for both builds: the scan and the module see the
    // same cooked inputs.
    let case = Case {
        name: "debounced",
        period_ms: 50,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: &[
            "name: a, point: mm1.X1, debounce: 30ms",
            "name: b, point: mm1.X2, stretch: 80ms",
            "name: y, point: mm1.Y1",
        ],
        program: "y = a | b\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm1.X2"],
        outputs: &["mm1.Y1"],
    };
    level_case(&case, &[("y", true)]);
}

#[test]
fn central_rungs_keep_their_reason() {
    let case = Case {
        name: "reasons",
        period_ms: 50,
        tick_ms: 1,
        modules: &[
            "name: mm1, model: minimod, address: 1",
            "name: mm2, model: minimod, address: 2",
        ],
        tags: &[
            "name: a, point: mm1.X1",
            "name: b, point: mm2.X1",
            "name: m, type: bool",
            "name: y1, point: mm1.Y1",
            "name: y2, point: mm1.Y2",
            "name: y3, point: mm1.Y3",
            "name: y4, point: mm1.Y4, offload: never",
        ],
        program: "y1 = a & b\ny2 = ton(a, 1s)\ny3 = a | m\ny4 = a\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm2.X1"],
        outputs: &["mm1.Y1", "mm1.Y2", "mm1.Y3", "mm1.Y4"],
    };
    let auto = case.project("auto");
    let image =
        softplc::image::ProcessImage::new(auto.tags.iter().map(|t| (t.name.clone(), t.initial)));
    let engine = softplc::logic::load_program(&auto, &image).unwrap();
    let plan = softplc::offload::plan_program(&auto, engine.as_ref());
    let reasons: Vec<(String, Reason)> = plan
        .rungs
        .iter()
        .filter_map(|r| match &r.placement {
            Placement::Central(reason) => Some((r.coil.clone(), reason.clone())),
            Placement::Module(_) => None,
        })
        .collect();
    assert!(matches!(&reasons[0], (c, Reason::OtherModule { .. }) if c == "y1"));
    assert!(matches!(&reasons[1], (c, Reason::Opaque(why)) if c == "y2" && why.contains("timer")));
    assert!(matches!(&reasons[2], (c, Reason::Memory { .. }) if c == "y3"));
    assert!(
        matches!(&reasons[3], (c, Reason::Never { by_tag: true, would: Some(_) }) if c == "y4")
    );
    let report = softplc::offload::report(&auto, &plan);
    assert!(
        report.contains("an input from another module: b is on mm2"),
        "{report}"
    );
    // Nothing pushed down: the PLC builds and runs as with offload: never.
    let run_for = ms(5000);
    let inputs = schedule(2, 7, ms(300), run_for - ms(1000));
    let traces = run(&case, auto, &inputs, run_for);
    assert!(!traces[3].is_empty());
}

/// Pulse pairs (rise, fall) of a trace after `from`.
fn pulses(trace: &[Edge], from: Duration) -> Vec<(Duration, Duration)> {
    let mut out = Vec::new();
    let mut rise = None;
    for &(t, v) in trace.iter().filter(|e| e.0 >= from) {
        match (v, rise) {
            (true, _) => rise = Some(t),
            (false, Some(r)) => {
                out.push((r, t));
                rise = None;
            }
            (false, None) => {}
        }
    }
    out
}

#[test]
fn pulses_run_in_the_minimod_pulser_exactly() {
    let case = Case {
        name: "pulses",
        period_ms: 100,
        tick_ms: 1,
        // Polled: in event mode a round takes one event a slave, so inputs that change
        // together reach the program a cycle apart, and which cycle depends on the module's
        // full reads, which differ between the two builds (the central build's writes answer
        // for the module, `line/housekeeping.rs`). What is compared here is the pulser.
        modules: &["name: mm1, model: minimod, address: 1, settings: {events: false}"],
        tags: &[
            "name: a, point: mm1.X1",
            "name: b, point: mm1.X2",
            "name: c, point: mm1.X3",
            "name: short, point: mm1.Y1",
            "name: long, point: mm1.Y2",
        ],
        program: "short = tp(a, 50ms)\nlong = tp(b & !c, 130ms)\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm1.X2", "mm1.X3"],
        outputs: &["mm1.Y1", "mm1.Y2"],
    };
    let (never, auto, bound) = plans(&case);
    assert_eq!(
        pushed(&auto),
        vec![("short".to_string(), true), ("long".to_string(), true)]
    );
    let period = ms(case.period_ms);
    let run_for = ms(30_000);
    let write_tolerance = bound - period; // the same cycle's write phase, give or take
    for seed in [11u64, 12] {
        let inputs = schedule(3, seed, period * 2 + bound, run_for - ms(1000));
        let central = run(&case, never.clone(), &inputs, run_for);
        let pushed_traces = run(&case, auto.clone(), &inputs, run_for);
        for (j, width) in [(0usize, ms(50)), (1, ms(130))] {
            let name = format!("pulses seed {seed} {}", case.outputs[j]);
            let c = pulses(&central[j], ms(1000));
            let p = pulses(&pushed_traces[j], ms(1000));
            assert_eq!(c.len(), p.len(), "{name}: pulse count\n{c:?}\n{p:?}");
            assert!(!c.is_empty(), "{name}: the inputs trigger pulses");
            let scans = width.as_millis().div_ceil(period.as_millis()) as u32;
            for (i, (cp, pp)) in c.iter().zip(&p).enumerate() {
                assert!(
                    cp.0.abs_diff(pp.0) <= write_tolerance,
                    "{name}: pulse {i} starts at {:?} central, {:?} pushed",
                    cp.0,
                    pp.0
                );
                let pw = pp.1 - pp.0;
                assert!(
                    pw.abs_diff(width) <= ms(2),
                    "{name}: pulse {i} lasts {pw:?} in the module, preset {width:?}"
                );
                let cw = cp.1 - cp.0;
                assert!(
                    cw >= width && cw.abs_diff(period * scans) <= write_tolerance,
                    "{name}: pulse {i} lasts {cw:?} centrally ({scans} scans)"
                );
            }
        }
    }
}

#[test]
fn the_example_project_pushes_its_fast_rungs() {
    let path: PathBuf = softplc_tests::workspace_root().join("examples/pushdown/project.yaml");
    let project = project::load(Path::new(&path)).unwrap_or_else(|e| panic!("{e}"));
    let placed = pushed(&project);
    assert_eq!(
        placed,
        vec![
            ("press_enable".to_string(), true),
            ("pump".to_string(), true),
            ("ejector".to_string(), true),
            ("alarm".to_string(), false),
            ("beacon".to_string(), false),
        ]
    );
    // The tables are in the modules' registers once the PLC is built (start-up verified them).
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project, clock).unwrap();
    let world = plc.world().unwrap().lock().unwrap();
    let reg = |m: &str, p: &str| world.get(world.find(m).unwrap(), p).unwrap();
    use softplc_io::point::Value;
    assert_eq!(reg("mm1", "Y1AON1"), Value::U16(0x0001)); // X1, OFF wins below
    assert_eq!(reg("mm1", "Y1AOFF1"), Value::U16(0x0101)); // -X1
    assert_eq!(reg("mm1", "XLATUP2"), Value::U16(20));
    assert_eq!(reg("mm2", "Y1AON1"), Value::U16(0x0001)); // start
    assert_eq!(reg("mm2", "Y1AOFF2"), Value::U16(0x0004)); // level_high
    assert_eq!(reg("mm3", "XLATDN1"), Value::U16(150));
}

/// A case for a project loaded from its file (its modules, tags and program are the file's),
/// at a 100 ms scan on MiniMods.
fn loaded_case(
    name: &'static str,
    inputs: &'static [&'static str],
    outputs: &'static [&'static str],
) -> Case {
    Case {
        name,
        period_ms: 100,
        tick_ms: 1,
        modules: &[],
        tags: &[],
        program: "",
        lang: Lang::Expr,
        inputs,
        outputs,
    }
}

#[test]
fn the_example_project_behaves_the_same_pushed_down_and_faster() {
    // The example's own inputs (the guard, the hands, start/stop, the level, parts) played
    // against both builds: every output matches, and the pushed ones lead.
    let path: PathBuf = softplc_tests::workspace_root().join("examples/pushdown/project.yaml");
    let auto = project::load(Path::new(&path)).unwrap_or_else(|e| panic!("{e}"));
    let mut never = auto.clone();
    never.offload.mode = softplc::project::OffloadMode::Never;
    for t in &mut never.offload.tags {
        t.mode = None; // press_enable says `require`
    }
    let case = loaded_case(
        "example",
        &["mm1.X1", "mm1.X2", "mm1.X3", "mm2.X1", "mm2.X2", "mm2.X3"],
        &["mm1.Y1", "mm2.Y1", "mm1.Y4", "mm2.Y2"],
    );
    let image =
        softplc::image::ProcessImage::new(never.tags.iter().map(|t| (t.name.clone(), t.initial)));
    let engine = softplc::logic::load_program(&never, &image).unwrap();
    let plan = softplc::offload::plan_program(&never, engine.as_ref());
    let bound = softplc::offload::central_bound(&never, &plan, 0);
    let run_for = ms(30_000);
    let inputs = schedule(6, 5, ms(200) + bound, run_for - ms(1000));
    let central = run(&case, never, &inputs, run_for);
    let pushed_traces = run(&case, auto, &inputs, run_for);
    for (j, in_module) in [(0, true), (1, true), (2, false), (3, false)] {
        same_levels(
            &format!("example {}", case.outputs[j]),
            &central[j],
            &pushed_traces[j],
            ms(1000),
            bound,
            in_module,
            ms(1),
        );
    }
}

#[test]
fn edge_functions_run_in_the_resi_16di8ro() {
    let case = Case {
        name: "resi",
        period_ms: 50,
        tick_ms: 10,
        modules: &["name: r1, model: resi-16di8ro, address: 1"],
        tags: &[
            "name: on_button, point: r1.DI1",
            "name: off_button, point: r1.DI2",
            "name: push, point: r1.DI3",
            "name: level, point: r1.DI4",
            "name: hall, point: r1.RO1",
            "name: stairs, point: r1.RO2",
            "name: pump, point: r1.RO3",
            "name: mixed, point: r1.RO4",
        ],
        program: "hall = (rising(on_button) | hall) & !rising(off_button)\n\
                  stairs = stairs ^ (rising(push) | rising(on_button))\n\
                  pump = level\n\
                  mixed = level & push\n",
        lang: Lang::Expr,
        inputs: &["r1.DI1", "r1.DI2", "r1.DI3", "r1.DI4"],
        outputs: &["r1.RO1", "r1.RO2", "r1.RO3", "r1.RO4"],
    };
    // SWITCH follows one input: `level & push` stays central.
    level_case(
        &case,
        &[
            ("hall", true),
            ("stairs", true),
            ("pump", true),
            ("mixed", false),
        ],
    );
}

#[test]
fn stop_clears_the_tables_or_keeps_them() {
    use softplc_io::point::Value;
    let mut case = Case {
        name: "stop",
        period_ms: 50,
        tick_ms: 1,
        modules: &[
            "name: mm1, model: minimod, address: 1",
            "name: r1, model: resi-16di8ro, address: 2",
        ],
        tags: &[
            "name: a, point: mm1.X1",
            "name: y, point: mm1.Y1, safe: false",
            "name: on_button, point: r1.DI1",
            "name: off_button, point: r1.DI2",
            "name: hall, point: r1.RO1, safe: false",
            "name: level, point: r1.DI3",
            "name: pump, point: r1.RO2, safe: false",
        ],
        // `pump` follows its input (SWITCH, a level): its table must be gone before the relay
        // is set safe, or the next 10 ms sample would switch it on again.
        program: "y = a\nhall = (rising(on_button) | hall) & !rising(off_button)\npump = level\n",
        lang: Lang::Expr,
        inputs: &[],
        outputs: &[],
    };
    for (mode, cleared) in [("auto", true), ("{ mode: auto, on_stop: keep }", false)] {
        case.name = if cleared { "stop-clear" } else { "stop-keep" };
        let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
        let plc = Plc::build(case.project(mode), clock).unwrap();
        let world = plc.world().unwrap().clone();
        {
            let mut w = world.lock().unwrap();
            let (mm1, r1) = (w.find("mm1").unwrap(), w.find("r1").unwrap());
            w.set(mm1, "X1", Value::Bool(true)).unwrap();
            w.set(r1, "DI1", Value::Bool(true)).unwrap();
            w.set(r1, "DI3", Value::Bool(true)).unwrap();
        }
        let mut engine = ScanEngine::new(plc).max_cycles(10);
        let outcome = engine.run();
        assert_eq!(outcome.stats.overruns, 0);
        let mut w = world.lock().unwrap();
        let t = w.now() + ms(100);
        w.advance_to(t);
        let (mm1, r1) = (w.find("mm1").unwrap(), w.find("r1").unwrap());
        let get = |d: usize, p: &str| w.get(d, p).unwrap();
        if cleared {
            assert_eq!(get(mm1, "Y1AON1"), Value::U16(0), "tables cleared");
            assert_eq!(
                get(mm1, "Y1"),
                Value::Bool(false),
                "safe value, X1 still on"
            );
            assert_eq!(get(r1, "SWITCH_ON_RO1"), Value::U16(0));
            assert_eq!(get(r1, "RO1"), Value::Bool(false));
            assert_eq!(get(r1, "SWITCH_RO2"), Value::U16(0));
            assert_eq!(get(r1, "RO2"), Value::Bool(false), "DI3 still on");
        } else {
            assert_eq!(get(mm1, "Y1AON1"), Value::U16(1), "tables kept");
            assert_eq!(
                get(mm1, "Y1"),
                Value::Bool(true),
                "the module keeps driving"
            );
            assert_eq!(get(r1, "SWITCH_ON_RO1"), Value::U16(1));
            assert_eq!(get(r1, "RO1"), Value::Bool(true));
            assert_eq!(get(r1, "RO2"), Value::Bool(true));
        }
    }
}

#[test]
fn ladder_latches_run_in_the_minimod() {
    let case = Case {
        name: "ladder-latches",
        period_ms: 50,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: &ABC_Y1_Y4,
        program: "a -> SR l1(r=b) -> y1\n\
                  c -> RS l2(r=a) -> y2\n\
                  b -> set y3\n\
                  c -> reset y3\n\
                  a /c -> y4",
        lang: Lang::Ladder,
        inputs: &["mm1.X1", "mm1.X2", "mm1.X3"],
        outputs: &["mm1.Y1", "mm1.Y2", "mm1.Y3", "mm1.Y4"],
    };
    level_case(
        &case,
        &[("y1", true), ("y2", true), ("y3", true), ("y4", true)],
    );
}

#[test]
fn ladder_blocks_run_in_the_resi_16di8ro() {
    let case = Case {
        name: "ladder-resi",
        period_ms: 50,
        tick_ms: 10,
        modules: &["name: r1, model: resi-16di8ro, address: 1"],
        tags: &[
            "name: on_button, point: r1.DI1",
            "name: off_button, point: r1.DI2",
            "name: push, point: r1.DI3",
            "name: level, point: r1.DI4",
            "name: stairs, point: r1.RO1",
            "name: lamp, point: r1.RO2",
            "name: hall, point: r1.RO3",
            "name: pump, point: r1.RO4",
        ],
        program: "push -> STAIR s(300ms) -> stairs\n\
                  on_button -> TOGGLE t -> lamp\n\
                  rising(on_button) -> set hall\n\
                  rising(off_button) -> reset hall\n\
                  level -> pump",
        lang: Lang::Ladder,
        inputs: &["r1.DI1", "r1.DI2", "r1.DI3", "r1.DI4"],
        outputs: &["r1.RO1", "r1.RO2", "r1.RO3", "r1.RO4"],
    };
    // A staircase of a whole number of scans: the central pulse ends as the module's does.
    level_case(
        &case,
        &[
            ("stairs", true),
            ("lamp", true),
            ("hall", true),
            ("pump", true),
        ],
    );
}

#[test]
fn pushed_outputs_belong_to_their_module() {
    use softplc::logic::ScanContext;
    use softplc_io::point::Value;
    let case = Case {
        name: "ownership",
        period_ms: 50,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: &[
            "name: a, point: mm1.X1",
            "name: y, point: mm1.Y1, safe: false",
            "name: seen, type: bool",
        ],
        program: "y = a\nseen = y\n",
        lang: Lang::Expr,
        inputs: &[],
        outputs: &[],
    };
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let mut plc = Plc::build(case.project("auto"), clock.clone()).unwrap();
    assert!(plc.plan().pushed().count() == 1);
    {
        let world = plc.world().unwrap().clone();
        let mut w = world.lock().unwrap();
        let mm1 = w.find("mm1").unwrap();
        w.set(mm1, "X1", Value::Bool(true)).unwrap();
    }
    let y = plc.image().id("y").unwrap();
    let seen = plc.image().id("seen").unwrap();
    for cycle in 0..4 {
        let now = clock.now();
        plc.read_inputs();
        let ctx = ScanContext {
            now,
            delta: ms(50),
            cycle,
        };
        plc.run_logic(&ctx).unwrap();
        plc.write_outputs();
        clock.sleep_until(now + ms(50));
    }
    // The module switched Y1 on; the image shows it, and the program reads it.
    assert_eq!(plc.image().get(y), Value::Bool(true));
    assert_eq!(plc.image().get(seen), Value::Bool(true));
    let refused = plc.force("y", "0").unwrap_err().to_string();
    assert!(refused.contains("driven by its module"), "{refused}");
    // Its input is read by the module's own logic, which a force cannot reach: refused too.
    let refused = plc.force("a", "0").unwrap_err().to_string();
    assert!(
        refused.contains("read by the module's own logic for y"),
        "{refused}"
    );
    // A reload that keeps the placement is taken; one that moves a rung is refused.
    if let Err(e) = plc.reload_program() {
        panic!("the same program reloads: {e}");
    }
    std::fs::write(case.dir().join("program.expr"), "y = a & seen\nseen = y\n").unwrap();
    let refused = plc.reload_program().unwrap_err().to_string();
    assert!(refused.contains("moves rungs"), "{refused}");
}

// --- Beyond steady state: prior module state, kill -9 and restart, bus loss, forcing, stop,
// inputs shorter than a scan ---

/// Simulated modules that outlive a PLC, as a real machine does: a PLC killed with `kill -9`
/// and the next one started on the same modules see the same module state (outputs, tables,
/// FRAM, the module's clock).
///
/// `Plc::build` makes its simulated world from the project's model specs, so the test gives
/// the project a copy of each spec whose simulator constructor hands out a shared handle to
/// this thread's module at that address (each test runs on its own thread).
mod machine {
    use softplc_io::time::LineInstant;
    use std::cell::RefCell;
    use std::sync::{Arc, Mutex};

    use softplc::project::Project;
    use softplc_io::devices::{self, ModelSpec, Protocol};
    use softplc_io::point::{PointSpec, Value};
    use softplc_io::sim::{SimDevice, SimError, SimReply};

    type Module = Arc<Mutex<Box<dyn SimDevice>>>;

    thread_local! {
        static MODULES: RefCell<Vec<(&'static str, u8, Module)>> = const { RefCell::new(Vec::new()) };
    }

    /// A handle on a module of the machine.
    #[derive(Debug, Clone)]
    pub(crate) struct Shared(Module);

    impl Shared {
        fn lock(&self) -> std::sync::MutexGuard<'_, Box<dyn SimDevice>> {
            self.0.lock().unwrap_or_else(|e| e.into_inner())
        }
    }

    impl SimDevice for Shared {
        fn model(&self) -> &'static str {
            self.lock().model()
        }
        fn address(&self) -> u8 {
            self.lock().address()
        }
        fn advance_to(&mut self, t: LineInstant) {
            self.lock().advance_to(t);
        }
        fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply> {
            self.lock().on_frame(frame, t)
        }
        fn points(&self) -> &'static [PointSpec] {
            self.lock().points()
        }
        fn get(&self, point: &str) -> Result<Value, SimError> {
            self.lock().get(point)
        }
        fn set(&mut self, point: &str, value: Value) -> Result<(), SimError> {
            self.lock().set(point, value)
        }
        fn command(&mut self, words: &[&str]) -> Result<String, SimError> {
            self.lock().command(words)
        }
        fn yields_to_earlier_reply(&self, frame: &[u8]) -> bool {
            self.lock().yields_to_earlier_reply(frame)
        }
        fn set_protocol(&mut self, protocol: Protocol) -> Result<(), SimError> {
            self.lock().set_protocol(protocol)
        }
        fn command_help(&self) -> &'static str {
            self.lock().command_help()
        }
    }

    /// The machine's module of `model` at `address` (made on first use, powered on).
    pub(crate) fn module(model: &'static str, address: u8) -> Shared {
        MODULES.with(|m| {
            let mut m = m.borrow_mut();
            if let Some((_, _, d)) = m.iter().find(|(n, a, _)| *n == model && *a == address) {
                return Shared(d.clone());
            }
            let spec = devices::model(model).expect("a model of the catalog");
            let d: Module = Arc::new(Mutex::new((spec.simulator)(address)));
            m.push((model, address, d.clone()));
            Shared(d)
        })
    }

    /// A new machine: the next PLC gets modules fresh from the factory.
    pub(crate) fn replace() {
        MODULES.with(|m| m.borrow_mut().clear());
    }

    fn minimod(address: u8) -> Box<dyn SimDevice> {
        Box::new(module("minimod", address))
    }

    fn resi(address: u8) -> Box<dyn SimDevice> {
        Box::new(module("resi-16di8ro", address))
    }

    /// `project` on this thread's machine.
    pub(crate) fn on_machine(mut project: Project) -> Project {
        for m in &mut project.modules {
            let simulator: fn(u8) -> Box<dyn SimDevice> = match m.model.name {
                "minimod" => minimod,
                "resi-16di8ro" => resi,
                other => panic!("no machine module for {other}"),
            };
            let spec = m.model;
            let shared: &'static ModelSpec = Box::leak(Box::new(ModelSpec {
                simulator,
                addresses: spec.addresses.clone(),
                ..*spec
            }));
            m.model = shared;
        }
        project
    }
}

use machine::{module, on_machine};
use softplc::logic::ScanContext;
use softplc_io::point::Value;
use softplc_io::sim::SimDevice;
use softplc_io::time::{LineInstant, ScanInstant};

/// A PLC on this thread's machine, scanned cycle by cycle: dropping it is a `kill -9` (no
/// safe state, the tables stay armed); [`Session::stop`] is the clean stop. Input schedules and
/// the recorded output traces count from the session's first scan.
struct Session {
    plc: Plc,
    origin: ScanInstant,
    cycle: u64,
    trace: Arc<Mutex<Vec<Vec<Edge>>>>,
}

impl Session {
    fn start(
        case: &Case,
        project: Project,
        clock: &Arc<VirtualClock>,
        inputs: &[Vec<Edge>],
    ) -> Self {
        let dyn_clock: Arc<dyn Clock> = clock.clone();
        let plc = Plc::build(on_machine(project), dyn_clock)
            .unwrap_or_else(|e| panic!("{}: builds: {e}", case.name));
        let origin = clock.now();
        let trace = Arc::new(Mutex::new(vec![Vec::new(); case.outputs.len()]));
        {
            let world = plc.world().expect("a simulated line");
            let mut world = world.lock().unwrap();
            let wires = case
                .inputs
                .iter()
                .chain(case.outputs)
                .map(|t| {
                    let (m, point) = t.split_once('.').unwrap();
                    (world.find(m).unwrap(), point.to_string())
                })
                .collect();
            let mut schedule = inputs.to_vec();
            schedule.resize(case.inputs.len(), Vec::new());
            world.set_plant(
                Box::new(Recorder {
                    // The simulated world keeps the virtual clock's time.
                    origin: origin.on_line_clock(),
                    next: vec![0; schedule.len()],
                    schedule,
                    outputs: case.outputs.len(),
                    last: vec![false; case.outputs.len()],
                    trace: trace.clone(),
                }),
                wires,
            );
        }
        Self {
            plc,
            origin,
            cycle: 0,
            trace,
        }
    }

    /// Scans until `t` after the first scan.
    fn run_until(&mut self, t: Duration) {
        let clock = self.plc.clock().clone();
        let period = self.plc.project().scan.period;
        while clock.now() < self.origin + t {
            let now = clock.now();
            self.plc.read_inputs();
            let ctx = ScanContext {
                now,
                delta: period,
                cycle: self.cycle,
            };
            self.plc.run_logic(&ctx).unwrap();
            self.plc.write_outputs();
            self.cycle += 1;
            clock.sleep_until(now + period);
        }
        self.world(|_| ());
    }

    /// The clean stop: the safe state (tables cleared unless kept), the lines stopped.
    fn stop(mut self) {
        self.plc.shutdown();
    }

    /// Runs `f` on the world, brought up to the clock's time.
    fn world<R>(&self, f: impl FnOnce(&mut softplc_io::sim::SimWorld) -> R) -> R {
        let world = self.plc.world().expect("a simulated line").clone();
        let mut w = world.lock().unwrap();
        let now = self.plc.clock().now();
        w.advance_to(now.on_line_clock());
        f(&mut w)
    }

    fn trace(&self) -> Vec<Vec<Edge>> {
        self.trace.lock().unwrap().clone()
    }
}

/// A level of `module.point` of the machine.
fn level(m: &machine::Shared, point: &str) -> bool {
    m.get(point).unwrap().as_bool()
}

/// A press of `len` from `at` (a schedule of one input).
fn press(at: u64, len: u64) -> Vec<Edge> {
    vec![(ms(at), true), (ms(at + len), false)]
}

/// The edges of a trace from `from` on.
fn after(trace: &[Edge], from: Duration) -> Vec<Edge> {
    trace.iter().copied().filter(|e| e.0 >= from).collect()
}

/// The logic registers a MiniMod start-up must leave cleared (or set by its plan).
const MINIMOD_LOGIC: [&str; 28] = [
    "Y1AON1", "Y1AON2", "Y1AON3", "Y2AON1", "Y2AON2", "Y2AON3", "Y3AON1", "Y3AON2", "Y3AON3",
    "Y4AON1", "Y4AON2", "Y4AON3", "Y1AOFF1", "Y1AOFF2", "Y1AOFF3", "Y2AOFF1", "Y2AOFF2", "Y2AOFF3",
    "Y3AOFF1", "Y3AOFF2", "Y3AOFF3", "Y4AOFF1", "Y4AOFF2", "Y4AOFF3", "YPULSE1", "YPULSE2",
    "YLAMP1", "YLAMP2",
];

/// Every non-zero logic register of a RESI-16DI8RO.
fn resi_logic(m: &machine::Shared) -> Vec<String> {
    let mut names = vec!["ENABLE_LOGIC_FUNCTIONS".to_string()];
    for f in [
        "SWITCH",
        "TOGGLE",
        "SWITCH_ON",
        "SWITCH_OFF",
        "PULSE",
        "PULSE_TIME",
    ] {
        names.extend((1..=8).map(|r| format!("{f}_RO{r}")));
    }
    names
        .into_iter()
        .filter(|n| m.get(n).unwrap().as_bool())
        .collect()
}

const MM_LATCH_TAGS: &[&str] = &[
    "name: start, point: mm1.X1",
    "name: stop, point: mm1.X2",
    "name: x3, point: mm1.X3",
    "name: motor, point: mm1.Y2, safe: false",
];

#[test]
fn tables_a_crashed_run_left_do_not_drive_the_next_program() {
    // The run that crashes pushes `y2 = (x1 | y2) & !x2` into the MiniMod.
    let crashed = Case {
        name: "crash-before",
        period_ms: 100,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: MM_LATCH_TAGS,
        program: "motor = (start | motor) & !stop\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm1.X2", "mm1.X3"],
        outputs: &["mm1.Y2"],
    };
    // The next project keeps everything central and drives the output from X3 only.
    let next = Case {
        name: "crash-after",
        program: "motor = x3\n",
        ..crashed
    };
    let mm1 = module("minimod", 1);
    let clock = Arc::new(VirtualClock::new());
    let mut a = Session::start(
        &crashed,
        crashed.project("auto"),
        &clock,
        &[press(300, 300)],
    );
    a.run_until(ms(1000));
    assert!(level(&mm1, "Y2"), "the module latched the start press");
    assert_eq!(mm1.get("Y2AON1"), Ok(Value::U16(0x0001)));
    drop(a); // kill -9: no clean stop, the tables stay armed
    clock.sleep_until(clock.now() + ms(2000));

    // X1 held for a second, then X3 pressed: only X3 may switch the output.
    let inputs = [press(500, 1000), vec![], press(2000, 500)];
    let mut b = Session::start(&next, next.project("never"), &clock, &inputs);
    // Start-up cleared every logic register and read it back before the first scan.
    for name in MINIMOD_LOGIC {
        assert_eq!(mm1.get(name), Ok(Value::U16(0)), "{name} after start-up");
    }
    b.run_until(ms(3500));
    let trace = b.trace();
    let bound = plans(&next).2;
    let edges = after(&trace[0], ms(200));
    assert_eq!(
        edges.len(),
        2,
        "X1 held does not switch Y2; X3 does: {edges:?}"
    );
    assert!(edges[0].1 && edges[0].0 >= ms(2000) && edges[0].0 <= ms(2000) + bound);
    assert!(!edges[1].1 && edges[1].0 >= ms(2500) && edges[1].0 <= ms(2500) + bound);
    // The same program on a module that never saw the crashed run gives the same trace.
    drop(b);
    machine::replace();
    let fresh_clock = Arc::new(VirtualClock::new());
    let mut fresh = Session::start(&next, next.project("never"), &fresh_clock, &inputs);
    fresh.run_until(ms(3500));
    assert_eq!(after(&fresh.trace()[0], ms(200)), edges);
}

#[test]
fn resi_tables_in_fram_survive_a_power_cycle_and_are_cleared_at_start_up() {
    let crashed = Case {
        name: "fram-before",
        period_ms: 100,
        tick_ms: 10,
        modules: &["name: r1, model: resi-16di8ro, address: 1"],
        tags: &[
            "name: button, point: r1.DI1",
            "name: level, point: r1.DI3",
            "name: other, point: r1.DI5",
            "name: lamp, point: r1.RO4, safe: false",
            "name: pump, point: r1.RO1, safe: false",
        ],
        program: "lamp = lamp ^ rising(button)\npump = level\n",
        lang: Lang::Expr,
        inputs: &["r1.DI1", "r1.DI3", "r1.DI5"],
        outputs: &["r1.RO4", "r1.RO1"],
    };
    let next = Case {
        name: "fram-after",
        program: "lamp = other\npump = other\n",
        ..crashed
    };
    let r1 = module("resi-16di8ro", 1);
    let clock = Arc::new(VirtualClock::new());
    let mut a = Session::start(
        &crashed,
        crashed.project("auto"),
        &clock,
        &[press(300, 200)],
    );
    a.run_until(ms(1000));
    assert!(level(&r1, "RO4"), "TOGGLE switched the lamp on");
    drop(a); // kill -9
             // The module loses power too; its tables are in FRAM (L16434–L16436).
    r1.clone().command(&["power-cycle"]).unwrap();
    assert_eq!(
        resi_logic(&r1),
        ["ENABLE_LOGIC_FUNCTIONS", "SWITCH_RO1", "TOGGLE_RO4"],
        "kept across the power cycle"
    );
    clock.sleep_until(clock.now() + ms(2000));
    // The button pressed twice, the level held: neither may touch the relays now.
    let inputs = [
        vec![
            (ms(500), true),
            (ms(700), false),
            (ms(900), true),
            (ms(1100), false),
        ],
        press(500, 1500),
        press(2500, 500),
    ];
    let mut b = Session::start(&next, next.project("never"), &clock, &inputs);
    assert_eq!(resi_logic(&r1), Vec::<String>::new(), "cleared at start-up");
    b.run_until(ms(3500));
    let trace = b.trace();
    let bound = plans(&next).2;
    for (j, name) in ["RO4", "RO1"].iter().enumerate() {
        let edges = after(&trace[j], ms(200));
        assert_eq!(edges.len(), 2, "{name} follows DI5 only: {edges:?}");
        // The module samples its inputs every 10 ms: the scan may see DI5 that much later.
        let late = bound + ms(10);
        assert!(
            edges[0].1 && edges[0].0 >= ms(2500) && edges[0].0 <= ms(2500) + late,
            "{name}: {edges:?}"
        );
        assert!(
            !edges[1].1 && edges[1].0 >= ms(3000) && edges[1].0 <= ms(3000) + late,
            "{name}: {edges:?}"
        );
    }
}

/// The latch of the kill -9 cases, on a MiniMod output.
fn motor_case(name: &'static str) -> Case {
    Case {
        name,
        period_ms: 100,
        tick_ms: 1,
        modules: &["name: mm1, model: minimod, address: 1"],
        tags: MM_LATCH_TAGS,
        program: "motor = (start | motor) & !stop\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm1.X2", "mm1.X3"],
        outputs: &["mm1.Y2"],
    }
}

#[test]
fn a_clean_stop_leaves_the_output_safe_and_the_inputs_without_effect_in_both() {
    for mode in ["never", "auto"] {
        machine::replace();
        let case = motor_case("stop-both");
        let mm1 = module("minimod", 1);
        let clock = Arc::new(VirtualClock::new());
        let mut s = Session::start(&case, case.project(mode), &clock, &[press(300, 300)]);
        s.run_until(ms(1000));
        assert!(level(&mm1, "Y2"), "{mode}: running");
        s.stop();
        // After the stop a start press changes nothing: no table is left in the module.
        mm1.clone().set("X1", Value::Bool(true)).unwrap();
        mm1.clone()
            .advance_to(clock.now().on_line_clock() + ms(500));
        assert!(!level(&mm1, "Y2"), "{mode}: safe value, start pressed");
        for name in MINIMOD_LOGIC {
            assert_eq!(mm1.get(name), Ok(Value::U16(0)), "{mode}: {name}");
        }
    }
}

/// Runs `case` in `mode` on this thread's machine as it is: `before` presses for the run that
/// is killed, then a restart of the same project with `after`; the restart's traces.
fn kill_and_restart(
    case: &Case,
    mode: &str,
    before: &[Vec<Edge>],
    after: &[Vec<Edge>],
) -> Vec<Vec<Edge>> {
    let clock = Arc::new(VirtualClock::new());
    let mut a = Session::start(case, case.project(mode), &clock, before);
    a.run_until(ms(1500));
    drop(a); // kill -9
    clock.sleep_until(clock.now() + ms(2000));
    let mut b = Session::start(case, case.project(mode), &clock, after);
    b.run_until(ms(4000));
    b.trace()
}

#[test]
fn a_latch_restarted_after_kill_9_needs_a_new_start_press_in_both() {
    // With the MiniMod's watchdog (armed by default) and without it.
    for (modules, fires) in [
        (&["name: mm1, model: minimod, address: 1"], true),
        (
            &["name: mm1, model: minimod, address: 1, watchdog: off"],
            false,
        ),
    ] {
        let case = Case {
            modules,
            ..motor_case("restart-latch")
        };
        let bound = plans(&case).2;
        // Started, then killed while running; after the restart start is pressed at 2 s and
        // stop at 3 s.
        let before = [press(300, 300)];
        let after = [press(2000, 200), press(3000, 200)];
        let mut traces = Vec::new();
        for mode in ["never", "auto"] {
            machine::replace();
            let mm1 = module("minimod", 1);
            let t = kill_and_restart(&case, mode, &before, &after);
            assert!(!level(&mm1, "Y2"), "{mode}: stopped at the end");
            traces.push(t.into_iter().next().unwrap_or_default());
        }
        let (central, pushed) = (&traces[0], &traces[1]);
        let name = format!("restart-latch (watchdog fires: {fires})");
        if fires {
            // The dead host fired the watchdog during the 2 s restart: Y2 is off (its safe
            // value) when the new run starts, in both builds.
            assert!(
                central.first().is_some_and(|e| e.0 >= ms(2000)),
                "{name}: {central:?}"
            );
        } else {
            // Central: Y2 is still on when the new run starts and goes off at its first write
            // (the latch starts reset).
            assert!(
                central.first().is_some_and(|e| e.1)
                    && central.get(1).is_some_and(|e| !e.1 && e.0 < bound),
                "{name}: {central:?}"
            );
        }
        // Pushed down: the start-up writes Y2 off before arming the tables, so the new run
        // never sees it on. Then both: on at the start press, off at stop.
        assert!(
            pushed.first().is_some_and(|e| e.0 >= ms(2000)),
            "{name}: {pushed:?}"
        );
        same_levels(&name, central, pushed, ms(1000), bound, true, ms(1));
    }
}

#[test]
fn a_toggle_restarted_after_kill_9_starts_off_in_both() {
    let case = Case {
        name: "restart-toggle",
        period_ms: 100,
        tick_ms: 10,
        modules: &["name: r1, model: resi-16di8ro, address: 1"],
        tags: &[
            "name: button, point: r1.DI1",
            "name: lamp, point: r1.RO4, safe: false",
        ],
        program: "lamp = lamp ^ rising(button)\n",
        lang: Lang::Expr,
        inputs: &["r1.DI1"],
        outputs: &["r1.RO4"],
    };
    let bound = plans(&case).2;
    let mut traces = Vec::new();
    for mode in ["never", "auto"] {
        machine::replace();
        let r1 = module("resi-16di8ro", 1);
        // Toggled on, killed; after the restart two presses: on at 2 s, off at 3 s.
        let after = [[press(2000, 300), press(3000, 300)].concat()];
        let t = kill_and_restart(&case, mode, &[press(300, 300)], &after);
        assert!(!level(&r1, "RO4"), "{mode}: toggled off at the end");
        traces.push(t.into_iter().next().unwrap_or_default());
    }
    assert_eq!(
        traces[0].first().map(|e| e.1),
        Some(true),
        "central: on until its first write"
    );
    assert_eq!(
        traces[1].first().map(|e| (e.0 >= ms(2000), e.1)),
        Some((true, true)),
        "pushed: off from start-up, on at the press"
    );
    same_levels(
        "restart-toggle",
        &traces[0],
        &traces[1],
        ms(1000),
        bound,
        true,
        ms(10),
    );
}

#[test]
fn prior_module_state_does_not_change_the_traces() {
    // A MiniMod and a RESI-16DI8RO as another controller left them: every output on, tables
    // on every output, a blinker and a pulse running, the relays' logic enabled.
    let case = Case {
        name: "prior",
        period_ms: 50,
        tick_ms: 10,
        modules: &[
            "name: mm1, model: minimod, address: 1",
            "name: r1, model: resi-16di8ro, address: 2",
        ],
        tags: &[
            "name: a, point: mm1.X1",
            "name: b, point: mm1.X2",
            "name: latch, point: mm1.Y1",
            "name: both, point: mm1.Y2",
            "name: on_button, point: r1.DI1",
            "name: off_button, point: r1.DI2",
            "name: lamp, point: r1.RO1",
            "name: hall, point: r1.RO2",
        ],
        program: "latch = (a | latch) & !b\nboth = a & b\n\
                  lamp = lamp ^ rising(on_button)\n\
                  hall = (rising(on_button) | hall) & !rising(off_button)\n",
        lang: Lang::Expr,
        inputs: &["mm1.X1", "mm1.X2", "r1.DI1", "r1.DI2"],
        outputs: &["mm1.Y1", "mm1.Y2", "r1.RO1", "r1.RO2"],
    };
    let prior = || {
        let mut mm1 = module("minimod", 1);
        for (p, v) in [
            ("Y1AON1", 0x0004), // X3
            ("Y2AON1", 0x0001),
            ("Y3AON1", 0x0101), // -X1
            ("YLAMP4", 0x00FF),
            ("YPULSE3", 60000),
            ("YWORD", 0x0F),
        ] {
            mm1.set(p, Value::U16(v)).unwrap();
        }
        let mut r1 = module("resi-16di8ro", 2);
        for (p, v) in [
            ("SWITCH_RO1", 0x0004),
            ("TOGGLE_RO2", 0x0001),
            ("SWITCH_ON_RO3", 0x0002),
            ("ENABLE_LOGIC_FUNCTIONS", 1),
            ("ROS", 0xFF),
        ] {
            r1.set(p, Value::U16(v)).unwrap();
        }
    };
    let (never, auto, bound) = plans(&case);
    assert_eq!(
        pushed(&auto).iter().filter(|(_, p)| *p).count(),
        4,
        "{:?}",
        pushed(&auto)
    );
    let run_for = ms(20_000);
    for seed in [4u64, 5] {
        let inputs = schedule(4, seed, ms(100) * 2 + bound, run_for - ms(1000));
        let mut traces = Vec::new();
        for project in [never.clone(), auto.clone()] {
            machine::replace();
            prior();
            let clock = Arc::new(VirtualClock::new());
            let mut s = Session::start(&case, project, &clock, &inputs);
            s.run_until(run_for);
            traces.push(s.trace());
        }
        for (j, out) in case.outputs.iter().enumerate() {
            // Every output was on when each build started; the first scan (central) or the
            // start-up (pushed down) sets it as the program says.
            same_levels(
                &format!("prior seed {seed} {out}"),
                &traces[0][j],
                &traces[1][j],
                ms(1000),
                bound,
                true,
                ms(case.tick_ms),
            );
        }
    }
}

/// Whether `edges` are `want` (time, level), each no earlier than its time and at most `late`
/// after it.
fn edges_near(edges: &[Edge], want: &[(u64, bool)], late: Duration) -> bool {
    edges.len() == want.len()
        && edges
            .iter()
            .zip(want)
            .all(|(e, &(t, v))| e.1 == v && e.0 >= ms(t) && e.0 <= ms(t) + late)
}

#[test]
fn bus_loss_in_the_middle_of_a_run() {
    // The module's own watchdog is off here: this is about the line (the watchdog's safe state
    // is tested with the drivers). Polled, pinned: a lost line is seen at the next poll (in
    // event mode, this line's default, only at the module's refresh).
    let case = Case {
        name: "bus-loss",
        modules: &[
            "name: mm1, model: minimod, address: 1, settings: { WDTTIME: 0, events: false }",
        ],
        ..motor_case("bus-loss")
    };
    let bound = plans(&case).2;
    // Start at 1 s; the line dies from 3 s to 4.5 s and stop is pressed at 3.5 s meanwhile;
    // start at 7 s, stop at 8 s, start at 9 s; the line dies again from 10 s to 11.5 s with
    // nobody at the buttons.
    let inputs = [
        [press(1000, 200), press(7000, 200), press(9000, 200)].concat(),
        [press(3500, 300), press(8000, 200)].concat(),
    ];
    let mut traces = Vec::new();
    for mode in ["never", "auto"] {
        machine::replace();
        let clock = Arc::new(VirtualClock::new());
        let mut s = Session::start(&case, case.project(mode), &clock, &inputs);
        for (until, dead) in [(3000, true), (4500, false), (10_000, true), (11_500, false)] {
            s.run_until(ms(until));
            s.world(|w| w.faults_mut().set_dead(0, dead));
        }
        s.run_until(ms(16_000));
        traces.push(s.trace().remove(0));
    }
    let (central, pushed) = (&traces[0], &traces[1]);
    // Central: the stop pressed while the line was dead never reaches the scan, so the motor
    // runs on until the stop at 8 s; each time the module comes back its outputs are written
    // again from the latch, which still holds.
    assert!(
        edges_near(central, &[(1000, true), (8000, false), (9000, true)], bound),
        "central {central:?}"
    );
    // Pushed down: the module sees the stop at 3.5 s itself and stops the motor within its
    // tick. When a lost module comes back it gets its whole start-up again (it may have been
    // power-cycled, the scan cannot tell), which starts the latch reset, as after a restart:
    // the motor running when the line died at 10 s is stopped when the line is back (within
    // the reconnect backoff after 11.5 s, grown to 2 s by then) and needs a new start press.
    // The module's reaction: the inputs' power-on latency (XLATUP/XLATDN 20 ms) and a tick.
    let tick = ms(22);
    assert!(
        edges_near(
            &pushed[..3],
            &[(1000, true), (3500, false), (7000, true)],
            tick
        ),
        "pushed {pushed:?}"
    );
    assert!(
        edges_near(&pushed[3..5], &[(8000, false), (9000, true)], tick),
        "pushed {pushed:?}"
    );
    assert_eq!(pushed.len(), 6, "pushed {pushed:?}");
    assert!(
        !pushed[5].1 && pushed[5].0 >= ms(11_500) && pushed[5].0 <= ms(14_500),
        "pushed: reset when the module comes back {pushed:?}"
    );
}

#[test]
fn forcing_beside_a_pushed_down_rung() {
    // The latch is pushed down; the lamp (Y1) stays central in both builds and is forced on
    // from 2 s to 4 s.
    let case = Case {
        name: "forcing",
        tags: &[
            "name: start, point: mm1.X1",
            "name: stop, point: mm1.X2",
            "name: x3, point: mm1.X3",
            "name: motor, point: mm1.Y2, safe: false",
            "name: lamp, point: mm1.Y1, safe: false, offload: never",
        ],
        program: "motor = (start | motor) & !stop\nlamp = x3\n",
        outputs: &["mm1.Y2", "mm1.Y1"],
        ..motor_case("forcing")
    };
    let (never, auto, bound) = plans(&case);
    assert_eq!(
        pushed(&auto),
        vec![("motor".to_string(), true), ("lamp".to_string(), false)]
    );
    let inputs = [
        [press(1000, 200), press(5000, 200)].concat(),
        press(3000, 200),
        press(4500, 200),
    ];
    let mut traces = Vec::new();
    for (mode, project) in [("never", never), ("auto", auto)] {
        machine::replace();
        let clock = Arc::new(VirtualClock::new());
        let mut s = Session::start(&case, project, &clock, &inputs);
        s.run_until(ms(2000));
        s.plc.force("lamp", "1").unwrap();
        // A force on the latch's input: the scan takes it centrally; pushed down, the module
        // reads its terminal itself, so the force is refused rather than ignored.
        let start = s.plc.force("start", "1");
        match mode {
            "never" => {
                assert!(start.is_ok(), "{start:?}");
                s.plc.unforce(Some("start")).unwrap();
            }
            _ => assert!(
                start.as_ref().is_err_and(|e| e
                    .to_string()
                    .contains("read by the module's own logic for motor")),
                "{start:?}"
            ),
        }
        s.run_until(ms(4000));
        s.plc.unforce(Some("lamp")).unwrap();
        s.run_until(ms(6000));
        traces.push(s.trace());
    }
    // The lamp: forced on, then following X3, the same in both (central in both).
    for t in &traces {
        assert!(
            edges_near(
                &after(&t[1], ms(100)),
                &[(2000, true), (4000, false), (4500, true), (4700, false)],
                bound + ms(20) // X3's power-on latency
            ),
            "lamp {:?}",
            t[1]
        );
    }
    // The motor: the same edges, the module's earlier.
    same_levels(
        "forcing motor",
        &traces[0][0],
        &traces[1][0],
        ms(500),
        bound,
        true,
        ms(1),
    );
}

#[test]
fn inputs_shorter_than_a_scan_reach_the_module_only() {
    // A MiniMod with no input latency samples every millisecond: a 5 ms start pulse in the
    // middle of a 100 ms cycle latches the pushed-down motor, and the central scan, which reads
    // the inputs at the start of each cycle, never sees it. The expected result is the
    // module's: the press happened. (With the power-on latency of 20 ms the module would filter
    // the pulse out too, "Input conditioning".) Polled, pinned: in event mode, this line's
    // default, the module queues the pulse's two edges as events and the central scan sees
    // them too.
    let mm = Case {
        name: "short-minimod",
        modules: &["name: mm1, model: minimod, address: 1, settings: { XLATUP1: 0, XLATDN1: 0, events: false }"],
        ..motor_case("short-minimod")
    };
    // A RESI-16DI8RO samples every 10 ms: a 15 ms press always spans a sample, so its TOGGLE
    // sees it; a scan of 100 ms misses it.
    let resi = Case {
        name: "short-resi",
        period_ms: 100,
        tick_ms: 10,
        modules: &["name: r1, model: resi-16di8ro, address: 1"],
        tags: &[
            "name: button, point: r1.DI1",
            "name: lamp, point: r1.RO4, safe: false",
        ],
        program: "lamp = lamp ^ rising(button)\n",
        lang: Lang::Expr,
        inputs: &["r1.DI1"],
        outputs: &["r1.RO4"],
    };
    // Reaction bounds: the MiniMod samples every 1 ms; the RESI every 10 ms, and its relay
    // follows in a later tick than the sample that saw the press (where the press falls
    // against the module's sample grid depends on how long the start-up took).
    for (case, len, react) in [(&mm, 5, 2), (&resi, 15, 12)] {
        let inputs = [vec![(ms(1050), true), (ms(1050 + len), false)]];
        let mut traces = Vec::new();
        for mode in ["never", "auto"] {
            machine::replace();
            let clock = Arc::new(VirtualClock::new());
            let mut s = Session::start(case, case.project(mode), &clock, &inputs);
            s.run_until(ms(2000));
            traces.push(after(&s.trace()[0], ms(500)));
        }
        assert_eq!(
            traces[0],
            [],
            "{}: the scan misses a {len} ms press",
            case.name
        );
        assert!(
            edges_near(&traces[1], &[(1050, true)], ms(react)),
            "{}: the module sees it: {:?}",
            case.name,
            traces[1]
        );
    }
}
