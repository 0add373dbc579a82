//! The push-down view of an `.expr` program: each statement as a [`Rung`] of the offload IR.
//!
//! Recognised (`c` is the statement's coil, `E`, `S`, `R` conditions without edges, timers or
//! comparisons, `a`, `b` such conditions too):
//! - `c = E` where `E` does not read `c` → combinational;
//! - `c = (S | c) & !R` → latch, reset dominant; `c = S | (c & !R)` → latch, set dominant;
//!   any other `c = E` reading `c` whose step is "set", "reset" or "keep" for every input
//!   (never "invert") → latch with `S = E[c:=0]`, `R = !E[c:=1]` (which never hold together);
//! - `c = tp(E, T)` → pulse (IEC TP, the trigger's rising edge);
//! - `c = c ^ (rising(a) | rising(b) ...)` → impulse relay (toggle);
//! - `c = (rising(a) | ... | c) & !rising(b) & ...` → edge set / edge reset, reset winning;
//! - anything else → opaque, with the reason (an edge, a timer, a comparison).

use std::path::Path;

use super::check::{BoolExpr as Expr, CheckedStmt};
use super::parser::EdgeKind;
use crate::image::TagId;
use crate::logic::blocks::Kind;
use std::collections::BTreeMap;

use crate::logic::Rung;
use crate::logic::SourcePos;
use crate::project::DocText;
use softplc_io::rung::{BoolExpr, RungShape};

/// The rungs of checked statements, each titled by its comment's first sentence.
pub(crate) fn describe(
    stmts: &[CheckedStmt],
    file: &Path,
    comments: &BTreeMap<u32, DocText>,
) -> Vec<Rung> {
    stmts
        .iter()
        .map(|s| Rung {
            coil: s.coil,
            shape: shape(s.coil, &s.expr),
            pos: SourcePos {
                file: file.to_path_buf(),
                line: s.pos.line,
                column: s.pos.col,
            },
            title: comments.get(&s.pos.line).map(DocText::summary),
        })
        .collect()
}

/// The shape of `c = e`.
fn shape(c: TagId, e: &Expr) -> RungShape {
    if let Some(ir) = pure(e) {
        return if ir.reads(c) {
            latch(c, e, &ir)
        } else {
            RungShape::Combinational { expr: ir }
        };
    }
    if let Expr::Timer {
        kind: Kind::Tp,
        arg,
        preset,
    } = e
    {
        if let Some(trigger) = pure(arg).filter(|t| !t.reads(c)) {
            return RungShape::Pulse {
                trigger: vec![trigger],
                width: *preset,
            };
        }
    }
    if let Some(trigger) = toggle(c, e) {
        return RungShape::Toggle { trigger };
    }
    if let Some((set, reset)) = edge_set_reset(c, e) {
        return RungShape::EdgeSetReset { set, reset };
    }
    RungShape::Opaque {
        reason: opaque_reason(e).into(),
    }
}

/// The condition as IR when it has no edge, timer or comparison.
fn pure(e: &Expr) -> Option<BoolExpr> {
    Some(match e {
        Expr::Load(id) => BoolExpr::Tag(*id),
        Expr::Const(b) => BoolExpr::Const(*b),
        Expr::Not(inner) => BoolExpr::negate(pure(inner)?),
        Expr::And(items) => BoolExpr::And(items.iter().map(pure).collect::<Option<_>>()?),
        Expr::Or(items) => BoolExpr::Or(items.iter().map(pure).collect::<Option<_>>()?),
        Expr::Xor(items) => BoolExpr::Xor(items.iter().map(pure).collect::<Option<_>>()?),
        Expr::Cmp { .. }
        | Expr::Edge { .. }
        | Expr::Timer { .. }
        | Expr::Good(_)
        | Expr::Bad(_) => return None,
    })
}

/// Whether a condition tests a tag's quality (`good(x)`, `bad(x)`): only the scan knows it.
fn reads_quality(e: &Expr) -> bool {
    match e {
        Expr::Good(_) | Expr::Bad(_) => true,
        Expr::Load(_) | Expr::Const(_) | Expr::Cmp { .. } => false,
        Expr::Not(inner) | Expr::Edge { arg: inner, .. } | Expr::Timer { arg: inner, .. } => {
            reads_quality(inner)
        }
        Expr::And(items) | Expr::Or(items) | Expr::Xor(items) => items.iter().any(reads_quality),
    }
}

/// Why a condition is none of the forms.
fn opaque_reason(e: &Expr) -> &'static str {
    if reads_quality(e) {
        return "a tag's quality (good/bad) in the condition, which only the scan knows";
    }
    fn find(e: &Expr, timer: &mut bool, edge: &mut bool, cmp: &mut bool) {
        match e {
            Expr::Load(_) | Expr::Const(_) | Expr::Good(_) | Expr::Bad(_) => {}
            Expr::Not(inner) => find(inner, timer, edge, cmp),
            Expr::And(items) | Expr::Or(items) | Expr::Xor(items) => {
                items.iter().for_each(|i| find(i, timer, edge, cmp));
            }
            Expr::Cmp { .. } => *cmp = true,
            Expr::Edge { arg, .. } => {
                *edge = true;
                find(arg, timer, edge, cmp);
            }
            Expr::Timer { arg, .. } => {
                *timer = true;
                find(arg, timer, edge, cmp);
            }
        }
    }
    let (mut timer, mut edge, mut cmp) = (false, false, false);
    find(e, &mut timer, &mut edge, &mut cmp);
    if timer {
        "memory or a timer in the condition (a timer the module cannot run there)"
    } else if edge {
        "memory or a timer in the condition (an edge the module cannot see there)"
    } else if cmp {
        "a comparison of numbers in the condition"
    } else {
        "the coil is used in a way that is no latch"
    }
}

/// A latch from a condition that reads its own coil.
fn latch(c: TagId, e: &Expr, ir: &BoolExpr) -> RungShape {
    // The written forms first: their set and reset read as the program says.
    if let Some((set, reset, reset_dominant)) = written_latch(c, e) {
        return RungShape::Latch {
            set,
            reset,
            reset_dominant,
        };
    }
    // Otherwise by substitution, when the step never inverts the coil.
    RungShape::self_latch(c, ir)
}

/// `(S | c) & !R` (reset dominant) or `S | (c & !R)` (set dominant), in any operand order;
/// `R` is the conjunction of the negated terms.
fn written_latch(c: TagId, e: &Expr) -> Option<(BoolExpr, BoolExpr, bool)> {
    let is_c = |x: &Expr| matches!(x, Expr::Load(id) if *id == c);
    match e {
        Expr::And(items) => {
            let (or, rest) = holding(items, is_c, |x| match x {
                Expr::Or(o) => Some(o),
                _ => None,
            })?;
            let set = or_of(or.iter().filter(|x| !is_c(x)))?;
            let keep = and_of(rest)?;
            (!set.reads(c) && !keep.reads(c)).then(|| (set, BoolExpr::negate(keep), true))
        }
        Expr::Or(items) => {
            let (and, rest) = holding(items, is_c, |x| match x {
                Expr::And(a) => Some(a),
                _ => None,
            })?;
            let keep = and_of(and.iter().filter(|x| !is_c(x)))?;
            let set = or_of(rest)?;
            (!set.reads(c) && !keep.reads(c)).then(|| (set, BoolExpr::negate(keep), false))
        }
        _ => None,
    }
}

/// The first operand of `items` that `inner` opens (an `Or` inside an `And`, or the other way
/// round) and that holds the coil `c` itself, with its list, and the other operands.
fn holding(
    items: &[Expr],
    is_c: impl Fn(&Expr) -> bool,
    inner: impl Fn(&Expr) -> Option<&Vec<Expr>>,
) -> Option<(&[Expr], impl Iterator<Item = &Expr>)> {
    let hold = items
        .iter()
        .position(|i| inner(i).is_some_and(|list| list.iter().any(&is_c)))?;
    let list = inner(&items[hold])?;
    let rest = items
        .iter()
        .enumerate()
        .filter(move |(i, _)| *i != hold)
        .map(|(_, x)| x);
    Some((list.as_slice(), rest))
}

fn or_of<'a>(items: impl Iterator<Item = &'a Expr>) -> Option<BoolExpr> {
    let v: Vec<BoolExpr> = items.map(pure).collect::<Option<_>>()?;
    Some(single(v, BoolExpr::Or))
}

fn and_of<'a>(items: impl Iterator<Item = &'a Expr>) -> Option<BoolExpr> {
    let v: Vec<BoolExpr> = items.map(pure).collect::<Option<_>>()?;
    Some(single(v, BoolExpr::And))
}

/// One operand stays itself; none or several make the n-ary node.
fn single(mut v: Vec<BoolExpr>, make: fn(Vec<BoolExpr>) -> BoolExpr) -> BoolExpr {
    if v.len() == 1 {
        v.remove(0)
    } else {
        make(v)
    }
}

/// `rising(a)` or `rising(a) | rising(b) | ...` with pure arguments not reading `c`: the
/// conditions whose edges count.
fn edges(c: TagId, e: &Expr) -> Option<Vec<BoolExpr>> {
    let one = |x: &Expr| match x {
        Expr::Edge {
            kind: EdgeKind::Rising,
            arg,
        } => pure(arg).filter(|a| !a.reads(c)),
        _ => None,
    };
    match e {
        Expr::Or(items) => items.iter().map(one).collect(),
        other => one(other).map(|a| vec![a]),
    }
}

/// `c ^ EDGES` or `EDGES ^ c`.
fn toggle(c: TagId, e: &Expr) -> Option<Vec<BoolExpr>> {
    let Expr::Xor(items) = e else { return None };
    match items.as_slice() {
        [Expr::Load(id), other] | [other, Expr::Load(id)] if *id == c => edges(c, other),
        _ => None,
    }
}

/// `(EDGES | c) & !EDGES & ...`.
fn edge_set_reset(c: TagId, e: &Expr) -> Option<(Vec<BoolExpr>, Vec<BoolExpr>)> {
    let Expr::And(items) = e else { return None };
    let is_c = |x: &Expr| matches!(x, Expr::Load(id) if *id == c);
    let mut set = None;
    let mut reset = Vec::new();
    for item in items {
        match item {
            Expr::Or(or) if or.iter().any(is_c) && set.is_none() => {
                let mut s = Vec::new();
                for x in or.iter().filter(|x| !is_c(x)) {
                    s.extend(edges(c, x)?);
                }
                set = Some(s);
            }
            Expr::Not(inner) => reset.extend(edges(c, inner)?),
            _ => return None,
        }
    }
    let set = set.filter(|s| !s.is_empty())?;
    (!reset.is_empty()).then_some((set, reset))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use softplc_io::point::ValueType;

    use super::*;
    use crate::logic::expr::{compile, TagTable};
    use crate::logic::LogicEngine;

    fn shapes(src: &str) -> Vec<RungShape> {
        let tags = TagTable::new(["a", "b", "c", "y", "n"].iter().enumerate().map(|(i, n)| {
            let ty = if *n == "n" {
                ValueType::U16
            } else {
                ValueType::Bool
            };
            (n.to_string(), TagId(i as u32), ty, true)
        }));
        let p = compile(src, Path::new("t.expr"), &tags).unwrap();
        p.rungs().unwrap().into_iter().map(|r| r.shape).collect()
    }

    fn t(i: u32) -> BoolExpr {
        BoolExpr::Tag(TagId(i))
    }

    fn one(src: &str) -> RungShape {
        shapes(src).remove(0)
    }

    #[test]
    fn combinational_and_latches() {
        assert_eq!(
            one("y = a & !b | c\n"),
            RungShape::Combinational {
                expr: BoolExpr::Or(vec![
                    BoolExpr::And(vec![t(0), BoolExpr::negate(t(1))]),
                    t(2)
                ])
            }
        );
        assert_eq!(
            one("y = (a | y) & !b\n"),
            RungShape::Latch {
                set: t(0),
                reset: t(1),
                reset_dominant: true
            }
        );
        assert_eq!(
            one("y = a | (y & !b)\n"),
            RungShape::Latch {
                set: t(0),
                reset: t(1),
                reset_dominant: false
            }
        );
        // By substitution: keep while a, set by b.
        assert!(matches!(
            one("y = y & a | b & a\n"),
            RungShape::Latch { .. }
        ));
        assert!(matches!(one("y = !y\n"), RungShape::Opaque { .. }));
        assert!(matches!(one("y = y ^ a\n"), RungShape::Opaque { .. }));
    }

    #[test]
    fn pulses_edges_and_opaque() {
        assert_eq!(
            one("y = tp(a & b, 50ms)\n"),
            RungShape::Pulse {
                trigger: vec![BoolExpr::And(vec![t(0), t(1)])],
                width: Duration::from_millis(50)
            }
        );
        assert_eq!(
            one("y = y ^ (rising(a) | rising(b))\n"),
            RungShape::Toggle {
                trigger: vec![t(0), t(1)]
            }
        );
        assert_eq!(
            one("y = (rising(a) | y) & !rising(b)\n"),
            RungShape::EdgeSetReset {
                set: vec![t(0)],
                reset: vec![t(1)]
            }
        );
        let RungShape::Opaque { reason } = one("y = ton(a, 1s)\n") else {
            panic!()
        };
        assert!(reason.contains("timer"));
        let RungShape::Opaque { reason } = one("y = n > 3\n") else {
            panic!()
        };
        assert!(reason.contains("comparison"));
        let RungShape::Opaque { reason } = one("y = (rising(a) | y) & !b\n") else {
            panic!()
        };
        assert!(reason.contains("edge"));
        assert!(matches!(one("y = tp(y, 1s)\n"), RungShape::Opaque { .. }));
    }
}
