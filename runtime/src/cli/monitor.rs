//! `softplc monitor PORT --baud B --format 8E1`: a passive bus monitor. It only listens (a tap
//! on the line, a second adapter) and prints every frame it hears with the silence before it
//! and its decoding: Modbus RTU framed by silence (t3.5 from the baud and format, 1.75 ms above
//! 19200 Bd), MiniMod text, RESI ASCII and DCON lines framed by their CR. The framing is
//! `softplc_io::wire::framer`, the decoding `softplc_io::wire::decode`, the same decoder as
//! `softplc run --trace-bus`.
//!
//! Times are the monitor's own monotonic clock since it started: a frame's time is when its
//! first byte was read, so an adapter that holds bytes (an FTDI latency timer) shifts them;
//! `--gap` sets a longer frame gap for such an adapter, which would otherwise cut one frame in
//! two at high baud rates.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use softplc_io::line::{LineError, LineSettings, SerialFormat, SerialTransport, Transport};
use softplc_io::wire::{
    frame_gap, unglue, Conversation, FrameEnd, Framer, Framing, HeardFrame, LineTime, Shown,
    MAX_FRAME,
};

use super::out;
use crate::clock::MonotonicClock;
use crate::scan::fmt_duration;

/// Arguments of `softplc monitor`.
#[derive(Debug, clap::Args)]
pub(crate) struct MonitorArgs {
    /// The serial device to listen on (a second adapter on the line, a tap).
    port: PathBuf,
    /// The line's baud rate.
    #[arg(long, default_value_t = 19200, value_parser = clap::value_parser!(u32).range(1..))]
    baud: u32,
    /// The line's character format (data bits, parity, stop bits), e.g. 8E1, 8N1, 8N2.
    #[arg(long, default_value = "8E1", value_parser = parse_format)]
    format: SerialFormat,
    /// How frames are told apart: auto (text lines by content, the rest as RTU), rtu (silence
    /// only), text (CR only).
    #[arg(long, value_enum, default_value_t = ProtocolArg::Auto)]
    protocol: ProtocolArg,
    /// The silence that ends an RTU frame (default: t3.5 of the baud and format, 1.75 ms above
    /// 19200 Bd); longer for a USB adapter that delivers in bursts (e.g. 20ms).
    #[arg(long, value_parser = super::parse_duration)]
    gap: Option<Duration>,
    /// Stop by itself after this long (e.g. 10s); otherwise Ctrl-C ends it.
    #[arg(long = "for", value_parser = super::parse_duration)]
    run_for: Option<Duration>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum ProtocolArg {
    Auto,
    Rtu,
    Text,
}

fn parse_format(text: &str) -> Result<SerialFormat, String> {
    text.parse().map_err(|e| format!("{text:?}: {e}"))
}

/// The longest the monitor waits in one read: how soon it notices Ctrl-C.
const MAX_WAIT: Duration = Duration::from_millis(50);

pub(super) fn monitor(args: MonitorArgs) -> anyhow::Result<ExitCode> {
    let settings = LineSettings {
        baud: args.baud,
        format: args.format,
    };
    let (framing, framing_name) = match args.protocol {
        ProtocolArg::Auto => (Framing::Auto, "auto"),
        ProtocolArg::Rtu => (Framing::Rtu, "rtu"),
        ProtocolArg::Text => (Framing::Text, "text"),
    };
    let gap = args.gap.unwrap_or_else(|| frame_gap(settings));
    // Only read, never written: a second adapter must not drive the line.
    let mut line = SerialTransport::open(&args.port, settings, Arc::new(MonotonicClock::new()))
        .with_context(|| format!("cannot listen on {}", args.port.display()))?;
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone()).context("cannot install signal handlers")?;
    }
    out::errln(&format!(
        "monitoring {} at {} Bd {} ({framing_name} framing); a frame ends after {} of silence; \
         t = time since the start, gap = silence before the frame",
        args.port.display(),
        settings.baud,
        settings.format,
        fmt_duration(gap)
    ));
    let start = line.now();
    let end = args.run_for.map(|d| start + d);
    let since_start = |line: &SerialTransport| line.now().saturating_duration_since(start);
    let mut framer = Framer::new(framing, gap);
    let mut talk = Conversation::new();
    let mut frames = Vec::new();
    let mut chunk = Vec::with_capacity(MAX_FRAME);
    let mut heard = 0u64;
    let hung_up = loop {
        let now = line.now();
        if stop.load(Ordering::Relaxed) || end.is_some_and(|e| now >= e) {
            break false;
        }
        let wake = now + MAX_WAIT;
        let deadline = framer
            .deadline()
            .map_or(wake, |d| (start + d).min(wake))
            .min(end.unwrap_or(wake));
        chunk.clear();
        match line.read_until(&mut chunk, deadline) {
            Ok(_) => framer.push(&chunk, since_start(&line), &mut frames),
            // The other end went away (a pty's master closed, an adapter unplugged).
            Err(LineError::Io(e))
                if e.kind() == std::io::ErrorKind::BrokenPipe
                    || e.raw_os_error() == Some(libc::EIO) =>
            {
                break true
            }
            Err(e) => {
                return Err(anyhow::Error::new(e)
                    .context(format!("cannot read from {}", args.port.display())))
            }
        }
        frames.extend(framer.poll(since_start(&line)));
        for frame in frames.drain(..).flat_map(unglue) {
            heard += 1;
            out::outln(&frame_line(&frame, &mut talk))?;
        }
    };
    for frame in framer.finish().into_iter().flat_map(unglue) {
        heard += 1;
        out::outln(&frame_line(&frame, &mut talk))?;
    }
    out::errln(&format!(
        "{heard} frame(s) in {}{}",
        fmt_duration(since_start(&line)),
        if hung_up { "; the line hung up" } else { "" }
    ));
    Ok(ExitCode::SUCCESS)
}

/// `t=<start>  gap <silence>  <hex>  | <decoding>`.
fn frame_line(frame: &HeardFrame, talk: &mut Conversation) -> String {
    let gap = frame.gap.map_or_else(|| "-".to_string(), fmt_duration);
    let note = match frame.ended_by {
        FrameEnd::Silence | FrameEnd::Terminator => "",
        FrameEnd::Overflow => " (cut: longer than any frame)",
        FrameEnd::Finished => " (cut: the capture ended)",
        FrameEnd::Glued => " (no silence after it: split from the next by their CRCs)",
    };
    format!(
        "t={}  gap {gap:>9}  {}  | {}{note}",
        LineTime(frame.start),
        Shown(&frame.bytes),
        talk.frame(&frame.bytes)
    )
}
