//! Blocks of one's own (issue 31, item 2): a block file included by projects, instances
//! declared by the project, calls from ladder and Rhai of blocks whose bodies are written in
//! either, each instance's variables as tags `s1.start` a scenario addresses, and every
//! refusal `check` gives, with its file:line:col and its exact words.

use crate::common::host::{run_virtual, softplc, softplc_in};
use crate::common::scratch::Scratch;

const SUBJECT: &str = "user-blocks";

/// A latch block with a ladder body, an edge counter in its state, and a Rhai block.
const BLOCKS: &str = "\
blocks:
  - name: LATCH
    inputs:
      - { name: en, type: bool }
      - { name: set, type: bool }
      - { name: clear, type: bool }
      - { name: limit, type: i32, default: 3 }
    outputs:
      - { name: on, type: bool }
      - { name: full, type: bool }
    state:
      - { name: sets, type: i32, initial: 0 }
    body: latch.ladder.yaml
  - name: PULSE
    inputs:
      - { name: x, type: bool }
    outputs:
      - { name: q, type: bool }
    body: pulse.rhai
";

const LATCH_BODY: &str = "\
rungs:
  - en (set | on) /clear -> on
  - rising(set) en -> ADD(sets, 1) => sets
  - sets >= limit -> full
  - clear -> MOVE(0) => sets
";

const PULSE_BODY: &str = "q = r_trig(\"e\", x);\n";

/// A project with `n` (at most 8) instances of LATCH (`l1`..) and one of PULSE (`p`), their
/// buttons and lamps on a simulated RESI-16DI8RO and a MiniMod, and its program.
fn project(n: usize, program: &str, kind: &str) -> String {
    let mut text = String::from(
        "project: blocks\nscan: { period: 100ms }\n\
         buses: [{ name: line, port: sim }]\n\
         modules:\n  - { name: io, bus: line, model: resi-16di8ro, address: 1 }\n\
         \x20 - { name: mm, bus: line, model: minimod, address: 2 }\n\
         tags:\n  - { name: run, type: bool, initial: true }\n",
    );
    for i in 1..=n {
        let c = i + 8;
        text.push_str(&format!(
            "  - {{ name: b{i}, point: io.DI{i} }}\n  - {{ name: c{i}, point: io.DI{c} }}\n  - {{ name: y{i}, point: io.RO{i} }}\n"
        ));
    }
    text.push_str("  - { name: edge, point: mm.X1 }\n  - { name: tick, point: mm.Y1 }\n");
    text.push_str("  - { name: full1, point: mm.Y2 }\n");
    text.push_str("blocks: [lib/my.blocks.yaml]\ninstances:\n");
    for i in 1..=n {
        text.push_str(&format!("  - {{ name: l{i}, block: LATCH }}\n"));
    }
    text.push_str(&format!(
        "  - {{ name: p, block: PULSE }}\nprogram: {{ file: {program}, kind: {kind} }}\n"
    ));
    text
}

fn ladder_program(n: usize) -> String {
    let mut text = String::from("rungs:\n");
    for i in 1..=n {
        text.push_str(&format!("  - run -> LATCH l{i}(b{i}, c{i}) -> y{i}\n"));
    }
    text.push_str("  - edge -> PULSE p -> tick\n  - l1.full -> full1\n");
    text
}

fn rhai_program(n: usize) -> String {
    let mut text = String::new();
    for i in 1..=n {
        text.push_str(&format!("y{i} = latch(\"l{i}\", run, b{i}, c{i});\n"));
    }
    text.push_str("tick = pulse(\"p\", edge);\nfull1 = output(\"l1\", \"full\");\n");
    text
}

/// A scratch folder with the block file, both bodies, a project per language and `files`.
fn folder(case: &str, n: usize, files: &[(&str, &str)]) -> Scratch {
    let s = Scratch::new(SUBJECT, case);
    std::fs::create_dir_all(s.dir.join("lib")).expect("lib/");
    s.write("lib/my.blocks.yaml", BLOCKS);
    s.write("lib/latch.ladder.yaml", LATCH_BODY);
    s.write("lib/pulse.rhai", PULSE_BODY);
    s.write("ladder.yaml", &project(n, "main.ladder.yaml", "ladder"));
    s.write("main.ladder.yaml", &ladder_program(n));
    s.write("rhai.yaml", &project(n, "main.rhai", "rhai"));
    s.write("main.rhai", &rhai_program(n));
    for (name, text) in files {
        s.write(name, text);
    }
    s
}

/// `softplc check FILE`'s error lines, in order.
fn check_errors(s: &Scratch, file: &str) -> Vec<String> {
    let (ok, text) = softplc_in(&s.dir, &["check", file]);
    assert!(!ok, "check passed:\n{text}");
    text.lines()
        .filter(|l| l.contains(": error: "))
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_stations_example_gives_one_trace_in_ladder_and_rhai() {
    for project in [
        "examples/stations/ladder/project.yaml",
        "examples/stations/rhai/project.yaml",
    ] {
        let (ok, text) = softplc(&["check", project]);
        assert!(ok, "{project}: {text}");
        assert!(
            text.contains("  s8.fill_ms i32 = 2000  — How long one fill takes"),
            "{text}"
        );
    }
    let (ok, text) = softplc(&["test", "examples/stations"]);
    assert!(ok, "{text}");
    assert!(text.contains("[stations.ladder.yaml]"), "{text}");
    assert!(text.contains("[stations.rhai]"), "{text}");
    assert!(text.contains("give the same trace"), "{text}");
    assert!(text.contains("2 passed, 0 failed"), "{text}");
}

/// Eight instances of one block keep eight states: each latch follows its own buttons, counts
/// its own presses and reports full at its own limit; the traces of both languages agree.
#[test]
fn eight_instances_behave_independently_in_both_languages() {
    let scenario = "\
name: eight latches
project: ladder.yaml
programs: [main.ladder.yaml, main.rhai]
steps:
  - { at: 1s,   set: { b1: 1, b3: 1, b5: 1, b7: 1 } }
  - { at: 1.2s, set: { b1: 0, b3: 0, b5: 0, b7: 0 } }
  - { at: 1.5s, expect: { y1: 1, y2: 0, y3: 1, y4: 0, y5: 1, y6: 0, y7: 1, y8: 0 } }
  - { at: 1.5s, expect: { l1.on: 1, l2.on: 0, l1.sets: 1, l2.sets: 0, l1.set: 0 } }
  - { at: 2s,   set: { b1: 1 } }
  - { at: 2.2s, set: { b1: 0 } }
  - { at: 3s,   set: { b1: 1 } }
  - { at: 3.2s, set: { b1: 0 } }
  - { at: 3.5s, expect: { l1.sets: 3, l1.full: 1, full1: 1, l3.sets: 1, l3.full: 0, l1.limit: 3 } }
  - { at: 4s,   set: { c1: 1, b2: 1 } }
  - { at: 4.2s, set: { c1: 0, b2: 0 } }
  - { at: 4.5s, expect: { y1: 0, l1.sets: 0, l1.full: 0, full1: 0, y2: 1, l2.sets: 1, y3: 1 } }
  - { at: 5s,   set: { edge: 1 } }
  - { at: 5s,   expect: { tick: 1, p.q: 1, p.x: 1 } }
  - { at: 5.1s, expect: { tick: 0, p.q: 0 } }
";
    let s = folder("eight", 8, &[("eight.scenario.yaml", scenario)]);
    let (ok, text) = softplc_in(&s.dir, &["test", "eight.scenario.yaml"]);
    assert!(ok, "{text}");
    assert!(text.contains("2 passed, 0 failed"), "{text}");
    assert!(text.contains("give the same trace"), "{text}");
}

#[test]
fn ladder_calls_are_held_against_the_block() {
    let program = "\
rungs:
  - run -> LATCH l1(b1, clear=y2, speed=2)
  - run -> LATCH l2(b2)
  - run -> LATCH l9(b1, c1)
  - run -> LATCH l3(b3, c3, limit=b1) -> y3
  - run -> PULSE l4(b4)
  - run -> LATCH l5(b5, c5, 4, 5)
  - l5.bogus -> y1
";
    let s = folder("ladder-calls", 5, &[("main.ladder.yaml", program)]);
    assert_eq!(
        check_errors(&s, "ladder.yaml"),
        [
            "main.ladder.yaml:2:35: error: LATCH has no input `speed`; its inputs are set, clear, limit",
            "main.ladder.yaml:3:18: error: input `clear` of LATCH is missing: it has no default, so every call gives it (`clear=...`)",
            "main.ladder.yaml:4:18: error: instance `l9` of LATCH is not declared: add `- { name: l9, block: LATCH }` to the project's `instances:`",
            "main.ladder.yaml:5:35: error: input `limit` of LATCH is an i32, not `b1`, a bool",
            "main.ladder.yaml:6:18: error: instance `l4` is a LATCH (the project's `instances:`), not a PULSE",
            "main.ladder.yaml:7:32: error: LATCH takes at most 3 positional arguments (set, clear, limit)",
            "main.ladder.yaml:8:8: error: LATCH `l5` has no `bogus`; it has en, set, clear, limit, on, full, sets",
        ]
    );
}

#[test]
fn rhai_calls_are_held_against_the_block() {
    let program = "\
y1 = latch(\"l1\", run, 5, c1);
y2 = latch(\"l2\", run, b2);
y3 = latch(\"l9\", run, b3, c3);
y4 = latch(\"l4\", run, b4, c4, true);
y5 = latch(\"l5\", run, b5, c5, 7);
tick = output(\"l9\", \"on\");
tick = output(\"l1\", \"bogus\");
y1 = latch(\"l1\", run, b1, c1);
";
    let s = folder("rhai-calls", 5, &[("main.rhai", program)]);
    assert_eq!(
        check_errors(&s, "rhai.yaml"),
        [
            "main.rhai:1:23: error: argument `set` of latch() is a bool (an input of LATCH), not an integer",
            "main.rhai:2:6: error: latch() takes 4 to 5 arguments: latch(name, en, set, clear[, limit]); this call has 3",
            "main.rhai:3:12: error: latch(): \"l9\" is not a declared instance of LATCH (declared: l1, l2, l3, l4, l5); declare it under the project's `instances:`",
            "main.rhai:4:31: error: argument `limit` of latch() is an i32 (an input of LATCH), not a bool",
            "main.rhai:6:15: error: output(): \"l9\" is no declared instance (the project's `instances:`: l1, l2, l3, l4, l5, p)",
            "main.rhai:7:21: error: output(): LATCH \"l1\" has no \"bogus\"; it has en, set, clear, limit, on, full, sets",
            "main.rhai:8:6: error: instance \"l1\" is already called at line 1; call each instance once per scan and read its variables with output(\"l1\", …)",
        ]
    );
}

#[test]
fn a_body_sees_only_its_block_and_calls_the_instances_it_declares() {
    let body = "\
rungs:
  - en -> on, set
  - en -> y1
  - en -> PULSE inner(en)
";
    let s = folder("body", 1, &[("lib/latch.ladder.yaml", body)]);
    assert_eq!(
        check_errors(&s, "ladder.yaml"),
        [
            "lib/latch.ladder.yaml:2:15: error: `set` is an input of LATCH: its body reads it, a call writes it",
            "lib/latch.ladder.yaml:3:11: error: `y1` is not declared by LATCH: its body sees only its inputs, outputs and state (en, set, clear, limit, on, full, sets); declare it under the block's `outputs:` or `state:`",
            "lib/latch.ladder.yaml:4:17: error: instance `inner` of PULSE is not declared by LATCH: add `- { name: inner, block: PULSE }` to the `instances:` of LATCH in its block file",
        ]
    );
}

/// Blocks that nest LATCH (ladder body) and PULSE (Rhai body): PAIR's body is ladder,
/// RPAIR's Rhai.
const NEST_BLOCKS: &str = "\
blocks:
  - name: PAIR
    inputs: [{ name: en, type: bool }, { name: a, type: bool }, { name: b, type: bool }]
    outputs: [{ name: both, type: bool }, { name: edge, type: bool }]
    state: [{ name: pulses, type: i32 }]
    instances:
      - { name: la, block: LATCH }
      - { name: pb, block: PULSE }
    body: pair.ladder.yaml
  - name: RPAIR
    inputs: [{ name: en, type: bool }, { name: a, type: bool }, { name: b, type: bool }]
    outputs: [{ name: both, type: bool }, { name: edge, type: bool }]
    state: [{ name: pulses, type: i32 }]
    instances: [{ name: la, block: LATCH }, { name: pb, block: PULSE }]
    body: pair.rhai
";

/// A project calling a PAIR `p1` and an RPAIR `p2` on the same buttons.
const NEST_PROJECT: &str = "\
project: nest
scan: { period: 100ms }
buses: [{ name: line, port: sim }]
modules: [{ name: io, bus: line, model: resi-16di8ro, address: 1 }]
tags:
  - { name: run, type: bool, initial: true }
  - { name: a, point: io.DI1 }
  - { name: b, point: io.DI2 }
  - { name: y1, point: io.RO1 }
  - { name: y2, point: io.RO2 }
blocks: [lib/my.blocks.yaml, lib/nest.blocks.yaml]
instances: [{ name: p1, block: PAIR }, { name: p2, block: RPAIR }]
program: { file: nest.ladder.yaml, kind: ladder }
traces: [{ name: nested, tags: [p1.la.on, p1.la.sets, p2.pb.q], trigger: p1.la.sets >= 1 }]
";

/// A scratch folder with [`NEST_BLOCKS`], their bodies and [`NEST_PROJECT`] (its program
/// `nest.ladder.yaml`), and `files`.
fn nest_folder(case: &str, files: &[(&str, &str)]) -> Scratch {
    let mut all = vec![
        ("lib/nest.blocks.yaml", NEST_BLOCKS),
        (
            "lib/pair.ladder.yaml",
            "rungs:\n  - en -> LATCH la(a, b) -> both\n  - a -> PULSE pb -> edge\n  - pb.q -> ADD(pulses, 1) => pulses\n",
        ),
        (
            "lib/pair.rhai",
            "both = latch(\"la\", en, a, b);\nedge = pulse(\"pb\", a);\nif output(\"pb\", \"q\") { pulses += 1; }\n",
        ),
        ("nest.yaml", NEST_PROJECT),
        (
            "nest.ladder.yaml",
            "rungs:\n  - run -> PAIR p1(a, b) -> y1\n  - run -> RPAIR p2(a, b) -> y2\n",
        ),
        (
            "nest.rhai",
            "y1 = pair(\"p1\", run, a, b);\ny2 = rpair(\"p2\", run, a, b) && output(\"p2\", \"la.on\");\n",
        ),
    ];
    all.extend_from_slice(files);
    folder(case, 1, &all)
}

/// `check project.yaml` in `s` passes and its push-down report holds every one of `lines`;
/// then the scenario runs with that plan and passes.
fn plans_and_passes(s: &Scratch, lines: &[&str], scenario: &str) {
    let (ok, text) = softplc_in(&s.dir, &["check", "project.yaml"]);
    assert!(ok, "{text}");
    for line in lines {
        assert!(text.contains(line), "no {line:?} in:\n{text}");
    }
    let (ok, text) = softplc_in(&s.dir, &["test", scenario]);
    assert!(ok && text.contains("1 passed, 0 failed"), "{text}");
}

/// A call whose body's main output comes from a nested instance's latch is described to the
/// push-down planner through both bodies: `-> OUTER o1(start, stop) -> motor` over a body
/// `en -> STARTER st(a, b) -> q` is the latch of start and stop, planned into the module; the
/// bodies still run in the scan, so the nested tags go on showing the latch.
#[test]
fn a_latch_inside_a_nested_instance_is_pushed_down() {
    let s = Scratch::new(SUBJECT, "nested-push-down");
    s.write(
        "my.blocks.yaml",
        "blocks:\n  - name: STARTER\n    inputs: [{ name: en, type: bool }, { name: start, type: bool }, { name: stop, type: bool }]\n    outputs: [{ name: on, type: bool }]\n    body: starter.ladder.yaml\n\
         \x20 - name: OUTER\n    inputs: [{ name: en, type: bool }, { name: a, type: bool }, { name: b, type: bool }]\n    outputs: [{ name: q, type: bool }]\n    instances: [{ name: st, block: STARTER }]\n    body: outer.ladder.yaml\n",
    );
    s.write(
        "starter.ladder.yaml",
        "rungs:\n  - en (start | on) /stop -> on\n",
    );
    s.write(
        "outer.ladder.yaml",
        "rungs:\n  - en -> STARTER st(a, b) -> q\n",
    );
    s.write(
        "machine.ladder.yaml",
        "rungs:\n  - -> OUTER o1(start, stop) -> motor\n",
    );
    s.write(
        "project.yaml",
        "project: npd\nscan: { period: 100ms }\noffload: auto\n\
         buses: [{ name: line1, port: sim }]\n\
         modules: [{ name: mm1, bus: line1, model: minimod, address: 1 }]\n\
         tags:\n  - { name: start, point: mm1.X2 }\n  - { name: stop, point: mm1.X3 }\n\
         \x20 - { name: motor, point: mm1.Y1, safe: false }\n\
         blocks: [my.blocks.yaml]\n\
         instances: [{ name: o1, block: OUTER }]\n\
         program: { file: machine.ladder.yaml, kind: ladder }\n",
    );
    s.write(
        "npd.scenario.yaml",
        "name: o1 latches the motor in the module\nproject: project.yaml\nsteps:\n\
         \x20 - { at: 1s,   set: { start: 1 } }\n  - { at: 1.2s, set: { start: 0 } }\n\
         \x20 - { at: 1.5s, expect: { motor: 1, o1.q: 1, o1.st.on: 1, o1.st.start: 0 } }\n\
         \x20 - { at: 2s,   set: { stop: 1 } }\n  - { at: 2.2s, set: { stop: 0 } }\n\
         \x20 - { at: 2.5s, expect: { motor: 0, o1.q: 0, o1.st.on: 0 } }\n",
    );
    plans_and_passes(
        &s,
        &[
            "machine.ladder.yaml:2:5 motor (set/reset latch): module mm1 Y1, automatic outputs AON/AOFF (an OFF condition wins)",
            "      Y1AON1         = 0x0002 X2",
            "      Y1AOFF1        = 0x0004 X3",
            "1 coil(s) planned: 1 in modules, 0 central",
        ],
        "npd.scenario.yaml",
    );
}

/// A block's body calls blocks of one's own through the instances its block declares, in
/// either language; the nested instances' pins are the tags `p1.la.on`, which a scenario
/// expects, and two outer instances keep two nested states.
#[test]
fn a_body_calls_its_own_nested_instances() {
    let scenario = "\
name: nested latches and pulses
project: nest.yaml
programs: [nest.ladder.yaml, nest.rhai]
steps:
  - { at: 1s,   set: { a: 1 } }
  - { at: 1.2s, set: { a: 0 } }
  - { at: 1.5s, expect: { y1: 1, y2: 1, p1.la.on: 1, p2.la.on: 1, p1.la.sets: 1, p2.la.sets: 1 } }
  - { at: 1.5s, expect: { p1.pulses: 1, p2.pulses: 1, p1.pb.x: 0, p1.la.limit: 3, p1.la.set: 0 } }
  - { at: 2s,   set: { a: 1 } }
  - { at: 2s,   expect: { p1.pb.q: 1, p1.edge: 1, p2.pb.q: 1, p2.edge: 1 } }
  - { at: 2.1s, expect: { p1.pb.q: 0, p2.pb.q: 0 } }
  - { at: 2.2s, set: { a: 0 } }
  - { at: 2.5s, expect: { p1.pulses: 2, p2.pulses: 2, p1.la.sets: 2, p1.la.full: 0 } }
  - { at: 3s,   set: { b: 1 } }
  - { at: 3.2s, set: { b: 0 } }
  - { at: 3.5s, expect: { y1: 0, y2: 0, p1.la.on: 0, p2.la.on: 0, p1.la.sets: 0, p1.both: 0 } }
";
    let s = nest_folder("nest", &[("nest.scenario.yaml", scenario)]);
    let (ok, text) = softplc_in(&s.dir, &["check", "nest.yaml"]);
    assert!(ok, "{text}");
    assert!(text.contains("p1.la.sets"), "{text}");
    let (ok, text) = softplc_in(&s.dir, &["test", "nest.scenario.yaml"]);
    assert!(ok, "{text}");
    assert!(text.contains("2 passed, 0 failed"), "{text}");
    assert!(text.contains("give the same trace"), "{text}");
}

/// A block that reaches itself through its instances, directly or through a chain, is
/// refused at the instance's `block:`, naming the chain; so is an instance of a block no file
/// defines.
#[test]
fn recursion_through_nested_instances_is_refused_naming_the_chain() {
    let blocks = "\
blocks:
  - name: SELF
    inputs: [{ name: en, type: bool }]
    outputs: [{ name: q, type: bool }]
    instances: [{ name: me, block: SELF }]
    body: self.ladder.yaml
  - name: OUTER
    inputs: [{ name: en, type: bool }]
    outputs: [{ name: q, type: bool }]
    instances:
      - { name: m, block: MIDDLE }
    body: self.ladder.yaml
  - name: MIDDLE
    inputs: [{ name: en, type: bool }]
    outputs: [{ name: q, type: bool }]
    instances:
      - { name: o, block: OUTER }
      - { name: g, block: GHOST }
    body: self.ladder.yaml
";
    let project = "\
project: rec
scan: { period: 100ms }
tags: [{ name: run, type: bool }]
blocks: [lib/rec.blocks.yaml]
program: { file: main.ladder.yaml, kind: ladder }
";
    let s = folder(
        "recursion",
        1,
        &[
            ("lib/rec.blocks.yaml", blocks),
            ("lib/self.ladder.yaml", "rungs:\n  - en -> q\n"),
            ("rec.yaml", project),
        ],
    );
    let errors = check_errors(&s, "rec.yaml");
    assert_eq!(
        errors,
        [
            "lib/rec.blocks.yaml:5:36: error: block SELF calls itself through its instances: SELF (me: SELF) -> SELF; a block's instances are of other blocks, none of which may call it back",
            "lib/rec.blocks.yaml:11:27: error: block OUTER calls itself through its instances: OUTER (m: MIDDLE) -> MIDDLE (o: OUTER) -> OUTER; a block's instances are of other blocks, none of which may call it back",
            "lib/rec.blocks.yaml:17:27: error: block MIDDLE calls itself through its instances: MIDDLE (o: OUTER) -> OUTER (m: MIDDLE) -> MIDDLE; a block's instances are of other blocks, none of which may call it back",
            "lib/rec.blocks.yaml:18:27: error: unknown block \"GHOST\" (known: SELF, OUTER, MIDDLE)",
        ],
        "{errors:#?}"
    );
    // A nested instance named like one of the block's variables: refused with the file's
    // other errors, before any block is looked up.
    s.write(
        "lib/rec.blocks.yaml",
        "blocks:\n  - name: CLASH\n    inputs: [{ name: en, type: bool }]\n    outputs: [{ name: q, type: bool }]\n    instances: [{ name: en, block: OUTER }]\n    body: self.ladder.yaml\n",
    );
    assert_eq!(
        check_errors(&s, "rec.yaml"),
        [
            "rec.yaml:4:10: error: the block file lib/rec.blocks.yaml has 1 error(s)",
            "lib/rec.blocks.yaml:5:25: error: instance name `en` is already used by a variable at line 3",
        ]
    );
}

#[test]
fn a_name_clash_names_both_files_and_a_built_in_is_refused() {
    let other = "\
blocks:
  - name: LATCH
    inputs: [{ name: en, type: bool }]
    outputs: [{ name: q, type: bool }]
    body: pulse.rhai
";
    let s = folder("clash", 1, &[("lib/other.blocks.yaml", other)]);
    let text = std::fs::read_to_string(s.dir.join("ladder.yaml")).expect("the project");
    let both = text.replace(
        "blocks: [lib/my.blocks.yaml]",
        "blocks: [lib/my.blocks.yaml, lib/other.blocks.yaml]",
    );
    s.write("ladder.yaml", &both);
    assert_eq!(
        check_errors(&s, "ladder.yaml"),
        ["lib/other.blocks.yaml:2:11: error: block LATCH is also defined in lib/my.blocks.yaml:2; a project includes one block of a name"]
    );
    s.write("lib/other.blocks.yaml", &other.replace("LATCH", "TON"));
    assert_eq!(
        check_errors(&s, "ladder.yaml"),
        ["lib/other.blocks.yaml:2:11: error: block TON has the name of a built-in block; name yours otherwise (built-in blocks: TON, TOF, TP, STAIR, CTU, CTD, CTUD, R_TRIG, F_TRIG, SR, RS, TOGGLE, BLINK, LAMP)"]
    );
}

#[test]
fn a_block_file_is_checked_at_its_own_lines() {
    let bad = "\
blocks:
  - name: Latch
    inputs:
      - { name: en, type: int }
      - { name: x, type: bool, initial: 1 }
    outputs:
      - { name: n, type: i32 }
    state:
      - { name: s, type: u16, initial: -1 }
    body: latch.txt
";
    let s = folder("file", 1, &[("lib/my.blocks.yaml", bad)]);
    assert_eq!(
        check_errors(&s, "ladder.yaml"),
        [
            "lib/my.blocks.yaml:2:11: error: block name \"Latch\" must be upper case letters, digits and _, not first a digit (STATION, PUMP_2)",
            "lib/my.blocks.yaml:4:27: error: unknown type \"int\" (known: bool, u16, i32, f32)",
            "lib/my.blocks.yaml:5:41: error: `initial` is for state variables, not for input `x`",
            "lib/my.blocks.yaml:7:26: error: the first output of block Latch, `n`, is an i32: it is the block's main output, a bool",
            "lib/my.blocks.yaml:9:40: error: initial \"-1\" of `s` is not a u16",
            "lib/my.blocks.yaml:10:11: error: the body \"latch.txt\" must be a ladder file (.yaml) or a Rhai script (.rhai)",
            "ladder.yaml:15:10: error: the block file lib/my.blocks.yaml has 6 error(s)",
        ]
    );
}

#[test]
fn instances_are_declared_once_of_a_known_block() {
    let s = folder("instances", 1, &[]);
    let text = std::fs::read_to_string(s.dir.join("ladder.yaml")).expect("the project");
    let bad = text.replace(
        "  - { name: p, block: PULSE }",
        "  - { name: p, block: PULS }\n  - { name: run, block: PULSE }\n  - { name: l1, block: PULSE }\n  - { name: io, block: PULSE }",
    );
    s.write("ladder.yaml", &bad);
    assert_eq!(
        check_errors(&s, "ladder.yaml"),
        [
            "ladder.yaml:18:23: error: unknown block \"PULS\" (known: LATCH, PULSE)",
            "ladder.yaml:19:13: error: instance name `run` is already used by a tag at line 8",
            "ladder.yaml:20:13: error: instance name `l1` is already used by an instance at line 17",
            "ladder.yaml:21:13: error: instance name `io` is already used by a module at line 5",
        ]
    );
}

/// An instance's variables are recorded as any tag: the flight record of a virtual run holds
/// two tickers' pins and state, a replay of the program gives them back cycle by cycle, and
/// a trace may name them.
#[test]
fn instance_pins_are_recorded_replayed_and_named_by_a_trace() {
    let s = Scratch::new(SUBJECT, "record");
    s.write(
        "tick.blocks.yaml",
        "blocks:\n  - name: TICKER\n    inputs: [{ name: en, type: bool }, { name: ms, type: i32, default: 300 }]\n    outputs: [{ name: q, type: bool }]\n    state: [{ name: ticks, type: i32 }]\n    body: ticker.ladder.yaml\n",
    );
    s.write(
        "ticker.ladder.yaml",
        "rungs:\n  - en -> BLINK b(ms, ms) -> q\n  - rising(q) -> ADD(ticks, 1) => ticks\n",
    );
    s.write(
        "project.yaml",
        "project: rec\nscan: { period: 100ms }\nbuses: [{ name: line, port: sim }]\n\
         modules: [{ name: mm, bus: line, model: minimod, address: 1 }]\n\
         tags:\n  - { name: run, type: bool, initial: true }\n  - { name: lamp, point: mm.Y1 }\n  - { name: lamp2, point: mm.Y2 }\n\
         blocks: [tick.blocks.yaml]\n\
         instances: [{ name: t1, block: TICKER }, { name: t2, block: TICKER }]\n\
         program: { file: main.ladder.yaml, kind: ladder }\n\
         traces:\n  - { name: ticks, tags: [t1.q, t1.ticks, lamp], trigger: t1.ticks >= 3 }\n",
    );
    s.write(
        "main.ladder.yaml",
        "rungs:\n  - run -> TICKER t1 -> lamp\n  - run -> TICKER t2(ms=500ms) -> lamp2\n",
    );
    let (ok, text) = softplc_in(&s.dir, &["check", "project.yaml"]);
    assert!(ok, "{text}");
    let (ok, text) = softplc_in(
        &s.dir,
        &[
            "run",
            "project.yaml",
            "--virtual",
            "--for",
            "5s",
            "--record",
            "1m",
        ],
    );
    assert!(ok, "{text}");
    let (ok, text) = softplc_in(
        &s.dir,
        &[
            "replay",
            "project.yaml.record",
            "project.yaml",
            "--csv",
            "out.csv",
        ],
    );
    assert!(ok && text.contains("outputs identical"), "{text}");
    let csv = std::fs::read_to_string(s.dir.join("out.csv")).expect("the CSV");
    let header: Vec<&str> = csv.lines().next().expect("a header").split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| h.split(" [").next() == Some(name))
            .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
    };
    let last: Vec<&str> = csv.lines().last().expect("a row").split(',').collect();
    let value = |name: &str| -> i64 { last[column(name)].parse().expect("a number") };
    // 5 s of a 300/300 ms blinker and of a 500/500 ms one, each counting its own rises.
    assert_eq!(value("rec.t1.ticks"), value("new.t1.ticks"));
    assert_eq!(value("rec.t1.ms"), 300);
    assert_eq!(value("rec.t2.ms"), 500);
    assert!(value("rec.t1.ticks") >= 7, "{}", last.join(","));
    assert!(
        (4..=5).contains(&value("rec.t2.ticks")),
        "{}",
        last.join(",")
    );
}

/// A body a module's logic can run (a start/stop latch on the block's inputs) is pushed down
/// per instance, like the same rung written out: the call feeding it a module's inputs goes
/// into the module, a call fed a memory tag and a body comparing numbers stay central, each
/// with `check`'s reason; the scenario runs with the plan.
#[test]
fn a_pushable_body_is_pushed_down_per_instance() {
    let s = Scratch::new(SUBJECT, "push-down");
    s.write(
        "my.blocks.yaml",
        "blocks:\n  - name: STARTER\n    inputs: [{ name: en, type: bool }, { name: start, type: bool }, { name: stop, type: bool }]\n    outputs: [{ name: on, type: bool }]\n    state: [{ name: presses, type: i32 }]\n    body: starter.ladder.yaml\n  - name: COUNTED\n    inputs: [{ name: en, type: bool }, { name: start, type: bool }]\n    outputs: [{ name: on, type: bool }]\n    state: [{ name: n, type: i32 }]\n    body: counted.ladder.yaml\n",
    );
    s.write(
        "starter.ladder.yaml",
        "rungs:\n  - en (start | on) /stop -> on\n  - rising(start) -> ADD(presses, 1) => presses\n",
    );
    s.write(
        "counted.ladder.yaml",
        "rungs:\n  - en start n > 2 -> on\n  - rising(start) -> ADD(n, 1) => n\n",
    );
    s.write(
        "machine.ladder.yaml",
        "rungs:\n  - -> STARTER s1(start, stop) -> motor\n  - run -> STARTER s2(stop, start) -> fan\n  - -> COUNTED c1(start) -> lamp\n",
    );
    s.write(
        "project.yaml",
        "project: pd\nscan: { period: 100ms }\noffload: auto\n\
         buses: [{ name: line1, port: sim }]\n\
         modules: [{ name: mm1, bus: line1, model: minimod, address: 1 }]\n\
         tags:\n  - { name: start, point: mm1.X2 }\n  - { name: stop, point: mm1.X3 }\n\
         \x20 - { name: motor, point: mm1.Y1, safe: false }\n  - { name: fan, point: mm1.Y2, safe: false }\n\
         \x20 - { name: lamp, point: mm1.Y3, safe: false }\n  - { name: run, type: bool, initial: true }\n\
         blocks: [my.blocks.yaml]\n\
         instances: [{ name: s1, block: STARTER }, { name: s2, block: STARTER }, { name: c1, block: COUNTED }]\n\
         program: { file: machine.ladder.yaml, kind: ladder }\n",
    );
    s.write(
        "pd.scenario.yaml",
        "name: s1 latches the motor in the module\nproject: project.yaml\nsteps:\n\
         \x20 - { at: 1s,   set: { start: 1 } }\n  - { at: 1.2s, set: { start: 0 } }\n\
         \x20 - { at: 1.5s, expect: { motor: 1, s1.on: 1, s1.presses: 1, fan: 0 } }\n\
         \x20 - { at: 2s,   set: { stop: 1 } }\n  - { at: 2.2s, set: { stop: 0 } }\n\
         \x20 - { at: 2.5s, expect: { motor: 0, s1.on: 0, s1.presses: 1 } }\n",
    );
    plans_and_passes(
        &s,
        &[
            "machine.ladder.yaml:2:5 motor (set/reset latch): module mm1 Y1, automatic outputs AON/AOFF (an OFF condition wins)",
            "      Y1AON1         = 0x0002 X2",
            "      Y1AOFF1        = 0x0004 X3",
            "machine.ladder.yaml:3:5 fan (set/reset latch): central: memory or a timer in the condition: run is a memory tag, which the module cannot see",
            "machine.ladder.yaml:4:5 lamp (other): central: a block of your own drives this coil, and its body's main output: a comparison of numbers in the condition",
            "3 coil(s) planned: 1 in modules, 2 central",
        ],
        "pd.scenario.yaml",
    );
}

/// A state variable with `retain: true` is kept across a restart like a retained tag: each
/// instance's count goes on from where the last run left it.
#[test]
fn a_retained_state_goes_on_after_a_restart() {
    let s = Scratch::new(SUBJECT, "retain");
    s.write(
        "tick.blocks.yaml",
        "blocks:\n  - name: TICKER\n    inputs: [{ name: en, type: bool }, { name: ms, type: i32, default: 300 }]\n    outputs: [{ name: q, type: bool }]\n    state: [{ name: ticks, type: i32, retain: true }]\n    body: ticker.ladder.yaml\n",
    );
    s.write(
        "ticker.ladder.yaml",
        "rungs:\n  - en -> BLINK b(ms, ms) -> q\n  - rising(q) -> ADD(ticks, 1) => ticks\n",
    );
    s.write(
        "project.yaml",
        "project: retained\nscan: { period: 100ms }\nbuses: [{ name: line, port: sim }]\n\
         modules: [{ name: mm, bus: line, model: minimod, address: 1 }]\n\
         tags:\n  - { name: run, type: bool, initial: true }\n  - { name: lamp, point: mm.Y1 }\n  - { name: lamp2, point: mm.Y2 }\n\
         blocks: [tick.blocks.yaml]\n\
         instances: [{ name: t1, block: TICKER }, { name: t2, block: TICKER }]\n\
         program: { file: main.ladder.yaml, kind: ladder }\n",
    );
    s.write(
        "main.ladder.yaml",
        "rungs:\n  - run -> TICKER t1 -> lamp\n  - run -> TICKER t2(ms=500ms) -> lamp2\n",
    );
    let retained = || -> (i64, i64) {
        let text = std::fs::read_to_string(s.dir.join("project.retain.json")).expect("saved");
        let json: serde_json::Value = serde_json::from_str(&text).expect("JSON");
        let count = |tag: &str| json["values"][tag].as_i64().expect("a count");
        (count("t1.ticks"), count("t2.ticks"))
    };
    let (ok, text) = softplc_in(&s.dir, &["run", "project.yaml", "--virtual", "--for", "3s"]);
    assert!(ok, "{text}");
    let (t1, t2) = retained();
    assert!(t1 > t2 && t2 > 0, "{t1}, {t2}");
    let (ok, text) = softplc_in(&s.dir, &["run", "project.yaml", "--virtual", "--for", "3s"]);
    assert!(ok, "{text}");
    assert_eq!(
        retained(),
        (2 * t1, 2 * t2),
        "each count goes on from the first run's"
    );
}

/// A reload of the program keeps every instance's outputs and state: its count goes on from
/// where it was, not from its `initial:`.
#[test]
fn a_reload_keeps_an_instances_state() {
    let s = Scratch::new(SUBJECT, "reload");
    s.write(
        "tick.blocks.yaml",
        "blocks:\n  - name: TICKER\n    inputs: [{ name: en, type: bool }]\n    outputs: [{ name: q, type: bool }]\n    state: [{ name: ticks, type: i32 }]\n    body: ticker.ladder.yaml\n",
    );
    s.write(
        "ticker.ladder.yaml",
        "rungs:\n  - en -> BLINK b(300ms, 300ms) -> q\n  - rising(q) -> ADD(ticks, 1) => ticks\n",
    );
    s.write(
        "project.yaml",
        "project: reload\nscan: { period: 100ms }\nbuses: [{ name: line, port: sim }]\n\
         modules: [{ name: mm, bus: line, model: minimod, address: 1 }]\n\
         tags:\n  - { name: run, type: bool, initial: true }\n  - { name: lamp, point: mm.Y1 }\n\
         blocks: [tick.blocks.yaml]\ninstances: [{ name: t1, block: TICKER }]\n\
         program: { file: main.ladder.yaml, kind: ladder }\n",
    );
    s.write("main.ladder.yaml", "rungs:\n  - run -> TICKER t1 -> lamp\n");
    let socket = s.dir.join("ctl.sock");
    let socket_arg = socket.to_str().expect("a UTF-8 path");
    let running = run_virtual(&s.dir.join("project.yaml"), &socket);
    let ticks = || -> i64 {
        let (_, text) = softplc(&["status", "--json", "--socket", socket_arg]);
        let status: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        status["tags"]
            .as_array()
            .and_then(|tags| tags.iter().find(|t| t["name"] == "t1.ticks"))
            .and_then(|t| t["value"].as_str()?.parse().ok())
            .unwrap_or(-1)
    };
    let wait_past = |floor: i64| {
        let begin = std::time::Instant::now();
        loop {
            let n = ticks();
            if n > floor {
                return n;
            }
            assert!(
                begin.elapsed() < std::time::Duration::from_secs(30),
                "t1.ticks stayed at {n}"
            );
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
    };
    let before = wait_past(5);
    let (ok, text) = softplc(&["reload", "--socket", socket_arg]);
    assert!(ok && text.contains("reloaded"), "{text}");
    // The first reading after the reload is not below the last one before it.
    let after = wait_past(0);
    assert!(
        after >= before,
        "t1.ticks went from {before} back to {after}"
    );
    drop(running);
}

/// An operator forcing an instance's pins at cycle boundaries, as `softplc force` would, and
/// the watched tags after every cycle.
struct ForcingOperator {
    /// The instance whose LATCH pins are forced (`l1`, `p1.la`).
    inst: String,
    watch: Vec<String>,
    trace: std::sync::Arc<std::sync::Mutex<Vec<(u64, String)>>>,
}

impl softplc::scan::CycleBoundary for ForcingOperator {
    fn between_cycles(
        &mut self,
        plc: &mut softplc::plc::Plc,
        stats: &softplc::scan::ScanStats,
        _now: softplc_io::time::ScanInstant,
    ) {
        let image = plc.image();
        let row: Vec<String> = self
            .watch
            .iter()
            .map(|t| {
                image
                    .id(t)
                    .map_or("?".into(), |id| image.get(id).to_string())
            })
            .collect();
        if let Ok(mut trace) = self.trace.lock() {
            trace.push((stats.cycles, row.join(" ")));
        }
        let forced = |r: Result<(), softplc::plc::TagError>| assert!(r.is_ok(), "{:?}", r.err());
        let pin = |p: &str| format!("{}.{p}", self.inst);
        match stats.cycles {
            10 => forced(plc.force(&pin("set"), "1").map(drop)),
            15 => forced(plc.unforce(Some(&pin("set"))).map(drop)),
            20 => {
                forced(plc.force(&pin("set"), "1").map(drop));
                forced(plc.force(&pin("on"), "0").map(drop));
                forced(plc.force(&pin("full"), "1").map(drop));
            }
            25 => {
                forced(plc.unforce(Some(&pin("on"))).map(drop));
                forced(plc.unforce(Some(&pin("full"))).map(drop));
            }
            30 => forced(plc.unforce(None).map(drop)),
            _ => {}
        }
    }
}

/// `project` run for 4 s of virtual time under a [`ForcingOperator`] forcing `inst`'s pins:
/// after each cycle, `inst`'s set, on, full, sets, then `out` (what its main output drives)
/// and `other`.
fn forcing_trace(
    project: &std::path::Path,
    inst: &str,
    out: &str,
    other: &str,
) -> Vec<(u64, String)> {
    let trace = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let loaded = softplc::project::load(project).expect("the project");
    let plc = softplc::plc::Plc::build(
        loaded,
        std::sync::Arc::new(softplc::clock::VirtualClock::new()),
    )
    .expect("a PLC");
    let mut watch: Vec<String> = ["set", "on", "full", "sets"]
        .iter()
        .map(|p| format!("{inst}.{p}"))
        .collect();
    watch.extend([out.to_owned(), other.to_owned()]);
    let operator = ForcingOperator {
        inst: inst.to_owned(),
        watch,
        trace: trace.clone(),
    };
    let mut engine = softplc::scan::ScanEngine::new(plc)
        .run_for(std::time::Duration::from_secs(4))
        .with_boundary(operator);
    engine.run();
    drop(engine);
    let trace = trace.lock().expect("the trace").clone();
    assert!(trace.len() >= 35, "{}: {trace:?}", project.display());
    trace
}

/// What the forcing operator's trace holds after `cycle` for the LATCH's set, on, full,
/// sets and the output its main output drives.
fn forced_latch(cycle: u64) -> &'static str {
    match cycle {
        ..=10 => "0 0 0 0 0",
        // set forced: the body latches `on`, counts the rise.
        11..=15 => "1 1 0 1 1",
        // Unforced: the call's argument (0) again, the latch holds.
        16..=20 => "0 1 0 1 1",
        // set forced again (a second rise), on forced off though the body computes it on,
        // full forced on though the body computes 2 < 3.
        21..=25 => "1 0 1 2 0",
        // on and full back to the body.
        26..=30 => "1 1 0 2 1",
        // Everything unforced.
        _ => "0 1 0 2 1",
    }
}

/// A force on an instance's input pin is what its body reads in the next scan, a force on an
/// output pin holds what the rest of the program and the module's output see whatever the
/// body computes, and an unforce gives the pin back to the call and the body: the same trace
/// from a ladder and a Rhai program calling the block.
#[test]
fn a_forced_pin_is_what_the_body_reads_and_the_program_sees() {
    let s = folder("force", 1, &[]);
    for project in ["ladder.yaml", "rhai.yaml"] {
        let trace = forcing_trace(&s.dir.join(project), "l1", "y1", "full1");
        for (cycle, row) in &trace {
            // full1: a rung of the program reading l1.full.
            let full1 = if (21..=25).contains(cycle) { "1" } else { "0" };
            assert_eq!(
                *row,
                format!("{} {full1}", forced_latch(*cycle)),
                "{project}: after cycle {cycle}; the trace: {trace:#?}"
            );
        }
    }
}

/// A force on a nested instance's pin (`p1.la.set`, `p1.la.on`) reaches the nested body
/// through its outer instance's, whichever language the outer body is written in; the other
/// outer instance (p2, on the same buttons) is not touched.
#[test]
fn a_forced_nested_pin_reaches_the_nested_body() {
    let s = nest_folder("nest-force", &[]);
    for (inst, out, other) in [("p1.la", "y1", "y2"), ("p2.la", "y2", "y1")] {
        let trace = forcing_trace(&s.dir.join("nest.yaml"), inst, out, other);
        for (cycle, row) in &trace {
            assert_eq!(
                *row,
                format!("{} 0", forced_latch(*cycle)),
                "{inst}: after cycle {cycle}; the trace: {trace:#?}"
            );
        }
    }
}
