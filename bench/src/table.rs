//! The results as a Markdown table (for the terminal and for `bench/README.md`).

use std::fmt::Write;

use std::time::Duration;

use softplc::scan::fmt_duration;

use crate::report::{Bound, Figure, Goal, Quantity, Row};
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

/// A quantity for the table: sizes in decimal megabytes (as package sizes are given), with
/// three digits below 10 MB.
pub(crate) fn fmt_quantity(q: &Quantity) -> String {
    match *q {
        Quantity::Bytes(b) if b >= 10_000_000 => format!("{:.1} MB", b as f64 / 1e6),
        Quantity::Bytes(b) if b >= 1_000_000 => format!("{:.2} MB", b as f64 / 1e6),
        Quantity::Bytes(b) if b >= 1_000 => format!("{:.0} kB", b as f64 / 1e3),
        Quantity::Bytes(b) => format!("{b} B"),
        Quantity::PercentOfCore(p) => format!("{p:.2} % of a core"),
        Quantity::Count(n) => n.to_string(),
        Quantity::Time(d) => fmt_time(d),
    }
}

/// The goal cell of a one-number row: the goal and the figure's ratio to it.
fn goal_cell(value: &Quantity, goal: Option<&Goal>) -> String {
    let Some(g) = goal else {
        return String::new();
    };
    match value.ratio_to(&g.limit) {
        Some(r) => format!("{} {}: {}", g.name, fmt_quantity(&g.limit), fmt_ratio(r)),
        None => format!("{} {}", g.name, fmt_quantity(&g.limit)),
    }
}

/// Whether a scenario's rows are all single numbers (or rows without a figure): its table
/// then has a value column instead of the percentiles.
fn scalar_table(rows: &[Row]) -> bool {
    rows.iter()
        .any(|r| matches!(r.figure, Figure::Scalar { .. }))
        && !rows.iter().any(|r| matches!(r.figure, Figure::Measured(_)))
}

/// A Markdown row: the row's case and metric, `cells`, its note.
fn line(row: &Row, cells: &[String]) -> String {
    format!(
        "| {} | {} | {} | {} |",
        row.case.replace('|', "\\|"),
        row.metric,
        cells.join(" | "),
        row.note.replace('|', "\\|")
    )
}

/// One Markdown row of a table of single numbers.
fn scalar_row_line(row: &Row) -> String {
    let cells = match &row.figure {
        Figure::Scalar { value, goal } => [fmt_quantity(value), goal_cell(value, goal.as_ref())],
        Figure::Measured(p) => [fmt_time(p.p50), String::new()],
        Figure::NotYet { feature, issue } => [
            format!("not yet available: {feature} ({issue})"),
            String::new(),
        ],
        Figure::Unavailable(why) => [format!("not measured: {why}"), String::new()],
    };
    line(row, &cells)
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
        Figure::Scalar { value, goal } => {
            let mut v = vec![String::new(); 6];
            v[1] = fmt_quantity(value);
            v[5] = goal_cell(value, goal.as_ref());
            v
        }
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
    line(row, &cells)
}

/// The whole table, one section per scenario.
pub(crate) fn markdown(results: &[ScenarioResult]) -> String {
    let mut out = String::new();
    for r in results {
        let _ = writeln!(out, "#### {}. {}\n", r.number, r.title);
        if !r.summary.is_empty() {
            let _ = writeln!(out, "{}\n", r.summary);
        }
        if scalar_table(&r.rows) {
            out.push_str("| case | metric | value | goal (ratio) | note |\n");
            out.push_str("|---|---|--:|---|---|\n");
            for row in &r.rows {
                out.push_str(&scalar_row_line(row));
                out.push('\n');
            }
        } else {
            out.push_str("| case | metric | n | p50 | p99 | p99.9 | max | against (ratio at p50, p99) | note |\n");
            out.push_str("|---|---|--:|--:|--:|--:|--:|---|---|\n");
            for row in &r.rows {
                out.push_str(&row_line(row));
                out.push('\n');
            }
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
    fn a_size_row_shows_its_value_and_its_ratio_to_the_goal() {
        let goal = Goal {
            name: "goal".into(),
            limit: Quantity::Bytes(15_000_000),
        };
        let row = Row::scalar(
            "default features",
            "stripped binary",
            Quantity::Bytes(12_345_678),
            Some(goal),
        );
        assert!(scalar_table(std::slice::from_ref(&row)));
        assert_eq!(
            scalar_row_line(&row),
            "| default features | stripped binary | 12.3 MB | goal 15.0 MB: ×0.82 |  |"
        );
        assert_eq!(fmt_quantity(&Quantity::Bytes(7_654_321)), "7.65 MB");
        assert_eq!(
            fmt_quantity(&Quantity::PercentOfCore(0.4567)),
            "0.46 % of a core"
        );
    }

    #[test]
    fn a_goal_of_another_unit_gives_no_ratio() {
        let goal = Goal {
            name: "goal".into(),
            limit: Quantity::Bytes(10),
        };
        assert_eq!(
            goal_cell(&Quantity::PercentOfCore(1.0), Some(&goal)),
            "goal 10 B"
        );
    }

    #[test]
    fn a_missing_feature_says_so() {
        let row = Row::not_yet("ladder, 10 rungs", "ladder engine", "logic issue");
        assert!(row_line(&row).contains("not yet available: ladder engine (logic issue)"));
    }
}
