//! The output trace of a scenario run and a readable line diff of two traces.

use std::fmt::Write;
use std::time::Duration;

use softplc_io::point::Value;

use crate::service::alarms::EventKind;

/// One change of a watched tag, a plant state or an alarm.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Change {
    /// Scan time.
    pub at: Duration,
    /// The tag (`plant.STATE`, `alarm.NAME`).
    pub tag: String,
    /// Its new value.
    pub value: Shown,
}

/// What a trace line shows: a value, or what happened to an alarm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Shown {
    /// A tag's or a plant state's new value.
    Value(Value),
    /// An alarm raised, cleared or acknowledged.
    Alarm(EventKind),
}

impl From<Value> for Shown {
    fn from(v: Value) -> Self {
        Shown::Value(v)
    }
}

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Shown::Value(v) => write!(f, "{v}"),
            Shown::Alarm(e) => write!(f, "{e}"),
        }
    }
}

impl std::fmt::Display for Change {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:>10.3}s  {} = {}",
            self.at.as_secs_f64(),
            self.tag,
            self.value
        )
    }
}

/// Longest trace shown or compared line by line.
const MAX_LINES: usize = 400;

/// The trace, one change per line, indented.
pub(crate) fn render(trace: &[Change]) -> String {
    let mut out = String::new();
    for c in trace.iter().take(MAX_LINES) {
        let _ = writeln!(out, "      {c}");
    }
    if trace.len() > MAX_LINES {
        let _ = writeln!(out, "      … {} more changes", trace.len() - MAX_LINES);
    }
    out
}

/// A line diff of two traces (longest common subsequence): `-` only in `a`, `+` only in `b`,
/// with two lines of context around each difference.
pub(crate) fn diff(a: &[Change], b: &[Change]) -> String {
    let a: Vec<String> = a.iter().take(MAX_LINES).map(ToString::to_string).collect();
    let b: Vec<String> = b.iter().take(MAX_LINES).map(ToString::to_string).collect();
    let (n, m) = (a.len(), b.len());
    let mut lcs = vec![vec![0u16; m + 1]; n + 1];
    for i in (0..n).rev() {
        for j in (0..m).rev() {
            lcs[i][j] = if a[i] == b[j] {
                lcs[i + 1][j + 1] + 1
            } else {
                lcs[i + 1][j].max(lcs[i][j + 1])
            };
        }
    }
    let mut lines: Vec<(char, &str)> = Vec::new();
    let (mut i, mut j) = (0, 0);
    while i < n || j < m {
        if i < n && j < m && a[i] == b[j] {
            lines.push((' ', &a[i]));
            i += 1;
            j += 1;
        } else if j < m && (i == n || lcs[i][j + 1] >= lcs[i + 1][j]) {
            lines.push(('+', &b[j]));
            j += 1;
        } else {
            lines.push(('-', &a[i]));
            i += 1;
        }
    }
    let near = |k: usize| {
        lines[k.saturating_sub(2)..(k + 3).min(lines.len())]
            .iter()
            .any(|(c, _)| *c != ' ')
    };
    let mut out = String::new();
    let mut skipped = false;
    for (k, (c, text)) in lines.iter().enumerate() {
        if near(k) {
            let _ = writeln!(out, "    {c} {text}");
            skipped = false;
        } else if !skipped {
            let _ = writeln!(out, "      …");
            skipped = true;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ch(ms: u64, v: bool) -> Change {
        Change {
            at: Duration::from_millis(ms),
            tag: "light".into(),
            value: Value::Bool(v).into(),
        }
    }

    #[test]
    fn diff_marks_the_differences() {
        let a = [ch(0, false), ch(100, true), ch(200, false)];
        let b = [ch(0, false), ch(100, true), ch(300, false)];
        let d = diff(&a, &b);
        assert!(d.contains("-      0.200s  light = 0"), "{d}");
        assert!(d.contains("+      0.300s  light = 0"), "{d}");
        assert!(render(&a).contains("0.100s  light = 1"));
    }
}
