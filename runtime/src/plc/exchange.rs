//! The tags tasks share: one exchange holding the latest published slot of every tag.
//!
//! The rule an engineer relies on: each task has its own process image; at its cycle's start
//! (after its inputs are read) it copies every tag another task owns from the exchange, and at
//! its cycle's end (after its outputs are handed to its lines) it publishes every tag it owns.
//! So within one cycle a task sees a consistent picture that no other task changes, and a
//! value published by one task is seen by another at that one's next cycle start, never in
//! the middle of a cycle. Each copy and each publication is one short lock over slots
//! allocated once.
//!
//! On the real clock a publication is visible at once. On virtual clocks the tasks' cycles
//! run one after the other on one thread in the order of their starts (`scan::tasks`), so a
//! cycle that started before another task's but ends after its start must not be seen by
//! it: a publication is held, stamped with its cycle's end, until a copy at or after that
//! time takes it in, which keeps a run of several tasks deterministic and true to what the
//! threads would do.

use std::sync::{Arc, Mutex, MutexGuard};

use softplc_io::time::ScanInstant;

use crate::image::{ProcessImage, Slot, TagId};

/// The shared slots (one per tag of the project) and the publications not yet visible.
#[derive(Debug)]
pub struct Exchange {
    shared: Mutex<Shared>,
    /// Publications wait for their cycle's end to be visible (virtual clocks).
    deferred: bool,
}

#[derive(Debug)]
struct Shared {
    slots: Vec<Slot>,
    /// Held publications, not yet visible.
    held: Vec<Held>,
    published: u64,
}

impl Exchange {
    /// An exchange starting from `image`'s slots; `deferred` on virtual clocks (see the
    /// module's docs).
    pub fn new(image: &ProcessImage, deferred: bool) -> Arc<Self> {
        Arc::new(Self {
            shared: Mutex::new(Shared {
                slots: image.slots().to_vec(),
                held: Vec::new(),
                published: 0,
            }),
            deferred,
        })
    }

    fn lock(&self) -> MutexGuard<'_, Shared> {
        // A task thread that panicked while holding the lock left whole slots behind (every
        // write is one slot's copy): the others go on with them.
        self.shared
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Copies `tags` (those the calling task does not own) into `image`, as published by
    /// `now` (the copying cycle's start).
    pub(crate) fn copy_in(&self, tags: &[TagId], image: &mut ProcessImage, now: ScanInstant) {
        let mut shared = self.lock();
        if self.deferred && !shared.held.is_empty() {
            shared.release_until(now);
        }
        for &tag in tags {
            if let Some(&slot) = shared.slots.get(tag.index()) {
                image.restore(tag, slot);
            }
        }
    }

    /// Publishes `tags` (those the calling task owns) from `image`, at the end `now` of the
    /// publishing cycle.
    pub(crate) fn publish(&self, tags: &[TagId], image: &ProcessImage, now: ScanInstant) {
        let mut shared = self.lock();
        if self.deferred {
            let slots = tags.iter().map(|&t| (t, *image.slot(t))).collect();
            let order = shared.published;
            shared.published += 1;
            shared.held.push((now, order, slots));
            return;
        }
        for &tag in tags {
            if let Some(slot) = shared.slots.get_mut(tag.index()) {
                *slot = *image.slot(tag);
            }
        }
    }

    /// The latest visible slot of `tag` (what the next copy at `now` would take).
    pub fn slot(&self, tag: TagId, now: ScanInstant) -> Option<Slot> {
        let mut shared = self.lock();
        if self.deferred {
            shared.release_until(now);
        }
        shared.slots.get(tag.index()).copied()
    }
}

impl Shared {
    /// Makes every held publication of a cycle ended by `now` visible, in the order the
    /// cycles ended.
    fn release_until(&mut self, now: ScanInstant) {
        let mut due: Vec<Held> = Vec::new();
        let mut k = 0;
        while k < self.held.len() {
            if self.held[k].0 <= now {
                due.push(self.held.swap_remove(k));
            } else {
                k += 1;
            }
        }
        due.sort_by_key(|(end, order, _)| (*end, *order));
        for (_, _, slots) in due {
            for (tag, slot) in slots {
                if let Some(s) = self.slots.get_mut(tag.index()) {
                    *s = slot;
                }
            }
        }
    }
}

impl super::Plc {
    /// The tags other tasks own, as their owners last published them by now (nothing for a
    /// PLC of one task): fresher than this task's copies, taken at its cycle's start.
    pub(crate) fn published_by_others(&self) -> Vec<(TagId, Slot)> {
        let Some(link) = &self.task else {
            return Vec::new();
        };
        let now = self.clock.now();
        link.foreign
            .iter()
            .filter_map(|&t| Some((t, link.exchange.slot(t, now)?)))
            .collect()
    }
}

/// A publication held until its cycle's end: (that end, order of publication, the slots).
type Held = (ScanInstant, u64, Vec<(TagId, Slot)>);

/// A task's part in the exchange: the tags it copies in and those it publishes.
#[derive(Debug, Clone)]
pub struct TaskLink {
    /// The exchange all tasks share.
    pub exchange: Arc<Exchange>,
    /// The tags this task owns, published at its cycle's end.
    pub owned: Vec<TagId>,
    /// The tags other tasks own, copied in at its cycle's start.
    pub foreign: Vec<TagId>,
    /// What the task's reloads check (who owns each tag, the program running).
    pub(crate) reload: super::task_reload::TaskReload,
}

#[cfg(test)]
mod tests {
    use super::*;
    use softplc_io::point::{Quality, Value};
    use std::time::Duration;

    fn image() -> ProcessImage {
        ProcessImage::new([
            ("a".to_string(), Value::U16(0)),
            ("b".to_string(), Value::U16(0)),
        ])
    }

    fn at(ms: u64) -> ScanInstant {
        ScanInstant::ZERO + Duration::from_millis(ms)
    }

    #[test]
    fn a_held_publication_is_seen_from_its_cycles_end_on() {
        let ex = Exchange::new(&image(), true);
        let mut writer = image();
        writer.set(TagId(0), Value::U16(7), at(5));
        ex.publish(&[TagId(0)], &writer, at(10));
        let mut reader = image();
        ex.copy_in(&[TagId(0)], &mut reader, at(9));
        assert_eq!(reader.get(TagId(0)), Value::U16(0), "not before its end");
        ex.copy_in(&[TagId(0)], &mut reader, at(10));
        assert_eq!(reader.get(TagId(0)), Value::U16(7));
        assert_eq!(reader.slot(TagId(0)).quality, Quality::Good);
    }

    #[test]
    fn on_the_real_clock_a_publication_is_seen_at_once_and_only_the_owned_tags() {
        let ex = Exchange::new(&image(), false);
        let mut writer = image();
        writer.set(TagId(0), Value::U16(3), at(1));
        writer.set(TagId(1), Value::U16(4), at(1));
        ex.publish(&[TagId(0)], &writer, at(2));
        let mut reader = image();
        ex.copy_in(&[TagId(0), TagId(1)], &mut reader, at(0));
        assert_eq!(reader.get(TagId(0)), Value::U16(3));
        assert_eq!(reader.get(TagId(1)), Value::U16(0));
    }

    #[test]
    fn the_status_shows_another_tasks_tag_as_its_owner_last_published_it() {
        let project = crate::project::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../examples/two-tasks/project.yaml"),
        )
        .expect("the example loads");
        let builder = crate::plc::TaskBuilder::new(&project, None, None).expect("it compiles");
        let (press, mut panel) = (
            builder.build(0).expect("the press"),
            builder.build(1).expect("the panel"),
        );
        // The panel task (which owns `enabled`) publishes it; the press has not copied it in.
        let enabled = panel.plc.image.id("enabled").expect("a tag");
        panel
            .plc
            .image
            .set(enabled, Value::Bool(true), ScanInstant::ZERO);
        let link = panel.plc.task.as_ref().expect("a task's link");
        link.exchange
            .publish(&link.owned, &panel.plc.image, ScanInstant::ZERO);
        assert_eq!(press.plc.image.get(enabled), Value::Bool(false));
        let status =
            crate::service::StatusReport::of(&press.plc, &crate::scan::ScanStats::default());
        let tag = &status.tags[enabled.index()];
        assert_eq!((tag.value.as_str(), tag.quality.as_str()), ("1", "good"));
        // A tag the press owns is its own.
        let strokes = press.plc.image.id("strokes").expect("a tag");
        assert!(press
            .plc
            .published_by_others()
            .iter()
            .all(|(t, _)| *t != strokes));
    }
}
