//! Synthetic N-rung programs in each engine, with the tags and image to run them on, for the
//! logic-cost scenario (per-scan logic cost of 10, 100, 1000 rungs). They live here, with
//! their only user, and reach the engines through the runtime's public API alone.
//!
//! Rung `i` is a start/stop latch through an on-delay timer, the commonest rung shape:
//!
//! ```text
//! expr:   y{i} = ton((x{i} | y{i}) & !x{i+1}, 100ms)
//! ladder: (x{i} | y{i}) /x{i+1} -> TON t{i}(100ms) -> y{i}
//! rhai:   y{i} = ton("t{i}", (x{i} || y{i}) && !x{i+1}, 100);
//! ```
//!
//! Tags: inputs `x0..=xN` (read-only), outputs `y0..y(N-1)`; the three programs give the same
//! outputs for the same inputs and times. [`drive_inputs`] changes a few inputs per cycle,
//! deterministically, so timers start and stop.

use std::fmt::Write;
use std::path::Path;
use std::time::Duration;

use softplc::image::{ProcessImage, TagId};
use softplc::logic::expr::TagTable;
use softplc::logic::{expr, ladder, rhai, LogicEngine};
use softplc_io::point::{Value, ValueType};
use softplc_io::time::ScanInstant;

/// The engines a synthetic program exists in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Language {
    /// The `expr` engine: the baseline.
    Expr,
    /// Ladder YAML.
    Ladder,
    /// Rhai.
    Rhai,
}

/// Tag names in image order: `x0..=xN`, then `y0..y(N-1)`, with their types and whether the
/// program may write them.
pub(crate) fn tags(n: usize) -> Vec<(String, ValueType, bool)> {
    let inputs = (0..=n).map(|i| (format!("x{i}"), ValueType::Bool, false));
    let outputs = (0..n).map(|i| (format!("y{i}"), ValueType::Bool, true));
    inputs.chain(outputs).collect()
}

/// The tag table programs compile against.
pub(crate) fn tag_table(n: usize) -> TagTable {
    TagTable::new(
        tags(n)
            .into_iter()
            .enumerate()
            .map(|(i, (name, ty, w))| (name, TagId(i as u32), ty, w)),
    )
}

/// A process image with every tag false.
pub(crate) fn image(n: usize) -> ProcessImage {
    ProcessImage::new(tags(n).into_iter().map(|(name, ty, _)| (name, ty.zero())))
}

/// The `expr` program with `n` rungs.
pub(crate) fn expr_program(n: usize) -> String {
    (0..n)
        .map(|i| format!("y{i} = ton((x{i} | y{i}) & !x{j}, 100ms)\n", j = i + 1))
        .collect()
}

/// The ladder program with `n` rungs.
pub(crate) fn ladder_program(n: usize) -> String {
    let mut s = String::from("description: synthetic latch + timer rungs\nrungs:\n");
    for i in 0..n {
        let _ = writeln!(
            s,
            "  - (x{i} | y{i}) /x{j} -> TON t{i}(100ms) -> y{i}",
            j = i + 1
        );
    }
    s
}

/// The Rhai program with `n` rungs.
pub(crate) fn rhai_program(n: usize) -> String {
    let mut s = String::from("// synthetic latch + timer rungs\n");
    for i in 0..n {
        let _ = writeln!(
            s,
            "y{i} = ton(\"t{i}\", (x{i} || y{i}) && !x{j}, 100);",
            j = i + 1
        );
    }
    s
}

/// The `n`-rung program of `language`, compiled against [`tag_table`]. An error is a bug:
/// the programs are generated to be valid.
pub(crate) fn compile(language: Language, n: usize) -> anyhow::Result<Box<dyn LogicEngine>> {
    let table = tag_table(n);
    let fail =
        |e: &dyn std::fmt::Display| anyhow::anyhow!("synthetic program does not compile: {e}");
    Ok(match language {
        Language::Expr => Box::new(
            expr::compile(&expr_program(n), Path::new("synthetic.expr"), &table)
                .map_err(|e| fail(&e[0]))?,
        ),
        Language::Ladder => Box::new(
            ladder::compile(&ladder_program(n), Path::new("synthetic.yaml"), &table)
                .map_err(|e| fail(&e[0]))?,
        ),
        Language::Rhai => Box::new(
            rhai::compile(
                &rhai_program(n),
                Path::new("synthetic.rhai"),
                &table,
                Duration::from_secs(1),
            )
            .map_err(|e| fail(&e[0]))?,
        ),
    })
}

/// Sets the inputs for `cycle`: input `i` is true for 20 cycles out of every 20 + (i % 7),
/// a pattern that keeps latches and timers moving without any randomness.
pub(crate) fn drive_inputs(image: &mut ProcessImage, n: usize, cycle: u64) {
    for i in 0..=n {
        let period = 20 + (i as u64 % 7) + 20;
        let on = (cycle + i as u64 * 13) % period < 20;
        image.set(TagId(i as u32), Value::Bool(on), ScanInstant::ZERO);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use softplc::logic::ScanContext;

    #[test]
    fn every_engine_gives_the_same_outputs() {
        let n = 30;
        let mut programs = [
            compile(Language::Ladder, n).unwrap(),
            compile(Language::Rhai, n).unwrap(),
            compile(Language::Expr, n).unwrap(),
        ];
        let mut images = [image(n), image(n), image(n)];
        let mut lit = 0;
        for cycle in 0..200 {
            let ctx = ScanContext {
                now: ScanInstant::after_origin(Duration::from_millis(10 * cycle)),
                delta: Duration::from_millis(10),
                cycle,
            };
            for (p, img) in programs.iter_mut().zip(images.iter_mut()) {
                drive_inputs(img, n, cycle);
                p.scan(img, &ctx).unwrap();
            }
            let outs = |img: &ProcessImage| -> Vec<Value> {
                (n + 1..2 * n + 1)
                    .map(|i| img.get(TagId(i as u32)))
                    .collect()
            };
            assert_eq!(outs(&images[0]), outs(&images[1]), "cycle {cycle}");
            assert_eq!(outs(&images[0]), outs(&images[2]), "cycle {cycle}");
            lit += outs(&images[0]).iter().filter(|v| v.as_bool()).count();
        }
        assert!(lit > 100, "outputs move: {lit}");
    }
}
