//! The results as a Markdown table (for the terminal and for `bench/README.md`).

use std::fmt::Write;

use std::time::Duration;

use softplc::scan::fmt_duration;

use crate::report::{Bound, Figure, Row};
use crate::scenarios::ScenarioResult;

/// A duration for the table: like the runtime's `fmt_duration`, with nanoseconds and tenths
/// of microseconds below 10 µs (a logic scan of a few rungs).
pub(crate) fn fmt_time(d: Duration) -> String {
    let ns = d.as_nanos();
    if ns < 1_000 {
        format!("{ns}ns")
    } else if ns < 10_000 {
        format!("{:.2}µs", ns as f64 / 1e3)
    } else {
        fmt_duration(d)
    }
}

/// A ratio as the table prints it: `×1.03`, `×0.052`.
pub(crate) fn fmt_ratio(r: f64) -> String {
    if r >= 10.0 {
        format!("×{r:.1}")
    } else if r >= 0.1 {
        format!("×{r:.2}")
    } else {
        format!("×{r:.3}")
    }
}

/// The "against" cell: each bound with the figure's ratio to it at p50 (and p99).
fn against(bounds: &[Bound], row: &Row) -> String {
    let Some(p) = row.percentiles() else {
        return String::new();
    };
    bounds
        .iter()
        .map(|b| {
            let value = if b.p50 == b.p99 {
                fmt_time(b.p50)
            } else {
                format!("{}/{}", fmt_time(b.p50), fmt_time(b.p99))
            };
            match b.ratios(p) {
                (Some(r50), Some(r99)) => {
                    format!(
                        "{} {value}: {} (p99 {})",
                        b.name,
                        fmt_ratio(r50),
                        fmt_ratio(r99)
                    )
                }
                _ => format!("{} {value}", b.name),
            }
        })
        .collect::<Vec<_>>()
        .join("<br>")
}

/// One Markdown row.
fn row_line(row: &Row) -> String {
    let cells: Vec<String> = match &row.figure {
        Figure::Measured(p) => vec![
            p.count.to_string(),
            fmt_time(p.p50),
            fmt_time(p.p99),
            fmt_time(p.p999),
            fmt_time(p.max),
            against(&row.bounds, row),
        ],
        Figure::NotYet { feature, issue } => {
            let mut v = vec![String::new(); 6];
            v[0] = format!("not yet available: {feature} ({issue})");
            v
        }
        Figure::Unavailable(why) => {
            let mut v = vec![String::new(); 6];
            v[0] = format!("not measured: {why}");
            v
        }
    };
    format!(
        "| {} | {} | {} | {} |",
        row.case.replace('|', "\\|"),
        row.metric,
        cells.join(" | "),
        row.note.replace('|', "\\|")
    )
}

/// The whole table, one section per scenario.
pub(crate) fn markdown(results: &[ScenarioResult]) -> String {
    let mut out = String::new();
    for r in results {
        let _ = writeln!(out, "#### {}. {}\n", r.number, r.title);
        if !r.summary.is_empty() {
            let _ = writeln!(out, "{}\n", r.summary);
        }
        out.push_str("| case | metric | n | p50 | p99 | p99.9 | max | against (ratio at p50, p99) | note |\n");
        out.push_str("|---|---|--:|--:|--:|--:|--:|---|---|\n");
        for row in &r.rows {
            out.push_str(&row_line(row));
            out.push('\n');
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use softplc::scan::Percentiles;

    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn small_durations_keep_their_digits() {
        assert_eq!(fmt_time(Duration::from_nanos(420)), "420ns");
        assert_eq!(fmt_time(Duration::from_nanos(2_345)), "2.35µs");
        assert_eq!(fmt_time(Duration::from_micros(57)), "57µs");
        assert_eq!(fmt_time(ms(21)), "21.00ms");
    }

    #[test]
    fn ratios_print_with_sensible_digits() {
        assert_eq!(fmt_ratio(1.0345), "×1.03");
        assert_eq!(fmt_ratio(12.34), "×12.3");
        assert_eq!(fmt_ratio(0.0523), "×0.052");
    }

    #[test]
    fn a_measured_row_shows_percentiles_and_ratios() {
        let p = Percentiles {
            count: 10,
            p50: ms(21),
            p99: ms(22),
            p999: ms(23),
            max: ms(24),
        };
        let row = Row::measured("N=1", "I/O cycle", p)
            .bound(Bound::fixed("floor", ms(20)))
            .note("n/a");
        let line = row_line(&row);
        assert_eq!(
            line,
            "| N=1 | I/O cycle | 10 | 21.00ms | 22.00ms | 23.00ms | 24.00ms | \
             floor 20.00ms: ×1.05 (p99 ×1.10) | n/a |"
        );
    }

    #[test]
    fn a_missing_feature_says_so() {
        let row = Row::not_yet("ladder, 10 rungs", "ladder engine", "logic issue");
        assert!(row_line(&row).contains("not yet available: ladder engine (logic issue)"));
    }
}
