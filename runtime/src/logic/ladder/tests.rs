//! Ladder engine tests: programs run over virtual time, and every error with its position.

use std::path::Path;
use std::time::Duration;

use softplc_io::point::{Value, ValueType};

use super::*;
use crate::image::{ProcessImage, TagId};
use crate::logic::{LogicEngine, ScanContext};
use softplc_io::time::ScanInstant;

/// Tags: name, type, writable.
const TAGS: &[(&str, ValueType, bool)] = &[
    ("start", ValueType::Bool, false),
    ("stop", ValueType::Bool, false),
    ("sensor", ValueType::Bool, false),
    ("level", ValueType::U16, false),
    ("temp", ValueType::F32, false),
    ("motor", ValueType::Bool, true),
    ("lamp", ValueType::Bool, true),
    ("alarm", ValueType::Bool, true),
    ("count", ValueType::I32, true),
    ("speed", ValueType::F32, true),
    ("small", ValueType::U16, true),
];

fn table() -> TagTable {
    TagTable::new(
        TAGS.iter()
            .enumerate()
            .map(|(i, &(n, ty, w))| (n.to_string(), TagId(i as u32), ty, w)),
    )
}

fn id(name: &str) -> TagId {
    TagId(TAGS.iter().position(|t| t.0 == name).expect("a tag") as u32)
}

fn program(rungs: &[&str]) -> String {
    let mut s = String::from("rungs:\n");
    for r in rungs {
        s.push_str("  - ");
        s.push_str(r);
        s.push('\n');
    }
    s
}

fn build(rungs: &[&str]) -> LadderProgram {
    match compile(&program(rungs), Path::new("p.yaml"), &table()) {
        Ok(p) => p,
        Err(e) => panic!(
            "{}",
            e.iter()
                .map(|e| e.to_string())
                .collect::<Vec<_>>()
                .join("\n")
        ),
    }
}

/// Every error, as `line:col: message`.
fn errors(rungs: &[&str]) -> Vec<String> {
    match compile(&program(rungs), Path::new("p.yaml"), &table()) {
        Ok(_) => panic!("expected errors"),
        Err(e) => e
            .iter()
            .map(|e| format!("{}:{}: {}", e.pos.line, e.pos.column, e.kind))
            .collect(),
    }
}

struct Rig {
    program: LadderProgram,
    image: ProcessImage,
    now: ScanInstant,
    cycle: u64,
}

impl Rig {
    fn new(rungs: &[&str]) -> Self {
        Self {
            program: build(rungs),
            image: ProcessImage::new(TAGS.iter().map(|&(n, ty, _)| (n.to_string(), ty.zero()))),
            now: ScanInstant::ZERO,
            cycle: 0,
        }
    }

    fn set(&mut self, name: &str, v: Value) {
        self.image.set(id(name), v, self.now);
    }

    fn get(&self, name: &str) -> Value {
        self.image.get(id(name))
    }

    /// One scan, then time moves on 10 ms.
    fn scan(&mut self) {
        let ctx = ScanContext {
            now: self.now,
            delta: Duration::from_millis(10),
            cycle: self.cycle,
        };
        self.program.scan(&mut self.image, &ctx).expect("no fault");
        self.now += Duration::from_millis(10);
        self.cycle += 1;
    }

    fn bit(&self, name: &str) -> bool {
        self.get(name).as_bool()
    }
}

#[test]
fn latch_with_series_and_parallel_contacts() {
    let mut r = Rig::new(&["(rising(start) | motor) /stop -> motor, /lamp"]);
    r.scan();
    assert!(!r.bit("motor") && r.bit("lamp"));
    r.set("start", Value::Bool(true));
    r.scan();
    assert!(r.bit("motor") && !r.bit("lamp"));
    r.set("start", Value::Bool(false));
    r.scan();
    assert!(r.bit("motor"));
    r.set("stop", Value::Bool(true));
    r.scan();
    assert!(!r.bit("motor"));
}

#[test]
fn set_reset_coils_and_constants() {
    let mut r = Rig::new(&["start -> set lamp", "stop -> reset lamp", "-> alarm"]);
    r.scan();
    assert!(!r.bit("lamp") && r.bit("alarm"));
    r.set("start", Value::Bool(true));
    r.scan();
    r.set("start", Value::Bool(false));
    r.scan();
    assert!(r.bit("lamp"));
    r.set("stop", Value::Bool(true));
    r.scan();
    assert!(!r.bit("lamp"));
}

#[test]
fn timer_feeds_coils_and_outputs_are_readable() {
    let mut r = Rig::new(&["t.ET >= 30ms /t.Q -> lamp", "start -> TON t(50ms) -> motor"]);
    r.set("start", Value::Bool(true));
    let mut motor = String::new();
    let mut lamp = String::new();
    for _ in 0..8 {
        r.scan();
        motor.push(if r.bit("motor") { '1' } else { '0' });
        lamp.push(if r.bit("lamp") { '1' } else { '0' });
    }
    assert_eq!(motor, "00000111");
    // The lamp rung runs before the timer: it sees the previous scan's ET and Q.
    assert_eq!(lamp, "00001100");
}

#[test]
fn instance_outputs_follow_the_blocks_over_time() {
    use crate::logic::blocks::{Member, OutputValue};
    use crate::logic::InstanceOutput;
    // A timer on a coil, a counter driving none, and a timer whose Q only a contact reads.
    let mut r = Rig::new(&[
        "start -> TON t(30ms) -> motor",
        "sensor -> CTU boxes(2)",
        "start -> TON jam(50ms)",
        "jam.Q -> alarm",
    ]);
    let mut out = vec![InstanceOutput {
        inst: 9,
        member: Member::Qd,
        value: OutputValue::Count(7),
    }];
    let trace = |r: &mut Rig, out: &mut Vec<InstanceOutput>| {
        r.program.instance_outputs(out);
        out.iter()
            .map(|o| {
                let v = match o.value {
                    OutputValue::Bool(b) => u8::from(b).to_string(),
                    OutputValue::Time(d) => format!("{}ms", d.as_millis()),
                    OutputValue::Count(c) => c.to_string(),
                };
                format!("{}.{}={v}", o.inst, o.member)
            })
            .collect::<Vec<_>>()
            .join(" ")
    };
    // Fresh: everything off and zero, the stale entry gone, instances in call order.
    assert_eq!(
        trace(&mut r, &mut out),
        "0.Q=0 0.ET=0ms 1.Q=0 1.CV=0 2.Q=0 2.ET=0ms"
    );
    r.set("start", Value::Bool(true));
    let mut seen = Vec::new();
    for k in 0..7 {
        r.set("sensor", Value::Bool(k % 2 == 1));
        r.scan();
        seen.push(trace(&mut r, &mut out));
    }
    assert_eq!(
        seen,
        [
            "0.Q=0 0.ET=0ms 1.Q=0 1.CV=0 2.Q=0 2.ET=0ms",
            "0.Q=0 0.ET=10ms 1.Q=0 1.CV=1 2.Q=0 2.ET=10ms",
            "0.Q=0 0.ET=20ms 1.Q=0 1.CV=1 2.Q=0 2.ET=20ms",
            "0.Q=1 0.ET=30ms 1.Q=1 1.CV=2 2.Q=0 2.ET=30ms",
            "0.Q=1 0.ET=30ms 1.Q=1 1.CV=2 2.Q=0 2.ET=40ms",
            "0.Q=1 0.ET=30ms 1.Q=1 1.CV=3 2.Q=1 2.ET=50ms",
            "0.Q=1 0.ET=30ms 1.Q=1 1.CV=3 2.Q=1 2.ET=50ms",
        ]
    );
    // The coils agree with the outputs published with them.
    assert!(r.bit("motor") && r.bit("alarm"));
    // A reset forgets them.
    r.program.reset();
    assert_eq!(
        trace(&mut r, &mut out),
        "0.Q=0 0.ET=0ms 1.Q=0 1.CV=0 2.Q=0 2.ET=0ms"
    );
}

#[test]
fn an_engine_without_instances_publishes_none() {
    use crate::logic::LogicEngine;
    #[derive(Debug)]
    struct Plain;
    impl LogicEngine for Plain {
        fn scan(
            &mut self,
            _: &mut ProcessImage,
            _: &ScanContext,
        ) -> Result<(), crate::logic::LogicFault> {
            Ok(())
        }
    }
    let mut out = Vec::new();
    build(&["start -> TON t(30ms) -> motor"]).instance_outputs(&mut out);
    assert_eq!(out.len(), 2);
    Plain.instance_outputs(&mut out);
    assert!(out.is_empty(), "the default leaves nothing behind: {out:?}");
}

#[test]
fn counters_and_math_boxes() {
    let mut r = Rig::new(&[
        "rising(sensor) -> ADD(count, 1) => count",
        "sensor -> CTU boxes(3, r=stop) -> lamp",
        "-> DIV(boxes.CV, 2) => small, MUL(level, 0.5) => speed",
        "count >= 2 -> alarm",
    ]);
    r.set("level", Value::U16(9));
    for x in [false, true, false, true, false, true] {
        r.set("sensor", Value::Bool(x));
        r.scan();
    }
    assert_eq!(r.get("count"), Value::I32(3));
    assert!(r.bit("lamp") && r.bit("alarm"));
    assert_eq!(r.get("small"), Value::U16(1));
    assert_eq!(r.get("speed"), Value::F32(4.5));
    r.set("stop", Value::Bool(true));
    r.scan();
    assert!(!r.bit("lamp"));
}

#[test]
fn limit_saturation_and_truncation() {
    let mut r = Rig::new(&[
        "-> LIMIT(0, temp, 100) => speed",
        "-> SUB(0, 5) => small",
        "-> MUL(temp, 1000000000) => count",
    ]);
    r.set("temp", Value::F32(250.0));
    r.scan();
    assert_eq!(r.get("speed"), Value::F32(100.0));
    assert_eq!(r.get("small"), Value::U16(0));
    assert_eq!(r.get("count"), Value::I32(i32::MAX));
}

#[test]
fn division_by_zero_faults_at_the_rung() {
    let mut p = build(&["start -> lamp", "-> DIV(count, 0) => count"]);
    let mut image = ProcessImage::new(TAGS.iter().map(|&(n, ty, _)| (n.to_string(), ty.zero())));
    let ctx = ScanContext {
        now: ScanInstant::ZERO,
        delta: Duration::from_millis(10),
        cycle: 0,
    };
    let fault = p.scan(&mut image, &ctx).unwrap_err();
    assert_eq!(fault.to_string(), "division by zero in DIV at p.yaml:3:5");
}

#[test]
fn blink_toggle_stair_and_bistables() {
    let mut r = Rig::new(&[
        "start -> BLINK b(20ms, 10ms) -> lamp",
        "sensor -> TOGGLE tg -> motor",
        "sensor -> STAIR st(30ms, r=stop) -> alarm",
        "start -> SR sr(r=stop)",
        "start -> RS rs(r=stop)",
        "-> BLINK p(pattern=0110, step=10ms)",
    ]);
    r.scan();
    r.set("start", Value::Bool(true));
    let mut lamp = String::new();
    for _ in 0..6 {
        r.scan();
        lamp.push(if r.bit("lamp") { '1' } else { '0' });
    }
    assert_eq!(lamp, "110110");
    r.set("sensor", Value::Bool(true));
    r.scan();
    assert!(r.bit("motor") && r.bit("alarm"));
    r.set("sensor", Value::Bool(false));
    r.scan();
    r.set("sensor", Value::Bool(true));
    r.scan();
    assert!(!r.bit("motor"));
}

#[test]
fn comparisons_with_literals_and_durations() {
    let mut r = Rig::new(&[
        "temp = 0.1 -> lamp",
        "level <> 3 level < 10 -> motor",
        "-> TON t(1s)",
        "t.ET == 0ms -> alarm",
    ]);
    r.set("temp", Value::F32(0.1));
    r.set("level", Value::U16(4));
    r.scan();
    assert!(r.bit("lamp") && r.bit("motor") && r.bit("alarm"));
}

#[test]
fn rungs_over_several_lines_and_quoted() {
    let text = "description: test\nrungs:\n  - \"start -> motor\"\n  - start\n    /stop -> lamp\n";
    assert!(compile(text, Path::new("p.yaml"), &table()).is_ok());
    let e = compile(
        "rungs:\n  - start\n    /stp -> lamp\n",
        Path::new("p.yaml"),
        &table(),
    )
    .unwrap_err();
    assert_eq!(
        e[0].to_string(),
        "p.yaml:3:6: error: unknown tag `stp`; did you mean `stop`?"
    );
}

#[test]
fn check_errors_point_at_the_offending_token() {
    assert_eq!(
        errors(&["start -> motor", "stop -> motor"]),
        ["3:13: tag `motor` is already driven by a coil at line 2; this rung drives it by a coil"]
    );
    assert_eq!(
        errors(&["start -> stop"]),
        ["2:14: tag `stop` is read-only (a module input); a program cannot write it"]
    );
    assert_eq!(
        errors(&["level -> lamp"]),
        ["2:5: `level` is u16, not bool; compare it, e.g. `level > 0`"]
    );
    assert_eq!(
        errors(&["start -> count"]),
        ["2:14: coil `count` is i32; coils drive bool tags (use `MOVE(…) => count` for numbers)"]
    );
    assert_eq!(
        errors(&["start -> TOM t(1s)"]),
        ["2:14: unknown block `TOM`; did you mean `TON`?; the blocks are TON, TOF, TP, STAIR, CTU, CTD, CTUD, R_TRIG, F_TRIG, SR, RS, TOGGLE, BLINK, LAMP"]
    );
    assert_eq!(
        errors(&["start -> LAMP l(70000)"]),
        ["2:21: type error: `70000` is not a u16 value (a whole number from 0 to 65535); a LAMP's mask is u16"]
    );
    assert_eq!(
        errors(&["start -> TON t(5)"]),
        ["2:20: bad duration `5`: no unit (ns, us, ms, s, m or h); write e.g. 500ms, 2s, 1.5s, 10m"]
    );
    assert_eq!(
        errors(&["t.CV > 1 -> lamp", "start -> TON t(1s)"]),
        ["2:7: TON `t` has no output `CV`; it has Q, ET"]
    );
    assert_eq!(
        errors(&["start -> TON t(1s)", "stop -> TON t(2s)"]),
        ["3:17: instance `t` is already called by the rung at line 2; call each instance once and read its outputs (`t.Q`) elsewhere"]
    );
    assert_eq!(
        errors(&["start -> TON motor(1s)"]),
        ["2:18: instance `motor` has the name of a tag; give it another name"]
    );
    assert_eq!(
        errors(&["start -> CTU c(pv=1, x=start)"]),
        ["2:26: CTU has no argument `x`; it takes pv, r"]
    );
    assert_eq!(
        errors(&["start -> CTU c(r=stop)"]),
        ["2:18: CTU needs `pv`: a preset value, e.g. `CTU c(10)`"]
    );
    assert_eq!(
        errors(&["start -> ADD(count) => count"]),
        ["2:14: `ADD` takes 2 arguments, found 1"]
    );
    assert_eq!(
        errors(&["start -> set motor", "stop -> motor"]),
        ["3:13: tag `motor` is already driven by a set/reset coil at line 2; this rung drives it by a coil"]
    );
    assert_eq!(
        errors(&["q.Q -> lamp", "start -> TON t(1s)", "t -> alarm"]),
        [
            "2:5: `q` is not a block instance (no rung calls a block named so)",
            "4:5: unknown tag `t`; did you mean `t.Q`?",
        ]
    );
    assert_eq!(
        errors(&["start ->", "-> BLINK b(1s)", "-> MOVE(1) => level"]),
        [
            "2:13: expected a coil (`tag`, `/tag`, `set tag`, `reset tag`), a block (`TON t(2s)`) or a box (`ADD(a, 1) => a`), found end of rung",
            "3:14: BLINK takes either on and off times (`BLINK b(1s, 1s)`) or a pattern (`BLINK b(pattern=1101, step=250ms)`)",
            "4:19: tag `level` is read-only (a module input); a program cannot write it",
        ]
        .map(|s| s.replace("b(1s, 1s)", "b(500ms, 500ms)"))
    );
}

#[test]
fn an_undeclared_coil_is_one_error_with_its_uses_and_how_to_declare_it() {
    assert_eq!(
        errors(&[
            "start /stop -> running",
            "running -> motor",
            "running good(running) -> alarm",
            "strt -> lamp",
        ]),
        [
            "2:20: unknown tag `running`; declare it under `tags:` in the project, e.g. `- { name: running, type: bool }` for a memory bit (also used on lines 3, 4)",
            "5:5: unknown tag `strt`; did you mean `start`?",
        ]
    );
}

#[test]
fn quality_contacts_of_unknown_tags_are_errors_at_the_name() {
    assert_eq!(
        errors(&["start -> motor", "/good(sensr) | bad(levl) -> alarm"]),
        [
            "3:11: unknown tag `sensr`; did you mean `sensor`?",
            "3:24: unknown tag `levl`; did you mean `level`?",
        ]
    );
    assert_eq!(
        errors(&["start -> TON t(1s)", "good(t.Q) -> alarm"]),
        ["3:10: `good` takes a tag name, e.g. `good(level)`, not a condition or a block output"]
    );
    // A block instance is no tag.
    assert_eq!(
        errors(&["start -> TON t(1s)", "good(t) -> alarm"]),
        ["3:10: unknown tag `t`; declare it under `tags:` in the project, e.g. `- { name: t, type: bool }` for a memory bit"]
    );
    assert_eq!(
        errors(&["good(level) > 3 -> alarm"]),
        ["2:17: expected `->`, found `>`"]
    );
}

#[test]
fn quality_contacts_follow_the_slot_quality() {
    use softplc_io::point::Quality;
    let mut r = Rig::new(&[
        "/good(sensor) -> alarm",
        "bad(level) -> lamp",
        "good(motor) good(sensor) -> set motor",
    ]);
    let (sensor, level) = (id("sensor"), id("level"));
    let step = |r: &mut Rig, q: Quality| {
        r.image.update(sensor, None, q, r.now);
        r.image.update(level, None, q, r.now);
        r.scan();
        (r.bit("alarm"), r.bit("lamp"))
    };
    // Never read: Bad. `motor` is a memory tag: the PLC marks it good at start-up.
    r.set("motor", Value::Bool(false));
    r.scan();
    assert_eq!((r.bit("alarm"), r.bit("lamp")), (true, true));
    r.image
        .update(sensor, Some(Value::Bool(false)), Quality::Good, r.now);
    r.image
        .update(level, Some(Value::U16(3)), Quality::Good, r.now);
    r.scan();
    assert_eq!((r.bit("alarm"), r.bit("lamp")), (false, false));
    assert!(r.bit("motor"), "good(motor) good(sensor) passed");
    assert_eq!(step(&mut r, Quality::Stale), (true, false));
    assert_eq!(step(&mut r, Quality::Bad), (true, true));
    assert_eq!(r.get("level"), Value::U16(3), "the last good value is kept");
    assert_eq!(step(&mut r, Quality::Good), (false, false));
    // A forced tag is good.
    r.image.update(sensor, None, Quality::Bad, r.now);
    r.image.force(sensor, Value::Bool(true));
    r.image.apply_forces(r.now);
    r.scan();
    assert!(!r.bit("alarm"));
}

#[test]
fn quality_contacts_lower_to_one_instruction() {
    let p = build(&["/good(sensor) | bad(level) -> alarm"]);
    assert_eq!(
        p.instructions(),
        [
            Instr::Good(id("sensor")),
            Instr::Not,
            Instr::Bad(id("level")),
            Instr::Or,
            Instr::Coil(id("alarm")),
            Instr::Pop,
        ]
    );
}

#[test]
fn yaml_errors_have_positions() {
    let e = compile("rungs:\n  - a -> b\n bad", Path::new("p.yaml"), &table()).unwrap_err();
    assert_eq!(e.len(), 1);
    assert_eq!(e[0].pos.file, Path::new("p.yaml"));
    let e = compile("steps: []\n", Path::new("p.yaml"), &table()).unwrap_err();
    assert!(
        e[0].to_string().contains("unknown field `steps`"),
        "{}",
        e[0]
    );
}

#[test]
fn lowered_code_is_balanced_and_flat() {
    let p = build(&[
        "(start | stop) /sensor rising(start) -> motor, set lamp",
        "start -> CTUD c(5, cd=stop, r=sensor, ld=stop) -> alarm",
    ]);
    assert!(lower::max_depth(p.instructions(), &[], &[]).is_none() || !p.instructions().is_empty());
    assert_eq!(p.outputs().count(), 3);
}

/// Arbitrary text never panics the compiler (a cheap stand-in for the fuzzer).
#[test]
fn garbage_never_panics() {
    let pieces = [
        "(", ")", "/", "|", "->", "=>", "=", "<>", "<", "TON", "t", ".", "Q", "1s", ",", "-",
        "start", "rising", "(", "é", "\"", ":", "#", "\n", " ", "1.5", "CTU", "ADD", "set", "0",
        "good", "bad",
    ];
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..3000 {
        let mut text = String::from("rungs:\n  - ");
        for _ in 0..(seed % 14) {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            text.push_str(pieces[(seed % pieces.len() as u64) as usize]);
            if seed % 3 == 0 {
                text.push(' ');
            }
        }
        // Any answer will do; the test is that it comes without a panic.
        drop(compile(&text, Path::new("f.yaml"), &table()));
    }
}

#[test]
fn numbers_that_the_destination_type_cannot_hold_are_type_errors() {
    // Each rung starts at column 5 of its line (`  - `); line 1 is `rungs:`.
    assert_eq!(
        errors(&[
            "start -> MOVE(0.5) => motor",
            "start -> MOVE(0.5) => count",
            "start -> MOVE(70000) => small",
            "count = 0.5 | -1 < small -> lamp",
            "start -> CTU c(2.5) -> alarm",
        ]),
        [
            "2:27: type error: `motor` is bool and MOVE(…) computes a number; drive a bool tag \
             with a coil, e.g. `… -> motor`",
            "3:19: type error: `0.5` is not an i32 value (a whole number from -2147483648 to \
             2147483647); `count` is i32",
            "4:19: type error: `70000` is not a u16 value (a whole number from 0 to 65535); \
             `small` is u16",
            "5:13: type error: `0.5` is not an i32 value (a whole number from -2147483648 to \
             2147483647); `count` is i32",
            "5:19: type error: `-1` is not a u16 value (a whole number from 0 to 65535); `small` \
             is u16",
            "6:20: type error: `2.5` is not an i32 value (a whole number from -2147483648 to \
             2147483647); a counter's preset is i32",
        ]
    );
    // Widening, computed values and reals stay as documented.
    build(&[
        "start -> MOVE(3) => speed, MOVE(level) => speed, MOVE(temp) => count",
        "start -> ADD(count, 0.5) => count, MOVE(-2) => count",
        "temp > 0.5 -> lamp",
        "level >= 65535 -> alarm",
    ]);
}

#[test]
fn a_rung_with_a_title_and_comment_runs_and_keeps_them_in_its_drawing_and_description() {
    let text = "\
rungs:
  - rung: (start | motor) /stop -> motor
    title: Motor latch
    comment: |
      Start latches the motor on;
      stop drops it.
  - start -> lamp
";
    let tags = table();
    let drawn = diagram(text, Path::new("m.yaml"), &tags, &OwnBlocks::none()).unwrap();
    assert_eq!(drawn[0].title.as_deref(), Some("Motor latch"));
    assert_eq!(
        drawn[0].comment.as_deref(),
        Some("Start latches the motor on;\nstop drops it.")
    );
    assert_eq!(drawn[0].line, 2, "the rung's own line, under `rung:`");
    assert_eq!(
        (drawn[1].title.as_ref(), drawn[1].comment.as_ref()),
        (None, None)
    );
    let json = serde_json::to_value(&drawn[1]).unwrap();
    assert!(json.get("title").is_none(), "no key for no title: {json}");

    let program = compile(text, Path::new("m.yaml"), &tags).unwrap();
    let rungs = program.rungs().unwrap();
    let titles: Vec<(u32, Option<&str>)> = rungs
        .iter()
        .map(|r| (r.pos.line, r.title.as_deref()))
        .collect();
    assert_eq!(titles, [(2, Some("Motor latch")), (7, None)]);

    // It runs as the same rung written alone.
    let mut run = Rig {
        program,
        ..Rig::new(&[])
    };
    run.set("start", Value::Bool(true));
    run.scan();
    run.set("start", Value::Bool(false));
    run.scan();
    assert!(run.bit("motor"), "latched");
}

#[test]
fn a_title_too_long_or_over_two_lines_is_refused_at_its_value() {
    let long = "x".repeat(81);
    let text = format!(
        "rungs:\n  - {{ rung: start -> lamp, title: {long} }}\n  - rung: stop -> alarm\n    title: |\n      two\n      lines\n  - {{ rung: a, comment: 1, titel: b }}\n"
    );
    let e = compile(&text, Path::new("m.yaml"), &table()).unwrap_err();
    let shown: Vec<String> = e.iter().map(ToString::to_string).collect();
    assert_eq!(
        shown,
        ["m.yaml:7:28: error: rungs[2]: unknown field `titel`, expected one of `rung`, `title`, `comment`"]
    );
    let text = text.replace("  - { rung: a, comment: 1, titel: b }\n", "");
    let e = compile(&text, Path::new("m.yaml"), &table()).unwrap_err();
    let shown: Vec<String> = e.iter().map(ToString::to_string).collect();
    assert_eq!(
        shown,
        [
            "m.yaml:2:35: error: rung title: 81 characters, at most 80 are allowed",
            "m.yaml:4:12: error: rung title: a line break at character 4: this text is one line \
             (a YAML folded block `>-` joins lines)",
        ]
    );
}
