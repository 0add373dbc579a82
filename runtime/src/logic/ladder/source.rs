//! The ladder file: a YAML document whose `rungs:` are strings, and where each rung's characters
//! are in the file, for `line:col` in errors.
//!
//! yaml_serde gives positions only with its own errors, so each rung is found in the text: first
//! verbatim after the previous rung (a one-line rung, plain or quoted without escapes, the usual
//! case, in one pass), otherwise through the project's path locator (a rung folded over several
//! lines, or with escapes). Inside a rung, a character is found by walking the rung and the text
//! side by side, a folded line break in the text matching one space of the rung; where they part
//! (an escape), the position falls back to the rung's start.

use std::fmt;

use schemars::JsonSchema;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::Deserialize;

use crate::logic::blocks::Kind;
use crate::project::span::{Locator, YPath};
use crate::project::{DocKind, DocText, DocTextError};

/// A ladder program: its rungs, each one line of text (`start /stop -> motor`), with a title
/// and a comment where the author gives them.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a ladder program: a mapping with `rungs:` (a list of rungs) and an optional `description:`"
)]
struct RawLadder {
    /// What the program does (free text).
    #[serde(default)]
    #[allow(dead_code)]
    description: Option<String>,
    /// The rungs, in execution order, each read left to right like a ladder diagram: contacts
    /// (`x`, `/x`, `rising(x)`, `level >= 80`) in series, `|` for parallel branches, `->`,
    /// then coils (`y`, `/y`, `set y`, `reset y`), a block (`TON t(10s) -> lamp`) or a box
    /// (`ADD(n, 1) => n`). A rung is its text, or a mapping with the text as `rung:` and a
    /// `title:` and `comment:` that document it. The guide is docs/programming.md.
    rungs: Vec<RawRung>,
}

/// One `rungs:` entry: the rung's text alone, or with its documentation. `untagged` is for the
/// schema's sake (either form, no tag); the file is read by the hand-written `Deserialize`.
#[derive(Debug, JsonSchema)]
#[serde(untagged)]
enum RawRung {
    /// The rung's text.
    Text(String),
    /// The rung with a title and a comment.
    Documented(DocumentedRung),
}

/// A rung with its documentation: `{ rung: start /stop -> motor, title: Motor latch }`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a rung: its text, or a mapping with rung, title and comment"
)]
struct DocumentedRung {
    /// The rung's text (`start /stop -> motor`).
    rung: String,
    /// What the rung is, in a few words (one line, at most 80 characters): the web page's
    /// drawing and `check`'s push-down report name the rung by it.
    #[serde(default)]
    #[schemars(length(max = 80))]
    title: Option<String>,
    /// Why the rung is as it is (at most 1,000 characters, lines allowed): shown above the
    /// rung's diagram on the web page.
    #[serde(default)]
    #[schemars(length(max = 1000))]
    comment: Option<String>,
}

impl RawRung {
    fn into_parts(self) -> (String, Option<String>, Option<String>) {
        match self {
            RawRung::Text(text) => (text, None, None),
            RawRung::Documented(d) => (d.rung, d.title, d.comment),
        }
    }
}

impl<'de> Deserialize<'de> for RawRung {
    // By hand rather than `untagged`: serde's untagged enums buffer the value and lose the
    // YAML reader's positions, and a rung written as a number or `true` is still text.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawRung;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a rung: its text, or a mapping with rung, title and comment")
            }

            fn visit_bool<E: de::Error>(self, v: bool) -> Result<RawRung, E> {
                Ok(RawRung::Text(v.to_string()))
            }

            fn visit_i64<E: de::Error>(self, v: i64) -> Result<RawRung, E> {
                Ok(RawRung::Text(v.to_string()))
            }

            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RawRung, E> {
                Ok(RawRung::Text(v.to_string()))
            }

            fn visit_f64<E: de::Error>(self, v: f64) -> Result<RawRung, E> {
                Ok(RawRung::Text(v.to_string()))
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawRung, E> {
                Ok(RawRung::Text(v.to_owned()))
            }

            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RawRung, A::Error> {
                DocumentedRung::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(RawRung::Documented)
            }
        }
        d.deserialize_any(V)
    }
}

/// The JSON Schema of a ladder program file (`softplc schema ladder`): a rung's description
/// lists the blocks and their arguments, from the block registry, for an editor's hover.
pub(crate) fn file_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
    let mut schema = generator.root_schema_for::<RawLadder>();
    // On the rung's text in both forms: draft 7 ignores a description beside a `$ref`, so
    // on the list's items it would never reach an editor's hover.
    let definitions = schema
        .as_object_mut()
        .and_then(|o| o.get_mut("definitions"))
        .and_then(|d| d.as_object_mut());
    if let Some(definitions) = definitions {
        for (name, path) in [
            ("RawRung", "/anyOf/0"),
            ("DocumentedRung", "/properties/rung"),
        ] {
            let rung = definitions
                .get_mut(name)
                .and_then(|d| d.pointer_mut(path))
                .and_then(|r| r.as_object_mut());
            if let Some(rung) = rung {
                rung.insert("description".into(), block_list().into());
            }
        }
    }
    schema
}

/// `A rung. Its blocks (`condition -> KIND name(arguments) -> coils`): TON t(5s) (IN; PT; Q,
/// ET), ...`: every form of every block, its power flow, arguments and outputs.
fn block_list() -> String {
    let forms = Kind::ALL.iter().flat_map(|k| {
        let def = k.def();
        def.forms.iter().map(move |form| {
            let args: Vec<String> = def
                .form_arguments(form)
                .map(|p| p.name.to_ascii_lowercase())
                .collect();
            let outputs: Vec<&str> = def.outputs.iter().map(|m| m.name()).collect();
            format!(
                "`{}` ({}; {}; {}): {}",
                form.example,
                def.main_input().name,
                if args.is_empty() {
                    "-".into()
                } else {
                    args.join(", ")
                },
                outputs.join(", "),
                form.doc
            )
        })
    });
    let forms: Vec<String> = forms.collect();
    format!(
        "A rung. Its blocks (`condition -> KIND name(arguments) -> coils`; power flow; \
         arguments; outputs):\n{}",
        forms.join("\n")
    )
}

/// One rung's text and where it starts in the file.
#[derive(Debug, Clone)]
pub(crate) struct RungText {
    /// The rung, as YAML delivered it.
    pub text: String,
    /// Its `title:`.
    pub title: Option<DocText>,
    /// Its `comment:`.
    pub comment: Option<DocText>,
    /// Byte offset in the file of the rung's scalar (its first character, or its opening quote).
    start: usize,
}

/// A rung's `title:` or `comment:` refused: 1-based line and column of its value, the key,
/// and why.
pub(crate) type DocError = (u32, u32, &'static str, DocTextError);

/// A ladder file, read.
#[derive(Debug, Clone)]
pub(crate) struct LadderSource {
    /// The file's text.
    text: String,
    /// Byte offset of each line's start.
    line_starts: Vec<usize>,
    /// The rungs, in order.
    pub rungs: Vec<RungText>,
    /// The rungs' titles and comments that cannot document them.
    pub doc_errors: Vec<DocError>,
}

/// A YAML error: 1-based line and column, and the message.
pub(crate) type YamlError = (u32, u32, String);

impl LadderSource {
    /// Reads the document and locates its rungs.
    pub(crate) fn read(text: &str) -> Result<Self, YamlError> {
        let raw: RawLadder = yaml_serde::from_str(text).map_err(|e| {
            let (line, col) = e
                .location()
                .map_or((1, 1), |l| (to_u32(l.line()), to_u32(l.column())));
            let mut message = e.to_string();
            if let Some(at) = message.find(" at line ") {
                message.truncate(at);
            }
            (line, col, message)
        })?;
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        let mut src = Self {
            text: text.to_string(),
            line_starts,
            rungs: Vec::with_capacity(raw.rungs.len()),
            doc_errors: Vec::new(),
        };
        let locator = Locator::new(text);
        let mut cursor = 0;
        for (i, raw_rung) in raw.rungs.into_iter().enumerate() {
            let documented = matches!(raw_rung, RawRung::Documented(_));
            let (rung, title, comment) = raw_rung.into_parts();
            let entry = YPath::root().key("rungs").index(i);
            let start = match find_verbatim(text, cursor, &rung) {
                Some(at) => {
                    cursor = at + rung.len();
                    at
                }
                None => {
                    let path = if documented {
                        entry.key("rung")
                    } else {
                        entry.clone()
                    };
                    let (line, col) = locator.position(&path);
                    let at = src.offset(line, col);
                    cursor = cursor.max(at);
                    at
                }
            };
            let mut doc =
                |key: &'static str, kind: DocKind, text: Option<String>| match DocText::new(
                    kind,
                    text.as_deref()?,
                ) {
                    Ok(d) => d,
                    Err(e) => {
                        let (line, col) = locator.position(&entry.key(key));
                        src.doc_errors.push((to_u32(line), to_u32(col), key, e));
                        None
                    }
                };
            let title = doc("title", DocKind::Title, title);
            let comment = doc("comment", DocKind::Comment, comment);
            src.rungs.push(RungText {
                text: rung,
                title,
                comment,
                start,
            });
        }
        Ok(src)
    }

    /// 1-based `(line, column)` of character `index` of rung `rung`.
    pub(crate) fn position(&self, rung: usize, index: usize) -> (u32, u32) {
        let Some(r) = self.rungs.get(rung) else {
            return (1, 1);
        };
        self.line_col(align(&self.text, r.start, &r.text, index))
    }

    /// 1-based `(line, column)` of a byte offset (columns count characters).
    fn line_col(&self, offset: usize) -> (u32, u32) {
        let line = self.line_starts.partition_point(|&s| s <= offset).max(1) - 1;
        let start = self.line_starts.get(line).copied().unwrap_or(0);
        let col = self
            .text
            .get(start..offset)
            .map_or(0, |s| s.chars().count());
        (to_u32(line + 1), to_u32(col + 1))
    }

    /// The byte offset of a 1-based `(line, column)`.
    fn offset(&self, line: usize, col: usize) -> usize {
        let start = self
            .line_starts
            .get(line.saturating_sub(1))
            .copied()
            .unwrap_or(0);
        let rest = self.text.get(start..).unwrap_or("");
        rest.char_indices()
            .take_while(|&(_, c)| c != '\n')
            .nth(col.saturating_sub(1))
            .map_or(start, |(i, _)| start + i)
    }
}

fn to_u32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// The first place at or after `from` where `rung` stands verbatim as a YAML scalar: not in a
/// comment, after a sequence dash, key or quote, and followed by the end of the line, a
/// comment, a quote or a flow separator.
fn find_verbatim(text: &str, from: usize, rung: &str) -> Option<usize> {
    let first = rung.chars().next()?;
    let mut at = from;
    while let Some(k) = text.get(at..).and_then(|t| t.find(rung)) {
        let m = at + k;
        let line_start = text[..m].rfind('\n').map_or(0, |i| i + 1);
        let prefix = &text[line_start..m];
        let in_comment = prefix
            .char_indices()
            .any(|(i, c)| c == '#' && prefix[..i].chars().last().is_none_or(char::is_whitespace));
        let before = prefix.trim_end();
        let starts = before.is_empty() || before.ends_with(['-', '"', '\'', ':', '[', ',']);
        let after = text[m + rung.len()..]
            .split('\n')
            .next()
            .unwrap_or("")
            .trim_start();
        let ends = after.is_empty() || after.starts_with(['#', '"', '\'', ',', ']']);
        if !in_comment && starts && ends {
            return Some(m);
        }
        at = m + first.len_utf8();
    }
    None
}

/// The byte offset in `text` of character `index` of the scalar `rung` that starts at `start`.
fn align(text: &str, start: usize, rung: &str, index: usize) -> usize {
    let Some(src) = text.get(start..) else {
        return start.min(text.len());
    };
    let mut src = src.char_indices().peekable();
    let first = rung.chars().next();
    if let Some(&(_, q @ ('"' | '\''))) = src.peek() {
        if first != Some(q) {
            src.next();
        }
    }
    for (i, c) in rung.chars().enumerate() {
        // Skip folded line breaks and indentation in the text that stand for one space.
        let Some(&(at, s)) = src.peek() else {
            return start;
        };
        if i == index {
            return start + at;
        }
        if s == c {
            src.next();
        } else if c == ' ' && s.is_whitespace() {
            while src.peek().is_some_and(|&(_, s)| s.is_whitespace()) {
                src.next();
            }
        } else {
            return start;
        }
    }
    src.peek().map_or(text.len(), |&(at, _)| start + at)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
# a -> b in a comment
rungs:
  - a -> b            # first
  - \"c -> d\"
  - e
    -> f
  - a -> b
";

    #[test]
    fn finds_rungs_and_characters() {
        let src = LadderSource::read(TEXT).unwrap();
        let texts: Vec<&str> = src.rungs.iter().map(|r| r.text.as_str()).collect();
        assert_eq!(texts, ["a -> b", "c -> d", "e -> f", "a -> b"]);
        assert_eq!(src.position(0, 0), (3, 5));
        assert_eq!(src.position(0, 5), (3, 10));
        assert_eq!(src.position(1, 0), (4, 6));
        assert_eq!(src.position(2, 0), (5, 5));
        assert_eq!(src.position(2, 2), (6, 5), "after the folded line break");
        assert_eq!(src.position(2, 5), (6, 8));
        assert_eq!(src.position(3, 0), (7, 5));
        assert_eq!(src.position(3, 99), (7, 11), "after the last character");
        assert_eq!(src.position(9, 0), (1, 1));
    }

    #[test]
    fn yaml_errors_have_positions() {
        let (line, _, msg) = LadderSource::read("rungs:\n  - a -> b\n  rungz: 1\n").unwrap_err();
        assert_eq!(line, 3, "{msg}");
        let (_, _, msg) = LadderSource::read("rung: []\n").unwrap_err();
        assert!(msg.contains("unknown field"), "{msg}");
        assert!(LadderSource::read("").is_err());
        assert!(LadderSource::read("rungs: [1, true]\n").is_ok());
    }
}
