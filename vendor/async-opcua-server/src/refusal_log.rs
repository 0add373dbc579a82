//! Refusals for a configured limit (sessions, subscriptions, monitored items), logged at
//! `warn` at most once a minute per limit, with how many were refused since the last line:
//! an operator learns that clients are turned away, and a client retrying in a loop cannot
//! flood the log.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often one limit's refusals are logged at most.
const EVERY: Duration = Duration::from_secs(60);

/// The refusals of one limit.
pub(crate) struct RefusalLog {
    /// What is refused, for the log line ("session", "subscription", "monitored item(s)").
    what: &'static str,
    /// The limit's name in the server's configuration.
    limit_name: &'static str,
    last: Mutex<Option<Instant>>,
    unlogged: AtomicU64,
}

impl RefusalLog {
    pub(crate) const fn new(what: &'static str, limit_name: &'static str) -> Self {
        Self {
            what,
            limit_name,
            last: Mutex::new(None),
            unlogged: AtomicU64::new(0),
        }
    }

    /// One refusal with `status` at `limit`.
    pub(crate) fn refused(&self, status: opcua_types::StatusCode, limit: usize) {
        let unlogged = self.unlogged.fetch_add(1, Ordering::Relaxed) + 1;
        let now = Instant::now();
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        if last.is_some_and(|t| now.duration_since(t) < EVERY) {
            return;
        }
        *last = Some(now);
        self.unlogged.fetch_sub(unlogged, Ordering::Relaxed);
        tracing::warn!(
            "OPC UA: {} refused ({status}): the limit is {limit} ({}); {unlogged} refused since \
             the last such line (logged at most once a minute)",
            self.what,
            self.limit_name,
        );
    }
}

/// Sessions beyond `max_sessions`.
pub(crate) static SESSIONS: RefusalLog = RefusalLog::new("session", "max_sessions");
/// Subscriptions beyond `max_subscriptions_per_session`.
pub(crate) static SUBSCRIPTIONS: RefusalLog =
    RefusalLog::new("subscription", "max_subscriptions_per_session");
/// Monitored items beyond `max_monitored_items_per_sub`.
pub(crate) static MONITORED_ITEMS: RefusalLog =
    RefusalLog::new("monitored item(s)", "max_monitored_items_per_sub");
