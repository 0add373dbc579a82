//! Serving simulated modules over TCP (`softplc sim --tcp ADDR` / `--rtu-tcp ADDR`), so a
//! project can point `port: tcp://…` or `port: rtu+tcp://…` at them:
//!
//! - [`NetFraming::ModbusTcp`]: a Modbus TCP-to-RTU gateway. Each MBAP request becomes the RTU
//!   frame for its unit id on the simulated line; the module's reply goes back with the
//!   request's transaction id once it is due (the module's reply delay and wire time). A unit
//!   that does not answer (absent, a line fault, a bad CRC) gets exception 0x0B, "gateway
//!   target device failed to respond", as real gateways answer.
//! - [`NetFraming::RtuOverTcp`]: a serial device server in transparent mode: bytes in are the
//!   line's, bytes out are the modules' replies, framed as on the pty server
//!   ([`crate::sim::serve`]).
//!
//! Every connection has its own thread; one lock keeps the line to one request at a time, as
//! one RS-485 line behind a gateway is.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::line::settings::LineSettings;
use crate::line::tcp::NetFraming;
use crate::modbus::crc::{append_crc, check_crc};
use crate::sim::line::SharedWorld;
use crate::sim::serve::{answer, complete_frame, lock, ServeStats};
use crate::time::Clock;

/// The exception a gateway answers for a unit that did not respond.
const GATEWAY_TARGET_FAILED: u8 = 0x0B;

/// Shared by the connection threads.
#[derive(Debug)]
struct Served {
    world: SharedWorld,
    settings: LineSettings,
    clock: Arc<dyn Clock>,
    /// One request on the line at a time.
    line: Mutex<()>,
    frames: AtomicU64,
    replies: AtomicU64,
    noise: AtomicU64,
}

/// Serves `world` on `listener` with `framing` until `stop` is set.
pub fn serve_tcp(
    listener: TcpListener,
    world: SharedWorld,
    framing: NetFraming,
    settings: LineSettings,
    clock: Arc<dyn Clock>,
    stop: &AtomicBool,
) -> std::io::Result<ServeStats> {
    let served = Arc::new(Served {
        world,
        settings,
        clock,
        line: Mutex::new(()),
        frames: AtomicU64::new(0),
        replies: AtomicU64::new(0),
        noise: AtomicU64::new(0),
    });
    listener.set_nonblocking(true)?;
    let stopping = Arc::new(AtomicBool::new(false));
    let mut threads = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, peer)) => {
                tracing::info!(%peer, "master connected");
                let served = served.clone();
                let stopping = stopping.clone();
                threads.push(std::thread::Builder::new().name("sim-tcp".into()).spawn(
                    move || {
                        let r = match framing {
                            NetFraming::ModbusTcp => gateway(stream, &served, &stopping),
                            NetFraming::RtuOverTcp => transparent(stream, &served, &stopping),
                        };
                        match r {
                            Ok(()) => tracing::info!(%peer, "master disconnected"),
                            Err(e) => tracing::info!(%peer, "connection ended: {e}"),
                        }
                    },
                )?);
                threads.retain(|t| !t.is_finished());
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(2));
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    stopping.store(true, Ordering::Relaxed);
    for t in threads {
        drop(t.join());
    }
    Ok(ServeStats {
        frames: served.frames.load(Ordering::Relaxed),
        replies: served.replies.load(Ordering::Relaxed),
        noise_bytes: served.noise.load(Ordering::Relaxed),
    })
}

/// Reads exactly `buf.len()` bytes, looking at `stop` every few ms; `Ok(false)` at a clean
/// end of the connection before the first byte.
fn read_exact_or_end(
    stream: &mut TcpStream,
    buf: &mut [u8],
    stop: &AtomicBool,
) -> std::io::Result<bool> {
    let mut got = 0;
    while got < buf.len() {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        match stream.read(&mut buf[got..]) {
            Ok(0) if got == 0 => return Ok(false),
            Ok(0) => return Err(ErrorKind::UnexpectedEof.into()),
            Ok(n) => got += n,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

/// One Modbus TCP master: MBAP requests in, MBAP replies out.
fn gateway(mut stream: TcpStream, served: &Served, stop: &AtomicBool) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_millis(20)))?;
    stream.set_nodelay(true)?;
    let mut header = [0u8; 7];
    loop {
        if !read_exact_or_end(&mut stream, &mut header, stop)? {
            return Ok(());
        }
        let length = usize::from(u16::from_be_bytes([header[4], header[5]]));
        // MBAP: protocol id 0, length = unit id + PDU (at most 253 bytes of PDU).
        if header[2..4] != [0, 0] || !(2..=254).contains(&length) {
            return Err(std::io::Error::new(
                ErrorKind::InvalidData,
                "not a Modbus TCP request (protocol id or length)",
            ));
        }
        let unit = header[6];
        let mut pdu = vec![0u8; length - 1];
        if !read_exact_or_end(&mut stream, &mut pdu, stop)? {
            return Err(ErrorKind::UnexpectedEof.into());
        }
        let mut frame = Vec::with_capacity(pdu.len() + 3);
        frame.push(unit);
        frame.extend_from_slice(&pdu);
        append_crc(&mut frame);
        let mut heard = Vec::new();
        {
            let _line = served.line.lock().unwrap_or_else(|e| e.into_inner());
            lock(&served.world).advance_to(served.clock.line_now());
            served.frames.fetch_add(1, Ordering::Relaxed);
            answer(
                &mut heard,
                &served.world,
                &frame,
                served.settings,
                served.clock.as_ref(),
            )
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        }
        if unit == 0 {
            // A broadcast: the modules act, nobody answers.
            continue;
        }
        let reply_pdu = match first_frame(&heard, unit) {
            Some(rtu) => {
                served.replies.fetch_add(1, Ordering::Relaxed);
                rtu[1..rtu.len() - 2].to_vec()
            }
            None => {
                served
                    .noise
                    .fetch_add(heard.len() as u64, Ordering::Relaxed);
                vec![pdu[0] | 0x80, GATEWAY_TARGET_FAILED]
            }
        };
        let mut out = Vec::with_capacity(reply_pdu.len() + 7);
        out.extend_from_slice(&header[0..4]);
        out.extend_from_slice(&(reply_pdu.len() as u16 + 1).to_be_bytes());
        out.push(unit);
        out.extend_from_slice(&reply_pdu);
        stream.write_all(&out)?;
    }
}

/// The first RTU frame from `unit` at the head of `heard` with a good CRC.
fn first_frame(heard: &[u8], unit: u8) -> Option<&[u8]> {
    if heard.first() != Some(&unit) {
        return None;
    }
    (4..=heard.len())
        .find(|&n| check_crc(&heard[..n]))
        .map(|n| &heard[..n])
}

/// One master of a transparent serial server: bytes in, the line's bytes out.
fn transparent(mut stream: TcpStream, served: &Served, stop: &AtomicBool) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_millis(1)))?;
    stream.set_nodelay(true)?;
    let silence = served.settings.t3_5().max(Duration::from_millis(5));
    let mut buf: Vec<u8> = Vec::with_capacity(512);
    let mut chunk = [0u8; 256];
    let mut last_byte = served.clock.line_now();
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut chunk) {
            Ok(0) => return Ok(()),
            Ok(n) => {
                buf.extend_from_slice(&chunk[..n]);
                last_byte = served.clock.line_now();
            }
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
        let now = served.clock.line_now();
        let ended = !buf.is_empty() && now - last_byte >= silence;
        while let Some(n) = complete_frame(&buf).or(ended.then_some(buf.len())) {
            if n == 0 {
                break;
            }
            let frame: Vec<u8> = buf.drain(..n).collect();
            let _line = served.line.lock().unwrap_or_else(|e| e.into_inner());
            lock(&served.world).advance_to(served.clock.line_now());
            served.frames.fetch_add(1, Ordering::Relaxed);
            let replied = answer(
                &mut stream,
                &served.world,
                &frame,
                served.settings,
                served.clock.as_ref(),
            )
            .map_err(|e| std::io::Error::other(e.to_string()))?;
            if replied {
                served.replies.fetch_add(1, Ordering::Relaxed);
            } else if ended {
                served
                    .noise
                    .fetch_add(frame.len() as u64, Ordering::Relaxed);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_good_frame_is_taken_from_what_the_line_heard() {
        let mut frame = vec![5, 3, 2, 0, 7];
        append_crc(&mut frame);
        let mut twice = frame.clone();
        twice.extend_from_slice(&frame);
        assert_eq!(first_frame(&twice, 5), Some(&frame[..]));
        assert_eq!(first_frame(&frame, 6), None);
        assert_eq!(first_frame(&frame[..5], 5), None);
    }
}
