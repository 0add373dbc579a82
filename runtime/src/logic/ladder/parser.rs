//! Parser: one rung's tokens → a [`Rung`] tree. Positions are character indexes in the rung.
//!
//! ```text
//! rung      := [condition] "->" action
//! condition := series ("|" series)*                 parallel branches
//! series    := contact+                             contacts in series, left to right
//! contact   := "/" contact                          normally closed
//!            | "rising" "(" condition ")" | "falling" "(" condition ")"
//!            | "good" "(" name ")" | "bad" "(" name ")"    a tag's quality
//!            | "(" condition ")"
//!            | operand [cmp operand]                 a bool contact, or a comparison
//! operand   := name ["." MEMBER] | number | duration | "-" number | true | false
//! cmp       := "=" | "==" | "<>" | "!=" | "<" | "<=" | ">" | ">="
//! action    := output ("," output)*
//!            | BLOCK name ["(" args ")"] ["->" coil ("," coil)*]
//! output    := coil | BOX "(" args ")" "=>" name
//! coil      := name | "/" name | "set" name | "reset" name
//! args      := arg ("," arg)*     arg := [name "="] condition
//! ```

use super::error::{CompileErrorKind, Expected};
use super::lexer::{lex, Spanned, Tok};
use crate::logic::vm::CmpOp;

/// Deepest nesting of parentheses, negations and edges.
pub(crate) const MAX_DEPTH: u32 = 64;

/// A parse error: character index and kind.
pub(crate) type ParseError = (usize, CompileErrorKind);

/// A name with its position.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Name {
    pub text: String,
    pub pos: usize,
}

/// `name` or `name.MEMBER`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Ref {
    pub name: Name,
    pub member: Option<Name>,
}

/// A literal as written.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Lit {
    /// A number, with its text (a pattern argument reads the digits).
    Number { value: f64, text: String },
    /// A number with a unit (a duration, checked later).
    Duration { text: String },
    /// `true` / `false`.
    Bool(bool),
}

/// A condition (power flow) or a value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Cond {
    Ref(Ref),
    Lit(Lit, usize),
    Not(Box<Cond>),
    Series(Vec<Cond>),
    Parallel(Vec<Cond>),
    Edge {
        rising: bool,
        arg: Box<Cond>,
    },
    Cmp {
        lhs: Box<Cond>,
        op: CmpOp,
        rhs: Box<Cond>,
        pos: usize,
    },
    /// `good(tag)` (`good`) or `bad(tag)`: a contact on the tag's quality; `pos` is the
    /// function name's.
    Quality {
        good: bool,
        tag: Name,
        pos: usize,
    },
}

impl Cond {
    /// Where the condition starts.
    pub(crate) fn pos(&self) -> usize {
        match self {
            Cond::Ref(r) => r.name.pos,
            Cond::Lit(_, p) => *p,
            Cond::Not(c) => c.pos().saturating_sub(1),
            Cond::Series(v) | Cond::Parallel(v) => v.first().map_or(0, Cond::pos),
            Cond::Edge { arg, .. } => arg.pos(),
            Cond::Cmp { lhs, .. } => lhs.pos(),
            Cond::Quality { pos, .. } => *pos,
        }
    }
}

/// How a coil writes its tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CoilKind {
    /// `tag`: the power flow.
    Normal,
    /// `/tag`: its negation.
    Negated,
    /// `set tag`: true when power flows, else unchanged.
    Set,
    /// `reset tag`: false when power flows, else unchanged.
    Reset,
}

/// A coil.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Coil {
    pub kind: CoilKind,
    pub name: Name,
}

/// One argument of a block or box.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Arg {
    pub name: Option<Name>,
    pub value: Cond,
}

/// `KIND name(args)`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BlockCall {
    pub kind: Name,
    pub instance: Name,
    pub args: Vec<Arg>,
}

/// `BOX(args) => dest`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct BoxCall {
    pub op: Name,
    pub args: Vec<Arg>,
    pub dest: Name,
}

/// One output of a rung.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Output {
    Coil(Coil),
    Box(BoxCall),
}

/// What a rung does with its power flow.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Action {
    /// Coils and boxes, all fed by the condition.
    Outputs(Vec<Output>),
    /// A block fed by the condition, its main output feeding the coils.
    Block { call: BlockCall, coils: Vec<Coil> },
}

/// A parsed rung.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Rung {
    /// `None`: always powered (`-> action`).
    pub cond: Option<Cond>,
    pub action: Action,
}

/// Parses one rung.
pub(crate) fn parse_rung(text: &str) -> Result<Rung, ParseError> {
    let toks = lex(text);
    if toks.len() == 1 {
        return Err((0, CompileErrorKind::EmptyRung));
    }
    let mut p = Parser {
        toks,
        i: 0,
        depth: 0,
    };
    let cond = if p.peek() == Tok::Arrow {
        None
    } else {
        Some(p.condition()?)
    };
    p.expect(Tok::Arrow, Expected::Arrow)?;
    let action = p.action()?;
    if p.peek() != Tok::End {
        return Err(p.unexpected(Expected::CommaOrEnd));
    }
    Ok(Rung { cond, action })
}

struct Parser<'a> {
    toks: Vec<Spanned<'a>>,
    i: usize,
    depth: u32,
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Tok<'a> {
        self.toks.get(self.i).map_or(Tok::End, |t| t.0)
    }

    fn peek_at(&self, k: usize) -> Tok<'a> {
        self.toks.get(self.i + k).map_or(Tok::End, |t| t.0)
    }

    fn pos(&self) -> usize {
        self.toks
            .get(self.i)
            .or(self.toks.last())
            .map_or(0, |t| t.1)
    }

    fn bump(&mut self) -> Spanned<'a> {
        let t = self
            .toks
            .get(self.i)
            .copied()
            .unwrap_or((Tok::End, self.pos()));
        if self.i < self.toks.len().saturating_sub(1) {
            self.i += 1;
        }
        t
    }

    fn unexpected(&self, expected: Expected) -> ParseError {
        (
            self.pos(),
            CompileErrorKind::Syntax {
                expected,
                found: self.peek().to_string(),
            },
        )
    }

    fn expect(&mut self, tok: Tok<'_>, expected: Expected) -> Result<usize, ParseError> {
        if self.peek() == tok {
            Ok(self.bump().1)
        } else {
            Err(self.unexpected(expected))
        }
    }

    fn name(&mut self, expected: Expected) -> Result<Name, ParseError> {
        match self.peek() {
            Tok::Ident(s) => {
                let pos = self.bump().1;
                Ok(Name {
                    text: s.to_string(),
                    pos,
                })
            }
            _ => Err(self.unexpected(expected)),
        }
    }

    fn nest(&mut self) -> Result<(), ParseError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err((self.pos(), CompileErrorKind::TooDeep { limit: MAX_DEPTH }));
        }
        Ok(())
    }

    fn condition(&mut self) -> Result<Cond, ParseError> {
        let mut branches = vec![self.series()?];
        while self.peek() == Tok::Pipe {
            self.bump();
            branches.push(self.series()?);
        }
        Ok(if branches.len() == 1 {
            branches.remove(0)
        } else {
            Cond::Parallel(branches)
        })
    }

    fn starts_contact(tok: Tok<'_>) -> bool {
        matches!(
            tok,
            Tok::Ident(_)
                | Tok::Number(_)
                | Tok::NumberUnit { .. }
                | Tok::Slash
                | Tok::LParen
                | Tok::Minus
        )
    }

    fn series(&mut self) -> Result<Cond, ParseError> {
        let mut items = vec![self.contact()?];
        while Self::starts_contact(self.peek()) {
            items.push(self.contact()?);
        }
        Ok(if items.len() == 1 {
            items.remove(0)
        } else {
            Cond::Series(items)
        })
    }

    fn contact(&mut self) -> Result<Cond, ParseError> {
        self.nest()?;
        let c = self.contact_inner();
        self.depth -= 1;
        c
    }

    fn contact_inner(&mut self) -> Result<Cond, ParseError> {
        match self.peek() {
            Tok::Slash => {
                self.bump();
                Ok(Cond::Not(Box::new(self.contact()?)))
            }
            Tok::LParen => {
                self.bump();
                let c = self.condition()?;
                self.expect(Tok::RParen, Expected::CloseParen)?;
                self.comparison_tail(c)
            }
            Tok::Ident(word @ ("rising" | "falling")) if self.peek_at(1) == Tok::LParen => {
                self.bump();
                self.bump();
                let arg = self.condition()?;
                self.expect(Tok::RParen, Expected::CloseParen)?;
                Ok(Cond::Edge {
                    rising: word == "rising",
                    arg: Box::new(arg),
                })
            }
            Tok::Ident(word @ ("good" | "bad")) if self.peek_at(1) == Tok::LParen => {
                let at = self.bump().1;
                self.bump();
                let pos = self.pos();
                match (self.peek(), self.peek_at(1)) {
                    (Tok::Ident(name), Tok::RParen) => {
                        self.bump();
                        self.bump();
                        Ok(Cond::Quality {
                            good: word == "good",
                            tag: Name {
                                text: name.to_string(),
                                pos,
                            },
                            pos: at,
                        })
                    }
                    _ => Err((
                        pos,
                        CompileErrorKind::QualityArgument {
                            function: if word == "good" { "good" } else { "bad" },
                        },
                    )),
                }
            }
            Tok::Ident(_) | Tok::Number(_) | Tok::NumberUnit { .. } | Tok::Minus => {
                let operand = self.operand(Expected::Contact)?;
                self.comparison_tail(operand)
            }
            _ => Err(self.unexpected(Expected::Contact)),
        }
    }

    /// `lhs`, or `lhs OP rhs` when a comparison operator follows.
    fn comparison_tail(&mut self, lhs: Cond) -> Result<Cond, ParseError> {
        let op = match self.peek() {
            Tok::Assign | Tok::EqEq => CmpOp::Eq,
            Tok::Ne => CmpOp::Ne,
            Tok::Lt => CmpOp::Lt,
            Tok::Le => CmpOp::Le,
            Tok::Gt => CmpOp::Gt,
            Tok::Ge => CmpOp::Ge,
            _ => return Ok(lhs),
        };
        let pos = self.bump().1;
        let rhs = self.operand(Expected::Operand)?;
        Ok(Cond::Cmp {
            lhs: Box::new(lhs),
            op,
            rhs: Box::new(rhs),
            pos,
        })
    }

    /// A name, `name.MEMBER`, a number, a duration, `true`, `false`.
    fn operand(&mut self, expected: Expected) -> Result<Cond, ParseError> {
        let (tok, pos) = (self.peek(), self.pos());
        match tok {
            Tok::Ident("true") | Tok::Ident("false") => {
                self.bump();
                Ok(Cond::Lit(Lit::Bool(tok == Tok::Ident("true")), pos))
            }
            Tok::Ident(s) => {
                self.bump();
                let name = Name {
                    text: s.to_string(),
                    pos,
                };
                let member = if self.peek() == Tok::Dot {
                    self.bump();
                    Some(self.name(Expected::MemberName)?)
                } else {
                    None
                };
                Ok(Cond::Ref(Ref { name, member }))
            }
            Tok::Number(_) | Tok::NumberUnit { .. } => self.literal(false),
            Tok::Minus => {
                self.bump();
                match self.peek() {
                    Tok::Number(_) | Tok::NumberUnit { .. } => {
                        let lit = self.literal(true)?;
                        Ok(match lit {
                            Cond::Lit(l, _) => Cond::Lit(l, pos),
                            other => other,
                        })
                    }
                    _ => Err(self.unexpected(Expected::Number)),
                }
            }
            _ => Err(self.unexpected(expected)),
        }
    }

    fn literal(&mut self, negative: bool) -> Result<Cond, ParseError> {
        let (tok, pos) = self.bump();
        let sign = if negative { "-" } else { "" };
        Ok(match tok {
            Tok::Number(text) => {
                let value: f64 = text.parse().unwrap_or(f64::INFINITY);
                Cond::Lit(
                    Lit::Number {
                        value: if negative { -value } else { value },
                        text: format!("{sign}{text}"),
                    },
                    pos,
                )
            }
            Tok::NumberUnit { num, unit } => Cond::Lit(
                Lit::Duration {
                    text: format!("{sign}{num}{unit}"),
                },
                pos,
            ),
            _ => return Err(self.unexpected(Expected::Number)),
        })
    }

    fn action(&mut self) -> Result<Action, ParseError> {
        // A block: `KIND name(...)`, an upper-case word followed by a name.
        if let (Tok::Ident(kind), Tok::Ident(_)) = (self.peek(), self.peek_at(1)) {
            if !matches!(kind, "set" | "reset") {
                let kind = self.name(Expected::Action)?;
                let instance = self.name(Expected::Action)?;
                let args = if self.peek() == Tok::LParen {
                    self.args()?
                } else {
                    Vec::new()
                };
                let mut coils = Vec::new();
                if self.peek() == Tok::Arrow {
                    self.bump();
                    coils.push(self.coil()?);
                    while self.peek() == Tok::Comma {
                        self.bump();
                        coils.push(self.coil()?);
                    }
                }
                return Ok(Action::Block {
                    call: BlockCall {
                        kind,
                        instance,
                        args,
                    },
                    coils,
                });
            }
        }
        let mut outputs = vec![self.output()?];
        while self.peek() == Tok::Comma {
            self.bump();
            outputs.push(self.output()?);
        }
        Ok(Action::Outputs(outputs))
    }

    fn output(&mut self) -> Result<Output, ParseError> {
        if let (Tok::Ident(op), Tok::LParen) = (self.peek(), self.peek_at(1)) {
            // Every `WORD(` is a box; the checker names the unknown ones.
            let op = Name {
                text: op.to_string(),
                pos: self.bump().1,
            };
            let args = self.args()?;
            self.expect(Tok::FatArrow, Expected::FatArrow)?;
            let dest = self.name(Expected::Destination)?;
            return Ok(Output::Box(BoxCall { op, args, dest }));
        }
        Ok(Output::Coil(self.coil()?))
    }

    fn coil(&mut self) -> Result<Coil, ParseError> {
        let kind = match self.peek() {
            Tok::Slash => {
                self.bump();
                CoilKind::Negated
            }
            Tok::Ident("set") if matches!(self.peek_at(1), Tok::Ident(_)) => {
                self.bump();
                CoilKind::Set
            }
            Tok::Ident("reset") if matches!(self.peek_at(1), Tok::Ident(_)) => {
                self.bump();
                CoilKind::Reset
            }
            Tok::Ident(_) => CoilKind::Normal,
            _ => return Err(self.unexpected(Expected::Action)),
        };
        let name = self.name(Expected::CoilName)?;
        Ok(Coil { kind, name })
    }

    fn args(&mut self) -> Result<Vec<Arg>, ParseError> {
        self.expect(Tok::LParen, Expected::OpenParen)?;
        let mut args = Vec::new();
        if self.peek() == Tok::RParen {
            self.bump();
            return Ok(args);
        }
        loop {
            let name = match (self.peek(), self.peek_at(1)) {
                (Tok::Ident(n), Tok::Assign) => {
                    let pos = self.bump().1;
                    self.bump();
                    Some(Name {
                        text: n.to_string(),
                        pos,
                    })
                }
                _ => None,
            };
            if !Self::starts_contact(self.peek()) {
                return Err(self.unexpected(Expected::Argument));
            }
            let value = self.condition()?;
            args.push(Arg { name, value });
            match self.peek() {
                Tok::Comma => {
                    self.bump();
                }
                Tok::RParen => {
                    self.bump();
                    return Ok(args);
                }
                _ => return Err(self.unexpected(Expected::CommaOrClose)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(text: &str, pos: usize) -> Cond {
        Cond::Ref(Ref {
            name: Name {
                text: text.into(),
                pos,
            },
            member: None,
        })
    }

    #[test]
    fn series_binds_tighter_than_parallel() {
        let rung = parse_rung("a /b | c -> q").unwrap();
        assert_eq!(
            rung.cond,
            Some(Cond::Parallel(vec![
                Cond::Series(vec![r("a", 0), Cond::Not(Box::new(r("b", 3)))]),
                r("c", 7),
            ]))
        );
        assert_eq!(
            rung.action,
            Action::Outputs(vec![Output::Coil(Coil {
                kind: CoilKind::Normal,
                name: Name {
                    text: "q".into(),
                    pos: 12
                }
            })])
        );
    }

    #[test]
    fn blocks_boxes_and_coils() {
        let rung = parse_rung("x -> CTU n(10, r=rst) -> full, /empty").unwrap();
        let Action::Block { call, coils } = rung.action else {
            panic!("a block")
        };
        assert_eq!(call.kind.text, "CTU");
        assert_eq!(call.instance.text, "n");
        assert_eq!(call.args.len(), 2);
        assert_eq!(
            call.args[1].name.as_ref().map(|n| n.text.as_str()),
            Some("r")
        );
        assert_eq!(coils[1].kind, CoilKind::Negated);

        let rung = parse_rung("-> ADD(h, 1) => h, set on, reset off").unwrap();
        assert_eq!(rung.cond, None);
        let Action::Outputs(outs) = rung.action else {
            panic!("outputs")
        };
        assert!(matches!(&outs[0], Output::Box(b) if b.dest.text == "h"));
        assert!(matches!(&outs[1], Output::Coil(c) if c.kind == CoilKind::Set));
        assert!(matches!(&outs[2], Output::Coil(c) if c.kind == CoilKind::Reset));
    }

    #[test]
    fn comparisons_edges_and_members() {
        let rung = parse_rung("rising(b) t.ET >= 1.5s level <> -3 -> q").unwrap();
        let Some(Cond::Series(items)) = rung.cond else {
            panic!("series")
        };
        assert!(matches!(items[0], Cond::Edge { rising: true, .. }));
        assert!(matches!(&items[1], Cond::Cmp { op: CmpOp::Ge, .. }));
        assert!(
            matches!(&items[2], Cond::Cmp { op: CmpOp::Ne, rhs, .. } if **rhs == Cond::Lit(Lit::Number { value: -3.0, text: "-3".into() }, 32))
        );
    }

    #[test]
    fn quality_contacts() {
        let rung = parse_rung("/good(level) bad(x) good -> alarm").unwrap();
        let quality = |good, text: &str, pos: usize| Cond::Quality {
            good,
            tag: Name {
                text: text.into(),
                pos,
            },
            pos: pos - if good { 5 } else { 4 },
        };
        assert_eq!(
            rung.cond,
            Some(Cond::Series(vec![
                Cond::Not(Box::new(quality(true, "level", 6))),
                quality(false, "x", 17),
                // Without `(`, `good` is a tag.
                r("good", 20),
            ]))
        );
        let err = |t: &str| parse_rung(t).unwrap_err();
        let arg = |function| CompileErrorKind::QualityArgument { function };
        assert_eq!(err("good(a b) -> q"), (5, arg("good")));
        assert_eq!(err("bad(t.Q) -> q"), (4, arg("bad")));
        assert_eq!(err("good() -> q"), (5, arg("good")));
        assert_eq!(err("good(/a) -> q"), (5, arg("good")));
    }

    #[test]
    fn syntax_errors_point_at_the_token() {
        let err = |t: &str| parse_rung(t).unwrap_err();
        assert_eq!(err("").1, CompileErrorKind::EmptyRung);
        assert_eq!(err("a b").0, 3);
        assert_eq!(err("a -> ").0, 5);
        assert_eq!(err("(a -> q").0, 3);
        assert_eq!(err("a -> q )").0, 7);
        assert_eq!(err("a -> ADD(1; 2) => x").0, 10);
        assert_eq!(err("a @ -> q").0, 2);
        let deep = format!("{}a{} -> q", "(".repeat(100), ")".repeat(100));
        assert!(matches!(err(&deep).1, CompileErrorKind::TooDeep { .. }));
        let nots = format!("{}a -> q", "/".repeat(10_000));
        assert!(matches!(err(&nots).1, CompileErrorKind::TooDeep { .. }));
    }
}
