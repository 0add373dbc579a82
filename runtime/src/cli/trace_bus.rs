//! `softplc run --trace-bus`: every bus owner's frames on stdout, one line each
//! (`softplc_io::wire::format_event`), written by a thread of their own so a slow
//! terminal never holds a line.
//!
//! On the real clock a bus thread never waits for the printer: when the queue is full a line
//! is dropped and the count is said at the end. On the virtual clock nothing is dropped (the
//! scan waits instead; time does not run meanwhile), so the trace is the same on every run.
//! A closed stdout (`softplc run ... --trace-bus | head`) ends the trace, never the PLC.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use softplc_io::time::LineInstant;
use softplc_io::wire::{format_event, WireEvent, WireTap};

/// Trace lines queued for the printer before a real-clock line drops one.
const QUEUE: usize = 4096;

/// The tap the bus owners report to.
#[derive(Debug)]
pub(super) struct StdoutTrace {
    lines: Sender<String>,
    /// Wait for the printer instead of dropping (the virtual clock).
    lossless: bool,
    dropped: Arc<AtomicU64>,
}

impl WireTap for StdoutTrace {
    fn record(&self, bus: &str, at: LineInstant, event: &WireEvent<'_>) {
        let line = format_event(bus, at, event);
        let sent = if self.lossless {
            self.lines.send(line).is_ok()
        } else {
            self.lines.try_send(line).is_ok()
        };
        if !sent {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The printer thread, and how many lines were dropped.
pub(super) struct Printer {
    handle: JoinHandle<()>,
    dropped: Arc<AtomicU64>,
}

/// Starts the printer; `virtual_clock` makes the trace lossless. The header says which clock
/// the times are on.
pub(super) fn start(virtual_clock: bool) -> anyhow::Result<(Arc<StdoutTrace>, Printer)> {
    let (lines, rx) = crossbeam_channel::bounded::<String>(QUEUE);
    let dropped = Arc::new(AtomicU64::new(0));
    let clock = if virtual_clock {
        "virtual time since the start of the run"
    } else {
        "monotonic time since softplc started"
    };
    super::out::outln(&format!(
        "# bus trace: t = the line's clock ({clock}); TX = sent (t: start), RX = received \
         (t: last byte)"
    ))?;
    let handle = std::thread::Builder::new()
        .name("trace-bus".into())
        .spawn(move || print(&rx))?;
    let tap = Arc::new(StdoutTrace {
        lines,
        lossless: virtual_clock,
        dropped: dropped.clone(),
    });
    Ok((tap, Printer { handle, dropped }))
}

fn print(rx: &Receiver<String>) {
    let mut open = true;
    for line in rx {
        // After a closed stdout the lines are still taken, so no bus ever waits on them.
        open = open && super::out::outln(&line).is_ok();
    }
}

impl Printer {
    /// Waits (at most `limit`) for every bus owner to let go of the tap and the last lines to
    /// be printed; says how many were dropped.
    pub(super) fn finish(self, limit: Duration) {
        let deadline = Instant::now() + limit;
        while !self.handle.is_finished() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
        let dropped = self.dropped.load(Ordering::Relaxed);
        if dropped > 0 {
            tracing::warn!("bus trace: {dropped} line(s) dropped (stdout could not keep up)");
        }
    }
}
