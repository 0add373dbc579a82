//! The scan's side of the recorder: what a cycle saw and did, handed to the writer thread
//! without ever waiting for it.
//!
//! The tap keeps a copy of the image as it last reported it and sends only the differences.
//! The channel is bounded and sent to with `try_send`: when the writer falls behind (a slow
//! disk), the record is dropped and counted, its control requests are carried into the next
//! record, and the next record lists every tag (a gap the reader and replay report), so the
//! record stays right after a gap instead of drifting.

use crossbeam_channel::{Sender, TrySendError};
use softplc_io::point::{Quality, Value};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use crate::image::ProcessImage;
use crate::recorder::format::{Change, CycleRecord, Event};
use softplc_io::time::ScanInstant;

/// Records handed to the writer, and the ones it could not take.
#[derive(Debug, Default)]
pub(crate) struct TapCounters {
    /// Records handed over.
    pub sent: AtomicU64,
    /// Records dropped because the writer's channel was full (or the writer had stopped).
    pub dropped: AtomicU64,
}

/// Called by the PLC at the start of the logic, after the output phase and for every control
/// request applied between cycles (see [`crate::plc::Plc::record`]).
#[derive(Debug)]
pub struct Tap {
    tx: Sender<CycleRecord>,
    /// The image as last reported (value, quality per tag).
    mirror: Vec<(Value, Quality)>,
    /// Control requests since the last record.
    events: Vec<Event>,
    /// The cycle being recorded, between its start and its output phase.
    current: Option<CycleRecord>,
    /// Records dropped since the last one sent.
    dropped: u64,
    /// The next record lists every tag (after a gap).
    resync: bool,
    counters: Arc<TapCounters>,
}

impl Tap {
    /// A tap sending to `tx`, starting from the image as the keyframe holds it.
    pub(crate) fn new(
        tx: Sender<CycleRecord>,
        image: &ProcessImage,
        counters: Arc<TapCounters>,
    ) -> Self {
        Self {
            tx,
            mirror: snapshot(image),
            events: Vec::new(),
            current: None,
            dropped: 0,
            resync: false,
            counters,
        }
    }

    /// A control request was applied at the boundary: it goes with the next cycle's record.
    pub fn event(&mut self, event: Event) {
        self.events.push(event);
    }

    /// The logic is about to run on `image` at cycle `cycle`, time `now`.
    pub fn seen(&mut self, image: &ProcessImage, cycle: u64, now: ScanInstant) {
        let seen = if std::mem::take(&mut self.resync) {
            self.mirror = snapshot(image);
            all(&self.mirror)
        } else {
            diff(&mut self.mirror, image)
        };
        self.current = Some(CycleRecord {
            cycle,
            now,
            dropped_before: 0,
            faulted: false,
            events: std::mem::take(&mut self.events),
            seen,
            wrote: Vec::new(),
        });
    }

    /// The output phase has ended: the record is complete and handed to the writer.
    pub fn wrote(&mut self, image: &ProcessImage) {
        let Some(mut record) = self.current.take() else {
            return;
        };
        record.wrote = diff(&mut self.mirror, image);
        self.send(record);
    }

    /// The run stops in a cycle that never reached its output phase (its program faulted):
    /// the cycle is recorded as it started, marked, since it is the one an operator asks about.
    pub fn unfinished(&mut self) {
        if let Some(mut record) = self.current.take() {
            record.faulted = true;
            self.send(record);
        }
    }

    fn send(&mut self, mut record: CycleRecord) {
        record.dropped_before = self.dropped;
        match self.tx.try_send(record) {
            Ok(()) => {
                self.dropped = 0;
                self.counters.sent.fetch_add(1, Ordering::Relaxed);
            }
            Err(TrySendError::Full(lost) | TrySendError::Disconnected(lost)) => {
                // The requests must still reach the record: they change what replay does.
                let mut events = lost.events;
                events.append(&mut self.events);
                self.events = events;
                self.dropped += 1;
                self.resync = true;
                self.counters.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

fn snapshot(image: &ProcessImage) -> Vec<(Value, Quality)> {
    image.slots().iter().map(|s| (s.value, s.quality)).collect()
}

fn all(state: &[(Value, Quality)]) -> Vec<Change> {
    state
        .iter()
        .enumerate()
        .map(|(i, &(value, quality))| Change {
            tag: i as u32,
            value,
            quality,
        })
        .collect()
}

/// The tags of `image` that differ from `mirror`, which is brought up to date.
fn diff(mirror: &mut [(Value, Quality)], image: &ProcessImage) -> Vec<Change> {
    let mut out = Vec::new();
    for (i, (m, s)) in mirror.iter_mut().zip(image.slots()).enumerate() {
        if !same(m.0, s.value) || m.1 != s.quality {
            *m = (s.value, s.quality);
            out.push(Change {
                tag: i as u32,
                value: s.value,
                quality: s.quality,
            });
        }
    }
    out
}

/// Equality of values as the record sees it: floats by their bits, so a NaN is a NaN.
pub(crate) fn same(a: Value, b: Value) -> bool {
    match (a, b) {
        (Value::F32(x), Value::F32(y)) => x.to_bits() == y.to_bits(),
        _ => a == b,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn image() -> ProcessImage {
        ProcessImage::new([
            ("a".to_string(), Value::Bool(false)),
            ("b".to_string(), Value::U16(0)),
        ])
    }

    #[test]
    fn only_changes_are_sent() {
        let (tx, rx) = crossbeam_channel::bounded(4);
        let mut img = image();
        let mut tap = Tap::new(tx, &img, Arc::default());
        img.set(crate::image::TagId(0), Value::Bool(true), ScanInstant::ZERO);
        tap.seen(&img, 0, ScanInstant::ZERO);
        img.set(crate::image::TagId(1), Value::U16(5), ScanInstant::ZERO);
        tap.wrote(&img);
        let r = rx.try_recv().unwrap();
        assert_eq!(
            r.seen,
            [Change {
                tag: 0,
                value: Value::Bool(true),
                quality: Quality::Good
            }]
        );
        assert_eq!(r.wrote.len(), 1);
        assert_eq!(r.wrote[0].tag, 1);
        tap.seen(
            &img,
            1,
            ScanInstant::after_origin(Duration::from_millis(10)),
        );
        tap.wrote(&img);
        let r = rx.try_recv().unwrap();
        assert!(r.seen.is_empty() && r.wrote.is_empty(), "{r:?}");
    }

    #[test]
    fn a_full_channel_drops_counts_and_resyncs_without_losing_requests() {
        let (tx, rx) = crossbeam_channel::bounded(1);
        let img = image();
        let counters = Arc::new(TapCounters::default());
        let mut tap = Tap::new(tx, &img, counters.clone());
        for cycle in 0..3 {
            if cycle == 1 {
                tap.event(Event::UnforceAll);
            }
            tap.seen(&img, cycle, ScanInstant::ZERO);
            tap.wrote(&img);
        }
        assert_eq!(counters.sent.load(Ordering::Relaxed), 1);
        assert_eq!(counters.dropped.load(Ordering::Relaxed), 2);
        assert_eq!(rx.try_recv().unwrap().cycle, 0);
        tap.seen(&img, 3, ScanInstant::ZERO);
        tap.wrote(&img);
        let r = rx.try_recv().unwrap();
        assert_eq!(r.cycle, 3);
        assert_eq!(r.dropped_before, 2);
        assert_eq!(r.events, [Event::UnforceAll]);
        assert_eq!(r.seen.len(), 2, "every tag after a gap");
    }
}
