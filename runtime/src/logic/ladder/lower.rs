//! Lowering: checked rungs → the VM's flat program ([`crate::logic::vm`]) over [`TagId`]s,
//! instance indexes and edge slots, with the stack depth it needs.

use super::check::{BoolExpr, CAction, COut, CRung};
use super::parser::CoilKind;
use crate::image::TagId;
use crate::logic::vm::{BoxSite, CallSite, Instr, Num, OwnPin, OwnSite, PinArg};

/// The stack-depth proof, for the compiler's debug check and the tests.
pub(crate) use crate::logic::vm::max_depth;

/// A lowered program.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Lowered {
    pub code: Vec<Instr>,
    pub calls: Vec<CallSite>,
    pub boxes: Vec<BoxSite>,
    pub own_sites: Vec<OwnSite>,
    pub edges: usize,
    pub max_depth: usize,
    /// The highest tag used, and the rung that uses it.
    pub highest_tag: Option<(TagId, usize)>,
    /// The coils and box results, in rung order, without repeats, each with the first rung
    /// writing it.
    pub writes: Vec<(TagId, usize)>,
}

/// Lowers checked rungs.
pub(crate) fn lower(rungs: &[CRung]) -> Lowered {
    let mut l = Lowerer {
        out: Lowered {
            code: Vec::new(),
            calls: Vec::new(),
            boxes: Vec::new(),
            own_sites: Vec::new(),
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
                            let site = l.out.boxes.len() as u32;
                            l.out.boxes.push(BoxSite {
                                op: *op,
                                args: *args,
                                dest: *dest,
                                rung: rung.index as u32,
                            });
                            l.out.code.push(Instr::Box(site));
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
                let site = l.out.calls.len() as u32;
                l.out.calls.push(CallSite {
                    inst: *inst,
                    call: call.clone(),
                    bools: bools.len() as u8,
                });
                let nums = call.pins.iter().filter_map(|pin| match pin {
                    PinArg::Num(n) => Some(*n),
                    _ => None,
                });
                l.call(bools, nums, Instr::Call(site), coils);
            }
            CAction::Own {
                inst,
                pins,
                bools,
                coils,
            } => {
                let site = l.out.own_sites.len() as u32;
                l.out.own_sites.push(OwnSite {
                    inst: *inst,
                    pins: pins.clone(),
                });
                let nums = pins.iter().filter_map(|pin| match pin {
                    OwnPin::Num(n) => Some(*n),
                    _ => None,
                });
                l.call(bools, nums, Instr::Own(site), coils);
            }
        }
        l.out.code.push(Instr::Pop);
    }
    l.out.max_depth = max_depth(&l.out.code, &l.out.calls, &l.out.own_sites).unwrap_or(0);
    l.out
}

struct Lowerer {
    out: Lowered,
    rung: usize,
}

impl Lowerer {
    /// A block call after its power flow: its bool arguments, the tags its numbers read, the
    /// call, then the coils its main output drives.
    fn call(
        &mut self,
        bools: &[BoolExpr],
        nums: impl Iterator<Item = Num>,
        call: Instr,
        coils: &[(CoilKind, TagId)],
    ) {
        for b in bools {
            self.expr(b);
        }
        for n in nums {
            self.num(n);
        }
        self.out.code.push(call);
        for (kind, id) in coils {
            self.coil(*kind, *id);
        }
    }

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
        if !self.out.writes.iter().any(|&(w, _)| w == id) {
            self.out.writes.push((id, self.rung));
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
