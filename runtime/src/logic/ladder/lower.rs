//! Lowering: checked rungs → one flat stack-machine program over [`TagId`]s, instance indexes
//! and edge slots, with the stack depth it needs.

use super::check::{BoolExpr, CAction, COut, CRung, Call, Num};
use super::exec::{CallSite, Instr};
use super::parser::CoilKind;
use crate::image::TagId;

/// A lowered program.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Lowered {
    pub code: Vec<Instr>,
    pub calls: Vec<CallSite>,
    pub edges: usize,
    pub max_depth: usize,
    /// The highest tag used, and the rung that uses it.
    pub highest_tag: Option<(TagId, usize)>,
    /// The coils and box results, in rung order, without repeats.
    pub writes: Vec<TagId>,
}

/// Lowers checked rungs.
pub(crate) fn lower(rungs: &[CRung]) -> Lowered {
    let mut l = Lowerer {
        out: Lowered {
            code: Vec::new(),
            calls: Vec::new(),
            edges: 0,
            max_depth: 0,
            highest_tag: None,
            writes: Vec::new(),
        },
        rung: 0,
    };
    for rung in rungs {
        l.rung = rung.index;
        l.expr(&rung.cond);
        match &rung.action {
            CAction::Outputs(outs) => {
                for out in outs {
                    match out {
                        COut::Coil(kind, id) => l.coil(*kind, *id),
                        COut::Box { op, args, dest } => {
                            args.iter().for_each(|n| l.num(*n));
                            l.write(*dest);
                            l.out.code.push(Instr::Box {
                                op: *op,
                                args: *args,
                                dest: *dest,
                                rung: rung.index as u32,
                            });
                        }
                    }
                }
            }
            CAction::Block {
                inst,
                call,
                bools,
                coils,
            } => {
                for b in bools {
                    l.expr(b);
                }
                match call {
                    Call::Ton { pt } | Call::Tof { pt } | Call::Tp { pt } | Call::Stair { pt } => {
                        l.num(*pt)
                    }
                    Call::Ctu { pv } | Call::Ctd { pv } | Call::Ctud { pv } => l.num(*pv),
                    Call::Blink { on, off } => {
                        l.num(*on);
                        l.num(*off);
                    }
                    Call::BlinkPattern { step, .. } => l.num(*step),
                    Call::RTrig | Call::FTrig | Call::Sr | Call::Rs | Call::Toggle => {}
                }
                let site = l.out.calls.len() as u32;
                l.out.calls.push(CallSite {
                    inst: *inst,
                    call: call.clone(),
                    bools: bools.len() as u8,
                });
                l.out.code.push(Instr::Call(site));
                for (kind, id) in coils {
                    l.coil(*kind, *id);
                }
            }
        }
        l.out.code.push(Instr::Pop);
    }
    l.out.max_depth = max_depth(&l.out.code, &l.out.calls).unwrap_or(0);
    l.out
}

struct Lowerer {
    out: Lowered,
    rung: usize,
}

impl Lowerer {
    fn use_tag(&mut self, id: TagId) {
        if self.out.highest_tag.is_none_or(|(h, _)| id > h) {
            self.out.highest_tag = Some((id, self.rung));
        }
    }

    fn num(&mut self, n: Num) {
        if let Num::Tag(id) = n {
            self.use_tag(id);
        }
    }

    fn write(&mut self, id: TagId) {
        self.use_tag(id);
        if !self.out.writes.contains(&id) {
            self.out.writes.push(id);
        }
    }

    fn coil(&mut self, kind: CoilKind, id: TagId) {
        self.write(id);
        self.out.code.push(match kind {
            CoilKind::Normal => Instr::Coil(id),
            CoilKind::Negated => Instr::NegCoil(id),
            CoilKind::Set => Instr::Set(id),
            CoilKind::Reset => Instr::Reset(id),
        });
    }

    fn expr(&mut self, e: &BoolExpr) {
        match e {
            BoolExpr::Load(id) => {
                self.use_tag(*id);
                self.out.code.push(Instr::Load(*id));
            }
            BoolExpr::Out(i, m) => self.out.code.push(Instr::LoadOut(*i, *m)),
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
            BoolExpr::Or(items) => self.chain(items, Instr::Or),
            BoolExpr::Edge { rising, arg } => {
                self.expr(arg);
                let slot = self.out.edges as u32;
                self.out.edges += 1;
                self.out.code.push(if *rising {
                    Instr::Rising(slot)
                } else {
                    Instr::Falling(slot)
                });
            }
            BoolExpr::Cmp { lhs, op, rhs } => {
                self.num(*lhs);
                self.num(*rhs);
                self.out.code.push(Instr::Cmp {
                    lhs: *lhs,
                    op: *op,
                    rhs: *rhs,
                });
            }
        }
    }

    /// Every operand evaluated, left to right (edges inside see every scan).
    fn chain(&mut self, items: &[BoolExpr], op: Instr) {
        for (i, item) in items.iter().enumerate() {
            self.expr(item);
            if i > 0 {
                self.out.code.push(op);
            }
        }
    }
}

/// The deepest stack `code` reaches; `None` if it would pop an empty stack or leave values
/// behind (never for lowered code: checked in debug builds and tests).
pub(crate) fn max_depth(code: &[Instr], calls: &[CallSite]) -> Option<usize> {
    let mut depth = 0usize;
    let mut max = 0usize;
    for instr in code {
        let (pops, pushes) = match instr {
            Instr::Load(_)
            | Instr::LoadOut(..)
            | Instr::Const(_)
            | Instr::Cmp { .. }
            | Instr::Good(_)
            | Instr::Bad(_) => (0, 1),
            Instr::Not | Instr::Rising(_) | Instr::Falling(_) => (1, 1),
            Instr::And | Instr::Or => (2, 1),
            Instr::Coil(_)
            | Instr::NegCoil(_)
            | Instr::Set(_)
            | Instr::Reset(_)
            | Instr::Box { .. } => (1, 1),
            Instr::Call(site) => {
                let n = calls
                    .get(*site as usize)
                    .map_or(0, |c| usize::from(c.bools));
                (n + 1, 1)
            }
            Instr::Pop => (1, 0),
        };
        depth = depth.checked_sub(pops)? + pushes;
        max = max.max(depth);
    }
    (depth == 0).then_some(max)
}
