//! The trend's history: a few tags sampled from the published snapshot into a ring, so a page
//! opened now shows the last minute at once and then scrolls on with the live updates.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc_io::point::Value;

use crate::service::snapshot::SnapshotCell;

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
    /// The cycle count of the last sample, so a stalled scan adds nothing.
    last_cycle: Option<u64>,
}

impl Trend {
    /// An empty trend of `tags`.
    pub(crate) fn new(tags: Vec<usize>) -> Self {
        Self {
            tags,
            samples: VecDeque::with_capacity(TREND_SAMPLES),
            last_cycle: None,
        }
    }

    /// Adds a sample of `values` (all tags, in tag order) taken at `now` after `cycles`
    /// cycles, unless no cycle completed since the last one.
    pub(crate) fn sample(&mut self, cycles: u64, now: Duration, values: &[Value]) {
        if self.last_cycle == Some(cycles) {
            return;
        }
        self.last_cycle = Some(cycles);
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
            let taken = snapshot.with(|s| s.published.then(|| (s.cycles, s.now, s.values.clone())));
            if let Some((cycles, now, values)) = taken {
                let mut t = trend.lock().unwrap_or_else(|e| e.into_inner());
                t.sample(cycles, now.since_origin(), &values);
            }
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
        t.sample(1, Duration::from_millis(100), &values);
        t.sample(1, Duration::from_millis(200), &values);
        assert_eq!(t.samples.len(), 1, "no new cycle, no sample");
        assert_eq!(t.samples[0].1, vec![None, Some(1.0)]);
        for c in 2..(TREND_SAMPLES as u64 + 10) {
            t.sample(c, Duration::from_millis(100 * c), &values);
        }
        assert_eq!(t.samples.len(), TREND_SAMPLES);
        assert_eq!(
            t.samples.back().map(|s| s.0),
            Some(Duration::from_millis(100 * (TREND_SAMPLES as u64 + 9)))
        );
    }
}
