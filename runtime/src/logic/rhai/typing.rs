//! What `softplc check` (and a reload's compile) finds in a script before it runs, beyond
//! Rhai's parser: Rhai resolves functions and checks types only when a call or an operator is
//! reached, so a typo in a branch taken at scan 101 would fault the running PLC then. The
//! checker walks every statement and expression, every branch and every script function, and
//! reports:
//!
//! - a call of a function nobody defines (with the closest known one), or with a number of
//!   arguments none of its forms takes;
//! - a library call's arguments whose types are known (literals, tags) and do not fit, and
//!   literal durations and blink patterns that do not parse;
//! - an assignment to a tag of a value whose type the tag cannot hold, an operator given
//!   operands it cannot take, a condition that is not a bool.
//!
//! The walk is Rhai's own (a visitor over every node, in the `internals` API, behind
//! [`internals::walk`]), not a match over every statement and expression kind here: the visitor follows the
//! language as Rhai maintains it, and each check looks only at the nodes it knows. Types are
//! those [`types::infer`] can see; a value of an unknown type is checked when the script
//! assigns it (`RhaiProgram::copy_out`).

use std::collections::HashSet;

use rhai::{Engine, Position};
use softplc_io::point::ValueType;

use super::error::CompileErrorKind;
use super::internals::{self, Assignment, Call, Expr, ExprView, Node, StmtView, AST};
use super::signatures::{self, Param, Signature};
use super::types::{self, Ty};
use crate::logic::blocks::Pattern;
use crate::logic::expr::{closest_name, literal_fits, TagTable};

type Errors = Vec<(Position, CompileErrorKind)>;

/// Functions Rhai itself handles, whatever their arguments.
const KEYWORDS: [&str; 9] = [
    "print",
    "debug",
    "type_of",
    "Fn",
    "call",
    "curry",
    "is_shared",
    "is_def_var",
    "is_def_fn",
];

/// The functions a script may call besides the library: the engine's packages and the
/// script's own functions, by name and number of parameters.
#[derive(Debug, Default)]
pub(crate) struct Known {
    forms: HashSet<(String, usize)>,
    /// The project's blocks of one's own.
    pub(crate) own: Vec<super::own::OwnSignature>,
    /// Names callable by a user (no operators or property accessors), for suggestions.
    names: Vec<String>,
}

impl Known {
    /// What `engine` (its packages; the library is held against [`signatures`]) and `ast`
    /// define.
    pub(crate) fn of(engine: &Engine, ast: &AST) -> Known {
        let mut forms: HashSet<(String, usize)> =
            internals::function_forms(engine).into_iter().collect();
        forms.extend(
            ast.iter_functions()
                .map(|f| (f.name.to_string(), f.params.len())),
        );
        let mut names: Vec<String> = forms
            .iter()
            .map(|(n, _)| n.clone())
            .filter(|n| {
                n.chars()
                    .next()
                    .is_some_and(|c| c.is_alphabetic() || c == '_')
            })
            .filter(|n| !n.contains('$'))
            .collect();
        names.sort();
        names.dedup();
        Known {
            forms,
            names,
            own: Vec::new(),
        }
    }

    fn arities(&self, name: &str) -> Vec<usize> {
        let mut a: Vec<usize> = self
            .forms
            .iter()
            .filter(|(n, _)| n == name)
            .map(|(_, k)| *k)
            .collect();
        a.sort_unstable();
        a
    }
}

/// Checks `ast` (the user's statements and functions) against `tags` and `known`.
pub(crate) fn check(ast: &AST, tags: &TagTable, known: &Known, errors: &mut Errors) {
    // Names the script declares itself (`let`, `const`, loop variables) shadow tags of the
    // same name; their types are not known.
    let mut declared: HashSet<String> = HashSet::new();
    internals::walk(ast, |node| {
        match node {
            Node::Stmt(s) => match internals::stmt(s) {
                StmtView::Let(name) => {
                    declared.insert(name.to_string());
                }
                StmtView::For(name, counter) => {
                    declared.insert(name.to_string());
                    if let Some(counter) = counter {
                        declared.insert(counter.to_string());
                    }
                }
                _ => {}
            },
            Node::Expr(_) => {}
        }
        true
    });
    let tag_type = |name: &str| {
        if declared.contains(name) {
            return None;
        }
        tags.get(name).map(|t| Ty::of_tag(t.ty))
    };
    // Script functions do not see tags.
    let no_tags = |_: &str| None;
    let mut checker = Checker {
        tags,
        known,
        errors,
        own_calls: std::collections::HashMap::new(),
    };
    checker.walk(&ast.clone_statements_only(), &tag_type, true);
    checker.walk(&ast.clone_functions_only(), &no_tags, false);
}

struct Checker<'a> {
    tags: &'a TagTable,
    known: &'a Known,
    errors: &'a mut Errors,
    /// Instances of blocks of one's own called so far, where.
    own_calls: std::collections::HashMap<String, Position>,
}

impl Checker<'_> {
    fn walk(&mut self, ast: &AST, var: &dyn Fn(&str) -> Option<Ty>, sees_tags: bool) {
        internals::walk(ast, |node| {
            match node {
                Node::Expr(e) => match internals::expr(e) {
                    ExprView::Call(call) => self.call(call, var),
                    ExprView::Method(call) => self.method(call),
                    ExprView::And(items) | ExprView::Or(items) => {
                        for item in items {
                            self.condition(item, var);
                        }
                    }
                    _ => {}
                },
                Node::Stmt(s) => match internals::stmt(s) {
                    StmtView::Call(call) => self.call(call, var),
                    StmtView::If(cond) | StmtView::While(cond) | StmtView::Do(cond) => {
                        self.condition(cond, var)
                    }
                    StmtView::Assign(a) if sees_tags => self.assignment(a, var),
                    _ => {}
                },
            }
            true
        });
    }

    fn fail(&mut self, pos: Position, kind: CompileErrorKind) {
        self.errors.push((pos, kind));
    }

    fn condition(&mut self, expr: &Expr, var: &dyn Fn(&str) -> Option<Ty>) {
        // `loop { … }` is a `while` whose guard is `()`.
        if matches!(internals::expr(expr), ExprView::Unit) {
            return;
        }
        let ty = types::infer(expr, var);
        if !matches!(ty, Ty::Bool | Ty::Unknown) {
            self.fail(
                start(expr),
                CompileErrorKind::ConditionType { found: ty.words() },
            );
        }
    }

    fn assignment(&mut self, a: Assignment<'_>, var: &dyn Fn(&str) -> Option<Ty>) {
        let (lhs, rhs) = (a.lhs, a.rhs);
        let ExprView::Var(name, _) = internals::expr(lhs) else {
            return;
        };
        let (Some(tag), Some(tag_ty)) = (self.tags.get(name), var(name)) else {
            return;
        };
        let value = types::infer(rhs, var);
        let (value, pos) = match a.operator {
            Some(syntax) => {
                let operands = [tag_ty, value];
                if types::operands_clash(syntax, &operands) {
                    self.operands(syntax, &operands, a.pos);
                    return;
                }
                (types::operator(syntax, &operands), a.pos)
            }
            None => {
                self.literal_against(rhs, lhs, var);
                (value, start(rhs))
            }
        };
        if !value.fits(tag.ty) {
            self.fail(
                pos,
                CompileErrorKind::AssignType {
                    name: name.to_string(),
                    ty: tag.ty,
                    value: value.words(),
                },
            );
        }
    }

    /// `lit`, when it is a number literal, met with `tag` (assigned to it or compared with
    /// it): one the tag's type can hold.
    fn literal_against(&mut self, lit: &Expr, tag: &Expr, var: &dyn Fn(&str) -> Option<Ty>) {
        let ExprView::Var(name, _) = internals::expr(tag) else {
            return;
        };
        let (Some(entry), Some(_)) = (self.tags.get(name), var(name)) else {
            return;
        };
        let Some((value, text)) = number_literal(lit) else {
            return;
        };
        if entry.ty != ValueType::Bool && !literal_fits(value, entry.ty) {
            self.fail(
                start(lit),
                CompileErrorKind::LiteralOutOfType {
                    value: text,
                    name: name.to_string(),
                    ty: entry.ty,
                },
            );
        }
    }

    fn operands(&mut self, op: &str, args: &[Ty], pos: Position) {
        let words: Vec<&str> = args.iter().map(|t| t.words()).collect();
        self.fail(
            pos,
            CompileErrorKind::OperandType {
                op: op.to_string(),
                operands: words.join(" and "),
            },
        );
    }

    fn call(&mut self, call: Call<'_>, var: &dyn Fn(&str) -> Option<Ty>) {
        let (name, pos) = (call.name, call.pos);
        let args: Vec<Ty> = call.args.iter().map(|a| types::infer(a, var)).collect();
        if call.operator {
            if types::operands_clash(name, &args) {
                self.operands(name, &args, pos);
            } else if let [a, b] = call.args {
                if types::is_comparison(name) {
                    self.literal_against(a, b, var);
                    self.literal_against(b, a, var);
                }
            }
            return;
        }
        // `good`/`bad` are checked by `quality.rs`.
        if KEYWORDS.contains(&name) || super::quality::FUNCTIONS.contains(&name) {
            return;
        }
        if name == super::own::OUTPUT && !self.known.own.is_empty() {
            self.own_output(call.args, pos);
            return;
        }
        if let Some(sig) = self.known.own.iter().find(|s| s.function == name) {
            self.own_call(sig, call.args, &args, pos);
            return;
        }
        let library: Vec<&'static Signature> = signatures::overloads(name).collect();
        if let Some(sig) = library.iter().find(|s| s.params.len() == args.len()) {
            self.arguments(sig, call.args, &args);
            return;
        }
        if self.known.forms.contains(&(name.to_string(), args.len())) {
            return;
        }
        self.unknown_or_arity(name, &library, self.known.arities(name), args.len(), pos);
    }

    /// `output("s1", "done")`: two arguments, a declared instance and one of its variables
    /// (where they are literals).
    fn own_output(&mut self, exprs: &[Expr], pos: Position) {
        let [instance, var] = exprs else {
            let kind = CompileErrorKind::Arity {
                name: super::own::OUTPUT.to_owned(),
                usage: "2 arguments: output(instance, variable)".to_owned(),
                found: exprs.len(),
            };
            self.fail(pos, kind);
            return;
        };
        let ExprView::Str(name, _) = internals::expr(instance) else {
            return;
        };
        let Some(sig) = self
            .known
            .own
            .iter()
            .find(|s| s.instances.iter().any(|i| i == name))
        else {
            let declared: Vec<&str> = self
                .known
                .own
                .iter()
                .flat_map(|s| s.instances.iter().map(String::as_str))
                .collect();
            let what = format!(
                "\"{name}\" is no declared instance (the project's `instances:`: {})",
                declared.join(", ")
            );
            self.fail(start(instance), CompileErrorKind::OwnOutput { what });
            return;
        };
        if let ExprView::Str(v, _) = internals::expr(var) {
            if !sig.vars.iter().any(|x| x == v) {
                let what = format!(
                    "{} \"{name}\" has no \"{v}\"; it has {}",
                    sig.block,
                    sig.vars.join(", ")
                );
                self.fail(start(var), CompileErrorKind::OwnOutput { what });
            }
        }
    }

    /// A call of a block of one's own: its number of arguments, a declared instance's name,
    /// each input's type where it shows.
    fn own_call(
        &mut self,
        sig: &super::own::OwnSignature,
        exprs: &[Expr],
        types: &[Ty],
        pos: Position,
    ) {
        let given = types.len().saturating_sub(1);
        if types.is_empty() || given < sig.required || given > sig.inputs.len() {
            let usage = if sig.required == sig.inputs.len() {
                format!("{} arguments: {}", sig.inputs.len() + 1, sig.usage())
            } else {
                format!(
                    "{} to {} arguments: {}",
                    sig.required + 1,
                    sig.inputs.len() + 1,
                    sig.usage()
                )
            };
            let kind = CompileErrorKind::Arity {
                name: sig.function.clone(),
                usage,
                found: types.len(),
            };
            self.fail(pos, kind);
            return;
        }
        if let Some(name) = exprs.first() {
            match internals::expr(name) {
                ExprView::Str(text, _) if !sig.instances.iter().any(|i| i == text) => {
                    let declared = if sig.instances.is_empty() {
                        "none is declared".to_owned()
                    } else {
                        format!("declared: {}", sig.instances.join(", "))
                    };
                    let kind = CompileErrorKind::OwnInstance {
                        function: sig.function.clone(),
                        name: text.to_string(),
                        block: sig.block.clone(),
                        declared,
                    };
                    self.fail(start(name), kind);
                }
                ExprView::Str(text, _) => match self.own_calls.get(text) {
                    Some(&first) => {
                        let kind = CompileErrorKind::OwnCalledTwice {
                            name: text.to_string(),
                            first_line: super::check::line(first),
                        };
                        self.fail(pos, kind);
                    }
                    None => {
                        self.own_calls.insert(text.to_string(), pos);
                    }
                },
                _ => {}
            }
        }
        for (((param, ty), expr), &found) in sig.inputs.iter().zip(&exprs[1..]).zip(&types[1..]) {
            let fits = match ty {
                ValueType::Bool => matches!(found, Ty::Bool | Ty::Unknown),
                _ => matches!(found, Ty::Int | Ty::Float | Ty::Unknown),
            };
            if !fits {
                let kind = CompileErrorKind::OwnArgumentType {
                    function: sig.function.clone(),
                    block: sig.block.clone(),
                    param: param.clone(),
                    expected: *ty,
                    found: found.words(),
                };
                self.fail(start(expr), kind);
            }
        }
    }

    /// `x.f(a)`: `f` with `x` as its first argument. Only the name and the arity are checked
    /// (the receiver's type is rarely known).
    fn method(&mut self, call: Call<'_>) {
        let (name, pos) = (call.name, call.pos);
        let arity = call.args.len() + 1;
        if KEYWORDS.contains(&name) {
            return;
        }
        let library: Vec<&'static Signature> = signatures::overloads(name).collect();
        if library.iter().any(|s| s.params.len() == arity)
            || self.known.forms.contains(&(name.to_string(), arity))
            // A script function called as a method takes the receiver as `this`.
            || self.known.forms.contains(&(name.to_string(), call.args.len()))
        {
            return;
        }
        self.unknown_or_arity(name, &library, self.known.arities(name), arity, pos);
    }

    fn unknown_or_arity(
        &mut self,
        name: &str,
        library: &[&'static Signature],
        arities: Vec<usize>,
        found: usize,
        pos: Position,
    ) {
        let counts = |arities: &[usize]| {
            let words: Vec<String> = arities.iter().map(usize::to_string).collect();
            let plural = if arities == [1] { "" } else { "s" };
            format!("{} argument{plural}", words.join(" or "))
        };
        let usage = if !library.is_empty() {
            let arities: Vec<usize> = library.iter().map(|s| s.params.len()).collect();
            let forms: Vec<String> = library.iter().map(|s| s.usage()).collect();
            Some(format!("{}: {}", counts(&arities), forms.join(" or ")))
        } else if !arities.is_empty() {
            Some(counts(&arities))
        } else {
            None
        };
        let kind = match usage {
            Some(usage) => CompileErrorKind::Arity {
                name: name.to_string(),
                usage,
                found,
            },
            None => {
                let candidates = signatures::LIBRARY
                    .iter()
                    .map(|s| s.name)
                    .chain(self.known.names.iter().map(String::as_str));
                let suggestion = closest_name(name, candidates).map(|n| {
                    signatures::overloads(&n)
                        .find(|s| s.params.len() == found)
                        .or_else(|| signatures::overloads(&n).next())
                        .map_or(n.clone(), |s| s.usage())
                });
                CompileErrorKind::UnknownFunction {
                    name: name.to_string(),
                    suggestion,
                }
            }
        };
        self.fail(pos, kind);
    }

    /// The arguments of a library call: types where known, literals parsed.
    fn arguments(&mut self, sig: &'static Signature, exprs: &[Expr], types: &[Ty]) {
        let mut numbers = Vec::new();
        for ((&(param, kind), expr), &ty) in sig.params.iter().zip(exprs).zip(types) {
            let pos = start(expr);
            let wrong = |expected: &'static str| CompileErrorKind::ArgumentType {
                function: sig.name,
                param,
                expected,
                found: ty.words(),
            };
            match kind {
                Param::Name if !matches!(ty, Ty::Str | Ty::Unknown) => {
                    self.fail(pos, wrong("an instance name, a string such as \"t1\""));
                }
                Param::Bool if !matches!(ty, Ty::Bool | Ty::Unknown) => {
                    self.fail(pos, wrong("a bool"));
                }
                Param::Int if !matches!(ty, Ty::Int | Ty::Unknown) => {
                    self.fail(pos, wrong("an integer"));
                }
                Param::Mask => match internals::expr(expr) {
                    ExprView::Int(n, _) if u16::try_from(n).is_err() => {
                        let kind = CompileErrorKind::ArgumentType {
                            function: sig.name,
                            param,
                            expected: "a 16-bit mask, 0 to 65535",
                            found: "a number outside it",
                        };
                        self.fail(pos, kind);
                    }
                    _ if !matches!(ty, Ty::Int | Ty::Unknown) => {
                        self.fail(pos, wrong("a 16-bit mask, 0 to 65535"));
                    }
                    _ => {}
                },
                Param::Time => match internals::expr(expr) {
                    ExprView::Str(text, _) => {
                        if let Err(reason) = crate::project::parse_duration(text) {
                            self.fail(
                                pos,
                                CompileErrorKind::BadDuration {
                                    function: sig.name,
                                    param,
                                    text: text.to_string(),
                                    reason,
                                },
                            );
                        }
                    }
                    _ if ty == Ty::Bool => {
                        self.fail(pos, wrong("a time (ms, or a string such as \"2s\")"));
                    }
                    _ => {}
                },
                Param::Pattern => match internals::expr(expr) {
                    ExprView::Str(text, _) => {
                        if let Err(reason) = Pattern::parse(text) {
                            let text = text.to_string();
                            self.fail(pos, CompileErrorKind::BadPattern { text, reason });
                        }
                    }
                    _ if !matches!(ty, Ty::Str | Ty::Unknown) => {
                        self.fail(
                            pos,
                            wrong("a pattern, a string of 0 and 1 such as \"1101\""),
                        );
                    }
                    _ => {}
                },
                Param::Number => {
                    if matches!(ty, Ty::Int | Ty::Float | Ty::Unknown) {
                        numbers.push((pos, param, ty));
                    } else {
                        self.fail(pos, wrong("a number"));
                    }
                }
                Param::Name | Param::Bool | Param::Int | Param::Tag => {}
            }
        }
        // `limit(0, x, 100.0)`: Rhai has it for three integers or three floats, not a mix.
        let has_float = numbers.iter().any(|(_, _, t)| *t == Ty::Float);
        if let Some(&(pos, param, _)) = numbers.iter().find(|(_, _, t)| *t == Ty::Int) {
            if has_float {
                self.fail(
                    pos,
                    CompileErrorKind::ArgumentType {
                        function: sig.name,
                        param,
                        expected: "a float like the others (write 0.0, not 0)",
                        found: Ty::Int.words(),
                    },
                );
            }
        }
    }
}

/// Where an expression begins: Rhai places a binary operator's call at the operator.
fn start(expr: &Expr) -> Position {
    match internals::expr(expr) {
        ExprView::Call(call) if call.operator && call.args.len() == 2 => call
            .args
            .first()
            .map_or(internals::start_position(expr), start),
        _ => internals::start_position(expr),
    }
}

/// A number literal's value and text (`-5` too, however Rhai folds it).
fn number_literal(expr: &Expr) -> Option<(f64, String)> {
    match internals::expr(expr) {
        ExprView::Int(i, _) => Some((i as f64, i.to_string())),
        ExprView::Float(f) => Some((f, internals::float_text(f))),
        ExprView::Call(call) if call.operator && call.name == "-" => match call.args {
            [inner] => number_literal(inner).map(|(v, t)| (-v, format!("-{t}"))),
            _ => None,
        },
        _ => None,
    }
}
