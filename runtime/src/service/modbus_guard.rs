//! What stands between a Modbus TCP client and tokio-modbus's frame decoder: a bound on frame
//! size, a check of the frames its decoder cannot take, an idle timeout counted from the last
//! completed exchange, a deadline for each reply to be taken, and a limit on the number of
//! clients.
//!
//! tokio-modbus 0.17 panics on an FC 15 frame whose quantity needs more bytes than its byte
//! count gives (an index past its buffer), and multiplies an FC 16/23 quantity by two in `u16`
//! (an overflow panic in debug builds). The guard passes only whole MBAP frames of at most 260
//! bytes (the protocol's maximum: 7-byte header + 253-byte PDU) whose counts agree; anything
//! else closes the connection, as tokio-modbus itself does for a frame it cannot decode.

use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::time::{Instant, Sleep};

/// MBAP header length (transaction, protocol, length, unit).
const HEADER: usize = 7;
/// Largest value of the MBAP length field: the unit byte + a 253-byte PDU.
const MAX_LENGTH_FIELD: usize = 254;

/// Why a frame was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Malformed {
    /// The MBAP length field is below 2 (unit + function) or above 254.
    #[error("MBAP length {0} is outside 2..=254")]
    Length(usize),
    /// A write whose quantity, byte count and frame length disagree.
    #[error("function {0:#04x}: quantity, byte count and length disagree")]
    Counts(u8),
}

/// The length of the leading whole frames of `buf` that pass the checks (the rest is an
/// incomplete frame, to be completed by the next read), or why the stream must be closed.
pub fn whole_frames(buf: &[u8]) -> Result<usize, Malformed> {
    let mut at = 0;
    loop {
        let Some(header) = buf.get(at..at + HEADER) else {
            return Ok(at);
        };
        let length = usize::from(u16::from_be_bytes([header[4], header[5]]));
        if !(2..=MAX_LENGTH_FIELD).contains(&length) {
            return Err(Malformed::Length(length));
        }
        let total = HEADER - 1 + length;
        let Some(frame) = buf.get(at..at + total) else {
            return Ok(at);
        };
        check_pdu(&frame[HEADER..])?;
        at += total;
    }
}

/// Checks the counts of the writes tokio-modbus cannot decode safely; other PDUs pass.
pub fn check_pdu(pdu: &[u8]) -> Result<(), Malformed> {
    let u16_at = |i: usize| {
        pdu.get(i..i + 2)
            .map(|b| usize::from(u16::from_be_bytes([b[0], b[1]])))
    };
    let byte_at = |i: usize| pdu.get(i).map(|&b| usize::from(b));
    let Some(&function) = pdu.first() else {
        return Ok(());
    };
    let ok = match function {
        // address, quantity, byte count, packed bits
        0x0F => match (u16_at(3), byte_at(5)) {
            (Some(q), Some(n)) => n == q.div_ceil(8) && pdu.len() == 6 + n,
            _ => false,
        },
        // address, quantity, byte count, registers
        0x10 => match (u16_at(3), byte_at(5)) {
            (Some(q), Some(n)) => n == 2 * q && pdu.len() == 6 + n,
            _ => false,
        },
        // read address, read quantity, write address, write quantity, byte count, registers
        0x17 => match (u16_at(7), byte_at(9)) {
            (Some(q), Some(n)) => n == 2 * q && pdu.len() == 10 + n,
            _ => false,
        },
        _ => true,
    };
    if ok {
        Ok(())
    } else {
        Err(Malformed::Counts(function))
    }
}

/// One of a limited number of client slots, given back on drop.
#[derive(Debug)]
pub(crate) struct ClientSlot(Arc<AtomicUsize>);

impl ClientSlot {
    /// Takes a slot if fewer than `max` are taken.
    pub(crate) fn take(count: &Arc<AtomicUsize>, max: usize) -> Option<Self> {
        count
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |n| {
                (n < max).then_some(n + 1)
            })
            .ok()
            .map(|_| Self(count.clone()))
    }
}

impl Drop for ClientSlot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

/// How long a client may take: to finish an exchange once the previous one ended (or it
/// connected), and to take a reply the server is sending.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Patience {
    /// From the end of the last completed exchange (a reply sent) or the connection, to the
    /// next request arriving whole; a client that sends nothing, or a frame byte by byte, is
    /// disconnected once it passes.
    pub idle: Duration,
    /// From the first byte of a reply to its last one taken by the socket; a client that does
    /// not read its replies is disconnected once it passes.
    pub send: Duration,
}

/// A client stream that releases only whole, checked frames to the decoder, and fails with
/// `TimedOut` when the client does not complete an exchange within [`Patience::idle`] of the
/// previous one, or does not take a reply within [`Patience::send`].
///
/// An exchange is complete when the reply has been flushed to the socket. The idle clock is
/// not restarted by bytes that do not complete a frame (a client dribbling a frame byte by
/// byte keeps its slot no longer than a silent one), and it runs only while the server waits
/// for the client: a write the scan takes seconds to apply does not count against it.
#[derive(Debug)]
pub(crate) struct FrameGuard<T> {
    inner: T,
    /// Received, not yet a whole frame.
    pending: Vec<u8>,
    /// Whole checked frames not yet read by the decoder.
    ready: Vec<u8>,
    ready_at: usize,
    patience: Patience,
    /// Ends the wait for the next request.
    idle: Pin<Box<Sleep>>,
    /// Ends the wait for the client to take the reply being sent, once one is.
    send: Option<Pin<Box<Sleep>>>,
    _slot: ClientSlot,
}

impl<T> FrameGuard<T> {
    /// Guards `inner`, holding `slot` until dropped.
    pub(crate) fn new(inner: T, slot: ClientSlot, patience: Patience) -> Self {
        Self {
            inner,
            pending: Vec::with_capacity(512),
            ready: Vec::with_capacity(512),
            ready_at: 0,
            patience,
            idle: Box::pin(tokio::time::sleep(patience.idle)),
            send: None,
            _slot: slot,
        }
    }

    /// Fails once the reply being sent has waited longer than [`Patience::send`]; starts
    /// that clock at the reply's first write. Registers the waker for the deadline.
    fn poll_send_deadline(&mut self, cx: &mut Context<'_>) -> Poll<io::Error> {
        let patience = self.patience.send;
        let sleep = self
            .send
            .get_or_insert_with(|| Box::pin(tokio::time::sleep(patience)));
        match sleep.as_mut().poll(cx) {
            Poll::Ready(()) => Poll::Ready(io::Error::new(
                io::ErrorKind::TimedOut,
                "the client did not take its reply in time",
            )),
            Poll::Pending => Poll::Pending,
        }
    }
}

fn idle_error() -> io::Error {
    io::Error::new(
        io::ErrorKind::TimedOut,
        "the client completed no request in time",
    )
}

impl<T: AsyncRead + Unpin> AsyncRead for FrameGuard<T> {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        loop {
            if this.ready_at < this.ready.len() {
                let n = buf.remaining().min(this.ready.len() - this.ready_at);
                buf.put_slice(&this.ready[this.ready_at..this.ready_at + n]);
                this.ready_at += n;
                return Poll::Ready(Ok(()));
            }
            // Judged before taking more bytes, so a request completed after the deadline is
            // refused even when this task runs late.
            if this.idle.deadline() <= Instant::now() {
                return Poll::Ready(Err(idle_error()));
            }
            let mut chunk = [0u8; 512];
            let mut rb = ReadBuf::new(&mut chunk);
            match Pin::new(&mut this.inner).poll_read(cx, &mut rb) {
                Poll::Ready(Ok(())) => {
                    let got = rb.filled();
                    if got.is_empty() {
                        // End of stream; an incomplete frame is dropped with the connection.
                        return Poll::Ready(Ok(()));
                    }
                    this.pending.extend_from_slice(got);
                    let n = whole_frames(&this.pending)
                        .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))?;
                    this.ready.clear();
                    this.ready_at = 0;
                    this.ready.extend(this.pending.drain(..n));
                }
                Poll::Ready(Err(e)) => return Poll::Ready(Err(e)),
                Poll::Pending => {
                    if this.idle.as_mut().poll(cx).is_ready() {
                        return Poll::Ready(Err(idle_error()));
                    }
                    return Poll::Pending;
                }
            }
        }
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for FrameGuard<T> {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        match Pin::new(&mut this.inner).poll_write(cx, buf) {
            Poll::Pending => this.poll_send_deadline(cx).map(Err),
            done => {
                // The reply's clock starts at its first write, blocked or not.
                let patience = this.patience.send;
                this.send
                    .get_or_insert_with(|| Box::pin(tokio::time::sleep(patience)));
                done
            }
        }
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        match Pin::new(&mut this.inner).poll_flush(cx) {
            Poll::Ready(Ok(())) => {
                // The reply is out: the exchange is complete, the wait for the next begins.
                if this.send.take().is_some() {
                    let next = Instant::now() + this.patience.idle;
                    this.idle.as_mut().reset(next);
                }
                Poll::Ready(Ok(()))
            }
            Poll::Pending => this.poll_send_deadline(cx).map(Err),
            Poll::Ready(Err(e)) => Poll::Ready(Err(e)),
        }
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_shutdown(cx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(pdu: &[u8]) -> Vec<u8> {
        let len = (pdu.len() + 1) as u16;
        let mut f = vec![0, 1, 0, 0];
        f.extend_from_slice(&len.to_be_bytes());
        f.push(1);
        f.extend_from_slice(pdu);
        f
    }

    #[test]
    fn passes_whole_frames_and_waits_for_the_rest() {
        let read = frame(&[0x03, 0, 0, 0, 2]);
        let mut two = read.clone();
        two.extend_from_slice(&read);
        assert_eq!(whole_frames(&two), Ok(24));
        assert_eq!(whole_frames(&two[..20]), Ok(12));
        assert_eq!(whole_frames(&two[..5]), Ok(0));
        assert_eq!(whole_frames(&[]), Ok(0));
    }

    #[test]
    fn refuses_what_the_decoder_cannot_take() {
        // FC 15: 100 coils announced with a 1-byte payload (tokio-modbus indexes past it).
        assert_eq!(
            whole_frames(&frame(&[0x0F, 0, 0, 0, 100, 1, 0xFF])),
            Err(Malformed::Counts(0x0F))
        );
        assert_eq!(
            whole_frames(&frame(&[0x0F, 0, 0, 0, 9, 2, 0xFF, 1])),
            Ok(15)
        );
        // FC 16: quantity 0x8000 (overflows `quantity * 2` in u16).
        assert_eq!(
            whole_frames(&frame(&[0x10, 0, 0, 0x80, 0, 0])),
            Err(Malformed::Counts(0x10))
        );
        assert_eq!(
            whole_frames(&frame(&[0x17, 0, 0, 0, 1, 0, 0, 0x80, 0, 0])),
            Err(Malformed::Counts(0x17))
        );
        // Length field out of range.
        assert_eq!(
            whole_frames(&[0, 1, 0, 0, 0xFF, 0xFF, 1]),
            Err(Malformed::Length(65535))
        );
        assert_eq!(
            whole_frames(&[0, 1, 0, 0, 0, 0, 1]),
            Err(Malformed::Length(0))
        );
    }

    #[test]
    fn no_byte_string_panics() {
        // Every short string over a small alphabet of interesting bytes.
        let alphabet = [0u8, 1, 2, 6, 7, 0x0F, 0x10, 0x17, 0x80, 0xFF];
        let mut buf = vec![0u8, 1, 0, 0, 0, 0, 1];
        for len in 0..=6u8 {
            buf[5] = len;
            for &a in &alphabet {
                for &b in &alphabet {
                    for &c in &alphabet {
                        buf.truncate(7);
                        buf.extend_from_slice(&[a, b, c, a, b, c]);
                        let _ = whole_frames(&buf);
                        let _ = check_pdu(&buf[7..]);
                    }
                }
            }
        }
    }

    /// A guarded server side and a std client of one loopback connection, on `rt`.
    fn pair(
        rt: &tokio::runtime::Runtime,
        patience: Patience,
    ) -> (FrameGuard<tokio::net::TcpStream>, std::net::TcpStream) {
        rt.block_on(async {
            let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            let client = std::net::TcpStream::connect(listener.local_addr().unwrap()).unwrap();
            let (server, _) = listener.accept().await.unwrap();
            let count = Arc::new(AtomicUsize::new(0));
            let slot = ClientSlot::take(&count, 1).unwrap();
            (FrameGuard::new(server, slot, patience), client)
        })
    }

    fn runtime() -> tokio::runtime::Runtime {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap()
    }

    #[test]
    fn a_reply_the_client_does_not_take_times_out() {
        use tokio::io::AsyncWriteExt;
        let rt = runtime();
        let patience = Patience {
            idle: Duration::from_secs(60),
            send: Duration::from_millis(200),
        };
        let (mut guard, _client) = pair(&rt, patience);
        // Far more than the socket buffers hold; the client never reads.
        let reply = vec![0u8; 64 << 20];
        let started = std::time::Instant::now();
        let r = rt.block_on(async {
            tokio::time::timeout(Duration::from_secs(20), async {
                guard.write_all(&reply).await?;
                guard.flush().await
            })
            .await
        });
        let e = r.expect("the write was never given up").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::TimedOut, "{e}");
        assert!(started.elapsed() < Duration::from_secs(10));
    }

    #[test]
    fn a_frame_dribbled_slower_than_the_idle_timeout_is_refused() {
        use tokio::io::AsyncReadExt;
        let rt = runtime();
        let patience = Patience {
            idle: Duration::from_millis(300),
            send: Duration::from_secs(60),
        };
        let (mut guard, mut client) = pair(&rt, patience);
        let dribble = std::thread::spawn(move || {
            for b in frame(&[0x03, 0, 0, 0, 1]) {
                if std::io::Write::write_all(&mut client, &[b]).is_err() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(100));
            }
            client
        });
        let mut got = [0u8; 12];
        let r = rt.block_on(async {
            tokio::time::timeout(Duration::from_secs(20), guard.read(&mut got)).await
        });
        let e = r.expect("the read never gave up").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::TimedOut, "{e}");
        drop(guard);
        // The dribbler fails its writes once the guard is gone; only its end matters here.
        drop(dribble.join());
    }

    #[test]
    fn each_completed_exchange_restarts_the_idle_clock() {
        use std::io::{Read, Write};
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        let rt = runtime();
        let patience = Patience {
            idle: Duration::from_secs(2),
            send: Duration::from_secs(60),
        };
        let (mut guard, mut client) = pair(&rt, patience);
        let request = frame(&[0x03, 0, 0, 0, 1]);
        let client = std::thread::spawn(move || {
            // Eight exchanges, 0.4 s apart: 3.2 s in all, more than the idle timeout, each
            // well within it of the previous reply.
            for _ in 0..8 {
                std::thread::sleep(Duration::from_millis(400));
                client.write_all(&request).unwrap();
                let mut reply = [0u8; 2];
                client.read_exact(&mut reply).unwrap();
                assert_eq!(reply, [0xAB, 0xCD]);
            }
        });
        rt.block_on(async {
            for _ in 0..8 {
                let mut got = [0u8; 12];
                guard.read_exact(&mut got).await.unwrap();
                guard.write_all(&[0xAB, 0xCD]).await.unwrap();
                guard.flush().await.unwrap();
            }
        });
        client.join().unwrap();
    }

    #[test]
    fn client_slots_are_limited_and_given_back() {
        let count = Arc::new(AtomicUsize::new(0));
        let a = ClientSlot::take(&count, 2);
        let b = ClientSlot::take(&count, 2);
        assert!(a.is_some() && b.is_some());
        assert!(ClientSlot::take(&count, 2).is_none());
        drop(a);
        assert!(ClientSlot::take(&count, 2).is_some());
    }
}
