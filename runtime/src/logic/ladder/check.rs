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
use crate::logic::user_blocks::{Found, OwnBlocks};
use crate::logic::vm::{BoxOp, Call, CmpOp, Num, OwnPin, PinArg};
use crate::project::UserBlock;

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
    /// A call of a block of one's own: the instance (its index among the declared ones),
    /// what the call gives each input, the bool arguments after the power flow, the coils.
    Own {
        inst: u32,
        pins: Vec<OwnPin>,
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
    /// Instances of blocks of one's own called: name → rung that calls it.
    own: HashMap<String, usize>,
}

/// Checks parsed rungs (`(rung index, rung)`); `line_of` gives a rung's first line.
pub(crate) fn check(
    rungs: &[(usize, Rung)],
    tags: &TagTable,
    own: &OwnBlocks,
    line_of: &dyn Fn(usize) -> u32,
    errors: &mut Vec<Error>,
) -> (Vec<CRung>, Instances) {
    let mut c = Checker {
        tags,
        own,
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
    own: &'a OwnBlocks,
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
            if let Some(Found::Own(block)) = self.own.find(&call.kind.text) {
                self.declare_own(call, block, *index, line_of);
                continue;
            }
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
            let first = self
                .insts
                .by_name
                .get(&name.text)
                .map(|&(_, _, first)| first);
            if let Some(first) = first.or_else(|| self.insts.own.get(&name.text).copied()) {
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

    /// Pass 1 for a call of a block of one's own: a declared instance of that block, called
    /// once (in a block's body: an instance the block declares).
    fn declare_own(
        &mut self,
        call: &super::parser::BlockCall,
        block: &UserBlock,
        index: usize,
        line_of: &dyn Fn(usize) -> u32,
    ) {
        let name = &call.instance;
        let declared = self.own.instance(&name.text).map(|(_, b)| b.name.clone());
        let kind = match (declared, &self.own.in_body) {
            (None, Some(body)) => CompileErrorKind::OwnNotDeclaredInBody {
                name: name.text.clone(),
                block: block.name.clone(),
                body: body.clone(),
            },
            (None, None) => CompileErrorKind::OwnNotDeclared {
                name: name.text.clone(),
                block: block.name.clone(),
            },
            (Some(declared), _) if declared != block.name => CompileErrorKind::OwnWrongBlock {
                name: name.text.clone(),
                declared,
                called: block.name.clone(),
            },
            (Some(_), _) => {
                let first = self
                    .insts
                    .by_name
                    .get(&name.text)
                    .map(|&(_, _, first)| first);
                match first.or_else(|| self.insts.own.get(&name.text).copied()) {
                    Some(first) => CompileErrorKind::InstanceCalledTwice {
                        name: name.text.clone(),
                        first_line: line_of(first),
                    },
                    None => {
                        self.insts.own.insert(name.text.clone(), index);
                        return;
                    }
                }
            }
        };
        self.fail::<()>(name.pos, kind);
    }

    fn kind(&mut self, name: &Name) -> Option<Kind> {
        if let Some(k) = Kind::parse(&name.text) {
            return Some(k);
        }
        let upper = name.text.to_ascii_uppercase();
        let suggestion = Kind::parse(&upper)
            .map(|k| k.name().to_string())
            .or_else(|| closest(&name.text, self.own.names()));
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
                let dotted = format!("{}.{}", r.name.text, member.text);
                if let Some(e) = self.tags.get(&dotted) {
                    return Some((Num::Tag(e.id), Some(e.ty), dotted));
                }
                if let Some((_, block)) = self.own.instance(&r.name.text) {
                    let vars: Vec<&str> = block.vars().map(|(_, v)| v.name.as_str()).collect();
                    let kind = CompileErrorKind::OwnUnknownVar {
                        instance: r.name.text.clone(),
                        block: block.name.clone(),
                        member: member.text.clone(),
                        vars: vars.join(", "),
                    };
                    return self.fail(member.pos, kind);
                }
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
                if let Some(Found::Own(block)) = self.own.find(&call.kind.text) {
                    if self.insts.own.get(&call.instance.text) != Some(&self.rung) {
                        // Not declared, or a second call: reported by `declare`.
                        return None;
                    }
                    let (inst, _) = self.own.instance(&call.instance.text)?;
                    let (pins, bools) = self.own_call(block, &call.args, call.instance.pos)?;
                    let coils = checked_coils.into_iter().collect::<Option<Vec<_>>>()?;
                    return Some(CAction::Own {
                        inst,
                        pins,
                        bools,
                        coils,
                    });
                }
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

    /// Matches a call's arguments to a block of one's own's inputs (the power flow is the
    /// first; the others by position or by name) and checks their types.
    fn own_call(
        &mut self,
        block: &UserBlock,
        args: &[Arg],
        at: usize,
    ) -> Option<(Vec<OwnPin>, Vec<BoolExpr>)> {
        let inputs = &block.inputs;
        let after_flow = || {
            let names: Vec<&str> = inputs.iter().skip(1).map(|v| v.name.as_str()).collect();
            if names.is_empty() {
                "none after the power flow".to_owned()
            } else {
                names.join(", ")
            }
        };
        let mut given: Vec<Option<&Cond>> = vec![None; inputs.len()];
        let mut next_positional = 1;
        let mut ok = true;
        for arg in args {
            let slot = match &arg.name {
                None if next_positional < inputs.len() => {
                    next_positional += 1;
                    next_positional - 1
                }
                None => {
                    let kind = CompileErrorKind::OwnTooManyArgs {
                        block: block.name.clone(),
                        max: inputs.len().saturating_sub(1),
                        inputs: after_flow(),
                    };
                    self.fail::<()>(arg.value.pos(), kind);
                    ok = false;
                    continue;
                }
                Some(n) => match inputs.iter().skip(1).position(|v| v.name == n.text) {
                    Some(i) => i + 1,
                    None => {
                        let kind = CompileErrorKind::OwnUnknownPin {
                            block: block.name.clone(),
                            pin: n.text.clone(),
                            inputs: after_flow(),
                        };
                        self.fail::<()>(n.pos, kind);
                        ok = false;
                        continue;
                    }
                },
            };
            if given[slot].is_some() {
                let pos = arg.name.as_ref().map_or(arg.value.pos(), |n| n.pos);
                let kind = CompileErrorKind::OwnDuplicatePin {
                    pin: inputs[slot].name.clone(),
                };
                self.fail::<()>(pos, kind);
                ok = false;
                continue;
            }
            given[slot] = Some(&arg.value);
        }
        let mut pins = vec![OwnPin::Stack];
        let mut bools = Vec::new();
        for (i, var) in inputs.iter().enumerate().skip(1) {
            let Some(cond) = given[i] else {
                if var.optional {
                    pins.push(OwnPin::Default(crate::logic::user_blocks::default_of(
                        block, i,
                    )));
                } else {
                    let kind = CompileErrorKind::OwnMissingInput {
                        block: block.name.clone(),
                        pin: var.name.clone(),
                    };
                    self.fail::<()>(at, kind);
                    ok = false;
                }
                continue;
            };
            if let Some(found) = self.wrong_type(cond, var.ty) {
                let kind = CompileErrorKind::OwnPinType {
                    block: block.name.clone(),
                    pin: var.name.clone(),
                    expected: var.ty,
                    found,
                };
                self.fail::<()>(cond.pos(), kind);
                ok = false;
                continue;
            }
            if var.ty == ValueType::Bool {
                match self.boolean(cond) {
                    Some(b) => {
                        bools.push(b);
                        pins.push(OwnPin::Stack);
                    }
                    None => ok = false,
                }
            } else {
                let pin = format!("input `{}` of {}", var.name, block.name);
                let n = self.number(cond);
                let fits = self.literal_into(cond, var.ty, || pin);
                match (n, fits) {
                    (Some((n, _)), Some(())) => pins.push(OwnPin::Num(n)),
                    _ => ok = false,
                }
            }
        }
        ok.then_some((pins, bools))
    }

    /// What `cond` is, in words, when it cannot be a value of type `ty`; `None` when it
    /// can (or when the checks of its own will say why not).
    fn wrong_type(&self, cond: &Cond, ty: ValueType) -> Option<String> {
        let tag_type = |r: &Ref| -> Option<(String, ValueType)> {
            let name = match &r.member {
                None => r.name.text.clone(),
                Some(m) => format!("{}.{}", r.name.text, m.text),
            };
            let e = self.tags.get(&name)?;
            Some((name, e.ty))
        };
        let is_bool = ty == ValueType::Bool;
        match cond {
            Cond::Ref(r) => {
                let (name, found) = tag_type(r)?;
                (is_bool != (found == ValueType::Bool))
                    .then(|| format!("`{name}`, {}", crate::logic::user_blocks::a_type(found)))
            }
            Cond::Lit(Lit::Bool(b), _) if !is_bool => Some(format!("`{b}`, a bool")),
            Cond::Lit(Lit::Number { text, .. }, _) if is_bool && text != "0" && text != "1" => {
                Some(format!("the number {text}"))
            }
            Cond::Lit(Lit::Duration { text }, _) if is_bool => Some(format!("the time {text}")),
            Cond::Lit(..) => None,
            _ if !is_bool => Some("a condition".to_owned()),
            _ => None,
        }
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
