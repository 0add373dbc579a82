//! The audit file: every operator or client action on a running PLC (a write, a force, an
//! unforce, a reload, an alarm's acknowledgement), with who asked (the [`Origin`]), when (UTC and the cycle it was applied
//! at) and what became of it, in `PROJECT.audit.jsonl` beside the retained values (under
//! systemd, in the state directory). One JSON object a line, the oldest first.
//!
//! The scan only hands an entry over (`try_send`, never waits): a thread of its own keeps the
//! latest [`KEPT`] entries and rewrites the file atomically after each batch, so the file is
//! bounded and never torn. A failing disk is counted and shown in `status` (the service
//! `audit` degraded, with the reason); the scan goes on. Entries the thread could not take in
//! time (a burst past the queue) are counted too.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

use crossbeam_channel::{Receiver, Sender};
use serde::{Deserialize, Serialize};

/// How many entries the file keeps: the latest, older ones give way.
pub const KEPT: usize = 1_000;
/// Entries the scan may hand over before the thread takes them; past it they are counted lost.
const QUEUE: usize = 256;

/// Who asked for a change.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// The control socket (`softplc force`, `write`, `reload`, ...).
    Cli,
    /// The web page, from a client address, signed in as a role.
    Web(
        Option<std::net::SocketAddr>,
        Option<crate::project::WebRole>,
    ),
    /// An OPC UA client.
    Opcua,
    /// A Modbus TCP client, from its address.
    Modbus(Option<std::net::SocketAddr>),
    /// A Sparkplug command, on its topic.
    Mqtt(String),
    /// SIGHUP (a reload).
    Signal,
}

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Origin::Cli => f.write_str("cli"),
            Origin::Web(peer, role) => {
                f.write_str("web")?;
                if let Some(a) = peer {
                    write!(f, " {a}")?;
                }
                if let Some(r) = role {
                    write!(f, " {r}")?;
                }
                Ok(())
            }
            Origin::Opcua => f.write_str("opcua"),
            Origin::Modbus(Some(a)) => write!(f, "modbus {a}"),
            Origin::Modbus(None) => f.write_str("modbus"),
            Origin::Mqtt(topic) => write!(f, "mqtt {topic}"),
            Origin::Signal => f.write_str("sighup"),
        }
    }
}

/// What was asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Action {
    /// A write of tags (once).
    Write,
    /// A force.
    Force,
    /// An unforce (one tag or every tag).
    Unforce,
    /// A program reload.
    Reload,
    /// An alarm's acknowledgement (`all`: every alarm waiting).
    Acknowledge,
}

impl std::fmt::Display for Action {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Action::Write => "write",
            Action::Force => "force",
            Action::Unforce => "unforce",
            Action::Reload => "reload",
            Action::Acknowledge => "acknowledge",
        })
    }
}

/// One line of the audit file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Entry {
    /// Wall-clock time, UTC, RFC 3339 with milliseconds.
    pub utc: String,
    /// The scan's count of completed cycles when it was applied (or refused).
    pub cycle: u64,
    /// Who asked: `cli`, `web ADDRESS`, `opcua`, `modbus ADDRESS`, `mqtt TOPIC`, `sighup`.
    pub source: String,
    /// What was asked.
    pub action: Action,
    /// The tags and values (`speed=42`), the tag unforced (`*` for every tag), or empty.
    pub what: String,
    /// Whether it was carried out.
    pub ok: bool,
    /// What the PLC answered (the refusal's reason when refused).
    pub result: String,
}

impl Entry {
    /// An entry stamped now.
    pub fn now(
        cycle: u64,
        origin: &Origin,
        action: Action,
        what: String,
        ok: bool,
        result: String,
    ) -> Self {
        let utc = chrono::DateTime::<chrono::Utc>::from(std::time::SystemTime::now())
            .to_rfc3339_opts(chrono::SecondsFormat::Millis, true);
        Self {
            utc,
            cycle,
            source: origin.to_string(),
            action,
            what,
            ok,
            result,
        }
    }
}

impl std::fmt::Display for Entry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}  cycle {:<8} {:<24} {:<7} {:<20} {}{}",
            self.utc,
            self.cycle,
            self.source,
            self.action,
            self.what,
            if self.ok { "" } else { "REFUSED: " },
            self.result
        )
    }
}

/// The audit file of `project_file`: `PROJECT.audit.jsonl` in its state folder.
pub fn audit_path(project_file: &Path) -> PathBuf {
    let mut name = project_file.file_name().unwrap_or_default().to_os_string();
    name.push(".audit.jsonl");
    crate::project::state::default_state_folder(project_file).join(name)
}

/// Why the audit file cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file cannot be opened or read.
    #[error("{path}: cannot read the audit file: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A line is not an entry.
    #[error("{path}:{line}: not an audit entry: {source}")]
    Bad {
        /// The file.
        path: PathBuf,
        /// The line (from 1).
        line: usize,
        /// Why.
        source: serde_json::Error,
    },
}

/// The entries of the audit file at `path`, the oldest first; none when it does not exist yet.
pub fn read(path: &Path) -> Result<Vec<Entry>, ReadError> {
    super::json_lines::read(path).map_err(|e| match e {
        super::json_lines::LinesError::Io(source) => ReadError::Io {
            path: path.to_path_buf(),
            source,
        },
        super::json_lines::LinesError::Bad(line, source) => ReadError::Bad {
            path: path.to_path_buf(),
            line,
            source,
        },
    })
}

/// What the writer thread shares with its readers (the page, the status).
#[derive(Debug, Default)]
struct Shared {
    entries: Mutex<VecDeque<Entry>>,
    /// Rewrites of the file that failed.
    failed: AtomicU64,
    /// The last failure's reason, while the file cannot be written.
    failing: Mutex<Option<String>>,
    /// Entries lost because the thread was behind.
    lost: AtomicU64,
    /// Entries handed over and not yet through a rewrite (written or failed).
    unwritten: AtomicU64,
}

/// The scan's side: hands entries to the writer thread, never waits.
#[derive(Debug, Clone)]
pub struct AuditLog {
    tx: Sender<Entry>,
    shared: Arc<Shared>,
}

impl AuditLog {
    /// Starts the writer of the audit file at `path`, keeping the entries it already holds
    /// (an unreadable file is logged and started afresh: the audit goes on).
    pub fn start(path: PathBuf) -> std::io::Result<Self> {
        let mut kept: VecDeque<Entry> = match read(&path) {
            Ok(e) => e.into(),
            Err(e) => {
                tracing::error!("{e}; a new audit file is started");
                VecDeque::new()
            }
        };
        while kept.len() > KEPT {
            kept.pop_front();
        }
        let shared = Arc::new(Shared {
            entries: Mutex::new(kept),
            ..Shared::default()
        });
        let (tx, rx) = crossbeam_channel::bounded(QUEUE);
        let writer = shared.clone();
        std::thread::Builder::new()
            .name("audit".into())
            .spawn(move || write_loop(&rx, &writer, &path))?;
        Ok(Self { tx, shared })
    }

    /// Hands `entry` to the writer; counted lost when its queue is full.
    pub fn note(&self, entry: Entry) {
        self.shared.unwritten.fetch_add(1, Ordering::AcqRel);
        if self.tx.try_send(entry).is_err() {
            self.shared.unwritten.fetch_sub(1, Ordering::AcqRel);
            self.shared.lost.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Waits (at most `within`) until every entry handed over has been through a rewrite of
    /// the file: at the end of a run, so the last actions (a stop's, a reload's) are not lost
    /// with the process.
    pub fn finish(&self, within: std::time::Duration) {
        let end = std::time::Instant::now() + within;
        while self.shared.unwritten.load(Ordering::Acquire) > 0 && std::time::Instant::now() < end {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }

    /// The latest `n` entries, the newest first.
    pub fn latest(&self, n: usize) -> Vec<Entry> {
        let e = self
            .shared
            .entries
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        e.iter().rev().take(n).cloned().collect()
    }

    /// The service's state for the status: degraded while the file cannot be written or
    /// when entries were lost.
    pub fn state(&self) -> super::health::ServiceState {
        let failed = self.shared.failed.load(Ordering::Relaxed);
        let lost = self.shared.lost.load(Ordering::Relaxed);
        let failing = self
            .shared
            .failing
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        match (failing, lost) {
            (Some(why), _) => super::health::ServiceState::Degraded(format!(
                "cannot write the audit file ({why}); {failed} failed write(s), the latest \
                 entries kept in memory"
            )),
            (None, 0) => super::health::ServiceState::Running,
            (None, lost) => super::health::ServiceState::Degraded(format!(
                "{lost} entries lost (the writer was behind)"
            )),
        }
    }
}

fn write_loop(rx: &Receiver<Entry>, shared: &Shared, path: &Path) {
    while let Ok(first) = rx.recv() {
        let mut batch = 0;
        let text = {
            let mut e = shared
                .entries
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            // A burst is written once: everything waiting joins this rewrite.
            for entry in std::iter::once(first).chain(rx.try_iter()) {
                batch += 1;
                e.push_back(entry);
                if e.len() > KEPT {
                    e.pop_front();
                }
            }
            super::json_lines::text(e.iter())
        };
        let outcome = crate::retain::write_file_atomic(path, text.as_bytes());
        let mut failing = shared
            .failing
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        match outcome {
            Ok(()) => *failing = None,
            Err(e) => {
                shared.failed.fetch_add(1, Ordering::Relaxed);
                if failing.is_none() {
                    tracing::error!("audit: {e}");
                }
                *failing = Some(e.to_string());
            }
        }
        shared.unwritten.fetch_sub(batch, Ordering::AcqRel);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(i: u64) -> Entry {
        Entry::now(
            i,
            &Origin::Cli,
            Action::Write,
            format!("n={i}"),
            true,
            "n written".into(),
        )
    }

    /// Waits until the thread has been through every entry; the file's last is `last`.
    fn settled(log: &AuditLog, path: &Path, last: u64) {
        log.finish(std::time::Duration::from_secs(10));
        let kept = read(path).unwrap();
        assert_eq!(
            kept.last().map(|x| x.cycle),
            Some(last),
            "{:?}",
            log.state()
        );
    }

    #[test]
    fn the_file_keeps_the_latest_thousand_across_a_restart() {
        let dir = std::env::temp_dir().join(format!("softplc-audit-{}", std::process::id()));
        drop(std::fs::remove_dir_all(&dir));
        let path = dir.join("p.yaml.audit.jsonl");
        let log = AuditLog::start(path.clone()).unwrap();
        for i in 1..=600 {
            log.note(entry(i));
            if i % 200 == 0 {
                // Below the queue's bound: nothing is lost to a slow disk.
                settled(&log, &path, i);
            }
        }
        drop(log);
        // Started again: the entries are there, and 1,000 + more keep the latest 1,000.
        let log = AuditLog::start(path.clone()).unwrap();
        assert_eq!(log.latest(1)[0].cycle, 600);
        for i in 601..=1_100 {
            log.note(entry(i));
            if i % 200 == 0 {
                settled(&log, &path, i);
            }
        }
        settled(&log, &path, 1_100);
        let kept = read(&path).unwrap();
        assert_eq!(kept.len(), KEPT);
        assert_eq!(kept[0].cycle, 101);
        assert_eq!(kept[0].source, "cli");
        assert_eq!(log.latest(2)[1].what, "n=1099");
        assert_eq!(log.state(), crate::service::health::ServiceState::Running);
        drop(std::fs::remove_dir_all(dir));
    }

    #[test]
    fn a_file_that_cannot_be_written_is_counted_not_fatal() {
        let dir = std::env::temp_dir().join(format!("softplc-audit-bad-{}", std::process::id()));
        drop(std::fs::remove_dir_all(&dir));
        std::fs::create_dir_all(&dir).unwrap();
        // Its folder is a file: every write fails, as on a full or read-only disk.
        std::fs::write(dir.join("state"), "").unwrap();
        let log = AuditLog::start(dir.join("state/p.audit.jsonl")).unwrap();
        log.note(entry(1));
        let end = std::time::Instant::now() + std::time::Duration::from_secs(10);
        while log.state() == crate::service::health::ServiceState::Running
            && std::time::Instant::now() < end
        {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        let state = log.state();
        let why = state.reason().unwrap_or_default().to_string();
        assert!(
            why.contains("cannot write the audit file") && why.contains("1 failed"),
            "{why}"
        );
        // Kept in memory for the page all the same.
        assert_eq!(log.latest(5).len(), 1);
        drop(std::fs::remove_dir_all(dir));
    }
}
