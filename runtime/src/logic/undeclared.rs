//! What expr and ladder say of a name that is no tag: one error per name, at its first use,
//! with the lines of its other uses, and a way out. A coil nobody declared used to give one
//! `unknown tag` per use and no hint, so a newcomer saw a wall of errors for one missing line
//! in the project file.

use std::fmt::Write as _;

/// The tail of an unknown-tag message: the closest tag when there is one (a typo), else how to
/// declare it (a memory tag the project lacks); then where else the name is used.
pub(crate) fn hint(name: &str, suggestion: Option<&str>, also: &[u32]) -> String {
    let mut out = match suggestion {
        Some(s) => format!("; did you mean `{s}`?"),
        None => format!(
            "; declare it under `tags:` in the project, e.g. `- {{ name: {name}, type: bool }}` for a memory bit"
        ),
    };
    if !also.is_empty() {
        let lines: Vec<String> = also.iter().map(u32::to_string).collect();
        let _ = write!(
            out,
            " (also used on line{} {})",
            if also.len() == 1 { "" } else { "s" },
            lines.join(", ")
        );
    }
    out
}

/// Adds `line` to the `also` list of the unknown-tag error for `name` among `errors` (each as
/// its name, its own line and its list), unless it is that error's own line; true when there
/// was one (then no new error is due).
pub(crate) fn seen_before<'a>(
    mut errors: impl Iterator<Item = (&'a str, u32, &'a mut Vec<u32>)>,
    name: &str,
    line: u32,
) -> bool {
    match errors.find(|(n, _, _)| *n == name) {
        Some((_, first, also)) => {
            if line != first && !also.contains(&line) {
                also.push(line);
            }
            true
        }
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_typo_gets_the_closest_name_and_a_missing_tag_the_declaration() {
        assert_eq!(hint("strt", Some("start"), &[]), "; did you mean `start`?");
        assert_eq!(
            hint("running", None, &[2, 5]),
            "; declare it under `tags:` in the project, e.g. `- { name: running, type: bool }` for a memory bit (also used on lines 2, 5)"
        );
        assert_eq!(
            hint("a", Some("b"), &[3]),
            "; did you mean `b`? (also used on line 3)"
        );
    }
}
