//! Errors of Rhai programs: compile errors with `file:line:col`, and the conversion of a
//! script's run-time error into a [`LogicFault`].

use std::path::Path;

use crate::logic::{LogicFault, SourcePos};

/// One error in a script.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{pos}: error: {kind}")]
pub struct CompileError {
    /// Where.
    pub pos: SourcePos,
    /// What.
    pub kind: CompileErrorKind,
}

/// What is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompileErrorKind {
    /// Rhai's parser refused the script (syntax, an undeclared variable, an assignment to a
    /// module input, which the script sees as a constant, ...).
    #[error("{message}")]
    Parse {
        /// Rhai's message.
        message: String,
    },
    /// One instance name used for blocks of two kinds.
    #[error("instance \"{name}\" is already a {first} (line {first_line}); give this {this} another name")]
    KindClash {
        /// The instance.
        name: String,
        /// Its first kind.
        first: &'static str,
        /// The kind here.
        this: &'static str,
        /// Line of the first call.
        first_line: u32,
    },
    /// One instance called from two places.
    #[error("instance \"{name}\" is already called at line {first_line}; call each instance once per scan and read its outputs with q(\"{name}\"), et(…), cv(…)")]
    CalledTwice {
        /// The instance.
        name: String,
        /// Line of the first call.
        first_line: u32,
    },
    /// An output read of an instance that no call creates.
    #[error("no block call creates instance \"{name}\"")]
    UnknownInstance {
        /// The instance.
        name: String,
    },
    /// `good(…)` / `bad(…)` given something other than one tag name.
    #[error("{function}() takes one tag name, e.g. {function}(level), not an expression")]
    QualityArgument {
        /// `good` or `bad`.
        function: &'static str,
    },
    /// `good(x)` / `bad(x)` where `x` is a script variable, not a tag.
    #[error("`{name}` is not a tag; {function}() reads a tag's quality")]
    QualityOfNonTag {
        /// `good` or `bad`.
        function: &'static str,
        /// The variable.
        name: String,
    },
    /// `good(…)` / `bad(…)` inside a script function, which does not see tags.
    #[error("{function}() reads a tag's quality and functions do not see tags; call it in the script's body and pass the result")]
    QualityInFunction {
        /// `good` or `bad`.
        function: &'static str,
    },
    /// A tag name the script cannot use (a Rhai keyword), used anyway.
    #[error("tag `{name}` has the name of a Rhai keyword and cannot be used in a script; rename it in the project")]
    KeywordTag {
        /// The tag.
        name: String,
    },
}

/// A 1-based line and column in the user's file, from a Rhai position in the compiled text
/// (which has the tag declarations on one extra line at the top).
pub(crate) fn user_pos(file: &Path, pos: rhai::Position) -> SourcePos {
    let line = pos.line().unwrap_or(2).saturating_sub(1).max(1);
    let column = pos.position().unwrap_or(1).max(1);
    SourcePos {
        file: file.to_path_buf(),
        line: u32::try_from(line).unwrap_or(u32::MAX),
        column: u32::try_from(column).unwrap_or(u32::MAX),
    }
}

/// Rhai's message without its ` (line N, position M)` suffix (the position is reported apart,
/// shifted to the user's lines).
pub(crate) fn message(text: String) -> String {
    match text.find(" (line ") {
        Some(at) => text[..at].to_string(),
        None => text,
    }
}

/// A script's run-time error as a PLC fault.
pub(crate) fn fault(
    err: &rhai::EvalAltResult,
    file: &Path,
    budget: std::time::Duration,
) -> LogicFault {
    use rhai::EvalAltResult as E;
    let text = match err {
        E::ErrorTerminated(..) => format!(
            "script stopped: it ran longer than its budget of {} ms in one scan (a loop that does not end?)",
            budget.as_millis()
        ),
        E::ErrorTooManyOperations(..) => {
            "script stopped: too many operations in one scan (a loop that does not end?)".into()
        }
        other => format!("script error: {}", message(other.to_string())),
    };
    LogicFault {
        message: text,
        pos: user_pos(file, err.position()),
    }
}
