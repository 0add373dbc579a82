//! Every change of every cycle, in cycle order, for the services that must not miss one (the
//! OPC UA server, the Sparkplug edge node and the alarms), with the modules whose quality
//! changed (a lost module is one alarm, not one per signal).
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
//!
//! In a PLC of several tasks every task's boundary feeds the same consumers (`ChangeFeed::
//! share`): the changes of the tags it owns and of its modules, at its own cycle end, with
//! its own cycle number and timestamps. A consumer so sees every change a fast task makes,
//! whatever the first task's period; each tag's changes come in order (one task feeds them),
//! and a delivery says which task's cycle it is.

use crossbeam_channel::{Receiver, Sender, TrySendError};
use softplc_io::point::{Quality, Value};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use super::task_share::TaskShare;
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
    /// The task whose cycle it is (0 for a PLC of one task).
    pub(crate) task: usize,
    /// The cycle (the task's count of completed cycles at its boundary).
    pub(crate) cycle: u64,
    /// The scan time of its boundary: the changes' source time.
    pub(crate) at: ScanInstant,
    /// The tags it changed, in tag order (with several tasks: of the tags its task owns).
    pub(crate) changes: Vec<TagChange>,
    /// The modules whose quality it changed (index in the project, quality after it; with
    /// several tasks: of its task's modules).
    pub(crate) modules: Vec<(usize, Quality)>,
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
    /// After a loss: every module's quality now (else empty; the cycle's own follow).
    pub(crate) modules_catch_up: Vec<(usize, Quality)>,
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
    // Read by the optional services (the alarms read their figures through `counts`).
    #[cfg_attr(not(feature = "mqtt"), allow(dead_code))]
    pub(crate) fn lost(&self) -> u64 {
        self.counts.lost()
    }

    /// Its figures, for a reader of its own.
    pub(crate) fn counts(&self) -> Arc<FeedCounts> {
        self.counts.clone()
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
    /// A cycle that changed a module's quality was lost.
    modules_lost: bool,
}

/// The scan's side (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct ChangeFeed {
    last: Vec<(Value, Quality)>,
    last_modules: Vec<Quality>,
    producers: Vec<Producer>,
    /// With several tasks: the tags and modules this task's boundary feeds.
    share: Option<TaskShare>,
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
            modules_lost: false,
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

    /// A feed of the same consumers for one task's boundary of a PLC of several tasks: it
    /// offers the changes of `share`'s tags and modules only. Its consumers' figures are
    /// shared (a change lost by any task's feed is counted once, in the same figure).
    pub(crate) fn share(&self, share: TaskShare) -> ChangeFeed {
        ChangeFeed {
            last: Vec::new(),
            last_modules: Vec::new(),
            producers: self
                .producers
                .iter()
                .map(|p| Producer {
                    name: p.name,
                    tx: p.tx.clone(),
                    counts: p.counts.clone(),
                    lost: Vec::new(),
                    any_lost: false,
                    modules_lost: false,
                })
                .collect(),
            share: Some(share),
        }
    }

    /// The project's index of this feed's module `local`.
    fn module_id(&self, local: usize) -> usize {
        match &self.share {
            Some(share) => share.module(local).unwrap_or(local),
            None => local,
        }
    }

    /// Whether this feed offers the changes of tag `tag`.
    fn feeds(&self, tag: usize) -> bool {
        self.share.as_ref().is_none_or(|s| s.owns(tag))
    }

    /// At a cycle boundary: what `image` and the modules' qualities (`modules`, in project
    /// order) changed since the last call (everything at the first), offered to every
    /// consumer without waiting.
    pub(crate) fn offer(
        &mut self,
        image: &ProcessImage,
        modules: impl ExactSizeIterator<Item = Quality>,
        cycle: u64,
        at: ScanInstant,
    ) {
        if self.producers.is_empty() {
            return;
        }
        let first_modules = self.last_modules.len() != modules.len();
        if first_modules {
            self.last_modules = vec![Quality::Bad; modules.len()];
        }
        let mut module_changes = Vec::new();
        for (m, q) in modules.enumerate() {
            if first_modules || self.last_modules[m] != q {
                self.last_modules[m] = q;
                module_changes.push((self.module_id(m), q));
            }
        }
        let slots = image.slots();
        let first = self.last.len() != slots.len();
        let mut changes = Vec::new();
        for (tag, s) in slots.iter().enumerate() {
            let now = (s.value, s.quality);
            if (first || !same(self.last[tag], now)) && self.feeds(tag) {
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
        let cycle = Arc::new(CycleChanges {
            task: self.share.as_ref().map_or(0, TaskShare::task),
            cycle,
            at,
            changes,
            modules: module_changes,
        });
        let modules: Vec<(usize, Quality)> = if self.producers.iter().any(|p| p.modules_lost) {
            (0..self.last_modules.len())
                .map(|m| (self.module_id(m), self.last_modules[m]))
                .collect()
        } else {
            Vec::new()
        };
        for p in &mut self.producers {
            p.offer(&cycle, image, &modules);
        }
    }
}

/// Equal as a client sees it (a NaN that stays NaN is no change).
fn same(a: (Value, Quality), b: (Value, Quality)) -> bool {
    let nan = |v: Value| matches!(v, Value::F32(f) if f.is_nan());
    a.1 == b.1 && (a.0 == b.0 || (nan(a.0) && nan(b.0)))
}

impl Producer {
    /// `modules`: every module's quality now, when a producer lost a cycle of them.
    fn offer(
        &mut self,
        cycle: &Arc<CycleChanges>,
        image: &ProcessImage,
        modules: &[(usize, Quality)],
    ) {
        if cycle.changes.is_empty() && cycle.modules.is_empty() && !self.any_lost {
            return;
        }
        let mut delivery = Delivery {
            cycle: cycle.clone(),
            catch_up: Vec::new(),
            overflowed: Vec::new(),
            modules_catch_up: Vec::new(),
        };
        if self.modules_lost {
            delivery.modules_catch_up = modules.to_vec();
        }
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
                    self.modules_lost = false;
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
                self.modules_lost |= !cycle.modules.is_empty();
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
            std::iter::empty(),
            1,
            ScanInstant::after_origin(Duration::from_millis(10)),
        );
        for n in 1..=3 {
            img.set(a, Value::I32(n), ScanInstant::ZERO);
            feed.offer(
                &img,
                std::iter::empty(),
                1 + n as u64,
                ScanInstant::after_origin(Duration::from_millis(10 * (1 + n as u64))),
            );
        }
        // A cycle that changed nothing sends nothing.
        feed.offer(
            &img,
            std::iter::empty(),
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
        feed.offer(&img, std::iter::empty(), 1, ScanInstant::ZERO);
        img.set(a, Value::I32(1), ScanInstant::ZERO);
        feed.offer(&img, std::iter::empty(), 2, ScanInstant::ZERO);
        // Full: cycles 3 (a and b) and 4 (a) are lost.
        img.set(a, Value::I32(2), ScanInstant::ZERO);
        img.set(b, Value::Bool(true), ScanInstant::ZERO);
        feed.offer(&img, std::iter::empty(), 3, ScanInstant::ZERO);
        img.set(a, Value::I32(3), ScanInstant::ZERO);
        feed.offer(&img, std::iter::empty(), 4, ScanInstant::ZERO);
        assert_eq!(s.lost(), 3);
        assert_eq!(feed.counts()[0].1.lost(), 3);
        let got: Vec<Delivery> = s.receiver().try_iter().collect();
        assert_eq!(got.len(), 2);
        // Room again: cycle 5 changes a; b is caught up, both are marked.
        img.set(a, Value::I32(4), ScanInstant::ZERO);
        feed.offer(&img, std::iter::empty(), 5, ScanInstant::ZERO);
        let d = s.receiver().try_recv().unwrap();
        assert_eq!(
            values(&d),
            [(1, Value::Bool(true), true), (0, Value::I32(4), true)]
        );
        // Then in step: nothing marked.
        img.set(a, Value::I32(5), ScanInstant::ZERO);
        feed.offer(&img, std::iter::empty(), 6, ScanInstant::ZERO);
        let d = s.receiver().try_recv().unwrap();
        assert_eq!(values(&d), [(0, Value::I32(5), false)]);
    }

    #[test]
    fn a_quality_change_is_a_change() {
        let mut img = image();
        let mut feed = ChangeFeed::new();
        let s = feed.subscribe("test", 10);
        feed.offer(&img, std::iter::empty(), 1, ScanInstant::ZERO);
        img.set_quality(img.id("b").unwrap(), Quality::Good);
        feed.offer(&img, std::iter::empty(), 2, ScanInstant::ZERO);
        let d: Vec<Delivery> = s.receiver().try_iter().collect();
        assert_eq!(d[1].cycle.changes[0].quality, Quality::Good);
        assert_eq!(d[1].cycle.changes[0].tag, 1);
    }

    fn q(qs: &[Quality]) -> impl ExactSizeIterator<Item = Quality> + '_ {
        qs.iter().copied()
    }

    #[test]
    fn a_module_quality_change_is_delivered_and_caught_up_after_a_loss() {
        let img = image();
        let mut feed = ChangeFeed::new();
        let s = feed.subscribe("alarms", 1);
        feed.offer(
            &img,
            q(&[Quality::Good, Quality::Good]),
            1,
            ScanInstant::ZERO,
        );
        // Full: cycle 2 (mm2 lost) is lost.
        feed.offer(
            &img,
            q(&[Quality::Good, Quality::Bad]),
            2,
            ScanInstant::ZERO,
        );
        let d = s.receiver().try_recv().unwrap();
        assert_eq!(d.cycle.modules, [(0, Quality::Good), (1, Quality::Good)]);
        // A cycle that changes nothing still carries every module's quality now.
        feed.offer(
            &img,
            q(&[Quality::Good, Quality::Bad]),
            3,
            ScanInstant::ZERO,
        );
        let d = s.receiver().try_recv().unwrap();
        assert!(d.cycle.modules.is_empty());
        assert_eq!(d.modules_catch_up, [(0, Quality::Good), (1, Quality::Bad)]);
        feed.offer(
            &img,
            q(&[Quality::Good, Quality::Good]),
            4,
            ScanInstant::ZERO,
        );
        let d = s.receiver().try_recv().unwrap();
        assert_eq!(d.cycle.modules, [(1, Quality::Good)]);
        assert!(d.modules_catch_up.is_empty());
    }
}
