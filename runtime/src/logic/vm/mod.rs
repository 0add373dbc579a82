//! The logic VM: one instruction set ([`Instr`]) and one executor ([`Program`]) for every
//! compiled language.
//!
//! `expr` and `ladder` each parse, check and lower their own syntax, and both lower to this
//! one stack machine, so a contact, an edge, a timer or a coil means the same thing, runs the
//! same code and costs the same in either language. The program is flat (no jumps: every
//! instruction runs every scan, so each edge, timer and block sees every scan) and works on a
//! bool stack allocated once, whose depth the compiler proves ([`max_depth`]); numbers live
//! only inside an instruction (a comparison's operands, a block's presets, a math box), read
//! from the image or from an instance's outputs when it runs.
//!
//! State is indexed at compile time: an edge slot per `rising`/`falling`, an
//! [`Instance`](crate::logic::blocks::Instance) of the shared block library per timer or block
//! call site. A scan looks up no names and allocates nothing.

mod exec;
mod instr;

pub(crate) use exec::{number_as, tag_types, Parts, Program};
pub(crate) use instr::max_depth;
pub use instr::{BoxOp, BoxSite, Call, CallSite, CmpOp, Instr, Num, PinArg};
pub(crate) use instr::{OwnPin, OwnSite};
