//! The push-down view of a script: each output it assigns as a [`Rung`] of the offload IR.
//!
//! A Rhai assignment may sit in any control flow and read any variable; the planner is given
//! a shape only for the plain form, which behaves as the `expr` statement of the same text:
//!
//! - a top-level statement `c = E;` (not inside `if`, a loop or a function), the only
//!   assignment of `c` in the script;
//! - `E` built from bool tags, `true`/`false`, `!`, `&&`, `||` and `^` only; every tag it reads
//!   is one the script never assigns, or `c` itself (read before the assignment: the previous
//!   scan's value, as in `expr`).
//!
//! One block call has a form too: `c = lamp("name", E, MASK);` (top level, assigned once, `E`
//! as above and not reading `c`, `MASK` an integer literal in 0..=65535, the instance named
//! nowhere else in the script) is the module's blinker, [`RungShape::Lamp`], as the ladder
//! rung `E -> LAMP name(MASK) -> c`.
//!
//! `E` has no side effect and `&&`/`||` only skip reads of tags, so evaluating it is the
//! `expr` condition's evaluation; `c = E` reading `c` is then a latch exactly when
//! [`RungShape::self_latch`] says so, otherwise it is combinational. Every other output the
//! script writes is [`RungShape::Opaque`], with the reason.
//!
//! Once the module runs a rung, [`super::RhaiProgram`]'s `release` drops the statement from
//! the script: the tag's variable then holds the module's value read back into the image, for
//! the statements after it, as an `expr` program's later rungs read it.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use rhai::Position;
use softplc_io::point::ValueType;

use super::error::user_pos;
use super::internals::{self, Expr, ExprView, Node, StmtView, AST};
use crate::image::TagId;
use crate::logic::blocks::Kind;
use crate::logic::expr::TagTable;
use crate::logic::Rung;
use softplc_io::rung::{BoolExpr, RungShape};

/// Why an assigned output is not a plain form (the report's and `offload: require`'s reason).
pub const NOT_PLAIN: &str = "a Rhai assignment other than a plain condition: the planner \
     moves `c = E;` at the top level, assigned once, with E of bool tags the script does not \
     write, `!`, `&&`, `||`, `^`";

/// The script's rungs, and the top-level statement index of each one the planner may move.
#[derive(Debug, Default)]
pub(crate) struct Described {
    pub rungs: Vec<Rung>,
    pub statements: HashMap<TagId, usize>,
}

/// Describes every output of `written` (the tags the script assigns, with their first
/// assignment) in `ast`.
pub(crate) fn describe(
    ast: &AST,
    tags: &TagTable,
    written: &[(TagId, Position)],
    file: &Path,
) -> Described {
    let mut assignments: HashMap<String, usize> = HashMap::new();
    let mut declared: HashSet<String> = HashSet::new();
    // How many calls name each block instance (`q("w")` reads one).
    let mut instances: HashMap<String, usize> = HashMap::new();
    internals::walk(ast, |node| {
        let s = match node {
            Node::Stmt(s) => s,
            Node::Expr(e) => {
                if let ExprView::Call(call) = internals::expr(e) {
                    if let Some(ExprView::Str(name, _)) = call.args.first().map(internals::expr) {
                        *instances.entry(name.to_string()).or_default() += 1;
                    }
                }
                return true;
            }
        };
        match internals::stmt(s) {
            StmtView::Assign(a) => {
                if let ExprView::Var(name, _) = internals::expr(a.lhs) {
                    *assignments.entry(name.to_string()).or_default() += 1;
                }
            }
            StmtView::Let(name) | StmtView::For(name, _) => {
                declared.insert(name.to_string());
            }
            _ => {}
        }
        true
    });
    let plain = Plain {
        tags,
        assignments: &assignments,
        declared: &declared,
        instances: &instances,
    };
    let mut out = Described::default();
    let mut shapes: HashMap<TagId, (RungShape, usize)> = HashMap::new();
    for (i, stmt) in internals::statements(ast).iter().enumerate() {
        let StmtView::Assign(a) = internals::stmt(stmt) else {
            continue;
        };
        let ExprView::Var(name, _) = internals::expr(a.lhs) else {
            continue;
        };
        let Some(coil) = tags
            .get(name)
            .filter(|t| t.writable && t.ty == ValueType::Bool)
        else {
            continue;
        };
        if a.operator.is_some() || assignments.get(name) != Some(&1) || declared.contains(name) {
            continue;
        }
        if let Some(ir) = plain.condition(a.rhs, coil.id) {
            let shape = if ir.reads(coil.id) {
                RungShape::self_latch(coil.id, &ir)
            } else {
                RungShape::Combinational { expr: ir }
            };
            shapes.insert(coil.id, (shape, i));
        } else if let Some(shape) = plain.lamp(a.rhs, coil.id) {
            shapes.insert(coil.id, (shape, i));
        }
    }
    let mut written = written.to_vec();
    written.sort_by_key(|(_, at)| (at.line(), at.position()));
    for (coil, at) in written {
        let shape = match shapes.remove(&coil) {
            Some((shape, i)) => {
                out.statements.insert(coil, i);
                shape
            }
            None => RungShape::Opaque {
                reason: NOT_PLAIN.to_string(),
            },
        };
        out.rungs.push(Rung {
            coil,
            shape,
            pos: user_pos(file, at),
            // A Rhai statement has no title: see docs/programming.md, "Documenting a program".
            title: None,
        });
    }
    out
}

/// What the plain form may read.
struct Plain<'a> {
    tags: &'a TagTable,
    assignments: &'a HashMap<String, usize>,
    declared: &'a HashSet<String>,
    instances: &'a HashMap<String, usize>,
}

impl Plain<'_> {
    /// `lamp("name", E, MASK)` as the module's blinker, if it is that form for coil `coil`.
    fn lamp(&self, expr: &Expr, coil: TagId) -> Option<RungShape> {
        let ExprView::Call(call) = internals::expr(expr) else {
            return None;
        };
        if call.operator || call.name != Kind::Lamp.def().function() {
            return None;
        }
        let [name, enable, mask] = call.args else {
            return None;
        };
        let ExprView::Str(name, _) = internals::expr(name) else {
            return None;
        };
        // Once the module runs it the call leaves the script: nothing else may read it.
        if self.instances.get(name) != Some(&1) {
            return None;
        }
        let ExprView::Int(mask, _) = internals::expr(mask) else {
            return None;
        };
        let mask = u16::try_from(mask).ok()?;
        let enable = self.condition(enable, coil).filter(|e| !e.reads(coil))?;
        Some(RungShape::Lamp { enable, mask })
    }

    /// `expr` as an IR condition, if it is one of the plain form for coil `coil`.
    fn condition(&self, expr: &Expr, coil: TagId) -> Option<BoolExpr> {
        let all = |items: &[Expr]| -> Option<Vec<BoolExpr>> {
            items.iter().map(|e| self.condition(e, coil)).collect()
        };
        Some(match internals::expr(expr) {
            ExprView::Bool(b) => BoolExpr::Const(b),
            ExprView::Var(name, _) => {
                let tag = self.tags.get(name)?;
                let unwritten = !self.assignments.contains_key(name);
                if tag.ty != ValueType::Bool
                    || self.declared.contains(name)
                    || !(unwritten || tag.id == coil)
                {
                    return None;
                }
                BoolExpr::Tag(tag.id)
            }
            ExprView::And(items) => BoolExpr::And(all(items)?),
            ExprView::Or(items) => BoolExpr::Or(all(items)?),
            ExprView::Call(call) if call.operator => match (call.name, call.args) {
                ("!", [inner]) => BoolExpr::negate(self.condition(inner, coil)?),
                ("^", [a, b]) => {
                    BoolExpr::Xor(vec![self.condition(a, coil)?, self.condition(b, coil)?])
                }
                _ => return None,
            },
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;
    use std::time::Duration;

    use super::*;
    use crate::image::ProcessImage;
    use crate::logic::rhai::{compile, tests::table};
    use crate::logic::{LogicEngine, ScanContext};
    use softplc_io::point::Value;
    use softplc_io::time::ScanInstant;

    fn id(name: &str) -> TagId {
        table().get(name).expect("a tag").id
    }

    /// `(coil, shape name)` of every rung of `script`.
    fn shapes(script: &str) -> Vec<(String, &'static str)> {
        let p = compile(
            script,
            Path::new("s.rhai"),
            &table(),
            Duration::from_secs(1),
        )
        .unwrap();
        let names = table();
        p.rungs()
            .unwrap()
            .iter()
            .map(|r| {
                let name = names.iter().find(|t| t.id == r.coil).unwrap().name.clone();
                (name, r.shape.name())
            })
            .collect()
    }

    #[test]
    fn plain_forms_have_shapes_and_everything_else_is_opaque() {
        assert_eq!(
            shapes("motor = (start || motor) && !stop;\nlamp = start ^ stop;\n"),
            [
                ("motor".into(), "set/reset latch"),
                ("lamp".into(), "combinational")
            ]
        );
        for script in [
            "if count > 0 { lamp = start; }\n",        // control flow
            "lamp = start;\nlamp = stop;\n",           // assigned twice
            "motor = start;\nlamp = motor && stop;\n", // reads a tag the script writes
            "lamp = ton(\"t\", start, 100);\n",        // a block
            "lamp = level > 2;\n",                     // a comparison
            "let x = start;\nlamp = x;\n",             // a variable
            "lamp = !lamp;\n",                         // inverts itself: no latch
            "fn f() { 1 }\nlamp = start;\nlamp = f() > 0;\n",
        ] {
            let last = shapes(script).pop().unwrap();
            assert_eq!(last, ("lamp".into(), "other"), "{script}");
        }
        assert_eq!(
            shapes("lamp = lamp(\"w\", start && !stop, 3855);\n"),
            [("lamp".into(), "free-running blinker (LAMP)")]
        );
        for script in [
            "lamp = lamp(\"w\", start, count);\n", // a mask read from a tag
            "lamp = lamp(\"w\", lamp, 3855);\n",   // reads its own coil
            "lamp = lamp(\"w\", start, 3855);\nmotor = q(\"w\");\n", // read elsewhere
        ] {
            assert_eq!(shapes(script)[0], ("lamp".into(), "other"), "{script}");
        }
        assert_eq!(
            shapes("motor = start;\nlamp = motor && stop;\n")[0],
            ("motor".into(), "combinational")
        );
    }

    #[test]
    fn a_released_rung_leaves_the_script_and_later_statements_read_the_module() {
        let mut p = compile(
            "lamp = start;\ncount = if lamp { 1 } else { 2 };\n",
            Path::new("s.rhai"),
            &table(),
            Duration::from_secs(1),
        )
        .unwrap();
        let names = table();
        let mut image = ProcessImage::new(names.iter().map(|t| (t.name.clone(), t.ty.zero())));
        let ctx = ScanContext {
            now: ScanInstant::ZERO,
            delta: Duration::from_millis(10),
            cycle: 0,
        };
        image.set(id("start"), Value::Bool(true), ScanInstant::ZERO);
        p.scan(&mut image, &ctx).unwrap();
        assert_eq!(image.get(id("lamp")), Value::Bool(true));
        assert_eq!(image.get(id("count")), Value::I32(1));
        p.release(id("lamp"));
        // The module's read-back says off: the script no longer writes it, and reads it.
        image.set(id("lamp"), Value::Bool(false), ScanInstant::ZERO);
        p.scan(&mut image, &ctx).unwrap();
        assert_eq!(image.get(id("lamp")), Value::Bool(false));
        assert_eq!(image.get(id("count")), Value::I32(2));
    }
}
