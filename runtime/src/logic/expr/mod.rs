//! `expr`: the minimal logic engine — boolean coil assignments, one per line.
//!
//! A program (`.expr` file) is parsed (with line:column positions), checked against the
//! project's [`TagTable`], lowered to a flat stack-machine program over [`TagId`]s ([`Instr`],
//! the instruction set of the logic VM that ladder lowers to as well), and executed once per
//! scan by [`ExprProgram`], a [`LogicEngine`].
//!
//! The language (statements, operators, edges, timers, quality, how a scan runs a program) is
//! documented for engineers in `docs/expr.md`; this module implements it as written there.
//!
//! [`LogicEngine`]: crate::logic::LogicEngine

mod check;
mod comments;
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
/// use softplc::scan::ScanInstant;
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
/// image.set(TagId(0), Value::Bool(true), ScanInstant::ZERO);
/// let ctx = ScanContext { now: ScanInstant::ZERO, delta: Duration::from_millis(10), cycle: 0 };
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
    let comments = comments::statement_comments(source, &mut errors);
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
    let rungs = rungs::describe(&checked, file, &comments);
    let types = crate::logic::vm::tag_types(tags);
    Ok(ExprProgram::new(lowered, types, file.to_path_buf()).with_rungs(rungs))
}
