//! Argument parsers shared by the subcommands.

use std::time::Duration;

/// Parses a duration argument (`10s`, `500ms`, `1.5s`, `2m`) with the project file's syntax.
pub fn parse_duration(text: &str) -> Result<Duration, String> {
    crate::project::parse_duration(text)
        .map_err(|e| format!("{text:?}: {e} (examples: 500ms, 10s, 2m)"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_project_syntax_and_explains_errors() {
        assert_eq!(parse_duration("10s"), Ok(Duration::from_secs(10)));
        assert_eq!(parse_duration("1.5s"), Ok(Duration::from_millis(1500)));
        assert!(parse_duration("10").unwrap_err().contains("examples"));
    }
}
