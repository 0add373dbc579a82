//! The signatures of the library softplc registers for scripts (blocks, output readers,
//! quality, `limit`): what the checker holds every call against. `blocks::register` and
//! `quality::register` are the implementations; a test asserts that every signature here is
//! registered and that nothing is registered that is not here.

/// What an argument must be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Param {
    /// A block instance's name: a string.
    Name,
    /// A bool.
    Bool,
    /// A time: milliseconds (integer or float) or a duration string such as `"1.5s"`.
    Time,
    /// An integer (a counter's preset).
    Int,
    /// A blink pattern: a string of `0` and `1`.
    Pattern,
    /// A number; all `Number` arguments of one call have one type (integers or floats).
    Number,
    /// A tag variable (`good`/`bad`; `quality.rs` checks it).
    Tag,
}

/// What a function returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Returns {
    Bool,
    Int,
    /// The type of its `Number` arguments.
    SameNumber,
}

/// One overload of a library function.
#[derive(Debug)]
pub(crate) struct Signature {
    pub name: &'static str,
    /// Parameter names (as the docs and messages call them) and kinds.
    pub params: &'static [(&'static str, Param)],
    pub returns: Returns,
}

impl Signature {
    /// `ton(name, in, pt)`.
    pub(crate) fn usage(&self) -> String {
        let names: Vec<&str> = self.params.iter().map(|(n, _)| *n).collect();
        format!("{}({})", self.name, names.join(", "))
    }
}

use Param::*;

const fn sig(
    name: &'static str,
    params: &'static [(&'static str, Param)],
    returns: Returns,
) -> Signature {
    Signature {
        name,
        params,
        returns,
    }
}

const TIMER: &[(&str, Param)] = &[("name", Name), ("in", Bool), ("pt", Time)];
const STAIR_RESET: &[(&str, Param)] =
    &[("name", Name), ("in", Bool), ("pt", Time), ("reset", Bool)];
/// SR: set dominant (`s1`); RS: reset dominant (`r1`), as IEC 61131-3 names them.
const SET_LATCH: &[(&str, Param)] = &[("name", Name), ("s1", Bool), ("r", Bool)];
const RESET_LATCH: &[(&str, Param)] = &[("name", Name), ("s", Bool), ("r1", Bool)];
const UP: &[(&str, Param)] = &[("name", Name), ("cu", Bool), ("reset", Bool), ("pv", Int)];
const DOWN: &[(&str, Param)] = &[("name", Name), ("cd", Bool), ("load", Bool), ("pv", Int)];
const UP_DOWN: &[(&str, Param)] = &[
    ("name", Name),
    ("cu", Bool),
    ("cd", Bool),
    ("reset", Bool),
    ("load", Bool),
    ("pv", Int),
];
const EDGE: &[(&str, Param)] = &[("name", Name), ("x", Bool)];
const TOGGLE_RESET: &[(&str, Param)] = &[("name", Name), ("x", Bool), ("reset", Bool)];
const BLINK: &[(&str, Param)] = &[("name", Name), ("en", Bool), ("on", Time), ("off", Time)];
const PATTERN: &[(&str, Param)] = &[
    ("name", Name),
    ("en", Bool),
    ("pattern", Pattern),
    ("step", Time),
];
const READER: &[(&str, Param)] = &[("name", Name)];
const QUALITY: &[(&str, Param)] = &[("tag", Tag)];
const LIMIT: &[(&str, Param)] = &[("min", Number), ("x", Number), ("max", Number)];

/// Every library function, each overload once (as the `rhai` module docs list them).
pub(crate) const LIBRARY: &[Signature] = &[
    sig("ton", TIMER, Returns::Bool),
    sig("tof", TIMER, Returns::Bool),
    sig("tp", TIMER, Returns::Bool),
    sig("stair", TIMER, Returns::Bool),
    sig("stair", STAIR_RESET, Returns::Bool),
    sig("ctu", UP, Returns::Bool),
    sig("ctd", DOWN, Returns::Bool),
    sig("ctud", UP_DOWN, Returns::Bool),
    sig("r_trig", EDGE, Returns::Bool),
    sig("f_trig", EDGE, Returns::Bool),
    sig("sr", SET_LATCH, Returns::Bool),
    sig("rs", RESET_LATCH, Returns::Bool),
    sig("toggle", EDGE, Returns::Bool),
    sig("toggle", TOGGLE_RESET, Returns::Bool),
    sig("blink", BLINK, Returns::Bool),
    sig("blink_pattern", PATTERN, Returns::Bool),
    sig("q", READER, Returns::Bool),
    sig("qu", READER, Returns::Bool),
    sig("qd", READER, Returns::Bool),
    sig("et", READER, Returns::Int),
    sig("cv", READER, Returns::Int),
    sig("good", QUALITY, Returns::Bool),
    sig("bad", QUALITY, Returns::Bool),
    sig("limit", LIMIT, Returns::SameNumber),
];

/// The overloads of `name`.
pub(crate) fn overloads(name: &str) -> impl Iterator<Item = &'static Signature> + '_ {
    LIBRARY.iter().filter(move |s| s.name == name)
}

/// What `name` called with `arity` arguments returns, if it is a library function.
pub(crate) fn returns(name: &str, arity: usize) -> Option<Returns> {
    overloads(name)
        .find(|s| s.params.len() == arity)
        .map(|s| s.returns)
}
