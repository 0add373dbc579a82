//! The executor: runs the flat instruction list once per scan over a preallocated bool stack.
//! No name lookups and no allocation per scan.

use std::path::PathBuf;
use std::time::Duration;

use softplc_io::point::{Quality, Value};

use super::lower::Lowered;
use super::CmpOp;
use crate::image::{ProcessImage, TagId};
use crate::logic::{LogicEngine, LogicFault, ScanContext, SourcePos};
use crate::offload::ir::Rung;

/// One instruction of the stack machine. Every instruction is executed every scan (there are
/// no jumps), so each edge and timer call site sees every scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instr {
    /// Push a tag's value as a bool (non-zero is true).
    Load(TagId),
    /// Push a constant.
    Const(bool),
    /// Push whether a tag's quality is Good (read in the last cycle, or a memory or forced
    /// tag): `good(tag)`.
    Good(TagId),
    /// Push whether a tag's quality is Bad (its module lost, or never read): `bad(tag)`.
    Bad(TagId),
    /// Replace the top with its negation.
    Not,
    /// Pop two, push their conjunction.
    And,
    /// Pop two, push their exclusive or.
    Xor,
    /// Pop two, push their disjunction.
    Or,
    /// Push the result of a numeric comparison.
    Cmp {
        /// Left side.
        lhs: Operand,
        /// The operator.
        op: CmpOp,
        /// Right side.
        rhs: Operand,
    },
    /// Replace the top with "it is true and was false last scan"; edge slot index.
    Rising(u32),
    /// Replace the top with "it is false and was true last scan"; edge slot index.
    Falling(u32),
    /// On-delay timer on the top; timer slot index and preset.
    Ton {
        /// Timer slot.
        timer: u32,
        /// Preset time.
        preset: Duration,
    },
    /// Off-delay timer on the top.
    Tof {
        /// Timer slot.
        timer: u32,
        /// Preset time.
        preset: Duration,
    },
    /// Pulse timer on the top.
    Tp {
        /// Timer slot.
        timer: u32,
        /// Preset time.
        preset: Duration,
    },
    /// Pop and write into a bool tag.
    Store(TagId),
}

/// One side of a comparison.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Operand {
    /// A numeric tag's current value.
    Tag(TagId),
    /// A literal (already rounded to `f32` when compared with an `f32` tag).
    Const(f64),
}

/// State of one timer call site.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct TimerState {
    /// Output.
    q: bool,
    /// Timing since `start`.
    running: bool,
    /// When timing started.
    start: Duration,
    /// The input last scan (`None` before the first scan); for `tp`'s edge.
    prev: Option<bool>,
}

/// A compiled `.expr` program, ready to scan. Build it with [`super::compile`].
#[derive(Debug, Clone)]
pub struct ExprProgram {
    code: Vec<Instr>,
    coils: Vec<TagId>,
    stack: Vec<bool>,
    /// Last scan's input per edge call site (`None` before the first scan).
    edges: Vec<Option<bool>>,
    timers: Vec<TimerState>,
    /// Number of tags the image must hold, and the statement that needs the last one.
    needs_tags: usize,
    needs_pos: SourcePos,
    /// The statements as rungs, for the push-down planner.
    rungs: Vec<Rung>,
    /// Per tag index: coils a module now drives, which `Store` skips.
    released: Vec<bool>,
}

impl ExprProgram {
    pub(crate) fn new(lowered: Lowered, file: PathBuf) -> Self {
        let (needs_tags, pos) = match lowered.highest_tag {
            Some((id, pos)) => (id.index() + 1, pos),
            None => (0, super::parser::Pos { line: 1, col: 1 }),
        };
        Self {
            stack: Vec::with_capacity(lowered.max_depth),
            edges: vec![None; lowered.edges],
            timers: vec![TimerState::default(); lowered.timers],
            code: lowered.code,
            coils: lowered.coils,
            needs_tags,
            needs_pos: SourcePos {
                file,
                line: pos.line,
                column: pos.col,
            },
            rungs: Vec::new(),
            released: vec![false; needs_tags],
        }
    }

    /// The program with its statements described as rungs.
    pub(crate) fn with_rungs(mut self, rungs: Vec<Rung>) -> Self {
        self.rungs = rungs;
        self
    }

    /// The coils the program writes (the outputs and memory tags it owns), in file order.
    pub fn outputs(&self) -> impl Iterator<Item = TagId> + '_ {
        self.coils.iter().copied()
    }

    /// The lowered instructions, statements in file order.
    pub fn instructions(&self) -> &[Instr] {
        &self.code
    }

    /// Forgets all edge and timer state, as on a fresh start.
    pub fn reset(&mut self) {
        self.edges.fill(None);
        self.timers.fill(TimerState::default());
    }
}

impl LogicEngine for ExprProgram {
    fn scan(&mut self, image: &mut ProcessImage, ctx: &ScanContext) -> Result<(), LogicFault> {
        if image.len() < self.needs_tags {
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
            stack,
            edges,
            timers,
            released,
            ..
        } = self;
        stack.clear();
        for instr in code.iter() {
            match *instr {
                Instr::Load(id) => stack.push(image.get(id).as_bool()),
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
                    stack.push(compare(operand(image, lhs), op, operand(image, rhs)));
                }
                Instr::Rising(slot) => {
                    let x = pop(stack);
                    let prev = edges[slot as usize].replace(x);
                    stack.push(x && prev == Some(false));
                }
                Instr::Falling(slot) => {
                    let x = pop(stack);
                    let prev = edges[slot as usize].replace(x);
                    stack.push(!x && prev == Some(true));
                }
                Instr::Ton { timer, preset } => {
                    let x = pop(stack);
                    stack.push(ton(&mut timers[timer as usize], x, preset, now));
                }
                Instr::Tof { timer, preset } => {
                    let x = pop(stack);
                    stack.push(tof(&mut timers[timer as usize], x, preset, now));
                }
                Instr::Tp { timer, preset } => {
                    let x = pop(stack);
                    stack.push(tp(&mut timers[timer as usize], x, preset, now));
                }
                Instr::Store(id) => {
                    let x = pop(stack);
                    // A released coil is the module's: the statement still runs (its timers
                    // and edges see every scan) but its result is not written.
                    if !released.get(id.index()).copied().unwrap_or(false) {
                        image.set(id, Value::Bool(x), now);
                    }
                }
            }
        }
        Ok(())
    }

    fn rungs(&self) -> Option<Vec<Rung>> {
        Some(self.rungs.clone())
    }

    fn release(&mut self, coil: TagId) {
        if let Some(r) = self.released.get_mut(coil.index()) {
            *r = true;
        }
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

fn operand(image: &ProcessImage, op: Operand) -> f64 {
    match op {
        Operand::Const(v) => v,
        Operand::Tag(id) => match image.get(id) {
            Value::Bool(b) => f64::from(u8::from(b)),
            Value::U16(v) => f64::from(v),
            Value::I32(v) => f64::from(v),
            Value::F32(v) => f64::from(v),
        },
    }
}

/// IEEE comparison: with a NaN only `!=` holds.
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

/// Time since the timer started. Should the clock go back (a replayed or reset virtual clock),
/// the timer starts again from `now` rather than waiting for the old start time.
fn elapsed(t: &mut TimerState, now: Duration) -> Duration {
    if now < t.start {
        t.start = now;
    }
    now - t.start
}

/// On-delay: true once the input has been true for `preset`, measured from the first scan that
/// saw it true; false as soon as the input is false.
fn ton(t: &mut TimerState, x: bool, preset: Duration, now: Duration) -> bool {
    if x {
        if !t.running {
            t.running = true;
            t.start = now;
        }
        t.q = elapsed(t, now) >= preset;
    } else {
        t.running = false;
        t.q = false;
    }
    t.q
}

/// Off-delay: true while the input is true and until it has been false for `preset`, measured
/// from the first scan that saw it false.
fn tof(t: &mut TimerState, x: bool, preset: Duration, now: Duration) -> bool {
    if x {
        t.running = false;
        t.q = true;
    } else if t.q {
        if !t.running {
            t.running = true;
            t.start = now;
        }
        if elapsed(t, now) >= preset {
            t.running = false;
            t.q = false;
        }
    }
    t.q
}

/// Pulse: a rising edge of the input (false last scan, true now) starts a pulse of `preset`,
/// true on the scans with `now - start < preset`; edges during a pulse are ignored.
fn tp(t: &mut TimerState, x: bool, preset: Duration, now: Duration) -> bool {
    let edge = x && t.prev == Some(false);
    t.prev = Some(x);
    if t.running && elapsed(t, now) >= preset {
        t.running = false;
    }
    if !t.running && edge {
        t.running = true;
        t.start = now;
    }
    t.q = t.running;
    t.q
}
