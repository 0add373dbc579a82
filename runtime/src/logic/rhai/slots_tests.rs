//! The slot path (inputs read through the resolver, writable tags kept in the scope and copied
//! in only when the image changed them, block calls resolved at compile time) against a
//! reference model of the same program written out in Rust, scan by scan.

use std::path::Path;
use std::time::Duration;

use softplc_io::point::{Value, ValueType};

use super::*;
use crate::image::{ProcessImage, TagId};
use crate::logic::{LogicEngine, ScanContext};

/// Memory tags `m0..m{M-1}`: more than [`REBUILD_ABOVE`], so a change of all of them from
/// outside takes the rebuild path.
const M: usize = 12;

/// Tags: inputs `start`, `stop`, `level` (u16), `temp` (f32); outputs and memory `motor`,
/// `count` (i32), `lamp`, `speed` (f32), `small` (u16), `m0..`.
fn tags() -> Vec<(String, ValueType, bool)> {
    let mut t: Vec<(String, ValueType, bool)> = [
        ("start", ValueType::Bool, false),
        ("stop", ValueType::Bool, false),
        ("level", ValueType::U16, false),
        ("temp", ValueType::F32, false),
        ("motor", ValueType::Bool, true),
        ("count", ValueType::I32, true),
        ("lamp", ValueType::Bool, true),
        ("speed", ValueType::F32, true),
        ("small", ValueType::U16, true),
    ]
    .into_iter()
    .map(|(n, ty, w)| (n.to_string(), ty, w))
    .collect();
    t.extend((0..M).map(|i| (format!("m{i}"), ValueType::I32, true)));
    t
}

fn id(name: &str) -> TagId {
    TagId(tags().iter().position(|t| t.0 == name).expect("a tag") as u32)
}

fn compile_sample(script: &str) -> Result<RhaiProgram, Vec<CompileError>> {
    let table = TagTable::new(
        tags()
            .into_iter()
            .enumerate()
            .map(|(i, (n, ty, w))| (n, TagId(i as u32), ty, w)),
    );
    compile(script, Path::new("s.rhai"), &table, Duration::from_secs(1))
}

/// Written and read in the same scan (`count`, then `lamp` from it; `m{i}` from `m{i-1}`
/// written just before), inputs of every type, a timer resolved by its literal name and its
/// output read back by a name in a variable.
fn sample() -> String {
    let mut s = String::from(
        "motor = (start || motor) && !stop;\n\
         count = if motor { count + 1 } else { 0 };\n\
         lamp = count > 3 && motor;\n\
         speed = temp * 2.0 + level;\n\
         small = level + 70000;\n\
         ton(\"t\", motor, 30);\n\
         let name = \"t\";\n\
         m0 = if q(name) { m0 + 1 } else { m0 };\n",
    );
    for i in 1..M {
        s.push_str(&format!("m{i} = m{i} + m{} + count;\n", i - 1));
    }
    s
}

/// The reference: the sample's values after one scan, from the image's values before it.
#[derive(Debug, Clone, PartialEq)]
struct Model {
    motor: bool,
    count: i32,
    on_for: Duration,
    m: [i64; M],
}

impl Model {
    fn scan(&mut self, start: bool, stop: bool, delta: Duration) -> bool {
        let was_on = self.motor;
        self.motor = (start || self.motor) && !stop;
        self.count = if self.motor { self.count + 1 } else { 0 };
        // TON 30 ms: Q once its input has been on for 30 ms of scan time, counted from the
        // scan that first saw it on.
        self.on_for = match (was_on, self.motor) {
            (true, true) => self.on_for + delta,
            _ => Duration::ZERO,
        };
        let q = self.motor && self.on_for >= Duration::from_millis(30);
        if q {
            self.m[0] += 1;
        }
        for i in 1..M {
            self.m[i] += self.m[i - 1] + i64::from(self.count);
        }
        self.count > 3 && self.motor
    }
}

#[test]
fn the_slot_path_gives_the_reference_results_scan_by_scan() {
    let mut program = compile_sample(&sample()).unwrap_or_else(|e| panic!("{}", e[0]));
    let mut image = ProcessImage::new(tags().into_iter().map(|(n, ty, _)| (n, ty.zero())));
    let mut model = Model {
        motor: false,
        count: 0,
        on_for: Duration::ZERO,
        m: [0; M],
    };
    let delta = Duration::from_millis(10);
    let mut lit = 0;
    for cycle in 0..120u64 {
        let now = ScanInstant::after_origin(delta * cycle as u32);
        let start = cycle % 17 < 3;
        let stop = cycle % 29 == 28;
        let level = (cycle * 7 % 50) as u16;
        let temp = cycle as f32 * 0.25;
        image.set(id("start"), Value::Bool(start), now);
        image.set(id("stop"), Value::Bool(stop), now);
        image.set(id("level"), Value::U16(level), now);
        image.set(id("temp"), Value::F32(temp), now);
        // Writes from outside the script, which the next scan must see: one tag (searched
        // by name), then every memory tag at once (the scope rebuilt).
        if cycle == 40 {
            image.set(id("count"), Value::I32(100), now);
            model.count = 100;
        }
        if cycle == 80 {
            for i in 0..M {
                image.set(id(&format!("m{i}")), Value::I32(i as i32), now);
                model.m[i] = i as i64;
            }
        }
        let ctx = ScanContext { now, delta, cycle };
        program.scan(&mut image, &ctx).expect("no fault");
        let lamp = model.scan(start, stop, delta);
        assert_eq!(
            image.get(id("motor")),
            Value::Bool(model.motor),
            "cycle {cycle}"
        );
        assert_eq!(
            image.get(id("count")),
            Value::I32(model.count),
            "cycle {cycle}"
        );
        assert_eq!(image.get(id("lamp")), Value::Bool(lamp), "cycle {cycle}");
        assert_eq!(
            image.get(id("speed")),
            Value::F32(temp * 2.0 + f32::from(level)),
            "cycle {cycle}"
        );
        assert_eq!(
            image.get(id("small")),
            Value::U16(u16::MAX),
            "saturated, cycle {cycle}"
        );
        for i in 0..M {
            let want = model.m[i].clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
            assert_eq!(
                image.get(id(&format!("m{i}"))),
                Value::I32(want),
                "m{i}, cycle {cycle}"
            );
            // Saturated in the image: the model goes on from the image's value, as the script
            // does (the scan copies the saturated value back in).
            model.m[i] = i64::from(want);
        }
        lit += usize::from(lamp) + usize::from(model.m[0] > 0);
    }
    assert!(lit > 20, "the program moves: {lit}");
}

#[test]
fn unknown_tags_and_captured_inputs_are_refused_at_check_time() {
    let errors = |script: &str| -> Vec<String> {
        compile_sample(script)
            .err()
            .unwrap_or_default()
            .iter()
            .map(ToString::to_string)
            .collect()
    };
    let e = errors("motor = strt && !stop;\nlamp = levl > 3;\n");
    assert_eq!(e.len(), 2, "{e:#?}");
    assert!(
        e[0].starts_with("s.rhai:1:9: error: unknown tag or variable `strt`"),
        "{}",
        e[0]
    );
    assert!(e[0].contains("start"), "a suggestion: {}", e[0]);
    assert!(
        e[1].starts_with("s.rhai:2:8: error: unknown tag or variable `levl`"),
        "{}",
        e[1]
    );
    let e = errors("let f = || start;\nmotor = f.call();\n");
    assert!(
        e.iter()
            .any(|e| e.contains("a closure cannot capture the input `start`")),
        "{e:#?}"
    );
    assert!(errors(&sample()).is_empty());
}
