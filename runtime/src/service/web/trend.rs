//! The trend's history: a few tags sampled from the published snapshot into a ring, so a page
//! opened now shows the last minute at once and then scrolls on with the live updates.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc_io::point::Value;

use crate::service::snapshot::{ServiceSnapshot, SnapshotCell};

/// Samples kept: a minute at the fastest sampling.
pub(crate) const TREND_SAMPLES: usize = 600;
/// The fastest sampling; a slower scan is sampled once per cycle.
pub(crate) const FASTEST: Duration = Duration::from_millis(100);

/// A value as a number for a plot (bools 0/1); `None` when not finite.
pub(crate) fn number(v: Value) -> Option<f64> {
    let x = match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(x) => f64::from(x),
        Value::I32(x) => f64::from(x),
        Value::F32(x) => f64::from(x),
    };
    x.is_finite().then_some(x)
}

/// The ring of samples of the trend's tags.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Trend {
    /// The tags sampled (indexes into the project's tags).
    pub tags: Vec<usize>,
    /// Samples, oldest first: scan time and one value per tag.
    pub samples: VecDeque<(Duration, Vec<Option<f64>>)>,
    /// With several tasks, the task publishing each tag (in `tags` order); empty for one
    /// task.
    owners: Vec<usize>,
    /// The cycle counts of the last sample (the one task's, or each owning task's), so a
    /// stalled scan adds nothing.
    last_cycles: Vec<u64>,
}

impl Trend {
    /// An empty trend of `tags`.
    pub(crate) fn new(tags: Vec<usize>) -> Self {
        Self {
            tags,
            samples: VecDeque::with_capacity(TREND_SAMPLES),
            owners: Vec::new(),
            last_cycles: Vec::new(),
        }
    }

    /// The same, each tag sampled at the cycles of the task publishing it (`owners`, in
    /// `tags` order: a PLC of several tasks; empty for one task).
    pub(crate) fn sampled_by(mut self, owners: Vec<usize>) -> Self {
        self.owners = owners;
        self
    }

    /// Adds a sample of `s`'s values taken after the last cycle of the tasks owning the
    /// trend's tags, at the latest of their times, unless none of them completed a cycle
    /// since the last sample.
    pub(crate) fn sample_snapshot(&mut self, s: &ServiceSnapshot) {
        if self.owners.is_empty() {
            return self.sample(&[s.cycles], s.now.since_origin(), &s.values);
        }
        let cycles: Vec<u64> = self.owners.iter().map(|&t| s.cycles_of(t)).collect();
        let now = (self.owners.iter())
            .map(|&t| s.now_of(t).since_origin())
            .max()
            .unwrap_or_default();
        self.sample(&cycles, now, &s.values)
    }

    /// Adds a sample of `values` (all tags, in tag order) taken at `now` after `cycles`
    /// cycles (of each task sampled), unless no cycle completed since the last one.
    fn sample(&mut self, cycles: &[u64], now: Duration, values: &[Value]) {
        if self.last_cycles == cycles {
            return;
        }
        self.last_cycles.clear();
        self.last_cycles.extend_from_slice(cycles);
        if self.samples.len() >= TREND_SAMPLES {
            self.samples.pop_front();
        }
        let row = self
            .tags
            .iter()
            .map(|&t| values.get(t).copied().and_then(number))
            .collect();
        self.samples.push_back((now, row));
    }
}

/// Samples `snapshot` into `trend` every `every` (at least [`FASTEST`]) on a thread of its own,
/// for the life of the process.
pub(crate) fn spawn_sampler(
    snapshot: SnapshotCell,
    trend: Arc<Mutex<Trend>>,
    every: Duration,
) -> std::io::Result<()> {
    let every = every.max(FASTEST);
    std::thread::Builder::new()
        .name("web-trend".into())
        .spawn(move || loop {
            std::thread::sleep(every);
            // Under the snapshot's lock, briefly: a copy of a row, not of the snapshot.
            snapshot.with(|s| {
                if s.published {
                    let mut t = trend.lock().unwrap_or_else(|e| e.into_inner());
                    t.sample_snapshot(s);
                }
            });
        })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ring_keeps_the_last_samples_of_new_cycles() {
        let mut t = Trend::new(vec![1, 0]);
        let values = [Value::Bool(true), Value::F32(f32::NAN)];
        t.sample(&[1], Duration::from_millis(100), &values);
        t.sample(&[1], Duration::from_millis(200), &values);
        assert_eq!(t.samples.len(), 1, "no new cycle, no sample");
        assert_eq!(t.samples[0].1, vec![None, Some(1.0)]);
        for c in 2..(TREND_SAMPLES as u64 + 10) {
            t.sample(&[c], Duration::from_millis(100 * c), &values);
        }
        assert_eq!(t.samples.len(), TREND_SAMPLES);
        assert_eq!(
            t.samples.back().map(|s| s.0),
            Some(Duration::from_millis(100 * (TREND_SAMPLES as u64 + 9)))
        );
    }
}
