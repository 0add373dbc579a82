//! RTU over TCP: a serial device server that passes the bytes of its RS-485 line through a
//! TCP connection (its "transparent" or "raw" mode). Framed by our own RTU codec, with the
//! bus owner's full discipline (response timeout, guard and flush after a miss, reply
//! verification, CRC).
//!
//! Why not tokio-modbus here: its RTU client can be attached to a TCP stream, but it is the
//! RTU client DESIGN.md principle 4 rules out: nothing drops a late reply, so the answer to a
//! timed-out request would be taken as the answer to the next one, and RTU frames carry no
//! transaction id to tell them apart. This transport is a byte pipe like a serial port; the
//! line behind the server is the bus's `baud:` and `format:`, and its timing (t3.5, the guard
//! after a timeout, the budget) is that line's.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::Arc;
use std::time::Duration;

use crate::line::settings::LineSettings;
use crate::line::tcp::endpoint::TcpEndpoint;
use crate::line::transport::{LineError, Transport};
use crate::time::{Clock, LineInstant};

/// A byte pipe to a serial device server.
#[derive(Debug)]
pub struct RtuOverTcpTransport {
    endpoint: TcpEndpoint,
    stream: Option<TcpStream>,
    settings: LineSettings,
    connect_timeout: Duration,
    clock: Arc<dyn Clock>,
}

impl RtuOverTcpTransport {
    /// A pipe to `endpoint`, whose serial side runs at `settings`; nothing is connected yet
    /// (the first exchange connects).
    pub fn new(
        endpoint: TcpEndpoint,
        settings: LineSettings,
        connect_timeout: Duration,
        clock: Arc<dyn Clock>,
    ) -> Self {
        Self {
            endpoint,
            stream: None,
            settings,
            connect_timeout,
            clock,
        }
    }

    fn connect(&mut self) -> Result<(), LineError> {
        let connect_err = |source| LineError::Connect {
            endpoint: self.endpoint.to_string(),
            source,
        };
        let mut last =
            std::io::Error::new(ErrorKind::NotFound, "the host name resolves to nothing");
        let addrs = self
            .endpoint
            .authority()
            .to_socket_addrs()
            .map_err(connect_err)?;
        for addr in addrs {
            match TcpStream::connect_timeout(&addr, self.connect_timeout) {
                Ok(stream) => {
                    stream.set_nodelay(true).map_err(connect_err)?;
                    self.stream = Some(stream);
                    return Ok(());
                }
                Err(e) => last = e,
            }
        }
        Err(connect_err(last))
    }

    fn stream(&mut self) -> Result<&mut TcpStream, LineError> {
        if self.stream.is_none() {
            self.connect()?;
        }
        self.stream.as_mut().ok_or_else(|| {
            LineError::Io(std::io::Error::new(
                ErrorKind::NotConnected,
                "not connected",
            ))
        })
    }

    /// The connection failed: drop it, so the bus owner's reopen makes a new one.
    fn failed(&mut self, e: std::io::Error) -> LineError {
        self.stream = None;
        LineError::Io(e)
    }
}

impl Transport for RtuOverTcpTransport {
    fn settings(&self) -> LineSettings {
        self.settings
    }

    fn now(&self) -> LineInstant {
        self.clock.line_now()
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        let start = self.now();
        let stream = self.stream()?;
        if let Err(e) = stream.write_all(frame) {
            return Err(self.failed(e));
        }
        // The server sends it on its line at the line's baud: the response timeout counts
        // from when its last character has left there, as on a local port.
        self.wait_until(start + self.settings.chars(frame.len()));
        Ok(())
    }

    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        let mut chunk = [0u8; 256];
        loop {
            let now = self.now();
            let wait = (deadline - now).max(Duration::from_micros(100));
            let past = now >= deadline;
            let stream = self.stream()?;
            if let Err(e) = stream.set_read_timeout(Some(wait)) {
                return Err(self.failed(e));
            }
            match stream.read(&mut chunk) {
                Ok(0) => {
                    return Err(self.failed(std::io::Error::new(
                        ErrorKind::UnexpectedEof,
                        "the server closed the connection",
                    )))
                }
                Ok(n) => {
                    buf.extend_from_slice(&chunk[..n]);
                    return Ok(n);
                }
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    if past {
                        return Ok(0);
                    }
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(self.failed(e)),
            }
        }
    }

    fn wait_until(&mut self, t: LineInstant) {
        self.clock.sleep_until_on_line(t);
    }

    fn flush_input(&mut self) -> Result<usize, LineError> {
        // The first exchange connects here: it is the first thing every exchange does.
        let stream = self.stream()?;
        let mut dropped = 0;
        let mut chunk = [0u8; 256];
        if let Err(e) = stream.set_nonblocking(true) {
            return Err(self.failed(e));
        }
        let result = loop {
            match stream.read(&mut chunk) {
                Ok(0) => {
                    break Err(std::io::Error::new(
                        ErrorKind::UnexpectedEof,
                        "the server closed the connection",
                    ))
                }
                Ok(n) => dropped += n,
                Err(e) if e.kind() == ErrorKind::WouldBlock => break Ok(()),
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => break Err(e),
            }
        };
        let blocking = stream.set_nonblocking(false);
        match result.and(blocking) {
            Ok(()) => Ok(dropped),
            Err(e) => Err(self.failed(e)),
        }
    }

    fn reopen(&mut self) -> Result<(), LineError> {
        self.stream = None;
        self.connect()
    }
}
