//! USB adapters' latency timer: read it, lower it, and count it in the budget
//! (`adapter_latency: auto | <duration>`).
//!
//! An FTDI chip (`ftdi_sio`) holds received bytes until its buffer fills or its latency timer
//! expires, 16 ms by default since Linux 4.9.13 (before, the driver set `ASYNC_LOW_LATENCY`,
//! 1 ms): every reply, however short, reaches the host up to that much late, so every
//! transaction of a poll plan costs up to that much more than its wire time.
//!
//! When a bus's port opens ([`lower`]): the tty's sysfs node is found
//! (`/sys/class/tty/<name>/device/latency_timer`, which the kernel links to the usb-serial
//! port; `/sys/bus/usb-serial/devices/<name>/latency_timer` otherwise) and read; when it is
//! above 1 ms, `ASYNC_LOW_LATENCY` is set with `TIOCGSERIAL`/`TIOCSSERIAL` (ftdi_sio then
//! programs 1 ms; the flag is one a non-root process may change), and if the timer still reads
//! higher, 1 is written to the attribute (root only). What the port has afterwards is logged;
//! a refusal is a warning, unless the project demands a value ([`AdapterLatency::AtMost`]) the
//! port stays above, which stops the start.
//!
//! A port without a latency timer (a pty, a UART, an adapter whose driver has none: cp210x,
//! ch341) adds nothing the budget can know: it counts 0. Where `check` cannot look (the port is
//! on another machine), a configured value is what it assumes.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::line::transport::TTYPort;

/// A bus's `adapter_latency:`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AdapterLatency {
    /// Read the port's latency timer where it has one (and lower it); 0 where it has none.
    #[default]
    Auto,
    /// The adapter's latency is at most this: what `check` assumes, and a ceiling the port
    /// must be brought under when it opens (it tries 1 ms first).
    AtMost(Duration),
}

impl AdapterLatency {
    /// The largest value the ftdi_sio attribute takes (a `u8` in ms).
    pub const MAX: Duration = Duration::from_millis(255);
}

/// Where the sysfs tree is mounted: `/sys`, or a fake tree in tests.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SysfsRoot(pub PathBuf);

impl Default for SysfsRoot {
    fn default() -> Self {
        Self(PathBuf::from("/sys"))
    }
}

/// The tty behind a port path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum TtyNode {
    /// A pseudo-terminal: no adapter, no latency timer.
    Pty,
    /// A tty the kernel names (`ttyUSB0`), after following links such as
    /// `/dev/serial/by-id/...`.
    Named(String),
}

impl TtyNode {
    /// The tty of `port` (links followed when the path exists).
    pub(crate) fn of(port: &Path) -> Self {
        let real = std::fs::canonicalize(port).unwrap_or_else(|_| port.to_path_buf());
        if real.starts_with("/dev/pts") || real == Path::new("/dev/ptmx") {
            return Self::Pty;
        }
        Self::Named(
            real.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
        )
    }
}

/// Why a port has no latency timer to read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NoTimer {
    /// A pseudo-terminal.
    Pty,
    /// Its driver has no latency timer (`serial8250`, `cp210x`, ...).
    Driver(String),
    /// The tty has no device behind it in sysfs (a virtual console, a tty of a driver sysfs
    /// does not describe).
    NoDevice,
}

impl fmt::Display for NoTimer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Pty => f.write_str("pty"),
            Self::Driver(d) => write!(f, "its driver {d} has no latency timer"),
            Self::NoDevice => f.write_str("no device behind the tty in sysfs"),
        }
    }
}

/// What sysfs says about a port's latency timer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Probe {
    /// The timer, in whole ms, read from `path`.
    Timer {
        /// The attribute read.
        path: PathBuf,
        /// Its value.
        ms: u8,
    },
    /// The port has none.
    None(NoTimer),
    /// Sysfs does not know the tty: the port is not on this machine (or not plugged in).
    Absent,
    /// The attribute exists but could not be read as a number of ms.
    Unreadable {
        /// The attribute.
        path: PathBuf,
        /// What failed (`InvalidData`: not a number).
        kind: std::io::ErrorKind,
    },
}

/// The latency timer attribute of `tty` under `root`, if sysfs has one.
fn timer_path(root: &SysfsRoot, tty: &str) -> Option<PathBuf> {
    [
        root.0
            .join("class/tty")
            .join(tty)
            .join("device/latency_timer"),
        root.0
            .join("bus/usb-serial/devices")
            .join(tty)
            .join("latency_timer"),
    ]
    .into_iter()
    .find(|p| p.exists())
}

fn read_ms(path: &Path) -> Result<u8, std::io::ErrorKind> {
    let text = std::fs::read_to_string(path).map_err(|e| e.kind())?;
    text.trim()
        .parse::<u8>()
        .map_err(|_| std::io::ErrorKind::InvalidData)
}

/// Reads the latency timer of `tty` under `root`.
pub(crate) fn probe(root: &SysfsRoot, tty: &TtyNode) -> Probe {
    let name = match tty {
        TtyNode::Pty => return Probe::None(NoTimer::Pty),
        TtyNode::Named(n) => n,
    };
    if let Some(path) = timer_path(root, name) {
        return match read_ms(&path) {
            Ok(ms) => Probe::Timer { path, ms },
            Err(kind) => Probe::Unreadable { path, kind },
        };
    }
    let class = root.0.join("class/tty").join(name);
    if !class.exists() {
        return Probe::Absent;
    }
    match driver_name(&class.join("device")) {
        Some(driver) => Probe::None(NoTimer::Driver(driver)),
        None => Probe::None(NoTimer::NoDevice),
    }
}

/// The name of the driver behind the tty device `device`. Since Linux 6.5 a UART's tty hangs
/// below serial-base's `port` and `ctrl` devices (drivers of those names); the hardware's
/// driver (`serial8250`, `uart-pl011`, `sc16is7xx`) is that of the first ancestor outside
/// serial-base.
fn driver_name(device: &Path) -> Option<String> {
    let mut dir = std::fs::canonicalize(device).ok()?;
    for _ in 0..4 {
        let driver = std::fs::canonicalize(dir.join("driver")).ok()?;
        if !driver.components().any(|c| c.as_os_str() == "serial-base") {
            return driver.file_name().map(|n| n.to_string_lossy().into_owned());
        }
        dir = dir.parent()?.to_path_buf();
    }
    None
}

/// Where the latency a budget counts came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// Read from this sysfs attribute.
    Read(PathBuf),
    /// The project's `adapter_latency`.
    Configured,
    /// The port has no latency timer.
    None(NoTimer),
    /// The simulated line (no adapter).
    Simulated,
    /// `auto`, and the port is not on this machine: nothing to read, 0 counted.
    Absent(PathBuf),
    /// `auto`, and the attribute could not be read: 0 counted.
    Unreadable(PathBuf, std::io::ErrorKind),
}

/// The most an adapter holds a reply by default: an FTDI chip's latency timer since Linux
/// 4.9.13. What a line whose port is not there yet counts until it opens (a late USB adapter
/// is most likely one of these).
pub(crate) const DEFAULT_FTDI_LATENCY: Duration = Duration::from_millis(16);

impl AdapterLatency {
    /// The latency to count for a port that could not be opened yet: a configured ceiling as
    /// given, else an FTDI adapter's default (16 ms), so that echo and
    /// reply waits are long enough whatever adapter appears.
    pub fn before_open(self) -> Duration {
        match self {
            AdapterLatency::AtMost(d) => d,
            AdapterLatency::Auto => DEFAULT_FTDI_LATENCY,
        }
    }
}

/// The adapter latency a budget counts for one bus, and where the figure came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Assumed {
    /// Added to every transaction that waits for bytes back.
    pub latency: Duration,
    /// Where it came from.
    pub source: Source,
}

impl Assumed {
    /// No adapter: the simulated line.
    pub fn simulated() -> Self {
        Self {
            latency: Duration::ZERO,
            source: Source::Simulated,
        }
    }

    /// What `check` counts for a bus on `port` with `config`: a configured value as given;
    /// `auto`, what sysfs under `root` says now.
    pub fn for_port(config: AdapterLatency, port: &Path, root: &SysfsRoot) -> Self {
        if let AdapterLatency::AtMost(latency) = config {
            return Self {
                latency,
                source: Source::Configured,
            };
        }
        let (latency, source) = match probe(root, &TtyNode::of(port)) {
            Probe::Timer { path, ms } => (Duration::from_millis(u64::from(ms)), Source::Read(path)),
            Probe::None(why) => (Duration::ZERO, Source::None(why)),
            Probe::Absent => (Duration::ZERO, Source::Absent(port.to_path_buf())),
            Probe::Unreadable { path, kind } => (Duration::ZERO, Source::Unreadable(path, kind)),
        };
        Self { latency, source }
    }
}

fn fmt_ms(d: Duration) -> String {
    let us = d.as_micros();
    if us % 1000 == 0 {
        format!("{} ms", us / 1000)
    } else {
        format!("{:.3} ms", d.as_secs_f64() * 1e3)
    }
}

impl fmt::Display for Assumed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = fmt_ms(self.latency);
        match &self.source {
            Source::Read(path) => write!(f, "{ms}, read from {}", path.display()),
            Source::Configured => write!(f, "{ms}, configured"),
            Source::None(why) => write!(f, "none: {why}"),
            Source::Simulated => f.write_str("none: simulated line"),
            Source::Absent(port) => write!(
                f,
                "0 ms assumed: {} is not on this machine (set adapter_latency to the adapter's: \
                 16 ms for an FTDI adapter without the udev rule, 1 ms with it); `run` starts \
                 with this line lost and takes the port when it appears",
                port.display()
            ),
            Source::Unreadable(path, kind) => {
                write!(f, "0 ms assumed: cannot read {}: {kind}", path.display())
            }
        }
    }
}

/// `ASYNC_LOW_LATENCY` of `include/uapi/linux/tty_flags.h` (`1 << 13`).
const ASYNC_LOW_LATENCY: libc::c_int = 1 << 13;

/// `struct serial_struct` of `include/uapi/linux/serial.h` (`libc` has the ioctl numbers but
/// not the struct); the pointer field is kept as an address, never dereferenced.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
struct SerialStruct {
    kind: libc::c_int,
    line: libc::c_int,
    port: libc::c_uint,
    irq: libc::c_int,
    flags: libc::c_int,
    xmit_fifo_size: libc::c_int,
    custom_divisor: libc::c_int,
    baud_base: libc::c_int,
    close_delay: libc::c_ushort,
    io_type: libc::c_char,
    reserved_char: [libc::c_char; 1],
    hub6: libc::c_int,
    closing_wait: libc::c_ushort,
    closing_wait2: libc::c_ushort,
    iomem_base: usize,
    iomem_reg_shift: libc::c_ushort,
    port_high: libc::c_uint,
    iomap_base: libc::c_ulong,
}

#[allow(unsafe_code)] // one ioctl; see SAFETY below
fn serial_ioctl(port: &TTYPort, request: libc::Ioctl, s: &mut SerialStruct) -> std::io::Result<()> {
    use std::os::fd::AsRawFd;
    // SAFETY: the descriptor is open for as long as `port` is borrowed; both requests read or
    // write exactly one `struct serial_struct`, which `SerialStruct` lays out (repr(C), the
    // kernel's field order and types) and `s` points to for the whole call.
    let rc = unsafe { libc::ioctl(port.as_raw_fd(), request, s as *mut SerialStruct) };
    if rc < 0 {
        Err(std::io::Error::last_os_error())
    } else {
        Ok(())
    }
}

/// A refused `ASYNC_LOW_LATENCY`: which ioctl, and the OS error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{ioctl} refused ASYNC_LOW_LATENCY: {}", os_error(*errno))]
pub struct LowLatencyRefused {
    /// `TIOCGSERIAL` or `TIOCSSERIAL`.
    pub ioctl: &'static str,
    /// The OS error number (`ENOTTY` on a pty).
    pub errno: i32,
}

/// The OS error number of `e` (`EIO` for one that has none).
fn errno(e: &std::io::Error) -> i32 {
    e.raw_os_error().unwrap_or(libc::EIO)
}

/// The OS's text for `errno` ("Inappropriate ioctl for device (os error 25)").
fn os_error(errno: i32) -> std::io::Error {
    std::io::Error::from_raw_os_error(errno)
}

/// Sets `ASYNC_LOW_LATENCY` on `port` (`TIOCGSERIAL`, then `TIOCSSERIAL` with the flag; a
/// flag already set is left). ftdi_sio then runs its timer at 1 ms; drivers without serial
/// info (a pty, cp210x, ch341) refuse it.
pub(crate) fn set_low_latency(port: &TTYPort) -> Result<(), LowLatencyRefused> {
    let mut s = SerialStruct::default();
    serial_ioctl(port, libc::TIOCGSERIAL, &mut s).map_err(|e| LowLatencyRefused {
        ioctl: "TIOCGSERIAL",
        errno: errno(&e),
    })?;
    if s.flags & ASYNC_LOW_LATENCY != 0 {
        return Ok(());
    }
    s.flags |= ASYNC_LOW_LATENCY;
    serial_ioctl(port, libc::TIOCSSERIAL, &mut s).map_err(|e| LowLatencyRefused {
        ioctl: "TIOCSSERIAL",
        errno: errno(&e),
    })
}

/// What opening a port did about its latency timer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Lowered {
    /// The timer before, or why there is none.
    pub before: Probe,
    /// Its value afterwards (ms), when it has one and it could be read again.
    pub after: Option<u8>,
    /// `ASYNC_LOW_LATENCY`, when it was tried.
    pub low_latency: Option<Result<(), LowLatencyRefused>>,
    /// Writing 1 to the attribute, when it was tried (the OS error number if refused).
    pub written: Option<Result<(), i32>>,
}

impl Lowered {
    /// The latency the port has now (0 without a timer).
    pub fn effective(&self) -> Duration {
        let ms = match (&self.before, self.after) {
            (_, Some(ms)) => ms,
            (Probe::Timer { ms, .. }, None) => *ms,
            _ => 0,
        };
        Duration::from_millis(u64::from(ms))
    }

    /// Whether it was left above 1 ms (worth a warning).
    pub fn left_high(&self) -> bool {
        self.effective() > Duration::from_millis(1)
    }
}

impl fmt::Display for Lowered {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (path, before) = match &self.before {
            Probe::Timer { path, ms } => (path, *ms),
            Probe::None(why) => return write!(f, "no adapter latency timer ({why})"),
            Probe::Absent => return f.write_str("no adapter latency timer (not in sysfs)"),
            Probe::Unreadable { path, kind } => {
                return write!(f, "cannot read {}: {kind}", path.display())
            }
        };
        let now = self.after.unwrap_or(before);
        write!(f, "latency timer {now} ms ({})", path.display())?;
        if now != before {
            write!(f, ", was {before} ms")?;
        }
        match &self.low_latency {
            Some(Ok(())) => f.write_str("; ASYNC_LOW_LATENCY set")?,
            Some(Err(e)) => write!(f, "; {e}")?,
            None => {}
        }
        match self.written {
            Some(Ok(())) => write!(f, "; 1 written to {}", path.display())?,
            Some(Err(e)) => write!(
                f,
                "; writing 1 to it was refused: {} (the udev rule in deploy/ sets it at plug-in)",
                os_error(e)
            )?,
            None => {}
        }
        Ok(())
    }
}

/// Brings the latency timer of `port` (the tty `tty`, sysfs under `root`) down to 1 ms where
/// it is higher: `ASYNC_LOW_LATENCY` first, then the sysfs attribute; reads it back.
pub(crate) fn lower(root: &SysfsRoot, port: &TTYPort, tty: &TtyNode) -> Lowered {
    let before = probe(root, tty);
    let mut done = Lowered {
        before: before.clone(),
        after: None,
        low_latency: None,
        written: None,
    };
    let Probe::Timer { path, ms } = before else {
        return done;
    };
    if ms <= 1 {
        return done;
    }
    done.low_latency = Some(set_low_latency(port));
    let mut now = read_ms(&path).ok();
    if now.is_none_or(|ms| ms > 1) {
        done.written = Some(std::fs::write(&path, "1").map_err(|e| errno(&e)));
        now = read_ms(&path).ok();
    }
    done.after = now;
    done
}

/// The port's latency timer stays above the `adapter_latency` the project demands.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{}: the adapter's {lowered}, above adapter_latency {} (run as root, install the udev rule, \
     or raise adapter_latency to what the adapter has)",
    port.display(), fmt_ms(*demanded)
)]
pub struct LatencyRefused {
    /// The port.
    pub port: PathBuf,
    /// What was tried and what it has.
    pub lowered: Lowered,
    /// The ceiling asked for.
    pub demanded: Duration,
}

/// Lowers the latency timer of `port` (opened from `path`) and checks it against `config`:
/// the latency the port has, or the refusal of a demanded ceiling. A refusal under `auto` is
/// logged, not an error.
pub(crate) fn apply(
    config: AdapterLatency,
    root: &SysfsRoot,
    port: &TTYPort,
    path: &Path,
) -> Result<Duration, LatencyRefused> {
    enforce(config, lower(root, port, &TtyNode::of(path)), path)
}

/// Holds what opening did against `config`: the latency the port has, or the refusal of a
/// demanded ceiling it stays above (logged either way under `auto`).
fn enforce(
    config: AdapterLatency,
    lowered: Lowered,
    path: &Path,
) -> Result<Duration, LatencyRefused> {
    let effective = lowered.effective();
    if let AdapterLatency::AtMost(demanded) = config {
        if effective > demanded {
            return Err(LatencyRefused {
                port: path.to_path_buf(),
                lowered,
                demanded,
            });
        }
    }
    if lowered.left_high() {
        tracing::warn!(port = %path.display(), "{lowered}: every transaction can take that much longer");
    } else {
        tracing::info!(port = %path.display(), "{lowered}");
    }
    Ok(effective)
}

#[cfg(test)]
mod tests;
