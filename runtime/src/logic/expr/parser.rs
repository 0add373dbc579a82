//! Recursive-descent parser: one line → one [`Stmt`] (or nothing for a blank/comment line).
//!
//! The first syntax error of a line ends that line's parse; the other lines are still parsed.
//! `&`, `^` and `|` chains build n-ary nodes, so the tree depth is bounded by the nesting of
//! `(`, `!` and calls, which is limited to [`MAX_DEPTH`]: no program text can overflow the stack.

use super::error::{CompileErrorKind, Expected};
use super::lexer::{lex_line, Spanned, Tok};
use crate::logic::blocks::Kind;
use crate::logic::vm::CmpOp;

/// Deepest nesting of parentheses, `!`/`not` and calls.
pub(crate) const MAX_DEPTH: u32 = 64;

/// A 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) struct Pos {
    pub line: u32,
    pub col: u32,
}

/// A name and where it is written.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Ident {
    pub name: String,
    pub pos: Pos,
}

/// `COIL = EXPR`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Stmt {
    pub coil: Ident,
    pub expr: Expr,
}

/// `rising` or `falling`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum EdgeKind {
    Rising,
    Falling,
}

/// The function names, for "did you mean".
pub(crate) fn functions() -> Vec<&'static str> {
    let blocks = Kind::ALL.iter().filter(|k| k.def().expr);
    let blocks = blocks.map(|k| k.def().function());
    ["rising", "falling"]
        .into_iter()
        .chain(blocks)
        .chain(["good", "bad"])
        .collect()
}

/// The block `expr` offers as function `name` (`ton`): a plain timer.
fn timer(name: &str) -> Option<Kind> {
    Kind::ALL
        .into_iter()
        .find(|k| k.def().expr && k.def().function() == name)
}

/// A number literal as written (`-` included) and its value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct NumLit {
    pub text: String,
    pub value: f64,
    pub pos: Pos,
}

/// A timer's duration as written: number and unit (checked by the checker).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct DurLit {
    pub num: String,
    pub unit: Option<String>,
    pub pos: Pos,
}

/// An expression, untyped.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Expr {
    Tag(Ident),
    Number(NumLit),
    Bool(bool),
    Not(Box<Expr>),
    /// Two or more operands.
    And(Vec<Expr>),
    /// Two or more operands.
    Xor(Vec<Expr>),
    /// Two or more operands.
    Or(Vec<Expr>),
    Cmp {
        lhs: Box<Expr>,
        lhs_pos: Pos,
        op: CmpOp,
        rhs: Box<Expr>,
        rhs_pos: Pos,
    },
    Edge {
        kind: EdgeKind,
        arg: Box<Expr>,
    },
    Timer {
        kind: Kind,
        arg: Box<Expr>,
        preset: DurLit,
    },
    /// `good(tag)` (`good`) or `bad(tag)`: a test of the tag's quality.
    Quality {
        good: bool,
        tag: Ident,
    },
}

/// A syntax error and where.
pub(crate) type ParseError = (Pos, CompileErrorKind);

/// Parses one line (1-based number `line`). `Ok(None)` for a blank or comment-only line.
pub(crate) fn parse_line(text: &str, line: u32) -> Result<Option<Stmt>, ParseError> {
    let toks = lex_line(text);
    if matches!(toks.first(), Some((Tok::End, _))) {
        return Ok(None);
    }
    let mut p = Parser {
        toks,
        at: 0,
        line,
        depth: 0,
    };
    p.statement().map(Some)
}

struct Parser<'a> {
    toks: Vec<Spanned<'a>>,
    at: usize,
    line: u32,
    depth: u32,
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Tok<'a> {
        self.toks.get(self.at).map_or(Tok::End, |t| t.0)
    }

    fn peek2(&self) -> Tok<'a> {
        self.toks.get(self.at + 1).map_or(Tok::End, |t| t.0)
    }

    fn pos(&self) -> Pos {
        let col = self
            .toks
            .get(self.at)
            .or(self.toks.last())
            .map_or(1, |t| t.1);
        Pos {
            line: self.line,
            col,
        }
    }

    fn bump(&mut self) -> Tok<'a> {
        let t = self.peek();
        if self.at < self.toks.len() {
            self.at += 1;
        }
        t
    }

    fn error<T>(&self, expected: Expected) -> Result<T, ParseError> {
        Err((
            self.pos(),
            CompileErrorKind::Syntax {
                expected,
                found: self.peek().to_string(),
            },
        ))
    }

    fn expect(&mut self, tok: Tok<'_>, expected: Expected) -> Result<(), ParseError> {
        if self.peek() == tok {
            self.bump();
            Ok(())
        } else {
            self.error(expected)
        }
    }

    fn enter(&mut self) -> Result<(), ParseError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            Err((self.pos(), CompileErrorKind::TooDeep { limit: MAX_DEPTH }))
        } else {
            Ok(())
        }
    }

    fn leave(&mut self) {
        self.depth = self.depth.saturating_sub(1);
    }

    fn statement(&mut self) -> Result<Stmt, ParseError> {
        let pos = self.pos();
        let Tok::Ident(name) = self.peek() else {
            return self.error(Expected::CoilName);
        };
        self.bump();
        self.expect(Tok::Assign, Expected::Assign)?;
        let expr = self.or()?;
        self.expect(Tok::End, Expected::OperatorOrEnd)?;
        Ok(Stmt {
            coil: Ident {
                name: name.to_string(),
                pos,
            },
            expr,
        })
    }

    /// `xor (('|' | 'or') xor)*`
    fn or(&mut self) -> Result<Expr, ParseError> {
        let mut items = vec![self.xor()?];
        while matches!(self.peek(), Tok::Pipe | Tok::KwOr) {
            self.bump();
            items.push(self.xor()?);
        }
        Ok(if items.len() == 1 {
            items.remove(0)
        } else {
            Expr::Or(items)
        })
    }

    /// `and ('^' and)*`
    fn xor(&mut self) -> Result<Expr, ParseError> {
        let mut items = vec![self.and()?];
        while self.peek() == Tok::Caret {
            self.bump();
            items.push(self.and()?);
        }
        Ok(if items.len() == 1 {
            items.remove(0)
        } else {
            Expr::Xor(items)
        })
    }

    /// `unary (('&' | 'and') unary)*`
    fn and(&mut self) -> Result<Expr, ParseError> {
        let mut items = vec![self.unary()?];
        while matches!(self.peek(), Tok::Amp | Tok::KwAnd) {
            self.bump();
            items.push(self.unary()?);
        }
        Ok(if items.len() == 1 {
            items.remove(0)
        } else {
            Expr::And(items)
        })
    }

    /// `('!' | 'not') unary | cmp`
    fn unary(&mut self) -> Result<Expr, ParseError> {
        if matches!(self.peek(), Tok::Bang | Tok::KwNot) {
            self.enter()?;
            self.bump();
            let inner = self.unary();
            self.leave();
            return Ok(Expr::Not(Box::new(inner?)));
        }
        self.cmp()
    }

    /// `primary [cmpop primary]`
    fn cmp(&mut self) -> Result<Expr, ParseError> {
        let lhs_pos = self.pos();
        let lhs = self.primary(Expected::Operand)?;
        let op = match self.peek() {
            Tok::Lt => CmpOp::Lt,
            Tok::Le => CmpOp::Le,
            Tok::Gt => CmpOp::Gt,
            Tok::Ge => CmpOp::Ge,
            Tok::Eq => CmpOp::Eq,
            Tok::Ne => CmpOp::Ne,
            _ => return Ok(lhs),
        };
        self.bump();
        let rhs_pos = self.pos();
        let rhs = self.primary(Expected::ComparisonOperand)?;
        Ok(Expr::Cmp {
            lhs: Box::new(lhs),
            lhs_pos,
            op,
            rhs: Box::new(rhs),
            rhs_pos,
        })
    }

    /// A tag, a literal, `-NUMBER`, `( expr )` or a call.
    fn primary(&mut self, expected: Expected) -> Result<Expr, ParseError> {
        let pos = self.pos();
        match self.peek() {
            Tok::Ident(name) if self.peek2() == Tok::LParen => self.call(name, pos),
            Tok::Ident(name) => {
                self.bump();
                Ok(Expr::Tag(Ident {
                    name: name.to_string(),
                    pos,
                }))
            }
            Tok::KwTrue | Tok::KwFalse => Ok(Expr::Bool(self.bump() == Tok::KwTrue)),
            Tok::Number(text) => {
                self.bump();
                Ok(Expr::Number(NumLit {
                    text: text.to_string(),
                    value: number(text),
                    pos,
                }))
            }
            Tok::Minus => {
                self.bump();
                let Tok::Number(text) = self.peek() else {
                    return self.error(Expected::Number);
                };
                self.bump();
                Ok(Expr::Number(NumLit {
                    text: format!("-{text}"),
                    value: -number(text),
                    pos,
                }))
            }
            Tok::LParen => {
                self.enter()?;
                self.bump();
                let inner = self.or().and_then(|e| {
                    self.expect(Tok::RParen, Expected::CloseParen)?;
                    Ok(e)
                });
                self.leave();
                inner
            }
            _ => self.error(expected),
        }
    }

    /// `rising(e)`, `falling(e)`, a plain timer (`ton(e, D)`, ...: [`functions`]),
    /// `good(tag)`, `bad(tag)`; at the name.
    fn call(&mut self, name: &str, pos: Pos) -> Result<Expr, ParseError> {
        let func = match name {
            "good" | "bad" => return self.quality(name == "good"),
            "rising" => Func::Edge(EdgeKind::Rising),
            "falling" => Func::Edge(EdgeKind::Falling),
            _ => match timer(name) {
                Some(kind) => Func::Timer(kind),
                None => {
                    let suggestion = super::check::closest(name, functions().into_iter());
                    let name = name.to_string();
                    return Err((pos, CompileErrorKind::UnknownFunction { name, suggestion }));
                }
            },
        };
        self.bump();
        self.enter()?;
        let call = self.call_args(func);
        self.leave();
        call
    }

    /// `good(tag)` or `bad(tag)`, at the name: the argument is a tag name, not an expression
    /// (quality belongs to a tag read from a module).
    fn quality(&mut self, good: bool) -> Result<Expr, ParseError> {
        self.bump();
        self.expect(Tok::LParen, Expected::OpenParen)?;
        let pos = self.pos();
        match (self.peek(), self.peek2()) {
            (Tok::Ident(name), Tok::RParen) => {
                self.bump();
                self.bump();
                Ok(Expr::Quality {
                    good,
                    tag: Ident {
                        name: name.to_string(),
                        pos,
                    },
                })
            }
            _ => Err((
                pos,
                CompileErrorKind::QualityArgument {
                    function: if good { "good" } else { "bad" },
                },
            )),
        }
    }

    /// `( expr )` or `( expr , duration )`, after the function name.
    fn call_args(&mut self, func: Func) -> Result<Expr, ParseError> {
        self.expect(Tok::LParen, Expected::OpenParen)?;
        let arg = Box::new(self.or()?);
        let call = match func {
            Func::Edge(kind) => Expr::Edge { kind, arg },
            Func::Timer(kind) => {
                self.expect(Tok::Comma, Expected::Comma)?;
                let pos = self.pos();
                let preset = match self.peek() {
                    Tok::Number(num) => DurLit {
                        num: num.to_string(),
                        unit: None,
                        pos,
                    },
                    Tok::NumberUnit { num, unit } => DurLit {
                        num: num.to_string(),
                        unit: Some(unit.to_string()),
                        pos,
                    },
                    _ => return self.error(Expected::Duration),
                };
                self.bump();
                Expr::Timer { kind, arg, preset }
            }
        };
        self.expect(Tok::RParen, Expected::CloseParen)?;
        Ok(call)
    }
}

/// A built-in function.
#[derive(Debug, Clone, Copy)]
enum Func {
    Edge(EdgeKind),
    Timer(Kind),
}

/// The value of a lexed number (`digits[.digits]`, always parseable; huge ones become large).
fn number(text: &str) -> f64 {
    text.parse().unwrap_or(f64::INFINITY)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tree as an S-expression.
    fn sexp(e: &Expr) -> String {
        let list = |op: &str, items: &[Expr]| {
            let inner: Vec<String> = items.iter().map(sexp).collect();
            format!("({op} {})", inner.join(" "))
        };
        match e {
            Expr::Tag(i) => i.name.clone(),
            Expr::Number(n) => n.text.clone(),
            Expr::Bool(b) => b.to_string(),
            Expr::Not(e) => format!("(not {})", sexp(e)),
            Expr::And(v) => list("and", v),
            Expr::Xor(v) => list("xor", v),
            Expr::Or(v) => list("or", v),
            Expr::Cmp { lhs, op, rhs, .. } => {
                format!("({} {} {})", op.symbol(), sexp(lhs), sexp(rhs))
            }
            Expr::Edge { kind, arg } => format!("({kind:?} {})", sexp(arg)).to_lowercase(),
            Expr::Timer { kind, arg, preset } => format!(
                "({} {} {}{})",
                format!("{kind:?}").to_lowercase(),
                sexp(arg),
                preset.num,
                preset.unit.as_deref().unwrap_or("")
            ),
            Expr::Quality { good, tag } => {
                format!("({} {})", if *good { "good" } else { "bad" }, tag.name)
            }
        }
    }

    fn parse(text: &str) -> String {
        let stmt = parse_line(text, 1).unwrap().unwrap();
        format!("{} = {}", stmt.coil.name, sexp(&stmt.expr))
    }

    fn err(text: &str) -> (u32, String) {
        let (pos, kind) = parse_line(text, 1).unwrap_err();
        (pos.col, kind.to_string())
    }

    #[test]
    fn precedence_not_and_xor_or() {
        assert_eq!(
            parse("q = a | b ^ c & !d"),
            "q = (or a (xor b (and c (not d))))"
        );
        assert_eq!(parse("q = !a & b | c"), "q = (or (and (not a) b) c)");
        assert_eq!(
            parse("q = a & b & c | d ^ e ^ f"),
            "q = (or (and a b c) (xor d e f))"
        );
        assert_eq!(parse("q = a ^ b | c ^ d"), "q = (or (xor a b) (xor c d))");
        assert_eq!(parse("q = (a | b) & c"), "q = (and (or a b) c)");
        assert_eq!(parse("q = !(a | b)"), "q = (not (or a b))");
        assert_eq!(parse("q = !!a"), "q = (not (not a))");
    }

    #[test]
    fn keywords_are_synonyms() {
        assert_eq!(parse("q = a or b and not c"), parse("q = a | b & !c"));
        assert_eq!(
            parse("q = true & false | 0 ^ 1"),
            "q = (or (and true false) (xor 0 1))"
        );
    }

    #[test]
    fn comparisons_bind_tighter_than_not_and_and() {
        assert_eq!(parse("q = !level > 5"), "q = (not (> level 5))");
        assert_eq!(
            parse("q = a & level <= 2.5 | t != -3"),
            "q = (or (and a (<= level 2.5)) (!= t -3))"
        );
        assert_eq!(parse("q = x == 0"), "q = (== x 0)");
    }

    #[test]
    fn calls() {
        assert_eq!(
            parse("q = rising(a) & !falling(b | c)"),
            "q = (and (rising a) (not (falling (or b c))))"
        );
        assert_eq!(
            parse("q = ton(a & b, 2s) | tof(c, 1.5s) ^ tp(d, 100us)"),
            "q = (or (ton (and a b) 2s) (xor (tof c 1.5s) (tp d 100us)))"
        );
        // A function name without `(` is a tag.
        assert_eq!(parse("q = ton"), "q = ton");
    }

    #[test]
    fn syntax_errors_point_at_the_token() {
        assert_eq!(err("= a"), (1, "expected a coil name, found `=`".into()));
        assert_eq!(err("q a"), (3, "expected `=`, found `a`".into()));
        assert_eq!(
            err("q ="),
            (
                4,
                "expected a tag, 0, 1, true, false, `!`, `(` or a function call, found end of line"
                    .into()
            )
        );
        assert_eq!(
            err("q = a b"),
            (7, "expected an operator or end of line, found `b`".into())
        );
        assert_eq!(
            err("q = (a | b"),
            (11, "expected `)`, found end of line".into())
        );
        assert_eq!(
            err("q = a && b"),
            (
                8,
                "expected a tag, 0, 1, true, false, `!`, `(` or a function call, found `&`".into()
            )
        );
        assert_eq!(err("q = ton(a)"), (10, "expected `,`, found `)`".into()));
        assert_eq!(
            err("q = rising(a, 2s)"),
            (13, "expected `)`, found `,`".into())
        );
        assert_eq!(
            err("q = tp(a, b)"),
            (11, "expected a duration like `250ms`, found `b`".into())
        );
        assert_eq!(
            err("q = x > !y"),
            (9, "expected a tag or a number, found `!`".into())
        );
        assert_eq!(
            err("q = x > -y"),
            (10, "expected a number, found `y`".into())
        );
        assert_eq!(
            err("q = a @ b"),
            (7, "expected an operator or end of line, found `@`".into())
        );
        assert_eq!(
            err("q = 2s"),
            (
                5,
                "expected a tag, 0, 1, true, false, `!`, `(` or a function call, found `2s`".into()
            )
        );
        assert_eq!(
            err("q = a < b < c"),
            (11, "expected an operator or end of line, found `<`".into())
        );
    }

    #[test]
    fn unknown_function_suggests() {
        assert_eq!(
            err("q = rsing(a)"),
            (5, "unknown function `rsing`; did you mean `rising`?; the functions are rising, falling, ton, tof, tp, good and bad".into())
        );
    }

    #[test]
    fn quality_tests_take_a_tag_name() {
        assert_eq!(
            parse("alarm = !good(level_high) | bad(x)"),
            "alarm = (or (not (good level_high)) (bad x))"
        );
        // A tag may still be called `good`.
        assert_eq!(parse("q = good & bad"), "q = (and good bad)");
        let msg = "`good` takes a tag name, e.g. `good(level)`, not an expression".to_string();
        assert_eq!(err("q = good(a & b)"), (10, msg.clone()));
        assert_eq!(err("q = good(!a)"), (10, msg.clone()));
        assert_eq!(err("q = good()"), (10, msg));
        assert_eq!(
            err("q = bad(1)"),
            (
                9,
                "`bad` takes a tag name, e.g. `bad(level)`, not an expression".into()
            )
        );
        // Without `(` it is a tag named `good`.
        assert_eq!(
            err("q = good a"),
            (10, "expected an operator or end of line, found `a`".into())
        );
    }

    #[test]
    fn nesting_is_limited() {
        let ok = format!(
            "q = {}a{}",
            "(".repeat(MAX_DEPTH as usize),
            ")".repeat(MAX_DEPTH as usize)
        );
        assert!(parse_line(&ok, 1).is_ok());
        let deep = format!("q = {}a", "(".repeat(100_000));
        let (pos, kind) = parse_line(&deep, 1).unwrap_err();
        assert_eq!(kind, CompileErrorKind::TooDeep { limit: MAX_DEPTH });
        assert_eq!(pos.col, 5 + MAX_DEPTH);
        let nots = format!("q = {}a", "!".repeat(100_000));
        assert!(matches!(
            parse_line(&nots, 1),
            Err((_, CompileErrorKind::TooDeep { .. }))
        ));
        let calls = format!("q = {}a", "rising(".repeat(100_000));
        assert!(matches!(
            parse_line(&calls, 1),
            Err((_, CompileErrorKind::TooDeep { .. }))
        ));
        let long = format!("q = a{}", " & a".repeat(100_000));
        assert!(parse_line(&long, 1).is_ok());
    }

    #[test]
    fn blank_and_comment_lines() {
        assert_eq!(parse_line("", 1), Ok(None));
        assert_eq!(parse_line("  \t # x = y", 1), Ok(None));
        assert_eq!(parse("q = a # trailing comment"), "q = a");
    }
}
