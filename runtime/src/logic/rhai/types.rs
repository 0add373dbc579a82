//! The types the checker can see in a script without running it: a literal's, a tag's (its
//! declared type), and what an operator or a library function makes of them. Anything else (a
//! `let` variable, a script function's result, an `if` expression) is [`Ty::Unknown`] and is
//! checked when the script runs instead (see `RhaiProgram::copy_out`).

use super::internals::{self, Expr, ExprView};
use softplc_io::point::ValueType;

use super::signatures::{self, Returns};

/// A script value's type, as far as the checker knows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ty {
    Bool,
    Int,
    Float,
    Str,
    /// An array, an object map, a character or `()`: never a tag's value.
    Other(&'static str),
    /// Not known before the script runs.
    Unknown,
}

impl Ty {
    /// The type Rhai gives a tag of type `ty` (see the module docs of `rhai`).
    pub(crate) fn of_tag(ty: ValueType) -> Ty {
        match ty {
            ValueType::Bool => Ty::Bool,
            ValueType::U16 | ValueType::I32 => Ty::Int,
            ValueType::F32 => Ty::Float,
        }
    }

    /// The type in words, with its article, for messages.
    pub(crate) fn words(self) -> &'static str {
        match self {
            Ty::Bool => "a bool",
            Ty::Int => "an integer",
            Ty::Float => "a float",
            Ty::Str => "a string",
            Ty::Other(words) => words,
            Ty::Unknown => "a value",
        }
    }

    /// Whether a value of this type may be stored in a tag of type `tag` (a known mismatch is
    /// a type error; an unknown type is checked at run time). Integers widen to `f32`; a float
    /// into an integer tag needs an explicit `to_int()`, a number into a bool a comparison.
    pub(crate) fn fits(self, tag: ValueType) -> bool {
        matches!(
            (self, tag),
            (Ty::Unknown, _)
                | (Ty::Bool, ValueType::Bool)
                | (Ty::Int, ValueType::U16 | ValueType::I32 | ValueType::F32)
                | (Ty::Float, ValueType::F32)
        )
    }

    fn is_number(self) -> bool {
        matches!(self, Ty::Int | Ty::Float)
    }
}

/// Comparison operators: a bool whatever the operands.
const COMPARISONS: [&str; 6] = ["==", "!=", "<", ">", "<=", ">="];
/// Arithmetic operators: an integer from integers, a float when either side is a float.
const ARITHMETIC: [&str; 6] = ["+", "-", "*", "/", "%", "**"];
/// Bitwise/logical operators without short-circuit: bools give a bool, integers an integer.
const BITWISE: [&str; 3] = ["&", "|", "^"];

/// Whether `op` compares.
pub(crate) fn is_comparison(op: &str) -> bool {
    COMPARISONS.contains(&op)
}

/// The type of `expr`; `var` gives a variable's type (a tag's, or `None`).
pub(crate) fn infer(expr: &Expr, var: &dyn Fn(&str) -> Option<Ty>) -> Ty {
    match internals::expr(expr) {
        ExprView::Bool(_) => Ty::Bool,
        ExprView::Int(..) => Ty::Int,
        ExprView::Float(_) => Ty::Float,
        ExprView::Str(..) | ExprView::Interpolated => Ty::Str,
        ExprView::Array => Ty::Other("an array"),
        ExprView::Map => Ty::Other("an object map"),
        ExprView::Char => Ty::Other("a character"),
        ExprView::Unit => Ty::Other("() (nothing)"),
        ExprView::Var(name, _) => var(name).unwrap_or(Ty::Unknown),
        ExprView::And(_) | ExprView::Or(_) => Ty::Bool,
        ExprView::Call(call) if call.operator => {
            let args: Vec<Ty> = call.args.iter().map(|a| infer(a, var)).collect();
            operator(call.name, &args)
        }
        ExprView::Call(call) => {
            let args: Vec<Ty> = call.args.iter().map(|a| infer(a, var)).collect();
            match signatures::returns(call.name, args.len()) {
                Some(Returns::Bool) => Ty::Bool,
                Some(Returns::Int) => Ty::Int,
                Some(Returns::SameNumber) => number(&args),
                None => Ty::Unknown,
            }
        }
        _ => Ty::Unknown,
    }
}

/// What operator `op` gives for operands of types `args` (unknown when it would fail: the
/// operand checks report that).
pub(crate) fn operator(op: &str, args: &[Ty]) -> Ty {
    if COMPARISONS.contains(&op) || op == "!" {
        return Ty::Bool;
    }
    if ARITHMETIC.contains(&op) {
        return match args {
            [a] if a.is_number() => *a,
            [Ty::Str, _] | [_, Ty::Str] if op == "+" => Ty::Str,
            _ => number(args),
        };
    }
    if BITWISE.contains(&op) {
        return match args {
            [Ty::Bool, Ty::Bool] => Ty::Bool,
            [Ty::Int, Ty::Int] => Ty::Int,
            _ => Ty::Unknown,
        };
    }
    Ty::Unknown
}

/// The number type of an arithmetic result: integer when every operand is, float when one is
/// a float and the others are numbers.
fn number(args: &[Ty]) -> Ty {
    if args.iter().all(|a| *a == Ty::Int) {
        Ty::Int
    } else if args.iter().all(|a| a.is_number()) {
        Ty::Float
    } else {
        Ty::Unknown
    }
}

/// Whether operator `op` cannot take operands of these types: a bool compared with a number
/// or a string, a number negated with `!`, a bool in arithmetic. Rhai would fault at run time
/// (or, for `==` across types, answer false for ever).
pub(crate) fn operands_clash(op: &str, args: &[Ty]) -> bool {
    let known = |t: Ty| t != Ty::Unknown;
    match args {
        [a, b] if COMPARISONS.contains(&op) => {
            known(*a) && known(*b) && (a.is_number() != b.is_number() || (!a.is_number() && a != b))
        }
        [a] if op == "!" => known(*a) && *a != Ty::Bool,
        _ if ARITHMETIC.contains(&op) => args.contains(&Ty::Bool),
        _ => false,
    }
}
