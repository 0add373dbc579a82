//! `expr`: the minimal logic engine — boolean coil assignments, one per line.
//!
//! A program (`.expr` file) is parsed (with line:column positions), checked against the
//! project's [`TagTable`], lowered to a flat stack-machine program over [`TagId`]s ([`Instr`],
//! the instruction set of the logic VM that ladder lowers to as well), and executed once per
//! scan by [`ExprProgram`], a [`LogicEngine`].
//!
//! # Example
//!
//! ```text
//! # Conveyor: a start press latches the motor; stop or a box at the exit drops it.
//! motor = (rising(start) | motor) & !stop & !box_at_exit
//! lamp  = box_at_exit                      # a box waits at the exit
//! alarm = ton(motor & !box_at_entry, 30s)  # running empty for 30 s
//! hot   = temperature > 80.5 or not cooling_ok
//! alarm = !good(level_high)                # the level switch's module is lost
//! ```
//!
//! # Language
//!
//! - **Lines.** One statement per line; `#` starts a comment; blank lines are ignored.
//! - **Statement.** `COIL = EXPR` assigns the value of `EXPR` to the bool tag `COIL` every
//!   scan. Each coil is assigned by one statement only, and only tags the program may write
//!   (not module inputs). Only bool tags are assigned: numbers are for ladder or rhai programs.
//! - **Names.** Tags are written `[A-Za-z_][A-Za-z0-9_]*`, case-sensitive. `and`, `or`, `not`,
//!   `true`, `false` are reserved. A name followed by `(` is a function call; otherwise it is a
//!   tag (so a tag may be called `ton`).
//! - **Operators**, loosest first: `|` (or `or`), `^` (xor), `&` (or `and`), `!` (or `not`);
//!   comparisons bind tighter still, so `!level > 5` is `!(level > 5)`; parentheses group.
//!   `a | b ^ c & !d` is `a | (b ^ (c & (!d)))`.
//! - **Literals.** `0`, `1`, `true`, `false`. Other numbers appear only in comparisons.
//! - **Comparisons.** `<`, `<=`, `>`, `>=`, `==`, `!=` between a numeric tag (u16, i32, f32)
//!   and a number (`5`, `-3`, `2.5`) or another numeric tag, giving a bool. A numeric tag is
//!   used nowhere else. Values compare as exact `f64`; a literal compared with an `f32` tag is
//!   first rounded to `f32`, so `temp == 0.1` holds when `temp` holds `0.1`.
//! - **Edges.** `rising(E)` is true for the one scan where `E` is true and was false on the
//!   previous scan; `falling(E)` likewise for true → false. The first scan has no previous
//!   value and sees no edge: a button held down through start-up is not a press (unlike IEC
//!   `R_TRIG`, which fires on the first scan; here the machine does not restart by itself).
//! - **Timers** (IEC 61131-3 semantics, time from [`ScanContext::now`] only):
//!   - `ton(E, PT)` on-delay: true once `E` has been true continuously for `PT`, measured from
//!     the first scan that saw `E` true (`now - start >= PT`); false as soon as `E` is false.
//!     With a 20 ms period, `ton(E, 100ms)` is true from the 6th consecutive scan with `E`.
//!   - `tof(E, PT)` off-delay: true while `E` is true and until `E` has been false for `PT`,
//!     measured the same way; false before `E` was ever true.
//!   - `tp(E, PT)` pulse: a rising edge of `E` (same rule as `rising`) starts a pulse that is
//!     true on the scans with `now - start < PT`, whatever `E` does meanwhile; edges during a
//!     pulse are ignored. With a 20 ms period, `tp(E, 50ms)` is true for 3 scans.
//!
//!   `PT` is a duration literal: a number with a unit `us`, `ms` or `s` (`100us`, `250ms`,
//!   `2s`, `1.5s`), greater than zero and at most 2³² − 1 ms (≈ 49.7 days).
//! - **Quality.** `good(T)` is true while tag `T`'s quality is Good: read from its module in
//!   the last cycle, or a memory tag, or a forced tag. It is false while `T` is Stale (its
//!   module missed a cycle) or Bad (its module is lost after its line's fail limit, or was
//!   never read). `bad(T)` is true only while `T` is Bad. The argument is a tag name of any
//!   type (`good(level)` for a u16 tag too), not an expression: `good(a & b)` is an error.
//!   The quality is the image's at the moment the statement runs (set by the input phase).
//! - **State per call site.** Each `rising`, `falling`, `ton`, `tof`, `tp` written in the
//!   program has its own memory; two `rising(start)` are two independent one-shots.
//!
//! # Execution
//!
//! Statements run in file order each scan; a statement reads the image as the statements
//! before it left it (so `motor` on the right of its own assignment is the previous scan's
//! value, a self-holding contact). Every part of every expression is evaluated every scan — no
//! short-circuit — so timers and edges inside `&`/`|` always see their input. Tags are read with
//! [`ProcessImage::get`] whatever their quality: a tag whose quality is Bad or Stale still reads
//! its current (last good or initial) value; a program that must act on a lost module tests
//! `good(T)` (its [`Slot::quality`], looked up by index like a value). Coils are written
//! with [`ProcessImage::set`] stamped with the scan time. Same inputs and same scan times give
//! the same outputs. A scan allocates nothing and looks up no names.
//!
//! [`LogicEngine`]: crate::logic::LogicEngine
//! [`ScanContext::now`]: crate::logic::ScanContext::now
//! [`ProcessImage::get`]: crate::image::ProcessImage::get
//! [`Slot::quality`]: crate::image::Slot::quality
//! [`ProcessImage::set`]: crate::image::ProcessImage::set

mod check;
mod error;
mod exec;
mod lexer;
mod lower;
mod parser;
mod rungs;
#[cfg(test)]
mod tests;

use std::collections::HashMap;
use std::path::Path;

use softplc_io::point::ValueType;

pub use crate::logic::vm::{CmpOp, Instr, Num as Operand};
pub use error::{CompileError, CompileErrorKind, DurationError, Expected, TypeError};
pub use exec::ExprProgram;

/// The closest name within two edits, for "did you mean" (shared with the ladder engine).
pub(crate) use check::{closest as closest_name, literal_fits, type_words};

use crate::image::TagId;
use crate::logic::SourcePos;

/// One tag a program may use.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TagEntry {
    /// The name programs use.
    pub name: String,
    /// Its slot in the process image.
    pub id: TagId,
    /// Its type.
    pub ty: ValueType,
    /// Whether the program may assign it (false for tags bound to module inputs).
    pub writable: bool,
}

/// The tags a program may use, by name.
#[derive(Debug, Clone, Default)]
pub struct TagTable {
    entries: Vec<TagEntry>,
    by_name: HashMap<String, usize>,
}

impl TagTable {
    /// A table from `(name, id, type, writable)`; on a repeated name the first entry counts.
    pub fn new(tags: impl IntoIterator<Item = (String, TagId, ValueType, bool)>) -> Self {
        tags.into_iter().collect()
    }

    /// A tag by name.
    pub fn get(&self, name: &str) -> Option<&TagEntry> {
        self.by_name.get(name).and_then(|&i| self.entries.get(i))
    }

    /// All tags, in the order given.
    pub fn iter(&self) -> impl Iterator<Item = &TagEntry> + '_ {
        self.entries.iter()
    }

    /// Number of tags.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when there are no tags.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

impl FromIterator<(String, TagId, ValueType, bool)> for TagTable {
    fn from_iter<I: IntoIterator<Item = (String, TagId, ValueType, bool)>>(iter: I) -> Self {
        let mut table = TagTable::default();
        for (name, id, ty, writable) in iter {
            if table.by_name.contains_key(&name) {
                continue;
            }
            table.by_name.insert(name.clone(), table.entries.len());
            table.entries.push(TagEntry {
                name,
                id,
                ty,
                writable,
            });
        }
        table
    }
}

/// Compiles an `.expr` program. `file` is used in positions only (the text is `source`).
///
/// On failure returns every error found, sorted by position: at least one per bad line
/// (the first syntax error of a line), and every name, type, coil and duration error of the
/// lines that parse.
///
/// ```
/// use std::path::Path;
/// use std::time::Duration;
/// use softplc::image::{ProcessImage, TagId};
/// use softplc::logic::{expr, LogicEngine, ScanContext};
/// use softplc_io::point::{Value, ValueType};
///
/// let tags = expr::TagTable::new([
///     ("start".to_string(), TagId(0), ValueType::Bool, false),
///     ("stop".to_string(), TagId(1), ValueType::Bool, false),
///     ("motor".to_string(), TagId(2), ValueType::Bool, true),
/// ]);
/// let mut program =
///     expr::compile("motor = (start | motor) & !stop\n", Path::new("m.expr"), &tags).unwrap();
/// let mut image = ProcessImage::new(
///     ["start", "stop", "motor"].map(|n| (n.to_string(), Value::Bool(false))),
/// );
/// image.set(TagId(0), Value::Bool(true), Duration::ZERO);
/// let ctx = ScanContext { now: Duration::ZERO, delta: Duration::from_millis(10), cycle: 0 };
/// program.scan(&mut image, &ctx).unwrap();
/// assert_eq!(image.get(TagId(2)), Value::Bool(true));
///
/// let err = expr::compile("motor = strat\n", Path::new("m.expr"), &tags).unwrap_err();
/// assert_eq!(
///     err[0].to_string(),
///     "m.expr:1:9: error: unknown tag `strat`; did you mean `start`?"
/// );
/// ```
pub fn compile(
    source: &str,
    file: &Path,
    tags: &TagTable,
) -> Result<ExprProgram, Vec<CompileError>> {
    let source = source.strip_prefix('\u{feff}').unwrap_or(source);
    let mut errors = Vec::new();
    let mut stmts = Vec::new();
    for (i, text) in source.split('\n').enumerate() {
        let line = u32::try_from(i + 1).unwrap_or(u32::MAX);
        let text = text.strip_suffix('\r').unwrap_or(text);
        match parser::parse_line(text, line) {
            Ok(Some(stmt)) => stmts.push(stmt),
            Ok(None) => {}
            Err(e) => errors.push(e),
        }
    }
    let checked = check::check(&stmts, tags, &mut errors);
    if !errors.is_empty() {
        errors.sort_by_key(|(pos, _)| *pos);
        return Err(errors
            .into_iter()
            .map(|(pos, kind)| CompileError {
                pos: SourcePos {
                    file: file.to_path_buf(),
                    line: pos.line,
                    column: pos.col,
                },
                kind,
            })
            .collect());
    }
    let lowered = lower::lower(&checked);
    debug_assert!(
        lower::max_depth(&lowered.code).is_some(),
        "unbalanced lowered code"
    );
    let rungs = rungs::describe(&checked, file);
    let types = crate::logic::vm::tag_types(tags);
    Ok(ExprProgram::new(lowered, types, file.to_path_buf()).with_rungs(rungs))
}
