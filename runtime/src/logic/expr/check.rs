//! Checker: resolves names against the [`TagTable`], checks types, coils and durations, and
//! turns the parse tree into a typed tree over [`TagId`]s. Reports every error it finds.

use std::collections::HashMap;
use std::time::Duration;

use softplc_io::point::ValueType;

use super::error::{CompileErrorKind, DurationError, TypeError};
use super::parser::{DurLit, EdgeKind, Expr, Ident, NumLit, Pos, Stmt};
use super::{Operand, TagTable};
use crate::image::TagId;
use crate::logic::blocks::Kind;
use crate::logic::vm::CmpOp;
use crate::suggest::edit_distance;

/// Longest timer preset: `u32::MAX` milliseconds, the range of an IEC `TIME` on most PLCs.
pub(crate) const MAX_PRESET_MS: u64 = u32::MAX as u64;

/// A checked boolean expression.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum BoolExpr {
    Load(TagId),
    Const(bool),
    Not(Box<BoolExpr>),
    And(Vec<BoolExpr>),
    Xor(Vec<BoolExpr>),
    Or(Vec<BoolExpr>),
    Cmp {
        lhs: Operand,
        op: CmpOp,
        rhs: Operand,
    },
    Edge {
        kind: EdgeKind,
        arg: Box<BoolExpr>,
    },
    Timer {
        kind: Kind,
        arg: Box<BoolExpr>,
        preset: Duration,
    },
    /// `good(tag)`: the tag's quality is Good.
    Good(TagId),
    /// `bad(tag)`: the tag's quality is Bad.
    Bad(TagId),
}

/// A checked statement.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CheckedStmt {
    pub coil: TagId,
    pub pos: Pos,
    pub expr: BoolExpr,
}

/// Checks all statements; the typed statements when there is no error.
pub(crate) fn check(
    stmts: &[Stmt],
    tags: &TagTable,
    errors: &mut Vec<(Pos, CompileErrorKind)>,
) -> Vec<CheckedStmt> {
    let mut checker = Checker { tags, errors };
    let mut assigned: HashMap<TagId, u32> = HashMap::new();
    let mut out = Vec::with_capacity(stmts.len());
    for stmt in stmts {
        let coil = checker.coil(&stmt.coil, &mut assigned);
        let expr = checker.boolean(&stmt.expr);
        if let (Some(coil), Some(expr)) = (coil, expr) {
            out.push(CheckedStmt {
                coil,
                pos: stmt.coil.pos,
                expr,
            });
        }
    }
    out
}

struct Checker<'a> {
    tags: &'a TagTable,
    errors: &'a mut Vec<(Pos, CompileErrorKind)>,
}

impl Checker<'_> {
    fn fail<T>(&mut self, pos: Pos, kind: impl Into<CompileErrorKind>) -> Option<T> {
        self.errors.push((pos, kind.into()));
        None
    }

    /// The coil of a statement: a known, writable bool tag assigned once.
    fn coil(&mut self, coil: &Ident, assigned: &mut HashMap<TagId, u32>) -> Option<TagId> {
        let entry = self.tag(coil)?;
        let name = || coil.name.clone();
        if !entry.writable {
            return self.fail(coil.pos, CompileErrorKind::WriteToInput { name: name() });
        }
        if entry.ty != ValueType::Bool {
            return self.fail(
                coil.pos,
                TypeError::AssignNumber {
                    name: name(),
                    ty: entry.ty,
                },
            );
        }
        if let Some(&first_line) = assigned.get(&entry.id) {
            return self.fail(
                coil.pos,
                CompileErrorKind::DuplicateCoil {
                    name: name(),
                    first_line,
                },
            );
        }
        assigned.insert(entry.id, coil.pos.line);
        Some(entry.id)
    }

    /// A known tag, or an unknown-tag error with a suggestion.
    fn tag(&mut self, ident: &Ident) -> Option<super::TagEntry> {
        if let Some(entry) = self.tags.get(&ident.name) {
            return Some(entry.clone());
        }
        let uses = self.errors.iter_mut().filter_map(|(pos, k)| match k {
            CompileErrorKind::UnknownTag { name, also, .. } => {
                Some((name.as_str(), pos.line, also))
            }
            _ => None,
        });
        if crate::logic::undeclared::seen_before(uses, &ident.name, ident.pos.line) {
            return None;
        }
        let suggestion = closest(&ident.name, self.tags.iter().map(|t| t.name.as_str()));
        let name = ident.name.clone();
        self.fail(
            ident.pos,
            CompileErrorKind::UnknownTag {
                name,
                suggestion,
                also: Vec::new(),
            },
        )
    }

    /// An expression in a boolean place. Checks every part, even after an error.
    fn boolean(&mut self, expr: &Expr) -> Option<BoolExpr> {
        match expr {
            Expr::Tag(ident) => {
                let entry = self.tag(ident)?;
                if entry.ty == ValueType::Bool {
                    Some(BoolExpr::Load(entry.id))
                } else {
                    let name = ident.name.clone();
                    self.fail(ident.pos, TypeError::NumberAsBool { name, ty: entry.ty })
                }
            }
            Expr::Number(NumLit { text, pos, .. }) => match text.as_str() {
                "0" => Some(BoolExpr::Const(false)),
                "1" => Some(BoolExpr::Const(true)),
                _ => self.fail(*pos, TypeError::LiteralAsBool { text: text.clone() }),
            },
            Expr::Bool(b) => Some(BoolExpr::Const(*b)),
            Expr::Not(inner) => Some(BoolExpr::Not(Box::new(self.boolean(inner)?))),
            Expr::And(items) => self.all(items).map(BoolExpr::And),
            Expr::Xor(items) => self.all(items).map(BoolExpr::Xor),
            Expr::Or(items) => self.all(items).map(BoolExpr::Or),
            Expr::Cmp {
                lhs,
                lhs_pos,
                op,
                rhs,
                rhs_pos,
            } => {
                let l = self.operand(lhs, *lhs_pos);
                let r = self.operand(rhs, *rhs_pos);
                let (l, r) = (l?, r?);
                for (lit, tag) in [(rhs, lhs), (lhs, rhs)] {
                    if let (Expr::Number(n), Expr::Tag(t)) = (lit.as_ref(), tag.as_ref()) {
                        self.literal_of(n, t)?;
                    }
                }
                let (lhs, rhs) = match (l, r) {
                    (Side::Lit(_), Side::Lit(_)) => {
                        return self.fail(*lhs_pos, TypeError::ConstantComparison)
                    }
                    (Side::Tag(a, _), Side::Tag(b, _)) => (Operand::Tag(a), Operand::Tag(b)),
                    (Side::Tag(a, ty), Side::Lit(v)) => (Operand::Tag(a), literal_for(v, ty)),
                    (Side::Lit(v), Side::Tag(b, ty)) => (literal_for(v, ty), Operand::Tag(b)),
                };
                Some(BoolExpr::Cmp { lhs, op: *op, rhs })
            }
            Expr::Edge { kind, arg } => Some(BoolExpr::Edge {
                kind: *kind,
                arg: Box::new(self.boolean(arg)?),
            }),
            Expr::Timer { kind, arg, preset } => {
                let arg = self.boolean(arg);
                let preset = match duration(preset) {
                    Ok(d) => Some(d),
                    Err(e) => self.fail(preset.pos, e),
                };
                Some(BoolExpr::Timer {
                    kind: *kind,
                    arg: Box::new(arg?),
                    preset: preset?,
                })
            }
            // Any tag has a quality, whatever its type.
            Expr::Quality { good, tag } => {
                let id = self.tag(tag)?.id;
                Some(if *good {
                    BoolExpr::Good(id)
                } else {
                    BoolExpr::Bad(id)
                })
            }
        }
    }

    /// A number compared with tag `tag`: one the tag's type can hold.
    fn literal_of(&mut self, lit: &NumLit, tag: &Ident) -> Option<()> {
        let ty = self.tags.get(&tag.name)?.ty;
        if literal_fits(lit.value, ty) {
            return Some(());
        }
        let kind = TypeError::LiteralOutOfType {
            text: lit.text.clone(),
            name: tag.name.clone(),
            ty,
        };
        self.fail(lit.pos, kind)
    }

    fn all(&mut self, items: &[Expr]) -> Option<Vec<BoolExpr>> {
        let checked: Vec<Option<BoolExpr>> = items.iter().map(|e| self.boolean(e)).collect();
        checked.into_iter().collect()
    }

    /// One side of a comparison: a numeric tag or a number.
    fn operand(&mut self, expr: &Expr, pos: Pos) -> Option<Side> {
        match expr {
            Expr::Tag(ident) => {
                let entry = self.tag(ident)?;
                if entry.ty == ValueType::Bool {
                    let name = ident.name.clone();
                    self.fail(ident.pos, TypeError::BoolInComparison { name })
                } else {
                    Some(Side::Tag(entry.id, entry.ty))
                }
            }
            Expr::Number(lit) => Some(Side::Lit(lit.value)),
            _ => self.fail(pos, TypeError::ComparisonOperand),
        }
    }
}

/// A checked comparison side.
enum Side {
    Tag(TagId, ValueType),
    Lit(f64),
}

/// A literal compared with a tag of type `ty`: rounded to `f32` for an `f32` tag, so that
/// `temp == 0.1` holds when `temp` holds `0.1f32`.
fn literal_for(v: f64, ty: ValueType) -> Operand {
    match ty {
        ValueType::F32 => Operand::Const(f64::from(v as f32)),
        _ => Operand::Const(v),
    }
}

/// Whether a tag of type `ty` can hold the number `v` (the image's type lattice: integers are
/// whole and in their range, an `f32` finite and within its range; a bool holds no number).
/// The expr and ladder checkers hold literals against it, so `count == 0.5` or
/// `MOVE(70000) => level` (u16) is refused before the first scan.
pub(crate) fn literal_fits(v: f64, ty: ValueType) -> bool {
    let whole = v.fract() == 0.0;
    match ty {
        ValueType::Bool => false,
        ValueType::U16 => whole && (0.0..=f64::from(u16::MAX)).contains(&v),
        ValueType::I32 => whole && (f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&v),
        ValueType::F32 => v.is_finite() && v.abs() <= f64::from(f32::MAX),
    }
}

/// What values of type `ty` are, in words, for a literal that does not fit.
pub(crate) fn type_words(ty: ValueType) -> &'static str {
    match ty {
        ValueType::Bool => "a bool (true, false, 0 or 1)",
        ValueType::U16 => "a u16 value (a whole number from 0 to 65535)",
        ValueType::I32 => "an i32 value (a whole number from -2147483648 to 2147483647)",
        ValueType::F32 => "an f32 value (a number within ±3.4e38)",
    }
}

/// The duration a literal denotes: `us`, `ms` or `s`, fractions allowed, rounded to the
/// nanosecond (at least 1 ns), at most [`MAX_PRESET_MS`].
pub(crate) fn duration(lit: &DurLit) -> Result<Duration, DurationError> {
    let Some(unit) = lit.unit.as_deref() else {
        return Err(DurationError::MissingUnit {
            text: lit.num.clone(),
        });
    };
    let nanos_per_unit = match unit {
        "us" => 1e3,
        "ms" => 1e6,
        "s" => 1e9,
        _ => {
            return Err(DurationError::UnknownUnit {
                unit: unit.to_string(),
            })
        }
    };
    let value: f64 = lit.num.parse().unwrap_or(f64::INFINITY);
    if value == 0.0 {
        return Err(DurationError::Zero);
    }
    let nanos = (value * nanos_per_unit).round().max(1.0);
    if nanos > (MAX_PRESET_MS * 1_000_000) as f64 {
        return Err(DurationError::TooLong {
            max_ms: MAX_PRESET_MS,
        });
    }
    Ok(Duration::from_nanos(nanos as u64))
}

/// The candidate closest to `name` by edit distance, if within 2 edits and fewer edits than
/// `name` has characters (so `x` does not suggest `y`). Ties go to the first candidate.
pub(crate) fn closest<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> Option<String> {
    let len = name.chars().count();
    let mut best: Option<(usize, &str)> = None;
    for cand in candidates {
        // Two edits cannot bridge a longer difference in length: skip the distance.
        if cand.chars().count().abs_diff(len) > 2 {
            continue;
        }
        let d = edit_distance(name, cand);
        if d <= 2 && d < len && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, cand));
        }
    }
    best.map(|(_, c)| c.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dur(num: &str, unit: Option<&str>) -> Result<Duration, DurationError> {
        duration(&DurLit {
            num: num.into(),
            unit: unit.map(Into::into),
            pos: Pos { line: 1, col: 1 },
        })
    }

    #[test]
    fn durations() {
        assert_eq!(dur("250", Some("ms")), Ok(Duration::from_millis(250)));
        assert_eq!(dur("2", Some("s")), Ok(Duration::from_secs(2)));
        assert_eq!(dur("1.5", Some("s")), Ok(Duration::from_millis(1500)));
        assert_eq!(dur("0.1", Some("s")), Ok(Duration::from_millis(100)));
        assert_eq!(dur("100", Some("us")), Ok(Duration::from_micros(100)));
        assert_eq!(dur("0.0001", Some("us")), Ok(Duration::from_nanos(1)));
        assert_eq!(
            dur("2", None),
            Err(DurationError::MissingUnit { text: "2".into() })
        );
        assert_eq!(
            dur("2", Some("h")),
            Err(DurationError::UnknownUnit { unit: "h".into() })
        );
        assert_eq!(dur("0", Some("ms")), Err(DurationError::Zero));
        assert_eq!(dur("0.000", Some("s")), Err(DurationError::Zero));
        assert_eq!(
            dur("4294967295", Some("ms")),
            Ok(Duration::from_millis(MAX_PRESET_MS))
        );
        assert_eq!(
            dur("4294967.296", Some("s")),
            Err(DurationError::TooLong {
                max_ms: MAX_PRESET_MS
            })
        );
        let huge = "9".repeat(400);
        assert_eq!(
            dur(&huge, Some("s")),
            Err(DurationError::TooLong {
                max_ms: MAX_PRESET_MS
            })
        );
    }

    #[test]
    fn suggestions() {
        let tags = ["motor", "start", "stop", "box_at_exit", "lamp"];
        let near = |n: &str| closest(n, tags.iter().copied());
        assert_eq!(near("strt"), Some("start".into()));
        assert_eq!(near("stpo"), Some("stop".into()));
        assert_eq!(near("box_at_exti"), Some("box_at_exit".into()));
        assert_eq!(near("Motor"), Some("motor".into()));
        assert_eq!(near("conveyor"), None);
        assert_eq!(near("x"), None);
    }
}
