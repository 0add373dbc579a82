//! What the scan publishes for the services that look at it from other threads (the metrics
//! endpoint, the Modbus TCP server, the web page), and the publisher the scan calls at each
//! cycle boundary.
//!
//! The scan never waits for a reader: it publishes with `try_lock` and, when a reader holds the
//! lock, tries again at the next boundary. Tag values (and, for the web page, the block
//! instances' outputs) are copied every cycle (a copy into buffers that keep their capacity:
//! no allocation once warm); the statistics, whose
//! percentiles cost a walk over each histogram, every [`STATS_EVERY`] of scan time.
//!
//! In a PLC of several tasks every task's boundary publishes its share into the one
//! snapshot (`Publisher::with_share`): the values, qualities, timestamps and forced marks of
//! the tags it owns and its modules' states, at its own cycle end. The first task also
//! publishes what concerns the whole PLC (its cycles and phases, every task's figures, the
//! lost changes, the program's blocks). So a service shows each tag as its owning task last
//! published it, a force of any task, and every task's modules.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use softplc_io::line::Counters;
use softplc_io::point::{Quality, Value};

use super::changes::FeedCounts;
use super::task_share::TaskShare;
use crate::plc::Plc;
use crate::scan::{DurationHistogram, ScanStats};
use softplc_io::time::ScanInstant;

/// How often the statistics are refreshed, in scan time.
pub(crate) const STATS_EVERY: Duration = Duration::from_millis(250);

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

/// How many bars a published histogram has.
pub(crate) const HISTOGRAM_BUCKETS: usize = 40;

/// A phase's histogram reduced to `HISTOGRAM_BUCKETS` bars between its smallest and its
/// largest sample, for plots: equal widths, or equal ratios when the largest is more than 20
/// times the smallest (a long tail would otherwise squeeze every other sample into the first
/// bar).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HistogramView {
    /// Lower edge of the first bar.
    pub lo: Duration,
    /// Upper edge of the last bar.
    pub hi: Duration,
    /// Whether the bars have equal ratios (a log axis) rather than equal widths.
    pub log: bool,
    /// Samples per bar (empty when there are none).
    pub counts: Vec<u64>,
}

impl HistogramView {
    /// Fills `self` from `h`, reusing its buffer.
    fn fill(&mut self, h: &DurationHistogram) {
        self.counts.clear();
        let raw = h.raw();
        if raw.is_empty() {
            *self = HistogramView {
                counts: std::mem::take(&mut self.counts),
                ..HistogramView::default()
            };
            return;
        }
        let lo = raw.min().max(1);
        let hi = raw.max().max(lo + 1);
        let log = hi / lo > 20;
        self.lo = Duration::from_nanos(lo);
        self.hi = Duration::from_nanos(hi);
        self.log = log;
        self.counts.resize(HISTOGRAM_BUCKETS, 0);
        let n = HISTOGRAM_BUCKETS as f64;
        let (lo_f, hi_f) = (lo as f64, hi as f64);
        let span = if log { (hi_f / lo_f).ln() } else { hi_f - lo_f };
        for v in raw.iter_recorded() {
            let x = (raw.median_equivalent(v.value_iterated_to()) as f64).clamp(lo_f, hi_f);
            let at = if log { (x / lo_f).ln() } else { x - lo_f } / span;
            let i = ((at * n) as usize).min(HISTOGRAM_BUCKETS - 1);
            if let Some(c) = self.counts.get_mut(i) {
                *c += v.count_at_value();
            }
        }
    }
}

/// The timed phases, in the order [`Phase::ALL`] lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    /// Start to end of the output phase.
    Cycle,
    /// Input phase.
    Read,
    /// Logic phase.
    Logic,
    /// Output phase.
    Write,
    /// The cycle boundary (traces, control answers, the services' feed).
    Boundary,
    /// Wake-up lateness.
    Lateness,
}

impl Phase {
    /// Every phase.
    pub(crate) const ALL: [Phase; 6] = [
        Phase::Cycle,
        Phase::Read,
        Phase::Logic,
        Phase::Write,
        Phase::Boundary,
        Phase::Lateness,
    ];

    /// Its name in metrics.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Phase::Cycle => "cycle",
            Phase::Read => "read",
            Phase::Logic => "logic",
            Phase::Write => "write",
            Phase::Boundary => "boundary",
            Phase::Lateness => "lateness",
        }
    }

    fn histogram(self, s: &ScanStats) -> &DurationHistogram {
        match self {
            Phase::Cycle => &s.cycle,
            Phase::Read => &s.read,
            Phase::Logic => &s.logic,
            Phase::Write => &s.write,
            Phase::Boundary => &s.boundary,
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
    pub now: ScanInstant,
    /// Tag values, in tag order.
    pub values: Vec<Value>,
    /// Tag qualities, in tag order.
    pub qualities: Vec<Quality>,
    /// Scan time of each tag's last good read (inputs) or write, in tag order.
    pub timestamps: Vec<ScanInstant>,
    /// Whether each tag is forced, in tag order.
    pub forced: Vec<bool>,
    /// Phase summaries, in `Phase::ALL` order (refreshed every `STATS_EVERY`).
    pub phases: [PhaseSummary; Phase::ALL.len()],
    /// Modules, in project order (refreshed with the phases).
    pub modules: Vec<ModuleSnapshot>,
    /// Each module's last failure, when its last read failed (refreshed with the phases; only
    /// with `Publisher::with_details`).
    pub module_errors: Vec<Option<String>>,
    /// Each phase's histogram, in `Phase::ALL` order (refreshed with the phases; empty
    /// unless `Publisher::with_details`).
    pub histograms: Vec<HistogramView>,
    /// Every block instance's outputs, by instance index (every publication; empty for expr
    /// and Rhai programs, and unless `Publisher::with_details`: only the web page draws
    /// them).
    pub blocks: Vec<crate::logic::InstanceOutput>,
    /// Counts the refreshes of the statistics, so a reader sees when they changed.
    pub stats_seq: u64,
    /// Set by the last publication of a run, after the outputs went to their safe values.
    pub stopped: bool,
    /// Why the run ended (with [`Self::stopped`]): a request, a program fault, the watchdog.
    pub stop_reason: Option<String>,
    /// Per service fed every change (OPC UA, MQTT): its name and the changes it lost so far
    /// (refreshed with the statistics).
    pub lost_changes: Vec<(&'static str, u64)>,
    /// The simulated plant: running or stopped, and its states (every publication, only with
    /// `Publisher::with_details`: the web page's plant panel).
    pub plant: Option<super::status::PlantReport>,
    /// With several tasks, each task's figures (refreshed with the statistics).
    pub tasks: Vec<super::status::TaskReport>,
    /// With several tasks, each task's completed cycles at its last publication, in task
    /// order (empty for one task: [`Self::cycles`] is its count).
    pub task_cycles: Vec<u64>,
    /// With several tasks, whether each task has published its last state.
    pub task_stopped: Vec<bool>,
    /// With several tasks, the scan time of each task's last publication, in task order.
    pub task_now: Vec<ScanInstant>,
    /// With several tasks, each task's block instances' outputs by its own instance index,
    /// in task order (only with `Publisher::with_details`: the web page's ladders).
    pub task_blocks: Vec<Vec<crate::logic::InstanceOutput>>,
}

impl ServiceSnapshot {
    /// Task `task`'s completed cycles at its last publication (the one task's: `cycles`).
    pub fn cycles_of(&self, task: usize) -> u64 {
        self.task_cycles.get(task).copied().unwrap_or(self.cycles)
    }

    /// The scan time of task `task`'s last publication (the one task's: `now`).
    pub fn now_of(&self, task: usize) -> ScanInstant {
        self.task_now.get(task).copied().unwrap_or(self.now)
    }
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
    /// `Publisher`).
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
    stats_at: Option<ScanInstant>,
    details: bool,
    stop_reason: Option<String>,
    feeds: Vec<(&'static str, Arc<FeedCounts>)>,
    tasks: Vec<super::status::TaskStatus>,
    /// With several tasks: what this task publishes, and whether it is the first task (which
    /// also publishes what concerns the whole PLC).
    share: Option<(TaskShare, bool)>,
}

impl Publisher {
    /// A publisher into `cell`.
    pub fn new(cell: SnapshotCell) -> Self {
        Self {
            cell,
            stats_at: None,
            details: false,
            stop_reason: None,
            feeds: Vec::new(),
            tasks: Vec::new(),
            share: None,
        }
    }

    /// Publishes only `share` (a task of a PLC of several tasks); `host`: the first task,
    /// which also publishes what concerns the whole PLC.
    pub(crate) fn with_share(mut self, share: TaskShare, host: bool) -> Self {
        self.share = Some((share, host));
        self
    }

    /// Also publishes every task's figures (a PLC of several tasks, published by its first
    /// task).
    pub(crate) fn with_tasks(mut self, tasks: Vec<super::status::TaskStatus>) -> Self {
        self.tasks = tasks;
        self
    }

    /// Also publishes the lost changes of the services fed every change (see
    /// `crate::service::changes`).
    pub(crate) fn with_feeds(mut self, feeds: Vec<(&'static str, Arc<FeedCounts>)>) -> Self {
        self.feeds = feeds;
        self
    }

    /// Also publishes what only the web page shows: each phase's histogram and each module's
    /// last failure (a walk over each histogram every `STATS_EVERY`).
    pub fn with_details(mut self) -> Self {
        self.details = true;
        self
    }

    /// Why the run ends, published with the final publication.
    pub fn set_stop_reason(&mut self, why: String) {
        self.stop_reason = Some(why);
    }

    /// Publishes the PLC's image (every call) and statistics (every `STATS_EVERY`, or when
    /// `final_` is set) without blocking: skipped when a reader holds the lock.
    pub fn publish(&mut self, plc: &Plc, stats: &ScanStats, now: ScanInstant, final_: bool) {
        let Ok(mut s) = self.cell.0.try_lock() else {
            return;
        };
        let s = &mut *s;
        let host = self.share.as_ref().is_none_or(|(_, host)| *host);
        match &self.share {
            None => publish_image(s, plc),
            Some((share, _)) => {
                if s.values.len() != plc.image().len() {
                    // The first publication: every tag as this task holds it, until its
                    // owner publishes it.
                    publish_image(s, plc);
                }
                publish_tags(s, plc, share.tags());
                s.task_cycles.resize(share.tasks(), 0);
                s.task_stopped.resize(share.tasks(), false);
                if let Some(c) = s.task_cycles.get_mut(share.task()) {
                    *c = stats.cycles;
                }
                // Its figures' counts with its tags, at every publication: `PLC.Tasks.NAME.Scans`
                // is the task's cycle its values come from, not the count its scan last
                // published for the status line (every 200 ms, after the boundary).
                if let Some(t) = s.tasks.get_mut(share.task()) {
                    t.scans = stats.cycles;
                    t.overruns = stats.overruns;
                }
                if let Some(f) = s.task_stopped.get_mut(share.task()) {
                    *f = final_;
                }
                s.task_now.resize(share.tasks(), ScanInstant::ZERO);
                if let Some(at) = s.task_now.get_mut(share.task()) {
                    *at = now;
                }
                if self.details {
                    // Each task's ladders are lit by its own blocks, published with its tags.
                    s.task_blocks.resize_with(share.tasks(), Vec::new);
                    if let Some(blocks) = s.task_blocks.get_mut(share.task()) {
                        plc.instance_outputs(blocks);
                    }
                }
            }
        }
        if host {
            s.published = true;
            s.cycles = stats.cycles;
            s.overruns = stats.overruns;
            s.now = now;
            if final_ {
                s.stop_reason = self.stop_reason.clone();
            }
            if self.details {
                // Published with the tag values, so a block's ET and the coil it drives agree
                // (with several tasks in `task_blocks`, each task's own).
                if self.share.is_none() {
                    plc.instance_outputs(&mut s.blocks);
                }
                s.plant = super::status::PlantReport::of(plc);
            }
        }
        // With several tasks the services see the end once every task has published its
        // safe state.
        s.stopped = match &self.share {
            None => final_,
            Some(_) => !s.task_stopped.is_empty() && s.task_stopped.iter().all(|&f| f),
        };
        let due = self
            .stats_at
            .is_none_or(|at| now.saturating_duration_since(at) >= STATS_EVERY);
        if !(due || final_) {
            return;
        }
        self.stats_at = Some(now);
        if host {
            for (slot, phase) in s.phases.iter_mut().zip(Phase::ALL) {
                *slot = PhaseSummary::of(phase.histogram(stats));
            }
            // The live figures' percentiles, with each task's scans at its latest publication
            // here (the cycle its tags come from; its live figures may be a cycle either
            // side) and overruns that never go back.
            let overruns: Vec<u64> = s.tasks.iter().map(|t| t.overruns).collect();
            s.tasks.clear();
            s.tasks
                .extend(self.tasks.iter().filter_map(super::status::TaskReport::of));
            for (i, t) in s.tasks.iter_mut().enumerate() {
                t.scans = s.task_cycles.get(i).copied().unwrap_or(t.scans);
                t.overruns = t.overruns.max(overruns.get(i).copied().unwrap_or_default());
            }
            if let Some((share, _)) = &self.share {
                if let Some(t) = s.tasks.get_mut(share.task()) {
                    t.scans = stats.cycles;
                    t.overruns = stats.overruns;
                }
            }
            s.lost_changes.clear();
            s.lost_changes
                .extend(self.feeds.iter().map(|(name, c)| (*name, c.lost())));
            if self.details {
                s.histograms
                    .resize_with(Phase::ALL.len(), HistogramView::default);
                for (view, phase) in s.histograms.iter_mut().zip(Phase::ALL) {
                    view.fill(phase.histogram(stats));
                }
            }
        }
        self.publish_modules(s, plc);
        s.stats_seq += 1;
    }

    /// This task's modules (every module for one task), at their places in the project.
    fn publish_modules(&self, s: &mut ServiceSnapshot, plc: &Plc) {
        let status = plc.module_status();
        let place = |local: usize| match &self.share {
            Some((share, _)) => share.module(local),
            None => Some(local),
        };
        let count = match &self.share {
            Some((share, _)) => share.all_modules(),
            None => status.len(),
        };
        if self.share.is_none() {
            s.modules.clear();
            s.module_errors.clear();
        }
        s.modules.resize(count, ModuleSnapshot::default());
        if self.details {
            s.module_errors.resize(count, None);
        }
        for (local, m) in status.iter().enumerate() {
            let Some(at) = place(local) else { continue };
            if let Some(slot) = s.modules.get_mut(at) {
                *slot = ModuleSnapshot {
                    quality: m.quality,
                    counters: m.counters,
                };
            }
            if self.details {
                if let Some(slot) = s.module_errors.get_mut(at) {
                    *slot = m.last_error.as_ref().map(ToString::to_string);
                }
            }
        }
    }
}

/// Every tag of the image, filled anew.
fn publish_image(s: &mut ServiceSnapshot, plc: &Plc) {
    let image = plc.image();
    let slots = image.slots();
    s.values.clear();
    s.values.extend(slots.iter().map(|x| x.value));
    s.qualities.clear();
    s.qualities.extend(slots.iter().map(|x| x.quality));
    s.timestamps.clear();
    s.timestamps.extend(slots.iter().map(|x| x.timestamp));
    s.forced.clear();
    s.forced
        .extend((0..image.len()).map(|i| image.forced(crate::image::TagId(i as u32)).is_some()));
}

/// The tags `tags` of the image, at their places (the snapshot holds every tag already).
fn publish_tags(s: &mut ServiceSnapshot, plc: &Plc, tags: impl Iterator<Item = usize>) {
    let image = plc.image();
    for t in tags {
        let (Some(slot), Some(v), Some(q), Some(at), Some(f)) = (
            image.slots().get(t),
            s.values.get_mut(t),
            s.qualities.get_mut(t),
            s.timestamps.get_mut(t),
            s.forced.get_mut(t),
        ) else {
            continue;
        };
        (*v, *q, *at) = (slot.value, slot.quality, slot.timestamp);
        *f = image.forced(crate::image::TagId(t as u32)).is_some();
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

    #[test]
    fn a_histogram_view_counts_every_sample_once() {
        let mut h = DurationHistogram::new();
        for ms in 10..=50u64 {
            h.record(Duration::from_millis(ms));
        }
        let mut v = HistogramView::default();
        v.fill(&h);
        assert!(!v.log);
        assert_eq!(v.counts.len(), HISTOGRAM_BUCKETS);
        assert_eq!(v.counts.iter().sum::<u64>(), 41);
        assert!(v.lo.as_micros().abs_diff(10_000) <= 10, "{v:?}");
        assert!(v.hi.as_micros().abs_diff(50_000) <= 50, "{v:?}");
        assert!(v.counts.iter().all(|&c| c <= 2), "{v:?}");
        // A long tail switches to equal ratios.
        h.record(Duration::from_secs(5));
        v.fill(&h);
        assert!(v.log);
        assert_eq!(v.counts.iter().sum::<u64>(), 42);
        assert_eq!(v.counts.last(), Some(&1));
        // Empty: no bars.
        v.fill(&DurationHistogram::new());
        assert!(v.counts.is_empty() && v.lo.is_zero());
    }
}
