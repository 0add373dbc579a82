//! The executor: runs the flat instruction list once per scan over a preallocated bool stack.
//! No name lookups and no allocation per scan.

use std::path::PathBuf;

use softplc_io::point::{Quality, Value, ValueType};

use super::check::{BoxOp, Call, Num};
use super::lower::Lowered;
use super::parser::CmpOp;
use crate::image::{ProcessImage, TagId};
use crate::logic::blocks::{from_millis, Edge, Instance, Member};
use crate::logic::{LogicEngine, LogicFault, ScanContext, SourcePos};

/// One instruction. Every instruction runs every scan (no jumps), so every edge and block sees
/// every scan; a rung's outputs peek at its power flow, and [`Instr::Pop`] ends the rung.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instr {
    /// Push a tag as a bool (non-zero is true).
    Load(TagId),
    /// Push an instance's boolean output.
    LoadOut(u32, Member),
    /// Push a constant.
    Const(bool),
    /// Push whether a tag's quality is Good (read in the last cycle, or a memory or forced
    /// tag): the contact `good(tag)`.
    Good(TagId),
    /// Push whether a tag's quality is Bad (its module lost, or never read): `bad(tag)`.
    Bad(TagId),
    /// Negate the top.
    Not,
    /// Pop two, push their conjunction (series).
    And,
    /// Pop two, push their disjunction (parallel).
    Or,
    /// Push a numeric comparison.
    Cmp {
        /// Left side.
        lhs: Num,
        /// Operator.
        op: CmpOp,
        /// Right side.
        rhs: Num,
    },
    /// Replace the top with its rising edge; edge slot.
    Rising(u32),
    /// Replace the top with its falling edge; edge slot.
    Falling(u32),
    /// Write the top to a bool tag.
    Coil(TagId),
    /// Write the negated top.
    NegCoil(TagId),
    /// Set the tag when the top is true.
    Set(TagId),
    /// Clear the tag when the top is true.
    Reset(TagId),
    /// Call a block (call-site index): pops its bool arguments, then replaces the power flow
    /// under them with the block's main output.
    Call(u32),
    /// When the top is true, compute a math box into `dest`.
    Box {
        /// The operation.
        op: BoxOp,
        /// Its operands (unused ones are zero).
        args: [Num; 3],
        /// The result's tag.
        dest: TagId,
        /// The rung, for a fault's position.
        rung: u32,
    },
    /// End of a rung: drop its power flow.
    Pop,
}

/// A block call site: the instance and its non-boolean arguments.
#[derive(Debug, Clone, PartialEq)]
pub struct CallSite {
    /// Instance index.
    pub inst: u32,
    /// Kind and arguments.
    pub call: Call,
    /// Number of bool arguments on the stack above the power flow.
    pub bools: u8,
}

/// A compiled ladder program, ready to scan. Build it with [`super::compile`].
#[derive(Debug, Clone)]
pub struct LadderProgram {
    code: Vec<Instr>,
    calls: Vec<CallSite>,
    stack: Vec<bool>,
    edges: Vec<Edge>,
    instances: Vec<Instance>,
    fresh: Vec<Instance>,
    /// Types of the tags, for box results.
    types: Vec<ValueType>,
    writes: Vec<TagId>,
    /// Where each rung starts, for faults.
    rung_pos: Vec<SourcePos>,
    needs_tags: usize,
    needs_rung: usize,
    file: PathBuf,
    /// The coils as rungs, for the push-down planner.
    rungs: Vec<crate::offload::ir::Rung>,
    /// Per tag index: coils a module now drives, which the coil instructions skip.
    released: Vec<bool>,
}

impl LadderProgram {
    pub(crate) fn new(
        lowered: Lowered,
        instances: Vec<Instance>,
        types: Vec<ValueType>,
        rung_pos: Vec<SourcePos>,
        file: PathBuf,
    ) -> Self {
        let (needs_tags, needs_rung) = lowered
            .highest_tag
            .map_or((0, 0), |(id, rung)| (id.index() + 1, rung));
        Self {
            stack: Vec::with_capacity(lowered.max_depth),
            edges: vec![Edge::default(); lowered.edges],
            fresh: instances.clone(),
            instances,
            code: lowered.code,
            calls: lowered.calls,
            types,
            writes: lowered.writes,
            rung_pos,
            needs_tags,
            needs_rung,
            file,
            rungs: Vec::new(),
            released: vec![false; needs_tags],
        }
    }

    /// The program with its coils described as rungs.
    pub(crate) fn with_rungs(mut self, rungs: Vec<crate::offload::ir::Rung>) -> Self {
        self.rungs = rungs;
        self
    }

    /// Whether a module drives `id` (its coils then compute but do not write).
    fn released(released: &[bool], id: TagId) -> bool {
        released.get(id.index()).copied().unwrap_or(false)
    }

    /// The lowered instructions, rungs in file order.
    pub fn instructions(&self) -> &[Instr] {
        &self.code
    }

    /// The tags the program writes (coils, set/reset coils, box results), in rung order.
    pub fn outputs(&self) -> impl Iterator<Item = TagId> + '_ {
        self.writes.iter().copied()
    }

    /// Forgets every edge and block state, as on a fresh start.
    pub fn reset(&mut self) {
        self.edges.fill(Edge::default());
        self.instances.clone_from(&self.fresh);
    }

    fn pos(&self, rung: usize) -> SourcePos {
        self.rung_pos.get(rung).cloned().unwrap_or(SourcePos {
            file: self.file.clone(),
            line: 1,
            column: 1,
        })
    }
}

impl LogicEngine for LadderProgram {
    fn scan(&mut self, image: &mut ProcessImage, ctx: &ScanContext) -> Result<(), LogicFault> {
        if image.len() < self.needs_tags || self.types.len() < self.needs_tags {
            return Err(LogicFault {
                message: format!(
                    "program uses tag #{} but the process image holds {} tags",
                    self.needs_tags - 1,
                    image.len()
                ),
                pos: self.pos(self.needs_rung),
            });
        }
        let now = ctx.now;
        let Self {
            code,
            calls,
            stack,
            edges,
            instances,
            types,
            released,
            ..
        } = self;
        stack.clear();
        for instr in code.iter() {
            match *instr {
                Instr::Load(id) => stack.push(image.get(id).as_bool()),
                Instr::LoadOut(i, m) => {
                    stack.push(instances.get(i as usize).is_some_and(|b| b.bool_output(m)))
                }
                Instr::Const(b) => stack.push(b),
                Instr::Good(id) => stack.push(image.slot(id).quality == Quality::Good),
                Instr::Bad(id) => stack.push(image.slot(id).quality == Quality::Bad),
                Instr::Not => {
                    let a = pop(stack);
                    stack.push(!a);
                }
                Instr::And => {
                    let (a, b) = pop2(stack);
                    stack.push(a & b);
                }
                Instr::Or => {
                    let (a, b) = pop2(stack);
                    stack.push(a | b);
                }
                Instr::Cmp { lhs, op, rhs } => {
                    let (a, b) = (num(image, instances, lhs), num(image, instances, rhs));
                    stack.push(compare(a, op, b));
                }
                Instr::Rising(slot) => {
                    let x = pop(stack);
                    let q = edges.get_mut(slot as usize).is_some_and(|e| e.rising(x));
                    stack.push(q);
                }
                Instr::Falling(slot) => {
                    let x = pop(stack);
                    let q = edges.get_mut(slot as usize).is_some_and(|e| e.falling(x));
                    stack.push(q);
                }
                Instr::Coil(id) | Instr::NegCoil(id) | Instr::Set(id) | Instr::Reset(id)
                    if Self::released(released, id) => {}
                Instr::Coil(id) => image.set(id, Value::Bool(top(stack)), now),
                Instr::NegCoil(id) => image.set(id, Value::Bool(!top(stack)), now),
                Instr::Set(id) => {
                    if top(stack) {
                        image.set(id, Value::Bool(true), now);
                    }
                }
                Instr::Reset(id) => {
                    if top(stack) {
                        image.set(id, Value::Bool(false), now);
                    }
                }
                Instr::Call(site) => {
                    let Some(site) = calls.get(site as usize) else {
                        continue;
                    };
                    let mut args = [false; 3];
                    for k in (0..usize::from(site.bools)).rev() {
                        let v = pop(stack);
                        if let Some(a) = args.get_mut(k) {
                            *a = v;
                        }
                    }
                    let en = pop(stack);
                    // Read the numeric arguments first: they may be other instances' outputs.
                    let nums = call_nums(&site.call).map(|n| num(image, instances, n));
                    let q = match instances.get_mut(site.inst as usize) {
                        Some(inst) => call(inst, &site.call, en, args, nums, now),
                        None => false,
                    };
                    stack.push(q);
                }
                Instr::Box {
                    op,
                    args,
                    dest,
                    rung,
                } => {
                    if !top(stack) {
                        continue;
                    }
                    let [a, b, c] = args.map(|n| num(image, instances, n));
                    let x = match op {
                        BoxOp::Move => a,
                        BoxOp::Add => a + b,
                        BoxOp::Sub => a - b,
                        BoxOp::Mul => a * b,
                        BoxOp::Div if b == 0.0 => {
                            return Err(LogicFault {
                                message: "division by zero in DIV".into(),
                                pos: self.pos(rung as usize),
                            });
                        }
                        BoxOp::Div => a / b,
                        BoxOp::Limit => b.max(a).min(c),
                    };
                    let ty = types.get(dest.index()).copied().unwrap_or(ValueType::F32);
                    image.set(dest, from_f64(ty, x), now);
                }
                Instr::Pop => {
                    stack.pop();
                }
            }
        }
        Ok(())
    }

    fn rungs(&self) -> Option<Vec<crate::offload::ir::Rung>> {
        Some(self.rungs.clone())
    }

    fn release(&mut self, coil: TagId) {
        if let Some(r) = self.released.get_mut(coil.index()) {
            *r = true;
        }
    }
}

/// The numeric arguments of a call, in the order [`call`] reads them.
fn call_nums(call: &Call) -> [Num; 2] {
    let zero = Num::Const(0.0);
    match call {
        Call::Ton { pt } | Call::Tof { pt } | Call::Tp { pt } | Call::Stair { pt } => [*pt, zero],
        Call::Ctu { pv } | Call::Ctd { pv } | Call::Ctud { pv } => [*pv, zero],
        Call::Blink { on, off } => [*on, *off],
        Call::BlinkPattern { step, .. } => [*step, zero],
        Call::RTrig | Call::FTrig | Call::Sr | Call::Rs | Call::Toggle => [zero, zero],
    }
}

/// Calls one block with its power flow, bool arguments and numeric arguments (times in ms).
fn call(
    inst: &mut Instance,
    call: &Call,
    en: bool,
    args: [bool; 3],
    nums: [f64; 2],
    now: std::time::Duration,
) -> bool {
    let [a0, a1, a2] = args;
    let [n0, n1] = nums;
    let int = if n0.is_nan() {
        0
    } else {
        n0.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
    };
    let (t0, t1) = (from_millis(n0), from_millis(n1));
    match (inst, call) {
        (Instance::Ton(t), Call::Ton { .. }) => t.call(en, t0, now),
        (Instance::Tof(t), Call::Tof { .. }) => t.call(en, t0, now),
        (Instance::Tp(t), Call::Tp { .. }) => t.call(en, t0, now),
        (Instance::Stair(t), Call::Stair { .. }) => t.call(en, a0, t0, now),
        (Instance::Ctu(c), Call::Ctu { .. }) => c.call(en, a0, int),
        (Instance::Ctd(c), Call::Ctd { .. }) => c.call(en, a0, int),
        (Instance::Ctud(c), Call::Ctud { .. }) => c.call(en, a0, a1, a2, int),
        (Instance::RTrig(e), Call::RTrig) => e.rising(en),
        (Instance::FTrig(e), Call::FTrig) => e.falling(en),
        (Instance::Sr(b), Call::Sr) => b.call(en, a0),
        (Instance::Rs(b), Call::Rs) => b.call(en, a0),
        (Instance::Toggle(b), Call::Toggle) => b.call(en, a0),
        (Instance::Blink(b), Call::Blink { .. }) => b.call(en, t0, t1, now),
        (Instance::Blink(b), Call::BlinkPattern { pattern, .. }) => {
            b.call_pattern(en, *pattern, t0, now)
        }
        // The checker gives every instance the kind of its one call site.
        _ => false,
    }
}

// The compiler proves the stack never underflows (`lower::max_depth`); `false` is unreachable.
fn pop(stack: &mut Vec<bool>) -> bool {
    stack.pop().unwrap_or(false)
}

fn pop2(stack: &mut Vec<bool>) -> (bool, bool) {
    let b = pop(stack);
    (pop(stack), b)
}

fn top(stack: &[bool]) -> bool {
    stack.last().copied().unwrap_or(false)
}

/// A number's current value.
fn num(image: &ProcessImage, instances: &[Instance], n: Num) -> f64 {
    match n {
        Num::Const(v) => v,
        Num::Tag(id) => to_f64(image.get(id)),
        Num::Out(i, m) => instances
            .get(i as usize)
            .map_or(0.0, |b| b.number_output(m)),
    }
}

/// A value as a number (bools as 0/1).
pub(crate) fn to_f64(v: Value) -> f64 {
    match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(x) => f64::from(x),
        Value::I32(x) => f64::from(x),
        Value::F32(x) => f64::from(x),
    }
}

/// A number stored into a tag of type `ty`: integers truncate toward zero and saturate at the
/// type's range (NaN gives 0), bools are "not zero".
pub(crate) fn from_f64(ty: ValueType, x: f64) -> Value {
    let x0 = if x.is_nan() { 0.0 } else { x };
    match ty {
        ValueType::Bool => Value::Bool(x != 0.0 && !x.is_nan()),
        ValueType::U16 => Value::U16(x0.clamp(0.0, f64::from(u16::MAX)) as u16),
        ValueType::I32 => Value::I32(x0.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32),
        ValueType::F32 => Value::F32(x as f32),
    }
}

/// IEEE comparison: with a NaN only `<>` holds.
fn compare(a: f64, op: CmpOp, b: f64) -> bool {
    match op {
        CmpOp::Lt => a < b,
        CmpOp::Le => a <= b,
        CmpOp::Gt => a > b,
        CmpOp::Ge => a >= b,
        CmpOp::Eq => a == b,
        CmpOp::Ne => a != b,
    }
}
