//! The instruction set both compiled languages lower to, and the stack-depth proof over it.

use std::time::Duration;

use crate::image::TagId;
use crate::logic::blocks::{Kind, Member, Pattern, MAX_PINS};

/// One instruction of the logic VM. Every instruction runs every scan (there are no jumps), so
/// every edge, timer and block sees every scan.
///
/// Two ways to end a rung exist because the languages differ: an `expr` statement has exactly
/// one coil, so it ends with [`Instr::Store`] (pop and write, one dispatch); a ladder rung may
/// drive several outputs, which peek at its power flow ([`Instr::Coil`] ... [`Instr::Box`])
/// before [`Instr::Pop`] drops it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instr {
    /// Push a tag's value as a bool (non-zero is true).
    Load(TagId),
    /// Push an instance's boolean output (`name.Q`).
    LoadOut(u32, Member),
    /// Push a constant.
    Const(bool),
    /// Push whether a tag's quality is Good (read in the last cycle, or a memory or forced
    /// tag): `good(tag)`.
    Good(TagId),
    /// Push whether a tag's quality is Bad (its module lost, or never read): `bad(tag)`.
    Bad(TagId),
    /// Replace the top with its negation.
    Not,
    /// Pop two, push their conjunction (series).
    And,
    /// Pop two, push their exclusive or.
    Xor,
    /// Pop two, push their disjunction (parallel).
    Or,
    /// Push the result of a numeric comparison.
    Cmp {
        /// Left side.
        lhs: Num,
        /// The operator.
        op: CmpOp,
        /// Right side.
        rhs: Num,
    },
    /// Replace the top with "it is true and was false last scan"; edge slot.
    Rising(u32),
    /// Replace the top with "it is false and was true last scan"; edge slot.
    Falling(u32),
    /// A plain timer (TON, TOF, TP: a power flow and a time) on the top, with a constant
    /// preset: the instance's kind says which; one instruction, with no call site to look up.
    Timer {
        /// Instance index.
        timer: u32,
        /// Preset time.
        preset: Duration,
    },
    /// Pop and write into a bool tag: a rung's only coil and its end.
    Store(TagId),
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
    /// Call an instance of a block of one's own (own-site index): pops the bool inputs the
    /// site gives on the stack, then replaces the power flow under them with the block's main
    /// output.
    Own(u32),
    /// When the top is true, compute a math box (box-site index). Kept out of line: its
    /// operands would double the size of every instruction.
    Box(u32),
    /// End of a rung: drop its power flow.
    Pop,
}

/// A number: a constant, a tag's value, or an instance's output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Num {
    /// A literal (a duration is its milliseconds; compared with an `f32` tag, already rounded
    /// to `f32`).
    Const(f64),
    /// A numeric tag's current value.
    Tag(TagId),
    /// An instance's output (`ET` in milliseconds).
    Out(u32, Member),
}

/// A comparison operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CmpOp {
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `==` (ladder also reads `=`)
    Eq,
    /// `!=` (ladder also reads `<>`)
    Ne,
}

impl CmpOp {
    /// The operator as written (the spelling both languages read).
    pub fn symbol(self) -> &'static str {
        match self {
            CmpOp::Lt => "<",
            CmpOp::Le => "<=",
            CmpOp::Gt => ">",
            CmpOp::Ge => ">=",
            CmpOp::Eq => "==",
            CmpOp::Ne => "!=",
        }
    }
}

/// What a call gives one pin of its block.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum PinArg {
    /// Not given (a pin of the block's other form): `false`, zero.
    #[default]
    Absent,
    /// A bool on the stack: the power flow and the bool arguments, lowered in pin order.
    Stack,
    /// A number: a time in milliseconds, or a count.
    Num(Num),
    /// A blink pattern.
    Pattern(Pattern),
}

/// A block call with its checked arguments, by pin ([`BlockDef::pins`](crate::logic::blocks::BlockDef::pins)). The power flow is
/// each block's first pin (IN, CU, CLK, S, EN); the bool arguments are lowered in pin order.
#[derive(Debug, Clone, PartialEq)]
pub struct Call {
    /// The block.
    pub kind: Kind,
    /// Its pins' arguments, by pin index.
    pub pins: [PinArg; MAX_PINS],
}

impl Call {
    /// A call of `kind` with only its power flow given.
    pub fn new(kind: Kind) -> Self {
        let mut pins = [PinArg::Absent; MAX_PINS];
        pins[0] = PinArg::Stack;
        Call { kind, pins }
    }

    /// What the call gives the pin named `name`.
    pub fn pin(&self, name: &str) -> PinArg {
        self.kind
            .def()
            .pin(name)
            .and_then(|(i, _)| self.pins.get(i).copied())
            .unwrap_or_default()
    }

    /// The number the call gives the pin named `name`, if it gives one.
    pub fn num(&self, name: &str) -> Option<Num> {
        match self.pin(name) {
            PinArg::Num(n) => Some(n),
            _ => None,
        }
    }
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

/// What a call of a block of one's own gives one input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum OwnPin {
    /// A bool on the stack (the power flow and the bool inputs, lowered in input order).
    Stack,
    /// A number read when the call runs.
    Num(Num),
    /// Left out: the input's `default:`.
    Default(f64),
}

/// A call site of a block of one's own: the instance and what the call gives each input.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OwnSite {
    /// The instance, an index into the program's instances of blocks of one's own.
    pub(crate) inst: u32,
    /// Every input, in the block's order.
    pub(crate) pins: Vec<OwnPin>,
}

impl OwnSite {
    /// How many bools the call takes from the stack (the power flow included).
    pub(crate) fn bools(&self) -> usize {
        self.pins.iter().filter(|p| **p == OwnPin::Stack).count()
    }
}

/// A math box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxOp {
    /// `MOVE(a)`
    Move,
    /// `ADD(a, b)`
    Add,
    /// `SUB(a, b)`
    Sub,
    /// `MUL(a, b)`
    Mul,
    /// `DIV(a, b)`
    Div,
    /// `LIMIT(mn, in, mx)`
    Limit,
}

/// A math box site: computed when its rung is powered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxSite {
    /// The operation.
    pub op: BoxOp,
    /// Its operands (unused ones are zero).
    pub args: [Num; 3],
    /// The result's tag.
    pub dest: TagId,
    /// The rung, for a fault's position.
    pub rung: u32,
}

/// The deepest stack `code` reaches; `None` if it would pop an empty stack or leave values
/// behind (never, for lowered code: checked in tests and in debug builds). `calls` gives the
/// arity of each [`Instr::Call`].
pub(crate) fn max_depth(code: &[Instr], calls: &[CallSite], own: &[OwnSite]) -> Option<usize> {
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
            Instr::Not | Instr::Rising(_) | Instr::Falling(_) | Instr::Timer { .. } => (1, 1),
            Instr::And | Instr::Xor | Instr::Or => (2, 1),
            Instr::Store(_) | Instr::Pop => (1, 0),
            // Outputs peek: the power flow stays for the rung's next output.
            Instr::Coil(_)
            | Instr::NegCoil(_)
            | Instr::Set(_)
            | Instr::Reset(_)
            | Instr::Box(_) => (1, 1),
            Instr::Call(site) => {
                let n = calls
                    .get(*site as usize)
                    .map_or(0, |c| usize::from(c.bools));
                (n + 1, 1)
            }
            Instr::Own(site) => (own.get(*site as usize).map_or(1, OwnSite::bools), 1),
        };
        depth = depth.checked_sub(pops)? + pushes;
        max = max.max(depth);
    }
    (depth == 0).then_some(max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_counts_peeking_outputs_and_call_arity() {
        let calls = [CallSite {
            inst: 0,
            call: Call::new(crate::logic::blocks::Kind::Sr),
            bools: 1,
        }];
        let code = [
            Instr::Const(true),
            Instr::Load(TagId(1)),
            Instr::Call(0),
            Instr::Coil(TagId(2)),
            Instr::Box(0),
            Instr::Pop,
        ];
        assert_eq!(max_depth(&code, &calls, &[]), Some(2));
        assert_eq!(
            max_depth(&code[..2], &calls, &[]),
            None,
            "left values behind"
        );
        assert_eq!(
            max_depth(&[Instr::Pop], &calls, &[]),
            None,
            "popped an empty stack"
        );
    }

    #[test]
    fn an_instruction_stays_small() {
        // Box sites are out of line so that the hot loop walks 40-byte instructions.
        assert!(std::mem::size_of::<Instr>() <= 40);
    }
}
