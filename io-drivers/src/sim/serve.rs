//! Serving simulated modules on a real serial device, so any Modbus master or a terminal can
//! talk to them (`softplc sim --port /dev/pts/N ...`).
//!
//! Framing follows the devices' own rule, silence on the line. Where a module on the line
//! frames by silence itself (MiniMod: 28 bit times + RDELAYM, manual "Setting the Modbus
//! communication timeout"; [`crate::sim::SimDevice::frame_silence`]), a request ends when the
//! line has been silent that long (the longest of the line's modules), and nothing else ends
//! it: a pause inside a request shorter than the silence is part of it, a longer one makes two
//! requests, as the module would hear them. A pty gives no byte timing, so the gap is measured
//! on the host's clock when bytes arrive (a read waits no longer than the silence still to
//! run): a gap shorter than half the silence is one request, one longer than twice the silence
//! (and than 2 ms) is two; in between, and on a host so loaded that the server's thread waits
//! for a CPU longer than the silence, it depends on scheduling. Otherwise (no such module) the silence is t3.5, at least 5 ms for a
//! pty's jitter, with a fast path: bytes that already form a complete RTU request with a good
//! CRC, or a text line ended by CR or LF, are handled at once. A pty does not enforce baud,
//! so replies are written as a whole after the device's reply delay and the server then keeps
//! quiet for the reply's wire time.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use serialport::SerialPort;

use crate::line::settings::LineSettings;
use crate::line::transport::LineError;
use crate::modbus::crc::check_crc;
use crate::modbus::server::{request_frame_len, FrameLen};
use crate::sim::line::SharedWorld;
use crate::time::{Clock, LineInstant};

/// The line index the served world uses.
pub const SERVED_LINE: usize = 0;

/// Counters of a serving session.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ServeStats {
    /// Frames handed to the devices.
    pub frames: u64,
    /// Replies written.
    pub replies: u64,
    /// Bytes dropped as noise (no frame could be made of them).
    pub noise_bytes: u64,
}

/// Splits the head of `buf` into a frame if one is complete: an RTU request of known length
/// with a good CRC, or a text line.
pub fn complete_frame(buf: &[u8]) -> Option<usize> {
    if let FrameLen::Complete(n) = request_frame_len(buf) {
        if buf.len() >= n && check_crc(&buf[..n]) {
            return Some(n);
        }
    }
    // A text command (MiniMod `?X1`, RESI `#...`, DCON `$01M`) is printable ASCII up to its
    // CR or LF; an RTU frame nearly always holds a zero or control byte before any 0x0D.
    let end = buf.iter().position(|b| *b == b'\r' || *b == b'\n')?;
    if end > 0
        && buf[..end]
            .iter()
            .all(|b| b.is_ascii_graphic() || *b == b' ')
    {
        return Some(end + 1);
    }
    None
}

/// The settings a tty is set to (on the slave end of a pty: what the master program set).
pub fn tty_settings(port: &serialport::TTYPort) -> Option<LineSettings> {
    use crate::line::settings::{Parity, SerialFormat};
    let baud = port.baud_rate().ok()?;
    let data_bits = match port.data_bits().ok()? {
        serialport::DataBits::Seven => 7,
        serialport::DataBits::Eight => 8,
        _ => return None,
    };
    let parity = match port.parity().ok()? {
        serialport::Parity::None => Parity::None,
        serialport::Parity::Even => Parity::Even,
        serialport::Parity::Odd => Parity::Odd,
    };
    let stop_bits = match port.stop_bits().ok()? {
        serialport::StopBits::One => 1,
        serialport::StopBits::Two => 2,
    };
    Some(LineSettings {
        baud,
        format: SerialFormat {
            data_bits,
            parity,
            stop_bits,
        },
    })
}

/// Serves `world` on `port` until `stop` is set.
pub fn serve(
    port: serialport::TTYPort,
    world: SharedWorld,
    settings: LineSettings,
    clock: Arc<dyn Clock>,
    stop: &AtomicBool,
) -> Result<ServeStats, LineError> {
    serve_following(port, world, settings, clock, stop, None)
}

/// The baud the master's end of the line is set to now (on a pty: the termios of the slave
/// end, which the master program set; the kernel keeps no parity there, so only the baud is
/// followed); `None` when it cannot be read.
pub(crate) type MasterSettings<'a> = &'a dyn Fn() -> Option<LineSettings>;

/// Serves `world` on `port` until `stop` is set; before each frame is handed to the devices,
/// the world learns the master's settings from `master` (if given), so a module at other
/// settings hears that frame as garbage ([`crate::sim::line::SimWorld::deliver`]).
pub fn serve_following(
    mut port: serialport::TTYPort,
    world: SharedWorld,
    settings: LineSettings,
    clock: Arc<dyn Clock>,
    stop: &AtomicBool,
    master: Option<MasterSettings<'_>>,
) -> Result<ServeStats, LineError> {
    let mut follower = MasterFollower::default();
    let mut follow = || follower.frame(&world, master.and_then(|m| m()), settings);
    let mut stats = ServeStats::default();
    let mut buf: Vec<u8> = Vec::with_capacity(512);
    let mut chunk = [0u8; 256];
    let mut last_byte = clock.line_now();
    // Silence that ends a frame without a module's own: t3.5, but a pty's scheduling jitter
    // is larger than that.
    let t3_5_silence = settings.t3_5().max(Duration::from_millis(5));
    let mut silence = t3_5_silence;
    while !stop.load(Ordering::Relaxed) {
        // While a request is being heard, wait no longer than the silence still to run, so
        // its end is seen when it comes rather than up to a read timeout later.
        let wait = if buf.is_empty() {
            READ_WAIT
        } else {
            let heard_for = clock.line_now().saturating_duration_since(last_byte);
            silence
                .saturating_sub(heard_for)
                .clamp(SHORTEST_WAIT, READ_WAIT)
        };
        port.set_timeout(wait)
            .map_err(|e| std::io::Error::other(e.description))?;
        match port.read(&mut chunk) {
            Ok(n) if n > 0 => {
                let at = clock.line_now();
                // Bytes after a silence start a new request: the one before them ended when
                // its last byte came (the gap is measured when the bytes arrive, before they
                // join the buffer, so a late look at the buffer cannot join the two).
                if !buf.is_empty() && at.saturating_duration_since(last_byte) >= silence {
                    let ended = (std::mem::take(&mut buf), last_byte);
                    hand_over_ended(&mut port, &world, ended, &mut follow, &mut stats, &*clock)?;
                }
                buf.extend_from_slice(&chunk[..n]);
                last_byte = at;
            }
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e.into()),
        }
        let now = clock.line_now();
        let modules_silence = {
            let mut w = lock(&world);
            w.advance_to(now);
            w.frame_silence(SERVED_LINE)
        };
        // A module that frames by silence hears a request end only by silence.
        while let Some(n) = complete_frame(&buf).filter(|_| modules_silence.is_none()) {
            let frame: Vec<u8> = buf.drain(..n).collect();
            stats.frames += 1;
            let settings = follow();
            if answer(&mut port, &world, &frame, settings, clock.as_ref())? {
                stats.replies += 1;
            }
        }
        silence = modules_silence.unwrap_or(t3_5_silence);
        if !buf.is_empty() && now.saturating_duration_since(last_byte) >= silence {
            // A silence ended an incomplete frame: give it to the devices as the real ones
            // would get it (they drop it on a bad CRC), and start afresh.
            let ended = (std::mem::take(&mut buf), last_byte);
            hand_over_ended(&mut port, &world, ended, &mut follow, &mut stats, &*clock)?;
        }
    }
    Ok(stats)
}

/// The longest a read waits for bytes: the stop flag and the world's time are looked at
/// this often.
const READ_WAIT: Duration = Duration::from_millis(1);

/// The shortest read wait while a request is being heard, so a silence about to end does not
/// spin the loop.
const SHORTEST_WAIT: Duration = Duration::from_micros(50);

/// Hands a request a silence ended (`(bytes, when its last byte came)`) to the devices as
/// the real ones would get it (they drop it on a bad CRC) and counts it.
fn hand_over_ended(
    port: &mut serialport::TTYPort,
    world: &SharedWorld,
    (frame, ended): (Vec<u8>, LineInstant),
    master_now: &mut impl FnMut() -> LineSettings,
    stats: &mut ServeStats,
    clock: &dyn Clock,
) -> Result<(), LineError> {
    stats.frames += 1;
    let settings = master_now();
    if answer_frame_ended(port, world, (&frame, ended), settings, clock)? {
        stats.replies += 1;
    } else {
        stats.noise_bytes += frame.len() as u64;
    }
    Ok(())
}

/// What the served line's master talks at, frame by frame. The port's own settings (a pty's
/// baud, as the master program set its end) are followed when they change; in between, what
/// the world was told last stands, so a console's `DEVICE line 9600E` (a master said to talk
/// at other settings) holds until the master program changes its port.
#[derive(Debug, Default)]
struct MasterFollower {
    /// The port's settings when last looked at.
    seen: Option<LineSettings>,
}

impl MasterFollower {
    /// The settings of the next frame, given the port's now (`None`: not known).
    fn frame(
        &mut self,
        world: &SharedWorld,
        port: Option<LineSettings>,
        settings: LineSettings,
    ) -> LineSettings {
        let mut w = lock(world);
        if let Some(port) = port.filter(|p| self.seen != Some(*p)) {
            self.seen = Some(port);
            w.follow_master_baud(SERVED_LINE, port.baud);
        }
        w.master_settings(SERVED_LINE).unwrap_or(settings)
    }
}

pub(crate) fn lock(world: &SharedWorld) -> std::sync::MutexGuard<'_, crate::sim::line::SimWorld> {
    world.lock().unwrap_or_else(|e| e.into_inner())
}

/// Hands a frame to the devices and writes the reply when it is due. True if one was written.
pub(crate) fn answer<W: Write>(
    port: &mut W,
    world: &SharedWorld,
    frame: &[u8],
    settings: LineSettings,
    clock: &dyn Clock,
) -> Result<bool, LineError> {
    answer_frame_ended(port, world, (frame, clock.line_now()), settings, clock)
}

/// [`answer`] for a frame whose last byte came at `ended` (a module's reply delay counts from
/// there, not from when the silence after it was over).
pub(crate) fn answer_frame_ended<W: Write>(
    port: &mut W,
    world: &SharedWorld,
    (frame, ended): (&[u8], LineInstant),
    settings: LineSettings,
    clock: &dyn Clock,
) -> Result<bool, LineError> {
    {
        let mut w = lock(world);
        w.deliver(SERVED_LINE, frame, ended);
        // The server hands over a request it has framed: the line is silent after it.
        w.settle(SERVED_LINE, LineInstant::after_origin(Duration::MAX));
    }
    let char_time = settings.char_time();
    let mut wrote = false;
    // Each burst (a reply, a duplicate of it, noise) goes out when it is due, so a master on
    // the pty sees them as separate frames, as it would on a wire.
    loop {
        let burst = {
            let mut w = lock(world);
            let Some(first) = w.next_arrival(SERVED_LINE) else {
                break;
            };
            let mut bytes = Vec::new();
            let mut last = first;
            // Bytes that follow each other within two character times belong to one burst.
            while w
                .next_arrival(SERVED_LINE)
                .is_some_and(|at| at <= last + char_time * 2)
            {
                last = w.next_arrival(SERVED_LINE).unwrap_or(last);
                w.take_arrived(SERVED_LINE, last, &mut bytes);
            }
            (first, bytes)
        };
        let (first, bytes) = burst;
        let start = first - char_time;
        clock.sleep_until_on_line(start);
        port.write_all(&bytes)?;
        port.flush()?;
        // The master on a pty has the whole burst at once, a wire time earlier than on a
        // wire, and may send its next request at once. An echoing adapter must send that
        // request back while it is sent, so after the last burst the server listens again
        // at once (the next request's reply delay still counts from when it is heard).
        let last = lock(world).next_arrival(SERVED_LINE).is_none();
        if !(last && lock(world).echo(SERVED_LINE).on) {
            clock.sleep_until_on_line(start + settings.chars(bytes.len()));
        }
        wrote = true;
    }
    Ok(wrote)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::SimWorld;

    #[test]
    fn the_masters_settings_said_on_the_console_stand_until_the_port_changes() {
        let at = |baud, format: &str| LineSettings {
            baud,
            format: format.parse().unwrap(),
        };
        let model = crate::devices::model("minimod").unwrap();
        let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
        world.add_device(SERVED_LINE, "minimod@5", (model.simulator)(5));
        let world = world.shared();
        let mut follower = MasterFollower::default();
        let pty = Some(at(19200, "8N1"));
        let first = follower.frame(&world, pty, LineSettings::DEFAULT);
        assert_eq!(first.baud, 19200);
        // The console: the master now talks at 9600E.
        lock(&world).set_master_settings(SERVED_LINE, at(9600, "8E1"));
        for _ in 0..3 {
            assert_eq!(
                follower.frame(&world, pty, LineSettings::DEFAULT),
                at(9600, "8E1"),
                "the port has not changed: the console's word stands"
            );
        }
        // The master program sets its end to 38400: that is followed.
        let changed = follower.frame(&world, Some(at(38400, "8N1")), LineSettings::DEFAULT);
        assert_eq!(changed.baud, 38400);
        // A port whose settings are not known (a real device served by --port) leaves them.
        lock(&world).set_master_settings(SERVED_LINE, at(4800, "8O1"));
        assert_eq!(
            follower.frame(&world, None, LineSettings::DEFAULT),
            at(4800, "8O1")
        );
    }

    /// A MiniMod at 5 served on an in-process pty on the host's clock, its RDELAYM set by
    /// its text command, sends the FC 2 request in two halves `gap` apart and
    /// says whether a reply came, for each of `gaps`.
    fn served_minimod(rdelaym: u8, gaps: &[Duration]) -> Vec<bool> {
        use crate::line::transport::pty_pair;
        use crate::modbus::crc::append_crc;
        use crate::time::MonotonicClock;
        let model = crate::devices::model("minimod").unwrap();
        let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
        world.add_device(SERVED_LINE, "minimod@5", (model.simulator)(5));
        let world = world.shared();
        let (master, mut slave, _) = pty_pair().unwrap();
        let stop = AtomicBool::new(false);
        let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
        std::thread::scope(|s| {
            s.spawn(|| serve(master, world, LineSettings::DEFAULT, clock, &stop));
            slave
                .write_all(format!("@5>RDELAYM={rdelaym}\r").as_bytes())
                .unwrap();
            assert_eq!(read_for(&mut slave, Duration::from_millis(300)), b"OK\r");
            let mut request = vec![5, 0x02, 0x00, 0x00, 0x00, 0x0A];
            append_crc(&mut request);
            let replies = gaps
                .iter()
                .map(|gap| {
                    slave.write_all(&request[..4]).unwrap();
                    std::thread::sleep(*gap);
                    slave.write_all(&request[4..]).unwrap();
                    let reply = read_for(&mut slave, Duration::from_millis(150));
                    reply.starts_with(&[5, 0x02, 0x02])
                })
                .collect();
            stop.store(true, Ordering::Relaxed);
            replies
        })
    }

    /// Everything the master's end hears within `wait`.
    fn read_for(port: &mut serialport::TTYPort, wait: Duration) -> Vec<u8> {
        port.set_timeout(Duration::from_millis(20)).unwrap();
        let end = std::time::Instant::now() + wait;
        let mut got = Vec::new();
        let mut chunk = [0u8; 64];
        while std::time::Instant::now() < end {
            if let Ok(n) = port.read(&mut chunk) {
                got.extend_from_slice(&chunk[..n]);
            }
        }
        got
    }

    #[test]
    fn on_a_pty_a_pause_well_inside_the_silence_joins_and_one_well_past_it_splits() {
        // RDELAYM=200 at 19200: 1.46 ms + 20 ms of silence end a request. A 2 ms pause is far
        // under half of it (one request, answered); 60 ms is over twice it (two halves, each
        // failing its CRC: no reply). Wide margins: a pty gives no byte timing, the gap is
        // measured on the host's clock (the module's doc: within half to twice the silence).
        let ms = Duration::from_millis;
        assert_eq!(served_minimod(200, &[ms(2), ms(60)]), [true, false]);
        // RDELAYM=0: 1.46 ms of silence; 30 ms apart is two requests, sent whole is one.
        assert_eq!(served_minimod(0, &[ms(30), Duration::ZERO]), [false, true]);
    }

    #[test]
    fn splits_rtu_requests_and_text_lines() {
        // FC2 read of unit 5, then the next frame's first byte.
        let rtu = [0x05, 0x02, 0x00, 0x00, 0x00, 0x0A, 0xF9, 0x89, 0x01];
        assert_eq!(complete_frame(&rtu), Some(8));
        assert_eq!(complete_frame(&rtu[..5]), None);
        assert_eq!(complete_frame(b"?X1\r>Y1=1\r"), Some(4));
        assert_eq!(complete_frame(b"@25?DEVICE"), None);
        // A '$' address byte followed by binary data is not a text line even with a CR in it.
        assert_eq!(complete_frame(&[b'$', 0x03, 0x00, 0x0D, 0x00]), None);
    }
}
