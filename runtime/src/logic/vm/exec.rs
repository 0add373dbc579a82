//! The executor: runs the flat instruction list once per scan over a preallocated bool stack.
//! No name lookups and no allocation per scan.

use std::path::PathBuf;
use std::time::Duration;

use softplc_io::point::{Quality, Value, ValueType};

use super::instr::{BoxOp, BoxSite, Call, CallSite, CmpOp, Instr, Num, OwnPin, OwnSite, PinArg};
use crate::image::{ProcessImage, TagId};
use crate::logic::blocks::{from_millis, Edge, Instance, Pattern, Pins, TimerPins, MAX_PINS};
use crate::logic::expr::TagTable;
use crate::logic::user_blocks::UserInstance;
use crate::logic::{LogicFault, ScanContext, SourcePos};

/// What a language's lowering hands to the VM.
#[derive(Debug)]
pub(crate) struct Parts {
    /// The instructions, rungs in file order.
    pub code: Vec<Instr>,
    /// The block call sites [`Instr::Call`] indexes.
    pub calls: Vec<CallSite>,
    /// The math boxes [`Instr::Box`] indexes.
    pub boxes: Vec<BoxSite>,
    /// The calls of blocks of one's own [`Instr::Own`] indexes.
    pub own_sites: Vec<OwnSite>,
    /// The instances of blocks of one's own those calls run.
    pub own: Vec<UserInstance>,
    /// Number of edge slots.
    pub edges: usize,
    /// Deepest stack the code reaches.
    pub max_depth: usize,
    /// The block instances (timers included), fresh.
    pub instances: Vec<Instance>,
    /// Every tag's type, by index, for box results ([`tag_types`]).
    pub types: Vec<ValueType>,
    /// The highest tag the code uses and where it is first used.
    pub highest_tag: Option<(TagId, SourcePos)>,
    /// Where each rung starts, for a box's fault.
    pub rung_pos: Vec<SourcePos>,
    /// The program file, for a fault with no better place.
    pub file: PathBuf,
}

/// A lowered program with its state, ready to scan.
#[derive(Debug)]
pub(crate) struct Program {
    code: Vec<Instr>,
    calls: Vec<CallSite>,
    boxes: Vec<BoxSite>,
    own_sites: Vec<OwnSite>,
    own: Vec<UserInstance>,
    stack: Vec<bool>,
    edges: Vec<Edge>,
    instances: Vec<Instance>,
    fresh: Vec<Instance>,
    types: Vec<ValueType>,
    rung_pos: Vec<SourcePos>,
    file: PathBuf,
    /// Number of tags the image must hold, and where the code needs the last one.
    needs_tags: usize,
    needs_pos: SourcePos,
    /// Per tag index: coils a module now drives, which the write instructions skip.
    released: Vec<bool>,
}

impl Program {
    pub(crate) fn new(parts: Parts) -> Self {
        let at_start = SourcePos {
            file: parts.file.clone(),
            line: 1,
            column: 1,
        };
        let (needs_tags, needs_pos) = parts
            .highest_tag
            .map_or((0, at_start), |(id, pos)| (id.index() + 1, pos));
        Self {
            code: parts.code,
            calls: parts.calls,
            boxes: parts.boxes,
            own_sites: parts.own_sites,
            own: parts.own,
            stack: Vec::with_capacity(parts.max_depth),
            edges: vec![Edge::default(); parts.edges],
            fresh: parts.instances.clone(),
            instances: parts.instances,
            types: parts.types,
            rung_pos: parts.rung_pos,
            file: parts.file,
            needs_tags,
            needs_pos,
            released: vec![false; needs_tags],
        }
    }

    /// The instructions, rungs in file order.
    pub(crate) fn instructions(&self) -> &[Instr] {
        &self.code
    }

    /// The block instances with their state now, by instance index.
    pub(crate) fn instances(&self) -> &[Instance] {
        &self.instances
    }

    /// Forgets every edge, timer and block state, as on a fresh start.
    pub(crate) fn reset(&mut self) {
        self.edges.fill(Edge::default());
        self.instances.clone_from(&self.fresh);
    }

    /// A module now drives `coil`: its rungs still run (their timers and edges see every scan)
    /// but their results are not written.
    pub(crate) fn release(&mut self, coil: TagId) {
        if let Some(r) = self.released.get_mut(coil.index()) {
            *r = true;
        }
    }

    fn rung_pos(rung_pos: &[SourcePos], file: &std::path::Path, rung: usize) -> SourcePos {
        rung_pos.get(rung).cloned().unwrap_or_else(|| SourcePos {
            file: file.to_path_buf(),
            line: 1,
            column: 1,
        })
    }

    /// Runs the program once: reads and writes the image.
    pub(crate) fn scan(
        &mut self,
        image: &mut ProcessImage,
        ctx: &ScanContext,
    ) -> Result<(), LogicFault> {
        if image.len() < self.needs_tags || self.types.len() < self.needs_tags {
            return Err(LogicFault {
                message: format!(
                    "program uses tag #{} but the process image holds {} tags",
                    self.needs_tags - 1,
                    image.len()
                ),
                pos: self.needs_pos.clone(),
            });
        }
        let now = ctx.now;
        let Self {
            code,
            calls,
            boxes,
            own_sites,
            own,
            stack,
            edges,
            instances,
            types,
            released,
            rung_pos,
            file,
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
                Instr::Xor => {
                    let (a, b) = pop2(stack);
                    stack.push(a ^ b);
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
                Instr::Timer { timer, preset } => {
                    let x = pop(stack);
                    // A block's timers count in durations on the scan's clock (`logic::blocks`).
                    let q = instances.get_mut(timer as usize).is_some_and(|t| {
                        t.call(
                            &TimerPins {
                                input: x,
                                pt: preset,
                            },
                            now.since_origin(),
                        )
                    });
                    stack.push(q);
                }
                Instr::Store(id) => {
                    let x = pop(stack);
                    if !is_released(released, id) {
                        image.set(id, Value::Bool(x), now);
                    }
                }
                Instr::Coil(id) | Instr::NegCoil(id) | Instr::Set(id) | Instr::Reset(id)
                    if is_released(released, id) => {}
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
                    // The bools are on the stack in pin order, the power flow first.
                    let mut bools = [false; MAX_PINS];
                    for (slot, given) in bools.iter_mut().zip(&site.call.pins).rev() {
                        if *given == PinArg::Stack {
                            *slot = pop(stack);
                        }
                    }
                    // Read the numeric arguments first: they may be other instances' outputs.
                    let pins = CallPins::read(&site.call, bools, image, instances);
                    let q = instances
                        .get_mut(site.inst as usize)
                        .is_some_and(|inst| inst.call(&pins, now.since_origin()));
                    stack.push(q);
                }
                Instr::Own(site) => {
                    let Some(site) = own_sites.get(site as usize) else {
                        continue;
                    };
                    let Some(inst) = own.get_mut(site.inst as usize) else {
                        continue;
                    };
                    // The bools are on the stack in input order, the power flow first.
                    for (i, pin) in site.pins.iter().enumerate().rev() {
                        let v = match *pin {
                            OwnPin::Stack => f64::from(u8::from(pop(stack))),
                            OwnPin::Num(n) => num(image, instances, n),
                            OwnPin::Default(v) => v,
                        };
                        inst.set_input(i, v, ctx);
                    }
                    let q = inst.run(image, ctx)?;
                    stack.push(q);
                }
                Instr::Box(site) => {
                    let Some(b) = boxes.get(site as usize) else {
                        continue;
                    };
                    if !top(stack) {
                        continue;
                    }
                    let [a0, a1, a2] = b.args.map(|n| num(image, instances, n));
                    let x = match b.op {
                        BoxOp::Move => a0,
                        BoxOp::Add => a0 + a1,
                        BoxOp::Sub => a0 - a1,
                        BoxOp::Mul => a0 * a1,
                        BoxOp::Div if a1 == 0.0 => {
                            return Err(LogicFault {
                                message: "division by zero in DIV".into(),
                                pos: Self::rung_pos(rung_pos, file, b.rung as usize),
                            });
                        }
                        BoxOp::Div => a0 / a1,
                        BoxOp::Limit => a1.max(a0).min(a2),
                    };
                    let ty = types.get(b.dest.index()).copied().unwrap_or(ValueType::F32);
                    image.set(b.dest, from_f64(ty, x), now);
                }
                Instr::Pop => {
                    stack.pop();
                }
            }
        }
        Ok(())
    }
}

/// Every tag's type by image index, from the table a program compiles against (a gap, which
/// a table never has, reads as bool).
pub(crate) fn tag_types(tags: &TagTable) -> Vec<ValueType> {
    let mut types = vec![ValueType::Bool; tags.len()];
    for t in tags.iter() {
        if t.id.index() >= types.len() {
            types.resize(t.id.index() + 1, ValueType::Bool);
        }
        if let Some(slot) = types.get_mut(t.id.index()) {
            *slot = t.ty;
        }
    }
    types
}

/// Whether a module drives `id` (its coils then compute but do not write).
fn is_released(released: &[bool], id: TagId) -> bool {
    released.get(id.index()).copied().unwrap_or(false)
}

/// A call site's inputs, by pin: the stack's bools and the numbers read before the call (a
/// time in ms, a count; zero where the call gives none), turned into the pin's type as the
/// block reads it.
struct CallPins<'a> {
    call: &'a Call,
    bools: [bool; MAX_PINS],
    nums: [f64; MAX_PINS],
}

impl<'a> CallPins<'a> {
    fn read(
        call: &'a Call,
        bools: [bool; MAX_PINS],
        image: &ProcessImage,
        instances: &[Instance],
    ) -> Self {
        let mut nums = [0.0; MAX_PINS];
        for (slot, given) in nums.iter_mut().zip(&call.pins) {
            if let PinArg::Num(n) = given {
                *slot = num(image, instances, *n);
            }
        }
        CallPins { call, bools, nums }
    }
}

impl Pins for CallPins<'_> {
    fn bool(&self, i: usize) -> bool {
        self.bools.get(i).copied().unwrap_or(false)
    }

    fn time(&self, i: usize) -> Duration {
        from_millis(self.nums.get(i).copied().unwrap_or(0.0))
    }

    fn count(&self, i: usize) -> i32 {
        match self.nums.get(i).copied() {
            Some(v) if !v.is_nan() => v.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32,
            _ => 0,
        }
    }

    fn pattern(&self, i: usize) -> Option<Pattern> {
        match self.call.pins.get(i) {
            Some(PinArg::Pattern(p)) => Some(*p),
            _ => None,
        }
    }
}

// The compiler proves the stack never underflows (`max_depth`); `false` is unreachable.
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
fn to_f64(v: Value) -> f64 {
    match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(x) => f64::from(x),
        Value::I32(x) => f64::from(x),
        Value::F32(x) => f64::from(x),
    }
}

/// A number as a value of type `ty`, as a box stores it (see [`from_f64`]).
pub(crate) fn number_as(ty: ValueType, x: f64) -> Value {
    from_f64(ty, x)
}

/// A number stored into a tag of type `ty`: integers truncate toward zero and saturate at the
/// type's range (NaN gives 0), bools are "not zero".
fn from_f64(ty: ValueType, x: f64) -> Value {
    let x0 = if x.is_nan() { 0.0 } else { x };
    match ty {
        ValueType::Bool => Value::Bool(x != 0.0 && !x.is_nan()),
        ValueType::U16 => Value::U16(x0.clamp(0.0, f64::from(u16::MAX)) as u16),
        ValueType::I32 => Value::I32(x0.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32),
        ValueType::F32 => Value::F32(x as f32),
    }
}

/// IEEE comparison: with a NaN only `!=` (`<>`) holds.
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
