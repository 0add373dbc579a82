//! The VM path against the interpreter: each plain script runs both ways side by side over
//! many scans of pseudo-random inputs, qualities, forces and scan times, and every scan must
//! leave the same image (values, qualities, timestamps) and the same block states. Scripts
//! that are not plain stay in the interpreter, with the reason, and still run.

use std::path::Path;
use std::time::Duration;

use softplc_io::point::{Quality, Value, ValueType};

use super::*;
use crate::image::{ProcessImage, TagId};
use crate::logic::blocks::Instance;
use crate::logic::vm::Instr;
use crate::logic::{LogicEngine, ScanContext};

/// `(name, type, writable)`: inputs first, then what a script may write.
fn tags() -> Vec<(String, ValueType, bool)> {
    let mut t: Vec<(String, ValueType, bool)> = ["a", "b", "c", "d", "e"]
        .iter()
        .map(|n| (n.to_string(), ValueType::Bool, false))
        .collect();
    t.push(("level".into(), ValueType::U16, false));
    t.push(("temp".into(), ValueType::F32, false));
    t.push(("n".into(), ValueType::I32, false));
    t.extend((0..=10).map(|i| (format!("x{i}"), ValueType::Bool, false)));
    t.extend((0..10).map(|i| (format!("y{i}"), ValueType::Bool, true)));
    t.push(("m1".into(), ValueType::Bool, true));
    t.push(("m2".into(), ValueType::Bool, true));
    t.push(("count".into(), ValueType::I32, true));
    t.push(("speed".into(), ValueType::F32, true));
    t
}

fn table() -> TagTable {
    TagTable::new(
        tags()
            .into_iter()
            .enumerate()
            .map(|(i, (n, ty, w))| (n, TagId(i as u32), ty, w)),
    )
}

fn compile_ok(script: &str) -> RhaiProgram {
    match compile(
        script,
        Path::new("p.rhai"),
        &table(),
        Duration::from_secs(1),
    ) {
        Ok(p) => p,
        Err(e) => panic!("{script}: {}", e[0]),
    }
}

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }

    fn chance(&mut self, one_in: u64) -> bool {
        self.below(one_in) == 0
    }
}

/// What happens to the image between two scans, applied to both images alike.
enum Change {
    Set(TagId, Value),
    Quality(TagId, Quality),
    Force(TagId, Value),
    Unforce(TagId),
}

fn changes(rng: &mut Rng, kinds: &[(String, ValueType, bool)]) -> Vec<Change> {
    let mut out = Vec::new();
    for (i, (_, ty, writable)) in kinds.iter().enumerate() {
        let id = TagId(i as u32);
        // Inputs change often; what the script may write now and then (a write from outside).
        if rng.chance(if *writable { 17 } else { 3 }) {
            let v = match ty {
                ValueType::Bool => Value::Bool(rng.chance(2)),
                ValueType::U16 => Value::U16(rng.below(160) as u16),
                ValueType::I32 => Value::I32(rng.below(12) as i32 - 5),
                ValueType::F32 => Value::F32([2.5, 2.4, -1.0, 0.1, 3.0][rng.below(5) as usize]),
            };
            out.push(Change::Set(id, v));
        }
        if !writable && rng.chance(11) {
            let q = [Quality::Good, Quality::Stale, Quality::Bad][rng.below(3) as usize];
            out.push(Change::Quality(id, q));
        }
        if rng.chance(41) {
            out.push(match rng.chance(2) {
                true => Change::Force(id, Value::Bool(rng.chance(2))),
                false => Change::Unforce(id),
            });
        }
    }
    out
}

fn apply(image: &mut ProcessImage, changes: &[Change], now: ScanInstant) {
    for c in changes {
        match *c {
            Change::Set(id, v) => image.set(id, v, now),
            Change::Quality(id, q) => image.set_quality(id, q),
            Change::Force(id, v) => image.force(id, v),
            Change::Unforce(id) => {
                image.unforce(id);
            }
        }
    }
}

/// Runs `script` on the VM and in the interpreter for `scans` scans and compares every scan.
fn same_both_ways(script: &str, instances: &[&str], scans: usize, seed: u64) {
    let mut on_vm = compile_ok(script);
    assert_eq!(
        on_vm.execution().as_deref(),
        Some("rhai: plain rungs, runs on the logic VM"),
        "{script}"
    );
    let mut interpreted = compile_ok(script).interpreted();
    let kinds = tags();
    let fresh = || ProcessImage::new(kinds.iter().map(|(n, ty, _)| (n.clone(), ty.zero())));
    let (mut vm_image, mut rhai_image) = (fresh(), fresh());
    let mut rng = Rng(seed);
    let mut now = ScanInstant::ZERO;
    let mut changed = 0;
    for scan in 0..scans {
        let before: Vec<Value> = rhai_image.slots().iter().map(|s| s.value).collect();
        let changes = changes(&mut rng, &kinds);
        let delta = Duration::from_millis(rng.below(25));
        now += delta;
        let ctx = ScanContext {
            now,
            delta,
            cycle: scan as u64,
        };
        for image in [&mut vm_image, &mut rhai_image] {
            apply(image, &changes, now);
            image.apply_forces(now);
        }
        let vm = on_vm.scan(&mut vm_image, &ctx);
        let rhai = interpreted.scan(&mut rhai_image, &ctx);
        assert_eq!(vm, rhai, "scan {scan} of\n{script}");
        for image in [&mut vm_image, &mut rhai_image] {
            image.apply_forces(now);
        }
        for (i, (v, r)) in vm_image.slots().iter().zip(rhai_image.slots()).enumerate() {
            assert_eq!(v, r, "scan {scan}, tag {}, of\n{script}", kinds[i].0);
        }
        changed += kinds
            .iter()
            .zip(&before)
            .zip(rhai_image.slots())
            .filter(|(((_, _, writable), b), s)| *writable && **b != s.value)
            .count();
        for name in instances {
            let v = on_vm.instance(name).expect("the VM has every instance");
            let r = interpreted
                .instance(name)
                .unwrap_or_else(|| Instance::new(v.kind()));
            assert_eq!(v, r, "scan {scan}, instance {name}, of\n{script}");
        }
    }
    assert!(
        changed > scans / 10,
        "outputs that hardly move test little: {changed}"
    );
}

/// The bench's synthetic program with `n` rungs (`bench/src/scenarios/logic_cost`).
fn synthetic(n: usize) -> String {
    (0..n)
        .map(|i| {
            format!(
                "y{i} = ton(\"t{i}\", (x{i} || y{i}) && !x{j}, 100);\n",
                j = i + 1
            )
        })
        .collect()
}

#[test]
fn the_synthetic_program_gives_the_same_results_on_the_vm() {
    let names: Vec<String> = (0..10).map(|i| format!("t{i}")).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    same_both_ways(&synthetic(10), &names, 600, 1);
}

#[test]
fn latches_and_bistables_give_the_same_results() {
    let script = "m1 = (a || m1) && !b;\n\
                  y1 = sr(\"s\", a, b);\n\
                  y2 = rs(\"r\", c, d);\n\
                  y3 = toggle(\"tg\", a);\n\
                  y4 = toggle(\"tg2\", b, c);\n\
                  m2 = (r_trig(\"start\", c) || m2) && !d && !q(\"s\");\n";
    same_both_ways(script, &["s", "r", "tg", "tg2", "start"], 500, 2);
}

#[test]
fn timers_over_virtual_time_give_the_same_results() {
    let script = "y1 = ton(\"t1\", a, \"50ms\");\n\
                  y2 = tof(\"t2\", b, 30);\n\
                  y3 = tp(\"t3\", c, 25.5);\n\
                  y4 = ton(\"t4\", d, level);\n\
                  y5 = q(\"t1\") && !q(\"t2\") || q(\"t3\");\n\
                  y6 = stair(\"st\", e, 40) ^ stair(\"st2\", a, \"40ms\", b);\n\
                  y7 = blink(\"b1\", a, 30, \"20ms\") | blink_pattern(\"b2\", b, \"1101\", 10);\n\
                  y8 = tp(\"t5\", tof(\"t6\", e, \"1.5s\"), temp);\n";
    let names = ["t1", "t2", "t3", "t4", "st", "st2", "b1", "b2", "t5", "t6"];
    same_both_ways(script, &names, 800, 3);
}

#[test]
fn edges_counters_and_block_calls_as_statements_give_the_same_results() {
    let script = "y1 = r_trig(\"e1\", a);\n\
                  y2 = f_trig(\"e2\", a) || b;\n\
                  m1 = r_trig(\"e3\", a && b) ^ m1;\n\
                  y3 = ctu(\"c1\", r_trig(\"p\", c), d, 5);\n\
                  y4 = cv(\"c1\") >= 3 && !q(\"c1\");\n\
                  y5 = ctd(\"c2\", a, b, 4);\n\
                  ctud(\"c3\", a, b, c, d, count);\n\
                  y6 = qd(\"c3\") != qu(\"c3\");\n\
                  y7 = !q(\"later\") && a;\n\
                  ton(\"later\", b, 30);\n";
    let names = ["e1", "e2", "e3", "c1", "p", "c2", "c3", "later"];
    same_both_ways(script, &names, 600, 4);
}

#[test]
fn quality_comparisons_and_statement_order_give_the_same_results() {
    let script = "y1 = good(a) && !bad(b);\n\
                  y2 = bad(level) || good(temp);\n\
                  y3 = level > 100 && temp <= 2.5 || n != -3;\n\
                  y4 = level == n || temp > 2 && n <= level || temp == 0.1;\n\
                  y5 = (a == b) != c || n < temp && level != temp;\n\
                  m1 = a && b;\n\
                  y6 = m1 || c;\n\
                  y6 = y6 && !d;\n\
                  y0 = y9;\n\
                  y9 = e;\n\
                  y8 = true;\n\
                  y7 = false || y8;\n";
    same_both_ways(script, &[], 600, 5);
}

#[test]
fn what_is_not_plain_stays_in_the_interpreter_and_runs() {
    for (script, why) in [
        (
            "y1 = a || ton(\"t\", b, 10);\n",
            "line 1: `ton(..)` under `||`",
        ),
        ("y1 = a;\nif b { y2 = true; }\n", "line 2: `if`"),
        ("let x = a;\ny1 = x;\n", "line 1: `let`"),
        (
            "y1 = a;\ncount = count + 1;\n",
            "line 2: an assignment to i32 tag `count`",
        ),
        ("fn f(x) { x }\ny1 = f(a);\n", "script function `fn f`"),
        (
            "ton(\"t\", a, 10);\ny1 = et(\"t\") > 5;\n",
            "line 2: `et(..)`",
        ),
        (
            "y1 = good(y2);\ny2 = a;\n",
            "line 1: `good(y2)` of a tag the script assigns",
        ),
        ("y1 = level + 1 > 3;\n", "line 1: `+`"),
        (
            "y1 = a && r_trig(\"e\", b);\n",
            "line 1: `r_trig(..)` under `&&`",
        ),
    ] {
        let p = compile_ok(script);
        let line = p.execution().unwrap_or_default();
        assert!(
            line.starts_with("rhai: runs in the Rhai interpreter (") && line.contains(why),
            "{script}: {line}"
        );
        let mut image = ProcessImage::new(tags().into_iter().map(|(n, ty, _)| (n, ty.zero())));
        image.set(TagId(0), Value::Bool(true), ScanInstant::ZERO);
        let mut p = p;
        let ctx = ScanContext {
            now: ScanInstant::ZERO,
            delta: Duration::from_millis(10),
            cycle: 0,
        };
        p.scan(&mut image, &ctx).unwrap();
    }
    // Still the interpreter's meaning: the timer under `||` runs only while `a` is false.
    let mut p = compile_ok("y1 = a || ton(\"t\", b, 10);\n");
    let mut image = ProcessImage::new(tags().into_iter().map(|(n, ty, _)| (n, ty.zero())));
    let id = |n: &str| table().get(n).unwrap().id;
    image.set(id("a"), Value::Bool(true), ScanInstant::ZERO);
    image.set(id("b"), Value::Bool(true), ScanInstant::ZERO);
    let scan = |p: &mut RhaiProgram, image: &mut ProcessImage, ms: u64| {
        let ctx = ScanContext {
            now: ScanInstant::after_origin(Duration::from_millis(ms)),
            delta: Duration::from_millis(10),
            cycle: 0,
        };
        p.scan(image, &ctx).unwrap();
    };
    scan(&mut p, &mut image, 0);
    assert!(p.instance("t").is_none(), "never called while `a` holds");
    image.set(id("a"), Value::Bool(false), ScanInstant::ZERO);
    scan(&mut p, &mut image, 20);
    assert_eq!(
        image.get(id("y1")),
        Value::Bool(false),
        "the timer starts now"
    );
    scan(&mut p, &mut image, 30);
    assert_eq!(image.get(id("y1")), Value::Bool(true));
}

#[test]
fn the_vm_path_lowers_to_the_expr_shape() {
    // `y0 = ton("t0", (x0 || y0) && !x1, 100);` is the same instructions as the `expr` rung.
    let p = compile_ok(&synthetic(1));
    let Ok(vm) = &p.on_vm else {
        panic!("on the VM");
    };
    let id = |n: &str| table().get(n).unwrap().id;
    assert_eq!(
        vm.instructions(),
        [
            Instr::Load(id("x0")),
            Instr::Load(id("y0")),
            Instr::Or,
            Instr::Load(id("x1")),
            Instr::Not,
            Instr::And,
            Instr::Timer {
                timer: 0,
                preset: Duration::from_millis(100)
            },
            Instr::Store(id("y0")),
        ]
    );
}

#[test]
fn a_released_rung_is_not_written_on_the_vm_either() {
    let script = "y1 = a;\ny2 = y1 && b;\n";
    let mut p = compile_ok(script);
    assert!(p.execution().unwrap_or_default().contains("logic VM"));
    let id = |n: &str| table().get(n).unwrap().id;
    let mut image = ProcessImage::new(tags().into_iter().map(|(n, ty, _)| (n, ty.zero())));
    image.set(id("a"), Value::Bool(true), ScanInstant::ZERO);
    image.set(id("b"), Value::Bool(true), ScanInstant::ZERO);
    let ctx = ScanContext {
        now: ScanInstant::ZERO,
        delta: Duration::from_millis(10),
        cycle: 0,
    };
    p.scan(&mut image, &ctx).unwrap();
    assert_eq!(image.get(id("y2")), Value::Bool(true));
    p.release(id("y1"));
    // The module's read-back says off: the script no longer writes it, and reads it.
    image.set(id("y1"), Value::Bool(false), ScanInstant::ZERO);
    p.scan(&mut image, &ctx).unwrap();
    assert_eq!(image.get(id("y1")), Value::Bool(false));
    assert_eq!(image.get(id("y2")), Value::Bool(false));
}

#[test]
fn an_image_too_small_faults_alike_both_ways() {
    let script = "y1 = a && speed > 2.0;\n";
    let ctx = ScanContext {
        now: ScanInstant::ZERO,
        delta: Duration::from_millis(10),
        cycle: 0,
    };
    let short = || ProcessImage::new(tags().into_iter().take(5).map(|(n, ty, _)| (n, ty.zero())));
    let on_vm = compile_ok(script).scan(&mut short(), &ctx);
    let interpreted = compile_ok(script).interpreted().scan(&mut short(), &ctx);
    assert_eq!(on_vm, interpreted);
    let fault = on_vm.unwrap_err();
    assert!(
        fault.message.starts_with("program uses tag `y1` (#"),
        "{}",
        fault.message
    );
}
