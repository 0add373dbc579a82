//! Every unknown key at once, with the rest of the errors.
//!
//! The schema's structs deny unknown keys, so the YAML reader stops at the first one, and a
//! project with a typo in `buses:` and a wrong address in `modules:` got one error per run of
//! `check` (README, "Your first project": every error at once). When the reader's error is an unknown key, that
//! key's entry is blanked out of the text and the text is read again, until the reader finds
//! no more unknown keys; then the schema's own checks run on what is left.
//!
//! The entry is overwritten with spaces, keeping every newline, so every other node keeps its
//! line and column: the errors found in later readings point into the file as written. (A
//! rewrite through a YAML value would not do: it loses how scalars were written, and `8E1`, a
//! serial format as text, comes back as the number 80.)

use std::path::Path;

use super::error::{ErrorKind, ProjectError, ProjectErrors};
use serde::de::DeserializeOwned;

/// At most this many unknown keys are collected (each costs a reading of the document).
const MAX_UNKNOWN: usize = 64;

/// Reads a YAML file of the project's family (a project, a device profile) as schema `R`, then
/// checks it with `validate`: the nesting limit first (the reader's time grows with the square
/// of the nesting), every unknown key at once, the reader's other first error, then
/// `validate`'s errors on what is left, all in the order of the file. `validate` gets the text
/// it was read from (unknown keys blanked, positions kept) to locate its own errors.
pub(crate) fn read_checked<R: DeserializeOwned, T>(
    text: &str,
    file: &Path,
    validate: impl FnOnce(&R, &str, &Path) -> Result<T, Vec<ProjectError>>,
) -> Result<T, ProjectErrors> {
    if let Err(at) = super::nesting::check(text) {
        return Err(ProjectErrors {
            errors: vec![ProjectError {
                file: file.to_path_buf(),
                line: at.line,
                column: at.column,
                kind: ErrorKind::TooDeep {
                    limit: super::nesting::MAX_DEPTH,
                },
            }],
        });
    }
    let (raw, text, mut errors) = match yaml_serde::from_str::<R>(text) {
        Ok(raw) => (raw, std::borrow::Cow::Borrowed(text), Vec::new()),
        Err(e) => {
            let first = super::yaml_error(&e, file);
            if !matches!(first.kind, ErrorKind::UnknownKey { .. }) {
                return Err(ProjectErrors {
                    errors: vec![first],
                });
            }
            // A typo in a key: report every one, and the schema's errors of the rest.
            let pruned = prune::<R>(text, file, first);
            match pruned.rest {
                Ok((raw, blanked)) => (raw, std::borrow::Cow::Owned(blanked), pruned.unknown),
                Err(e) => {
                    let mut errors = pruned.unknown;
                    errors.push(e);
                    return Err(ProjectErrors { errors });
                }
            }
        }
    };
    match validate(&raw, &text, file) {
        Ok(value) if errors.is_empty() => Ok(value),
        Ok(_) => Err(ProjectErrors { errors }),
        Err(more) => {
            errors.extend(more);
            errors.sort_by_key(|e| (e.line, e.column));
            Err(ProjectErrors { errors })
        }
    }
}

/// What reading the text gave once every unknown key was blanked out.
pub(super) struct Pruned<T> {
    /// One error per unknown key, in the order found.
    pub(super) unknown: Vec<ProjectError>,
    /// The document without them (and that text, with the same positions as the original),
    /// or the reader's first other error.
    pub(super) rest: Result<(T, String), ProjectError>,
}

/// Reads `text` (whose first reading failed with `first`, an unknown key) again and again,
/// without each unknown key found.
pub(super) fn prune<T: DeserializeOwned>(
    text: &str,
    file: &Path,
    first: ProjectError,
) -> Pruned<T> {
    let mut unknown = Vec::new();
    let mut text = text.to_owned();
    let mut error = first;
    loop {
        if !matches!(error.kind, ErrorKind::UnknownKey { .. }) {
            return Pruned {
                unknown,
                rest: Err(error),
            };
        }
        let blanked = blank_entry(&mut text, error.line, error.column);
        unknown.push(error);
        if !blanked || unknown.len() >= MAX_UNKNOWN {
            // Nothing more can be read with confidence: report what was found.
            let last = unknown.pop().unwrap_or_else(|| unreachable_error(file));
            return Pruned {
                unknown,
                rest: Err(last),
            };
        }
        match yaml_serde::from_str::<T>(&text) {
            Ok(raw) => {
                return Pruned {
                    unknown,
                    rest: Ok((raw, text)),
                }
            }
            Err(e) => error = super::yaml_error(&e, file),
        }
    }
}

/// Never returned: [`prune`] pops only after a push. Kept as an error, not a panic, so a
/// mistake here costs a message, not the process.
fn unreachable_error(file: &Path) -> ProjectError {
    ProjectError {
        file: file.to_path_buf(),
        line: 1,
        column: 1,
        kind: ErrorKind::Yaml {
            message: "the document could not be read".into(),
        },
    }
}

/// Overwrites with spaces the mapping entry whose key starts at 1-based `line`:`column`: in a
/// flow mapping (`{ a: 1, typo: 2 }`) the key, its value and one comma; in a block mapping the
/// rest of the key's line and every line below it indented deeper (its value). False when
/// there is no such position.
fn blank_entry(text: &mut String, line: usize, column: usize) -> bool {
    let Some(start) = offset(text, line, column) else {
        return false;
    };
    let mut bytes = std::mem::take(text).into_bytes();
    let before = bytes.get(..start).unwrap_or_default();
    let in_flow = before
        .iter()
        .rev()
        .find(|b| !matches!(b, b' ' | b'\t' | b'\r' | b'\n'))
        .is_some_and(|b| matches!(b, b'{' | b','));
    if in_flow {
        blank_flow_entry(&mut bytes, start);
    } else {
        blank_block_entry(&mut bytes, start, column - 1);
    }
    // Only ASCII bytes were replaced, by spaces: the text stays UTF-8.
    *text = String::from_utf8(bytes).unwrap_or_default();
    true
}

/// The byte offset of a 1-based line and (char) column.
fn offset(text: &str, line: usize, column: usize) -> Option<usize> {
    let line_start = if line <= 1 {
        0
    } else {
        text.match_indices('\n').nth(line - 2).map(|(i, _)| i + 1)?
    };
    let rest = text.get(line_start..)?;
    let in_line = rest
        .char_indices()
        .nth(column.checked_sub(1)?)
        .map(|(i, _)| i)?;
    Some(line_start + in_line)
}

/// A flow entry: up to the next `,`, `}` or `]` outside quotes and brackets.
fn blank_flow_entry(bytes: &mut [u8], start: usize) {
    let mut depth = 0usize;
    let mut quote: Option<u8> = None;
    let mut end = bytes.len();
    let mut ends_at_comma = false;
    for (i, &b) in bytes.iter().enumerate().skip(start) {
        match (quote, b) {
            (Some(q), _) if b == q => quote = None,
            (Some(_), _) => {}
            (None, b'"' | b'\'') => quote = Some(b),
            (None, b'{' | b'[') => depth += 1,
            (None, b'}' | b']') if depth == 0 => {
                end = i;
                break;
            }
            (None, b'}' | b']') => depth -= 1,
            (None, b',') if depth == 0 => {
                end = i + 1;
                ends_at_comma = true;
                break;
            }
            _ => {}
        }
    }
    blank(bytes, start, end);
    if !ends_at_comma {
        // The last entry: the comma before it goes with it.
        if let Some(comma) = bytes
            .get(..start)
            .and_then(|b| {
                b.iter()
                    .rposition(|&c| !matches!(c, b' ' | b'\t' | b'\r' | b'\n'))
            })
            .filter(|&i| bytes.get(i) == Some(&b','))
        {
            blank(bytes, comma, comma + 1);
        }
    }
}

/// A block entry: the rest of its line, then the lines indented deeper than its key (blank
/// and comment lines among them).
fn blank_block_entry(bytes: &mut [u8], start: usize, key_column: usize) {
    let line_end = |from: usize| {
        bytes
            .iter()
            .skip(from)
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| from + i)
    };
    let mut end = line_end(start);
    while end < bytes.len() {
        let next = end + 1;
        let next_end = line_end(next);
        let line = bytes.get(next..next_end).unwrap_or_default();
        let indent = line.iter().take_while(|&&b| b == b' ').count();
        let content = line.get(indent..).unwrap_or_default();
        let blank_or_comment = content.is_empty() || content == b"\r" || content[0] == b'#';
        if !blank_or_comment && indent <= key_column {
            break;
        }
        end = next_end;
    }
    blank(bytes, start, end);
}

/// Spaces over `from..to`, newlines kept.
fn blank(bytes: &mut [u8], from: usize, to: usize) {
    for b in bytes.iter_mut().take(to).skip(from) {
        if *b != b'\n' && *b != b'\r' {
            *b = b' ';
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blanked(text: &str, line: usize, column: usize) -> String {
        let mut t = text.to_owned();
        assert!(blank_entry(&mut t, line, column));
        assert_eq!(t.len(), text.len(), "positions kept");
        t
    }

    #[test]
    fn a_block_entry_goes_with_its_value() {
        let text = "buses:\n  - name: a\n    typo:\n      deep: 1\n\n    # note\n    baud: 1\n";
        assert_eq!(
            blanked(text, 3, 5),
            "buses:\n  - name: a\n         \n             \n\n          \n    baud: 1\n"
        );
    }

    #[test]
    fn the_first_key_of_a_sequence_item_keeps_its_dash() {
        let text = "tags:\n  - typo: 1\n    name: a\n";
        let t = blanked(text, 2, 5);
        assert_eq!(t, "tags:\n  -        \n    name: a\n");
        let v: yaml_serde::Value = yaml_serde::from_str(&t).expect("still YAML");
        assert_eq!(v["tags"][0]["name"].as_str(), Some("a"));
    }

    #[test]
    fn a_flow_entry_takes_one_comma() {
        assert_eq!(
            blanked("- { name: m, save: \"a,b\", point: p }\n", 1, 14),
            "- { name: m,              point: p }\n"
        );
        assert_eq!(
            blanked("- { name: m, save: [1, 2] }\n", 1, 14),
            "- { name: m               }\n"
        );
    }

    #[test]
    fn scalars_keep_how_they_were_written() {
        let text = "a: { format: 8E1, typo: 1 }\n";
        let t = blanked(text, 1, 19);
        let v: yaml_serde::Value = yaml_serde::from_str(&t).expect("YAML");
        let format: String = yaml_serde::from_str::<
            std::collections::BTreeMap<String, std::collections::BTreeMap<String, String>>,
        >(&t)
        .expect("as text")["a"]["format"]
            .clone();
        assert_eq!(format, "8E1");
        assert!(v["a"].get("typo").is_none());
    }

    #[test]
    fn a_position_outside_the_text_is_refused() {
        let mut t = "a: 1\n".to_owned();
        assert!(!blank_entry(&mut t, 9, 1));
        assert!(!blank_entry(&mut t, 1, 40));
    }
}
