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

use crate::line::latency::{AdapterLatency, SysfsRoot};
use crate::line::settings::{LineSettings, Parity};
use crate::time::{Clock, LineInstant};

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
    /// The port refused kernel RS-485 mode (a pty, a USB adapter whose driver has no
    /// RS-485 support): `setting` is the project key it was asked for.
    #[error("{} does not support kernel RS-485 mode ({setting}): {source}", path.display())]
    Rs485 {
        /// The device path.
        path: PathBuf,
        /// The project key (`rs485.rts_on_send`).
        setting: &'static str,
        /// The OS error.
        source: std::io::Error,
    },
    /// The port took kernel RS-485 mode but reads back another value for one setting (the
    /// kernel reverts what the driver does not support).
    #[error("{} kept {setting} at {got}, not {asked} as configured (its driver does not support it)", path.display())]
    Rs485Kept {
        /// The device path.
        path: PathBuf,
        /// The project key (`rs485.delay_after_send`).
        setting: &'static str,
        /// What the project asks, in the key's own words (`5 ms`, `true`).
        asked: String,
        /// What the port reads back.
        got: String,
    },
    /// `echo: discard`: the request's echo did not come back as sent (see `line/echo.rs`).
    #[error("{0}")]
    Echo(crate::line::echo::EchoFault),
    /// A network bus could not connect to its endpoint (refused, unreachable, no answer
    /// within the connect timeout, a name that does not resolve).
    #[error("cannot connect to {endpoint}: {source}")]
    Connect {
        /// The endpoint, as the project gives it (`tcp://10.0.0.7:502`).
        endpoint: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The adapter's latency timer stays above the `adapter_latency` the project demands
    /// (see `line/latency.rs`).
    #[error("{0}")]
    Latency(Box<crate::line::latency::LatencyRefused>),
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
    /// The request's echo was wrong or missing (`echo: discard`), or came back unasked.
    #[error("{0}")]
    Echo(crate::line::echo::EchoFault),
    /// A network bus could not connect to its endpoint.
    #[error("cannot connect: {0}")]
    Connect(std::io::ErrorKind),
}

impl From<&LineError> for LineFault {
    fn from(e: &LineError) -> Self {
        match e {
            LineError::Open { source, .. } => LineFault::Open(source.kind()),
            LineError::Io(e) => LineFault::Io(e.kind()),
            LineError::Flush(e) => LineFault::Flush(e.kind()),
            LineError::Rs485 { source, .. } => LineFault::Open(source.kind()),
            LineError::Rs485Kept { .. } | LineError::Latency(_) => {
                LineFault::Open(std::io::ErrorKind::Unsupported)
            }
            LineError::Echo(f) => LineFault::Echo(*f),
            LineError::Connect { source, .. } => LineFault::Connect(source.kind()),
        }
    }
}

/// A half-duplex byte pipe with a notion of time.
pub trait Transport: Send + Debug {
    /// Baud and format.
    fn settings(&self) -> LineSettings;

    /// Time on this line.
    fn now(&self) -> LineInstant;

    /// Aligns a virtual cursor with the scan's time at the start of a cycle (no-op in real
    /// time): `t` is the scan's time mapped onto the line's clock.
    fn sync(&mut self, t: LineInstant) {
        let _ = t;
    }

    /// Sends a whole frame; returns once its last character has left.
    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError>;

    /// Waits until at least one byte has arrived or `deadline` passes; appends what arrived to
    /// `buf` and returns how many bytes (0: the deadline passed in silence).
    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError>;

    /// Keeps the line quiet until `t` (the t3.5 gap, the guard after a timeout).
    fn wait_until(&mut self, t: LineInstant);

    /// Drops every byte that has arrived and not been read; returns how many. An error means
    /// the input may still hold them ([`LineError::Flush`]): the line has failed.
    fn flush_input(&mut self) -> Result<usize, LineError>;

    /// Opens the port again after it failed (an unplugged adapter plugged back in).
    fn reopen(&mut self) -> Result<(), LineError> {
        Ok(())
    }

    /// The channel that carries Modbus requests whole, when this transport frames them itself
    /// (Modbus TCP: the MBAP header and its transaction id replace the RTU address, CRC and
    /// silences); `None` for a byte pipe the RTU codec frames.
    fn pdu_channel(&mut self) -> Option<&mut dyn PduChannel> {
        None
    }
}

/// Why a request on a [`PduChannel`] brought no usable answer.
#[derive(Debug)]
pub enum CallMiss {
    /// No answer within the response timeout (or a gateway said its target did not answer).
    Silence,
    /// An answer that is not the request's (transaction id, function, byte count, echo) or
    /// not Modbus at all.
    Bad(crate::modbus::master::ReplyError),
    /// The connection failed or could not be made.
    Line(LineError),
}

/// A transport that carries Modbus requests as whole messages (see
/// [`Transport::pdu_channel`]).
pub trait PduChannel {
    /// Sends `request` to `unit` and waits at most `timeout` for its answer; an exception is
    /// an answer ([`crate::modbus::Response::Exception`]).
    fn call(
        &mut self,
        unit: u8,
        request: &crate::modbus::Request,
        timeout: Duration,
    ) -> Result<crate::modbus::Response, CallMiss>;
}

/// A real serial device (a USB RS-485 adapter, or one end of a pty).
#[derive(Debug)]
pub struct SerialTransport {
    /// `None` only while a reopen is under way (or failed).
    port: Option<serialport::TTYPort>,
    /// Where it was opened from, to reopen it; `None` for a port handed over already open.
    path: Option<PathBuf>,
    settings: LineSettings,
    /// Kernel RS-485 mode, applied again on every reopen.
    rs485: Option<Rs485Mode>,
    /// The adapter's latency timer: what to ask of it, and where sysfs is; applied again on
    /// every reopen (a replugged FTDI adapter comes back at 16 ms).
    latency: Option<(AdapterLatency, SysfsRoot)>,
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

    /// A port that could not be opened at start (a USB adapter not enumerated yet): the line
    /// starts down, and [`Transport::reopen`] opens `path` when it appears, applying `rs485`
    /// and the adapter `latency` then, as a reopen after an unplug does.
    pub fn open_later(
        path: &Path,
        settings: LineSettings,
        clock: Arc<dyn Clock>,
        rs485: Option<Rs485Mode>,
        latency: (AdapterLatency, SysfsRoot),
    ) -> Self {
        Self {
            port: None,
            path: Some(path.to_path_buf()),
            settings,
            rs485,
            latency: Some(latency),
            clock,
        }
    }

    /// Wraps an already open port (one end of an in-process pty pair, in tests).
    pub fn from_port(
        mut port: serialport::TTYPort,
        settings: LineSettings,
        clock: Arc<dyn Clock>,
    ) -> Self {
        // A pty refuses exclusive mode on some kernels; the port works the same without it.
        drop(port.set_exclusive(false));
        Self {
            port: Some(port),
            path: None,
            settings,
            rs485: None,
            latency: None,
            clock,
        }
    }
}

impl SerialTransport {
    /// Puts the port in kernel RS-485 mode (the UART drives RTS, hence the transceiver's
    /// direction, itself) and reads the mode back; kept for every reopen. A port that refuses
    /// it, or keeps a setting other than asked, is an error, never a silent success.
    pub fn set_rs485(&mut self, mode: Rs485Mode) -> Result<(), LineError> {
        let path = self
            .path
            .clone()
            .unwrap_or_else(|| PathBuf::from("(port handed over open)"));
        apply_rs485(self.port()?, &path, mode)?;
        self.rs485 = Some(mode);
        Ok(())
    }

    /// Brings the adapter's latency timer down to 1 ms where it is higher
    /// (`crate::line::latency::apply`, sysfs under `root`) and logs what the port has; kept
    /// for every reopen. Returns the latency the port has now; an error only when `config`
    /// demands a ceiling the port stays above.
    pub fn set_adapter_latency(
        &mut self,
        config: AdapterLatency,
        root: SysfsRoot,
    ) -> Result<Duration, LineError> {
        let path = self
            .path
            .clone()
            .unwrap_or_else(|| PathBuf::from("(port handed over open)"));
        let latency = crate::line::latency::apply(config, &root, self.port()?, &path)
            .map_err(|e| LineError::Latency(Box::new(e)))?;
        self.latency = Some((config, root));
        Ok(latency)
    }

    fn port(&mut self) -> Result<&mut TTYPort, LineError> {
        self.port.as_mut().ok_or_else(|| {
            LineError::Io(std::io::Error::new(
                std::io::ErrorKind::NotConnected,
                "the port is closed",
            ))
        })
    }
}

/// Kernel RS-485 mode of a UART (`TIOCSRS485`, Documentation/driver-api/serial/serial-rs485.rst):
/// the driver raises RTS for the frame and drops it after, so a transceiver whose DE is wired to
/// RTS turns around with the frame. USB adapters switch in hardware and do not need it (most
/// refuse it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rs485Mode {
    /// RTS is high while sending (and low after); `false` inverts it.
    pub rts_on_send: bool,
    /// RTS raised this long before the first character (whole ms; the kernel caps at 100 ms).
    pub delay_before_send: Duration,
    /// RTS held this long after the last character (whole ms; the kernel caps at 100 ms).
    pub delay_after_send: Duration,
}

impl Rs485Mode {
    /// The longest delay the kernel accepts (`RS485_MAX_RTS_DELAY`).
    pub const MAX_DELAY: Duration = Duration::from_millis(100);
}

/// `SER_RS485_*` flags of `include/uapi/linux/serial.h`.
const SER_RS485_ENABLED: u32 = 1 << 0;
const SER_RS485_RTS_ON_SEND: u32 = 1 << 1;
const SER_RS485_RTS_AFTER_SEND: u32 = 1 << 2;

/// `struct serial_rs485` (32 bytes; `libc` has the ioctl numbers but not the struct).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct SerialRs485 {
    flags: u32,
    delay_rts_before_send: u32,
    delay_rts_after_send: u32,
    padding: [u32; 5],
}

fn ms(d: Duration) -> u32 {
    u32::try_from(d.as_millis()).unwrap_or(u32::MAX)
}

impl SerialRs485 {
    fn encode(mode: Rs485Mode) -> Self {
        let rts = if mode.rts_on_send {
            SER_RS485_RTS_ON_SEND
        } else {
            SER_RS485_RTS_AFTER_SEND
        };
        Self {
            flags: SER_RS485_ENABLED | rts,
            delay_rts_before_send: ms(mode.delay_before_send),
            delay_rts_after_send: ms(mode.delay_after_send),
            padding: [0; 5],
        }
    }

    /// The first setting the port kept other than asked: `(key, asked, got)`.
    fn differs(self, mode: Rs485Mode) -> Option<(&'static str, String, String)> {
        let want = Self::encode(mode);
        if self.flags & SER_RS485_ENABLED == 0 {
            return Some(("rs485", "enabled".into(), "disabled".into()));
        }
        let on_send = self.flags & SER_RS485_RTS_ON_SEND != 0;
        if on_send != mode.rts_on_send {
            return Some((
                "rs485.rts_on_send",
                mode.rts_on_send.to_string(),
                on_send.to_string(),
            ));
        }
        if self.delay_rts_before_send != want.delay_rts_before_send {
            return Some((
                "rs485.delay_before_send",
                format!("{} ms", want.delay_rts_before_send),
                format!("{} ms", self.delay_rts_before_send),
            ));
        }
        if self.delay_rts_after_send != want.delay_rts_after_send {
            return Some((
                "rs485.delay_after_send",
                format!("{} ms", want.delay_rts_after_send),
                format!("{} ms", self.delay_rts_after_send),
            ));
        }
        None
    }
}

/// One RS-485 ioctl on `port` (`TIOCSRS485` or `TIOCGRS485`). Written here rather than taken
/// from a crate: `serial2`'s `rs4xx` would mean opening the port with a second serial crate
/// (softplc opens it with `serialport`, which has no RS-485 API), and the `rs485` crate
/// hard-codes the x86/arm ioctl numbers (wrong on mips, powerpc, sparc) and dates from 2017;
/// `libc` has the right numbers for every architecture.
#[allow(unsafe_code)] // one ioctl; see SAFETY below
fn rs485_ioctl(
    port: &TTYPort,
    request: libc::Ioctl,
    conf: &mut SerialRs485,
) -> std::io::Result<()> {
    use std::os::fd::AsRawFd;
    // SAFETY: the descriptor is open for as long as `port` is borrowed, and both requests
    // read or write exactly one `struct serial_rs485`, which `SerialRs485` lays out (repr(C),
    // 8 u32s = 32 bytes) and `conf` points to for the whole call.
    let rc = unsafe { libc::ioctl(port.as_raw_fd(), request, conf as *mut SerialRs485) };
    if rc < 0 {
        Err(std::io::Error::last_os_error())
    } else {
        Ok(())
    }
}

/// Sets `mode` and reads it back: the kernel reverts what the driver does not support, and a
/// GET alone proves nothing (it succeeds on ports without RS-485).
fn apply_rs485(port: &TTYPort, path: &Path, mode: Rs485Mode) -> Result<(), LineError> {
    let refused = |source| LineError::Rs485 {
        path: path.to_path_buf(),
        setting: "rs485.rts_on_send",
        source,
    };
    let mut conf = SerialRs485::encode(mode);
    rs485_ioctl(port, libc::TIOCSRS485, &mut conf).map_err(refused)?;
    let mut back = SerialRs485::default();
    rs485_ioctl(port, libc::TIOCGRS485, &mut back).map_err(refused)?;
    match back.differs(mode) {
        None => {
            tracing::info!(
                port = %path.display(),
                flags = back.flags,
                delay_before_send_ms = back.delay_rts_before_send,
                delay_after_send_ms = back.delay_rts_after_send,
                "kernel RS-485 mode on"
            );
            Ok(())
        }
        Some((setting, asked, got)) => Err(LineError::Rs485Kept {
            path: path.to_path_buf(),
            setting,
            asked,
            got,
        }),
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
        let port = open_tty(&path, self.settings)?;
        if let Some(mode) = self.rs485 {
            apply_rs485(&port, &path, mode)?;
        }
        if let Some((config, root)) = &self.latency {
            crate::line::latency::apply(*config, root, &port, &path)
                .map_err(|e| LineError::Latency(Box::new(e)))?;
        }
        self.port = Some(port);
        Ok(())
    }

    fn settings(&self) -> LineSettings {
        self.settings
    }

    fn now(&self) -> LineInstant {
        self.clock.line_now()
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        let start = self.now();
        let port = self.port()?;
        port.write_all(frame)?;
        // tcdrain: on a real UART this returns once the last character has left.
        port.flush()?;
        // A pty drains at once; keep the line busy for the frame's wire time all the same, so
        // timing on a pty matches the wire (on a UART this deadline has already passed).
        self.wait_until(start + self.settings.chars(frame.len()));
        Ok(())
    }

    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        let mut chunk = [0u8; 256];
        loop {
            let now = self.now();
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

    fn wait_until(&mut self, t: LineInstant) {
        self.clock.sleep_until_on_line(t);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serial_rs485_is_the_kernels_32_bytes() {
        assert_eq!(std::mem::size_of::<SerialRs485>(), 32);
        assert_eq!(std::mem::align_of::<SerialRs485>(), 4);
    }

    #[test]
    fn rs485_mode_encodes_flags_and_delays() {
        let on = Rs485Mode {
            rts_on_send: true,
            delay_before_send: Duration::from_millis(2),
            delay_after_send: Duration::from_micros(5_900),
        };
        let c = SerialRs485::encode(on);
        assert_eq!(c.flags, 0b011); // ENABLED | RTS_ON_SEND
        assert_eq!((c.delay_rts_before_send, c.delay_rts_after_send), (2, 5));
        assert_eq!(c.padding, [0; 5]);
        assert_eq!(c.differs(on), None);

        let inverted = Rs485Mode {
            rts_on_send: false,
            ..on
        };
        assert_eq!(SerialRs485::encode(inverted).flags, 0b101); // ENABLED | RTS_AFTER_SEND
    }

    #[test]
    fn read_back_names_the_setting_the_port_kept() {
        let mode = Rs485Mode {
            rts_on_send: true,
            delay_before_send: Duration::ZERO,
            delay_after_send: Duration::from_millis(3),
        };
        // sc16is7xx: delay_rts_after_send is not supported and comes back 0.
        let mut back = SerialRs485::encode(mode);
        back.delay_rts_after_send = 0;
        assert_eq!(
            back.differs(mode),
            Some(("rs485.delay_after_send", "3 ms".into(), "0 ms".into()))
        );
        assert_eq!(
            SerialRs485::default().differs(mode).map(|d| d.0),
            Some("rs485")
        );
    }

    #[test]
    fn a_pty_refuses_rs485_mode_by_name() {
        let (_master, slave, name) = pty_pair().unwrap();
        let mode = Rs485Mode {
            rts_on_send: true,
            delay_before_send: Duration::ZERO,
            delay_after_send: Duration::ZERO,
        };
        let e = apply_rs485(&slave, Path::new(&name), mode).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with(&format!(
                "{name} does not support kernel RS-485 mode (rs485.rts_on_send): "
            )),
            "{text}"
        );
        assert!(matches!(e, LineError::Rs485 { .. }));
    }
}
