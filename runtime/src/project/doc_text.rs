//! The words a program documents itself with: a tag's or a module's `description:`, a ladder
//! rung's `title:` and `comment:`, an expr statement's `#` comment.
//!
//! Each is bounded, because every one of them travels: into `check`'s I/O map, the web page,
//! an OPC UA node's `Description` and a Sparkplug birth certificate, where a client keeps it
//! for the session. A description or a title is one line (a table cell, a tooltip, one line of
//! `check`); a comment may have several. Surrounding white space is dropped (a YAML folded
//! block `>` ends in a line break), and an empty text is no text.

use std::fmt;

/// Which kind of text, and so its bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DocKind {
    /// A tag's or module's `description:`: one line, at most 256 characters.
    Description,
    /// A ladder rung's `title:`: one line, at most 80 characters.
    Title,
    /// A ladder rung's `comment:` or an expr statement's comment: at most 1,000 characters,
    /// over any number of lines.
    Comment,
}

impl DocKind {
    /// The most characters (Unicode scalar values) a text of this kind may have.
    pub const fn max_chars(self) -> usize {
        match self {
            DocKind::Description => 256,
            DocKind::Title => 80,
            DocKind::Comment => 1000,
        }
    }

    /// Whether the text may span lines.
    pub const fn multiline(self) -> bool {
        matches!(self, DocKind::Comment)
    }
}

/// A text that documents a tag, a module or a rung: trimmed, not empty, within its kind's
/// bounds, with no control character other than a comment's line breaks.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DocText(String);

/// Why a text cannot document its item.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DocTextError {
    /// Longer than its kind allows.
    #[error("{chars} characters, at most {max} are allowed")]
    TooLong {
        /// Its length in characters, trimmed.
        chars: usize,
        /// The bound.
        max: usize,
    },
    /// A line break in a one-line text.
    #[error(
        "a line break at character {at}: this text is one line (a YAML folded block `>-` joins \
         lines)"
    )]
    LineBreak {
        /// 1-based character of the break, in the trimmed text.
        at: usize,
    },
    /// A control character (tab and line breaks of a comment excepted).
    #[error("a control character (U+{code:04X}) at character {at}")]
    Control {
        /// The character's code.
        code: u32,
        /// 1-based character, in the trimmed text.
        at: usize,
    },
}

impl DocText {
    /// `text` as a documentation text of `kind`; `None` when it is empty once trimmed.
    pub fn new(kind: DocKind, text: &str) -> Result<Option<DocText>, DocTextError> {
        let text = text.trim();
        if text.is_empty() {
            return Ok(None);
        }
        let chars = text.chars().count();
        if chars > kind.max_chars() {
            return Err(DocTextError::TooLong {
                chars,
                max: kind.max_chars(),
            });
        }
        for (i, c) in text.chars().enumerate() {
            let at = i + 1;
            match c {
                '\n' | '\r' if !kind.multiline() => return Err(DocTextError::LineBreak { at }),
                '\n' | '\r' | '\t' => {}
                c if c.is_control() => {
                    return Err(DocTextError::Control {
                        code: u32::from(c),
                        at,
                    })
                }
                _ => {}
            }
        }
        Ok(Some(DocText(text.to_owned())))
    }

    /// The text.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// A title made of the text: its first sentence (up to a `.`, `!` or `?` followed by a
    /// space or the end), its lines joined, within a title's length, cut after a word with
    /// `…` beyond it. Comments wrap where the author's editor did, so a first line can stop
    /// mid-sentence; a sentence is what the author meant as one thought.
    pub fn summary(&self) -> String {
        let joined = self.0.split_whitespace().collect::<Vec<_>>().join(" ");
        let words: Vec<&str> = joined.split(' ').collect();
        let end = words
            .iter()
            .position(|w| w.ends_with(['.', '!', '?']))
            .map_or(words.len(), |i| i + 1);
        let sentence = words.get(..end).unwrap_or(&words).join(" ");
        let max = DocKind::Title.max_chars();
        if sentence.chars().count() <= max {
            return sentence;
        }
        let mut out = String::new();
        for w in sentence.split(' ') {
            // One character is kept for the ellipsis.
            if out.chars().count() + 1 + w.chars().count() > max - 1 {
                break;
            }
            if !out.is_empty() {
                out.push(' ');
            }
            out.push_str(w);
        }
        if out.is_empty() {
            out = sentence.chars().take(max - 1).collect();
        }
        out.push('…');
        out
    }
}

impl fmt::Display for DocText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl AsRef<str> for DocText {
    fn as_ref(&self) -> &str {
        &self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trimmed_and_empty_is_none() {
        let d = DocText::new(DocKind::Description, "  Start button, green  \n").unwrap();
        assert_eq!(d.unwrap().as_str(), "Start button, green");
        assert_eq!(DocText::new(DocKind::Title, "   ").unwrap(), None);
    }

    #[test]
    fn bounds_in_characters_not_bytes() {
        let ok = "é".repeat(256);
        assert!(DocText::new(DocKind::Description, &ok).is_ok());
        let long = "é".repeat(257);
        assert_eq!(
            DocText::new(DocKind::Description, &long).unwrap_err(),
            DocTextError::TooLong {
                chars: 257,
                max: 256
            }
        );
        let e = DocText::new(DocKind::Title, &"x".repeat(81)).unwrap_err();
        assert_eq!(e.to_string(), "81 characters, at most 80 are allowed");
    }

    #[test]
    fn a_summary_is_the_first_sentence_within_a_titles_length() {
        let c = |t: &str| {
            DocText::new(DocKind::Comment, t)
                .unwrap()
                .unwrap()
                .summary()
        };
        assert_eq!(
            c("Pump latch: start sets it,\nstop resets it. Reset wins."),
            "Pump latch: start sets it, stop resets it."
        );
        assert_eq!(c("No full stop here"), "No full stop here");
        let long = c(
            "Two-hand control: the press may move only while the guard is closed and \
                      both hands are on\ntheir buttons. In mm1.",
        );
        assert_eq!(
            long,
            "Two-hand control: the press may move only while the guard is closed and both…"
        );
        assert!(long.chars().count() <= 80);
        assert_eq!(c(&"x".repeat(100)).chars().count(), 80);
    }

    #[test]
    fn line_breaks_only_in_comments() {
        let e = DocText::new(DocKind::Description, "one\ntwo").unwrap_err();
        assert_eq!(e, DocTextError::LineBreak { at: 4 });
        let c = DocText::new(DocKind::Comment, "one\ntwo").unwrap().unwrap();
        assert_eq!(c.as_str(), "one\ntwo");
        let e = DocText::new(DocKind::Comment, "bell\u{7}").unwrap_err();
        assert_eq!(e.to_string(), "a control character (U+0007) at character 5");
    }
}
