//! Tokens of one rung. The lexer never fails: a character the language does not use becomes
//! [`Tok::Unknown`] and the parser reports it where it meets it. Positions are character
//! indexes into the rung's text (0-based); [`super::source`] turns them into `line:col`.

use std::fmt;

/// Longest token text quoted back in an error message.
const MAX_QUOTED: usize = 32;

/// One token.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Tok<'a> {
    /// A name: `motor`, `TON`, `set`.
    Ident(&'a str),
    /// A number without a unit: `5`, `1.5`, `1101`.
    Number(&'a str),
    /// A number directly followed by letters: `250ms`, `2s`.
    NumberUnit {
        /// The digits.
        num: &'a str,
        /// The letters.
        unit: &'a str,
    },
    /// `/` (normally closed contact, negated coil)
    Slash,
    /// `|` (parallel branch)
    Pipe,
    /// `(`
    LParen,
    /// `)`
    RParen,
    /// `,`
    Comma,
    /// `.`
    Dot,
    /// `->` (power flows to the action)
    Arrow,
    /// `=>` (result goes to)
    FatArrow,
    /// `=` (a named argument; equality in a comparison)
    Assign,
    /// `==`
    EqEq,
    /// `<>` or `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `-` before a number
    Minus,
    /// A character the language does not use.
    Unknown(char),
    /// The end of the rung.
    End,
}

impl fmt::Display for Tok<'_> {
    /// How an error message names the token.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let fixed = match self {
            Tok::Ident(s) | Tok::Number(s) => return write!(f, "`{}`", clip(s)),
            Tok::NumberUnit { num, unit } => return write!(f, "`{}{}`", clip(num), clip(unit)),
            Tok::Unknown(c) => return write!(f, "`{}`", c.escape_debug()),
            Tok::End => return f.write_str("end of rung"),
            Tok::Slash => "/",
            Tok::Pipe => "|",
            Tok::LParen => "(",
            Tok::RParen => ")",
            Tok::Comma => ",",
            Tok::Dot => ".",
            Tok::Arrow => "->",
            Tok::FatArrow => "=>",
            Tok::Assign => "=",
            Tok::EqEq => "==",
            Tok::Ne => "<>",
            Tok::Lt => "<",
            Tok::Le => "<=",
            Tok::Gt => ">",
            Tok::Ge => ">=",
            Tok::Minus => "-",
        };
        write!(f, "`{fixed}`")
    }
}

/// At most [`MAX_QUOTED`] characters of `s`, with `…` when cut.
fn clip(s: &str) -> String {
    match s.char_indices().nth(MAX_QUOTED) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

/// A token and the character index where it starts.
pub(crate) type Spanned<'a> = (Tok<'a>, usize);

/// Splits a rung into tokens; the last is always [`Tok::End`], after the last character.
pub(crate) fn lex(text: &str) -> Vec<Spanned<'_>> {
    let mut out = Vec::new();
    let chars: Vec<(usize, char)> = text.char_indices().collect();
    let byte_at = |i: usize| chars.get(i).map_or(text.len(), |&(b, _)| b);
    let mut i = 0;
    while let Some(&(_, c)) = chars.get(i) {
        let start = i;
        let next = chars.get(i + 1).map(|&(_, d)| d);
        let tok = match c {
            c if c.is_whitespace() => {
                i += 1;
                continue;
            }
            c if c.is_ascii_alphabetic() || c == '_' => {
                i += 1;
                while chars
                    .get(i)
                    .is_some_and(|&(_, d)| d.is_ascii_alphanumeric() || d == '_')
                {
                    i += 1;
                }
                out.push((Tok::Ident(&text[byte_at(start)..byte_at(i)]), start));
                continue;
            }
            c if c.is_ascii_digit() => {
                i += 1;
                let mut seen_dot = false;
                loop {
                    match chars.get(i).map(|&(_, d)| d) {
                        Some(d) if d.is_ascii_digit() => i += 1,
                        Some('.')
                            if !seen_dot
                                && chars.get(i + 1).is_some_and(|&(_, d)| d.is_ascii_digit()) =>
                        {
                            seen_dot = true;
                            i += 1;
                        }
                        _ => break,
                    }
                }
                let num = &text[byte_at(start)..byte_at(i)];
                let unit_start = i;
                while chars.get(i).is_some_and(|&(_, d)| d.is_ascii_alphabetic()) {
                    i += 1;
                }
                let tok = if i > unit_start {
                    Tok::NumberUnit {
                        num,
                        unit: &text[byte_at(unit_start)..byte_at(i)],
                    }
                } else {
                    Tok::Number(num)
                };
                out.push((tok, start));
                continue;
            }
            '-' if next == Some('>') => {
                i += 1;
                Tok::Arrow
            }
            '=' if next == Some('>') => {
                i += 1;
                Tok::FatArrow
            }
            '=' if next == Some('=') => {
                i += 1;
                Tok::EqEq
            }
            '<' if next == Some('>') => {
                i += 1;
                Tok::Ne
            }
            '!' if next == Some('=') => {
                i += 1;
                Tok::Ne
            }
            '<' if next == Some('=') => {
                i += 1;
                Tok::Le
            }
            '>' if next == Some('=') => {
                i += 1;
                Tok::Ge
            }
            '=' => Tok::Assign,
            '<' => Tok::Lt,
            '>' => Tok::Gt,
            '-' => Tok::Minus,
            '/' => Tok::Slash,
            '|' => Tok::Pipe,
            '(' => Tok::LParen,
            ')' => Tok::RParen,
            ',' => Tok::Comma,
            '.' => Tok::Dot,
            other => Tok::Unknown(other),
        };
        i += 1;
        out.push((tok, start));
    }
    out.push((Tok::End, chars.len()));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_with_char_indexes() {
        let toks = lex("(start | m) /stop -> TON t(2s) -> lamp");
        let kinds: Vec<Tok> = toks.iter().map(|t| t.0).collect();
        assert_eq!(
            kinds,
            vec![
                Tok::LParen,
                Tok::Ident("start"),
                Tok::Pipe,
                Tok::Ident("m"),
                Tok::RParen,
                Tok::Slash,
                Tok::Ident("stop"),
                Tok::Arrow,
                Tok::Ident("TON"),
                Tok::Ident("t"),
                Tok::LParen,
                Tok::NumberUnit {
                    num: "2",
                    unit: "s"
                },
                Tok::RParen,
                Tok::Arrow,
                Tok::Ident("lamp"),
                Tok::End,
            ]
        );
        assert_eq!(toks[5].1, 12);
        assert_eq!(toks.last().map(|t| t.1), Some(38));
    }

    #[test]
    fn operators_and_odd_characters() {
        let kinds: Vec<Tok> = lex("a<>b!=c<=d>=e==f=g=>h -1.5 é 1. x.Q")
            .into_iter()
            .map(|t| t.0)
            .collect();
        assert!(kinds.contains(&Tok::Ne));
        assert!(kinds.contains(&Tok::FatArrow));
        assert!(kinds.contains(&Tok::Unknown('é')));
        assert!(kinds.contains(&Tok::Number("1.5")));
        assert!(kinds.contains(&Tok::Dot));
        assert_eq!(lex(""), vec![(Tok::End, 0)]);
    }
}
