//! End-to-end tests of the `expr` engine: compile errors with positions, and scan traces on
//! virtual time.

use std::path::Path;
use std::time::Duration;

use softplc_io::point::{Quality, Value, ValueType};

use super::*;
use crate::image::ProcessImage;
use crate::logic::{LogicEngine, ScanContext};
use softplc_io::time::ScanInstant;

/// `(name, initial value, writable)`: the tags every test program may use.
const TAGS: &[(&str, Value, bool)] = &[
    ("start", Value::Bool(false), false),
    ("stop", Value::Bool(false), false),
    ("at_exit", Value::Bool(false), false),
    ("a", Value::Bool(false), false),
    ("b", Value::Bool(false), false),
    ("level", Value::U16(0), false),
    ("limit", Value::U16(0), false),
    ("count", Value::I32(0), false),
    ("temp", Value::F32(0.0), false),
    ("motor", Value::Bool(false), true),
    ("lamp", Value::Bool(false), true),
    ("q", Value::Bool(false), true),
    ("q2", Value::Bool(false), true),
    ("q3", Value::Bool(false), true),
    ("setpoint", Value::U16(0), true),
];

fn table(tags: &[(&str, Value, bool)]) -> TagTable {
    TagTable::new(
        tags.iter()
            .enumerate()
            .map(|(i, (n, v, w))| (n.to_string(), TagId(i as u32), v.value_type(), *w)),
    )
}

fn errors(src: &str) -> Vec<String> {
    compile(src, Path::new("p.expr"), &table(TAGS))
        .expect_err("program should not compile")
        .iter()
        .map(ToString::to_string)
        .collect()
}

fn error_kinds(src: &str) -> Vec<(u32, u32, CompileErrorKind)> {
    compile(src, Path::new("p.expr"), &table(TAGS))
        .expect_err("program should not compile")
        .into_iter()
        .map(|e| (e.pos.line, e.pos.column, e.kind))
        .collect()
}

/// A program on an image, scanned on virtual time with a fixed period.
struct Rig {
    program: ExprProgram,
    image: ProcessImage,
    period: Duration,
    cycle: u64,
}

impl Rig {
    fn new(src: &str, period_ms: u64) -> Self {
        Self::with_tags(src, TAGS, period_ms)
    }

    fn with_tags(src: &str, tags: &[(&str, Value, bool)], period_ms: u64) -> Self {
        let program = match compile(src, Path::new("t.expr"), &table(tags)) {
            Ok(p) => p,
            Err(e) => panic!(
                "{}",
                e.iter()
                    .map(ToString::to_string)
                    .collect::<Vec<_>>()
                    .join("\n")
            ),
        };
        let image = ProcessImage::new(tags.iter().map(|(n, v, _)| (n.to_string(), *v)));
        Self {
            program,
            image,
            period: Duration::from_millis(period_ms),
            cycle: 0,
        }
    }

    fn id(&self, name: &str) -> TagId {
        self.image.id(name).expect("tag in the test table")
    }

    fn set(&mut self, name: &str, v: Value) {
        let id = self.id(name);
        self.image.update(id, Some(v), Quality::Good, self.now());
    }

    fn bit(&mut self, name: &str, b: bool) {
        self.set(name, Value::Bool(b));
    }

    fn get(&self, name: &str) -> bool {
        self.image.get(self.id(name)).as_bool()
    }

    fn now(&self) -> ScanInstant {
        ScanInstant::after_origin(self.period * self.cycle as u32)
    }

    fn scan(&mut self) {
        let ctx = ScanContext {
            now: self.now(),
            delta: self.period,
            cycle: self.cycle,
        };
        self.program.scan(&mut self.image, &ctx).expect("scan");
        self.cycle += 1;
    }

    /// Drives `input` through `trace` (one value a scan) and returns `output` after each scan.
    fn trace(&mut self, input: &str, output: &str, trace: &[u8]) -> Vec<u8> {
        trace
            .iter()
            .map(|&x| {
                self.bit(input, x != 0);
                self.scan();
                u8::from(self.get(output))
            })
            .collect()
    }
}

// ---- compile errors ------------------------------------------------------------------------

#[test]
fn every_error_kind_with_its_position() {
    let src = "\
# conveyor
lamp = at_exit
motor = strt & !stop
start = 1
lamp = a
q = level & a
q = ton(a, 2h)
setpoint = a
q2 = (a
";
    use CompileErrorKind as K;
    assert_eq!(
        error_kinds(src),
        vec![
            (
                3,
                9,
                K::UnknownTag {
                    name: "strt".into(),
                    suggestion: Some("start".into()),
                    also: vec![]
                }
            ),
            (
                4,
                1,
                K::WriteToInput {
                    name: "start".into()
                }
            ),
            (
                5,
                1,
                K::DuplicateCoil {
                    name: "lamp".into(),
                    first_line: 2
                }
            ),
            (
                6,
                5,
                K::Type(TypeError::NumberAsBool {
                    name: "level".into(),
                    ty: ValueType::U16
                })
            ),
            (
                7,
                1,
                K::DuplicateCoil {
                    name: "q".into(),
                    first_line: 6
                }
            ),
            (
                7,
                12,
                K::BadDuration(DurationError::UnknownUnit { unit: "h".into() })
            ),
            (
                8,
                1,
                K::Type(TypeError::AssignNumber {
                    name: "setpoint".into(),
                    ty: ValueType::U16
                })
            ),
            (
                9,
                8,
                K::Syntax {
                    expected: Expected::CloseParen,
                    found: "end of line".into()
                }
            ),
        ]
    );
    assert_eq!(
        errors(src),
        vec![
            "p.expr:3:9: error: unknown tag `strt`; did you mean `start`?",
            "p.expr:4:1: error: tag `start` is read-only (a module input); a program cannot assign it",
            "p.expr:5:1: error: coil `lamp` is already assigned at line 2",
            "p.expr:6:5: error: tag `level` is u16, not bool; compare it, e.g. `level != 0`",
            "p.expr:7:1: error: coil `q` is already assigned at line 6",
            "p.expr:7:12: error: unknown time unit `h`; use us, ms or s",
            "p.expr:8:1: error: tag `setpoint` is u16: expr programs assign only bool tags; use ladder or rhai for numbers",
            "p.expr:9:8: error: expected `)`, found end of line",
        ]
    );
}

#[test]
fn type_errors() {
    assert_eq!(
        errors("q = 2"),
        ["p.expr:1:5: error: `2` is not a boolean; use 0, 1, true or false"]
    );
    assert_eq!(
        errors("q = a > 3"),
        ["p.expr:1:5: error: tag `a` is bool; comparisons take numeric tags (use `a` or `!a`)"]
    );
    assert_eq!(
        errors("q = level > rising(a)"),
        ["p.expr:1:13: error: each side of a comparison must be a numeric tag or a number"]
    );
    assert_eq!(
        errors("q = 3 < 5"),
        ["p.expr:1:5: error: a comparison needs at least one tag"]
    );
    assert_eq!(
        errors("q = !count"),
        ["p.expr:1:6: error: tag `count` is i32, not bool; compare it, e.g. `count != 0`"]
    );
}

#[test]
fn duration_errors() {
    assert_eq!(
        errors("q = ton(a, 2)"),
        ["p.expr:1:12: error: duration `2` has no unit; write e.g. `2s`, `250ms` or `100us`"]
    );
    assert_eq!(
        errors("q = tp(a, 0ms)"),
        ["p.expr:1:11: error: a timer duration must be greater than zero"]
    );
    assert_eq!(
        errors("q = tof(a, 50d)"),
        ["p.expr:1:12: error: unknown time unit `d`; use us, ms or s"]
    );
    assert_eq!(
        errors("q = tof(a, 4294968s)"),
        ["p.expr:1:12: error: duration longer than the maximum of 4294967295 ms (about 49.7 days)"]
    );
}

#[test]
fn all_errors_are_reported_at_least_one_per_line() {
    let src = "q = a &\nq2 = (b\nmotor = x | y\n\n= lamp\nlamp = a b\n";
    assert_eq!(
        errors(src),
        [
            "p.expr:1:8: error: expected a tag, 0, 1, true, false, `!`, `(` or a function call, found end of line",
            "p.expr:2:8: error: expected `)`, found end of line",
            "p.expr:3:9: error: unknown tag `x`; declare it under `tags:` in the project, e.g. `- { name: x, type: bool }` for a memory bit",
            "p.expr:3:13: error: unknown tag `y`; declare it under `tags:` in the project, e.g. `- { name: y, type: bool }` for a memory bit",
            "p.expr:5:1: error: expected a coil name, found `=`",
            "p.expr:6:10: error: expected an operator or end of line, found `b`",
        ]
    );
}

#[test]
fn unknown_coil_and_function_and_depth() {
    assert_eq!(
        errors("mtor = a"),
        ["p.expr:1:1: error: unknown tag `mtor`; did you mean `motor`?"]
    );
    assert_eq!(
        errors("q = blink(a, 1s)"),
        ["p.expr:1:5: error: unknown function `blink`; the functions are rising, falling, ton, tof, tp, good and bad"]
    );
    let deep = format!("q = {}a{}", "(".repeat(70), ")".repeat(70));
    assert_eq!(
        errors(&deep),
        ["p.expr:1:69: error: expression nested deeper than 64 levels"]
    );
}

#[test]
fn crlf_bom_and_comments_are_accepted() {
    let src = "\u{feff}# header\r\nq = a # set q\r\n\r\n   \r\nq2 = b\r\n";
    let mut rig = Rig::new(src, 10);
    rig.bit("a", true);
    rig.scan();
    assert!(rig.get("q") && !rig.get("q2"));
    let err = errors("\u{feff}q = x\r\n");
    assert_eq!(err, ["p.expr:1:5: error: unknown tag `x`; declare it under `tags:` in the project, e.g. `- { name: x, type: bool }` for a memory bit"]);
}

// ---- scans ---------------------------------------------------------------------------------

#[test]
fn self_latching_motor() {
    let mut rig = Rig::new("motor = (start | motor) & !stop & !at_exit\n", 10);
    // (start, stop, at_exit) → motor
    type Step = ((u8, u8, u8), u8);
    let steps: &[Step] = &[
        ((0, 0, 0), 0),
        ((1, 0, 0), 1), // start pressed
        ((0, 0, 0), 1), // released: holds itself
        ((0, 0, 0), 1),
        ((0, 1, 0), 0), // stop
        ((0, 0, 0), 0), // stays off
        ((1, 1, 0), 0), // stop wins over start
        ((1, 0, 0), 1),
        ((0, 0, 0), 1),
        ((0, 0, 1), 0), // a box reaches the exit
        ((0, 0, 0), 0),
    ];
    for (i, &((start, stop, exit), motor)) in steps.iter().enumerate() {
        rig.bit("start", start != 0);
        rig.bit("stop", stop != 0);
        rig.bit("at_exit", exit != 0);
        rig.scan();
        assert_eq!(u8::from(rig.get("motor")), motor, "scan {i}");
    }
    let slot = rig.image.slot(rig.id("motor"));
    assert_eq!(slot.quality, Quality::Good);
    assert_eq!(
        slot.timestamp,
        ScanInstant::after_origin(Duration::from_millis(100)),
        "stamped with the last scan's time"
    );
}

#[test]
fn statements_run_in_file_order() {
    // q2 sees q as written by the statement above it in the same scan; q3 reads q2 before
    // q2 is written, so it lags one scan.
    let mut rig = Rig::new("q3 = q2\nq = a\nq2 = q\n", 10);
    assert_eq!(rig.trace("a", "q2", &[1, 1, 0, 0]), [1, 1, 0, 0]);
    let mut rig = Rig::new("q3 = q2\nq = a\nq2 = q\n", 10);
    assert_eq!(rig.trace("a", "q3", &[1, 1, 0, 0]), [0, 1, 1, 0]);
}

#[test]
fn rising_and_falling_are_one_shots_per_call_site() {
    let src = "q = rising(a)\nq2 = falling(a)\nq3 = rising(a) & !falling(a)\n";
    let trace = [1, 1, 0, 1, 1, 0, 0, 1];
    // The first scan has no previous value: `a` already true there is not an edge.
    let rising = [0, 0, 0, 1, 0, 0, 0, 1];
    let falling = [0, 0, 1, 0, 0, 1, 0, 0];
    assert_eq!(Rig::new(src, 10).trace("a", "q", &trace), rising);
    assert_eq!(Rig::new(src, 10).trace("a", "q2", &trace), falling);
    // Two more call sites on the same input in one scan: each has its own memory, so the second
    // `rising(a)` fires too (a shared memory would already hold `true`).
    assert_eq!(Rig::new(src, 10).trace("a", "q3", &trace), rising);
}

#[test]
fn ton_switches_on_at_the_sixth_scan_of_continuous_true() {
    // 20 ms period, 100 ms preset: scans at +0, +20, ..., +100 ms; `now - start >= 100 ms` first
    // holds on the 6th consecutive scan with the input true.
    let mut rig = Rig::new("q = ton(a, 100ms)\n", 20);
    let input = [0, 0, 1, 1, 1, 1, 1, 1, 1, 0, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1];
    let expect = [0, 0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1];
    assert_eq!(rig.trace("a", "q", &input), expect);
    assert_eq!(
        rig.image.slot(rig.id("q")).timestamp,
        ScanInstant::after_origin(Duration::from_millis(19 * 20))
    );
}

#[test]
fn tof_switches_off_at_the_sixth_scan_of_continuous_false() {
    let mut rig = Rig::new("q = tof(a, 100ms)\n", 20);
    // Never true: false. True: true at once. False: true for 5 scans (+0..+80 ms), false at the
    // 6th (+100 ms). A dip shorter than the preset does not reach the output.
    let input = [0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 1, 1, 0];
    let expect = [0, 0, 1, 1, 1, 1, 1, 1, 1, 0, 0, 1, 1, 1, 1, 1, 1];
    assert_eq!(rig.trace("a", "q", &input), expect);
}

#[test]
fn tp_pulses_for_a_fixed_time_on_a_rising_edge() {
    let mut rig = Rig::new("q = tp(a, 50ms)\n", 20);
    let input = [
        1, // first scan: no edge, no pulse
        0, //
        1, // edge: pulse from +0 ms
        0, // +20: the pulse ignores the input
        1, // +40: an edge inside the pulse is ignored
        1, // +60 >= 50: the pulse ends after 3 scans
        0, 1, // a new edge: a new pulse
        1, 1, // +20, +40
        1, 1, // held: no new pulse
    ];
    let expect = [0, 0, 1, 1, 1, 0, 0, 1, 1, 1, 0, 0];
    assert_eq!(rig.trace("a", "q", &input), expect);
}

#[test]
fn timers_inside_or_see_every_scan() {
    // No short-circuit: the timer runs even while `b` already makes the result true.
    let mut rig = Rig::new("q = b | ton(a, 40ms)\n", 20);
    rig.bit("b", true);
    assert_eq!(rig.trace("a", "q", &[1, 1, 1]), [1, 1, 1]);
    rig.bit("b", false);
    assert_eq!(rig.trace("a", "q", &[1]), [1], "timed 60 ms while b held q");
}

#[test]
fn timers_tolerate_time_going_backwards() {
    let mut rig = Rig::new(
        "q = ton(a, 10ms)\nq2 = tp(a, 10ms)\nq3 = tof(a, 10ms)\n",
        10,
    );
    rig.cycle = 100;
    assert_eq!(rig.trace("a", "q", &[0, 1]), [0, 0]);
    rig.cycle = 5;
    assert_eq!(
        rig.trace("a", "q", &[1, 1, 1]),
        [0, 1, 1],
        "timing restarts from the new time"
    );
    rig.cycle = 0;
    assert_eq!(rig.trace("a", "q2", &[0, 1, 1, 0]), [0, 1, 0, 0]);
}

#[test]
fn comparisons_on_numeric_tags() {
    let src = "q = level > 5\nq2 = level == 0\nq3 = level != 3 & level <= 10\n";
    let mut rig = Rig::new(src, 10);
    for (level, expect) in [
        (0u16, (0, 1, 1)),
        (3, (0, 0, 0)),
        (5, (0, 0, 1)),
        (6, (1, 0, 1)),
        (10, (1, 0, 1)),
        (11, (1, 0, 0)),
        (u16::MAX, (1, 0, 0)),
    ] {
        rig.set("level", Value::U16(level));
        rig.scan();
        let got = (
            u8::from(rig.get("q")),
            u8::from(rig.get("q2")),
            u8::from(rig.get("q3")),
        );
        assert_eq!(got, expect, "level {level}");
    }
}

#[test]
fn comparisons_on_i32_f32_and_between_tags() {
    let src = "q = count >= -2\nq2 = temp == 0.1 and 2.5 < temp + 0\nq3 = level < limit\n";
    // `temp + 0` is not in the language.
    assert!(compile(src, Path::new("x"), &table(TAGS)).is_err());
    let src = "q = count >= -2\nq2 = temp == 0.1\nq3 = level < limit\nlamp = 20.5 > temp\n";
    let mut rig = Rig::new(src, 10);
    rig.set("count", Value::I32(-3));
    rig.set("temp", Value::F32(0.1));
    rig.set("level", Value::U16(7));
    rig.set("limit", Value::U16(8));
    rig.scan();
    assert_eq!(
        (rig.get("q"), rig.get("q2"), rig.get("q3"), rig.get("lamp")),
        (false, true, true, true)
    );
    rig.set("count", Value::I32(-2));
    rig.set("temp", Value::F32(f32::NAN));
    rig.set("limit", Value::U16(7));
    rig.scan();
    assert_eq!(
        (rig.get("q"), rig.get("q2"), rig.get("q3"), rig.get("lamp")),
        (true, false, false, false)
    );
}

#[test]
fn bad_quality_tags_still_read_their_value() {
    let mut rig = Rig::new("q = a\n", 10);
    rig.bit("a", true);
    let a = rig.id("a");
    rig.image.set_quality(a, Quality::Bad);
    rig.scan();
    assert!(rig.get("q"));
}

// ---- quality -------------------------------------------------------------------------------

#[test]
fn quality_tests_of_unknown_tags_are_errors_at_the_name() {
    assert_eq!(
        errors("q = a\nlamp = !good(levl) & bad(tmp)\n"),
        [
            "p.expr:2:14: error: unknown tag `levl`; did you mean `level`?",
            "p.expr:2:26: error: unknown tag `tmp`; did you mean `temp`?",
        ]
    );
    assert_eq!(
        errors("q = good(a | b)\nq2 = bad(rising(a))\n"),
        [
            "p.expr:1:10: error: `good` takes a tag name, e.g. `good(level)`, not an expression",
            "p.expr:2:10: error: `bad` takes a tag name, e.g. `bad(level)`, not an expression",
        ]
    );
    assert_eq!(
        error_kinds("q = good(level) > 3\n"),
        [(1, 5, CompileErrorKind::Type(TypeError::ComparisonOperand))]
    );
}

#[test]
fn good_and_bad_follow_the_slot_quality() {
    // `level` is u16: any tag has a quality.
    let mut rig = Rig::new("q = good(a)\nq2 = bad(a)\nq3 = !good(level)\n", 10);
    let (a, level) = (rig.id("a"), rig.id("level"));
    let step = |rig: &mut Rig, quality: Quality| {
        let now = rig.now();
        rig.image.update(a, None, quality, now);
        rig.scan();
        (rig.get("q"), rig.get("q2"))
    };
    // Never read: Bad.
    rig.scan();
    assert_eq!(
        (rig.get("q"), rig.get("q2"), rig.get("q3")),
        (false, true, true)
    );
    rig.bit("a", false);
    rig.set("level", Value::U16(7));
    rig.scan();
    assert_eq!(
        (rig.get("q"), rig.get("q2"), rig.get("q3")),
        (true, false, false)
    );
    assert_eq!(step(&mut rig, Quality::Stale), (false, false));
    assert_eq!(step(&mut rig, Quality::Bad), (false, true));
    assert_eq!(step(&mut rig, Quality::Good), (true, false));
    // The value is kept while not good; the quality test does not read it.
    rig.image
        .update(level, None, Quality::Bad, ScanInstant::ZERO);
    rig.scan();
    assert!(rig.get("q3"));
    assert_eq!(rig.image.get(level), Value::U16(7));
}

#[test]
fn memory_and_forced_tags_are_good() {
    let mut rig = Rig::new("q = good(motor)\nq2 = good(b)\n", 10);
    let (motor, b) = (rig.id("motor"), rig.id("b"));
    rig.image.set(motor, Value::Bool(false), ScanInstant::ZERO);
    rig.image.update(b, None, Quality::Bad, ScanInstant::ZERO);
    rig.scan();
    assert_eq!((rig.get("q"), rig.get("q2")), (true, false));
    rig.image.force(b, Value::Bool(true));
    rig.image.apply_forces(ScanInstant::ZERO);
    rig.scan();
    assert!(rig.get("q2"));
}

#[test]
fn quality_tests_lower_to_one_instruction() {
    let rig = Rig::new("q = !good(a) | bad(b)\n", 10);
    let (a, b, q) = (rig.id("a"), rig.id("b"), rig.id("q"));
    assert_eq!(
        rig.program.instructions(),
        [
            Instr::Good(a),
            Instr::Not,
            Instr::Bad(b),
            Instr::Or,
            Instr::Store(q)
        ]
    );
}

#[test]
fn quality_tests_stay_in_the_scan() {
    use softplc_io::rung::RungShape;
    let rig = Rig::new("q = !good(a)\nq2 = (rising(b) | q2) & !bad(b)\n", 10);
    let rungs = rig.program.rungs().expect("expr describes its rungs");
    for rung in rungs {
        let RungShape::Opaque { reason } = rung.shape else {
            panic!("a module cannot see a tag's quality: {rung:?}")
        };
        assert!(reason.contains("quality"), "{reason}");
    }
}

#[test]
fn outputs_list_the_coils_in_file_order() {
    let rig = Rig::new("lamp = a\n# x\nmotor = b\nq = 1\n", 10);
    let names: Vec<&str> = rig.program.outputs().map(|id| rig.image.name(id)).collect();
    assert_eq!(names, ["lamp", "motor", "q"]);
    assert_eq!(rig.program.instructions().len(), 6);
}

#[test]
fn an_image_too_small_is_a_fault_not_a_panic() {
    let program = compile("q = a\n", Path::new("t.expr"), &table(TAGS));
    let mut program = program.unwrap();
    let mut image = ProcessImage::new([("a".to_string(), Value::Bool(false))]);
    let ctx = ScanContext {
        now: ScanInstant::ZERO,
        delta: Duration::ZERO,
        cycle: 0,
    };
    let fault = program.scan(&mut image, &ctx).unwrap_err();
    assert_eq!(
        fault.to_string(),
        "program uses tag #11 but the process image holds 1 tags at t.expr:1:1"
    );
}

#[test]
fn empty_program_compiles_and_scans() {
    let mut rig = Rig::new("# nothing yet\n\n", 10);
    rig.scan();
    assert_eq!(rig.program.outputs().count(), 0);
}

/// A tiny deterministic generator (no dependency, same sequence everywhere).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 33
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

#[test]
fn same_inputs_and_times_give_same_outputs() {
    let src = "\
motor = (rising(start) | motor) & !stop & !tof(at_exit, 30ms)
lamp = tp(falling(a) ^ b, 25ms) | level > 3
q = ton(a & !b, 45ms) ^ rising(motor)
q2 = tof(q | count < 0, 15ms)
q3 = (q2 or temp >= 1.5) and not lamp
";
    let run = |program: Option<ExprProgram>| {
        let mut rig = Rig::new(src, 10);
        if let Some(p) = program {
            rig.program = p;
        }
        let mut rng = Lcg(42);
        let mut now = ScanInstant::ZERO;
        let mut trace = Vec::new();
        for cycle in 0..2000u64 {
            for name in ["start", "stop", "at_exit", "a", "b"] {
                let b = rng.below(4) == 0;
                rig.bit(name, b);
            }
            rig.set("level", Value::U16(rng.below(6) as u16));
            rig.set("count", Value::I32(rng.below(5) as i32 - 2));
            rig.set("temp", Value::F32(rng.below(4) as f32 * 0.75));
            now += Duration::from_micros(9_000 + rng.below(2_000)); // jittered period
            let ctx = ScanContext {
                now,
                delta: Duration::from_millis(10),
                cycle,
            };
            rig.program.scan(&mut rig.image, &ctx).unwrap();
            let outs: Vec<bool> = ["motor", "lamp", "q", "q2", "q3"]
                .iter()
                .map(|n| rig.get(n))
                .collect();
            trace.push(outs);
        }
        (trace, rig.program)
    };
    let (first, mut used) = run(None);
    let (second, _) = run(None);
    assert_eq!(first, second);
    used.reset();
    let (after_reset, _) = run(Some(used));
    assert_eq!(first, after_reset);
    // The trace is not trivial.
    for col in 0..5 {
        assert!(
            first.iter().any(|o| o[col]) && first.iter().any(|o| !o[col]),
            "output {col}"
        );
    }
}

#[test]
fn no_program_text_makes_compile_or_scan_panic() {
    const PIECES: &[&str] = &[
        "a",
        "q",
        "motor",
        "level",
        "temp",
        "x",
        "(",
        ")",
        "!",
        "not",
        "&",
        "and",
        "|",
        "or",
        "^",
        "=",
        "==",
        "!=",
        "<",
        "<=",
        ">",
        ">=",
        "-",
        "0",
        "1",
        "2.5",
        "true",
        "rising",
        "falling",
        "ton",
        "tof",
        "tp",
        "good",
        "bad",
        "good(",
        ",",
        "2s",
        "0ms",
        "1.5",
        "3h",
        "#",
        "\n",
        "\r",
        "\t",
        " ",
        " ",
        " ",
        "é",
        "@",
        ".",
        "\u{feff}",
        "\0",
        "99999999999999999999999",
    ];
    let tags = table(TAGS);
    let mut rng = Lcg(7);
    let mut compiled = 0;
    for _ in 0..5000 {
        let mut src = String::new();
        if rng.below(2) == 0 {
            src.push_str(["q = ", "motor = ", "q2 = ", "lamp = "][rng.below(4) as usize]);
        }
        for _ in 0..rng.below(30) {
            src.push_str(PIECES[rng.below(PIECES.len() as u64) as usize]);
        }
        match compile(&src, Path::new("f.expr"), &tags) {
            Ok(mut program) => {
                compiled += 1;
                let mut image = ProcessImage::new(TAGS.iter().map(|(n, v, _)| (n.to_string(), *v)));
                for cycle in 0..3 {
                    let ctx = ScanContext {
                        now: ScanInstant::after_origin(Duration::from_millis(cycle * 7)),
                        delta: Duration::ZERO,
                        cycle,
                    };
                    program.scan(&mut image, &ctx).unwrap();
                }
            }
            Err(errs) => assert!(!errs.is_empty()),
        }
    }
    assert!(
        compiled > 50,
        "the generator should also make valid programs ({compiled})"
    );
    // Raw bytes.
    for _ in 0..2000 {
        let bytes: Vec<u8> = (0..rng.below(64)).map(|_| rng.below(256) as u8).collect();
        // Any answer will do; the test is that it comes without a panic.
        drop(compile(
            &String::from_utf8_lossy(&bytes),
            Path::new("f.expr"),
            &tags,
        ));
    }
}

// ---- the example program -------------------------------------------------------------------

#[test]
fn conveyor_program_scenario() {
    const CONVEYOR: &[(&str, Value, bool)] = &[
        ("start", Value::Bool(false), false),
        ("stop", Value::Bool(false), false),
        ("box_at_entry", Value::Bool(false), false),
        ("box_at_exit", Value::Bool(false), false),
        ("motor", Value::Bool(false), true),
        ("lamp", Value::Bool(false), true),
    ];
    let src = include_str!("../../../../programs/conveyor.expr");
    let mut rig = Rig::with_tags(src, CONVEYOR, 10);
    let names: Vec<&str> = rig.program.outputs().map(|id| rig.image.name(id)).collect();
    assert_eq!(names, ["motor", "lamp"]);
    // start, stop, box_at_exit → motor, lamp
    type Step = ((u8, u8, u8), (u8, u8));
    let steps: &[Step] = &[
        ((1, 0, 0), (0, 0)), // held through start-up: not a press
        ((0, 0, 0), (0, 0)),
        ((1, 0, 0), (1, 0)), // press
        ((1, 0, 0), (1, 0)), // held
        ((0, 0, 0), (1, 0)), // released: runs on
        ((0, 0, 1), (0, 1)), // a box reaches the exit: stop, lamp on
        ((1, 0, 1), (0, 1)), // a start press while the box is there does nothing
        ((0, 0, 0), (0, 0)), // box taken away
        ((1, 0, 0), (1, 0)), // press
        ((0, 1, 0), (0, 0)), // stop
        ((0, 0, 0), (0, 0)),
    ];
    for (i, &((start, stop, exit), (motor, lamp))) in steps.iter().enumerate() {
        rig.bit("start", start != 0);
        rig.bit("stop", stop != 0);
        rig.bit("box_at_exit", exit != 0);
        rig.scan();
        assert_eq!(
            (u8::from(rig.get("motor")), u8::from(rig.get("lamp"))),
            (motor, lamp),
            "scan {i}"
        );
    }
}

#[test]
fn literals_the_tag_type_cannot_hold_are_type_errors() {
    assert_eq!(
        errors("motor = level == 0.5\nlamp = count < 3000000000 | temp > 9999999999999999999999999999999999999999\nq = level > -1\n"),
        [
            "p.expr:1:18: error: type error: `0.5` is not a u16 value (a whole number from 0 to \
             65535); `level` is u16",
            "p.expr:2:16: error: type error: `3000000000` is not an i32 value (a whole number \
             from -2147483648 to 2147483647); `count` is i32",
            "p.expr:2:36: error: type error: `9999999999999999999999999999999999999999` is not an f32 value (a number within \
             ±3.4e38); `temp` is f32",
            "p.expr:3:13: error: type error: `-1` is not a u16 value (a whole number from 0 to \
             65535); `level` is u16",
        ]
    );
}

#[test]
fn an_undeclared_coil_is_one_error_with_its_uses_and_how_to_declare_it() {
    assert_eq!(
        errors("running = start | running\nmotor = running & !stop\nlamp = running\n"),
        ["p.expr:1:1: error: unknown tag `running`; declare it under `tags:` in the project, e.g. `- { name: running, type: bool }` for a memory bit (also used on lines 2, 3)"]
    );
}

#[test]
fn a_statements_comments_title_its_rung_and_a_comment_too_long_is_refused() {
    let src = "\
# Conveyor (a header: a blank line follows).

# Start/stop latch,
# stop winning.
motor = (start | motor) & !stop
lamp = motor  # lamp follows the belt
q = a
";
    let p = compile(src, Path::new("p.expr"), &table(TAGS)).unwrap();
    let titles: Vec<(u32, Option<String>)> = p
        .rungs()
        .unwrap()
        .into_iter()
        .map(|r| (r.pos.line, r.title))
        .collect();
    assert_eq!(
        titles,
        [
            (5, Some("Start/stop latch, stop winning.".to_string())),
            (6, Some("lamp follows the belt".to_string())),
            (7, None),
        ]
    );
    let long = format!("q = a  # {}\n", "x".repeat(1001));
    assert_eq!(
        errors(&long),
        ["p.expr:1:8: error: comment: 1001 characters, at most 1000 are allowed"]
    );
}
