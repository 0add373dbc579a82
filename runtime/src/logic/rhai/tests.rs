//! Rhai engine tests: tags, blocks, the sandbox, faults and positions.

use std::path::Path;
use std::time::Duration;

use softplc_io::point::{Value, ValueType};

use super::*;
use crate::image::{ProcessImage, TagId};
use crate::logic::{LogicEngine, ScanContext};

const TAGS: &[(&str, ValueType, bool)] = &[
    ("start", ValueType::Bool, false),
    ("stop", ValueType::Bool, false),
    ("level", ValueType::U16, false),
    ("motor", ValueType::Bool, true),
    ("lamp", ValueType::Bool, true),
    ("count", ValueType::I32, true),
    ("speed", ValueType::F32, true),
    ("small", ValueType::U16, true),
    ("fn", ValueType::Bool, true),
];

pub(super) fn table() -> TagTable {
    TagTable::new(
        TAGS.iter()
            .enumerate()
            .map(|(i, &(n, ty, w))| (n.to_string(), TagId(i as u32), ty, w)),
    )
}

fn id(name: &str) -> TagId {
    TagId(TAGS.iter().position(|t| t.0 == name).expect("a tag") as u32)
}

/// The compile errors of `script` against [`table`] (none when it compiles).
pub(super) fn compile_errors(script: &str) -> Vec<String> {
    match compile(
        script,
        Path::new("s.rhai"),
        &table(),
        Duration::from_secs(1),
    ) {
        Ok(_) => Vec::new(),
        Err(e) => e.iter().map(ToString::to_string).collect(),
    }
}

fn errors(script: &str) -> Vec<String> {
    let e = compile_errors(script);
    assert!(!e.is_empty(), "expected errors");
    e
}

struct Rig {
    program: RhaiProgram,
    image: ProcessImage,
    now: ScanInstant,
}

impl Rig {
    fn new(script: &str) -> Self {
        let program = match compile(
            script,
            Path::new("s.rhai"),
            &table(),
            Duration::from_secs(1),
        ) {
            Ok(p) => p,
            Err(e) => panic!("{}", e[0]),
        };
        Self {
            program,
            image: ProcessImage::new(TAGS.iter().map(|&(n, ty, _)| (n.to_string(), ty.zero()))),
            now: ScanInstant::ZERO,
        }
    }

    fn set(&mut self, name: &str, v: Value) {
        self.image.set(id(name), v, self.now);
    }

    fn get(&self, name: &str) -> Value {
        self.image.get(id(name))
    }

    fn try_scan(&mut self) -> Result<(), LogicFault> {
        let ctx = ScanContext {
            now: self.now,
            delta: Duration::from_millis(10),
            cycle: 0,
        };
        let r = self.program.scan(&mut self.image, &ctx);
        self.now += Duration::from_millis(10);
        r
    }

    fn scan(&mut self) {
        self.try_scan().expect("no fault");
    }
}

#[test]
fn tags_are_variables_and_writes_are_converted() {
    let mut r = Rig::new(
        "motor = (start || motor) && !stop;\nlet x = level * 2;\ncount = x - 1;\nspeed = level / 4.0;\nsmall = level - 20;\n",
    );
    r.set("level", Value::U16(10));
    r.set("start", Value::Bool(true));
    r.scan();
    assert_eq!(r.get("motor"), Value::Bool(true));
    assert_eq!(r.get("count"), Value::I32(19));
    assert_eq!(r.get("speed"), Value::F32(2.5));
    assert_eq!(r.get("small"), Value::U16(0));
    r.set("start", Value::Bool(false));
    r.scan();
    assert_eq!(r.get("motor"), Value::Bool(true), "latched");
    r.set("stop", Value::Bool(true));
    r.scan();
    assert_eq!(r.get("motor"), Value::Bool(false));
}

#[test]
fn lets_do_not_pile_up_in_the_scope() {
    let mut r = Rig::new("let a = 1; let b = [1, 2]; count += a;\n");
    let base = r.program.scope.len();
    for _ in 0..100 {
        r.scan();
    }
    assert_eq!(r.program.scope.len(), base);
    assert_eq!(r.get("count"), Value::I32(100));
}

#[test]
fn blocks_keep_state_by_name() {
    let mut r = Rig::new(
        r#"
motor = ton("t", start, "30ms");
lamp = et("t") >= 20 && !q("t");
if r_trig("edge", start) { count += 1; }
ctu("c", start, stop, 2);
small = cv("c");
speed = limit(0.0, 7.5, 5.0);
"#,
    );
    r.set("start", Value::Bool(true));
    let mut motor = String::new();
    for _ in 0..6 {
        r.scan();
        motor.push(if r.get("motor").as_bool() { '1' } else { '0' });
    }
    assert_eq!(motor, "000111");
    assert_eq!(r.get("count"), Value::I32(0), "no edge on the first scan");
    assert_eq!(r.get("speed"), Value::F32(5.0));
    r.set("start", Value::Bool(false));
    r.scan();
    r.set("start", Value::Bool(true));
    r.scan();
    assert_eq!(r.get("count"), Value::I32(1));
    assert_eq!(r.get("small"), Value::U16(1));
}

#[test]
fn compile_errors_have_user_positions() {
    let e = errors("motor = true;\nlamp = strat;\n");
    assert_eq!(e.len(), 1);
    assert!(e[0].starts_with("s.rhai:2:8: error: "), "{}", e[0]);
    assert!(e[0].contains("strat"), "{}", e[0]);
    let e = errors("\n  start = true;\n");
    assert!(e[0].starts_with("s.rhai:2:3: error: "), "{}", e[0]);
    assert!(e[0].contains("constant"), "{}", e[0]);
    let e = errors("ton(\"t\", start, 10);\nctu(\"t\", start, stop, 1);\nton(\"u\", start, 1);\nton(\"u\", stop, 1);\nlamp = q(\"v\");\n");
    assert_eq!(e.len(), 3, "{e:#?}");
    assert!(
        e[0].starts_with("s.rhai:2:1: error: instance \"t\" is already a TON (line 1)"),
        "{}",
        e[0]
    );
    assert!(
        e[1].starts_with("s.rhai:4:1: error: instance \"u\" is already called at line 3"),
        "{}",
        e[1]
    );
    assert!(
        e[2].starts_with("s.rhai:5:8: error: no block call creates instance \"v\""),
        "{}",
        e[2]
    );
    let e = errors("let x = eval(\"1\");\n");
    assert!(e[0].starts_with("s.rhai:1:"), "{}", e[0]);
    let e = errors("fn = true;\n");
    assert!(e.iter().any(|e| e.contains("Rhai keyword")), "{e:#?}");
}

#[test]
fn runtime_errors_fault_with_the_position() {
    let mut r = Rig::new("motor = true;\nlet x = [1, 2];\ncount = x[5];\n");
    let f = r.try_scan().unwrap_err();
    assert_eq!((f.pos.line, f.pos.column), (3, 11), "{f}");
    // Values whose types the compiler cannot see are checked when they are stored.
    for (script, message) in [
        (
            "let s = \"on\";\nmotor = s;\n",
            "script error: tag `motor` is bool, the script assigned it a string (on)",
        ),
        (
            "let v = 2;\nmotor = v;\n",
            "script error: tag `motor` is bool, the script assigned it an integer (2)",
        ),
        (
            "let v = 0.5;\ncount = v;\n",
            "script error: tag `count` is i32, the script assigned it a float (0.5)",
        ),
    ] {
        let mut r = Rig::new(script);
        let f = r.try_scan().unwrap_err();
        assert_eq!(
            (f.pos.line, f.pos.column, f.message.as_str()),
            (2, 1, message)
        );
        assert_eq!(r.get("motor"), Value::Bool(false), "nothing stored");
    }
    let mut r = Rig::new("let d = \"2 fortnights\";\nton(\"t\", start, d);\n");
    assert!(r.try_scan().unwrap_err().message.contains("bad duration"));
}

#[test]
fn a_runaway_loop_is_stopped() {
    let mut r = Rig::new("motor = true;\nloop { count += 1; }\n");
    let f = r.try_scan().unwrap_err();
    assert_eq!(f.pos.line, 2, "{f}");
    assert!(f.message.contains("script stopped"), "{f}");
    // The time budget stops it before the operation limit when operations are cheap enough.
    let mut p = compile_with(
        "loop { }\n",
        Path::new("s.rhai"),
        &table(),
        Duration::from_millis(20),
        Limits {
            operations: u64::MAX,
            ..Limits::default()
        },
    )
    .unwrap();
    let mut image = ProcessImage::new(TAGS.iter().map(|&(n, ty, _)| (n.to_string(), ty.zero())));
    let ctx = ScanContext {
        now: ScanInstant::ZERO,
        delta: Duration::from_millis(10),
        cycle: 0,
    };
    let f = p.scan(&mut image, &ctx).unwrap_err();
    assert!(f.message.contains("budget of 20 ms"), "{f}");
    let f = Rig::new("fn f(n) { f(n + 1) }\nf(1);\n")
        .try_scan()
        .unwrap_err();
    assert!(f.message.contains("script error"), "{f}");
}

#[test]
fn garbage_never_panics() {
    let pieces = [
        "(", ")", "{", "}", "motor", "=", ";", "start", "\"", "ton", "let", "fn", "1", "+", "loop",
        "if", "\n", " ", "[", "]", "#{", "q(\"t\")", ".", "é", "//", "/*", "`", "good(", "bad",
    ];
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..1500 {
        let mut text = String::new();
        for _ in 0..(seed % 12) {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            text.push_str(pieces[(seed % pieces.len() as u64) as usize]);
        }
        if let Ok(mut p) = compile(
            &text,
            Path::new("f.rhai"),
            &table(),
            Duration::from_millis(5),
        ) {
            let mut image =
                ProcessImage::new(TAGS.iter().map(|&(n, ty, _)| (n.to_string(), ty.zero())));
            let ctx = ScanContext {
                now: ScanInstant::ZERO,
                delta: Duration::from_millis(10),
                cycle: 0,
            };
            // Any answer will do; the test is that it comes without a panic.
            drop(p.scan(&mut image, &ctx));
        }
    }
}

#[test]
fn good_and_bad_read_the_quality_at_the_start_of_the_scan() {
    use softplc_io::point::Quality;
    // `level` is u16: any tag has a quality. `lamp` is written by the script itself.
    let mut r = Rig::new(
        "motor = !good(start);\nsmall = if bad(level) { 1 } else { 0 };\ncount = if good(lamp) { 1 } else { 0 };\nlamp = true;\n",
    );
    assert_eq!(r.program.qualities.len(), 3);
    let step = |r: &mut Rig, q: Quality| {
        r.image.update(id("start"), None, q, r.now);
        r.image.update(id("level"), None, q, r.now);
        r.scan();
        (r.get("motor"), r.get("small"))
    };
    // Never read: Bad; `lamp` is not written yet when the scan starts.
    r.scan();
    assert_eq!(
        (r.get("motor"), r.get("small")),
        (Value::Bool(true), Value::U16(1))
    );
    assert_eq!(r.get("count"), Value::I32(0));
    r.set("start", Value::Bool(false));
    r.set("level", Value::U16(4));
    r.scan();
    assert_eq!(
        (r.get("motor"), r.get("small")),
        (Value::Bool(false), Value::U16(0))
    );
    assert_eq!(r.get("count"), Value::I32(1), "written last scan: good");
    assert_eq!(
        step(&mut r, Quality::Stale),
        (Value::Bool(true), Value::U16(0))
    );
    assert_eq!(
        step(&mut r, Quality::Bad),
        (Value::Bool(true), Value::U16(1))
    );
    assert_eq!(
        step(&mut r, Quality::Good),
        (Value::Bool(false), Value::U16(0))
    );
    // A forced tag is good.
    r.image.update(id("start"), None, Quality::Bad, r.now);
    r.image.force(id("start"), Value::Bool(true));
    r.image.apply_forces(r.now);
    r.scan();
    assert_eq!(r.get("motor"), Value::Bool(false));
}

#[test]
fn quality_errors_have_user_positions() {
    // An unknown tag: the strict-variables error, at the name.
    let e = errors("motor = true;\nlamp = !good(strat);\n");
    assert_eq!(e.len(), 1, "{e:#?}");
    assert!(e[0].starts_with("s.rhai:2:14: error: "), "{}", e[0]);
    assert!(e[0].contains("strat"), "{}", e[0]);
    let e = errors(
        "lamp = good(start && stop);\nlamp = bad(\"level\");\nlet x = true;\nmotor = good(x);\nmotor = good(start, stop);\nfn f(a) { good(a) }\nmotor = start.good();\n",
    );
    assert_eq!(
        e,
        [
            "s.rhai:1:19: error: good() takes one tag name, e.g. good(level), not an expression",
            "s.rhai:2:12: error: bad() takes one tag name, e.g. bad(level), not an expression",
            "s.rhai:4:14: error: `x` is not a tag; good() reads a tag's quality",
            "s.rhai:5:9: error: good() takes one tag name, e.g. good(level), not an expression",
            "s.rhai:6:11: error: good() reads a tag's quality and functions do not see tags; call it in the script's body and pass the result",
            "s.rhai:7:15: error: good() takes one tag name, e.g. good(level), not an expression",
        ]
    );
}

#[test]
fn a_quality_call_the_compiler_did_not_resolve_faults() {
    let mut r = Rig::new("let f = Fn(\"good\");\nmotor = f.call(start);\n");
    let f = r.try_scan().unwrap_err();
    assert!(
        f.message
            .contains("good() must be called directly with a tag name"),
        "{f}"
    );
    assert_eq!((f.pos.line, f.pos.column), (2, 11), "{f}");
}
