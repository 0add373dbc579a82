//! Scan statistics: every phase timed into an HDR histogram.

use std::time::Duration;

use hdrhistogram::Histogram;

/// Percentiles of one histogram, in a form that prints and serialises easily.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Percentiles {
    /// Samples.
    pub count: u64,
    /// Median.
    pub p50: Duration,
    /// 99th percentile.
    pub p99: Duration,
    /// 99.9th percentile.
    pub p999: Duration,
    /// Largest sample.
    pub max: Duration,
}

impl std::fmt::Display for Percentiles {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "p50 {} p99 {} p99.9 {} max {}",
            fmt_duration(self.p50),
            fmt_duration(self.p99),
            fmt_duration(self.p999),
            fmt_duration(self.max)
        )
    }
}

/// A duration as a person reads it (the one formatting of the whole system).
pub use softplc_io::time::{fmt_duration, LineInstant, ScanInstant};

/// A histogram of durations with nanosecond resolution up to one minute.
#[derive(Debug, Clone)]
pub struct DurationHistogram {
    hist: Histogram<u64>,
}

impl Default for DurationHistogram {
    fn default() -> Self {
        Self::new()
    }
}

impl DurationHistogram {
    /// An empty histogram (3 significant digits, 1 ns .. 60 s).
    pub fn new() -> Self {
        // Bounds are constants that hdrhistogram accepts; failure here would be a code bug.
        let hist = Histogram::new_with_bounds(1, 60_000_000_000, 3)
            .unwrap_or_else(|_| Histogram::new(3).unwrap_or_else(|_| unreachable_histogram()));
        Self { hist }
    }

    /// Records one sample (clamped into range).
    pub fn record(&mut self, d: Duration) {
        let ns = (d.as_nanos() as u64).clamp(1, 60_000_000_000);
        self.hist.saturating_record(ns);
    }

    /// The percentiles so far.
    pub fn percentiles(&self) -> Percentiles {
        if self.hist.is_empty() {
            return Percentiles::default();
        }
        let at = |q: f64| Duration::from_nanos(self.hist.value_at_quantile(q));
        Percentiles {
            count: self.hist.len(),
            p50: at(0.50),
            p99: at(0.99),
            p999: at(0.999),
            max: Duration::from_nanos(self.hist.max()),
        }
    }

    /// The underlying histogram (for CDF plots).
    pub fn raw(&self) -> &Histogram<u64> {
        &self.hist
    }

    /// Forgets every sample.
    pub fn reset(&mut self) {
        self.hist.reset();
    }
}

fn unreachable_histogram() -> Histogram<u64> {
    // 3 significant digits is always valid for hdrhistogram; reaching this means the crate
    // changed its contract.
    panic!("hdrhistogram refused 3 significant digits")
}

/// Everything the scan measures.
#[derive(Debug, Clone, Default)]
pub struct ScanStats {
    /// Completed cycles.
    pub cycles: u64,
    /// Deadlines missed (skipped) because a cycle ran long.
    pub overruns: u64,
    /// Wake-up lateness: actual start − deadline.
    pub lateness: DurationHistogram,
    /// Input phase (all lines, in parallel).
    pub read: DurationHistogram,
    /// Logic phase.
    pub logic: DurationHistogram,
    /// Output phase, to the lines' acknowledgement of the writes.
    pub write: DurationHistogram,
    /// The cycle boundary: traces, control answers, the services' feed, the reload poll.
    pub boundary: DurationHistogram,
    /// Whole cycle: start to the later of the writes' end and the boundary's.
    pub cycle: DurationHistogram,
    /// Bus errors counted over all modules (timeouts, CRC, bad replies, exceptions).
    pub bus_errors: u64,
    /// The cycle just completed (what a trace samples).
    pub last: LastCycle,
}

/// The cycle just completed: its timestamp and its phases.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LastCycle {
    /// Its timestamp: the deadline it started on, the time its logic saw.
    pub start: ScanInstant,
    /// Input phase.
    pub read: Duration,
    /// Logic phase.
    pub logic: Duration,
    /// Output phase, as far as the scan's hand-off of the writes.
    pub write: Duration,
    /// The cycle up to the end of its output phase: its boundary, where a trace samples it,
    /// comes after (the histogram `ScanStats::cycle` counts it).
    pub cycle: Duration,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_of_known_samples() {
        let mut h = DurationHistogram::new();
        for ms in 1..=100u64 {
            h.record(Duration::from_millis(ms));
        }
        let p = h.percentiles();
        assert_eq!(p.count, 100);
        // 3 significant digits: within 0.1 %.
        assert!(p.p50.as_micros().abs_diff(50_000) <= 50, "{p:?}");
        assert!(p.max.as_micros().abs_diff(100_000) <= 100, "{p:?}");
    }

    #[test]
    fn formats_durations_for_people() {
        assert_eq!(fmt_duration(Duration::from_micros(850)), "850µs");
        assert_eq!(fmt_duration(Duration::from_micros(12_345)), "12.35ms");
        assert_eq!(fmt_duration(Duration::from_millis(1200)), "1.20s");
    }
}
