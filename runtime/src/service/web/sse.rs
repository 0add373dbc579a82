//! Server-sent events: `GET /api/events` streams the live state to the page without reloads.
//!
//! Each stream sends `state` after every new cycle of any task (checked every [`TICK`]) and
//! `stats` after every refresh of the statistics, a comment every [`KEEPALIVE`] while the
//! scan is quiet, and ends after [`LIFETIME`] (the browser's `EventSource` reconnects by
//! itself after the announced `retry`), so a thread is never held by a tab that went away
//! without closing.

use std::io::Write;
use std::time::{Duration, Instant};

use super::view;
use crate::service::snapshot::{ServiceSnapshot, SnapshotCell};

/// How often a stream looks for a new cycle.
pub(crate) const TICK: Duration = Duration::from_millis(100);
/// The longest silence on a stream.
pub(crate) const KEEPALIVE: Duration = Duration::from_secs(15);
/// How long one stream lasts before the browser is asked to reconnect.
pub(crate) const LIFETIME: Duration = Duration::from_secs(600);
/// The kernel's send buffer of a stream: a few seconds of events, so a stream nobody reads
/// fills it soon and is dropped by the write deadline (rather than after megabytes).
pub(crate) const SEND_BUFFER: usize = 32 * 1024;
/// How long the browser waits before reconnecting, in ms.
pub(crate) const RETRY_MS: u32 = 1000;

/// The response head of a stream.
pub(crate) fn head() -> String {
    format!(
        "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream; charset=utf-8\r\n{}\
         X-Accel-Buffering: no\r\nConnection: close\r\n\r\nretry: {RETRY_MS}\n\n",
        super::http::SECURITY_HEADERS
    )
}

/// One event: `event: NAME`, then `data:` lines (a newline in `data` starts another `data:`
/// line, as the format requires), then a blank line. A name with a line break or a colon
/// would corrupt the stream, so such characters are dropped from it.
pub(crate) fn event(name: &str, data: &str) -> String {
    let name: String = name
        .chars()
        .filter(|c| !matches!(c, '\r' | '\n' | ':'))
        .collect();
    let mut out = String::with_capacity(data.len() + name.len() + 16);
    out.push_str("event: ");
    out.push_str(&name);
    out.push('\n');
    for line in data.split('\n') {
        out.push_str("data: ");
        out.push_str(line.strip_suffix('\r').unwrap_or(line));
        out.push('\n');
    }
    out.push('\n');
    out
}

/// A comment line (ignored by the browser; keeps proxies and the connection awake).
pub(crate) fn comment(text: &str) -> String {
    format!(": {}\n\n", text.replace(['\r', '\n'], " "))
}

/// What makes a new `state` event: a cycle of any task (with several tasks, one that is not
/// the first's publishes its tags between the first task's cycles), or the end of the run
/// (the final publication adds no cycle, only `stopped`).
fn news(s: &ServiceSnapshot) -> (u64, u64, bool) {
    (s.cycles, s.task_cycles.iter().sum(), s.stopped)
}

/// Streams `snapshot` to `out` until the client goes away or [`LIFETIME`] passes.
pub(crate) fn stream(
    out: &mut impl Write,
    snapshot: &SnapshotCell,
    health: &crate::service::health::Health,
) -> std::io::Result<()> {
    out.write_all(head().as_bytes())?;
    out.flush()?;
    let begin = Instant::now();
    let mut last_sent = Instant::now();
    let mut cycles = None;
    let mut stats_seq = None;
    while begin.elapsed() < LIFETIME {
        let s = snapshot.get();
        let mut chunk = String::new();
        if s.published && cycles != Some(news(&s)) {
            cycles = Some(news(&s));
            chunk.push_str(&event("state", &view::state(&s).to_string()));
        }
        if s.published && stats_seq != Some(s.stats_seq) {
            stats_seq = Some(s.stats_seq);
            chunk.push_str(&event("stats", &view::stats(&s, health).to_string()));
        }
        if chunk.is_empty() && last_sent.elapsed() >= KEEPALIVE {
            chunk = comment("waiting for the scan");
        }
        if !chunk.is_empty() {
            out.write_all(chunk.as_bytes())?;
            out.flush()?;
            last_sent = Instant::now();
        }
        if s.stopped {
            // The run is over: the last state is out, the process is about to exit.
            break;
        }
        std::thread::sleep(TICK);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_are_framed_line_by_line() {
        assert_eq!(event("state", "{}"), "event: state\ndata: {}\n\n");
        assert_eq!(
            event("a\nb:c", "one\r\ntwo\nthree"),
            "event: abc\ndata: one\ndata: two\ndata: three\n\n"
        );
        assert_eq!(event("x", ""), "event: x\ndata: \n\n");
        assert_eq!(comment("a\nb"), ": a b\n\n");
        let h = head();
        assert!(h.starts_with("HTTP/1.1 200 OK\r\nContent-Type: text/event-stream"));
        assert!(h.ends_with("\r\n\r\nretry: 1000\n\n"));
    }

    #[test]
    fn a_cycle_of_any_task_is_news() {
        let mut s = ServiceSnapshot {
            cycles: 3,
            task_cycles: vec![3, 10],
            task_stopped: vec![false, false],
            ..ServiceSnapshot::default()
        };
        let before = news(&s);
        s.task_cycles[1] = 11;
        assert_ne!(news(&s), before, "the second task's cycle");
        let before = news(&s);
        s.stopped = true;
        assert_ne!(news(&s), before, "the end");
    }

    #[test]
    fn a_stream_sends_state_and_stats_then_ends_with_the_run() {
        let cell = SnapshotCell::new();
        cell.set(ServiceSnapshot {
            published: true,
            cycles: 3,
            stopped: true,
            ..ServiceSnapshot::default()
        });
        let mut out = Vec::new();
        stream(&mut out, &cell, &crate::service::health::Health::new()).unwrap();
        let text = String::from_utf8(out).unwrap();
        let body = text.split("\r\n\r\n").nth(1).unwrap();
        assert!(
            body.starts_with("retry: 1000\n\nevent: state\ndata: {"),
            "{body}"
        );
        assert!(body.contains("\"cycles\":3"), "{body}");
        assert!(body.contains("\n\nevent: stats\ndata: {"), "{body}");
        assert!(body.ends_with("}\n\n"), "{body}");
    }
}
