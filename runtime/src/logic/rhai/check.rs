//! What the compiled script does with tags and blocks, found by walking its AST once: the tags
//! it names, the first assignment of each (for a fault's position), and its block calls with
//! literal instance names (one kind and one call site per instance; every output read names a
//! called instance).

use std::collections::{HashMap, HashSet};

use rhai::Position;

use super::blocks::{block_function, READERS};
use super::error::CompileErrorKind;
use super::internals::{self, ExprView, Node, StmtView, AST};

/// What the walk found.
#[derive(Debug, Default)]
pub(crate) struct Usage {
    /// Every variable name read or written (a superset of the tags used).
    pub names: HashSet<String>,
    /// First assignment position of each assigned name.
    pub assigned: HashMap<String, Position>,
    /// Every block call and output read with a literal instance name: its position and the
    /// name (resolved to the instance's slot before the first scan, see `blocks.rs`).
    pub block_calls: Vec<(Position, String)>,
    /// Every variable a closure captures, where.
    pub captured: Vec<(Position, String)>,
}

/// Walks `ast`; errors (with their Rhai positions) go to `errors`.
pub(crate) fn walk(ast: &AST, errors: &mut Vec<(Position, CompileErrorKind)>) -> Usage {
    let mut usage = Usage::default();
    // Instance → (kind name, first call position).
    let mut calls: HashMap<String, (&'static str, Position)> = HashMap::new();
    let mut reads: Vec<(String, Position)> = Vec::new();
    internals::walk(ast, |node| {
        let stmt = match node {
            Node::Stmt(s) => Some(internals::stmt(s)),
            Node::Expr(_) => None,
        };
        let expr = match node {
            Node::Expr(e) => Some(internals::expr(e)),
            Node::Stmt(_) => None,
        };
        match (stmt, expr) {
            (_, Some(ExprView::Var(name, _))) => {
                usage.names.insert(name.to_string());
            }
            (Some(StmtView::Share(vars)), _) => {
                for (name, pos) in vars {
                    usage.captured.push((pos, name.to_string()));
                }
            }
            (Some(StmtView::Assign(a)), _) => {
                if let ExprView::Var(name, pos) = internals::expr(a.lhs) {
                    usage.assigned.entry(name.to_string()).or_insert(pos);
                }
            }
            (_, Some(ExprView::Call(call))) => {
                let pos = &call.pos;
                let literal = match call.args.first().map(internals::expr) {
                    Some(ExprView::Str(s, _)) => Some(s.to_string()),
                    _ => None,
                };
                if let Some(name) = literal {
                    let block = block_function(call.name);
                    if block.is_some() || READERS.contains(&call.name) {
                        usage.block_calls.push((*pos, name.clone()));
                    }
                    if let Some((def, _)) = block {
                        let this = def.name;
                        match calls.get(&name) {
                            Some(&(first, at)) if first != this => errors.push((
                                *pos,
                                CompileErrorKind::KindClash {
                                    name,
                                    first,
                                    this,
                                    first_line: line(at),
                                },
                            )),
                            Some(&(_, at)) => errors.push((
                                *pos,
                                CompileErrorKind::CalledTwice {
                                    name,
                                    first_line: line(at),
                                },
                            )),
                            None => {
                                calls.insert(name, (this, *pos));
                            }
                        }
                    } else if READERS.contains(&call.name) && call.args.len() == 1 {
                        reads.push((name, *pos));
                    }
                }
            }
            _ => {}
        }
        true
    });
    for (name, pos) in reads {
        if !calls.contains_key(&name) {
            errors.push((pos, CompileErrorKind::UnknownInstance { name }));
        }
    }
    usage
}

/// The user's line of a Rhai position (the script has one line of declarations on top).
pub(crate) fn line(pos: Position) -> u32 {
    u32::try_from(pos.line().unwrap_or(2).saturating_sub(1).max(1)).unwrap_or(u32::MAX)
}
