//! What the scan publishes for the services that look at it from other threads (the metrics
//! endpoint, the Modbus TCP server), and the publisher the scan calls at each cycle boundary.
//!
//! The scan never waits for a reader: it publishes with `try_lock` and, when a reader holds the
//! lock, tries again at the next boundary. Tag values are copied every cycle (a copy into
//! buffers that keep their capacity: no allocation once warm); the statistics, whose
//! percentiles cost a walk over each histogram, every [`STATS_EVERY`] of scan time.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use softplc_io::line::bus::Counters;
use softplc_io::point::{Quality, Value};

use crate::plc::Plc;
use crate::scan::{DurationHistogram, ScanStats};

/// How often the statistics are refreshed, in scan time.
pub const STATS_EVERY: Duration = Duration::from_millis(250);

/// One timed phase, summarised.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PhaseSummary {
    /// Samples.
    pub count: u64,
    /// Sum of the samples (count × the histogram's mean: within its 0.1 % precision).
    pub sum: Duration,
    /// Median.
    pub p50: Duration,
    /// 99th percentile.
    pub p99: Duration,
    /// 99.9th percentile.
    pub p999: Duration,
    /// Largest.
    pub max: Duration,
}

impl PhaseSummary {
    fn of(h: &DurationHistogram) -> Self {
        let p = h.percentiles();
        let mean_ns = h.raw().mean();
        let sum_ns = if mean_ns.is_finite() {
            mean_ns * p.count as f64
        } else {
            0.0
        };
        Self {
            count: p.count,
            sum: Duration::from_nanos(sum_ns.clamp(0.0, u64::MAX as f64) as u64),
            p50: p.p50,
            p99: p.p99,
            p999: p.p999,
            max: p.max,
        }
    }
}

/// The timed phases, in the order [`Phase::ALL`] lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Start to end of the output phase.
    Cycle,
    /// Input phase.
    Read,
    /// Logic phase.
    Logic,
    /// Output phase.
    Write,
    /// Wake-up lateness.
    Lateness,
}

impl Phase {
    /// Every phase.
    pub const ALL: [Phase; 5] = [
        Phase::Cycle,
        Phase::Read,
        Phase::Logic,
        Phase::Write,
        Phase::Lateness,
    ];

    /// Its name in metrics.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Cycle => "cycle",
            Phase::Read => "read",
            Phase::Logic => "logic",
            Phase::Write => "write",
            Phase::Lateness => "lateness",
        }
    }

    fn histogram(self, s: &ScanStats) -> &DurationHistogram {
        match self {
            Phase::Cycle => &s.cycle,
            Phase::Read => &s.read,
            Phase::Logic => &s.logic,
            Phase::Write => &s.write,
            Phase::Lateness => &s.lateness,
        }
    }
}

/// One module as last seen.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModuleSnapshot {
    /// Quality of its last read.
    pub quality: Quality,
    /// Its counters.
    pub counters: Counters,
}

/// What the services see of the running PLC. Names (tags, modules) are the project's and do
/// not change while it runs, so they are not copied here.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ServiceSnapshot {
    /// Whether anything was published yet.
    pub published: bool,
    /// Completed cycles.
    pub cycles: u64,
    /// Overruns.
    pub overruns: u64,
    /// Scan time of the publication.
    pub now: Duration,
    /// Tag values, in tag order.
    pub values: Vec<Value>,
    /// Tag qualities, in tag order.
    pub qualities: Vec<Quality>,
    /// Whether each tag is forced, in tag order.
    pub forced: Vec<bool>,
    /// Phase summaries, in [`Phase::ALL`] order (refreshed every [`STATS_EVERY`]).
    pub phases: [PhaseSummary; 5],
    /// Modules, in project order (refreshed with the phases).
    pub modules: Vec<ModuleSnapshot>,
}

/// The shared snapshot.
#[derive(Debug, Clone, Default)]
pub struct SnapshotCell(Arc<Mutex<ServiceSnapshot>>);

impl SnapshotCell {
    /// An empty cell.
    pub fn new() -> Self {
        Self::default()
    }

    /// A copy of the snapshot (readers hold the lock only for the copy).
    pub fn get(&self) -> ServiceSnapshot {
        self.lock().clone()
    }

    /// Replaces the snapshot (tests and fuzzing harnesses publish with this; the scan uses a
    /// [`Publisher`]).
    pub fn set(&self, snapshot: ServiceSnapshot) {
        *self.lock() = snapshot;
    }

    /// Runs `f` on the snapshot under the lock; keep `f` short, the scan skips a refresh
    /// while it runs.
    pub fn with<R>(&self, f: impl FnOnce(&ServiceSnapshot) -> R) -> R {
        f(&self.lock())
    }

    fn lock(&self) -> MutexGuard<'_, ServiceSnapshot> {
        // A reader that panicked left a valid snapshot behind: keep serving it.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Called by the scan at each cycle boundary.
#[derive(Debug)]
pub struct Publisher {
    cell: SnapshotCell,
    stats_at: Option<Duration>,
}

impl Publisher {
    /// A publisher into `cell`.
    pub fn new(cell: SnapshotCell) -> Self {
        Self {
            cell,
            stats_at: None,
        }
    }

    /// Publishes the PLC's image (every call) and statistics (every [`STATS_EVERY`], or when
    /// `final_` is set) without blocking: skipped when a reader holds the lock.
    pub fn publish(&mut self, plc: &Plc, stats: &ScanStats, now: Duration, final_: bool) {
        let Ok(mut s) = self.cell.0.try_lock() else {
            return;
        };
        let image = plc.image();
        s.published = true;
        s.cycles = stats.cycles;
        s.overruns = stats.overruns;
        s.now = now;
        s.values.clear();
        s.values.extend(image.slots().iter().map(|x| x.value));
        s.qualities.clear();
        s.qualities.extend(image.slots().iter().map(|x| x.quality));
        s.forced.clear();
        s.forced.extend(
            (0..image.len()).map(|i| image.forced(crate::image::TagId(i as u32)).is_some()),
        );
        let due = self
            .stats_at
            .is_none_or(|at| now.saturating_sub(at) >= STATS_EVERY);
        if due || final_ {
            self.stats_at = Some(now);
            for (slot, phase) in s.phases.iter_mut().zip(Phase::ALL) {
                *slot = PhaseSummary::of(phase.histogram(stats));
            }
            s.modules.clear();
            s.modules
                .extend(plc.module_status().iter().map(|m| ModuleSnapshot {
                    quality: m.quality,
                    counters: m.counters,
                }));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_phase_summary_has_the_sum_of_its_samples() {
        let mut h = DurationHistogram::new();
        for ms in 1..=10u64 {
            h.record(Duration::from_millis(ms));
        }
        let s = PhaseSummary::of(&h);
        assert_eq!(s.count, 10);
        assert!(s.sum.as_micros().abs_diff(55_000) <= 55, "{s:?}");
        assert_eq!(
            PhaseSummary::of(&DurationHistogram::new()).sum,
            Duration::ZERO
        );
    }
}
