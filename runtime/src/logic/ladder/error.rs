//! Compile errors of ladder programs, each with its `file:line:col`.

use std::fmt;

use softplc_io::point::ValueType;

use crate::logic::blocks::{Kind, PatternError};
use crate::logic::SourcePos;
use crate::project::DurationError;

/// One error in a program; a compile reports every error it finds (the first syntax error of
/// each bad rung, and every name, type and driver error of the rungs that parse).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{pos}: error: {kind}")]
pub struct CompileError {
    /// Where: the offending token.
    pub pos: SourcePos,
    /// What.
    pub kind: CompileErrorKind,
}

/// How a tag is written by a rung, for "driven twice" errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Driver {
    /// A coil `x`, `/x`, or a block's `-> x`: the rung decides the value every scan.
    Coil,
    /// `set x` / `reset x`: any number of rungs may latch a tag.
    Latch,
    /// A math box result `=> x`: any number of rungs may compute into a tag.
    Math,
}

impl fmt::Display for Driver {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Driver::Coil => "a coil",
            Driver::Latch => "a set/reset coil",
            Driver::Math => "a math box (=>)",
        })
    }
}

/// What is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompileErrorKind {
    /// The file is not a ladder document (YAML syntax, or not `rungs:` with text rungs).
    #[error("{message}")]
    Yaml {
        /// The YAML reader's message.
        message: String,
    },
    /// A rung's `title:` or `comment:` that cannot document it (too long, a line break in
    /// a title).
    #[error("rung {key}: {error}")]
    Documentation {
        /// `title` or `comment`.
        key: &'static str,
        /// What is wrong with the text.
        error: crate::project::DocTextError,
    },
    /// A rung with no text.
    #[error("empty rung; write `CONDITION -> COIL`")]
    EmptyRung,
    /// The text does not follow the grammar.
    #[error("expected {expected}, found {found}")]
    Syntax {
        /// What the grammar allows here.
        expected: Expected,
        /// The token met instead, quoted, or `end of rung`.
        found: String,
    },
    /// Parentheses, negations and edges nested too deep.
    #[error("rung nested deeper than {limit} levels")]
    TooDeep {
        /// The limit.
        limit: u32,
    },
    /// `good(…)` or `bad(…)` given something other than one tag name.
    #[error("`{function}` takes a tag name, e.g. `{function}(level)`, not a condition or a block output")]
    QualityArgument {
        /// `good` or `bad`.
        function: &'static str,
    },
    /// A name that is neither a tag nor a block instance.
    #[error("unknown tag `{name}`{}", crate::logic::undeclared::hint(name, suggestion.as_deref(), also))]
    UnknownTag {
        /// The name as written.
        name: String,
        /// The closest known name.
        suggestion: Option<String>,
        /// The first lines of the other rungs that use it (one error per name).
        also: Vec<u32>,
    },
    /// `name.MEMBER` where `name` is no block instance.
    #[error("`{name}` is not a block instance (no rung calls a block named so){}", suggest(.suggestion))]
    UnknownInstance {
        /// The name.
        name: String,
        /// The closest instance name.
        suggestion: Option<String>,
    },
    /// A block type that does not exist.
    #[error(
        "unknown block `{name}`{}; the blocks are {}",
        suggest(.suggestion),
        crate::logic::blocks::names()
    )]
    UnknownBlock {
        /// The name as written.
        name: String,
        /// The closest block name.
        suggestion: Option<String>,
    },
    /// A math box that does not exist.
    #[error(
        "unknown box `{name}`{}; the boxes are MOVE, ADD, SUB, MUL, DIV, LIMIT",
        suggest(.suggestion)
    )]
    UnknownBox {
        /// The name as written.
        name: String,
        /// The closest box name.
        suggestion: Option<String>,
    },
    /// An output an instance's kind does not have.
    #[error("{kind} `{instance}` has no output `{member}`; it has {}", members(.kind))]
    UnknownMember {
        /// The instance.
        instance: String,
        /// Its kind.
        kind: Kind,
        /// The member as written.
        member: String,
    },
    /// A block called without an instance name.
    #[error("a {kind} needs an instance name: `{kind} name(...)`")]
    MissingInstanceName {
        /// The block.
        kind: Kind,
    },
    /// A block's body calling an instance its block does not declare.
    #[error("instance `{name}` of {block} is not declared by {body}: add `- {{ name: {name}, block: {block} }}` to the `instances:` of {body} in its block file")]
    OwnNotDeclaredInBody {
        /// The instance.
        name: String,
        /// The block called.
        block: String,
        /// The block whose body calls it.
        body: String,
    },
    /// A block's body that writes one of the block's inputs.
    #[error("`{name}` is an input of {block}: its body reads it, a call writes it")]
    OwnBodyWritesInput {
        /// The input.
        name: String,
        /// The block.
        block: String,
    },
    /// A block's body naming what the block does not declare.
    #[error("`{name}` is not declared by {block}: its body sees only its inputs, outputs and state ({vars}); declare it under the block's `outputs:` or `state:`")]
    OwnBodyUndeclared {
        /// The name.
        name: String,
        /// The block.
        block: String,
        /// Its variables.
        vars: String,
    },
    /// A call of an instance the project does not declare.
    #[error("instance `{name}` of {block} is not declared: add `- {{ name: {name}, block: {block} }}` to the project's `instances:`")]
    OwnNotDeclared {
        /// The instance.
        name: String,
        /// The block called.
        block: String,
    },
    /// A call of an instance of another block.
    #[error("instance `{name}` is a {declared} (the project's `instances:`), not a {called}")]
    OwnWrongBlock {
        /// The instance.
        name: String,
        /// Its block.
        declared: String,
        /// The block the call names.
        called: String,
    },
    /// An argument naming no input of the block.
    #[error("{block} has no input `{pin}`; its inputs are {inputs}")]
    OwnUnknownPin {
        /// The block.
        block: String,
        /// The name as written.
        pin: String,
        /// Its inputs.
        inputs: String,
    },
    /// A read of a variable an instance does not have.
    #[error("{block} `{instance}` has no `{member}`; it has {vars}")]
    OwnUnknownVar {
        /// The instance.
        instance: String,
        /// Its block.
        block: String,
        /// The name as written.
        member: String,
        /// Its variables.
        vars: String,
    },
    /// An argument of the wrong type.
    #[error("input `{pin}` of {block} is {}, not {found}", crate::logic::user_blocks::a_type(*.expected))]
    OwnPinType {
        /// The block.
        block: String,
        /// The input.
        pin: String,
        /// Its type.
        expected: ValueType,
        /// What the call gives, in words.
        found: String,
    },
    /// A required input left out.
    #[error("input `{pin}` of {block} is missing: it has no default, so every call gives it (`{pin}=...`)")]
    OwnMissingInput {
        /// The block.
        block: String,
        /// The input.
        pin: String,
    },
    /// An input given twice.
    #[error("input `{pin}` is given twice")]
    OwnDuplicatePin {
        /// The input.
        pin: String,
    },
    /// More positional arguments than the block has inputs after its power flow.
    #[error("{block} takes at most {max} positional arguments ({inputs})")]
    OwnTooManyArgs {
        /// The block.
        block: String,
        /// How many it takes.
        max: usize,
        /// Its inputs after the power flow.
        inputs: String,
    },
    /// An instance named like a tag.
    #[error("instance `{name}` has the name of a tag; give it another name")]
    InstanceIsTag {
        /// The name.
        name: String,
    },
    /// Two calls of one instance.
    #[error("instance `{name}` is already called by the rung at line {first_line}; call each instance once and read its outputs (`{name}.Q`) elsewhere")]
    InstanceCalledTwice {
        /// The instance.
        name: String,
        /// The line of the first call.
        first_line: u32,
    },
    /// A write to a tag the program may not write.
    #[error("tag `{name}` is read-only (a module input); a program cannot write it")]
    WriteToInput {
        /// The tag.
        name: String,
    },
    /// A tag written by two rungs in ways that conflict.
    #[error("tag `{name}` is already driven by {first} at line {first_line}; this rung drives it by {this}")]
    DrivenTwice {
        /// The tag.
        name: String,
        /// How this rung writes it.
        this: Driver,
        /// How the first writer writes it.
        first: Driver,
        /// The first writer's line.
        first_line: u32,
    },
    /// A value used where its type does not fit.
    #[error(transparent)]
    Type(#[from] TypeError),
    /// A duration literal that is not valid.
    #[error("bad duration `{text}`: {reason}; write e.g. 500ms, 2s, 1.5s, 10m")]
    BadDuration {
        /// The literal.
        text: String,
        /// Why.
        reason: DurationError,
    },
    /// A blink pattern that is not valid.
    #[error("bad pattern: {0}")]
    BadPattern(#[from] PatternError),
    /// An argument name a block does not take.
    #[error("{kind} has no argument `{param}`; it takes {}", keywords(*.kind))]
    UnknownParam {
        /// The block.
        kind: Kind,
        /// The name as written.
        param: String,
    },
    /// An argument given twice.
    #[error("argument `{}` is given twice", .param.to_ascii_lowercase())]
    DuplicateParam {
        /// The argument (its pin's name).
        param: &'static str,
    },
    /// A required argument left out.
    #[error("{kind} needs `{}`: {hint}", .param.to_ascii_lowercase())]
    MissingParam {
        /// The block.
        kind: Kind,
        /// The argument (its pin's name).
        param: &'static str,
        /// An example.
        hint: &'static str,
    },
    /// More positional arguments than a block or box takes.
    #[error("`{name}` takes at most {max} positional arguments")]
    TooManyArgs {
        /// The block or box.
        name: &'static str,
        /// How many it takes.
        max: usize,
    },
    /// Too few arguments for a math box.
    #[error("`{name}` takes {expected} arguments, found {found}")]
    MathArity {
        /// The box.
        name: &'static str,
        /// How many it takes.
        expected: usize,
        /// How many were given.
        found: usize,
    },
    /// BLINK given both on/off times and a pattern, or neither.
    #[error("BLINK takes either on and off times (`BLINK b(500ms, 500ms)`) or a pattern (`BLINK b(pattern=1101, step=250ms)`)")]
    BlinkMode,
}

/// The argument keywords a ladder call of `kind` takes (`pt, r`), or "no arguments".
fn keywords(kind: Kind) -> String {
    let names: Vec<String> = kind
        .def()
        .arguments()
        .iter()
        .map(|p| p.name.to_ascii_lowercase())
        .collect();
    if names.is_empty() {
        "no arguments".into()
    } else {
        names.join(", ")
    }
}

fn suggest(s: &Option<String>) -> String {
    match s {
        Some(name) => format!("; did you mean `{name}`?"),
        None => String::new(),
    }
}

fn members(kind: &Kind) -> String {
    kind.outputs()
        .iter()
        .map(|m| m.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// What the grammar expected where a syntax error was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expected {
    /// A contact, `(`, `/`, a comparison or `->`.
    Contact,
    /// `->` between the condition and the action.
    Arrow,
    /// A coil, a block call or a math box.
    Action,
    /// A tag name after `set`/`reset`/`/`.
    CoilName,
    /// A member name after `.`.
    MemberName,
    /// A number or a numeric tag after a comparison operator.
    Operand,
    /// A number after `-`.
    Number,
    /// `(`.
    OpenParen,
    /// `)`.
    CloseParen,
    /// `,` or `)` in an argument list.
    CommaOrClose,
    /// `=>` after a math box.
    FatArrow,
    /// A tag after `=>`.
    Destination,
    /// `,` or the end of the rung after an action.
    CommaOrEnd,
    /// An argument value.
    Argument,
}

impl fmt::Display for Expected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Expected::Contact => "a contact (`tag`, `/tag`, `rising(tag)`, `good(tag)`, `(…)`, a comparison)",
            Expected::Arrow => "`->`",
            Expected::Action => "a coil (`tag`, `/tag`, `set tag`, `reset tag`), a block (`TON t(2s)`) or a box (`ADD(a, 1) => a`)",
            Expected::CoilName => "a tag name",
            Expected::MemberName => "an output name (Q, ET, CV, QU, QD)",
            Expected::Operand => "a number or a numeric tag",
            Expected::Number => "a number",
            Expected::OpenParen => "`(`",
            Expected::CloseParen => "`)`",
            Expected::CommaOrClose => "`,` or `)`",
            Expected::FatArrow => "`=>`",
            Expected::Destination => "the tag that receives the result",
            Expected::CommaOrEnd => "`,` or the end of the rung",
            Expected::Argument => "an argument (a number, a duration, a tag or a condition)",
        })
    }
}

/// A value used where its type does not fit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TypeError {
    /// A numeric tag or output used as a contact.
    #[error("`{name}` is {ty}, not bool; compare it, e.g. `{name} > 0`")]
    NumberAsContact {
        /// The tag or `instance.MEMBER`.
        name: String,
        /// Its type.
        ty: &'static str,
    },
    /// A number used as a contact.
    #[error("`{text}` is not a contact; only 0, 1, true and false are")]
    LiteralAsContact {
        /// The literal.
        text: String,
    },
    /// A bool tag used where a number is needed.
    #[error("`{name}` is bool; a number is needed here")]
    BoolAsNumber {
        /// The tag or `instance.MEMBER`.
        name: String,
    },
    /// A condition where a number is needed.
    #[error("a number or a numeric tag is needed here, not a condition")]
    ConditionAsNumber,
    /// A coil on a numeric tag.
    #[error("coil `{name}` is {ty}; coils drive bool tags (use `MOVE(…) => {name}` for numbers)")]
    NumberCoil {
        /// The tag.
        name: String,
        /// Its type.
        ty: ValueType,
    },
    /// A comparison between two numbers.
    #[error("a comparison needs at least one tag or block output")]
    ConstantComparison,
    /// A math box computing into a bool tag (`MOVE(0.5) => demand`).
    #[error("type error: `{name}` is bool and {op}(…) computes a number; drive a bool tag with a coil, e.g. `… -> {name}`")]
    NumberIntoBool {
        /// The tag.
        name: String,
        /// The box.
        op: &'static str,
    },
    /// A number literal that the type it meets cannot hold: compared with or moved into a tag
    /// (`count = 0.5` with an integer `count`, `MOVE(70000) => level` with a u16 `level`), or a
    /// counter's preset (an i32).
    #[error("type error: `{text}` is not {}; {target} is {ty}", crate::logic::expr::type_words(*.ty))]
    LiteralOutOfType {
        /// The literal as written.
        text: String,
        /// What it meets: "`count`", "the preset of CTU".
        target: String,
        /// Its type.
        ty: ValueType,
    },
}
