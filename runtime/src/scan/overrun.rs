//! Overruns in the log: one line for the first, then at most one every ten seconds with how
//! many came in between, each naming the phase that took the longest. A PLC that overruns
//! every cycle must not fill the journal, and one that overran once must not hide it.

use std::time::Duration;

use crate::scan::stats::{fmt_duration, ScanInstant};

/// The least time between two overrun lines.
const EVERY: Duration = Duration::from_secs(10);

/// A wake-up later than this after the cycle's deadline is named in the line.
const NOTABLE_LATENESS: Duration = Duration::from_millis(1);

/// Rate-limited overrun logging.
#[derive(Debug)]
pub(crate) struct OverrunLog {
    period: Duration,
    last: Option<ScanInstant>,
    /// Overruns since the last line.
    quiet: u64,
}

impl OverrunLog {
    pub(crate) fn new(period: Duration) -> Self {
        Self {
            period,
            last: None,
            quiet: 0,
        }
    }

    /// Records an overrun at `now` that skipped `skipped` deadlines, with the cycle's phases
    /// and how late it started after its deadline; returns the line it logged, if any.
    pub(crate) fn note<const N: usize>(
        &mut self,
        now: ScanInstant,
        skipped: u128,
        late: Duration,
        phases: [(&str, Duration); N],
    ) -> Option<String> {
        self.quiet += 1;
        if self.last.is_some_and(|t| now - t < EVERY) {
            return None;
        }
        let cycle: Duration = phases.iter().map(|(_, d)| *d).sum();
        let (worst, took) = phases
            .iter()
            .copied()
            .max_by_key(|(_, d)| *d)
            .unwrap_or(("inputs", Duration::ZERO));
        let detail = phases
            .iter()
            .map(|(name, d)| format!("{name} {}", fmt_duration(*d)))
            .collect::<Vec<_>>()
            .join(", ");
        let since = if self.last.is_some() && self.quiet > 1 {
            format!(" ({} overruns since the last line)", self.quiet)
        } else {
            String::new()
        };
        let skipped = if skipped == 0 {
            "no deadline skipped (a line was still writing when the period ended)".to_string()
        } else {
            format!("{skipped} deadline(s) skipped")
        };
        // A cycle that woke late (a busy machine, another thread at a higher priority) can
        // overrun in less than its period: say so, or "took 76ms against 100ms" reads wrong.
        let started = if late >= NOTABLE_LATENESS {
            format!("started {} late and ", fmt_duration(late))
        } else {
            String::new()
        };
        let line = format!(
            "overrun: the cycle {started}took {} against a period of {}, {skipped}; longest \
             phase {worst} {} ({detail}){since}",
            fmt_duration(cycle),
            fmt_duration(self.period),
            fmt_duration(took),
        );
        tracing::warn!("{line}");
        self.last = Some(now);
        self.quiet = 0;
        Some(line)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    fn at(n: u64) -> ScanInstant {
        ScanInstant::after_origin(ms(n))
    }

    #[test]
    fn the_first_overrun_is_logged_with_its_longest_phase() {
        let mut log = OverrunLog::new(ms(100));
        let line = log
            .note(
                at(1_000),
                1,
                Duration::ZERO,
                [("inputs", ms(20)), ("logic", ms(130)), ("outputs", ms(5))],
            )
            .expect("logged");
        assert_eq!(
            line,
            "overrun: the cycle took 155.00ms against a period of 100.00ms, 1 deadline(s) \
             skipped; longest phase logic 130.00ms (inputs 20.00ms, logic 130.00ms, outputs \
             5.00ms)"
        );
    }

    #[test]
    fn an_overrun_whose_line_was_still_writing_skips_no_deadline() {
        let mut log = OverrunLog::new(ms(20));
        let line = log
            .note(
                at(1_000),
                0,
                Duration::ZERO,
                [("inputs", ms(13)), ("logic", ms(0)), ("outputs", ms(21))],
            )
            .expect("logged");
        assert!(
            line.starts_with(
                "overrun: the cycle took 34.00ms against a period of 20.00ms, no deadline \
                 skipped (a line was still writing when the period ended); longest phase \
                 outputs 21.00ms"
            ),
            "{line}"
        );
    }

    #[test]
    fn a_cycle_that_woke_late_says_so_beside_a_time_under_its_period() {
        let mut log = OverrunLog::new(ms(100));
        let line = log
            .note(
                at(1_000),
                0,
                ms(24),
                [("inputs", ms(70)), ("logic", ms(0)), ("outputs", ms(6))],
            )
            .expect("logged");
        assert!(
            line.starts_with(
                "overrun: the cycle started 24.00ms late and took 76.00ms against a period of \
                 100.00ms, no deadline skipped"
            ),
            "{line}"
        );
    }

    #[test]
    fn later_ones_are_counted_into_one_line_every_ten_seconds() {
        let mut log = OverrunLog::new(ms(100));
        let phases = [("inputs", ms(90)), ("logic", ms(1)), ("outputs", ms(20))];
        assert!(log.note(at(0), 1, Duration::ZERO, phases).is_some());
        for t in 1..100 {
            assert_eq!(
                log.note(at(t * 100), 1, Duration::ZERO, phases),
                None,
                "at {t}"
            );
        }
        let line = log
            .note(at(10_000), 2, Duration::ZERO, phases)
            .expect("ten seconds on");
        assert!(line.contains("longest phase inputs 90.00ms"), "{line}");
        assert!(
            line.ends_with("(100 overruns since the last line)"),
            "{line}"
        );
    }
}
