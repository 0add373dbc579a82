//! What the compiler finds before a script runs (`typing.rs`): calls, arguments, types.

use std::collections::BTreeSet;
use std::sync::{Arc, Mutex};

use super::signatures::LIBRARY;
use super::tests::compile_errors as errors;
use super::{blocks, engine, quality};

fn error(script: &str) -> String {
    let mut e = errors(script);
    assert_eq!(e.len(), 1, "{script}: {e:#?}");
    e.remove(0)
}

#[test]
fn calls_in_branches_not_taken_are_checked() {
    assert_eq!(
        error("if count > 50 {\n  motor = tonn(\"t\", start, \"1s\");\n}\n"),
        "s.rhai:2:11: error: unknown function `tonn`; did you mean `ton(name, in, pt)`?"
    );
    assert_eq!(
        error("if false { motor = ton(\"t\", start); }\n"),
        "s.rhai:1:20: error: ton() takes 3 arguments: ton(name, in, pt); this call has 2"
    );
    assert_eq!(
        error("while false { motor = tof(\"t\", start, \"1 sec\"); }\n"),
        "s.rhai:1:39: error: bad duration \"1 sec\" for `pt` of tof(): unknown unit \"sec\" \
         (ns, us, ms, s, m or h); write e.g. \"500ms\", \"2s\" or a number of ms"
    );
    assert_eq!(
        error("motor = stair(\"s\", start);\n"),
        "s.rhai:1:9: error: stair() takes 3 or 4 arguments: stair(name, in, pt) or \
         stair(name, in, pt, reset); this call has 2"
    );
    assert_eq!(
        error("lamp = blink_pattern(\"b\", start, \"10x1\", 100);\n"),
        "s.rhai:1:34: error: bad pattern \"10x1\" for blink_pattern(): a blink pattern is \
         written with 0 and 1 only"
    );
    assert_eq!(
        error("lamp = lamp(\"l\", start, 70000);\n"),
        "s.rhai:1:25: error: argument `mask` of lamp() is a 16-bit mask, 0 to 65535, not a \
         number outside it"
    );
    assert_eq!(
        error("lamp = frobnicate(start);\n"),
        "s.rhai:1:8: error: unknown function `frobnicate`; the library is ton, tof, tp, stair, \
         ctu, ctd, ctud, r_trig, f_trig, sr, rs, toggle, blink, blink_pattern, lamp, q, et, cv, qu, \
         qd, good, bad, limit"
    );
}

#[test]
fn script_functions_and_rhai_functions_are_known() {
    assert_eq!(
        errors(
            "fn twice(x) { x * 2 }\ncount = twice(3);\nspeed = level.to_float().sqrt();\n\
             let a = [1, 2]; a.push(3); count = a.len();\nprint(type_of(a));\n"
        ),
        Vec::<String>::new()
    );
    assert_eq!(
        error("fn twice(x) { x * 2 }\ncount = twice(3, 4);\n"),
        "s.rhai:2:9: error: twice() takes 1 argument; this call has 2"
    );
    assert_eq!(
        error("fn twice(x) { x * 2 }\ncount = twise(3);\n"),
        "s.rhai:2:9: error: unknown function `twise`; did you mean `twice`?"
    );
    // Inside a function too, where tags are not seen.
    assert_eq!(
        error("fn f(x) { ton(\"t\", x) }\nmotor = f(start);\n"),
        "s.rhai:1:11: error: ton() takes 3 arguments: ton(name, in, pt); this call has 2"
    );
}

#[test]
fn arguments_of_known_types_must_fit() {
    assert_eq!(
        error("motor = ton(\"t\", level, \"1s\");\n"),
        "s.rhai:1:18: error: argument `in` of ton() is a bool, not an integer"
    );
    assert_eq!(
        error("motor = ctu(\"c\", start, stop, 2.5);\n"),
        "s.rhai:1:31: error: argument `pv` of ctu() is an integer, not a float"
    );
    assert_eq!(
        error("motor = r_trig(1, start);\n"),
        "s.rhai:1:16: error: argument `name` of r_trig() is an instance name, a string such \
         as \"t1\", not an integer"
    );
    assert_eq!(
        error("speed = limit(0, speed, 10.0);\n"),
        "s.rhai:1:15: error: argument `min` of limit() is a float like the others (write 0.0, \
         not 0), not an integer"
    );
}

#[test]
fn a_value_a_tag_cannot_hold_is_a_type_error() {
    assert_eq!(
        error("motor = 2;\n"),
        "s.rhai:1:9: error: type error: `motor` is bool, the value assigned is an integer; a \
         bool tag takes a condition, e.g. `x > 0`"
    );
    assert_eq!(
        error("count = speed * 2.0;\n"),
        "s.rhai:1:9: error: type error: `count` is i32, the value assigned is a float; round \
         it explicitly, e.g. `x.to_int()` or `x.round().to_int()`"
    );
    assert_eq!(
        error("speed = start;\n"),
        "s.rhai:1:9: error: type error: `speed` is f32, the value assigned is a bool; an f32 \
         tag takes a number"
    );
    assert_eq!(
        error("motor += 1;\n"),
        "s.rhai:1:7: error: type error: `+` cannot take a bool and an integer"
    );
    assert_eq!(
        error("if level { motor = true; }\n"),
        "s.rhai:1:4: error: type error: a condition is a bool, not an integer; compare it, \
         e.g. `x > 0`"
    );
    assert_eq!(
        error("motor = start && level;\n"),
        "s.rhai:1:18: error: type error: a condition is a bool, not an integer; compare it, \
         e.g. `x > 0`"
    );
    assert_eq!(
        error("motor = start == 1;\n"),
        "s.rhai:1:15: error: type error: `==` cannot take a bool and an integer"
    );
    assert_eq!(
        errors("motor = [1];\nlamp = ();\nspeed = #{ a: 1 };\n"),
        [
            "s.rhai:1:9: error: type error: `motor` is bool, the value assigned is an array; a \
             bool tag takes a condition, e.g. `x > 0`",
            "s.rhai:2:8: error: type error: `lamp` is bool, the value assigned is () (nothing); \
             a bool tag takes a condition, e.g. `x > 0`",
            "s.rhai:3:9: error: type error: `speed` is f32, the value assigned is an object \
             map; an f32 tag takes a number",
        ]
    );
    // Widening and the library's own types are fine; a `let` shadowing a tag is not typed.
    assert_eq!(
        errors(
            "speed = level;\nspeed = count / 4;\ncount = et(\"t\") + cv(\"c\");\n\
             motor = ton(\"t\", start, 100) && ctu(\"c\", start, stop, 3);\n\
             small = level - 20;\nfn g() { let motor = 2; motor }\n"
        ),
        Vec::<String>::new()
    );
}

#[test]
fn the_signatures_are_what_the_engine_registers() {
    let mut engine = engine::sandboxed(engine::Limits::default(), 16, &engine::Deadline::new());
    let registered = |engine: &rhai::Engine| -> BTreeSet<(String, usize)> {
        super::internals::function_forms(engine)
            .into_iter()
            .collect()
    };
    let packages = registered(&engine);
    blocks::register(
        &mut engine,
        &Arc::new(Mutex::new(blocks::Blocks::default())),
    );
    quality::register(&mut engine, &Arc::new(quality::Sites::default()));
    let library: BTreeSet<(String, usize)> =
        registered(&engine).difference(&packages).cloned().collect();
    let table: BTreeSet<(String, usize)> = LIBRARY
        .iter()
        .map(|s| (s.name.to_string(), s.params.len()))
        .collect();
    assert_eq!(library, table);
    // The conversions the type errors advise exist.
    for f in [("to_int", 1), ("round", 1), ("to_float", 1)] {
        assert!(packages.contains(&(f.0.to_string(), f.1)), "{f:?}");
    }
}

#[test]
fn every_undeclared_name_is_reported_once_with_the_closest_tag() {
    assert_eq!(
        errors("motor = strt || motor;\nlamp = strt && !stpo;\nif lvel > 2 { motor = tonn(\"t\", start, 1); }\n"),
        [
            "s.rhai:1:9: error: unknown tag or variable `strt`; did you mean `start`?",
            "s.rhai:2:17: error: unknown tag or variable `stpo`; did you mean `stop`?",
            "s.rhai:3:4: error: unknown tag or variable `lvel`; did you mean `level`?",
            "s.rhai:3:23: error: unknown function `tonn`; did you mean `ton(name, in, pt)`?",
        ]
    );
    // A script function sees no tags: its undeclared name is reported where it is.
    assert_eq!(
        errors("fn f() { moter }\nmotor = f();\n"),
        ["s.rhai:1:10: error: unknown tag or variable `moter`; did you mean `motor`?"]
    );
}

#[test]
fn a_literal_the_tag_cannot_hold_is_a_type_error() {
    assert_eq!(
        errors("small = 70000;\nsmall = -1;\nlamp = count == 0.5;\nlamp = 3000000000 > count;\n"),
        [
            "s.rhai:1:9: error: type error: `70000` is not a u16 value (a whole number from 0 \
             to 65535); `small` is u16",
            "s.rhai:2:9: error: type error: `-1` is not a u16 value (a whole number from 0 to \
             65535); `small` is u16",
            "s.rhai:3:17: error: type error: `0.5` is not an i32 value (a whole number from \
             -2147483648 to 2147483647); `count` is i32",
            "s.rhai:4:8: error: type error: `3000000000` is not an i32 value (a whole number \
             from -2147483648 to 2147483647); `count` is i32",
        ]
    );
    assert_eq!(
        errors("small = 65535;\nlamp = speed < 0.5;\ncount = -7;\n"),
        Vec::<String>::new()
    );
}
