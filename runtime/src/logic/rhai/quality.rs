//! `good(tag)` and `bad(tag)`: a script reads a tag's quality.
//!
//! A Rhai function receives values, not variables, so `good(level)` cannot know by itself
//! which tag it was given. The compiler resolves it instead: walking the AST, it finds every
//! call `good(NAME)` / `bad(NAME)` whose one argument is a tag variable, and records the call's
//! position with the tag's [`TagId`]. At the start of each scan the tags' qualities are copied,
//! by index, into one slot per call site; the registered function finds its slot from the
//! position of the call (a binary search over integers, no name is looked up) and answers from
//! it. A call the compiler did not resolve (through `call`, a function pointer, ...) is a
//! run-time error.

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

use rhai::{Dynamic, Engine, EvalAltResult, NativeCallContext, Position};
use softplc_io::point::Quality;

use super::error::CompileErrorKind;
use super::internals::{self, ExprView, Node, AST};
use crate::image::{ProcessImage, TagId};
use crate::logic::expr::TagTable;

/// The quality functions: `good` (quality is Good) and `bad` (quality is Bad).
pub(crate) const FUNCTIONS: [&str; 2] = ["good", "bad"];

/// One resolved call: where it is in the compiled text, and the tag it tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Site {
    /// `(line, column)` of the call in the compiled text (with the declarations line).
    at: (usize, usize),
    tag: TagId,
}

/// The call sites of a script and, per site, the quality its tag had at the start of the scan.
#[derive(Debug, Default)]
pub(crate) struct Sites {
    /// Sorted by position.
    sites: Vec<Site>,
    /// Per site: [`code`] of the tag's quality.
    qualities: Vec<AtomicU8>,
}

/// A quality as a byte.
fn code(q: Quality) -> u8 {
    match q {
        Quality::Good => 0,
        Quality::Stale => 1,
        Quality::Bad => 2,
    }
}

/// A position as a sortable key.
fn key(pos: Position) -> (usize, usize) {
    (pos.line().unwrap_or(0), pos.position().unwrap_or(0))
}

impl Sites {
    /// Copies each site's tag quality from the image (a tag beyond the image reads as Bad).
    pub(crate) fn copy_in(&self, image: &ProcessImage) {
        for (site, q) in self.sites.iter().zip(&self.qualities) {
            let quality = image
                .slots()
                .get(site.tag.index())
                .map_or(Quality::Bad, |s| s.quality);
            q.store(code(quality), Ordering::Relaxed);
        }
    }

    /// The quality code for the call at `pos`, if the compiler resolved it.
    fn at(&self, pos: Position) -> Option<u8> {
        let i = self.sites.binary_search_by_key(&key(pos), |s| s.at).ok()?;
        self.qualities.get(i).map(|q| q.load(Ordering::Relaxed))
    }

    /// Number of resolved call sites.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.sites.len()
    }
}

/// Finds and checks every `good(…)` / `bad(…)` call of `ast`: the argument must be one tag
/// variable, and the call must be in the script's body (functions do not see tags). Errors, with
/// their Rhai positions, go to `errors`.
pub(crate) fn resolve(
    ast: &AST,
    tags: &TagTable,
    errors: &mut Vec<(Position, CompileErrorKind)>,
) -> Sites {
    // Calls inside functions, found by walking the functions alone.
    let mut in_functions = Vec::new();
    internals::walk(&ast.clone_functions_only(), |node| {
        if let Node::Expr(e) = node {
            if let ExprView::Call(call) = internals::expr(e) {
                if let Some(function) = quality_function(call.name) {
                    in_functions.push((key(call.pos), function));
                }
            }
        }
        true
    });
    let mut sites = Vec::new();
    internals::walk(ast, |node| {
        let Node::Expr(e) = node else {
            return true;
        };
        match internals::expr(e) {
            ExprView::Call(call) => {
                let pos = &call.pos;
                let Some(function) = quality_function(call.name) else {
                    return true;
                };
                if in_functions.iter().any(|(k, _)| *k == key(*pos)) {
                    errors.push((*pos, CompileErrorKind::QualityInFunction { function }));
                    return true;
                }
                let arg = match call.args {
                    [arg] => arg,
                    _ => {
                        errors.push((*pos, CompileErrorKind::QualityArgument { function }));
                        return true;
                    }
                };
                match internals::expr(arg) {
                    ExprView::Var(name, _) => match tags.get(name) {
                        Some(entry) => sites.push(Site {
                            at: key(*pos),
                            tag: entry.id,
                        }),
                        None => errors.push((
                            internals::position(arg),
                            CompileErrorKind::QualityOfNonTag {
                                function,
                                name: name.to_string(),
                            },
                        )),
                    },
                    _ => errors.push((
                        internals::position(arg),
                        CompileErrorKind::QualityArgument { function },
                    )),
                }
            }
            ExprView::Method(call) => {
                if let Some(function) = quality_function(call.name) {
                    errors.push((call.pos, CompileErrorKind::QualityArgument { function }));
                }
            }
            _ => {}
        }
        true
    });
    sites.sort_by_key(|s| s.at);
    sites.dedup_by_key(|s| s.at);
    let qualities = sites
        .iter()
        .map(|_| AtomicU8::new(code(Quality::Bad)))
        .collect();
    Sites { sites, qualities }
}

/// `Some("good")` / `Some("bad")` for the quality functions.
fn quality_function(name: &str) -> Option<&'static str> {
    FUNCTIONS.iter().copied().find(|f| *f == name)
}

/// Registers `good` and `bad`, answering from `sites`.
pub(crate) fn register(engine: &mut Engine, sites: &Arc<Sites>) {
    for (function, wanted) in [("good", Quality::Good), ("bad", Quality::Bad)] {
        let sites = sites.clone();
        let wanted = code(wanted);
        engine.register_fn(
            function,
            move |ctx: NativeCallContext, _tag: Dynamic| -> Result<bool, Box<EvalAltResult>> {
                match sites.at(ctx.call_position()) {
                    Some(q) => Ok(q == wanted),
                    None => Err(format!(
                        "{function}() must be called directly with a tag name, e.g. {function}(level)"
                    )
                    .into()),
                }
            },
        );
    }
}
