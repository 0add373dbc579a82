//! The push-down view of a ladder program: each bool tag it drives as a [`Rung`] of the offload
//! IR (`c` is the tag, `E`, `S`, `R` conditions of contacts without edges, comparisons, block
//! outputs or quality tests):
//!
//! - `E -> c` → combinational (`E -> /c`: its negation); when `E` reads `c`, a latch if the
//!   rung never inverts `c` ([`RungShape::self_latch`]);
//! - `S -> set c` and `R -> reset c` (any number of rungs) → a latch, reset dominant when every
//!   `set` rung comes before every `reset` rung (the last write of a scan wins), set dominant
//!   when after; with `rising(a)` conditions only → edge set / edge reset (reset winning);
//! - `S -> SR l(r=R) -> c` / `RS` → a latch, set / reset dominant;
//! - `E -> TP p(T) -> c` → pulse; `E -> STAIR s(T) -> c` (no reset) → staircase pulse;
//!   `E -> TOGGLE t -> c` (no reset) → impulse relay; `E -> BLINK b(on, off) -> c` → blinker,
//!   `E -> BLINK b(pattern=P, step=T) -> c` → blink pattern; `E -> LAMP l(M) -> c` → the
//!   module's free-running blinker;
//! - anything else → opaque, with the reason.
//!
//! Presets must be constants; a block whose output drives several coils, or a coil through a
//! negated, set or reset coil of a block, stays opaque.

use std::collections::BTreeMap;
use std::time::Duration;

use super::check::{BoolExpr as Cond, CAction, COut, CRung};
use super::parser::CoilKind;
use crate::image::TagId;
use crate::logic::blocks::from_millis;
use crate::logic::blocks::Kind;
use crate::logic::vm::{Call, Num, PinArg};
use crate::logic::Rung;
use crate::logic::SourcePos;
use softplc_io::rung::{BoolExpr, RungShape};

/// How one rung drives a tag.
enum Drive {
    /// A whole shape (a coil or a block's output).
    Shape(RungShape),
    /// One `set` (true) or `reset` (false) coil with its condition.
    Latch(bool, Cond),
}

/// The rungs of checked ladder rungs; `rung_site(i)` is where rung `i` of the file starts and
/// its title. A tag several rungs drive (set and reset) is named after the first of them.
pub(crate) fn describe(
    rungs: &[CRung],
    own: &[Result<RungShape, String>],
    rung_site: impl Fn(usize) -> (SourcePos, Option<String>),
) -> Vec<Rung> {
    // Tag → (first rung index, drives in rung order).
    let mut by_tag: BTreeMap<TagId, (usize, Vec<Drive>)> = BTreeMap::new();
    let mut order: Vec<TagId> = Vec::new();
    let mut add = |tag: TagId, rung: usize, d: Drive| {
        let entry = by_tag.entry(tag).or_insert_with(|| {
            order.push(tag);
            (rung, Vec::new())
        });
        entry.1.push(d);
    };
    for r in rungs {
        match &r.action {
            CAction::Outputs(outs) => {
                for out in outs {
                    let COut::Coil(kind, tag) = out else {
                        continue;
                    };
                    let d = match kind {
                        CoilKind::Normal => Drive::Shape(coil(*tag, &r.cond, false)),
                        CoilKind::Negated => Drive::Shape(coil(*tag, &r.cond, true)),
                        CoilKind::Set => Drive::Latch(true, r.cond.clone()),
                        CoilKind::Reset => Drive::Latch(false, r.cond.clone()),
                    };
                    add(*tag, r.index, d);
                }
            }
            CAction::Block {
                call, bools, coils, ..
            } => {
                for (kind, tag) in coils {
                    let shape = if *kind == CoilKind::Normal && coils.len() == 1 {
                        block(call, &r.cond, bools)
                    } else {
                        opaque("a block's output drives this coil through several or negated coils")
                    };
                    add(*tag, r.index, Drive::Shape(shape));
                }
            }
            CAction::Own {
                inst,
                pins,
                bools,
                coils,
            } => {
                for (kind, tag) in coils {
                    let shape = match (kind, coils.len(), own.get(*inst as usize)) {
                        (CoilKind::Normal, 1, Some(Ok(body))) => {
                            own_call(*tag, body, &r.cond, pins, bools)
                        }
                        (_, _, Some(Err(why))) => {
                            opaque(&format!("a block of your own drives this coil, and {why}"))
                        }
                        _ => opaque(
                            "a block of your own drives this coil through several or negated coils",
                        ),
                    };
                    add(*tag, r.index, Drive::Shape(shape));
                }
            }
        }
    }
    order
        .into_iter()
        .filter_map(|tag| {
            let (first, drives) = by_tag.remove(&tag)?;
            let shape = match drives.as_slice() {
                [Drive::Shape(s)] => s.clone(),
                _ if drives.iter().all(|d| matches!(d, Drive::Latch(..))) => latch(&drives),
                // Several coils on one tag: the checker allows only set/reset to share it.
                _ => opaque("the tag is driven by several rungs"),
            };
            let (pos, title) = rung_site(first);
            Some(Rung {
                coil: tag,
                shape,
                pos,
                title,
            })
        })
        .collect()
}

fn opaque(reason: &str) -> RungShape {
    RungShape::Opaque {
        reason: reason.to_owned(),
    }
}

/// The condition as IR when it has only contacts of tags and constants.
fn pure(c: &Cond) -> Option<BoolExpr> {
    Some(match c {
        Cond::Load(id) => BoolExpr::Tag(*id),
        Cond::Const(b) => BoolExpr::Const(*b),
        Cond::Not(inner) => BoolExpr::negate(pure(inner)?),
        Cond::And(items) => BoolExpr::And(items.iter().map(pure).collect::<Option<_>>()?),
        Cond::Or(items) => BoolExpr::Or(items.iter().map(pure).collect::<Option<_>>()?),
        Cond::Out(..) | Cond::Edge { .. } | Cond::Cmp { .. } | Cond::Good(_) | Cond::Bad(_) => {
            return None
        }
    })
}

/// Why a condition is not pure.
fn impure_reason(c: &Cond) -> &'static str {
    fn walk(c: &Cond, found: &mut [bool; 4]) {
        match c {
            Cond::Load(_) | Cond::Const(_) => {}
            Cond::Not(inner) => walk(inner, found),
            Cond::And(items) | Cond::Or(items) => items.iter().for_each(|i| walk(i, found)),
            Cond::Out(..) => found[0] = true,
            Cond::Edge { arg, .. } => {
                found[1] = true;
                walk(arg, found);
            }
            Cond::Cmp { .. } => found[2] = true,
            Cond::Good(_) | Cond::Bad(_) => found[3] = true,
        }
    }
    let mut found = [false; 4];
    walk(c, &mut found);
    match found {
        [true, ..] => "memory or a timer in the condition (a block's output)",
        [_, true, ..] => "memory or a timer in the condition (an edge the module cannot see there)",
        [_, _, true, _] => "a comparison of numbers in the condition",
        _ => "a quality test (good/bad) in the condition",
    }
}

/// `E -> c` or `E -> /c`.
fn coil(tag: TagId, cond: &Cond, negated: bool) -> RungShape {
    let Some(e) = pure(cond) else {
        return opaque(impure_reason(cond));
    };
    let e = if negated { BoolExpr::negate(e) } else { e };
    if e.reads(tag) {
        RungShape::self_latch(tag, &e)
    } else {
        RungShape::Combinational { expr: e }
    }
}

/// `cond -> BLOCK inst(bools...) -> coil` for a block of your own whose body's main output is
/// `body` (over the block's variables): the same shape over the caller's tags, each input
/// replaced by the condition the call gives it and the main output by the coil.
fn own_call(
    coil: TagId,
    body: &RungShape,
    cond: &Cond,
    pins: &[crate::logic::vm::OwnPin],
    bools: &[Cond],
) -> RungShape {
    use crate::logic::vm::OwnPin;
    // The condition each bool input is given, by input index (the power flow first).
    let mut given = std::iter::once(cond).chain(bools);
    let inputs: Vec<Option<&Cond>> = pins
        .iter()
        .map(|p| match p {
            OwnPin::Stack => given.next(),
            OwnPin::Num(_) | OwnPin::Default(_) => None,
        })
        .collect();
    let main = TagId(pins.len() as u32);
    if let Some(impure) = inputs.iter().flatten().find(|c| pure(c).is_none()) {
        return opaque(&format!(
            "a block of your own's input: {}",
            impure_reason(impure)
        ));
    }
    let by = |t: TagId| -> Option<BoolExpr> {
        if t == main {
            return Some(BoolExpr::Tag(coil));
        }
        inputs.get(t.index()).copied().flatten().and_then(pure)
    };
    let sub = |e: &BoolExpr| crate::logic::user_blocks::substitute(e, &by);
    let shape = match body {
        RungShape::Combinational { expr } => sub(expr).map(|e| {
            if e.reads(coil) {
                RungShape::self_latch(coil, &e)
            } else {
                RungShape::Combinational { expr: e }
            }
        }),
        RungShape::Latch {
            set,
            reset,
            reset_dominant,
        } => sub(set)
            .zip(sub(reset))
            .map(|(set, reset)| RungShape::Latch {
                set,
                reset,
                reset_dominant: *reset_dominant,
            }),
        _ => None,
    };
    shape.unwrap_or_else(|| opaque("a block of your own whose main output reads a value input"))
}

/// `rising(E)` with `E` pure.
fn rising(cond: &Cond) -> Option<BoolExpr> {
    match cond {
        Cond::Edge { rising: true, arg } => pure(arg),
        _ => None,
    }
}

/// Set and reset coils of one tag, in rung order.
fn latch(drives: &[Drive]) -> RungShape {
    let parts: Vec<(bool, &Cond)> = drives
        .iter()
        .filter_map(|d| match d {
            Drive::Latch(set, c) => Some((*set, c)),
            Drive::Shape(_) => None,
        })
        .collect();
    let last_set = parts.iter().rposition(|(s, _)| *s);
    let first_reset = parts.iter().position(|(s, _)| !*s);
    let last_reset = parts.iter().rposition(|(s, _)| !*s);
    let first_set = parts.iter().position(|(s, _)| *s);
    let reset_dominant = match (first_set, last_set, first_reset, last_reset) {
        (Some(_), Some(ls), Some(fr), Some(_)) if ls < fr => true,
        (Some(fs), Some(_), Some(_), Some(lr)) if lr < fs => false,
        (Some(_), _, None, _) | (None, _, Some(_), _) => true,
        _ => return opaque("set and reset coils interleave: which wins depends on the inputs"),
    };
    let group = |set: bool| {
        parts
            .iter()
            .filter(move |(s, _)| *s == set)
            .map(|(_, c)| *c)
    };
    // All edges, reset winning: the RESI-16DI8RO's SWITCH ON / SWITCH OFF.
    let edges = |set: bool| group(set).map(rising).collect::<Option<Vec<_>>>();
    if let (Some(set), Some(reset)) = (edges(true), edges(false)) {
        if reset_dominant && !set.is_empty() && !reset.is_empty() {
            return RungShape::EdgeSetReset { set, reset };
        }
    }
    let levels = |set: bool| -> Result<BoolExpr, &'static str> {
        let v = group(set)
            .map(|c| pure(c).ok_or_else(|| impure_reason(c)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(if v.len() == 1 {
            v.into_iter().next().unwrap_or(BoolExpr::Const(false))
        } else {
            BoolExpr::Or(v)
        })
    };
    match (levels(true), levels(false)) {
        (Ok(set), Ok(reset)) => RungShape::Latch {
            set,
            reset,
            reset_dominant,
        },
        (Err(why), _) | (_, Err(why)) => opaque(why),
    }
}

/// A constant preset.
fn preset(n: &Num) -> Option<Duration> {
    match n {
        Num::Const(ms) => Some(from_millis(*ms)),
        Num::Tag(_) | Num::Out(..) => None,
    }
}

/// A constant 16-bit mask.
fn mask(n: &Num) -> Option<u16> {
    match n {
        Num::Const(v) if v.fract() == 0.0 && (0.0..=f64::from(u16::MAX)).contains(v) => {
            Some(*v as u16)
        }
        _ => None,
    }
}

/// Whether a block's optional bool argument is absent (constant false).
fn absent(bools: &[Cond], i: usize) -> bool {
    matches!(bools.get(i), None | Some(Cond::Const(false)))
}

/// `E -> BLOCK -> c`.
fn block(call: &Call, cond: &Cond, bools: &[Cond]) -> RungShape {
    let variable = "a preset read from a tag or a block: the module's time is fixed at start-up";
    let trigger = || pure(cond).ok_or_else(|| impure_reason(cond));
    let pt = call.num("PT");
    let shape = match call.kind {
        Kind::Tp => {
            let Some(width) = pt.as_ref().and_then(preset) else {
                return opaque(variable);
            };
            trigger().map(|t| RungShape::Pulse {
                trigger: vec![t],
                width,
            })
        }
        Kind::Stair if absent(bools, 0) => {
            let Some(time) = pt.as_ref().and_then(preset) else {
                return opaque(variable);
            };
            trigger().map(|t| RungShape::StairPulse {
                trigger: vec![t],
                time,
            })
        }
        Kind::Toggle if absent(bools, 0) => {
            trigger().map(|t| RungShape::Toggle { trigger: vec![t] })
        }
        Kind::Sr | Kind::Rs => {
            let reset = bools
                .first()
                .map(|r| pure(r).ok_or_else(|| impure_reason(r)))
                .unwrap_or(Ok(BoolExpr::Const(false)));
            match (trigger(), reset) {
                (Ok(set), Ok(reset)) => Ok(RungShape::Latch {
                    set,
                    reset,
                    reset_dominant: call.kind == Kind::Rs,
                }),
                (Err(why), _) | (_, Err(why)) => Err(why),
            }
        }
        Kind::Blink if call.pin("PATTERN") != PinArg::Absent => {
            let (PinArg::Pattern(pattern), Some(step)) = (
                call.pin("PATTERN"),
                call.num("STEP").as_ref().and_then(preset),
            ) else {
                return opaque(variable);
            };
            let bits = (0..pattern.len()).map(|i| pattern.bit(i)).collect();
            trigger().map(|enable| RungShape::BlinkPattern {
                enable,
                pattern: bits,
                step,
            })
        }
        Kind::Lamp => {
            let Some(mask) = call.num("MASK").as_ref().and_then(mask) else {
                return opaque(
                    "a mask read from a tag or a block, or outside 0..=65535: the module's \
                     blinker mask is a 16-bit constant",
                );
            };
            trigger().map(|enable| RungShape::Lamp { enable, mask })
        }
        Kind::Blink => match (call.num("ON"), call.num("OFF")) {
            (Some(on), Some(off)) => match (preset(&on), preset(&off)) {
                (Some(on), Some(off)) => {
                    trigger().map(|enable| RungShape::Blink { enable, on, off })
                }
                _ => return opaque(variable),
            },
            _ => return opaque(variable),
        },
        Kind::Stair | Kind::Toggle => {
            return opaque("a reset input on the block (the module's function has none)")
        }
        Kind::Ton | Kind::Tof => {
            return opaque("memory or a timer in the condition (a timer the module cannot run)")
        }
        Kind::Ctu | Kind::Ctd | Kind::Ctud => {
            return opaque("a counter (the module's XCOUNT is read as a tag, see offload docs)")
        }
        Kind::RTrig | Kind::FTrig => {
            return opaque(
                "memory or a timer in the condition (an edge the module cannot see there)",
            )
        }
    };
    shape.unwrap_or_else(opaque)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use softplc_io::point::ValueType;

    use super::*;
    use crate::logic::expr::TagTable;
    use crate::logic::{ladder, LogicEngine};

    fn shapes(rungs: &[&str]) -> Vec<(TagId, RungShape)> {
        let names = ["a", "b", "c", "y", "z"];
        let tags = TagTable::new(
            names
                .iter()
                .enumerate()
                .map(|(i, n)| (n.to_string(), TagId(i as u32), ValueType::Bool, true)),
        );
        let mut text = String::from("rungs:\n");
        for r in rungs {
            text.push_str(&format!("  - \"{r}\"\n"));
        }
        let p =
            ladder::compile(&text, Path::new("t.yaml"), &tags).unwrap_or_else(|e| panic!("{e:?}"));
        p.rungs()
            .unwrap()
            .into_iter()
            .map(|r| (r.coil, r.shape))
            .collect()
    }

    fn t(i: u32) -> BoolExpr {
        BoolExpr::Tag(TagId(i))
    }

    const Y: TagId = TagId(3);

    #[test]
    fn coils_and_latches() {
        assert_eq!(
            shapes(&["a /b -> y"]),
            vec![(
                Y,
                RungShape::Combinational {
                    expr: BoolExpr::And(vec![t(0), BoolExpr::negate(t(1))])
                }
            )]
        );
        assert!(matches!(
            shapes(&["(a | y) /b -> y"])[0].1,
            RungShape::Latch { .. }
        ));
        assert_eq!(
            shapes(&["a -> set y", "b -> reset y"])[0].1,
            RungShape::Latch {
                set: t(0),
                reset: t(1),
                reset_dominant: true
            }
        );
        assert!(matches!(
            shapes(&["b -> reset y", "a -> set y"])[0].1,
            RungShape::Latch {
                reset_dominant: false,
                ..
            }
        ));
        assert_eq!(
            shapes(&["rising(a) -> set y", "rising(b) -> reset y"])[0].1,
            RungShape::EdgeSetReset {
                set: vec![t(0)],
                reset: vec![t(1)]
            }
        );
        assert_eq!(
            shapes(&["a -> SR l(r=b) -> y"])[0].1,
            RungShape::Latch {
                set: t(0),
                reset: t(1),
                reset_dominant: false
            }
        );
    }

    #[test]
    fn blocks() {
        assert_eq!(
            shapes(&["a b -> TP p(50ms) -> y"])[0].1,
            RungShape::Pulse {
                trigger: vec![BoolExpr::And(vec![t(0), t(1)])],
                width: Duration::from_millis(50)
            }
        );
        assert_eq!(
            shapes(&["a -> STAIR s(30s) -> y"])[0].1,
            RungShape::StairPulse {
                trigger: vec![t(0)],
                time: Duration::from_secs(30)
            }
        );
        assert_eq!(
            shapes(&["a -> TOGGLE t -> y"])[0].1,
            RungShape::Toggle {
                trigger: vec![t(0)]
            }
        );
        assert_eq!(
            shapes(&["a -> BLINK bl(400ms, 400ms) -> y"])[0].1,
            RungShape::Blink {
                enable: t(0),
                on: Duration::from_millis(400),
                off: Duration::from_millis(400)
            }
        );
        assert_eq!(
            shapes(&["a -> BLINK bl(pattern=1101, step=200ms) -> y"])[0].1,
            RungShape::BlinkPattern {
                enable: t(0),
                pattern: vec![true, true, false, true],
                step: Duration::from_millis(200)
            }
        );
        assert_eq!(
            shapes(&["a /b -> LAMP l(3855) -> y"])[0].1,
            RungShape::Lamp {
                enable: BoolExpr::And(vec![t(0), BoolExpr::negate(t(1))]),
                mask: 0x0F0F
            }
        );
        assert!(matches!(
            &shapes(&["a -> STAIR s(30s, r=b) -> y"])[0].1,
            RungShape::Opaque { reason } if reason.contains("reset input")
        ));
        assert!(matches!(
            &shapes(&["a -> TON t(1s) -> y"])[0].1,
            RungShape::Opaque { reason } if reason.contains("timer")
        ));
    }
}
