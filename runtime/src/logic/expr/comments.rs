//! The `#` comments that document an expr statement: the comment lines directly above it (no
//! blank line between) and the comment at the end of its own line, in that order, one line
//! each. The push-down report and the web page's placement mark name the statement by the
//! first sentence of them (`DocText::summary`).
//!
//! A comment after a blank line documents nothing in particular (a file's header, a section's
//! heading) and stays in the source only.

use std::collections::BTreeMap;

use super::error::CompileErrorKind;
use super::parser::Pos;
use crate::project::{DocKind, DocText};

/// Each statement line's comment, by 1-based line; errors where a comment is too long.
pub(crate) fn statement_comments(
    source: &str,
    errors: &mut Vec<(Pos, CompileErrorKind)>,
) -> BTreeMap<u32, DocText> {
    let mut out = BTreeMap::new();
    // The comment lines seen since the last blank or code line, with where the first starts.
    let mut above: Vec<&str> = Vec::new();
    let mut above_at: Option<Pos> = None;
    for (i, text) in source.split('\n').enumerate() {
        let line = u32::try_from(i + 1).unwrap_or(u32::MAX);
        let text = text.strip_suffix('\r').unwrap_or(text);
        let (code, comment) = match text.find('#') {
            Some(at) => (&text[..at], Some((at, comment_text(&text[at..])))),
            None => (text, None),
        };
        if code.trim().is_empty() {
            match comment {
                Some((at, words)) => {
                    above_at.get_or_insert(Pos {
                        line,
                        col: column(text, at),
                    });
                    above.push(words);
                }
                None => {
                    above.clear();
                    above_at = None;
                }
            }
            continue;
        }
        let mut lines = std::mem::take(&mut above);
        let first = above_at.take();
        if let Some((_, words)) = comment {
            lines.push(words);
        }
        let at = first.or(comment.map(|(at, _)| Pos {
            line,
            col: column(text, at),
        }));
        match DocText::new(DocKind::Comment, &lines.join("\n")) {
            Ok(Some(doc)) => {
                out.insert(line, doc);
            }
            Ok(None) => {}
            Err(error) => errors.push((
                at.unwrap_or(Pos { line, col: 1 }),
                CompileErrorKind::Documentation { error },
            )),
        }
    }
    out
}

/// A comment's words: without its `#` (or `##`...) and the space after it.
fn comment_text(comment: &str) -> &str {
    comment.trim_start_matches('#').trim()
}

/// The 1-based column of byte `at` of `text`.
fn column(text: &str, at: usize) -> u32 {
    let chars = text.get(..at).map_or(0, |s| s.chars().count());
    u32::try_from(chars + 1).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn comments(source: &str) -> Vec<(u32, String)> {
        let mut errors = Vec::new();
        let out = statement_comments(source, &mut errors);
        assert!(errors.is_empty(), "{errors:?}");
        out.into_iter().map(|(l, d)| (l, d.to_string())).collect()
    }

    #[test]
    fn lines_above_and_the_end_of_the_line_document_a_statement() {
        let source = "\
# Conveyor.

# Start/stop latch:
# stop wins.
motor = (start | motor) & !stop   # the belt
lamp = motor
fan = motor  # cooling
";
        assert_eq!(
            comments(source),
            [
                (5, "Start/stop latch:\nstop wins.\nthe belt".to_string()),
                (7, "cooling".to_string()),
            ]
        );
    }

    #[test]
    fn a_comment_too_long_is_refused_at_its_first_line() {
        let source = format!("\n  # {}\nmotor = start\n", "x".repeat(1001));
        let mut errors = Vec::new();
        statement_comments(&source, &mut errors);
        let (pos, kind) = &errors[0];
        assert_eq!((pos.line, pos.col), (2, 3));
        assert_eq!(
            kind.to_string(),
            "comment: 1001 characters, at most 1000 are allowed"
        );
    }
}
