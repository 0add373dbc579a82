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
    /// One instance of a block of one's own called from two places.
    #[error("instance \"{name}\" is already called at line {first_line}; call each instance once per scan and read its variables with output(\"{name}\", …)")]
    OwnCalledTwice {
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
    /// A closure that captures a module input: the script reads inputs from the scan's
    /// slots, which a closure's captured copy would not follow.
    #[error("a closure cannot capture the input `{name}`; pass its value as an argument")]
    CapturedInput {
        /// The input tag.
        name: String,
    },
    /// A variable that is neither a tag nor declared with `let` (Rhai's strict variables).
    #[error("unknown tag or variable `{name}`{}", hint(.suggestion.as_deref(), "declare it under `tags:` in the project, or with `let` in the script"))]
    UnknownVariable {
        /// The name.
        name: String,
        /// The closest tag or variable name.
        suggestion: Option<String>,
    },
    /// A call of a function that neither the library, the script nor Rhai defines (Rhai would
    /// fault when the call is reached: `Function not found`).
    #[error("unknown function `{name}`{}", hint(.suggestion.as_deref(), &format!("the library is {}", super::signatures::names())))]
    UnknownFunction {
        /// The name called.
        name: String,
        /// The closest known function, as its usage (`ton(name, in, pt)`).
        suggestion: Option<String>,
    },
    /// A known function called with a number of arguments it has no form for.
    #[error("{name}() takes {usage}; this call has {found}")]
    Arity {
        /// The function.
        name: String,
        /// Its forms: `3 arguments: ton(name, in, pt)`, or `3 arguments` for a script
        /// function.
        usage: String,
        /// Arguments given.
        found: usize,
    },
    /// An argument of a block of one's own of a type its input does not take.
    #[error("argument `{param}` of {function}() is {} (an input of {block}), not {found}", crate::logic::user_blocks::a_type(*.expected))]
    OwnArgumentType {
        /// The function.
        function: String,
        /// The block.
        block: String,
        /// The input.
        param: String,
        /// Its type.
        expected: softplc_io::point::ValueType,
        /// What was given ("an integer").
        found: &'static str,
    },
    /// `output(instance, variable)` naming what no instance has.
    #[error("output(): {what}")]
    OwnOutput {
        /// What is not there, in words.
        what: String,
    },
    /// A call of a block of one's own naming no declared instance of it.
    #[error("{function}(): \"{name}\" is not a declared instance of {block} ({declared}); declare it under the project's `instances:`")]
    OwnInstance {
        /// The function.
        function: String,
        /// The name given.
        name: String,
        /// The block.
        block: String,
        /// Its declared instances, in words.
        declared: String,
    },
    /// An argument of a library function of a type the parameter does not take.
    #[error("argument `{param}` of {function}() is {expected}, not {found}")]
    ArgumentType {
        /// The function.
        function: &'static str,
        /// The parameter.
        param: &'static str,
        /// What it takes ("a bool", "a time (ms or a string like \"2s\")").
        expected: &'static str,
        /// What was given ("an integer").
        found: &'static str,
    },
    /// A literal duration argument that is not one.
    #[error("bad duration \"{text}\" for `{param}` of {function}(): {reason}; write e.g. \"500ms\", \"2s\" or a number of ms")]
    BadDuration {
        /// The function.
        function: &'static str,
        /// The parameter.
        param: &'static str,
        /// The literal.
        text: String,
        /// Why.
        reason: crate::project::DurationError,
    },
    /// A literal blink pattern that is not one.
    #[error("bad pattern \"{text}\" for blink_pattern(): {reason}")]
    BadPattern {
        /// The literal.
        text: String,
        /// Why.
        reason: crate::logic::blocks::PatternError,
    },
    /// A value of a type the tag cannot hold, assigned to it.
    #[error("type error: `{name}` is {ty}, the value assigned is {value}{}", assign_hint(*.ty))]
    AssignType {
        /// The tag.
        name: String,
        /// Its declared type.
        ty: softplc_io::point::ValueType,
        /// The value's type ("an integer").
        value: &'static str,
    },
    /// A number literal that the tag it is assigned to or compared with cannot hold
    /// (`level = 70000` or `count == 0.5` with an integer tag): it would saturate, or the
    /// comparison never change.
    #[error("type error: `{value}` is not {}; `{name}` is {ty}", crate::logic::expr::type_words(*.ty))]
    LiteralOutOfType {
        /// The literal.
        value: String,
        /// The tag.
        name: String,
        /// Its declared type.
        ty: softplc_io::point::ValueType,
    },
    /// An operator given operands of types it cannot take.
    #[error("type error: `{op}` cannot take {operands}")]
    OperandType {
        /// The operator.
        op: String,
        /// The operands' types ("a bool and an integer").
        operands: String,
    },
    /// A condition (`if`, `while`, `&&`, `||`) that is not a bool.
    #[error("type error: a condition is a bool, not {found}; compare it, e.g. `x > 0`")]
    ConditionType {
        /// Its type.
        found: &'static str,
    },
    /// A tag name the script cannot use (a Rhai keyword), used anyway.
    #[error("tag `{name}` has the name of a Rhai keyword and cannot be used in a script; rename it in the project")]
    KeywordTag {
        /// The tag.
        name: String,
    },
}

/// `; did you mean `x`?`, or the fallback advice.
fn hint(suggestion: Option<&str>, otherwise: &str) -> String {
    match suggestion {
        Some(s) => format!("; did you mean `{s}`?"),
        None => format!("; {otherwise}"),
    }
}

/// How to store a value in a tag of type `ty` when its type does not fit.
fn assign_hint(ty: softplc_io::point::ValueType) -> &'static str {
    use softplc_io::point::ValueType as T;
    match ty {
        T::Bool => "; a bool tag takes a condition, e.g. `x > 0`",
        T::U16 | T::I32 => "; round it explicitly, e.g. `x.to_int()` or `x.round().to_int()`",
        T::F32 => "; an f32 tag takes a number",
    }
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
