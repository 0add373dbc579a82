//! Connection slots with fairness, for the servers that give each client a thread (the web
//! page, the metrics endpoint, the control socket): a cap on connections, a smaller cap on
//! long-lived streams, and eviction of the client that has waited longest without sending
//! its request when a new one finds every slot taken.
//!
//! Why eviction rather than a plain refusal: with a plain cap, a few clients that connect and
//! say nothing (or send a byte a second) hold every slot until their deadline, and a
//! scrape or the page is refused for as long as they keep coming back. A client still
//! waiting to send its request after [`MIN_WAIT`] is the one that gives way: a real client's
//! request arrives within milliseconds of its connection. Streams (the page's events) are
//! long-lived by design, so they may take at most [`Caps::streams`] of the slots, leaving the
//! rest to requests; a stream that does not read is dropped by its write deadline.

use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

/// How long a client may wait without sending its request before a newcomer may take its
/// slot when every slot is taken.
pub(crate) const MIN_WAIT: Duration = Duration::from_millis(100);

/// How often at most the accepting thread waits [`MIN_WAIT`] for a slot.
pub(crate) const PATIENCE_EVERY: Duration = Duration::from_secs(1);

/// The caps of one server.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Caps {
    /// Connections at once.
    pub clients: usize,
    /// Of those, streams at once.
    pub streams: usize,
}

/// Where a client is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    /// Connected, its request not complete yet: may be evicted.
    Waiting,
    /// Its request being answered.
    Busy,
    /// Served a stream.
    Streaming,
    /// Told to go (its connection shut); its slot frees when its thread ends.
    Evicted,
}

/// Shuts a client's connection, so its thread's next read or write fails and it ends.
pub(crate) type Evict = Box<dyn Fn() + Send>;

struct Entry {
    id: u64,
    since: Instant,
    phase: Phase,
    evict: Evict,
}

#[derive(Default)]
struct Table {
    next: u64,
    entries: Vec<Entry>,
    evicted: u64,
    /// When the accepting thread last waited for a client to become evictable.
    waited: Option<Instant>,
}

/// The slots of one server; cloned handles share them.
#[derive(Clone)]
pub(crate) struct Slots {
    caps: Caps,
    table: Arc<Mutex<Table>>,
}

impl std::fmt::Debug for Slots {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Slots").field("caps", &self.caps).finish()
    }
}

/// A client's slot; given back when dropped.
pub(crate) struct Held {
    slots: Slots,
    id: u64,
}

impl std::fmt::Debug for Held {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Held").field("id", &self.id).finish()
    }
}

impl Slots {
    /// Empty slots with `caps`.
    pub(crate) fn new(caps: Caps) -> Self {
        Self {
            caps,
            table: Arc::new(Mutex::new(Table::default())),
        }
    }

    fn table(&self) -> std::sync::MutexGuard<'_, Table> {
        self.table.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// A slot for a new client at `now`, `evict` shutting its connection: a free one, or the
    /// one of the client waiting longest for its request (longer than [`MIN_WAIT`]), which is
    /// evicted. `None`: every slot is held by a client being served.
    pub(crate) fn admit(&self, now: Instant, evict: Evict) -> Option<Held> {
        let mut t = self.table();
        let live = t
            .entries
            .iter()
            .filter(|e| e.phase != Phase::Evicted)
            .count();
        // Evicted clients still hold their thread until it ends; they count against a second
        // cap's worth, so threads stay bounded (twice the cap at most).
        if live >= self.caps.clients || t.entries.len() >= 2 * self.caps.clients {
            let oldest = t
                .entries
                .iter_mut()
                .filter(|e| e.phase == Phase::Waiting && now.duration_since(e.since) >= MIN_WAIT)
                .min_by_key(|e| e.since)?;
            oldest.phase = Phase::Evicted;
            (oldest.evict)();
            t.evicted += 1;
        }
        let id = t.next;
        t.next += 1;
        t.entries.push(Entry {
            id,
            since: now,
            phase: Phase::Waiting,
            evict,
        });
        Some(Held {
            slots: self.clone(),
            id,
        })
    }

    /// [`Slots::admit`], and when every slot is taken by clients too young to give way, once
    /// more after [`MIN_WAIT`] (a burst of new silent clients is not yet evictable; a real
    /// client waits that long rather than be refused). The accepting thread waits so at most
    /// once per [`PATIENCE_EVERY`], so a burst of thousands of connections still drains at
    /// once. `evict` makes the evict function.
    pub(crate) fn admit_patiently(&self, evict: impl Fn() -> Evict) -> Option<Held> {
        if let Some(held) = self.admit(Instant::now(), evict()) {
            return Some(held);
        }
        let now = Instant::now();
        {
            let mut t = self.table();
            if t.waited
                .is_some_and(|at| now.duration_since(at) < PATIENCE_EVERY)
            {
                return None;
            }
            t.waited = Some(now);
        }
        std::thread::sleep(MIN_WAIT);
        self.admit(Instant::now(), evict())
    }

    /// Clients evicted so far.
    #[cfg(test)]
    pub(crate) fn evicted(&self) -> u64 {
        self.table().evicted
    }
}

impl Held {
    fn with<T>(&self, f: impl FnOnce(&mut Entry, &[Entry]) -> T) -> Option<T> {
        let mut t = self.slots.table();
        let i = t.entries.iter().position(|e| e.id == self.id)?;
        let mut entry = t.entries.remove(i);
        let out = f(&mut entry, &t.entries);
        t.entries.insert(i, entry);
        Some(out)
    }

    /// Its request is complete: it is being answered (no longer evictable).
    pub(crate) fn busy(&self) {
        self.with(|e, _| {
            if e.phase != Phase::Evicted {
                e.phase = Phase::Busy;
            }
        });
    }

    /// Waiting for its next request from `now` (a control-socket client between requests).
    pub(crate) fn waiting(&self, now: Instant) {
        self.with(|e, _| {
            if e.phase != Phase::Evicted {
                e.phase = Phase::Waiting;
                e.since = now;
            }
        });
    }

    /// Becomes a stream, if fewer than the streams' cap are; false: refuse it.
    pub(crate) fn stream(&self) -> bool {
        let cap = self.slots.caps.streams;
        self.with(|e, others| {
            let streams = others
                .iter()
                .filter(|o| o.phase == Phase::Streaming)
                .count();
            if streams >= cap || e.phase == Phase::Evicted {
                return false;
            }
            e.phase = Phase::Streaming;
            true
        })
        .unwrap_or(false)
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        let mut t = self.slots.table();
        t.entries.retain(|e| e.id != self.id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn counting(evicted: &Arc<AtomicUsize>) -> Evict {
        let e = evicted.clone();
        Box::new(move || {
            e.fetch_add(1, Ordering::SeqCst);
        })
    }

    #[test]
    fn a_newcomer_evicts_the_longest_silent_client_never_one_being_served() {
        let slots = Slots::new(Caps {
            clients: 3,
            streams: 1,
        });
        let evicted = Arc::new(AtomicUsize::new(0));
        let t0 = Instant::now();
        let a = slots.admit(t0, counting(&evicted)).unwrap();
        let b = slots
            .admit(t0 + Duration::from_millis(10), counting(&evicted))
            .unwrap();
        let c = slots
            .admit(t0 + Duration::from_millis(20), counting(&evicted))
            .unwrap();
        b.busy();
        // Full, and the silent ones have not waited MIN_WAIT yet: refused.
        assert!(slots
            .admit(t0 + Duration::from_millis(50), counting(&evicted))
            .is_none());
        // Later, the oldest silent one (a) gives way; b, being answered, never does.
        let d = slots
            .admit(t0 + Duration::from_millis(200), counting(&evicted))
            .unwrap();
        assert_eq!(evicted.load(Ordering::SeqCst), 1);
        let e = slots
            .admit(t0 + Duration::from_millis(300), counting(&evicted))
            .unwrap();
        assert_eq!(evicted.load(Ordering::SeqCst), 2, "then c");
        // Evicted clients' threads still run: at most twice the cap in all.
        assert!(slots
            .admit(t0 + Duration::from_millis(400), counting(&evicted))
            .is_some());
        assert_eq!(slots.evicted(), 3, "then d");
        drop((a, b, c, d, e));
        assert!(slots.table().entries.is_empty());
    }

    #[test]
    fn streams_take_at_most_their_cap() {
        let slots = Slots::new(Caps {
            clients: 4,
            streams: 2,
        });
        let t0 = Instant::now();
        let held: Vec<Held> = (0..4)
            .map(|_| slots.admit(t0, Box::new(|| {})).unwrap())
            .collect();
        assert!(held[0].stream());
        assert!(held[1].stream());
        assert!(!held[2].stream(), "a third stream is refused");
        drop(held);
        let again = slots.admit(t0, Box::new(|| {})).unwrap();
        assert!(again.stream(), "streams that ended give their place back");
    }
}
