//! The byte pipe a bus owner drives, and the real serial port.
//!
//! A transport knows the time on its line: a serial port follows the PLC's monotonic clock; the
//! virtual line ([`crate::sim::line::VirtualPort`]) can also run on its own virtual cursor so
//! a whole project replays deterministically.

use std::fmt::Debug;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use serialport::SerialPort;

use crate::line::settings::{LineSettings, Parity};
use crate::time::Clock;

/// A failure of the line itself (not of a device).
#[derive(Debug, thiserror::Error)]
pub enum LineError {
    /// The port could not be opened or configured.
    #[error("cannot open {path}: {source}")]
    Open {
        /// The device path.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// Reading or writing failed (the port went away).
    #[error("serial I/O failed: {0}")]
    Io(#[from] std::io::Error),
    /// Dropping the unread input failed: a late reply could then be read as the answer to
    /// the next request, so the line cannot be trusted.
    #[error("input flush failed: {0}")]
    Flush(std::io::Error),
}

/// How a line failed, as a value that can be kept, compared and copied (a [`LineError`]
/// carries the OS error itself): what was being done, and the OS error's kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum LineFault {
    /// The port could not be opened or configured.
    #[error("cannot open the port: {0}")]
    Open(std::io::ErrorKind),
    /// Reading or writing failed.
    #[error("serial I/O failed: {0}")]
    Io(std::io::ErrorKind),
    /// Dropping the unread input failed.
    #[error("input flush failed: {0}")]
    Flush(std::io::ErrorKind),
}

impl From<&LineError> for LineFault {
    fn from(e: &LineError) -> Self {
        match e {
            LineError::Open { source, .. } => LineFault::Open(source.kind()),
            LineError::Io(e) => LineFault::Io(e.kind()),
            LineError::Flush(e) => LineFault::Flush(e.kind()),
        }
    }
}

/// A half-duplex byte pipe with a notion of time.
pub trait Transport: Send + Debug {
    /// Baud and format.
    fn settings(&self) -> LineSettings;

    /// Time on this line.
    fn now(&self) -> Duration;

    /// Aligns a virtual cursor with the scan's time at the start of a cycle (no-op in real
    /// time).
    fn sync(&mut self, t: Duration) {
        let _ = t;
    }

    /// Sends a whole frame; returns once its last character has left.
    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError>;

    /// Waits until at least one byte has arrived or `deadline` passes; appends what arrived to
    /// `buf` and returns how many bytes (0: the deadline passed in silence).
    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: Duration) -> Result<usize, LineError>;

    /// Keeps the line quiet until `t` (the t3.5 gap, the guard after a timeout).
    fn wait_until(&mut self, t: Duration);

    /// Drops every byte that has arrived and not been read; returns how many. An error means
    /// the input may still hold them ([`LineError::Flush`]): the line has failed.
    fn flush_input(&mut self) -> Result<usize, LineError>;

    /// Opens the port again after it failed (an unplugged adapter plugged back in).
    fn reopen(&mut self) -> Result<(), LineError> {
        Ok(())
    }
}

/// A real serial device (a USB RS-485 adapter, or one end of a pty).
#[derive(Debug)]
pub struct SerialTransport {
    /// `None` only while a reopen is under way (or failed).
    port: Option<serialport::TTYPort>,
    /// Where it was opened from, to reopen it; `None` for a port handed over already open.
    path: Option<PathBuf>,
    settings: LineSettings,
    clock: Arc<dyn Clock>,
}

/// The serial port type softplc uses (a tty: a real adapter or a pty).
pub use serialport::TTYPort;

/// Opens the serial device `path` with `settings` (raw mode, no flow control).
pub fn open_tty(path: &Path, settings: LineSettings) -> Result<TTYPort, LineError> {
    let open_err = |e: serialport::Error| LineError::Open {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.description),
    };
    let builder = serialport::new(path.to_string_lossy(), settings.baud)
        .data_bits(match settings.format.data_bits {
            7 => serialport::DataBits::Seven,
            _ => serialport::DataBits::Eight,
        })
        .parity(match settings.format.parity {
            Parity::None => serialport::Parity::None,
            Parity::Even => serialport::Parity::Even,
            Parity::Odd => serialport::Parity::Odd,
        })
        .stop_bits(match settings.format.stop_bits {
            2 => serialport::StopBits::Two,
            _ => serialport::StopBits::One,
        })
        .flow_control(serialport::FlowControl::None)
        .timeout(Duration::from_millis(1));
    serialport::TTYPort::open(&builder).map_err(open_err)
}

/// Creates a pty pair in-process: `(master, slave, slave path)`. Whatever is written to one
/// end is read at the other; the slave's path can be handed to any serial program.
pub fn pty_pair() -> Result<(TTYPort, TTYPort, String), LineError> {
    let (master, slave) = TTYPort::pair().map_err(|e| LineError::Open {
        path: PathBuf::from("/dev/ptmx"),
        source: std::io::Error::other(e.description),
    })?;
    let name = slave.name().unwrap_or_else(|| "(unnamed pty)".to_string());
    Ok((master, slave, name))
}

impl SerialTransport {
    /// Opens `path` with `settings`; time is read from `clock`.
    pub fn open(
        path: &Path,
        settings: LineSettings,
        clock: Arc<dyn Clock>,
    ) -> Result<Self, LineError> {
        let port = open_tty(path, settings)?;
        let mut t = Self::from_port(port, settings, clock);
        t.path = Some(path.to_path_buf());
        Ok(t)
    }

    /// Wraps an already open port (one end of an in-process pty pair, in tests).
    pub fn from_port(
        mut port: serialport::TTYPort,
        settings: LineSettings,
        clock: Arc<dyn Clock>,
    ) -> Self {
        // A pty refuses exclusive mode on some kernels; the port works the same without it.
        let _ = port.set_exclusive(false);
        Self {
            port: Some(port),
            path: None,
            settings,
            clock,
        }
    }
}

impl SerialTransport {
    fn port(&mut self) -> Result<&mut TTYPort, LineError> {
        self.port.as_mut().ok_or_else(|| {
            LineError::Io(std::io::Error::new(
                std::io::ErrorKind::NotConnected,
                "the port is closed",
            ))
        })
    }
}

impl Transport for SerialTransport {
    fn reopen(&mut self) -> Result<(), LineError> {
        let Some(path) = self.path.clone() else {
            return Err(LineError::Io(std::io::Error::new(
                std::io::ErrorKind::Unsupported,
                "a port handed over open cannot be reopened",
            )));
        };
        // Close first: the old descriptor holds the device's exclusive lock, and a replugged
        // adapter gets its name back only once every descriptor of the old one is closed.
        self.port = None;
        self.port = Some(open_tty(&path, self.settings)?);
        Ok(())
    }

    fn settings(&self) -> LineSettings {
        self.settings
    }

    fn now(&self) -> Duration {
        self.clock.now()
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        let start = self.clock.now();
        let port = self.port()?;
        port.write_all(frame)?;
        // tcdrain: on a real UART this returns once the last character has left.
        port.flush()?;
        // A pty drains at once; keep the line busy for the frame's wire time all the same, so
        // timing on a pty matches the wire (on a UART this deadline has already passed).
        self.clock
            .sleep_until(start + self.settings.chars(frame.len()));
        Ok(())
    }

    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: Duration) -> Result<usize, LineError> {
        let mut chunk = [0u8; 256];
        loop {
            let now = self.clock.now();
            let port = self.port()?;
            if now >= deadline {
                // The thread may have been descheduled past the deadline with the reply already
                // waiting: take what is there before calling it a timeout.
                let waiting = port.bytes_to_read().unwrap_or(0) as usize;
                if waiting == 0 {
                    return Ok(0);
                }
                port.set_timeout(Duration::from_micros(100))
                    .map_err(|e| std::io::Error::other(e.description))?;
                return match port.read(&mut chunk) {
                    Ok(n) => {
                        buf.extend_from_slice(&chunk[..n]);
                        Ok(n)
                    }
                    Err(e)
                        if matches!(
                            e.kind(),
                            std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                        ) =>
                    {
                        Ok(0)
                    }
                    Err(e) => Err(e.into()),
                };
            }
            let wait = (deadline - now).max(Duration::from_micros(100));
            port.set_timeout(wait)
                .map_err(|e| std::io::Error::other(e.description))?;
            match port.read(&mut chunk) {
                Ok(0) => continue,
                Ok(n) => {
                    buf.extend_from_slice(&chunk[..n]);
                    return Ok(n);
                }
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            }
        }
    }

    fn wait_until(&mut self, t: Duration) {
        self.clock.sleep_until(t);
    }

    fn flush_input(&mut self) -> Result<usize, LineError> {
        let port = self.port()?;
        // Only counted: a port that cannot say how much is waiting can still drop it.
        let pending = port.bytes_to_read().unwrap_or(0) as usize;
        port.clear(serialport::ClearBuffer::Input)
            .map_err(|e| LineError::Flush(std::io::Error::from(e)))?;
        Ok(pending)
    }
}
