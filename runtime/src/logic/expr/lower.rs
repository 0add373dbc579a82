//! Lowering: checked statements → the VM's flat program ([`Instr`]s over [`TagId`]s, see
//! [`crate::logic::vm`]), with an edge slot and a timer instance per call site and the stack
//! depth the program needs.

use super::check::{BoolExpr, CheckedStmt};
use super::parser::{EdgeKind, Pos};
use super::{Instr, Operand};
use crate::image::TagId;
use crate::logic::blocks::Instance;
use crate::logic::vm;

/// A lowered program.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Lowered {
    /// The instructions, statements in file order, each ending with a [`Instr::Store`].
    pub code: Vec<Instr>,
    /// The coils, in file order.
    pub coils: Vec<TagId>,
    /// Number of edge call sites.
    pub edges: usize,
    /// Number of timer call sites.
    pub timers: usize,
    /// A fresh timer instance per call site, indexed by the timer instructions.
    pub instances: Vec<Instance>,
    /// Deepest stack the code reaches.
    pub max_depth: usize,
    /// The highest tag used and the statement that first uses it.
    pub highest_tag: Option<(TagId, Pos)>,
}

/// Lowers checked statements.
pub(crate) fn lower(stmts: &[CheckedStmt]) -> Lowered {
    let mut l = Lowerer {
        out: Lowered {
            code: Vec::new(),
            coils: Vec::with_capacity(stmts.len()),
            edges: 0,
            timers: 0,
            instances: Vec::new(),
            max_depth: 0,
            highest_tag: None,
        },
        stmt_pos: Pos { line: 1, col: 1 },
    };
    for stmt in stmts {
        l.stmt_pos = stmt.pos;
        l.expr(&stmt.expr);
        l.use_tag(stmt.coil);
        l.out.code.push(Instr::Store(stmt.coil));
        l.out.coils.push(stmt.coil);
    }
    l.out.max_depth = max_depth(&l.out.code).unwrap_or(0);
    l.out
}

struct Lowerer {
    out: Lowered,
    stmt_pos: Pos,
}

impl Lowerer {
    fn use_tag(&mut self, id: TagId) {
        if self.out.highest_tag.is_none_or(|(h, _)| id > h) {
            self.out.highest_tag = Some((id, self.stmt_pos));
        }
    }

    fn use_operand(&mut self, op: Operand) {
        if let Operand::Tag(id) = op {
            self.use_tag(id);
        }
    }

    fn expr(&mut self, e: &BoolExpr) {
        match e {
            BoolExpr::Load(id) => {
                self.use_tag(*id);
                self.out.code.push(Instr::Load(*id));
            }
            BoolExpr::Const(b) => self.out.code.push(Instr::Const(*b)),
            BoolExpr::Good(id) => {
                self.use_tag(*id);
                self.out.code.push(Instr::Good(*id));
            }
            BoolExpr::Bad(id) => {
                self.use_tag(*id);
                self.out.code.push(Instr::Bad(*id));
            }
            BoolExpr::Not(inner) => {
                self.expr(inner);
                self.out.code.push(Instr::Not);
            }
            BoolExpr::And(items) => self.chain(items, Instr::And),
            BoolExpr::Xor(items) => self.chain(items, Instr::Xor),
            BoolExpr::Or(items) => self.chain(items, Instr::Or),
            BoolExpr::Cmp { lhs, op, rhs } => {
                self.use_operand(*lhs);
                self.use_operand(*rhs);
                self.out.code.push(Instr::Cmp {
                    lhs: *lhs,
                    op: *op,
                    rhs: *rhs,
                });
            }
            BoolExpr::Edge { kind, arg } => {
                self.expr(arg);
                let slot = self.out.edges as u32;
                self.out.edges += 1;
                self.out.code.push(match kind {
                    EdgeKind::Rising => Instr::Rising(slot),
                    EdgeKind::Falling => Instr::Falling(slot),
                });
            }
            BoolExpr::Timer { kind, arg, preset } => {
                self.expr(arg);
                let timer = self.out.timers as u32;
                self.out.timers += 1;
                let preset = *preset;
                self.out.code.push(Instr::Timer { timer, preset });
                self.out.instances.push(Instance::new(*kind));
            }
        }
    }

    /// `a op b op c` as `a b op c op`: left to right, every operand evaluated.
    fn chain(&mut self, items: &[BoolExpr], op: Instr) {
        for (i, item) in items.iter().enumerate() {
            self.expr(item);
            if i > 0 {
                self.out.code.push(op);
            }
        }
    }
}

/// The deepest stack `code` reaches (`expr` calls no blocks); see [`vm::max_depth`].
pub(crate) fn max_depth(code: &[Instr]) -> Option<usize> {
    vm::max_depth(code, &[], &[])
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::logic::blocks::Kind;
    use crate::logic::expr::CmpOp;

    #[test]
    fn lowers_to_postfix_with_slots() {
        let (a, b, c, q) = (TagId(0), TagId(1), TagId(2), TagId(3));
        let stmts = [CheckedStmt {
            coil: q,
            pos: Pos { line: 1, col: 1 },
            expr: BoolExpr::Or(vec![
                BoolExpr::And(vec![
                    BoolExpr::Load(a),
                    BoolExpr::Not(Box::new(BoolExpr::Load(b))),
                ]),
                BoolExpr::Edge {
                    kind: EdgeKind::Rising,
                    arg: Box::new(BoolExpr::Load(c)),
                },
                BoolExpr::Timer {
                    kind: Kind::Ton,
                    arg: Box::new(BoolExpr::Cmp {
                        lhs: Operand::Tag(TagId(7)),
                        op: CmpOp::Gt,
                        rhs: Operand::Const(5.0),
                    }),
                    preset: Duration::from_secs(2),
                },
            ]),
        }];
        let l = lower(&stmts);
        assert_eq!(
            l.code,
            vec![
                Instr::Load(a),
                Instr::Load(b),
                Instr::Not,
                Instr::And,
                Instr::Load(c),
                Instr::Rising(0),
                Instr::Or,
                Instr::Cmp {
                    lhs: Operand::Tag(TagId(7)),
                    op: CmpOp::Gt,
                    rhs: Operand::Const(5.0)
                },
                Instr::Timer {
                    timer: 0,
                    preset: Duration::from_secs(2)
                },
                Instr::Or,
                Instr::Store(q),
            ]
        );
        assert_eq!((l.edges, l.timers, l.max_depth), (1, 1, 2));
        assert_eq!(l.coils, vec![q]);
        assert_eq!(l.highest_tag, Some((TagId(7), Pos { line: 1, col: 1 })));
    }

    #[test]
    fn depth_check_rejects_unbalanced_code() {
        assert_eq!(max_depth(&[Instr::And]), None);
        assert_eq!(max_depth(&[Instr::Const(true)]), None);
        assert_eq!(
            max_depth(&[Instr::Const(true), Instr::Store(TagId(0))]),
            Some(1)
        );
    }
}
