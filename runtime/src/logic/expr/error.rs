//! Compile errors of `.expr` programs, each with its `file:line:col`.

use std::fmt;

use softplc_io::point::ValueType;

use crate::logic::SourcePos;

/// One error in a program; a compile reports all it finds, at least one per bad line.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{pos}: error: {kind}")]
pub struct CompileError {
    /// Where: the offending token.
    pub pos: SourcePos,
    /// What.
    pub kind: CompileErrorKind,
}

/// What is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompileErrorKind {
    /// The `#` comment documenting a statement is too long or holds a control character.
    #[error("comment: {error}")]
    Documentation {
        /// What is wrong with the text.
        error: crate::project::DocTextError,
    },
    /// The text does not follow the grammar.
    #[error("expected {expected}, found {found}")]
    Syntax {
        /// What the grammar allows here.
        expected: Expected,
        /// The token met instead, quoted (`` `&` ``), or `end of line`.
        found: String,
    },
    /// A name that is not in the tag table.
    #[error("unknown tag `{name}`{}", crate::logic::undeclared::hint(name, suggestion.as_deref(), also))]
    UnknownTag {
        /// The name as written.
        name: String,
        /// The closest known tag name, within edit distance 2.
        suggestion: Option<String>,
        /// The other lines that use it (one error per name).
        also: Vec<u32>,
    },
    /// A call of a function the language does not have.
    #[error(
        "unknown function `{name}`{}; the functions are {}",
        suggest(.suggestion),
        function_list()
    )]
    UnknownFunction {
        /// The name as written.
        name: String,
        /// The closest function name, within edit distance 2.
        suggestion: Option<String>,
    },
    /// `good(…)` or `bad(…)` given something other than one tag name.
    #[error("`{function}` takes a tag name, e.g. `{function}(level)`, not an expression")]
    QualityArgument {
        /// `good` or `bad`.
        function: &'static str,
    },
    /// An assignment to a tag the program may not write (a module input).
    #[error("tag `{name}` is read-only (a module input); a program cannot assign it")]
    WriteToInput {
        /// The tag.
        name: String,
    },
    /// A second assignment to the same coil.
    #[error("coil `{name}` is already assigned at line {first_line}")]
    DuplicateCoil {
        /// The coil.
        name: String,
        /// The line of the first assignment (1-based).
        first_line: u32,
    },
    /// A value used where its type does not fit.
    #[error(transparent)]
    Type(#[from] TypeError),
    /// A timer duration that is not a valid duration.
    #[error(transparent)]
    BadDuration(#[from] DurationError),
    /// Parentheses, `!` and calls nested deeper than the parser allows.
    #[error("expression nested deeper than {limit} levels")]
    TooDeep {
        /// The nesting limit.
        limit: u32,
    },
}

/// `rising, falling, ton, tof, tp, good and bad`.
fn function_list() -> String {
    let mut names = super::parser::functions();
    let last = names.pop().unwrap_or_default();
    format!("{} and {last}", names.join(", "))
}

fn suggest(s: &Option<String>) -> String {
    match s {
        Some(name) => format!("; did you mean `{name}`?"),
        None => String::new(),
    }
}

/// What the grammar expected where a syntax error was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expected {
    /// A statement starts with the coil it assigns.
    CoilName,
    /// `=` after the coil.
    Assign,
    /// A tag, a literal, `!`, `(` or a function call.
    Operand,
    /// A tag or a number, after a comparison operator.
    ComparisonOperand,
    /// A number after `-`.
    Number,
    /// An operator, or the end of the statement.
    OperatorOrEnd,
    /// `(` after a function name.
    OpenParen,
    /// `)`.
    CloseParen,
    /// `,` between a timer's input and its duration.
    Comma,
    /// A duration literal.
    Duration,
}

impl fmt::Display for Expected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Expected::CoilName => "a coil name",
            Expected::Assign => "`=`",
            Expected::Operand => "a tag, 0, 1, true, false, `!`, `(` or a function call",
            Expected::ComparisonOperand => "a tag or a number",
            Expected::Number => "a number",
            Expected::OperatorOrEnd => "an operator or end of line",
            Expected::OpenParen => "`(`",
            Expected::CloseParen => "`)`",
            Expected::Comma => "`,`",
            Expected::Duration => "a duration like `250ms`",
        })
    }
}

/// A value used where its type does not fit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TypeError {
    /// A numeric tag used as a boolean, outside a comparison.
    #[error("tag `{name}` is {ty}, not bool; compare it, e.g. `{name} != 0`")]
    NumberAsBool {
        /// The tag.
        name: String,
        /// Its type.
        ty: ValueType,
    },
    /// A number literal other than 0 or 1 used as a boolean.
    #[error("`{text}` is not a boolean; use 0, 1, true or false")]
    LiteralAsBool {
        /// The literal as written.
        text: String,
    },
    /// An assignment to a numeric tag.
    #[error(
        "tag `{name}` is {ty}: expr programs assign only bool tags; use ladder or rhai for numbers"
    )]
    AssignNumber {
        /// The tag.
        name: String,
        /// Its type.
        ty: ValueType,
    },
    /// A bool tag in a comparison.
    #[error("tag `{name}` is bool; comparisons take numeric tags (use `{name}` or `!{name}`)")]
    BoolInComparison {
        /// The tag.
        name: String,
    },
    /// A comparison side that is neither a tag nor a number.
    #[error("each side of a comparison must be a numeric tag or a number")]
    ComparisonOperand,
    /// A comparison of two numbers.
    #[error("a comparison needs at least one tag")]
    ConstantComparison,
    /// A number literal compared with a tag whose type cannot hold it (`count == 0.5` with an
    /// integer `count`, `level < 70000` with a u16 `level`): the answer would never change.
    #[error("type error: `{text}` is not {}; `{name}` is {ty}", super::check::type_words(*.ty))]
    LiteralOutOfType {
        /// The literal as written.
        text: String,
        /// The tag.
        name: String,
        /// Its type.
        ty: ValueType,
    },
}

/// A timer duration that is not a valid duration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DurationError {
    /// A number without a unit.
    #[error("duration `{text}` has no unit; write e.g. `2s`, `250ms` or `100us`")]
    MissingUnit {
        /// The number as written.
        text: String,
    },
    /// A unit other than `us`, `ms`, `s`.
    #[error("unknown time unit `{unit}`; use us, ms or s")]
    UnknownUnit {
        /// The unit as written.
        unit: String,
    },
    /// Zero.
    #[error("a timer duration must be greater than zero")]
    Zero,
    /// Longer than the maximum.
    #[error("duration longer than the maximum of {max_ms} ms (about 49.7 days)")]
    TooLong {
        /// The maximum, in milliseconds.
        max_ms: u64,
    },
}
