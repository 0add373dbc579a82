//! Alarms: a tag's `alarm:` (a text, a priority, when it is active) and every module's
//! `lost.MODULE`, raised, cleared and acknowledged with UTC and the cycle, a current list and a
//! bounded history kept in `PROJECT.alarms.jsonl` across restarts.
//!
//! Evaluation sees every change: a thread of its own takes each cycle's changes from the
//! change feed (`super::changes`, the queue OPC UA and Sparkplug read), so an alarm that
//! lives one cycle is raised and cleared in the history, and the scan does no more than offer
//! the changes. Acknowledgements (the control socket's `alarms ack`, the page's buttons) come
//! through the scan's request queue like every other action, so they carry the cycle they
//! were taken at; the boundary hands them to this thread without waiting, which answers,
//! notes them in the audit file and rewrites the history.
//!
//! While a module is lost (its quality bad) its tags' alarms are held as they were and its
//! `lost.` alarm stands for them: a dead line shows one alarm per module, not one per
//! signal. When it is back, its tags' alarms are evaluated again from their values.

pub(crate) mod book;
pub(crate) mod history;

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, SystemTime};

use crossbeam_channel::{Receiver, Sender};
use serde::{Deserialize, Serialize};
use softplc_io::time::ScanInstant;

pub use book::{AckError, AlarmCounts, AlarmEvent, AlarmView, EventKind, Stamp};
pub use history::{history_path, read as read_history, HistoryError};

use self::book::AlarmBook;
use super::audit::{Action, AuditLog, Entry, Origin};
use super::changes::ChangeStream;
use super::control::Response;
use super::health::ServiceState;
use crate::project::Project;

/// Acknowledgements and lists waiting for the thread; past it they are refused as busy.
const JOBS: usize = 64;

/// A request about the alarms.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "action", rename_all = "lowercase", deny_unknown_fields)]
pub enum AlarmRequest {
    /// The current list, the counts, and the latest `history` events.
    List {
        /// How many of the latest events (default none).
        #[serde(default)]
        history: Option<usize>,
    },
    /// Acknowledge an alarm, or `all` of those waiting.
    Ack {
        /// The alarm's name (the tag's, or `lost.MODULE`), or `all`.
        alarm: String,
    },
}

/// What `alarms` answers.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct AlarmList {
    /// Active or unacknowledged alarms, those waiting first, then by priority.
    pub current: Vec<AlarmView>,
    /// The latest events, the newest first.
    #[serde(default)]
    pub history: Vec<AlarmEvent>,
    /// The figures.
    pub counts: AlarmCounts,
}

/// A request on its way to the alarm thread, with the way back.
#[derive(Debug)]
pub(crate) struct Job {
    pub(crate) request: AlarmRequest,
    pub(crate) reply: Sender<Response>,
    pub(crate) origin: Origin,
    /// The cycle boundary it was taken at, and the scan's time then.
    pub(crate) cycle: u64,
    pub(crate) at: ScanInstant,
}

/// The figures the scan reads for `status` without a lock.
#[derive(Debug, Default)]
struct Figures {
    active: [AtomicU64; 4],
    unacknowledged: AtomicU64,
    /// Rewrites of the history file that failed.
    failed: AtomicU64,
}

/// The readers' side: the page, the status, OPC UA and Sparkplug.
#[derive(Debug, Clone)]
pub struct Alarms {
    book: Arc<Mutex<AlarmBook>>,
    figures: Arc<Figures>,
    failing: Arc<Mutex<Option<String>>>,
    lost: Arc<super::changes::FeedCounts>,
}

impl Alarms {
    fn with_book<R>(&self, f: impl FnOnce(&AlarmBook) -> R) -> R {
        f(&self.book.lock().unwrap_or_else(PoisonError::into_inner))
    }

    /// The current list and the latest `history` events.
    pub fn list(&self, history: usize) -> AlarmList {
        self.with_book(|b| AlarmList {
            current: b.current(),
            history: b.history(history),
            counts: b.counts(),
        })
    }

    /// Every alarm in the project's order, and the book's generation (it changes with any
    /// alarm).
    pub fn all(&self) -> (Vec<AlarmView>, u64) {
        self.with_book(|b| (b.all(), b.generation()))
    }

    /// The book's generation: a publisher compares it to know whether to look again.
    pub fn generation(&self) -> u64 {
        self.with_book(AlarmBook::generation)
    }

    /// The figures, from atomics (the scan reads them for `status`).
    pub fn counts(&self) -> AlarmCounts {
        let f = &self.figures;
        AlarmCounts {
            active: std::array::from_fn(|i| f.active[i].load(Ordering::Relaxed)),
            unacknowledged: f.unacknowledged.load(Ordering::Relaxed),
        }
    }

    /// The service's state: degraded while the history cannot be written or when changes were
    /// lost (the thread was behind).
    pub fn state(&self) -> ServiceState {
        let failing = self
            .failing
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        let lost = self.lost.lost();
        match (failing, lost) {
            (Some(why), _) => ServiceState::Degraded(format!(
                "cannot write the alarm history ({why}); {} failed write(s), the alarms go on \
                 in memory",
                self.figures.failed.load(Ordering::Relaxed)
            )),
            (None, 0) => ServiceState::Running,
            (None, n) => ServiceState::Degraded(format!(
                "{n} changes lost (the alarm thread was behind); alarms were evaluated again \
                 from the values after"
            )),
        }
    }
}

/// The running alarm thread.
#[derive(Debug)]
pub struct AlarmService {
    alarms: Alarms,
    jobs: Sender<Job>,
    thread: std::thread::JoinHandle<()>,
}

impl AlarmService {
    /// Starts the alarms of `project`, evaluated from `stream`, with the history in `path`
    /// (read back first; a damaged file is set aside), UTC of the scan's origin
    /// `wall_origin`, acknowledgements noted in `audit`.
    pub(crate) fn start(
        project: &Project,
        stream: ChangeStream,
        path: PathBuf,
        wall_origin: SystemTime,
        audit: Option<AuditLog>,
    ) -> std::io::Result<Self> {
        let mut book = AlarmBook::new(project, wall_origin);
        book.restore(history::load(&path));
        let book = Arc::new(Mutex::new(book));
        let figures = Arc::new(Figures::default());
        let failing = Arc::new(Mutex::new(None));
        let alarms = Alarms {
            book: book.clone(),
            figures: figures.clone(),
            failing: failing.clone(),
            lost: stream.counts(),
        };
        let (jobs, rx) = crossbeam_channel::bounded(JOBS);
        let worker = Worker {
            alarms: alarms.clone(),
            path,
            audit,
            written: None,
        };
        let thread = std::thread::Builder::new()
            .name("alarms".into())
            .spawn(move || worker.run(&stream, &rx))?;
        Ok(Self {
            alarms,
            jobs,
            thread,
        })
    }

    /// The readers' handle.
    pub fn alarms(&self) -> &Alarms {
        &self.alarms
    }

    /// The boundary's way in.
    pub(crate) fn jobs(&self) -> Sender<Job> {
        self.jobs.clone()
    }

    /// Waits (at most `within`) for the thread to end after the scan did (its feed closed),
    /// so the last events reach the file.
    pub fn finish(self, within: Duration) {
        drop(self.jobs);
        let end = std::time::Instant::now() + within;
        while !self.thread.is_finished() && std::time::Instant::now() < end {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

struct Worker {
    alarms: Alarms,
    path: PathBuf,
    audit: Option<AuditLog>,
    /// The generation last written to the file.
    written: Option<u64>,
}

impl Worker {
    fn run(mut self, stream: &ChangeStream, jobs: &Receiver<Job>) {
        let feed = stream.receiver();
        let mut jobs_open = true;
        let closed = crossbeam_channel::never();
        loop {
            crossbeam_channel::select! {
                recv(feed) -> d => match d {
                    Ok(d) => {
                        self.lock().apply(&d);
                    }
                    // The scan has ended: the last state was offered.
                    Err(_) => break,
                },
                recv(if jobs_open { jobs } else { &closed }) -> j => match j {
                    Ok(job) => self.job(job),
                    Err(_) => jobs_open = false,
                },
            };
            // A burst is taken whole before the file is rewritten.
            for d in feed.try_iter() {
                self.lock().apply(&d);
            }
            self.settle();
        }
        for job in jobs.try_iter() {
            self.job(job);
        }
        self.settle();
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, AlarmBook> {
        self.alarms
            .book
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }

    fn job(&mut self, job: Job) {
        let response = match &job.request {
            AlarmRequest::List { history } => Response {
                ok: true,
                alarms: Some(self.alarms.list(history.unwrap_or(0))),
                ..Response::default()
            },
            AlarmRequest::Ack { alarm } => {
                let by = job.origin.to_string();
                let outcome = self.lock().acknowledge(alarm, &by, job.cycle, job.at);
                let response = match outcome {
                    Ok(names) if names.is_empty() => {
                        Response::done("no alarm was waiting for an acknowledgement")
                    }
                    Ok(names) => Response::done(format!(
                        "acknowledged: {} (at cycle {})",
                        names.join(", "),
                        job.cycle
                    )),
                    Err(e) => Response::refused(e.to_string()),
                };
                if let Some(log) = &self.audit {
                    let result = if response.ok {
                        &response.message
                    } else {
                        &response.error
                    };
                    log.note(Entry::now(
                        job.cycle,
                        &job.origin,
                        Action::Acknowledge,
                        alarm.clone(),
                        response.ok,
                        result.clone().unwrap_or_default(),
                    ));
                }
                response
            }
        };
        // A client that gave up meanwhile has nobody left to tell.
        drop(job.reply.send(response));
    }

    /// After a batch: the figures, and the file when an event was added.
    fn settle(&mut self) {
        let (counts, generation, events) = {
            let book = self.lock();
            let g = book.generation();
            let events = (self.written != Some(g)).then(|| book.events().cloned().collect());
            (book.counts(), g, events)
        };
        let f = &self.alarms.figures;
        for (slot, n) in f.active.iter().zip(counts.active) {
            slot.store(n, Ordering::Relaxed);
        }
        f.unacknowledged
            .store(counts.unacknowledged, Ordering::Relaxed);
        let Some(events) = events else { return };
        let events: Vec<AlarmEvent> = events;
        let outcome = history::write(&self.path, events.iter());
        let mut failing = self
            .alarms
            .failing
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        match outcome {
            Ok(()) => {
                *failing = None;
                self.written = Some(generation);
            }
            Err(e) => {
                f.failed.fetch_add(1, Ordering::Relaxed);
                if failing.is_none() {
                    tracing::error!("alarms: {e}");
                }
                *failing = Some(e.to_string());
            }
        }
    }
}
