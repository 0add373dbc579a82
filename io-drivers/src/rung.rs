//! The engine-neutral rung IR: what a logic engine tells the push-down planner about each coil
//! it writes, and what a family's push-down target takes.
//!
//! An engine describes a rung by its *shape*: one of the few behaviours a module can run
//! itself, with the boolean conditions it reads, or [`RungShape::Opaque`] with the reason it is
//! none of them. Every shape is defined here by its **central** semantics, scan by scan, as the
//! engines run it (a condition is sampled once per scan; "rising edge" means false on the
//! previous scan and true on this one, never on the first scan). The module mappings are
//! proved against these definitions. Tags are named by their index in the program's tag list
//! ([`TagId`]), and a rung's place in its program by the engine's own position type (the
//! runtime's `logic::Rung` is a [`Rung`] at a place in a program file).

use std::collections::BTreeSet;
use std::fmt;
use std::time::Duration;

/// Index of a tag in the process image (its position in the project's tag list).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TagId(pub u32);

impl TagId {
    /// As an index.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A boolean condition over bool tags: no memory, no time. Conditions with edges, timers,
/// comparisons or numbers are not representable and make the rung [`RungShape::Opaque`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BoolExpr {
    /// A constant.
    Const(bool),
    /// A bool tag's current value.
    Tag(TagId),
    /// Negation.
    Not(Box<BoolExpr>),
    /// Conjunction (true when empty).
    And(Vec<BoolExpr>),
    /// Disjunction (false when empty).
    Or(Vec<BoolExpr>),
    /// Exclusive or of all operands (false when empty).
    Xor(Vec<BoolExpr>),
}

impl BoolExpr {
    /// `!e`, folding `!!x` to `x` and `!1` to `0`.
    pub fn negate(e: BoolExpr) -> Self {
        match e {
            BoolExpr::Not(inner) => *inner,
            BoolExpr::Const(b) => BoolExpr::Const(!b),
            other => BoolExpr::Not(Box::new(other)),
        }
    }

    /// The value, reading tags through `value`.
    pub fn eval(&self, value: &mut dyn FnMut(TagId) -> bool) -> bool {
        match self {
            BoolExpr::Const(b) => *b,
            BoolExpr::Tag(id) => value(*id),
            BoolExpr::Not(e) => !e.eval(value),
            BoolExpr::And(items) => items.iter().fold(true, |acc, e| e.eval(value) & acc),
            BoolExpr::Or(items) => items.iter().fold(false, |acc, e| e.eval(value) | acc),
            BoolExpr::Xor(items) => items.iter().fold(false, |acc, e| e.eval(value) ^ acc),
        }
    }

    /// Every tag the condition reads.
    pub fn tags(&self) -> BTreeSet<TagId> {
        let mut out = BTreeSet::new();
        self.collect(&mut out);
        out
    }

    fn collect(&self, out: &mut BTreeSet<TagId>) {
        match self {
            BoolExpr::Const(_) => {}
            BoolExpr::Tag(id) => {
                out.insert(*id);
            }
            BoolExpr::Not(e) => e.collect(out),
            BoolExpr::And(items) | BoolExpr::Or(items) | BoolExpr::Xor(items) => {
                items.iter().for_each(|e| e.collect(out));
            }
        }
    }

    /// The condition with the tag `id` replaced by a constant.
    pub fn substitute(&self, id: TagId, value: bool) -> BoolExpr {
        let sub = |items: &[BoolExpr]| items.iter().map(|i| i.substitute(id, value)).collect();
        match self {
            BoolExpr::Tag(t) if *t == id => BoolExpr::Const(value),
            BoolExpr::Const(_) | BoolExpr::Tag(_) => self.clone(),
            BoolExpr::Not(inner) => BoolExpr::negate(inner.substitute(id, value)),
            BoolExpr::And(items) => BoolExpr::And(sub(items)),
            BoolExpr::Or(items) => BoolExpr::Or(sub(items)),
            BoolExpr::Xor(items) => BoolExpr::Xor(sub(items)),
        }
    }

    /// Whether the condition reads `id`.
    pub fn reads(&self, id: TagId) -> bool {
        match self {
            BoolExpr::Const(_) => false,
            BoolExpr::Tag(t) => *t == id,
            BoolExpr::Not(e) => e.reads(id),
            BoolExpr::And(items) | BoolExpr::Or(items) | BoolExpr::Xor(items) => {
                items.iter().any(|e| e.reads(id))
            }
        }
    }

    /// The condition with tag names (`names[id]`), for reports: `a & !b | c`.
    pub fn display<'a>(&'a self, names: &'a [String]) -> impl fmt::Display + 'a {
        Shown { expr: self, names }
    }
}

struct Shown<'a> {
    expr: &'a BoolExpr,
    names: &'a [String],
}

impl Shown<'_> {
    fn write(&self, e: &BoolExpr, f: &mut fmt::Formatter<'_>, outer: u8) -> fmt::Result {
        // Precedence as in the expr language: | loosest (1), ^ (2), & (3), ! and atoms (4).
        let (prec, op, items) = match e {
            BoolExpr::Const(b) => return write!(f, "{}", u8::from(*b)),
            BoolExpr::Tag(id) => {
                return match self.names.get(id.index()) {
                    Some(n) => f.write_str(n),
                    None => write!(f, "#{}", id.0),
                }
            }
            BoolExpr::Not(inner) => {
                f.write_str("!")?;
                return self.write(inner, f, 4);
            }
            BoolExpr::Or(items) => (1, " | ", items),
            BoolExpr::Xor(items) => (2, " ^ ", items),
            BoolExpr::And(items) => (3, " & ", items),
        };
        if items.is_empty() {
            return write!(f, "{}", u8::from(matches!(e, BoolExpr::And(_))));
        }
        let paren = prec < outer;
        if paren {
            f.write_str("(")?;
        }
        for (i, item) in items.iter().enumerate() {
            if i > 0 {
                f.write_str(op)?;
            }
            self.write(item, f, prec + 1)?;
        }
        if paren {
            f.write_str(")")?;
        }
        Ok(())
    }
}

impl fmt::Display for Shown<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write(self.expr, f, 0)
    }
}

/// What a rung does to its coil, by its central semantics (one step per scan).
///
/// "An edge of `trigger`" below means: a scan on which at least one of the conditions in the
/// list is true and was false on the previous scan (the first scan sees no edge).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RungShape {
    /// `coil = expr` every scan.
    Combinational {
        /// The condition.
        expr: BoolExpr,
    },
    /// A set/reset latch of levels: `coil = !reset & (set | coil)` when `reset_dominant`,
    /// else `coil = set | (!reset & coil)`.
    Latch {
        /// Sets while true.
        set: BoolExpr,
        /// Resets while true.
        reset: BoolExpr,
        /// Which wins when both are true.
        reset_dominant: bool,
    },
    /// IEC TP: an edge of `trigger` while no pulse runs starts a pulse; the coil is true on the
    /// scans with `now − start < width`; edges during a pulse are ignored.
    Pulse {
        /// Starts the pulse.
        trigger: Vec<BoolExpr>,
        /// Its length.
        width: Duration,
    },
    /// Staircase light: an edge of `trigger` sets the coil and (re)starts its timer; the coil
    /// falls on the first scan with `now − last edge ≥ time`.
    StairPulse {
        /// Starts or restarts the pulse.
        trigger: Vec<BoolExpr>,
        /// Time after the last edge.
        time: Duration,
    },
    /// Impulse relay: each edge of `trigger` inverts the coil (once per scan, however many of
    /// the conditions rise together).
    Toggle {
        /// Inverts the coil.
        trigger: Vec<BoolExpr>,
    },
    /// Edge-triggered set/reset: an edge of `set` sets the coil, an edge of `reset` resets it,
    /// reset winning when both come in the same scan.
    EdgeSetReset {
        /// Sets on an edge.
        set: Vec<BoolExpr>,
        /// Resets on an edge.
        reset: Vec<BoolExpr>,
    },
    /// Blinker: while `enable`, `on` true then `off` false, repeating, starting with `on` at
    /// the scan `enable` became true; false while `enable` is false.
    Blink {
        /// Runs the blinker.
        enable: BoolExpr,
        /// Time on.
        on: Duration,
        /// Time off.
        off: Duration,
    },
    /// Blinker playing a bit pattern: while `enable`, bit `i mod len` of `pattern` during the
    /// `i`-th `step` since the scan `enable` became true; false while `enable` is false.
    BlinkPattern {
        /// Runs the blinker.
        enable: BoolExpr,
        /// The bits, in the order they are played.
        pattern: Vec<bool>,
        /// Time of one bit.
        step: Duration,
    },
    /// The MiniMod's own blinker (LAMP): while `enable`, bit `k` of `mask` during step `k` =
    /// (time since the PLC's start / 100 ms) mod 16; false while `enable` is false. The phase
    /// runs freely: it is the clock's, not the enable's (the module's "Automatic continuous
    /// blinking").
    Lamp {
        /// Shows the mask.
        enable: BoolExpr,
        /// The 16-step mask, bit 0 first.
        mask: u16,
    },
    /// None of the above: the rung stays central, for this reason (shown in the report, after
    /// "the rung has …" style: "a timer in the condition").
    Opaque {
        /// Why, in words.
        reason: String,
    },
}

/// Most tags a self-reading condition may read for [`RungShape::self_latch`] to check it
/// (2^12 evaluations).
const MAX_LATCH_TAGS: usize = 12;

impl RungShape {
    /// The tags the module's own logic reads once this shape is pushed down. A pulse's trigger
    /// and a blinker's enable are not among them: the scan keeps them and only the width or
    /// the pattern runs in the module.
    pub fn module_inputs(&self) -> BTreeSet<TagId> {
        let all =
            |exprs: &[&BoolExpr]| exprs.iter().flat_map(|e| e.tags()).collect::<BTreeSet<_>>();
        match self {
            RungShape::Combinational { expr } => expr.tags(),
            RungShape::Latch { set, reset, .. } => all(&[set, reset]),
            RungShape::StairPulse { trigger, .. } | RungShape::Toggle { trigger } => {
                all(&trigger.iter().collect::<Vec<_>>())
            }
            RungShape::EdgeSetReset { set, reset } => {
                all(&set.iter().chain(reset).collect::<Vec<_>>())
            }
            RungShape::Pulse { .. }
            | RungShape::Blink { .. }
            | RungShape::BlinkPattern { .. }
            | RungShape::Lamp { .. }
            | RungShape::Opaque { .. } => BTreeSet::new(),
        }
    }

    /// The shape of `coil = expr` where `expr` reads `coil`: each scan the coil is set where
    /// `expr[coil:=0]` holds and reset where `expr[coil:=1]` does not. That is a latch exactly
    /// when the two never hold together (then the step never inverts the coil, and which one
    /// dominates does not matter); checked over every combination of the other tags, when
    /// there are at most `MAX_LATCH_TAGS` of them.
    pub fn self_latch(coil: TagId, expr: &BoolExpr) -> RungShape {
        let set = expr.substitute(coil, false);
        let reset = BoolExpr::negate(expr.substitute(coil, true));
        let tags: Vec<TagId> = expr.tags().into_iter().filter(|&t| t != coil).collect();
        if tags.len() > MAX_LATCH_TAGS {
            return RungShape::Opaque {
                reason: "the condition reads its own coil and too many tags to check it is a \
                         latch"
                    .into(),
            };
        }
        for m in 0u32..(1 << tags.len()) {
            let mut value = |t: TagId| {
                tags.iter()
                    .position(|&x| x == t)
                    .is_some_and(|i| m & (1 << i) != 0)
            };
            if set.eval(&mut value) && reset.eval(&mut value) {
                return RungShape::Opaque {
                    reason: "the rung inverts its coil for some inputs: no latch".into(),
                };
            }
        }
        RungShape::Latch {
            set,
            reset,
            reset_dominant: true,
        }
    }

    /// A short name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            RungShape::Combinational { .. } => "combinational",
            RungShape::Latch { .. } => "set/reset latch",
            RungShape::Pulse { .. } => "pulse (TP)",
            RungShape::StairPulse { .. } => "staircase pulse",
            RungShape::Toggle { .. } => "impulse relay (toggle)",
            RungShape::EdgeSetReset { .. } => "edge set/reset",
            RungShape::Blink { .. } => "blinker",
            RungShape::BlinkPattern { .. } => "blink pattern",
            RungShape::Lamp { .. } => "free-running blinker (LAMP)",
            RungShape::Opaque { .. } => "other",
        }
    }
}

/// One coil as an engine describes it, at `P`, where it is written (a place in a program
/// file).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rung<P> {
    /// The coil (the tag the rung writes).
    pub coil: TagId,
    /// What the rung does.
    pub shape: RungShape,
    /// Where it is written.
    pub pos: P,
    /// What the program calls the rung, when it names it (a ladder rung's `title:`, the first
    /// sentence of an expr statement's comment): reports name the rung by it.
    pub title: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(i: u32) -> BoolExpr {
        BoolExpr::Tag(TagId(i))
    }

    #[test]
    fn eval_and_tags() {
        let e = BoolExpr::Or(vec![
            BoolExpr::And(vec![t(0), BoolExpr::negate(t(1))]),
            BoolExpr::Xor(vec![t(2), t(0)]),
        ]);
        let v = [true, true, true];
        assert!(!e.eval(&mut |id| v[id.index()]));
        let v = [true, true, false];
        assert!(e.eval(&mut |id| v[id.index()]));
        assert_eq!(e.tags().len(), 3);
        assert!(e.reads(TagId(2)) && !e.reads(TagId(3)));
        assert!(BoolExpr::And(vec![]).eval(&mut |_| false));
        assert!(!BoolExpr::Or(vec![]).eval(&mut |_| true));
    }

    #[test]
    fn display_uses_names_and_precedence() {
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let e = BoolExpr::And(vec![
            BoolExpr::Or(vec![t(0), t(1)]),
            BoolExpr::negate(BoolExpr::And(vec![t(2), t(0)])),
        ]);
        assert_eq!(e.display(&names).to_string(), "(a | b) & !(c & a)");
        let e = BoolExpr::Or(vec![BoolExpr::And(vec![t(0), t(1)]), t(9)]);
        assert_eq!(e.display(&names).to_string(), "a & b | #9");
    }
}
