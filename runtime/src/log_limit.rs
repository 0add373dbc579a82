//! Rate-limited log sites: a line that a peer, a full disk or a flood can repeat thousands of
//! times a second is written at most [`BURST`] times per [`WINDOW`] for each site and cause;
//! what was held back is counted and said once the window ends, naming the cause:
//! `Modbus TCP: refused connections: … 12,345 more in the last 10 s (from 10.0.0.7)`.
//!
//! Why: under journald's rate limit (by default 10,000 lines in 30 s per service) a flood of
//! one kind drops every other line, the PLC's real alarms with them. Each site keeps its own
//! count per cause, so a flood from one peer neither hides another peer's first lines nor a
//! module's loss (a different site). The table of causes is bounded ([`MAX_CAUSES`]); past it,
//! new causes share one entry, `others`.
//!
//! Use `limited!(WARN, SITE, cause, "format", args)`: the format is only evaluated when the
//! line is written.

use std::collections::HashMap;
use std::sync::{LazyLock, Mutex, Once, PoisonError};
use std::time::{Duration, Instant};

use tracing::Level;

/// How long a site's count runs.
pub(crate) const WINDOW: Duration = Duration::from_secs(10);
/// Lines written per site and cause in one window.
pub(crate) const BURST: u32 = 5;
/// Causes counted at once, every site together.
pub(crate) const MAX_CAUSES: usize = 256;

/// A log site: its key, and the words its summary starts with.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Site {
    /// Unique among sites.
    pub key: &'static str,
    /// What it logs, for the summary: `Modbus TCP: refused connections`.
    pub what: &'static str,
}

impl Site {
    /// A site of key `key` (unique among sites) whose summary starts with `what`.
    pub(crate) const fn new(key: &'static str, what: &'static str) -> Self {
        Self { key, what }
    }
}

/// One site and cause's window.
#[derive(Debug)]
struct Window {
    site: Site,
    level: Level,
    start: Instant,
    passed: u32,
    held: u64,
}

/// What was held back of one site and cause over a window.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Summary {
    /// Its level (the site's).
    pub level: Level,
    /// The line.
    pub text: String,
}

/// The counts of every site and cause; [`Instant`]s are given, so a test sets the time.
#[derive(Debug, Default)]
pub(crate) struct Limiter {
    windows: HashMap<(&'static str, String), Window>,
}

/// `12345` as `12,345`.
fn thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

impl Window {
    fn summary(&self, cause: &str) -> Summary {
        let cause = if cause.is_empty() {
            String::new()
        } else {
            format!(" ({cause})")
        };
        Summary {
            level: self.level,
            text: format!(
                "{}: … {} more in the last {} s{cause}",
                self.site.what,
                thousands(self.held),
                WINDOW.as_secs()
            ),
        }
    }
}

impl Limiter {
    /// Whether a line of `site` for `cause` at `now` is written; a window that ended first
    /// gives its summary.
    pub(crate) fn check(
        &mut self,
        site: Site,
        cause: &str,
        level: Level,
        now: Instant,
    ) -> (bool, Option<Summary>) {
        let known = self.windows.contains_key(&(site.key, cause.to_owned()));
        let cause = if known || self.windows.len() < MAX_CAUSES {
            cause
        } else {
            "others"
        };
        let w = self
            .windows
            .entry((site.key, cause.to_owned()))
            .or_insert(Window {
                site,
                level,
                start: now,
                passed: 0,
                held: 0,
            });
        let mut summary = None;
        if now.saturating_duration_since(w.start) >= WINDOW {
            if w.held > 0 {
                summary = Some(w.summary(cause));
            }
            w.start = now;
            w.passed = 0;
            w.held = 0;
        }
        if w.passed < BURST {
            w.passed += 1;
            (true, summary)
        } else {
            w.held += 1;
            (false, summary)
        }
    }

    /// The summaries of the windows ended by `now`; quiet entries are forgotten.
    pub(crate) fn flush(&mut self, now: Instant) -> Vec<Summary> {
        let mut out = Vec::new();
        self.windows.retain(|(_, cause), w| {
            if now.saturating_duration_since(w.start) < WINDOW {
                return true;
            }
            if w.held == 0 {
                return false;
            }
            out.push(w.summary(cause));
            w.start = now;
            w.passed = 0;
            w.held = 0;
            true
        });
        out
    }
}

static LIMITER: LazyLock<Mutex<Limiter>> = LazyLock::new(Mutex::default);
static FLUSHER: Once = Once::new();

fn emit(s: &Summary) {
    match s.level {
        Level::ERROR => tracing::error!("{}", s.text),
        Level::WARN => tracing::warn!("{}", s.text),
        _ => tracing::info!("{}", s.text),
    }
}

/// Whether a line of `site` for `cause` is written now (see the module docs).
pub(crate) fn allow(site: Site, cause: &str, level: Level) -> bool {
    FLUSHER.call_once(|| {
        // A thread says what a flood held back once its window ends, even if the flood
        // stopped; without it, the summary comes with the site's next line.
        let spawned = std::thread::Builder::new()
            .name("log-limit".into())
            .spawn(|| loop {
                std::thread::sleep(Duration::from_secs(1));
                let summaries = LIMITER
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .flush(Instant::now());
                summaries.iter().for_each(emit);
            });
        if let Err(e) = spawned {
            tracing::warn!("log limit: no summary thread ({e}); summaries come with the next line");
        }
    });
    let (pass, summary) = LIMITER
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .check(site, cause, level, Instant::now());
    if let Some(s) = summary {
        emit(&s);
    }
    pass
}

/// Logs at `LEVEL` (`ERROR`, `WARN`, `INFO`) through this module: at most a few lines per site
/// and cause every 10 s, the rest counted and summarized.
macro_rules! limited {
    ($level:ident, $site:expr, $cause:expr, $($arg:tt)+) => {
        if $crate::log_limit::allow($site, &$cause, tracing::Level::$level) {
            tracing::event!(tracing::Level::$level, $($arg)+);
        }
    };
}
pub(crate) use limited;

/// The lines of the libraries the services run on (async-opcua, rumqttc, tokio-modbus),
/// limited as our own sites are: a library logs what a peer makes it log (async-opcua writes
/// three lines for each connection a peer opens and drops), so a flood of connections would
/// drown the log through it. Each of its log sites is a site here (its callsite), and the
/// cause is the peer's address when the line names one (`from 10.0.0.7`), so one flooding peer
/// is summarized without hiding another's first lines; the summary names the library's module
/// and the site: `opcua_server::server: … 2,804 more in the last 10 s (at src/server.rs:376,
/// from 127.0.0.1)`. softplc's own lines (`softplc`, `softplc_io`) pass: their sites that can
/// repeat are limited where they are written.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct LibraryLines;

impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for LibraryLines {
    fn event_enabled(
        &self,
        event: &tracing::Event<'_>,
        _ctx: tracing_subscriber::layer::Context<'_, S>,
    ) -> bool {
        let meta = event.metadata();
        if meta.target().starts_with("softplc") {
            return true;
        }
        let site = Site::new(meta.name(), meta.target());
        allow(site, &library_cause(event), *meta.level())
    }
}

/// Where a library's line was written and, when its message names a peer's address, which
/// peer (its IP without the port, so each connection of one peer is one cause).
fn library_cause(event: &tracing::Event<'_>) -> String {
    struct Message(String);
    impl tracing::field::Visit for Message {
        fn record_debug(&mut self, field: &tracing::field::Field, value: &dyn std::fmt::Debug) {
            if field.name() == "message" {
                self.0 = format!("{value:?}");
            }
        }
    }
    let mut message = Message(String::new());
    event.record(&mut message);
    let meta = event.metadata();
    let at = match (meta.file(), meta.line()) {
        (Some(file), Some(line)) => format!("at {file}:{line}"),
        _ => format!("at {}", meta.name()),
    };
    match peer_in(&message.0) {
        Some(ip) => format!("{at}, from {ip}"),
        None => at,
    }
}

/// The first IP address (with or without a port) among `text`'s words.
fn peer_in(text: &str) -> Option<std::net::IpAddr> {
    text.split(|c: char| c.is_whitespace() || "()[],;\"'".contains(c))
        .find_map(|word| {
            word.parse::<std::net::SocketAddr>()
                .map(|a| a.ip())
                .or_else(|_| word.trim_end_matches(['.', ':']).parse())
                .ok()
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    const REFUSED: Site = Site::new("test.refused", "Modbus TCP: refused connections");
    const LOST: Site = Site::new("test.lost", "modules lost");

    #[test]
    fn a_flood_passes_its_burst_then_is_counted_per_cause_and_summarized() {
        let mut l = Limiter::default();
        let t0 = Instant::now();
        let mut passed = 0;
        for i in 0..12_345 + BURST {
            let at = t0 + Duration::from_micros(u64::from(i));
            let (pass, summary) = l.check(REFUSED, "from 10.0.0.7", Level::WARN, at);
            passed += u32::from(pass);
            assert_eq!(summary, None);
        }
        assert_eq!(passed, BURST);
        // Another peer and another site are not held back by the flood.
        assert!(l.check(REFUSED, "from 10.0.0.8", Level::WARN, t0).0);
        assert!(l.check(LOST, "", Level::WARN, t0).0);
        assert_eq!(l.flush(t0 + Duration::from_secs(9)), []);
        let summaries = l.flush(t0 + WINDOW);
        assert_eq!(
            summaries,
            [Summary {
                level: Level::WARN,
                text: "Modbus TCP: refused connections: … 12,345 more in the last 10 s (from \
                       10.0.0.7)"
                    .into()
            }]
        );
        // The quiet ones are forgotten; the flooding one starts a new window.
        assert_eq!(l.windows.len(), 1);
        assert!(
            l.check(REFUSED, "from 10.0.0.7", Level::WARN, t0 + WINDOW)
                .0
        );
    }

    #[test]
    fn a_window_that_ends_at_the_next_line_gives_its_summary_with_it() {
        let mut l = Limiter::default();
        let t0 = Instant::now();
        for _ in 0..BURST + 2 {
            l.check(LOST, "", Level::ERROR, t0);
        }
        let (pass, summary) = l.check(LOST, "", Level::ERROR, t0 + WINDOW);
        assert!(pass);
        assert_eq!(
            summary.unwrap().text,
            "modules lost: … 2 more in the last 10 s"
        );
    }

    #[test]
    fn causes_past_the_bound_share_one_entry() {
        let mut l = Limiter::default();
        let t0 = Instant::now();
        for i in 0..MAX_CAUSES + 100 {
            l.check(
                REFUSED,
                &format!("from 10.0.{}.{}", i / 256, i % 256),
                Level::WARN,
                t0,
            );
        }
        assert_eq!(l.windows.len(), MAX_CAUSES + 1);
        assert!(l.windows.contains_key(&(REFUSED.key, "others".to_owned())));
    }

    #[test]
    fn a_librarys_flood_passes_its_burst_per_site_and_peer_and_ours_passes_whole() {
        use std::sync::atomic::{AtomicU32, Ordering};
        use std::sync::Arc;
        use tracing_subscriber::layer::SubscriberExt;

        /// Counts the lines written, the library's and ours.
        #[derive(Default)]
        struct Written(Arc<[AtomicU32; 3]>);
        impl<S: tracing::Subscriber> tracing_subscriber::Layer<S> for Written {
            fn on_event(
                &self,
                event: &tracing::Event<'_>,
                _: tracing_subscriber::layer::Context<'_, S>,
            ) {
                let i = match event.metadata().target() {
                    "opcua_server::server" => 0,
                    "opcua_server::other" => 1,
                    _ => 2,
                };
                self.0[i].fetch_add(1, Ordering::Relaxed);
            }
        }
        let written = Arc::new([AtomicU32::new(0), AtomicU32::new(0), AtomicU32::new(0)]);
        let subscriber = tracing_subscriber::registry()
            .with(LibraryLines)
            .with(Written(written.clone()));
        tracing::subscriber::with_default(subscriber, || {
            for port in 0..100 {
                tracing::info!(
                    target: "opcua_server::server",
                    "Accept new connection from 10.0.0.7:{} ({port})",
                    40000 + port
                );
            }
            // Another peer's first lines, at the same site, are not held back by the flood.
            for _ in 0..2 {
                tracing::info!(target: "opcua_server::server", "Accept new connection from 10.0.0.8:1");
            }
            for _ in 0..100 {
                tracing::error!(target: "opcua_server::other", "Connection failed");
            }
            for _ in 0..100 {
                tracing::warn!(target: "softplc::test", "ours");
            }
        });
        let written = written.each_ref().map(|n| n.load(Ordering::Relaxed));
        assert_eq!(written, [BURST + 2, BURST, 100]);
    }

    #[test]
    fn a_peer_is_the_first_address_a_line_names_without_its_port() {
        let ip = |s: &str| s.parse::<std::net::IpAddr>().ok();
        assert_eq!(
            peer_in("Accept new connection from 127.0.0.1:51234 (17)"),
            ip("127.0.0.1")
        );
        assert_eq!(peer_in("client [::1]:4840 closed"), ip("::1"));
        assert_eq!(peer_in("refused 10.0.0.7."), ip("10.0.0.7"));
        assert_eq!(peer_in("Connection 12 terminated after 1.5 s"), None);
    }

    #[test]
    fn thousands_are_grouped() {
        let n = [0, 999, 1_000, 12_345, 1_234_567].map(thousands);
        assert_eq!(n, ["0", "999", "1,000", "12,345", "1,234,567"]);
    }
}
