//! A plain script as a logic-VM program: every top-level statement is `tag = CONDITION;` (or a
//! block call for its effect), so the script means exactly what the VM's flat [`Instr`] list
//! computes, and the scan runs that instead of Rhai's tree walker.
//!
//! A condition is built from bool tags, `true`/`false`, `!`, `&&`, `||`, `&`, `|`, `^`, `==`
//! and `!=` of conditions, comparisons of numbers (numeric tags, literals, `cv(..)`),
//! `good(tag)`/`bad(tag)`, the block calls with a literal instance name (`ton("t", x, 100)`)
//! and the output reads `q`, `qu`, `qd`. The VM evaluates every instruction every scan, in
//! order, so the lowering keeps the script's meaning only where Rhai evaluates everything too;
//! anything else leaves the whole script in the interpreter, with the first reason found:
//!
//! - a block call that `&&`/`||` may skip (`a || ton(..)`): Rhai does not run the timer when
//!   `a` is true, the VM would. Reads under `&&`/`||` are fine: skipping a read changes
//!   nothing;
//! - `good`/`bad` of a tag the script assigns: Rhai answers the quality at the start of the
//!   scan, the VM the current one (a write makes it Good);
//! - an output read (`q("c")`) before its block's call, should a fresh instance's output not
//!   be the `false`/`0` Rhai gives for an instance not created yet (none is today);
//! - `et(..)`: Rhai reads whole milliseconds, the VM the exact time;
//! - control flow, `let`, script functions, arithmetic, strings, other functions, a block
//!   named by an expression, a preset the interpreter would convert at run time;
//! - a script so large that Rhai's operations limit could stop it.
//!
//! Tags are read and written in the image in statement order, which is what the interpreter's
//! scope shows the script: forces are applied after the logic, and a bool is stored exactly,
//! so a statement reads what an earlier one wrote in both. Only the stamp of a write differs
//! (the interpreter writes a tag only when its value changed); `on_vm.rs` puts that back.

use std::collections::{HashMap, HashSet};
use std::fmt;
use std::path::Path;
use std::time::Duration;

use rhai::Position;
use softplc_io::point::ValueType;

use super::blocks::{block_function, MAX_INSTANCES};
use super::error::user_pos;
use super::internals::{self, Call as RhaiCall, Expr, ExprView, Node, Stmt, StmtView, AST};
use crate::image::TagId;
use crate::logic::blocks::{
    from_millis, millis, Instance, Kind, Member, OutputValue, Pattern, Pin, PinType,
};
use crate::logic::expr::TagTable;
use crate::logic::vm::{self, Call, CallSite, CmpOp, Instr, Num, PinArg};

/// Operations Rhai may count per AST node at most (a statement, an expression, each call
/// argument, the call): a script whose nodes times this fit the limit never reaches it.
const OPERATIONS_PER_NODE: u64 = 4;

/// A plain script lowered for the VM.
#[derive(Debug)]
pub(crate) struct Lowered {
    /// The program's parts.
    pub parts: vm::Parts,
    /// Every tag the script assigns, once each, in order of first assignment.
    pub coils: Vec<TagId>,
    /// Every block instance by name, with its index in `parts.instances`.
    pub instances: Vec<(String, u32)>,
}

/// Why a script stays in the interpreter: the first statement or expression the VM cannot
/// run with the same meaning.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Interpreted {
    /// The user's line, when the reason has one.
    pub line: Option<u32>,
    /// What is there, in words (``` `if` ```, ``` `ton(..)` under `||` ```).
    pub what: String,
}

impl fmt::Display for Interpreted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "line {line}: {}", self.what),
            None => f.write_str(&self.what),
        }
    }
}

type Res<T> = Result<T, Interpreted>;

fn refuse<T>(pos: Position, what: impl Into<String>) -> Res<T> {
    Err(Interpreted {
        line: pos
            .line()
            .map(|l| u32::try_from(l.saturating_sub(1).max(1)).unwrap_or(u32::MAX)),
        what: what.into(),
    })
}

/// Lowers `ast` (the user's statements, compiled and checked) if every statement is plain.
/// `operations` is the engine's limit per scan.
pub(crate) fn lower(ast: &AST, tags: &TagTable, operations: u64, file: &Path) -> Res<Lowered> {
    if let Some(f) = ast.iter_functions().next() {
        return Err(Interpreted {
            line: None,
            what: format!("script function `fn {}`", f.name),
        });
    }
    let mut l = Lowerer::new(tags);
    for stmt in internals::statements(ast) {
        l.plan(stmt)?;
    }
    l.name_instances(ast)?;
    let mut nodes = 0u64;
    internals::walk(ast, |_| {
        nodes += 1;
        true
    });
    if nodes.saturating_mul(OPERATIONS_PER_NODE) > operations {
        return Err(Interpreted {
            line: None,
            what: format!("{nodes} expressions, near the operations limit ({operations})"),
        });
    }
    for stmt in internals::statements(ast) {
        l.statement(stmt)?;
    }
    let max_depth = vm::max_depth(&l.code, &l.calls, &[]).unwrap_or(0);
    let highest_tag = l.highest.map(|(id, pos)| (id, user_pos(file, pos)));
    let mut instances: Vec<(String, u32)> = l
        .named
        .iter()
        .map(|(name, &(i, _))| (name.to_string(), i))
        .collect();
    instances.sort_by_key(|&(_, i)| i);
    Ok(Lowered {
        parts: vm::Parts {
            code: l.code,
            calls: l.calls,
            boxes: Vec::new(),
            own_sites: Vec::new(),
            own: Vec::new(),
            edges: 0,
            max_depth,
            instances: l.instances,
            types: vm::tag_types(tags),
            highest_tag,
            rung_pos: Vec::new(),
            file: file.to_path_buf(),
        },
        coils: l.coils,
        instances,
    })
}

/// A timer preset: fixed when the script is compiled, or a numeric tag read when it runs.
enum Time {
    Fixed(Duration),
    Tag(TagId),
}

struct Lowerer<'a> {
    tags: &'a TagTable,
    /// The tags the script assigns, in order of first assignment.
    coils: Vec<TagId>,
    assigned: HashSet<TagId>,
    /// Instance index and kind by name (one call site per instance: the checker's rule).
    named: HashMap<String, (u32, Kind)>,
    /// Instances whose call is already lowered (so runs, every scan, before what follows).
    called: Vec<bool>,
    instances: Vec<Instance>,
    code: Vec<Instr>,
    calls: Vec<CallSite>,
    highest: Option<(TagId, Position)>,
}

impl<'a> Lowerer<'a> {
    fn new(tags: &'a TagTable) -> Self {
        Self {
            tags,
            coils: Vec::new(),
            assigned: HashSet::new(),
            named: HashMap::new(),
            called: Vec::new(),
            instances: Vec::new(),
            code: Vec::new(),
            calls: Vec::new(),
            highest: None,
        }
    }

    /// First pass over a top-level statement: is it plain, and which tag does it assign.
    fn plan(&mut self, stmt: &Stmt) -> Res<()> {
        let what = match internals::stmt(stmt) {
            StmtView::Noop | StmtView::Call(_) | StmtView::Expr(_) => return Ok(()),
            StmtView::Assign(a) => {
                if a.operator.is_some() {
                    return refuse(a.pos, "a compound assignment");
                }
                let ExprView::Var(name, pos) = internals::expr(a.lhs) else {
                    return refuse(internals::position(a.lhs), "an assignment to an element");
                };
                return match self.tags.get(name) {
                    Some(t) if t.writable && t.ty == ValueType::Bool => {
                        if self.assigned.insert(t.id) {
                            self.coils.push(t.id);
                        }
                        Ok(())
                    }
                    Some(t) => refuse(pos, format!("an assignment to {} tag `{}`", t.ty, t.name)),
                    None => refuse(pos, format!("an assignment to `{name}`")),
                };
            }
            StmtView::If(_) => "`if`",
            StmtView::Switch => "`switch`",
            StmtView::While(_) => "`while`",
            StmtView::Do(_) => "`do`",
            StmtView::For(..) => "`for`",
            StmtView::Let(_) => "`let`",
            StmtView::Block => "a block `{ .. }`",
            StmtView::Try => "`try`",
            StmtView::Break => "`break`",
            StmtView::Return => "`return`",
            StmtView::Share(_) | StmtView::Other => "a statement other than an assignment",
        };
        refuse(internals::stmt_position(stmt), what)
    }

    /// Gives every block call with a literal instance name its instance, in script order.
    fn name_instances(&mut self, ast: &AST) -> Res<()> {
        let mut kinds: Vec<(String, Kind)> = Vec::new();
        internals::walk(ast, |node| {
            let Node::Expr(e) = node else {
                return true;
            };
            if let ExprView::Call(call) = internals::expr(e) {
                let kind = block_function(call.name).map(|(def, _)| def.kind);
                let name = call.args.first().map(internals::expr);
                if let (Some(kind), Some(ExprView::Str(name, _))) = (kind, name) {
                    kinds.push((name.to_string(), kind));
                }
            }
            true
        });
        if kinds.len() > MAX_INSTANCES {
            return refuse(
                Position::NONE,
                format!("more than {MAX_INSTANCES} instances"),
            );
        }
        for (name, kind) in kinds {
            if self.named.contains_key(&name) {
                continue;
            }
            let index = self.instances.len() as u32;
            self.named.insert(name, (index, kind));
            self.instances.push(Instance::new(kind));
            self.called.push(false);
        }
        Ok(())
    }

    fn use_tag(&mut self, id: TagId, pos: Position) {
        if self.highest.is_none_or(|(h, _)| id > h) {
            self.highest = Some((id, pos));
        }
    }

    fn statement(&mut self, stmt: &Stmt) -> Res<()> {
        match internals::stmt(stmt) {
            StmtView::Assign(a) => {
                let ExprView::Var(name, pos) = internals::expr(a.lhs) else {
                    return refuse(internals::position(a.lhs), "an assignment to an element");
                };
                let Some(tag) = self.tags.get(name) else {
                    return refuse(pos, format!("an assignment to `{name}`"));
                };
                let id = tag.id;
                self.condition(a.rhs, None)?;
                self.use_tag(id, pos);
                self.code.push(Instr::Store(id));
            }
            StmtView::Call(call) => {
                self.call(call, None)?;
                self.code.push(Instr::Pop);
            }
            StmtView::Expr(e) => {
                self.condition(e, None)?;
                self.code.push(Instr::Pop);
            }
            StmtView::Noop => {}
            _ => {
                let pos = internals::stmt_position(stmt);
                return refuse(pos, "a statement other than an assignment");
            }
        }
        Ok(())
    }

    /// Lowers a bool expression. `skippable` names the `&&`/`||` that may skip it.
    fn condition(&mut self, e: &Expr, skippable: Option<&'static str>) -> Res<()> {
        match internals::expr(e) {
            ExprView::Bool(b) => self.code.push(Instr::Const(b)),
            ExprView::Var(name, pos) => {
                let id = self.tag(name, pos)?;
                if self.tags.get(name).map(|t| t.ty) != Some(ValueType::Bool) {
                    return refuse(pos, format!("`{name}`, a number, as a condition"));
                }
                self.code.push(Instr::Load(id));
            }
            ExprView::And(items) => self.short_circuit(items, Instr::And, "`&&`", skippable)?,
            ExprView::Or(items) => self.short_circuit(items, Instr::Or, "`||`", skippable)?,
            ExprView::Call(call) => self.call(call, skippable)?,
            other => return refuse(internals::start_position(e), describe(other)),
        }
        Ok(())
    }

    /// `a && b && c`: Rhai evaluates `b` and `c` only when needed, so nothing after the first
    /// item may have an effect.
    fn short_circuit(
        &mut self,
        items: &[Expr],
        op: Instr,
        symbol: &'static str,
        skippable: Option<&'static str>,
    ) -> Res<()> {
        for (i, item) in items.iter().enumerate() {
            self.condition(item, if i == 0 { skippable } else { Some(symbol) })?;
            if i > 0 {
                self.code.push(op);
            }
        }
        Ok(())
    }

    fn call(&mut self, call: RhaiCall<'_>, skippable: Option<&'static str>) -> Res<()> {
        let (args, name, pos) = (call.args, call.name, call.pos);
        if call.operator {
            return self.operator(name, args, pos, skippable);
        }
        let views: Vec<ExprView<'_>> = args.iter().map(internals::expr).collect();
        match (name, views.as_slice()) {
            ("good" | "bad", [ExprView::Var(tag, at)]) => {
                let id = self.tag(tag, *at)?;
                if self.assigned.contains(&id) {
                    return refuse(pos, format!("`{name}({tag})` of a tag the script assigns"));
                }
                self.code.push(if name == "good" {
                    Instr::Good(id)
                } else {
                    Instr::Bad(id)
                });
                Ok(())
            }
            ("q" | "qu" | "qd", [ExprView::Str(instance, _)]) => {
                let (i, kind) = self.instance(instance, pos)?;
                let member = match name {
                    "qu" => Member::Qu,
                    "qd" => Member::Qd,
                    _ if kind.main_output() == Member::Qu => Member::Qu,
                    _ => Member::Q,
                };
                self.read_before_call(i, member, name, instance, pos)?;
                self.code.push(Instr::LoadOut(i, member));
                Ok(())
            }
            _ if block_function(name).is_some() => self.block(name, args, pos, skippable),
            _ => refuse(pos, format!("`{name}(..)`")),
        }
    }

    fn operator(
        &mut self,
        op: &str,
        args: &[Expr],
        pos: Position,
        skippable: Option<&'static str>,
    ) -> Res<()> {
        match (op, args) {
            ("!", [a]) => {
                self.condition(a, skippable)?;
                self.code.push(Instr::Not);
            }
            ("&" | "|" | "^", [a, b]) => {
                self.condition(a, skippable)?;
                self.condition(b, skippable)?;
                self.code.push(match op {
                    "&" => Instr::And,
                    "|" => Instr::Or,
                    _ => Instr::Xor,
                });
            }
            ("==" | "!=", [a, b]) if !self.is_number(a) && !self.is_number(b) => {
                self.condition(a, skippable)?;
                self.condition(b, skippable)?;
                self.code.push(Instr::Xor);
                if op == "==" {
                    self.code.push(Instr::Not);
                }
            }
            ("<" | "<=" | ">" | ">=" | "==" | "!=", [a, b]) => {
                let op = match op {
                    "<" => CmpOp::Lt,
                    "<=" => CmpOp::Le,
                    ">" => CmpOp::Gt,
                    ">=" => CmpOp::Ge,
                    "==" => CmpOp::Eq,
                    _ => CmpOp::Ne,
                };
                let lhs = self.number(a)?;
                let rhs = self.number(b)?;
                self.code.push(Instr::Cmp { lhs, op, rhs });
            }
            _ => return refuse(pos, format!("`{op}`")),
        }
        Ok(())
    }

    /// Whether `e` is written as a number (a comparison's operand rather than a condition).
    fn is_number(&self, e: &Expr) -> bool {
        match internals::expr(e) {
            ExprView::Int(..) | ExprView::Float(_) => true,
            ExprView::Var(name, _) => self.tags.get(name).is_some_and(|t| t.ty != ValueType::Bool),
            ExprView::Call(call) => {
                matches!(call.name, "cv" | "et")
                    || (call.operator && call.name == "-" && call.args.len() == 1)
            }
            _ => false,
        }
    }

    /// A comparison's operand: Rhai compares integers and floats as the VM's `f64` does, as
    /// long as an integer is exact in `f64` (tags are; literals are checked).
    fn number(&mut self, e: &Expr) -> Res<Num> {
        match internals::expr(e) {
            ExprView::Int(i, pos) => Ok(Num::Const(exact(i, pos)?)),
            ExprView::Float(f) => Ok(Num::Const(f)),
            ExprView::Var(name, pos) => Ok(Num::Tag(self.numeric_tag(
                name,
                pos,
                "compared as a number",
            )?)),
            ExprView::Call(call) if call.operator => {
                let arg = call.args.first().map(internals::expr);
                match (call.name, call.args.len(), arg) {
                    ("-", 1, Some(ExprView::Int(i, at))) => Ok(Num::Const(-exact(i, at)?)),
                    ("-", 1, Some(ExprView::Float(f))) => Ok(Num::Const(-f)),
                    (op, _, _) => refuse(call.pos, format!("`{op}`")),
                }
            }
            ExprView::Call(call) => {
                let arg = call.args.first().map(internals::expr);
                match (call.name, call.args.len(), arg) {
                    ("cv", 1, Some(ExprView::Str(instance, _))) => {
                        let (i, _) = self.instance(instance, call.pos)?;
                        self.read_before_call(i, Member::Cv, "cv", instance, call.pos)?;
                        Ok(Num::Out(i, Member::Cv))
                    }
                    ("et", _, _) => refuse(
                        call.pos,
                        "`et(..)` (the interpreter reads whole milliseconds)",
                    ),
                    (name, _, _) => refuse(call.pos, format!("`{name}(..)`")),
                }
            }
            other => refuse(internals::start_position(e), describe(other)),
        }
    }

    fn tag(&mut self, name: &str, pos: Position) -> Res<TagId> {
        match self.tags.get(name) {
            Some(t) => {
                self.use_tag(t.id, pos);
                Ok(t.id)
            }
            None => refuse(pos, format!("`{name}`, not a tag")),
        }
    }

    /// A tag used as a number (`use_as` says how, for the refusal): a bool tag is refused.
    fn numeric_tag(&mut self, name: &str, pos: Position, use_as: &str) -> Res<TagId> {
        let id = self.tag(name, pos)?;
        match self.tags.get(name).map(|t| t.ty) {
            Some(ValueType::Bool) | None => refuse(pos, format!("`{name}`, a bool, {use_as}")),
            Some(_) => Ok(id),
        }
    }

    fn instance(&self, name: &str, pos: Position) -> Res<(u32, Kind)> {
        match self.named.get(name) {
            Some(&found) => Ok(found),
            None => refuse(pos, format!("instance \"{name}\" without a call")),
        }
    }

    /// An output read before its block's call, on the first scan, finds no instance in the
    /// interpreter (`false`, `0`) and a fresh one in the VM: the same only if the fresh
    /// instance's output is `false`/`0`.
    fn read_before_call(
        &self,
        i: u32,
        member: Member,
        reader: &str,
        name: &str,
        pos: Position,
    ) -> Res<()> {
        let called = self.called.get(i as usize).copied().unwrap_or(false);
        let fresh = self
            .instances
            .get(i as usize)
            .map(|inst| inst.output(member));
        let unset = matches!(
            fresh,
            Some(OutputValue::Bool(false) | OutputValue::Count(0))
        );
        if called || unset {
            Ok(())
        } else {
            refuse(
                pos,
                format!(
                    "`{reader}(\"{name}\")` before the block's call (a fresh one reads otherwise)"
                ),
            )
        }
    }

    /// A block call: its bool arguments in order, then the call.
    fn block(
        &mut self,
        function: &str,
        args: &[Expr],
        pos: Position,
        skippable: Option<&'static str>,
    ) -> Res<()> {
        if let Some(op) = skippable {
            return refuse(
                pos,
                format!("`{function}(..)` under {op} (the interpreter skips the call when {op} is decided)"),
            );
        }
        let named = args
            .split_first()
            .map(|(first, rest)| (internals::expr(first), rest));
        let Some((ExprView::Str(name, _), rest)) = named else {
            return refuse(
                pos,
                format!("`{function}(..)` with an instance named by an expression"),
            );
        };
        let (inst, _) = self.instance(name, pos)?;
        let unfit = || refuse(pos, format!("`{function}(..)` with these arguments"));
        let Some((def, form)) = block_function(function) else {
            return unfit();
        };
        let arity = form.pins.len() - form.optional..=form.pins.len();
        let pins: Vec<(usize, &Pin, Option<&Expr>)> = form
            .pins
            .iter()
            .enumerate()
            .filter_map(|(j, &i)| Some((i, def.pins.get(i)?, rest.get(j))))
            .collect();
        let pattern_literal = |(_, pin, arg): &(usize, &Pin, Option<&Expr>)| {
            pin.ty != PinType::Pattern
                || matches!(arg.map(internals::expr), Some(ExprView::Str(..)))
        };
        if !arity.contains(&rest.len()) || !pins.iter().all(pattern_literal) {
            return unfit();
        }
        let instr = match (def.is_plain_timer(), rest) {
            (true, [x, pt]) => {
                self.condition(x, None)?;
                match self.time(pt)? {
                    Time::Fixed(preset) => Instr::Timer {
                        timer: inst,
                        preset,
                    },
                    Time::Tag(id) => {
                        let mut call = Call::new(def.kind);
                        call.pins[1] = PinArg::Num(Num::Tag(id));
                        self.site(CallSite {
                            inst,
                            call,
                            bools: 0,
                        })
                    }
                }
            }
            _ => {
                // The bools first, in pin order (the VM pops them so), then the values.
                let mut call = Call::new(def.kind);
                let mut bools = 0;
                for &(i, pin, arg) in &pins {
                    if pin.ty == PinType::Bool {
                        match arg {
                            Some(x) => self.condition(x, None)?,
                            None => self.code.push(Instr::Const(false)),
                        }
                        bools += u8::from(i > 0);
                        call.pins[i] = PinArg::Stack;
                    }
                }
                for &(i, pin, arg) in &pins {
                    let Some(arg) = arg else { continue };
                    call.pins[i] = match (pin.ty, internals::expr(arg)) {
                        (PinType::Bool, _) => continue,
                        (PinType::Time, _) => PinArg::Num(self.time_num(arg)?),
                        (PinType::Count | PinType::Mask, _) => PinArg::Num(self.count(arg)?),
                        (PinType::Pattern, ExprView::Str(bits, at)) => match Pattern::parse(bits) {
                            Ok(pattern) => PinArg::Pattern(pattern),
                            Err(_) => return refuse(at, format!("pattern \"{bits}\"")),
                        },
                        (PinType::Pattern, _) => return unfit(),
                    };
                }
                self.site(CallSite { inst, call, bools })
            }
        };
        self.code.push(instr);
        if let Some(c) = self.called.get_mut(inst as usize) {
            *c = true;
        }
        Ok(())
    }

    fn site(&mut self, site: CallSite) -> Instr {
        self.calls.push(site);
        Instr::Call((self.calls.len() - 1) as u32)
    }

    /// A time argument as the interpreter reads it (`blocks::time`): milliseconds, a
    /// duration string, or a numeric tag's value in milliseconds.
    fn time(&mut self, e: &Expr) -> Res<Time> {
        match internals::expr(e) {
            ExprView::Int(i, _) => Ok(Time::Fixed(from_millis(i as f64))),
            ExprView::Float(f) => Ok(Time::Fixed(from_millis(f))),
            ExprView::Str(s, pos) => match crate::project::parse_duration(s) {
                Ok(d) => Ok(Time::Fixed(d)),
                Err(_) => refuse(pos, format!("duration \"{s}\"")),
            },
            ExprView::Call(call)
                if call.operator
                    && call.name == "-"
                    && call.args.len() == 1
                    && matches!(
                        call.args.first().map(internals::expr),
                        Some(ExprView::Int(..) | ExprView::Float(_))
                    ) =>
            {
                Ok(Time::Fixed(Duration::ZERO))
            }
            ExprView::Var(name, pos) => Ok(Time::Tag(self.numeric_tag(name, pos, "as a time")?)),
            other => refuse(
                internals::start_position(e),
                format!("{} as a time", describe(other)),
            ),
        }
    }

    /// A time argument as a number of milliseconds for a block call site, which the VM turns
    /// back into a duration: only where that gives the interpreter's duration exactly.
    fn time_num(&mut self, e: &Expr) -> Res<Num> {
        match self.time(e)? {
            Time::Tag(id) => Ok(Num::Tag(id)),
            Time::Fixed(d) if from_millis(millis(d)) == d => Ok(Num::Const(millis(d))),
            Time::Fixed(_) => refuse(
                internals::start_position(e),
                "a time finer than the VM's milliseconds keep",
            ),
        }
    }

    /// A counter's preset: Rhai takes an integer only, saturated into `i32`.
    fn count(&mut self, e: &Expr) -> Res<Num> {
        match internals::expr(e) {
            ExprView::Int(i, _) => Ok(Num::Const(f64::from(
                i.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
            ))),
            ExprView::Var(name, pos) => {
                let id = self.tag(name, pos)?;
                match self.tags.get(name).map(|t| t.ty) {
                    Some(ValueType::U16 | ValueType::I32) => Ok(Num::Tag(id)),
                    _ => refuse(pos, format!("`{name}` as a count")),
                }
            }
            other => refuse(
                internals::start_position(e),
                format!("{} as a count", describe(other)),
            ),
        }
    }
}

/// An integer literal as an exact `f64`.
fn exact(i: i64, pos: Position) -> Res<f64> {
    const EXACT: i64 = 1 << 53;
    if (-EXACT..=EXACT).contains(&i) {
        Ok(i as f64)
    } else {
        refuse(pos, format!("{i}, larger than a float holds exactly"))
    }
}

/// An expression the lowering does not take, in words.
fn describe(e: ExprView<'_>) -> String {
    match e {
        ExprView::Int(..) | ExprView::Float(_) => "a number as a condition".into(),
        ExprView::Str(..) | ExprView::Interpolated | ExprView::Char => "a string".into(),
        ExprView::Array => "an array".into(),
        ExprView::Map => "a map".into(),
        ExprView::Unit => "`()`".into(),
        ExprView::Block => "a block expression".into(),
        ExprView::Index => "indexing".into(),
        ExprView::Property | ExprView::Method(_) => "a method call".into(),
        ExprView::Call(call) => format!("`{}`", call.name),
        ExprView::Bool(_) | ExprView::Var(..) | ExprView::And(_) | ExprView::Or(_) => {
            "an expression other than a condition".into()
        }
        ExprView::Other => "an expression other than a condition".into(),
    }
}
