//! The simulated world and the virtual multidrop RS-485 line.
//!
//! [`SimWorld`] holds every simulated module of a project (grouped by line) and the plant, and
//! advances them together on a 1 ms tick. A [`VirtualPort`] is a master's end of one line: a
//! frame it writes occupies the wire for its character time, reaches every device on the line,
//! and each addressed device's reply arrives byte by byte after its reply delay. Replies that
//! overlap in time garble each other, as on a real bus.
//!
//! The world's time only moves forward: when several lines are replayed one after another on a
//! virtual clock, a line that asks about an earlier time sees the world as it is now.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use crate::line::settings::LineSettings;
use crate::line::transport::{LineError, Transport};
use crate::point::Value;
use crate::sim::device::{SimDevice, SimError};
use crate::sim::fault::LineFaults;
use crate::sim::framing::{Assembly, Heard};
use crate::sim::plant::{Plant, PlantIo};
use crate::time::{Clock, LineInstant};

const TICK: Duration = Duration::from_millis(1);

/// A device in the world, on a line.
#[derive(Debug)]
struct Placed {
    line: usize,
    name: String,
    device: Box<dyn SimDevice>,
    /// The baud and format the module's UART is set to; `None`: whatever the line's master
    /// uses (the module was configured for this line).
    settings: Option<LineSettings>,
    /// The module models its own UART ([`SimDevice::set_uart`]): it is told the master's
    /// settings before every frame and compares them itself.
    own_uart: bool,
    /// The request it is hearing, when it frames by silence ([`SimDevice::frame_silence`]).
    assembly: Option<Assembly>,
}

/// The plant and its wiring: per role, the device index and point name.
#[derive(Debug)]
struct WiredPlant {
    plant: Box<dyn Plant>,
    wires: Vec<(usize, String)>,
}

/// Bytes on their way from the devices to a line's master, with arrival times.
#[derive(Debug, Default)]
struct Inbound {
    bytes: VecDeque<(LineInstant, u8)>,
}

/// Every simulated module of a project and its plant.
#[derive(Debug)]
pub struct SimWorld {
    now: LineInstant,
    devices: Vec<Placed>,
    plant: Option<WiredPlant>,
    inbound: Vec<Inbound>,
    line_settings: Vec<LineSettings>,
    /// Per line: whether the master's character format is known (a pty conveys only the
    /// baud: the kernel forces its slave end to 8 data bits without parity).
    format_known: Vec<bool>,
    faults: LineFaults,
    /// Per line: what its simulated adapter hears of the master's own frames.
    echo: Vec<SimEcho>,
}

/// A line's simulated adapter that hears its own transmission (an FTDI design with its
/// receiver always enabled), as `echo: discard` expects (`line/echo.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SimEcho {
    /// Every frame the master sends comes back to it, byte for byte, as it is sent.
    pub on: bool,
    /// This many of the next echoes come back with one bit flipped (a collision, noise).
    pub corrupt_next: u32,
}

/// The shared handle the ports and `softplc sim` hold.
pub type SharedWorld = Arc<Mutex<SimWorld>>;

impl SimWorld {
    /// An empty world with one entry per line.
    pub fn new(lines: Vec<LineSettings>) -> Self {
        Self {
            now: LineInstant::ZERO,
            devices: Vec::new(),
            plant: None,
            inbound: lines.iter().map(|_| Inbound::default()).collect(),
            format_known: lines.iter().map(|_| true).collect(),
            echo: lines.iter().map(|_| SimEcho::default()).collect(),
            line_settings: lines,
            faults: LineFaults::new(0x5eed),
        }
    }

    /// Makes `line`'s adapter echo the master's frames (or stop).
    pub fn set_echo(&mut self, line: usize, on: bool) {
        if let Some(e) = self.echo.get_mut(line) {
            e.on = on;
        }
    }

    /// The next `n` echoes on `line` come back with a bit flipped.
    pub fn corrupt_next_echoes(&mut self, line: usize, n: u32) {
        if let Some(e) = self.echo.get_mut(line) {
            e.corrupt_next = n;
        }
    }

    /// What `line`'s adapter echoes.
    pub fn echo(&self, line: usize) -> SimEcho {
        self.echo.get(line).copied().unwrap_or_default()
    }

    /// Queues the echo of `frame`, which ended on the wire at `t`: each byte comes back as it
    /// is sent (on a real bus the receiver hears the transmitter's own bits).
    fn queue_echo(&mut self, line: usize, frame: &[u8], settings: LineSettings, t: LineInstant) {
        let Some(echo) = self.echo.get_mut(line).filter(|e| e.on) else {
            return;
        };
        let mut bytes = frame.to_vec();
        if echo.corrupt_next > 0 {
            echo.corrupt_next -= 1;
            if let Some(b) = bytes.get_mut(frame.len() / 2) {
                *b ^= 0x01;
            }
        }
        let Some(inbound) = self.inbound.get_mut(line) else {
            return;
        };
        let start = t - settings.chars(frame.len());
        inbound.bytes.extend(
            bytes
                .into_iter()
                .enumerate()
                .map(|(i, b)| (start + settings.chars(i + 1), b)),
        );
        inbound.bytes.make_contiguous().sort_by_key(|(at, _)| *at);
    }

    /// Puts a simulated device on `line` under `name`; returns its index.
    pub fn add_device(&mut self, line: usize, name: &str, device: Box<dyn SimDevice>) -> usize {
        self.devices.push(Placed {
            line,
            name: name.to_string(),
            device,
            settings: None,
            own_uart: false,
            assembly: None,
        });
        self.devices.len() - 1
    }

    /// Sets the baud and format the device's own UART runs at (its DIP switches or stored
    /// settings). A master at other settings is heard by it as garbage, see
    /// [`SimWorld::deliver`].
    /// A module that models its own UART ([`SimDevice::set_uart`]) takes them as its
    /// configuration, which commissioning and a power cycle can then change.
    pub fn set_device_settings(&mut self, index: usize, settings: LineSettings) {
        if !self.install_device_uart(index, settings) {
            if let Some(d) = self.devices.get_mut(index) {
                d.settings = Some(settings);
            }
        }
    }

    /// Installs a module for `settings` if it models its own UART ([`SimDevice::set_uart`]);
    /// any other module keeps following whatever the line's master uses. True if it took them.
    pub fn install_device_uart(&mut self, index: usize, settings: LineSettings) -> bool {
        let Some(d) = self.devices.get_mut(index) else {
            return false;
        };
        d.own_uart = d.device.set_uart(settings);
        d.own_uart
    }

    /// The baud and format `line`'s master talks at, as the world knows them.
    pub fn master_settings(&self, line: usize) -> Option<LineSettings> {
        self.line_settings.get(line).copied()
    }

    /// The baud and format of `line`'s master from now on (a served pty follows the settings
    /// the master program gave its end).
    pub fn set_master_settings(&mut self, line: usize, settings: LineSettings) {
        if let Some(s) = self.line_settings.get_mut(line) {
            *s = settings;
        }
        if let Some(k) = self.format_known.get_mut(line) {
            *k = true;
        }
        for d in self.devices.iter_mut().filter(|d| d.line == line) {
            d.device.master_line(settings.baud, Some(settings.format));
        }
    }

    /// The baud of `line`'s master from now on, its format unknown: a device then hears
    /// garbage only when its baud differs (a pty carries the baud a master sets, not the
    /// parity).
    pub fn follow_master_baud(&mut self, line: usize, baud: u32) {
        if let Some(s) = self.line_settings.get_mut(line) {
            s.baud = baud;
        }
        if let Some(k) = self.format_known.get_mut(line) {
            *k = false;
        }
        for d in self.devices.iter_mut().filter(|d| d.line == line) {
            d.device.master_line(baud, None);
        }
    }

    /// Attaches a plant; `wires[i]` is `(device index, point)` for the plant's role `i`.
    pub fn set_plant(&mut self, plant: Box<dyn Plant>, wires: Vec<(usize, String)>) {
        self.plant = Some(WiredPlant { plant, wires });
    }

    /// The attached plant, for its states and health.
    pub fn plant(&self) -> Option<&dyn Plant> {
        self.plant.as_ref().map(|w| w.plant.as_ref())
    }

    /// The attached plant, to switch its faults.
    pub fn plant_mut(&mut self) -> Option<&mut (dyn Plant + 'static)> {
        match self.plant.as_mut() {
            Some(w) => Some(w.plant.as_mut()),
            None => None,
        }
    }

    /// The injected faults (tests and `softplc sim` add and clear rules here).
    pub fn faults_mut(&mut self) -> &mut LineFaults {
        &mut self.faults
    }

    /// The injected faults.
    pub fn faults(&self) -> &LineFaults {
        &self.faults
    }

    /// Wraps the world for sharing between ports.
    pub fn shared(self) -> SharedWorld {
        Arc::new(Mutex::new(self))
    }

    /// The world's time.
    pub fn now(&self) -> LineInstant {
        self.now
    }

    /// Runs the plant and every device up to `t`, tick by tick while a plant is attached.
    pub fn advance_to(&mut self, t: LineInstant) {
        if t <= self.now {
            return;
        }
        match self.plant.as_mut() {
            None => {
                for d in &mut self.devices {
                    d.device.advance_to(t);
                }
            }
            Some(wired) => {
                let mut tick = self.now;
                while tick < t {
                    tick = (tick + TICK).min(t);
                    for d in &mut self.devices {
                        d.device.advance_to(tick);
                    }
                    let mut io = Wiring {
                        devices: &mut self.devices,
                        wires: &wired.wires,
                    };
                    wired.plant.step(tick, &mut io);
                }
            }
        }
        self.now = t;
    }

    /// A device's index by its name (`mm1`) or by `model@address` (`minimod@5`).
    pub fn find(&self, name: &str) -> Option<usize> {
        self.devices.iter().position(|d| {
            d.name == name || format!("{}@{}", d.device.model(), d.device.address()) == name
        })
    }

    /// Names of all devices, in order.
    pub fn names(&self) -> Vec<String> {
        self.devices.iter().map(|d| d.name.clone()).collect()
    }

    /// A device, for commands and tests.
    pub fn device_mut(&mut self, index: usize) -> Option<&mut dyn SimDevice> {
        match self.devices.get_mut(index) {
            Some(d) => Some(d.device.as_mut()),
            None => None,
        }
    }

    /// Reads a point of a device.
    pub fn get(&self, index: usize, point: &str) -> Result<Value, SimError> {
        match self.devices.get(index) {
            Some(d) => d.device.get(point),
            None => Err(SimError::UnknownCommand(format!("no device {index}"))),
        }
    }

    /// Sets a point of a device.
    pub fn set(&mut self, index: usize, point: &str, value: Value) -> Result<(), SimError> {
        match self.devices.get_mut(index) {
            Some(d) => d.device.set(point, value),
            None => Err(SimError::UnknownCommand(format!("no device {index}"))),
        }
    }

    /// A frame from the master of `line` has ended on the wire at `t`: every device on the line
    /// hears it; the replies are queued to arrive at the master byte by byte. A device that
    /// frames by silence ([`SimDevice::frame_silence`]) takes it as part of the request it is
    /// hearing when the pause before it was shorter than its silence, and gets that request
    /// once the silence has passed ([`Self::settle`]).
    pub fn deliver(&mut self, line: usize, frame: &[u8], t: LineInstant) {
        self.advance_to(t);
        let Some(settings) = self.line_settings.get(line).copied() else {
            return;
        };
        let format_known = self.format_known.get(line).copied().unwrap_or(true);
        // The adapter hears the frame even when nothing else on the line is alive.
        self.queue_echo(line, frame, settings, t);
        if self.faults.is_dead(line) {
            return;
        }
        let start = t - settings.chars(frame.len());
        let mut requests = Vec::new();
        for (i, d) in on_line(&mut self.devices, line) {
            if d.own_uart {
                d.device
                    .master_line(settings.baud, format_known.then_some(settings.format));
            }
            // A UART at another baud or format than the sender samples the wrong bits: it
            // hears garbage, and answers nothing a master at its own settings could read.
            let heard = match d.settings {
                Some(own)
                    if own.baud != settings.baud
                        || (format_known && own.format != settings.format) =>
                {
                    garble(frame)
                }
                _ => frame.to_vec(),
            };
            match d.device.frame_silence(settings) {
                None => requests.push((i, heard, t)),
                Some(silence) => {
                    if let Heard::Ended(bytes, end) =
                        Assembly::hear(&mut d.assembly, &heard, start, t, silence)
                    {
                        requests.push((i, bytes, end));
                    }
                }
            }
        }
        self.hand_over(line, settings, requests);
    }

    /// The longest end-of-request silence of the devices on `line` that frame by silence
    /// ([`SimDevice::frame_silence`]); `None` when none does.
    pub fn frame_silence(&self, line: usize) -> Option<Duration> {
        let settings = self.line_settings.get(line).copied()?;
        self.devices
            .iter()
            .filter(|d| d.line == line)
            .filter_map(|d| d.device.frame_silence(settings))
            .max()
    }

    /// The master of `line` has kept silent until `t`: every device whose end-of-request
    /// silence has passed gets the request it was hearing.
    pub fn settle(&mut self, line: usize, t: LineInstant) {
        let Some(settings) = self.line_settings.get(line).copied() else {
            return;
        };
        let mut requests = Vec::new();
        for (i, d) in on_line(&mut self.devices, line) {
            let Some(silence) = d.device.frame_silence(settings) else {
                continue;
            };
            if let Some((bytes, end)) = Assembly::complete(&mut d.assembly, t, silence) {
                requests.push((i, bytes, end));
            }
        }
        if !requests.is_empty() {
            self.hand_over(line, settings, requests);
        }
    }

    /// Requests as the devices have framed them, `(device, bytes, end on the wire)`: each
    /// device acts on its own, and the replies go on the wire.
    fn hand_over(
        &mut self,
        line: usize,
        settings: LineSettings,
        requests: Vec<(usize, Vec<u8>, LineInstant)>,
    ) {
        let char_time = settings.char_time();
        let mut replies = Vec::new();
        for (i, bytes, end) in requests {
            let Some(d) = self.devices.get_mut(i) else {
                continue;
            };
            d.device.advance_to(end);
            if let Some(reply) = d.device.on_frame(&bytes, end) {
                let polite = d.device.yields_to_earlier_reply(&bytes);
                replies.push((i, reply, end, polite));
            }
        }
        // Devices that listen before talking drop out when an earlier one answers.
        let earliest_polite = replies
            .iter()
            .filter(|r| r.3)
            .map(|(_, r, end, _)| *end + r.delay)
            .min();
        if let Some(first) = earliest_polite {
            let mut kept_first = false;
            replies.retain(|(_, r, end, polite)| {
                if !polite {
                    return true;
                }
                let keep = *end + r.delay == first && !kept_first;
                kept_first |= keep;
                keep
            });
        }
        let Some(inbound) = self.inbound.get_mut(line) else {
            return;
        };
        for (device, reply, end, _) in replies {
            let wire = self
                .faults
                .apply(device, reply.bytes, reply.delay, char_time);
            for (offset, bytes) in wire.bursts {
                for (i, b) in bytes.iter().enumerate() {
                    let at = end + offset + settings.chars(i + 1);
                    inbound.bytes.push_back((at, *b));
                }
            }
        }
        // Overlapping replies interleave on the wire; keep arrival order and let bytes that
        // land in the same character slot garble each other.
        let mut v: Vec<(LineInstant, u8)> = inbound.bytes.drain(..).collect();
        v.sort_by_key(|(at, _)| *at);
        let mut merged: VecDeque<(LineInstant, u8)> = VecDeque::with_capacity(v.len());
        for (at, b) in v {
            match merged.back_mut() {
                Some((last_at, last_b)) if at.max(*last_at) - at.min(*last_at) < char_time => {
                    *last_b |= b
                }
                _ => merged.push_back((at, b)),
            }
        }
        inbound.bytes = merged;
    }

    /// Time of the next byte due to the master of `line`, if any.
    pub fn next_arrival(&self, line: usize) -> Option<LineInstant> {
        self.inbound
            .get(line)
            .and_then(|i| i.bytes.front().map(|(at, _)| *at))
    }

    /// Moves every byte of `line` that has arrived by `t` into `buf`; returns how many.
    pub fn take_arrived(&mut self, line: usize, t: LineInstant, buf: &mut Vec<u8>) -> usize {
        // Taking what came by `t` means the master kept silent until then.
        self.settle(line, t);
        self.take_arrived_by(line, t, buf)
    }

    /// [`Self::take_arrived`] without settling the requests being heard.
    fn take_arrived_by(&mut self, line: usize, t: LineInstant, buf: &mut Vec<u8>) -> usize {
        let Some(inbound) = self.inbound.get_mut(line) else {
            return 0;
        };
        let mut n = 0;
        while let Some((at, b)) = inbound.bytes.front().copied() {
            if at > t {
                break;
            }
            inbound.bytes.pop_front();
            buf.push(b);
            n += 1;
        }
        n
    }

    /// Drops the bytes of `line` that have arrived by `t`; returns how many.
    /// (A master that transmits until `t` has not kept silent: nothing is settled here.)
    pub fn drop_arrived(&mut self, line: usize, t: LineInstant) -> usize {
        let mut sink = Vec::new();
        self.take_arrived_by(line, t, &mut sink)
    }
}

/// The devices on `line`, with their indexes in the world.
fn on_line(devices: &mut [Placed], line: usize) -> impl Iterator<Item = (usize, &mut Placed)> {
    devices
        .iter_mut()
        .enumerate()
        .filter(move |(_, d)| d.line == line)
}

/// What a UART at the wrong baud or format makes of `frame`, deterministically: every byte
/// inverted, so a text command (printable ASCII) becomes bytes above 0x7F that no text
/// protocol accepts, and an RTU frame's CRC no longer matches.
pub(crate) fn garble(frame: &[u8]) -> Vec<u8> {
    frame.iter().map(|b| !b).collect()
}

struct Wiring<'a> {
    devices: &'a mut [Placed],
    wires: &'a [(usize, String)],
}

impl PlantIo for Wiring<'_> {
    fn read(&self, role: usize) -> bool {
        self.wires
            .get(role)
            .and_then(|(dev, point)| self.devices.get(*dev).map(|d| d.device.get(point)))
            .and_then(Result::ok)
            .is_some_and(Value::as_bool)
    }

    fn write(&mut self, role: usize, value: bool) {
        self.write_value(role, Value::Bool(value));
    }

    fn read_value(&self, role: usize) -> Value {
        self.wires
            .get(role)
            .and_then(|(dev, point)| self.devices.get(*dev).map(|d| d.device.get(point)))
            .and_then(Result::ok)
            .unwrap_or(Value::Bool(false))
    }

    fn write_value(&mut self, role: usize, value: Value) {
        if let Some((dev, point)) = self.wires.get(role) {
            if let Some(d) = self.devices.get_mut(*dev) {
                // Wiring was checked against the model when the world was built.
                drop(d.device.set(point, value));
            }
        }
    }
}

/// How a virtual port keeps time.
#[derive(Debug)]
enum PortTime {
    /// Follows a real clock and sleeps for wire time.
    Real(Arc<dyn Clock>),
    /// Its own cursor, moved by the traffic and synced to the scan at each cycle start.
    Virtual(LineInstant),
}

/// The master's end of a virtual line.
#[derive(Debug)]
pub struct VirtualPort {
    world: SharedWorld,
    line: usize,
    settings: LineSettings,
    time: PortTime,
}

impl VirtualPort {
    /// A port on `line` of `world` that runs in real time on `clock` (or on its own virtual
    /// cursor when `clock` is virtual, so lines replay deterministically).
    pub fn new(
        world: SharedWorld,
        line: usize,
        settings: LineSettings,
        clock: Arc<dyn Clock>,
    ) -> Self {
        let time = if clock.is_virtual() {
            PortTime::Virtual(clock.line_now())
        } else {
            PortTime::Real(clock)
        };
        Self {
            world,
            line,
            settings,
            time,
        }
    }

    fn lock(&self) -> MutexGuard<'_, SimWorld> {
        // A panic while holding the lock leaves a world that is still consistent tick-wise; keep
        // serving rather than poisoning every later access.
        self.world.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn sleep_until(&mut self, t: LineInstant) {
        match &mut self.time {
            PortTime::Real(clock) => clock.sleep_until_on_line(t),
            PortTime::Virtual(cursor) => *cursor = (*cursor).max(t),
        }
    }
}

impl Transport for VirtualPort {
    fn settings(&self) -> LineSettings {
        self.settings
    }

    fn now(&self) -> LineInstant {
        match &self.time {
            PortTime::Real(clock) => clock.line_now(),
            PortTime::Virtual(cursor) => *cursor,
        }
    }

    fn sync(&mut self, t: LineInstant) {
        if let PortTime::Virtual(cursor) = &mut self.time {
            *cursor = (*cursor).max(t);
        }
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        let start = self.now();
        let end = start + self.settings.chars(frame.len());
        self.sleep_until(end);
        let line = self.line;
        let mut world = self.lock();
        // The line was silent until this frame began: what the modules heard before it and
        // whose silence is over by then are requests, answered before this one collides.
        world.settle(line, start);
        // A reply still on the wire while the master transmits collides with the request: the
        // master hears neither, so it cannot later take those bytes for the new reply.
        world.drop_arrived(line, end);
        world.deliver(line, frame, end);
        Ok(())
    }

    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        let line = self.line;
        // The master listens: it sends nothing before `deadline`, so every request whose
        // silence ends by then is complete.
        let first = {
            let mut world = self.lock();
            world.settle(line, deadline);
            world.next_arrival(line)
        };
        match first {
            Some(at) if at <= deadline => {
                let at = at.max(self.now());
                self.sleep_until(at);
                let now = self.now();
                Ok(self.lock().take_arrived(line, now, buf))
            }
            _ => {
                self.sleep_until(deadline);
                Ok(0)
            }
        }
    }

    fn wait_until(&mut self, t: LineInstant) {
        self.sleep_until(t);
        let (line, now) = (self.line, self.now());
        self.lock().settle(line, now);
    }

    fn flush_input(&mut self) -> Result<usize, LineError> {
        let (line, now) = (self.line, self.now());
        let mut world = self.lock();
        world.settle(line, now);
        Ok(world.drop_arrived(line, now))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::line::settings::SerialFormat;
    use crate::modbus::crc::append_crc;

    /// A module whose UART runs at 9600 8N1 does not answer a master at 19200 8E1, and does
    /// once the master changes to its settings.
    #[test]
    fn a_module_at_other_line_settings_hears_garbage() {
        let model = crate::devices::model("ex9053d").unwrap();
        let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
        let d = world.add_device(0, "ex5", (model.simulator)(5));
        let own = LineSettings {
            baud: 9600,
            format: "8N1".parse().unwrap(),
        };
        world.set_device_settings(d, own);
        let ask = b"$05M\r".to_vec();
        world.deliver(
            0,
            &ask,
            LineInstant::after_origin(Duration::from_millis(10)),
        );
        assert_eq!(world.next_arrival(0), None);
        // A pty carries the baud only: the same baud is enough.
        world.follow_master_baud(0, 9600);
        world.deliver(
            0,
            &ask,
            LineInstant::after_origin(Duration::from_millis(100)),
        );
        let mut reply = Vec::new();
        world.take_arrived(
            0,
            LineInstant::after_origin(Duration::from_secs(1)),
            &mut reply,
        );
        assert_eq!(reply, b"!059053\r", "{reply:?}");
        world.set_master_settings(
            0,
            LineSettings {
                baud: 9600,
                format: SerialFormat::EVEN_8E1,
            },
        );
        world.deliver(0, &ask, LineInstant::after_origin(Duration::from_secs(2)));
        assert_eq!(world.next_arrival(0), None);
    }

    /// Two MiniMods with queued input events hear one broadcast Collect: slave 4 answers in its
    /// slot and slave 6, hearing it, stays silent (the master then polls the window 5–16).
    #[test]
    fn a_collect_slot_reply_silences_the_later_slaves() {
        let model = crate::devices::model("minimod").unwrap();
        let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
        for addr in [4, 6] {
            let d = world.add_device(0, &format!("mm{addr}"), (model.simulator)(addr));
            world.set(d, "EVX1", Value::Bool(true)).unwrap();
            world.set(d, "X1", Value::Bool(true)).unwrap();
        }
        world.advance_to(LineInstant::after_origin(Duration::from_millis(100)));
        let mut collect = vec![0x00, 70, 1, 16, 0, 0];
        append_crc(&mut collect);
        world.deliver(
            0,
            &collect,
            LineInstant::after_origin(Duration::from_millis(100)),
        );
        let mut reply = Vec::new();
        world.take_arrived(
            0,
            LineInstant::after_origin(Duration::from_secs(1)),
            &mut reply,
        );
        assert_eq!(reply.len(), 9, "one reply, not two garbled: {reply:02X?}");
        assert_eq!(&reply[..2], &[4, 70]);
        assert!(crate::modbus::crc::check_crc(&reply));
    }
}
