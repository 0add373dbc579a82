//! Checker: resolves tags and instances, checks types, arguments and drivers, and turns parsed
//! rungs into typed ones over [`TagId`]s and instance indexes. Reports every error it finds.

use std::collections::HashMap;
use std::time::Duration;

use softplc_io::point::ValueType;

use super::error::{CompileErrorKind, Driver, Expected, TypeError};
use super::parser::{Action, Arg, BoxCall, Coil, CoilKind, Cond, Lit, Name, Output, Ref, Rung};
use crate::image::TagId;
use crate::logic::blocks::{millis, Form, Kind, Member, Pattern, PinType};
use crate::logic::expr::TagTable;
use crate::logic::vm::{BoxOp, Call, CmpOp, Num, PinArg};

/// An error: rung index, character index, kind.
pub(crate) type Error = (usize, usize, CompileErrorKind);

/// A checked condition. `Good(t)` / `Bad(t)`: tag `t`'s quality is Good / Bad (`good(t)`,
/// `bad(t)`).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum BoolExpr {
    Load(TagId),
    Out(u32, Member),
    Const(bool),
    Not(Box<BoolExpr>),
    And(Vec<BoolExpr>),
    Or(Vec<BoolExpr>),
    Edge { rising: bool, arg: Box<BoolExpr> },
    Cmp { lhs: Num, op: CmpOp, rhs: Num },
    Good(TagId),
    Bad(TagId),
}

impl BoxOp {
    const ALL: [(&'static str, BoxOp, usize); 6] = [
        ("MOVE", BoxOp::Move, 1),
        ("ADD", BoxOp::Add, 2),
        ("SUB", BoxOp::Sub, 2),
        ("MUL", BoxOp::Mul, 2),
        ("DIV", BoxOp::Div, 2),
        ("LIMIT", BoxOp::Limit, 3),
    ];
}

/// A checked output.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum COut {
    Coil(CoilKind, TagId),
    Box {
        op: BoxOp,
        args: [Num; 3],
        dest: TagId,
    },
}

/// A checked action.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum CAction {
    Outputs(Vec<COut>),
    Block {
        inst: u32,
        call: Call,
        bools: Vec<BoolExpr>,
        coils: Vec<(CoilKind, TagId)>,
    },
}

/// A checked rung.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CRung {
    /// Index in the file.
    pub index: usize,
    pub cond: BoolExpr,
    pub action: CAction,
}

/// The instances a program declares, by call.
#[derive(Debug, Clone, Default)]
pub(crate) struct Instances {
    /// Name → (index, kind, rung that calls it).
    by_name: HashMap<String, (u32, Kind, usize)>,
    /// Kinds, by index.
    pub kinds: Vec<Kind>,
}

/// Checks parsed rungs (`(rung index, rung)`); `line_of` gives a rung's first line.
pub(crate) fn check(
    rungs: &[(usize, Rung)],
    tags: &TagTable,
    line_of: &dyn Fn(usize) -> u32,
    errors: &mut Vec<Error>,
) -> (Vec<CRung>, Instances) {
    let mut c = Checker {
        tags,
        insts: Instances::default(),
        errors,
        rung: 0,
        line_of,
    };
    c.declare(rungs, line_of);
    let mut drivers: HashMap<TagId, (Driver, u32)> = HashMap::new();
    let mut out = Vec::with_capacity(rungs.len());
    for (index, rung) in rungs {
        c.rung = *index;
        let cond = match &rung.cond {
            Some(cond) => c.boolean(cond),
            None => Some(BoolExpr::Const(true)),
        };
        let action = c.action(&rung.action, &mut drivers, line_of(*index));
        if let (Some(cond), Some(action)) = (cond, action) {
            out.push(CRung {
                index: *index,
                cond,
                action,
            });
        }
    }
    (out, c.insts)
}

struct Checker<'a> {
    tags: &'a TagTable,
    insts: Instances,
    errors: &'a mut Vec<Error>,
    rung: usize,
    /// The first line of a rung.
    line_of: &'a dyn Fn(usize) -> u32,
}

/// The names of `kind`'s arguments, in order, each with whether it is a bool input (a power
/// flow, drawn as a wire into the block) and whether it may be given by position.
pub(crate) fn param_list(kind: Kind) -> impl Iterator<Item = (&'static str, bool, bool)> {
    kind.def()
        .arguments()
        .iter()
        .map(|p| (p.name, p.ty == PinType::Bool, p.positional))
}

/// A checked argument value.
#[derive(Debug, Clone)]
enum Value {
    Num(Num),
    Bool(BoolExpr),
    Pattern(Pattern),
}

impl Instances {
    /// The instance named `name`: its index and kind.
    pub(crate) fn get(&self, name: &str) -> Option<(u32, Kind)> {
        self.by_name.get(name).map(|&(i, k, _)| (i, k))
    }
}

impl Checker<'_> {
    fn fail<T>(&mut self, pos: usize, kind: impl Into<CompileErrorKind>) -> Option<T> {
        self.errors.push((self.rung, pos, kind.into()));
        None
    }

    /// Pass 1: every block call declares its instance.
    fn declare(&mut self, rungs: &[(usize, Rung)], line_of: &dyn Fn(usize) -> u32) {
        for (index, rung) in rungs {
            self.rung = *index;
            let Action::Block { call, .. } = &rung.action else {
                continue;
            };
            let Some(kind) = self.kind(&call.kind) else {
                continue;
            };
            let name = &call.instance;
            if self.tags.get(&name.text).is_some() {
                let kind = CompileErrorKind::InstanceIsTag {
                    name: name.text.clone(),
                };
                self.fail::<()>(name.pos, kind);
                continue;
            }
            if let Some(&(_, _, first)) = self.insts.by_name.get(&name.text) {
                let kind = CompileErrorKind::InstanceCalledTwice {
                    name: name.text.clone(),
                    first_line: line_of(first),
                };
                self.fail::<()>(name.pos, kind);
                continue;
            }
            let i = self.insts.kinds.len() as u32;
            self.insts.kinds.push(kind);
            self.insts
                .by_name
                .insert(name.text.clone(), (i, kind, *index));
        }
    }

    fn kind(&mut self, name: &Name) -> Option<Kind> {
        if let Some(k) = Kind::parse(&name.text) {
            return Some(k);
        }
        let upper = name.text.to_ascii_uppercase();
        let suggestion = Kind::parse(&upper)
            .map(|k| k.name().to_string())
            .or_else(|| closest(&name.text, Kind::ALL.iter().map(|k| k.name())));
        self.fail(
            name.pos,
            CompileErrorKind::UnknownBlock {
                name: name.text.clone(),
                suggestion,
            },
        )
    }

    fn unknown_tag<T>(&mut self, name: &Name) -> Option<T> {
        let suggestion = if let Some(&(_, kind, _)) = self.insts.by_name.get(&name.text) {
            Some(format!("{}.{}", name.text, kind.main_output()))
        } else {
            closest(&name.text, self.tags.iter().map(|t| t.name.as_str()))
        };
        self.undeclared(name, suggestion)
    }

    /// One error per unknown name, at its first use; later uses add their rung's line to it.
    fn undeclared<T>(&mut self, name: &Name, suggestion: Option<String>) -> Option<T> {
        let line_of = self.line_of;
        let line = line_of(self.rung);
        let uses = self.errors.iter_mut().filter_map(|(rung, _, k)| match k {
            CompileErrorKind::UnknownTag { name, also, .. } => {
                Some((name.as_str(), line_of(*rung), also))
            }
            _ => None,
        });
        if crate::logic::undeclared::seen_before(uses, &name.text, line) {
            return None;
        }
        self.fail(
            name.pos,
            CompileErrorKind::UnknownTag {
                name: name.text.clone(),
                suggestion,
                also: Vec::new(),
            },
        )
    }

    /// A reference as a typed source: a tag (with its type) or an instance output.
    fn reference(&mut self, r: &Ref) -> Option<(Num, Option<ValueType>, String)> {
        match &r.member {
            None => match self.tags.get(&r.name.text) {
                Some(e) => Some((Num::Tag(e.id), Some(e.ty), r.name.text.clone())),
                None => self.unknown_tag(&r.name),
            },
            Some(member) => {
                let Some(&(i, kind, _)) = self.insts.by_name.get(&r.name.text) else {
                    let suggestion =
                        closest(&r.name.text, self.insts.by_name.keys().map(String::as_str));
                    return self.fail(
                        r.name.pos,
                        CompileErrorKind::UnknownInstance {
                            name: r.name.text.clone(),
                            suggestion,
                        },
                    );
                };
                match Member::parse(&member.text.to_ascii_uppercase()) {
                    Some(m) if kind.outputs().contains(&m) => Some((
                        Num::Out(i, m),
                        None,
                        format!("{}.{}", r.name.text, m.name()),
                    )),
                    _ => self.fail(
                        member.pos,
                        CompileErrorKind::UnknownMember {
                            instance: r.name.text.clone(),
                            kind,
                            member: member.text.clone(),
                        },
                    ),
                }
            }
        }
    }

    /// A condition.
    fn boolean(&mut self, cond: &Cond) -> Option<BoolExpr> {
        match cond {
            Cond::Ref(r) => {
                let (src, ty, name) = self.reference(r)?;
                match (src, ty) {
                    (Num::Tag(id), Some(ValueType::Bool)) => Some(BoolExpr::Load(id)),
                    (Num::Tag(_), Some(ty)) => self.fail(
                        r.name.pos,
                        TypeError::NumberAsContact {
                            name,
                            ty: ty.name(),
                        },
                    ),
                    (Num::Out(i, m), _) if m.is_bool() => Some(BoolExpr::Out(i, m)),
                    _ => self.fail(
                        r.name.pos,
                        TypeError::NumberAsContact {
                            name,
                            ty: "a number",
                        },
                    ),
                }
            }
            Cond::Lit(lit, pos) => match lit {
                Lit::Bool(b) => Some(BoolExpr::Const(*b)),
                Lit::Number { text, .. } if text == "0" => Some(BoolExpr::Const(false)),
                Lit::Number { text, .. } if text == "1" => Some(BoolExpr::Const(true)),
                Lit::Number { text, .. } | Lit::Duration { text } => {
                    self.fail(*pos, TypeError::LiteralAsContact { text: text.clone() })
                }
            },
            Cond::Not(inner) => Some(BoolExpr::Not(Box::new(self.boolean(inner)?))),
            Cond::Series(items) => self.all(items).map(BoolExpr::And),
            Cond::Parallel(items) => self.all(items).map(BoolExpr::Or),
            Cond::Edge { rising, arg } => Some(BoolExpr::Edge {
                rising: *rising,
                arg: Box::new(self.boolean(arg)?),
            }),
            // Any tag has a quality, whatever its type; block outputs have none.
            Cond::Quality { good, tag, .. } => {
                let Some(e) = self.tags.get(&tag.text) else {
                    let suggestion = closest(&tag.text, self.tags.iter().map(|t| t.name.as_str()));
                    return self.undeclared(tag, suggestion);
                };
                Some(if *good {
                    BoolExpr::Good(e.id)
                } else {
                    BoolExpr::Bad(e.id)
                })
            }
            Cond::Cmp { lhs, op, rhs, .. } => {
                let l = self.number(lhs);
                let r = self.number(rhs);
                let ((l, lty), (r, rty)) = (l?, r?);
                for (lit, tag, ty) in [(rhs, lhs, lty), (lhs, rhs, rty)] {
                    if let (Cond::Ref(r), Some(ty)) = (tag.as_ref(), ty) {
                        self.literal_into(lit, ty, || format!("`{}`", r.name.text))?;
                    }
                }
                match (l, r) {
                    (Num::Const(_), Num::Const(_)) => {
                        self.fail(lhs.pos(), TypeError::ConstantComparison)
                    }
                    _ => Some(BoolExpr::Cmp {
                        lhs: round_for(l, rty),
                        op: *op,
                        rhs: round_for(r, lty),
                    }),
                }
            }
        }
    }

    fn all(&mut self, items: &[Cond]) -> Option<Vec<BoolExpr>> {
        let checked: Vec<Option<BoolExpr>> = items.iter().map(|c| self.boolean(c)).collect();
        checked.into_iter().collect()
    }

    /// A number: a literal, a duration (ms), a numeric tag or a numeric output; with the tag's
    /// type, for rounding literals compared with f32 tags.
    fn number(&mut self, cond: &Cond) -> Option<(Num, Option<ValueType>)> {
        match cond {
            Cond::Lit(Lit::Number { value, .. }, _) => Some((Num::Const(*value), None)),
            Cond::Lit(Lit::Duration { text }, pos) => {
                let d = self.duration(text, *pos)?;
                Some((Num::Const(millis(d)), None))
            }
            Cond::Ref(r) => {
                let (src, ty, name) = self.reference(r)?;
                match (src, ty) {
                    (Num::Tag(_), Some(ValueType::Bool)) => {
                        self.fail(r.name.pos, TypeError::BoolAsNumber { name })
                    }
                    (Num::Out(_, m), _) if m.is_bool() => {
                        self.fail(r.name.pos, TypeError::BoolAsNumber { name })
                    }
                    _ => Some((src, ty)),
                }
            }
            other => self.fail(other.pos(), TypeError::ConditionAsNumber),
        }
    }

    /// `cond`, when it is a number literal, as a value of type `ty` (`target` names what it
    /// meets, for the error).
    fn literal_into(
        &mut self,
        cond: &Cond,
        ty: ValueType,
        target: impl FnOnce() -> String,
    ) -> Option<()> {
        match cond {
            Cond::Lit(Lit::Number { value, text }, pos)
                if !crate::logic::expr::literal_fits(*value, ty) =>
            {
                let kind = TypeError::LiteralOutOfType {
                    text: text.clone(),
                    target: target(),
                    ty,
                };
                self.fail(*pos, kind)
            }
            _ => Some(()),
        }
    }

    fn duration(&mut self, text: &str, pos: usize) -> Option<Duration> {
        match crate::project::parse_duration(text) {
            Ok(d) => Some(d),
            Err(reason) => self.fail(
                pos,
                CompileErrorKind::BadDuration {
                    text: text.to_string(),
                    reason,
                },
            ),
        }
    }

    fn action(
        &mut self,
        action: &Action,
        drivers: &mut HashMap<TagId, (Driver, u32)>,
        line: u32,
    ) -> Option<CAction> {
        match action {
            Action::Outputs(outputs) => {
                let checked: Vec<Option<COut>> = outputs
                    .iter()
                    .map(|o| match o {
                        Output::Coil(c) => {
                            self.coil(c, drivers, line).map(|id| COut::Coil(c.kind, id))
                        }
                        Output::Box(b) => self.boxed(b, drivers, line),
                    })
                    .collect();
                checked
                    .into_iter()
                    .collect::<Option<Vec<_>>>()
                    .map(CAction::Outputs)
            }
            Action::Block { call, coils } => {
                let checked_coils: Vec<Option<(CoilKind, TagId)>> = coils
                    .iter()
                    .map(|c| self.coil(c, drivers, line).map(|id| (c.kind, id)))
                    .collect();
                let kind = Kind::parse(&call.kind.text)?;
                let &(inst, k, first) = self.insts.by_name.get(&call.instance.text)?;
                if k != kind || first != self.rung {
                    // A second call: reported by `declare`.
                    return None;
                }
                let (call, bools) = self.call(kind, &call.args, call.instance.pos)?;
                let coils = checked_coils.into_iter().collect::<Option<Vec<_>>>()?;
                Some(CAction::Block {
                    inst,
                    call,
                    bools,
                    coils,
                })
            }
        }
    }

    /// A written tag: known, writable, and not driven in a conflicting way before.
    fn written(
        &mut self,
        name: &Name,
        how: Driver,
        drivers: &mut HashMap<TagId, (Driver, u32)>,
        line: u32,
    ) -> Option<(TagId, ValueType)> {
        let Some(e) = self.tags.get(&name.text).cloned() else {
            return self.unknown_tag(name);
        };
        if !e.writable {
            return self.fail(
                name.pos,
                CompileErrorKind::WriteToInput {
                    name: name.text.clone(),
                },
            );
        }
        match drivers.get(&e.id) {
            Some(&(first, first_line)) if first == Driver::Coil || first != how => {
                return self.fail(
                    name.pos,
                    CompileErrorKind::DrivenTwice {
                        name: name.text.clone(),
                        this: how,
                        first,
                        first_line,
                    },
                );
            }
            Some(_) => {}
            None => {
                drivers.insert(e.id, (how, line));
            }
        }
        Some((e.id, e.ty))
    }

    fn coil(
        &mut self,
        coil: &Coil,
        drivers: &mut HashMap<TagId, (Driver, u32)>,
        line: u32,
    ) -> Option<TagId> {
        let how = match coil.kind {
            CoilKind::Normal | CoilKind::Negated => Driver::Coil,
            CoilKind::Set | CoilKind::Reset => Driver::Latch,
        };
        let (id, ty) = self.written(&coil.name, how, drivers, line)?;
        if ty != ValueType::Bool {
            return self.fail(
                coil.name.pos,
                TypeError::NumberCoil {
                    name: coil.name.text.clone(),
                    ty,
                },
            );
        }
        Some(id)
    }

    fn boxed(
        &mut self,
        b: &BoxCall,
        drivers: &mut HashMap<TagId, (Driver, u32)>,
        line: u32,
    ) -> Option<COut> {
        let Some(&(name, op, arity)) = BoxOp::ALL.iter().find(|(n, _, _)| *n == b.op.text) else {
            let suggestion = closest(
                &b.op.text.to_ascii_uppercase(),
                BoxOp::ALL.iter().map(|(n, _, _)| *n),
            );
            let kind = match Kind::parse(&b.op.text) {
                Some(kind) => CompileErrorKind::MissingInstanceName { kind },
                None => CompileErrorKind::UnknownBox {
                    name: b.op.text.clone(),
                    suggestion,
                },
            };
            return self.fail(b.op.pos, kind);
        };
        let dest = self.written(&b.dest, Driver::Math, drivers, line);
        if b.args.len() != arity {
            return self.fail(
                b.op.pos,
                CompileErrorKind::MathArity {
                    name,
                    expected: arity,
                    found: b.args.len(),
                },
            );
        }
        let mut args = [Num::Const(0.0); 3];
        let mut ok = true;
        for (slot, arg) in args.iter_mut().zip(&b.args) {
            if let Some(n) = &arg.name {
                self.fail::<()>(
                    n.pos,
                    CompileErrorKind::Syntax {
                        expected: Expected::Argument,
                        found: format!("`{} =`", n.text),
                    },
                );
                ok = false;
            }
            match self.number(&arg.value) {
                Some((n, _)) => *slot = n,
                None => ok = false,
            }
        }
        let (dest, ty) = dest?;
        if ty == ValueType::Bool {
            let kind = TypeError::NumberIntoBool {
                name: b.dest.text.clone(),
                op: name,
            };
            return self.fail(b.dest.pos, kind);
        }
        // A literal moved as it is must fit the tag; computed values are stored with the
        // tag's type (truncated, saturated), as documented.
        if let (BoxOp::Move, [arg]) = (op, b.args.as_slice()) {
            self.literal_into(&arg.value, ty, || format!("`{}`", b.dest.text))?;
        }
        ok.then_some(COut::Box { op, args, dest })
    }

    /// Matches a block's arguments to its pins and checks them.
    fn call(&mut self, kind: Kind, args: &[Arg], at: usize) -> Option<(Call, Vec<BoolExpr>)> {
        let def = kind.def();
        let spec = def.arguments();
        let mut given: Vec<Option<(&Cond, usize)>> = vec![None; spec.len()];
        let mut positional = spec.iter().enumerate().filter(|(_, p)| p.positional);
        let max_positional = spec.iter().filter(|p| p.positional).count();
        let mut ok = true;
        for arg in args {
            let slot = match &arg.name {
                None => match positional.next() {
                    Some((i, _)) => Some(i),
                    None => {
                        self.fail::<()>(
                            arg.value.pos(),
                            CompileErrorKind::TooManyArgs {
                                name: kind.name(),
                                max: max_positional,
                            },
                        );
                        None
                    }
                },
                Some(n) => match spec
                    .iter()
                    .position(|p| p.name.eq_ignore_ascii_case(&n.text))
                {
                    Some(i) => Some(i),
                    None => {
                        self.fail::<()>(
                            n.pos,
                            CompileErrorKind::UnknownParam {
                                kind,
                                param: n.text.clone(),
                            },
                        );
                        None
                    }
                },
            };
            let Some(i) = slot else {
                ok = false;
                continue;
            };
            let pos = arg.name.as_ref().map_or(arg.value.pos(), |n| n.pos);
            match given.get_mut(i) {
                Some(Some(_)) => {
                    let param = spec.get(i).map_or("", |p| p.name);
                    self.fail::<()>(pos, CompileErrorKind::DuplicateParam { param });
                    ok = false;
                }
                Some(slot) => *slot = Some((&arg.value, pos)),
                None => ok = false,
            }
        }
        let mut values: Vec<Option<Value>> = Vec::with_capacity(spec.len());
        for (p, g) in spec.iter().zip(&given) {
            let v = match g {
                None => None,
                Some((cond, _)) => {
                    let v = self.value(p.ty, cond);
                    ok &= v.is_some();
                    v
                }
            };
            values.push(v);
        }
        if !ok {
            return None;
        }
        // The form: the only one, or the one whose value pins are exactly those given.
        let form = match def.forms {
            [only] => only,
            forms => {
                let given_values = |form: &Form| {
                    spec.iter().zip(&values).enumerate().all(|(i, (p, v))| {
                        p.ty == PinType::Bool || form.pins.contains(&(i + 1)) == v.is_some()
                    })
                };
                match forms.iter().find(|f| given_values(f)) {
                    Some(form) => form,
                    None => return self.fail(at, CompileErrorKind::BlinkMode),
                }
            }
        };
        let mut call = Call::new(kind);
        let mut bools = Vec::new();
        for (i, (p, v)) in spec.iter().zip(values).enumerate() {
            let pin = i + 1;
            let arg = match (p.ty, v) {
                (PinType::Bool, v) => {
                    bools.push(match v {
                        Some(Value::Bool(b)) => b,
                        _ => BoolExpr::Const(false),
                    });
                    PinArg::Stack
                }
                (_, Some(Value::Num(n))) => PinArg::Num(n),
                (_, Some(Value::Pattern(pattern))) => PinArg::Pattern(pattern),
                (ty, _) if form.pins.contains(&pin) => {
                    let param = p.name;
                    let hint = match ty {
                        PinType::Count => "a preset value, e.g. `CTU c(10)`",
                        PinType::Mask => "a mask, e.g. `LAMP l(3855)`",
                        _ => "a preset time, e.g. `TON t(2s)`",
                    };
                    return self.fail(at, CompileErrorKind::MissingParam { kind, param, hint });
                }
                _ => PinArg::Absent,
            };
            if let Some(slot) = call.pins.get_mut(pin) {
                *slot = arg;
            }
        }
        Some((call, bools))
    }

    fn value(&mut self, ty: PinType, cond: &Cond) -> Option<Value> {
        match ty {
            PinType::Bool => self.boolean(cond).map(Value::Bool),
            // A preset is an i32 (`crate::logic::blocks`).
            PinType::Count => {
                let n = self.number(cond)?;
                self.literal_into(cond, ValueType::I32, || "a counter's preset".into())?;
                Some(Value::Num(n.0))
            }
            // A MiniMod blinker mask is 16 bits (YLAMPn).
            PinType::Mask => {
                let n = self.number(cond)?;
                self.literal_into(cond, ValueType::U16, || "a LAMP's mask".into())?;
                Some(Value::Num(n.0))
            }
            PinType::Time => match cond {
                Cond::Lit(Lit::Number { text, .. }, pos) => self.duration(text, *pos).map(|_| {
                    // A bare number always fails above: a duration needs its unit.
                    Value::Num(Num::Const(0.0))
                }),
                other => self.number(other).map(|(n, _)| Value::Num(n)),
            },
            PinType::Pattern => match cond {
                Cond::Lit(Lit::Number { text, .. }, pos) => match Pattern::parse(text) {
                    Ok(p) => Some(Value::Pattern(p)),
                    Err(e) => self.fail(*pos, e),
                },
                other => self.fail(
                    other.pos(),
                    CompileErrorKind::Syntax {
                        expected: Expected::Argument,
                        found: "not a pattern of 0 and 1".into(),
                    },
                ),
            },
        }
    }
}

/// A literal compared with an `f32` tag is rounded to `f32`, so `temp = 0.1` holds when `temp`
/// holds `0.1f32`.
fn round_for(n: Num, other: Option<ValueType>) -> Num {
    match (n, other) {
        (Num::Const(v), Some(ValueType::F32)) => Num::Const(f64::from(v as f32)),
        _ => n,
    }
}

/// The closest candidate within two edits (see the expr engine's rule).
fn closest<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> Option<String> {
    crate::logic::expr::closest_name(name, candidates)
}
