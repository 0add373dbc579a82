//! Tokens of one line of an `.expr` program.
//!
//! The lexer never fails: a character it does not know becomes [`Tok::Unknown`], and the parser
//! reports it as "expected X, found `@`" where it meets it. Columns count characters (a tab is one
//! column), 1-based.

use std::fmt;

/// Longest token text quoted back in an error message.
const MAX_QUOTED: usize = 32;

/// One token.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Tok<'a> {
    /// A name: `motor`, `box_at_exit`, `rising`.
    Ident(&'a str),
    /// A number without a unit: `5`, `1.5`.
    Number(&'a str),
    /// A number directly followed by letters: `250ms`, `2s`, `2h` (unit checked later).
    NumberUnit {
        /// The digits.
        num: &'a str,
        /// The letters.
        unit: &'a str,
    },
    /// `and`
    KwAnd,
    /// `or`
    KwOr,
    /// `not`
    KwNot,
    /// `true`
    KwTrue,
    /// `false`
    KwFalse,
    /// `!`
    Bang,
    /// `&`
    Amp,
    /// `|`
    Pipe,
    /// `^`
    Caret,
    /// `(`
    LParen,
    /// `)`
    RParen,
    /// `,`
    Comma,
    /// `=`
    Assign,
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `-` (only before a number literal)
    Minus,
    /// A character the language does not use.
    Unknown(char),
    /// End of the line (or the start of a comment).
    End,
}

impl fmt::Display for Tok<'_> {
    /// How an error message names the token: quoted text, or "end of line".
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let fixed = match self {
            Tok::Ident(s) | Tok::Number(s) => return write!(f, "`{}`", clip(s)),
            Tok::NumberUnit { num, unit } => return write!(f, "`{}{}`", clip(num), clip(unit)),
            Tok::Unknown(c) => return write!(f, "`{}`", c.escape_debug()),
            Tok::End => return f.write_str("end of line"),
            Tok::KwAnd => "and",
            Tok::KwOr => "or",
            Tok::KwNot => "not",
            Tok::KwTrue => "true",
            Tok::KwFalse => "false",
            Tok::Bang => "!",
            Tok::Amp => "&",
            Tok::Pipe => "|",
            Tok::Caret => "^",
            Tok::LParen => "(",
            Tok::RParen => ")",
            Tok::Comma => ",",
            Tok::Assign => "=",
            Tok::Eq => "==",
            Tok::Ne => "!=",
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

/// A token and its 1-based column.
pub(crate) type Spanned<'a> = (Tok<'a>, u32);

/// Splits one line (without its newline) into tokens; the last one is always [`Tok::End`], at the
/// column after the last character before any comment.
pub(crate) fn lex_line(line: &str) -> Vec<Spanned<'_>> {
    let mut out = Vec::new();
    let mut chars = line.char_indices().peekable();
    let mut col: u32 = 0;
    let mut end_col: u32 = 1;
    while let Some((start, c)) = chars.next() {
        col = col.saturating_add(1);
        end_col = col.saturating_add(1);
        let tok_col = col;
        let tok = match c {
            '#' => {
                end_col = col;
                break;
            }
            c if c.is_whitespace() => continue,
            c if c.is_ascii_alphabetic() || c == '_' => {
                let mut end = start + c.len_utf8();
                while let Some(&(i, d)) = chars.peek() {
                    if d.is_ascii_alphanumeric() || d == '_' {
                        end = i + d.len_utf8();
                        col = col.saturating_add(1);
                        chars.next();
                    } else {
                        break;
                    }
                }
                keyword(&line[start..end])
            }
            c if c.is_ascii_digit() => {
                let mut end = start + 1;
                let mut seen_dot = false;
                while let Some(&(i, d)) = chars.peek() {
                    let is_fraction_dot = d == '.'
                        && !seen_dot
                        && line[i + 1..]
                            .chars()
                            .next()
                            .is_some_and(|n| n.is_ascii_digit());
                    if d.is_ascii_digit() || is_fraction_dot {
                        seen_dot |= d == '.';
                        end = i + 1;
                        col = col.saturating_add(1);
                        chars.next();
                    } else {
                        break;
                    }
                }
                let num = &line[start..end];
                let unit_start = end;
                while let Some(&(i, d)) = chars.peek() {
                    if d.is_ascii_alphanumeric() || d == '_' {
                        end = i + 1;
                        col = col.saturating_add(1);
                        chars.next();
                    } else {
                        break;
                    }
                }
                if end > unit_start {
                    Tok::NumberUnit {
                        num,
                        unit: &line[unit_start..end],
                    }
                } else {
                    Tok::Number(num)
                }
            }
            '!' | '=' | '<' | '>' => {
                let two = chars.peek().is_some_and(|&(_, d)| d == '=');
                if two {
                    col = col.saturating_add(1);
                    chars.next();
                }
                match (c, two) {
                    ('!', false) => Tok::Bang,
                    ('!', true) => Tok::Ne,
                    ('=', false) => Tok::Assign,
                    ('=', true) => Tok::Eq,
                    ('<', false) => Tok::Lt,
                    ('<', true) => Tok::Le,
                    ('>', false) => Tok::Gt,
                    _ => Tok::Ge,
                }
            }
            '&' => Tok::Amp,
            '|' => Tok::Pipe,
            '^' => Tok::Caret,
            '(' => Tok::LParen,
            ')' => Tok::RParen,
            ',' => Tok::Comma,
            '-' => Tok::Minus,
            other => Tok::Unknown(other),
        };
        end_col = col.saturating_add(1);
        out.push((tok, tok_col));
    }
    out.push((Tok::End, end_col));
    out
}

fn keyword(word: &str) -> Tok<'_> {
    match word {
        "and" => Tok::KwAnd,
        "or" => Tok::KwOr,
        "not" => Tok::KwNot,
        "true" => Tok::KwTrue,
        "false" => Tok::KwFalse,
        _ => Tok::Ident(word),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_with_columns() {
        let toks = lex_line("motor = (start|motor) & !stop  # latch");
        assert_eq!(
            toks,
            vec![
                (Tok::Ident("motor"), 1),
                (Tok::Assign, 7),
                (Tok::LParen, 9),
                (Tok::Ident("start"), 10),
                (Tok::Pipe, 15),
                (Tok::Ident("motor"), 16),
                (Tok::RParen, 21),
                (Tok::Amp, 23),
                (Tok::Bang, 25),
                (Tok::Ident("stop"), 26),
                (Tok::End, 32),
            ]
        );
    }

    #[test]
    fn numbers_durations_and_two_char_operators() {
        let toks: Vec<_> = lex_line("ton(a>=1.5,250ms)!=2h<=x==-3 1.")
            .into_iter()
            .map(|t| t.0)
            .collect();
        assert_eq!(
            toks,
            vec![
                Tok::Ident("ton"),
                Tok::LParen,
                Tok::Ident("a"),
                Tok::Ge,
                Tok::Number("1.5"),
                Tok::Comma,
                Tok::NumberUnit {
                    num: "250",
                    unit: "ms"
                },
                Tok::RParen,
                Tok::Ne,
                Tok::NumberUnit {
                    num: "2",
                    unit: "h"
                },
                Tok::Le,
                Tok::Ident("x"),
                Tok::Eq,
                Tok::Minus,
                Tok::Number("3"),
                Tok::Number("1"),
                Tok::Unknown('.'),
                Tok::End,
            ]
        );
    }

    #[test]
    fn keywords_unknown_chars_and_end_column() {
        let toks = lex_line("x = a and not b or true @ é");
        assert_eq!(toks[3].0, Tok::KwAnd);
        assert_eq!(toks[4].0, Tok::KwNot);
        assert_eq!(toks[6].0, Tok::KwOr);
        assert_eq!(toks[7].0, Tok::KwTrue);
        assert_eq!(toks[8], (Tok::Unknown('@'), 25));
        assert_eq!(toks[9], (Tok::Unknown('é'), 27));
        assert_eq!(toks[10], (Tok::End, 28));
        assert_eq!(lex_line(""), vec![(Tok::End, 1)]);
        assert_eq!(lex_line("   # only a comment"), vec![(Tok::End, 4)]);
    }

    #[test]
    fn long_names_are_clipped_in_messages() {
        let long = "a".repeat(100);
        let shown = Tok::Ident(&long).to_string();
        assert_eq!(shown.chars().count(), MAX_QUOTED + 3);
        assert_eq!(Tok::Unknown('\0').to_string(), "`\\0`");
    }
}
