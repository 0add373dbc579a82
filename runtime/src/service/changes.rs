//! Every change of every cycle, in cycle order, for the services that must not miss one (the
//! OPC UA server and the Sparkplug edge node).
//!
//! The snapshot ([`super::snapshot`]) is one slot a reader samples when it can: a value that
//! lives one cycle (a pulse, a counter's step, an alarm that came and went) may never be in
//! it when a reader looks. So at each cycle boundary the scan also compares the image with the
//! one before and offers what changed (value or quality) to each consumer's own bounded queue,
//! with `try_send`: the scan never waits and never allocates more than one list per cycle.
//!
//! A consumer that falls [`QUEUE_CYCLES`] cycles behind loses changes, never silently: its
//! count of lost changes grows (`softplc status`, the metrics, the service's own figure), and
//! the next cycle it takes carries, for every tag whose change it lost, that tag's value now
//! (so it is in step again) and the tag's name in [`Delivery::overflowed`] (OPC UA sets the
//! Overflow InfoBit on it).

use crossbeam_channel::{Receiver, Sender, TrySendError};
use softplc_io::point::{Quality, Value};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::image::ProcessImage;
use softplc_io::time::ScanInstant;

/// How many cycles a consumer may fall behind before it loses changes (10 s at a 10 ms scan).
pub(crate) const QUEUE_CYCLES: usize = 1000;

/// One tag's new value or quality.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct TagChange {
    /// The tag (its index in the project).
    pub(crate) tag: usize,
    /// Its value after the cycle.
    pub(crate) value: Value,
    /// Its quality after the cycle.
    pub(crate) quality: Quality,
}

/// What one cycle changed.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CycleChanges {
    /// The cycle (the scan's count of completed cycles at its boundary).
    pub(crate) cycle: u64,
    /// The scan time of its boundary: the changes' source time.
    pub(crate) at: ScanInstant,
    /// The tags it changed, in tag order.
    pub(crate) changes: Vec<TagChange>,
}

/// What a consumer takes from its queue: one cycle, and what it must know of changes it lost
/// before it.
#[derive(Debug, Clone)]
pub(crate) struct Delivery {
    /// The cycle's changes (shared by every consumer).
    pub(crate) cycle: Arc<CycleChanges>,
    /// Tags whose changes this consumer lost and that this cycle did not change: their value
    /// now, to take before the cycle's own changes.
    pub(crate) catch_up: Vec<TagChange>,
    /// Every tag whose change this consumer lost before this cycle (sorted).
    pub(crate) overflowed: Vec<usize>,
}

impl Delivery {
    /// Every change to apply, catch-up first, each with whether a change of its tag was lost
    /// before it.
    pub(crate) fn all(&self) -> impl Iterator<Item = (TagChange, bool)> + '_ {
        self.catch_up
            .iter()
            .chain(&self.cycle.changes)
            .map(|c| (*c, self.overflowed.binary_search(&c.tag).is_ok()))
    }
}

/// A consumer's figures, shared between the scan (which counts) and whoever reports them.
#[derive(Debug, Default)]
pub(crate) struct FeedCounts {
    lost: AtomicU64,
}

impl FeedCounts {
    /// Changes this consumer lost so far.
    pub(crate) fn lost(&self) -> u64 {
        self.lost.load(Ordering::Relaxed)
    }
}

/// A consumer's end: its queue and its figures.
#[derive(Debug)]
pub(crate) struct ChangeStream {
    rx: Receiver<Delivery>,
    counts: Arc<FeedCounts>,
}

impl ChangeStream {
    /// The queue.
    pub(crate) fn receiver(&self) -> &Receiver<Delivery> {
        &self.rx
    }

    /// Changes lost so far.
    pub(crate) fn lost(&self) -> u64 {
        self.counts.lost()
    }
}

/// The scan's end of one consumer.
#[derive(Debug)]
struct Producer {
    name: &'static str,
    tx: Sender<Delivery>,
    counts: Arc<FeedCounts>,
    /// Per tag: a change of it was lost and the consumer has not been told.
    lost: Vec<bool>,
    any_lost: bool,
}

/// The scan's side (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct ChangeFeed {
    last: Vec<(Value, Quality)>,
    producers: Vec<Producer>,
}

impl ChangeFeed {
    /// A feed with no consumer yet.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// A new consumer named `name` (in status and metrics), with a queue of `cycles` cycles.
    pub(crate) fn subscribe(&mut self, name: &'static str, cycles: usize) -> ChangeStream {
        let (tx, rx) = crossbeam_channel::bounded(cycles.max(1));
        let counts = Arc::new(FeedCounts::default());
        self.producers.push(Producer {
            name,
            tx,
            counts: counts.clone(),
            lost: Vec::new(),
            any_lost: false,
        });
        ChangeStream { rx, counts }
    }

    /// Each consumer's name and figures.
    pub(crate) fn counts(&self) -> Vec<(&'static str, Arc<FeedCounts>)> {
        self.producers
            .iter()
            .map(|p| (p.name, p.counts.clone()))
            .collect()
    }

    /// Whether anyone consumes the feed.
    pub(crate) fn is_empty(&self) -> bool {
        self.producers.is_empty()
    }

    /// At a cycle boundary: what `image` changed since the last call (everything at the
    /// first), offered to every consumer without waiting.
    pub(crate) fn offer(&mut self, image: &ProcessImage, cycle: u64, at: ScanInstant) {
        if self.producers.is_empty() {
            return;
        }
        let slots = image.slots();
        let first = self.last.len() != slots.len();
        let mut changes = Vec::new();
        for (tag, s) in slots.iter().enumerate() {
            let now = (s.value, s.quality);
            if first || !same(self.last[tag], now) {
                changes.push(TagChange {
                    tag,
                    value: s.value,
                    quality: s.quality,
                });
            }
        }
        if first {
            self.last.clear();
            self.last.extend(slots.iter().map(|s| (s.value, s.quality)));
        } else {
            for c in &changes {
                self.last[c.tag] = (c.value, c.quality);
            }
        }
        let cycle = Arc::new(CycleChanges { cycle, at, changes });
        for p in &mut self.producers {
            p.offer(&cycle, image);
        }
    }
}

/// Equal as a client sees it (a NaN that stays NaN is no change).
fn same(a: (Value, Quality), b: (Value, Quality)) -> bool {
    let nan = |v: Value| matches!(v, Value::F32(f) if f.is_nan());
    a.1 == b.1 && (a.0 == b.0 || (nan(a.0) && nan(b.0)))
}

impl Producer {
    fn offer(&mut self, cycle: &Arc<CycleChanges>, image: &ProcessImage) {
        if cycle.changes.is_empty() && !self.any_lost {
            return;
        }
        let mut delivery = Delivery {
            cycle: cycle.clone(),
            catch_up: Vec::new(),
            overflowed: Vec::new(),
        };
        if self.any_lost {
            let slots = image.slots();
            delivery.overflowed = (0..self.lost.len()).filter(|&t| self.lost[t]).collect();
            delivery.catch_up = delivery
                .overflowed
                .iter()
                .filter(|&&t| cycle.changes.binary_search_by_key(&t, |c| c.tag).is_err())
                .filter_map(|&tag| {
                    let s = slots.get(tag)?;
                    Some(TagChange {
                        tag,
                        value: s.value,
                        quality: s.quality,
                    })
                })
                .collect();
        }
        match self.tx.try_send(delivery) {
            Ok(()) => {
                if self.any_lost {
                    self.lost.iter_mut().for_each(|l| *l = false);
                    self.any_lost = false;
                }
            }
            Err(TrySendError::Full(_)) => {
                self.counts
                    .lost
                    .fetch_add(cycle.changes.len() as u64, Ordering::Relaxed);
                if self.lost.len() < image.len() {
                    self.lost.resize(image.len(), false);
                }
                for c in &cycle.changes {
                    self.lost[c.tag] = true;
                }
                self.any_lost = true;
            }
            // The consumer has ended (its service stopped): nothing to tell it.
            Err(TrySendError::Disconnected(_)) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn image() -> ProcessImage {
        ProcessImage::new([
            ("a".to_string(), Value::I32(0)),
            ("b".to_string(), Value::Bool(false)),
        ])
    }

    fn values(d: &Delivery) -> Vec<(usize, Value, bool)> {
        d.all().map(|(c, o)| (c.tag, c.value, o)).collect()
    }

    #[test]
    fn every_cycle_reaches_a_consumer_in_order_with_only_what_changed() {
        let mut img = image();
        let mut feed = ChangeFeed::new();
        let s = feed.subscribe("test", 10);
        let a = img.id("a").unwrap();
        feed.offer(
            &img,
            1,
            ScanInstant::after_origin(Duration::from_millis(10)),
        );
        for n in 1..=3 {
            img.set(a, Value::I32(n), ScanInstant::ZERO);
            feed.offer(
                &img,
                1 + n as u64,
                ScanInstant::after_origin(Duration::from_millis(10 * (1 + n as u64))),
            );
        }
        // A cycle that changed nothing sends nothing.
        feed.offer(
            &img,
            5,
            ScanInstant::after_origin(Duration::from_millis(50)),
        );
        let got: Vec<Delivery> = s.receiver().try_iter().collect();
        assert_eq!(got.len(), 4);
        assert_eq!(got[0].cycle.changes.len(), 2, "everything at the first");
        for (n, d) in got[1..].iter().enumerate() {
            assert_eq!(d.cycle.cycle, n as u64 + 2);
            assert_eq!(
                d.cycle.at,
                ScanInstant::after_origin(Duration::from_millis(10 * (n as u64 + 2)))
            );
            assert_eq!(values(d), [(0, Value::I32(n as i32 + 1), false)]);
        }
        assert_eq!(s.lost(), 0);
    }

    #[test]
    fn a_consumer_that_falls_behind_loses_changes_visibly_and_is_put_back_in_step() {
        let mut img = image();
        let mut feed = ChangeFeed::new();
        let s = feed.subscribe("slow", 2);
        let (a, b) = (img.id("a").unwrap(), img.id("b").unwrap());
        feed.offer(&img, 1, ScanInstant::ZERO);
        img.set(a, Value::I32(1), ScanInstant::ZERO);
        feed.offer(&img, 2, ScanInstant::ZERO);
        // Full: cycles 3 (a and b) and 4 (a) are lost.
        img.set(a, Value::I32(2), ScanInstant::ZERO);
        img.set(b, Value::Bool(true), ScanInstant::ZERO);
        feed.offer(&img, 3, ScanInstant::ZERO);
        img.set(a, Value::I32(3), ScanInstant::ZERO);
        feed.offer(&img, 4, ScanInstant::ZERO);
        assert_eq!(s.lost(), 3);
        assert_eq!(feed.counts()[0].1.lost(), 3);
        let got: Vec<Delivery> = s.receiver().try_iter().collect();
        assert_eq!(got.len(), 2);
        // Room again: cycle 5 changes a; b is caught up, both are marked.
        img.set(a, Value::I32(4), ScanInstant::ZERO);
        feed.offer(&img, 5, ScanInstant::ZERO);
        let d = s.receiver().try_recv().unwrap();
        assert_eq!(
            values(&d),
            [(1, Value::Bool(true), true), (0, Value::I32(4), true)]
        );
        // Then in step: nothing marked.
        img.set(a, Value::I32(5), ScanInstant::ZERO);
        feed.offer(&img, 6, ScanInstant::ZERO);
        let d = s.receiver().try_recv().unwrap();
        assert_eq!(values(&d), [(0, Value::I32(5), false)]);
    }

    #[test]
    fn a_quality_change_is_a_change() {
        let mut img = image();
        let mut feed = ChangeFeed::new();
        let s = feed.subscribe("test", 10);
        feed.offer(&img, 1, ScanInstant::ZERO);
        img.set_quality(img.id("b").unwrap(), Quality::Good);
        feed.offer(&img, 2, ScanInstant::ZERO);
        let d: Vec<Delivery> = s.receiver().try_iter().collect();
        assert_eq!(d[1].cycle.changes[0].quality, Quality::Good);
        assert_eq!(d[1].cycle.changes[0].tag, 1);
    }
}
