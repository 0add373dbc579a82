//! The block registry against every language: each block, in each of its forms, is callable
//! in ladder and in Rhai (on the logic VM and in the interpreter), and in `expr` where the
//! registry offers it, with the registry's pins, and gives one trace in all of them; the
//! guide's block tables are the registry's.

use std::path::Path;
use std::time::Duration;

use softplc_io::point::{Value, ValueType};

use super::blocks::{BlockDef, Form, Kind, Pin, PinType};
use super::expr::TagTable;
use super::rhai::signatures;
use super::{expr, ladder, rhai, LogicEngine, ScanContext};
use crate::image::{ProcessImage, TagId};
use softplc_io::time::ScanInstant;

/// The bool inputs the pins are wired to, in pin order, and the coil.
const INPUTS: [&str; 5] = ["a", "b", "c", "d", "e"];
const COIL: &str = "q";

fn table() -> TagTable {
    let inputs = INPUTS.iter().map(|n| (n.to_string(), false));
    let tags = inputs.chain([(COIL.to_string(), true)]);
    TagTable::new(
        tags.enumerate()
            .map(|(i, (n, w))| (n, TagId(i as u32), ValueType::Bool, w)),
    )
}

/// A value for a pin that is not a power flow, as ladder and Rhai write it.
fn value(pin: &Pin) -> (&'static str, &'static str) {
    match (pin.ty, pin.name) {
        (PinType::Time, "ON") => ("20ms", "\"20ms\""),
        (PinType::Time, _) => ("30ms", "\"30ms\""),
        (PinType::Count | PinType::Mask, _) => ("3", "3"),
        (PinType::Pattern, _) => ("1101", "\"1101\""),
        (PinType::Bool, _) => ("", ""),
    }
}

/// The pins of `form` with the input or value each gets: the bools take the inputs in turn.
fn wiring(def: &BlockDef, form: &Form) -> Vec<(usize, &'static Pin, (String, String))> {
    let mut inputs = INPUTS.iter();
    let mut by_pin: Vec<(usize, &'static Pin, (String, String))> = def
        .pins
        .iter()
        .enumerate()
        .filter(|(i, _)| form.pins.contains(i))
        .map(|(i, pin)| {
            let v = match pin.ty {
                PinType::Bool => {
                    let input = inputs.next().expect("an input per bool pin");
                    (input.to_string(), input.to_string())
                }
                _ => {
                    let (l, r) = value(pin);
                    (l.to_string(), r.to_string())
                }
            };
            (i, pin, v)
        })
        .collect();
    by_pin.sort_by_key(|(i, _, _)| *i);
    by_pin
}

/// `a -> KIND t(pt=30ms, r=b) -> q`: every argument by its keyword.
fn ladder_rung(def: &BlockDef, form: &Form) -> String {
    let wired = wiring(def, form);
    let args: Vec<String> = wired
        .iter()
        .skip(1)
        .map(|(_, pin, (v, _))| format!("{}={v}", pin.name.to_ascii_lowercase()))
        .collect();
    let power = &wired[0].2 .0;
    if args.is_empty() {
        format!("{power} -> {} t -> {COIL}", def.name)
    } else {
        format!("{power} -> {} t({}) -> {COIL}", def.name, args.join(", "))
    }
}

/// `q = ton("t", a, "30ms");`: the arguments in the form's order.
fn rhai_call(def: &BlockDef, form: &Form) -> String {
    let wired = wiring(def, form);
    let args: Vec<&str> = form
        .pins
        .iter()
        .filter_map(|i| wired.iter().find(|w| w.0 == *i))
        .map(|w| w.2 .1.as_str())
        .collect();
    format!("{COIL} = {}(\"t\", {});\n", form.rhai, args.join(", "))
}

/// The coil over 60 scans of 10 ms, the inputs driven by a fixed pseudo-random sequence: the
/// power flow changes every few scans, the other inputs are rarely true.
fn trace(engine: &mut dyn LogicEngine) -> String {
    let tags = table();
    let mut image = ProcessImage::new(tags.iter().map(|t| (t.name.clone(), Value::Bool(false))));
    let mut seed: u32 = 0x2545_f491;
    let mut out = String::new();
    for cycle in 0..60u64 {
        let now = ScanInstant::after_origin(Duration::from_millis(10 * cycle));
        for (i, _) in INPUTS.iter().enumerate() {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let r = seed >> 16;
            let v = if i == 0 {
                cycle % 4 != 0 || r % 3 == 0
            } else {
                r % 8 == 0
            };
            if i > 0 || cycle % 2 == 0 {
                image.set(TagId(i as u32), Value::Bool(v), now);
            }
        }
        let ctx = ScanContext {
            now,
            delta: Duration::from_millis(10),
            cycle: cycle + 1,
        };
        engine.scan(&mut image, &ctx).expect("no fault");
        let q = image.get(TagId(INPUTS.len() as u32)).as_bool();
        out.push(if q { '1' } else { '0' });
    }
    out
}

fn ladder_program(rung: &str) -> ladder::LadderProgram {
    let text = format!("rungs:\n  - {rung}\n");
    ladder::compile(&text, Path::new("p.yaml"), &table())
        .unwrap_or_else(|e| panic!("{rung}: {}", e[0]))
}

fn rhai_program(script: &str) -> rhai::RhaiProgram {
    rhai::compile(
        script,
        Path::new("s.rhai"),
        &table(),
        Duration::from_secs(1),
    )
    .unwrap_or_else(|e| panic!("{script}: {}", e[0]))
}

#[test]
fn every_block_is_callable_with_its_pins_in_every_language_with_one_trace() {
    for kind in Kind::ALL {
        let def = kind.def();
        assert_eq!(def.kind, kind);
        assert_eq!(Kind::parse(def.name), Some(kind));
        assert_eq!(def.pins.first().map(|p| p.ty), Some(PinType::Bool));
        for form in def.forms {
            assert_eq!(
                form.pins.first(),
                Some(&0),
                "{}: the power flow first",
                form.rhai
            );
            // Rhai's bools come in pin order: the VM pops them so.
            let bools: Vec<usize> = form
                .pins
                .iter()
                .copied()
                .filter(|&i| def.pins[i].ty == PinType::Bool)
                .collect();
            assert!(bools.windows(2).all(|w| w[0] < w[1]), "{}", form.rhai);

            // Ladder: each pin by its keyword.
            let rung = ladder_rung(def, form);
            let mut ladder = ladder_program(&rung);
            let expected = trace(&mut ladder);
            assert!(
                expected.contains('1') && expected.contains('0'),
                "{rung}: a trace that shows the block working: {expected}"
            );

            // Rhai: the signature the checker holds calls against is the form's pins.
            let pins = form.pins;
            let params: Vec<&str> = pins.iter().map(|&i| def.pins[i].rhai).collect();
            let overload = signatures::overloads(form.rhai)
                .find(|s| s.params.len() == pins.len() + 1)
                .unwrap_or_else(|| panic!("{} has a signature", form.rhai));
            let names: Vec<&str> = overload.params.iter().skip(1).map(|p| p.0).collect();
            assert_eq!(names, params, "{}", form.rhai);

            // Rhai on the VM, and in the interpreter (a `let` keeps a script off the VM).
            let script = rhai_call(def, form);
            let mut on_vm = rhai_program(&script);
            let how = on_vm.execution().unwrap_or_default();
            assert!(how.contains("logic VM"), "{script}: {how}");
            assert_eq!(trace(&mut on_vm), expected, "{script} on the VM vs {rung}");
            let interpreted = format!("let unused = 1;\n{script}");
            let mut interpreter = rhai_program(&interpreted);
            let how = interpreter.execution().unwrap_or_default();
            assert!(how.contains("interpreter"), "{interpreted}: {how}");
            assert_eq!(
                trace(&mut interpreter),
                expected,
                "{script} interpreted vs {rung}"
            );

            // expr: where the registry offers it, `q = ton(a, 30ms)`; elsewhere unknown.
            let call = format!("{COIL} = {}(a, 30ms)\n", def.function());
            let compiled = expr::compile(&call, Path::new("p.expr"), &table());
            match compiled {
                Ok(mut program) => {
                    assert!(def.expr, "{call}: expr offers only what the registry says");
                    assert_eq!(trace(&mut program), expected, "{call} vs {rung}");
                }
                Err(e) => {
                    assert!(!def.expr, "{call}: {}", e[0]);
                    assert!(e[0].to_string().contains("unknown function"), "{}", e[0]);
                }
            }
        }
    }
}

#[test]
fn ladder_takes_exactly_the_registry_s_arguments() {
    for kind in Kind::ALL {
        let def = kind.def();
        let text = format!("rungs:\n  - a -> {} t(nope=1) -> q\n", def.name);
        let err = ladder::compile(&text, Path::new("p.yaml"), &table()).expect_err("refused");
        let keywords: Vec<String> = def
            .arguments()
            .iter()
            .map(|p| p.name.to_ascii_lowercase())
            .collect();
        let known = if keywords.is_empty() {
            "no arguments".to_string()
        } else {
            keywords.join(", ")
        };
        assert_eq!(
            err[0].kind.to_string(),
            format!("{} has no argument `nope`; it takes {known}", def.name)
        );
    }
}

/// The guide's ladder table of blocks, from the registry: one row per form.
fn ladder_table() -> String {
    let mut out = String::from(
        "| block | input (power flow) | arguments | outputs | what it does |\n|---|---|---|---|---|\n",
    );
    for kind in Kind::ALL {
        let def = kind.def();
        for form in def.forms {
            let args: Vec<String> = def
                .form_arguments(form)
                .map(|p| match p.positional {
                    true => p.name.to_string(),
                    false => format!("`{}`", p.name.to_ascii_lowercase()),
                })
                .collect();
            let outputs: Vec<&str> = def.outputs.iter().map(|m| m.name()).collect();
            out.push_str(&format!(
                "| `{}` | {} | {} | {} | {} |\n",
                form.example,
                def.main_input().name,
                args.join(", "),
                outputs.join(", "),
                form.doc
            ));
        }
    }
    out
}

/// The guide's Rhai table of blocks, from the registry: one row per form, each overload.
fn rhai_table() -> String {
    let mut out = String::from("| function | returns |\n|---|---|\n");
    for kind in Kind::ALL {
        let def = kind.def();
        for form in def.forms {
            let calls: Vec<String> = signatures::overloads(form.rhai)
                .map(|s| format!("`{}`", s.usage()))
                .collect();
            out.push_str(&format!(
                "| {} | {} |\n",
                calls.join(", "),
                def.main_output()
            ));
        }
    }
    out
}

#[test]
fn the_guide_lists_the_registry_s_blocks() {
    let guide = include_str!("../../../docs/programming.md");
    for (what, table) in [("ladder", ladder_table()), ("Rhai", rhai_table())] {
        assert!(
            guide.contains(&table),
            "docs/programming.md's {what} table of blocks is not the registry's; it is:\n{table}"
        );
    }
}
