//! `ladder`: rungs of contacts, coils and function blocks, one rung per line of a YAML file.
//!
//! ```yaml
//! description: conveyor with jam detection
//! rungs:
//!   - (rising(start) | motor) /stop /estop /jam.Q -> motor    # start/stop latch
//!   - motor /box_at_exit -> TON jam(10s) -> jam_lamp           # running 10 s without a box out
//!   - rising(box_at_exit) -> CTU boxes(1000, r=reset) -> full
//!   - rising(box_at_exit) -> ADD(total, 1) => total
//!   - rung: jam_lamp /reset -> horn
//!     title: Jam horn                     # one line, at most 80 characters
//!     comment: Sounds until reset.        # lines allowed, at most 1,000 characters
//! ```
//!
//! A rung is its text, or a mapping with the text as `rung:` and its `title:` and `comment:`:
//! the page's drawing shows both, `check`'s push-down report names the rung by its title.
//!
//! A rung reads left to right like a ladder diagram: contacts in series (written one after the
//! other), parallel branches (`|`, loosest), parentheses, then `->` and what the power flow
//! drives. `docs/programming.md` is the user's guide; the grammar is in `parser.rs`.
//!
//! - **Contacts**: `x` normally open, `/x` normally closed, `rising(x)` / `falling(x)` edges
//!   (no edge on the first scan), comparisons `level >= 80`, `t.ET > 1.5s`, `n.CV = 10`
//!   (`=`/`==`, `<>`/`!=`, `<`, `<=`, `>`, `>=`), constants `true`, `false`, `1`, `0`.
//!   An empty condition (`-> x`) is always powered. `good(x)` passes while tag `x`'s quality
//!   is Good (read in the last cycle, or a memory or forced tag), `/good(x)` while it is not
//!   (Stale: its module missed a cycle; Bad: the module is lost); `bad(x)` passes only while
//!   it is Bad. The argument is a tag name (of any type), not a condition or a block output.
//! - **Coils**: `x`, `/x` (negated), `set x`, `reset x`, several separated by `,`.
//! - **Blocks** (`crate::logic::blocks`): `KIND name(args)`: the power flow is the block's
//!   first input and its main output (`Q`, `QU`) feeds the coils after a second `->`. Its
//!   outputs `name.Q`, `name.ET` (ms), `name.CV`, `name.QU`, `name.QD` can be read by any rung
//!   (a rung before the call reads the previous scan's value). Each instance is called once.
//! - **Boxes**: `MOVE(a)`, `ADD(a, b)`, `SUB`, `MUL`, `DIV`, `LIMIT(min, x, max)`, then
//!   `=> tag`; computed when powered, in 64-bit floating point, stored with the tag's type
//!   (integers truncate toward zero and saturate). Division by zero faults the PLC.
//!
//! # Compilation
//!
//! YAML → rung texts located in the file → parse → check (unknown tags, instances and blocks,
//! types, arguments, a tag driven by two coils, a write to an input) → lower to a flat
//! instruction list of the logic VM (the one `expr` lowers to) → execute. Every error comes
//! before the first scan, with `file:line:col`.
//!
//! # Execution
//!
//! Rungs run in file order every scan; a rung sees the image as the rungs before it left it.
//! Every contact is evaluated every scan (no short-circuit), so edges and blocks always see
//! their inputs. A scan allocates nothing and looks up no names.

mod check;
mod diagram;
mod error;
mod exec;
mod lexer;
mod lower;
mod parser;
mod rungs;
mod source;
#[cfg(test)]
mod tests;

use std::path::Path;

pub use crate::logic::vm::{BoxOp, BoxSite, Call, CallSite, CmpOp, Instr, Num, PinArg};
pub use diagram::{
    diagram, BlockBox, BlockInput, Coil, Element, MathBox, Operand, Output, OwnBox, RungDiagram,
};
pub use error::{CompileError, CompileErrorKind, Driver, Expected, TypeError};
pub use exec::LadderProgram;
pub use parser::CoilKind;
pub(crate) use source::file_schema;

use crate::logic::blocks::Instance;
use crate::logic::expr::TagTable;
use crate::logic::user_blocks::OwnBlocks;
use crate::logic::SourcePos;

/// A program read, parsed and checked: what the compiler lowers and [`diagram`] draws.
struct Front {
    src: source::LadderSource,
    parsed: Vec<(usize, parser::Rung)>,
    checked: Vec<check::CRung>,
    instances: check::Instances,
}

/// Reads, parses and checks `source`; every error found, sorted by position.
fn front(
    source: &str,
    file: &Path,
    tags: &TagTable,
    own: &OwnBlocks,
) -> Result<Front, Vec<CompileError>> {
    let source = source.strip_prefix('\u{feff}').unwrap_or(source);
    let at = |line: u32, column: u32| SourcePos {
        file: file.to_path_buf(),
        line,
        column,
    };
    let src = match source::LadderSource::read(source) {
        Ok(s) => s,
        Err((line, column, message)) => {
            return Err(vec![CompileError {
                pos: at(line, column),
                kind: CompileErrorKind::Yaml { message },
            }])
        }
    };
    if !src.doc_errors.is_empty() {
        // A title or comment refused stops here, as a YAML error does: the rungs themselves
        // may be fine, but the file is not what its author meant to write.
        return Err(src
            .doc_errors
            .iter()
            .map(|&(line, column, key, error)| CompileError {
                pos: at(line, column),
                kind: CompileErrorKind::Documentation { key, error },
            })
            .collect());
    }
    let mut errors: Vec<check::Error> = Vec::new();
    let mut rungs = Vec::with_capacity(src.rungs.len());
    for (i, rung) in src.rungs.iter().enumerate() {
        match parser::parse_rung(&rung.text) {
            Ok(r) => rungs.push((i, r)),
            Err((pos, kind)) => errors.push((i, pos, kind)),
        }
    }
    let line_of = |rung: usize| src.position(rung, 0).0;
    let (checked, instances) = check::check(&rungs, tags, own, &line_of, &mut errors);
    if !errors.is_empty() {
        let mut out: Vec<CompileError> = errors
            .into_iter()
            .map(|(rung, index, kind)| {
                let (line, column) = src.position(rung, index);
                CompileError {
                    pos: at(line, column),
                    kind,
                }
            })
            .collect();
        out.sort_by_key(|e| (e.pos.line, e.pos.column));
        return Err(out);
    }
    Ok(Front {
        src,
        parsed: rungs,
        checked,
        instances,
    })
}

/// Compiles a ladder program. `file` is used in positions only (the text is `source`).
///
/// On failure returns every error found, sorted by position.
///
/// ```
/// use std::path::Path;
/// use std::time::Duration;
/// use softplc::image::{ProcessImage, TagId};
/// use softplc::scan::ScanInstant;
/// use softplc::logic::{expr::TagTable, ladder, LogicEngine, ScanContext};
/// use softplc_io::point::{Value, ValueType};
///
/// let tags = TagTable::new([
///     ("start".to_string(), TagId(0), ValueType::Bool, false),
///     ("stop".to_string(), TagId(1), ValueType::Bool, false),
///     ("motor".to_string(), TagId(2), ValueType::Bool, true),
/// ]);
/// let text = "rungs:\n  - (start | motor) /stop -> motor\n";
/// let mut program = ladder::compile(text, Path::new("m.yaml"), &tags).unwrap();
/// let mut image = ProcessImage::new(
///     ["start", "stop", "motor"].map(|n| (n.to_string(), Value::Bool(false))),
/// );
/// image.set(TagId(0), Value::Bool(true), ScanInstant::ZERO);
/// let ctx = ScanContext { now: ScanInstant::ZERO, delta: Duration::from_millis(10), cycle: 0 };
/// program.scan(&mut image, &ctx).unwrap();
/// assert_eq!(image.get(TagId(2)), Value::Bool(true));
///
/// let err = ladder::compile("rungs:\n  - strat -> motor\n", Path::new("m.yaml"), &tags)
///     .unwrap_err();
/// assert_eq!(
///     err[0].to_string(),
///     "m.yaml:2:5: error: unknown tag `strat`; did you mean `start`?"
/// );
/// ```
pub fn compile(
    source: &str,
    file: &Path,
    tags: &TagTable,
) -> Result<LadderProgram, Vec<CompileError>> {
    compile_with(source, file, tags, OwnBlocks::none())
}

/// [`compile`] for a program that may call the project's blocks of one's own: `own` holds
/// them and their instances, which the program takes.
pub fn compile_with(
    source: &str,
    file: &Path,
    tags: &TagTable,
    mut own: OwnBlocks,
) -> Result<LadderProgram, Vec<CompileError>> {
    let Front {
        src,
        checked,
        instances,
        ..
    } = front(source, file, tags, &own)?;
    let at = |line: u32, column: u32| SourcePos {
        file: file.to_path_buf(),
        line,
        column,
    };
    let lowered = lower::lower(&checked);
    debug_assert!(
        lower::max_depth(&lowered.code, &lowered.calls, &lowered.own_sites).is_some(),
        "unbalanced lowered code"
    );
    let rung_pos = (0..src.rungs.len())
        .map(|i| {
            let (line, column) = src.position(i, 0);
            at(line, column)
        })
        .collect();
    let types = crate::logic::vm::tag_types(tags);
    let instances = instances.kinds.iter().map(|&k| Instance::new(k)).collect();
    let shapes = own.shapes();
    let described = rungs::describe(&checked, &shapes, |i| {
        let (line, column) = src.position(i, 0);
        let title = src.rungs.get(i).and_then(|r| r.title.as_ref());
        (at(line, column), title.map(ToString::to_string))
    });
    Ok(LadderProgram::new(
        lowered,
        own.take_instances(),
        instances,
        types,
        rung_pos,
        file.to_path_buf(),
    )
    .with_rungs(described))
}
