//! What an instance's body does to its main output, for the push-down planner: the body's own
//! description of the rung writing it, over the block's variables. A caller's rung calling the
//! instance with pure conditions becomes that shape over the caller's tags (see
//! `ladder/rungs.rs`), so a body that a module's logic can run (a latch, a combination) is
//! pushed down per instance, like the same rung written out.

use softplc_io::rung::{BoolExpr, RungShape};

use crate::image::TagId;
use crate::logic::LogicEngine;

/// The main output's shape over the block's variables (ids: inputs first, then outputs, then
/// state), when it reads only inputs and itself; why not, otherwise.
pub(crate) fn main_output_shape(
    body: &dyn LogicEngine,
    inputs: usize,
) -> Result<RungShape, String> {
    let main = TagId(inputs as u32);
    let Some(rungs) = body.rungs() else {
        return Err("its body does not describe its rungs".to_owned());
    };
    let mut writing = rungs.into_iter().filter(|r| r.coil == main);
    let (Some(rung), None) = (writing.next(), writing.next()) else {
        return Err("its body writes the main output in several rungs, or in none".to_owned());
    };
    let shape = rung.shape;
    let reads_only = |e: &BoolExpr| e.tags().iter().all(|t| t.index() < inputs || *t == main);
    match &shape {
        RungShape::Combinational { expr } if reads_only(expr) => Ok(shape),
        RungShape::Latch { set, reset, .. } if reads_only(set) && reads_only(reset) => Ok(shape),
        RungShape::Combinational { .. } | RungShape::Latch { .. } => {
            Err("its body's main output reads its state or another output".to_owned())
        }
        RungShape::Opaque { reason } => Err(format!("its body's main output: {reason}")),
        other => Err(format!(
            "its body's main output is a {}: pushed down per instance are combinations and latches",
            other.name()
        )),
    }
}

/// `e` with each variable replaced by `by` (`None`: the whole expression cannot be built).
pub(crate) fn substitute(e: &BoolExpr, by: &dyn Fn(TagId) -> Option<BoolExpr>) -> Option<BoolExpr> {
    let all = |items: &[BoolExpr]| -> Option<Vec<BoolExpr>> {
        items.iter().map(|i| substitute(i, by)).collect()
    };
    Some(match e {
        BoolExpr::Const(b) => BoolExpr::Const(*b),
        BoolExpr::Tag(t) => by(*t)?,
        BoolExpr::Not(inner) => BoolExpr::negate(substitute(inner, by)?),
        BoolExpr::And(items) => BoolExpr::And(all(items)?),
        BoolExpr::Or(items) => BoolExpr::Or(all(items)?),
        BoolExpr::Xor(items) => BoolExpr::Xor(all(items)?),
    })
}
