//! The files the scan keeps up to date (retained values, kept forces) are written on a thread of
//! their own: the scan hands over the latest content and goes on. A write takes a create, an
//! fsync and a rename, milliseconds on an SD card and seconds on a failing one, which the scan's
//! period does not have (DESIGN: no file I/O on the scan thread).
//!
//! Only the latest content matters, so the hand-over holds one item: when the thread is still
//! busy with the previous one, the newest waits on the scan's side and goes at a later boundary
//! ([`SaveThread::flush`]). A thread that died (a panic while writing) is started again; one that
//! cannot be started leaves the content waiting and says why, and the file is written at stop.

use std::sync::Arc;
use std::thread::JoinHandle;

use crossbeam_channel::{Sender, TrySendError};

/// Writes one item; whether it was written (the function reports its own failures).
pub(crate) type Save<T> = Arc<dyn Fn(&T) -> bool + Send + Sync>;

/// A thread that writes the latest of what it is handed.
pub(crate) struct SaveThread<T: Send + 'static> {
    /// The thread's name (`retain`, `forces`): also what a failure to start it names.
    name: &'static str,
    save: Save<T>,
    /// What waits for the thread (it was busy, or could not be started).
    pending: Option<T>,
    writer: Option<(Sender<T>, JoinHandle<()>)>,
    /// Why the thread cannot be started, while it cannot.
    not_started: Option<String>,
}

impl<T: Send + 'static> std::fmt::Debug for SaveThread<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SaveThread")
            .field("name", &self.name)
            .field("pending", &self.pending.is_some())
            .field("running", &self.writer.is_some())
            .field("not_started", &self.not_started)
            .finish()
    }
}

/// What became of an item handed to [`SaveThread::offer`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Handed {
    /// The thread has it.
    Taken,
    /// It waits on the scan's side for a later [`SaveThread::flush`].
    Waiting,
}

impl<T: Send + 'static> SaveThread<T> {
    /// A thread named `name` that writes each item with `save`.
    pub(crate) fn new(name: &'static str, save: Save<T>) -> Self {
        let mut thread = Self {
            name,
            save,
            pending: None,
            writer: None,
            not_started: None,
        };
        thread.start();
        thread
    }

    /// Hands `item` over in place of anything still waiting. Never waits.
    pub(crate) fn offer(&mut self, item: T) -> Handed {
        self.pending = Some(item);
        self.flush()
    }

    /// Hands over what waits, if the thread can take it now. Never waits.
    pub(crate) fn flush(&mut self) -> Handed {
        let Some(item) = self.pending.take() else {
            return Handed::Taken;
        };
        if self.writer.is_none() && !self.start() {
            self.pending = Some(item);
            return Handed::Waiting;
        }
        let Some((tx, _)) = self.writer.as_ref() else {
            self.pending = Some(item);
            return Handed::Waiting;
        };
        match tx.try_send(item) {
            Ok(()) => Handed::Taken,
            Err(TrySendError::Full(item)) => {
                self.pending = Some(item);
                Handed::Waiting
            }
            Err(TrySendError::Disconnected(item)) => {
                tracing::error!(
                    "{}: the writer thread stopped; starting it again",
                    self.name
                );
                self.writer = None;
                self.pending = Some(item);
                Handed::Waiting
            }
        }
    }

    /// Why the thread cannot be started, while it cannot.
    pub(crate) fn not_started(&self) -> Option<&str> {
        self.not_started.as_deref()
    }

    /// Lets the thread write what it has and end, then writes what still waits from here: for
    /// the end of a run, when the scan has stopped.
    pub(crate) fn finish(&mut self) {
        self.stop_thread();
        if let Some(item) = self.pending.take() {
            (self.save)(&item);
        }
    }

    /// Writes `item` from here once the thread has written what it has: for the end of a run.
    pub(crate) fn finish_with(&mut self, item: &T) {
        self.stop_thread();
        self.pending = None;
        (self.save)(item);
    }

    fn stop_thread(&mut self) {
        if let Some((tx, handle)) = self.writer.take() {
            drop(tx);
            // A writer that panicked has reported it already (panic hook); what it was
            // writing is written again by the caller.
            drop(handle.join());
        }
    }

    /// Starts the thread; whether it runs.
    fn start(&mut self) -> bool {
        let (tx, rx) = crossbeam_channel::bounded::<T>(1);
        let save = self.save.clone();
        let spawned = std::thread::Builder::new()
            .name(self.name.into())
            .spawn(move || {
                for item in rx {
                    save(&item);
                }
            });
        match spawned {
            Ok(handle) => {
                if self.not_started.take().is_some() {
                    tracing::warn!("{}: the writer thread runs again", self.name);
                }
                self.writer = Some((tx, handle));
                true
            }
            Err(e) => {
                if self.not_started.is_none() {
                    tracing::error!(
                        "{}: cannot start the writer thread ({e}); the file is written at stop",
                        self.name
                    );
                }
                self.not_started = Some(format!("cannot start its writer thread: {e}"));
                false
            }
        }
    }
}

impl<T: Send + 'static> Drop for SaveThread<T> {
    fn drop(&mut self) {
        self.stop_thread();
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::{Condvar, Mutex};

    use super::*;

    /// A save that blocks until the test opens the gate, and counts what it wrote.
    struct Gate {
        open: Mutex<bool>,
        opened: Condvar,
        written: Mutex<Vec<u32>>,
    }

    fn gated() -> (Arc<Gate>, Save<u32>) {
        let gate = Arc::new(Gate {
            open: Mutex::new(false),
            opened: Condvar::new(),
            written: Mutex::new(Vec::new()),
        });
        let g = gate.clone();
        let save: Save<u32> = Arc::new(move |v: &u32| {
            let mut open = g.open.lock().unwrap();
            while !*open {
                open = g.opened.wait(open).unwrap();
            }
            g.written.lock().unwrap().push(*v);
            true
        });
        (gate, save)
    }

    #[test]
    fn a_busy_writer_never_holds_the_scan_and_the_latest_content_wins() {
        let (gate, save) = gated();
        let mut t = SaveThread::new("test", save);
        // The thread takes the first and blocks in it; the channel holds the second; the
        // third and fourth wait on the scan's side, the fourth in place of the third.
        assert_eq!(t.offer(1), Handed::Taken);
        // The first is in the thread once the channel has room again.
        let mut second = t.offer(2);
        for _ in 0..1000 {
            if second == Handed::Taken {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
            second = t.flush();
        }
        assert_eq!(second, Handed::Taken);
        assert_eq!(t.offer(3), Handed::Waiting);
        assert_eq!(t.offer(4), Handed::Waiting);
        *gate.open.lock().unwrap() = true;
        gate.opened.notify_all();
        t.finish();
        assert_eq!(*gate.written.lock().unwrap(), [1, 2, 4]);
    }

    #[test]
    fn a_writer_that_died_is_started_again() {
        let calls = Arc::new(AtomicUsize::new(0));
        let seen = Arc::new(Mutex::new(Vec::new()));
        let (c, s) = (calls.clone(), seen.clone());
        let save: Save<u32> = Arc::new(move |v: &u32| {
            assert!(
                c.fetch_add(1, Ordering::SeqCst) > 0,
                "the first write panics"
            );
            s.lock().unwrap().push(*v);
            true
        });
        let mut t = SaveThread::new("test", save);
        t.offer(1);
        // The first thread dies on its first item; offers go on until a new one writes.
        for v in 2..2000 {
            if !seen.lock().unwrap().is_empty() {
                break;
            }
            t.offer(v);
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        t.finish();
        assert!(
            !seen.lock().unwrap().is_empty(),
            "nothing written after the restart"
        );
    }
}
