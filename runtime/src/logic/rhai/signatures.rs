//! The signatures of the library softplc registers for scripts (blocks, output readers,
//! quality, `limit`): what the checker holds every call against. `blocks::register` and
//! `quality::register` are the implementations; a test asserts that every signature here is
//! registered and that nothing is registered that is not here.

use std::sync::LazyLock;

use crate::logic::blocks::{Kind, PinType};

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
    /// A 16-bit mask: an integer, 0..=65535.
    Mask,
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
    pub params: Vec<(&'static str, Param)>,
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

fn sig(name: &'static str, params: &[(&'static str, Param)], returns: Returns) -> Signature {
    Signature {
        name,
        params: params.to_vec(),
        returns,
    }
}

/// The block functions, from the block registry: each form of each block, each shorter
/// overload where its last pins are optional, in documentation order. Each returns its
/// block's main output, a bool.
fn block_signatures() -> impl Iterator<Item = Signature> {
    Kind::ALL.into_iter().flat_map(|kind| {
        let def = kind.def();
        def.forms.iter().flat_map(move |form| {
            form.overloads().map(move |pins| {
                let mut params = vec![("name", Name)];
                params.extend(pins.iter().filter_map(|&i| def.pins.get(i)).map(|p| {
                    let param = match p.ty {
                        PinType::Bool => Bool,
                        PinType::Time => Time,
                        PinType::Count => Int,
                        PinType::Mask => Mask,
                        PinType::Pattern => Pattern,
                    };
                    (p.rhai, param)
                }));
                Signature {
                    name: form.rhai,
                    params,
                    returns: Returns::Bool,
                }
            })
        })
    })
}

const READER: &[(&str, Param)] = &[("name", Name)];
const QUALITY: &[(&str, Param)] = &[("tag", Tag)];
const LIMIT: &[(&str, Param)] = &[("min", Number), ("x", Number), ("max", Number)];

/// Every library function, each overload once (as the `rhai` module docs list them).
pub(crate) static LIBRARY: LazyLock<Vec<Signature>> = LazyLock::new(|| {
    block_signatures()
        .chain([
            sig("q", READER, Returns::Bool),
            sig("qu", READER, Returns::Bool),
            sig("qd", READER, Returns::Bool),
            sig("et", READER, Returns::Int),
            sig("cv", READER, Returns::Int),
            sig("good", QUALITY, Returns::Bool),
            sig("bad", QUALITY, Returns::Bool),
            sig("limit", LIMIT, Returns::SameNumber),
        ])
        .collect()
});

/// The library's function names, each once: the blocks', the output readers, quality's,
/// `limit` (for messages).
pub(crate) fn names() -> String {
    let mut names: Vec<&str> = Vec::new();
    let blocks = block_signatures().map(|s| s.name);
    let others = super::blocks::READERS
        .into_iter()
        .chain(super::quality::FUNCTIONS)
        .chain(["limit"]);
    for name in blocks.chain(others) {
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names.join(", ")
}

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

/// Whether `name` is a function of softplc's library (a block of one's own may not take it).
pub(crate) fn is_library(name: &str) -> bool {
    overloads(name).next().is_some()
}
