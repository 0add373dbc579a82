//! The Collect planner alone, then Collect rounds through the real bus owner on the virtual
//! line with simulated MiniMods (virtual clock).

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::*;
use crate::devices::minimod::settings::Setting;
use crate::devices::minimod::MiniModDriver;
use crate::devices::{self, Protocol};
use crate::driver::Driver;
use crate::line::bus::{BusOwner, Discipline, InputFrame, Module, OutputFrame};
use crate::line::settings::LineSettings;
use crate::line::transport::{LineError, Transport};
use crate::modbus::crc::append_crc;
use crate::modbus::master::encode_request;
use crate::point::{Quality, Value};
use crate::sim::line::{SharedWorld, SimWorld, VirtualPort};
use crate::sim::{SimDevice, SimError, SimReply};
use crate::time::{Clock, LineInstant, ScanInstant, VirtualClock};

fn frame(bytes: &[u8]) -> Vec<u8> {
    let mut f = bytes.to_vec();
    append_crc(&mut f);
    f
}

fn wire(req: &Request) -> Vec<u8> {
    let mut out = Vec::new();
    encode_request(0, req, &mut out).unwrap();
    out
}

#[test]
fn the_manual_exchange_window_1_16_slave_4_then_5_16() {
    let mut round = CollectRound::new(1, 16, None).unwrap();
    let first = round.request().unwrap();
    assert_eq!(wire(&first), frame(&[0x00, 0x46, 0x01, 0x10, 0x00, 0x00]));
    assert_eq!(
        round.reply_window(),
        Duration::from_millis(16 * 3 + 1),
        "16 slots + 1 ms"
    );
    round.on_reply(4, 0x21);
    let second = round.request().unwrap();
    assert_eq!(
        second,
        Request::Collect {
            first: 5,
            last: 16,
            slave_ack: 4,
            slave_seq: 0x21
        }
    );
    assert_eq!(wire(&second), frame(&[0x00, 0x46, 0x05, 0x10, 0x04, 0x21]));
    assert_eq!(round.reply_window(), Duration::from_millis(12 * 3 + 1));
    round.on_silence();
    assert!(round.is_done() && !round.failed());
    assert_eq!(round.request(), None);
    assert_eq!(round.pending_ack(), None, "sent with 5–16");
}

#[test]
fn the_last_address_is_acknowledged_by_the_next_round() {
    let mut round = CollectRound::new(3, 9, None).unwrap();
    assert_eq!(
        round.slot_end(9),
        Duration::from_millis(21),
        "the seventh slot"
    );
    round.on_reply(9, 7);
    assert!(round.is_done());
    assert_eq!(round.request(), None);
    assert_eq!(round.pending_ack(), Some((9, 7)));
    let next = CollectRound::new(3, 9, round.pending_ack()).unwrap();
    assert_eq!(
        next.request(),
        Some(Request::Collect {
            first: 3,
            last: 9,
            slave_ack: 9,
            slave_seq: 7
        })
    );
    let mut garbled = CollectRound::new(1, 1, Some((1, 1))).unwrap();
    garbled.on_failure();
    assert!(garbled.failed() && garbled.request().is_none());
    assert_eq!(garbled.pending_ack(), None, "the acknowledgement went out");
}

#[test]
fn windows_from_members() {
    assert_eq!(CollectRound::over(&[], None), None);
    assert_eq!(CollectRound::new(0, 4, None), None);
    assert_eq!(CollectRound::new(5, 4, None), None);
    let r = CollectRound::over(&[12, 3, 7], None).unwrap();
    assert_eq!(
        r.request(),
        Some(Request::Collect {
            first: 3,
            last: 12,
            slave_ack: 0,
            slave_seq: 0
        })
    );
}

#[test]
fn membership_is_the_drivers() {
    let unit = crate::modbus::UnitId::new(9).unwrap();
    let settings = [
        Setting::parse("events", "true").unwrap(),
        Setting::parse("event_refresh", "1500ms").unwrap(),
    ];
    let member = MiniModDriver::new(Some(unit), &settings);
    assert_eq!(
        member.collect_membership(),
        Some(Membership {
            unit,
            answer_within: Duration::from_millis(1500),
            resync: Duration::from_secs(30),
            frame_timeout: Duration::ZERO,
        })
    );
    let polled = MiniModDriver::new(Some(unit), &[]);
    assert_eq!(polled.collect_membership(), None, "polled, not a member");
    assert_eq!(next_seq(1), 2);
    assert_eq!(next_seq(255), 1, "0 is skipped");
}

/// A transport that keeps every frame the master writes.
#[derive(Debug)]
struct Recorder {
    inner: VirtualPort,
    log: Arc<Mutex<Vec<Vec<u8>>>>,
}

impl Transport for Recorder {
    fn settings(&self) -> LineSettings {
        self.inner.settings()
    }
    fn now(&self) -> LineInstant {
        self.inner.now()
    }
    fn sync(&mut self, t: LineInstant) {
        self.inner.sync(t);
    }
    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        self.log.lock().unwrap().push(frame.to_vec());
        self.inner.write_frame(frame)
    }
    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        self.inner.read_until(buf, deadline)
    }
    fn wait_until(&mut self, t: LineInstant) {
        self.inner.wait_until(t);
    }
    fn flush_input(&mut self) -> Result<usize, LineError> {
        self.inner.flush_input()
    }
}

struct Rig {
    clock: Arc<VirtualClock>,
    world: SharedWorld,
    owner: BusOwner,
    log: Arc<Mutex<Vec<Vec<u8>>>>,
}

/// One MiniMod of a rig: address, protocol, settings.
type Spec<'a> = (u8, Protocol, &'a [(&'a str, &'a str)]);

/// A module's simulator as the rig puts it on the line (wrapped, or as it is).
type SimAs = fn(u8, Box<dyn SimDevice>) -> Box<dyn SimDevice>;

/// MiniMods on one line at 19200 8E1.
fn rig(specs: &[Spec<'_>]) -> Rig {
    rig_with(specs, |_, sim| sim)
}

/// [`rig`], each simulator passed through `sim_as` with its address.
fn rig_with(specs: &[Spec<'_>], sim_as: SimAs) -> Rig {
    rig_on(specs, sim_as, Duration::ZERO)
}

/// [`rig_with`], behind an adapter that holds received bytes `adapter_latency` back.
fn rig_on(specs: &[Spec<'_>], sim_as: SimAs, adapter_latency: Duration) -> Rig {
    let line = LineSettings::DEFAULT;
    let model = devices::model("minimod").unwrap();
    let mut world = SimWorld::new(vec![line]);
    let mut modules = Vec::new();
    for (address, protocol, settings) in specs {
        let name = format!("mm{address}");
        world.add_device(0, &name, sim_as(*address, (model.simulator)(*address)));
        let config = model
            .device_config(&name, *address, *protocol, settings)
            .unwrap();
        let driver = (model.driver)(&config);
        modules.push(Module::new(name, driver));
    }
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    let log = Arc::new(Mutex::new(Vec::new()));
    let port = Recorder {
        inner: VirtualPort::new(world.clone(), 0, line, clock.clone()),
        log: log.clone(),
    };
    let discipline = Discipline {
        response_timeout: Duration::from_millis(50),
        retries: 0,
        adapter_latency,
        ..Discipline::default()
    };
    let owner = BusOwner::new("line", Box::new(port), discipline, modules);
    Rig {
        clock,
        world,
        owner,
        log,
    }
}

impl Rig {
    /// Start-up at 0; returns when it ended, in ms.
    fn startup(&mut self) -> u64 {
        self.owner.sync(self.clock.line_now());
        self.owner.startup().unwrap();
        self.clock.now().since_origin().as_millis() as u64
    }

    /// One read cycle starting at `ms` (the line keeps its own time if still busy); returns
    /// the frame and what went on the wire.
    fn read_at(&mut self, ms: u64) -> (InputFrame, Vec<Vec<u8>>) {
        self.at(ms);
        self.log.lock().unwrap().clear();
        self.owner.sync(self.clock.line_now());
        let frame = self.owner.read_inputs();
        self.clock.advance_to(frame.finished.on_scan_clock());
        let sent = std::mem::take(&mut *self.log.lock().unwrap());
        (frame, sent)
    }

    /// Sets a simulated terminal now.
    fn set(&self, device: usize, point: &str, on: bool) {
        let mut w = self.world.lock().unwrap();
        w.advance_to(self.clock.line_now());
        w.set(device, point, Value::Bool(on)).unwrap();
    }

    /// Switches module `device` off and on at `ms` (the simulator's `power-cycle`).
    fn power_cycle_at(&self, ms: u64, device: usize) {
        self.at(ms);
        let mut w = self.world.lock().unwrap();
        w.advance_to(self.clock.line_now());
        w.device_mut(device)
            .unwrap()
            .command(&["power-cycle"])
            .unwrap();
    }

    fn at(&self, ms: u64) {
        self.clock
            .advance_to(ScanInstant::after_origin(Duration::from_millis(ms)));
    }
}

fn value(frame: &InputFrame, module: usize, point: &str) -> Option<Value> {
    let i = devices::model("minimod")
        .unwrap()
        .point_index(point)
        .unwrap();
    frame.modules[module].values[i]
}

fn collect(first: u8, last: u8, ack: u8, seq: u8) -> Vec<u8> {
    frame(&[0x00, 0x46, first, last, ack, seq])
}

fn fc2(unit: u8) -> Vec<u8> {
    frame(&[unit, 0x02, 0x00, 0x00, 0x00, 0x0A])
}

const EVENTS: &[(&str, &str)] = &[
    ("events", "true"),
    ("XLATUP1", "0"),
    ("XLATDN1", "0"),
    ("XLATUP2", "0"),
    ("XLATDN2", "0"),
];

#[test]
fn event_mode_through_the_bus_owner() {
    // mm2 polled, mm4 and mm9 in event mode.
    let mut r = rig(&[
        (2, Protocol::Modbus, &[]),
        (4, Protocol::Modbus, EVENTS),
        (9, Protocol::Modbus, EVENTS),
    ]);
    assert!(r.startup() < 900);

    // First cycle: a silent round over 4..=9, then everyone read in full.
    let (f, sent) = r.read_at(1000);
    assert_eq!(sent, [collect(4, 9, 0, 0), fc2(2), fc2(4), fc2(9)]);
    assert!(f.modules.iter().all(|m| m.quality == Quality::Good));
    assert_eq!(value(&f, 1, "X1"), Some(Value::Bool(false)));

    // X1 of slave 4 goes on: slave 4 answers in its slot, window 5..=9 acknowledges it, no
    // full read of 4 or 9.
    r.at(1050);
    r.set(1, "X1", true);
    let (f, sent) = r.read_at(1100);
    assert_eq!(sent, [collect(4, 9, 0, 0), collect(5, 9, 4, 1), fc2(2)]);
    assert_eq!(
        value(&f, 1, "X1"),
        Some(Value::Bool(true)),
        "from the event"
    );
    assert_eq!(f.modules[1].quality, Quality::Good);

    // Nothing happens: one silent Collect and the polled module.
    let (_, sent) = r.read_at(1200);
    assert_eq!(sent, [collect(4, 9, 0, 0), fc2(2)]);

    // Slave 9, the window's last address: acknowledged by the next round.
    r.at(1250);
    r.set(2, "X2", true);
    let (f, sent) = r.read_at(1300);
    assert_eq!(sent, [collect(4, 9, 0, 0), fc2(2)]);
    assert_eq!(value(&f, 2, "X2"), Some(Value::Bool(true)));
    let (_, sent) = r.read_at(1400);
    assert_eq!(sent, [collect(4, 9, 9, 1), fc2(2)]);
    assert!(!r
        .world
        .lock()
        .unwrap()
        .get(2, "EVENTSPRS")
        .unwrap()
        .as_bool());

    // A pulse shorter than a cycle: on in one cycle, off in the next (one event per round).
    r.at(1450);
    r.set(1, "X2", true);
    r.at(1460);
    r.set(1, "X2", false);
    let (f, _) = r.read_at(1500);
    assert_eq!(
        value(&f, 1, "X2"),
        Some(Value::Bool(true)),
        "the pulse is seen"
    );
    let (f, _) = r.read_at(1600);
    assert_eq!(value(&f, 1, "X2"), Some(Value::Bool(false)));

    // From three quarters of a second after their full read on, one member a cycle is read
    // in full again (nothing else addressed to them answered): 4 first, then 9, never both.
    let (_, sent) = r.read_at(1700);
    assert_eq!(sent, [collect(4, 9, 0, 0), fc2(2)]);
    let (_, sent) = r.read_at(1800);
    assert_eq!(sent, [collect(4, 9, 0, 0), fc2(2), fc2(4)]);
    let (_, sent) = r.read_at(1900);
    assert_eq!(sent, [collect(4, 9, 0, 0), fc2(2), fc2(9)]);
    let (_, sent) = r.read_at(2000);
    assert_eq!(sent, [collect(4, 9, 0, 0), fc2(2)]);

    let stats = r.owner.collect_stats();
    assert_eq!(stats.events, 4);
    assert_eq!(stats.failures, 0);
    assert_eq!(stats.gaps, 0);
    assert_eq!(stats.refreshes, 4);
}

/// One event-mode member, read in full when nothing answered for 300 ms, X1 unfiltered.
const FAST_REFRESH: &[(&str, &str)] = &[
    ("events", "true"),
    ("event_refresh", "300ms"),
    ("XLATUP1", "0"),
];

#[test]
fn periodic_refresh_repairs_a_lost_event() {
    let mut r = rig(&[(4, Protocol::Modbus, FAST_REFRESH)]);
    r.startup();
    let (_, sent) = r.read_at(1000);
    assert_eq!(sent, [collect(4, 4, 0, 0), fc2(4)]);
    // The module stops recording events (as after a power cycle): X1 changes silently.
    r.at(1050);
    {
        let mut w = r.world.lock().unwrap();
        w.set(0, "XEVMASK", Value::U16(0)).unwrap();
        w.set(0, "X1", Value::Bool(true)).unwrap();
    }
    for t in [1100, 1200] {
        let (f, sent) = r.read_at(t);
        assert_eq!(sent, [collect(4, 4, 0, 0)]);
        assert_eq!(value(&f, 0, "X1"), Some(Value::Bool(false)), "not seen yet");
    }
    let (f, sent) = r.read_at(1300);
    assert_eq!(sent, [collect(4, 4, 0, 0), fc2(4)]);
    assert_eq!(
        value(&f, 0, "X1"),
        Some(Value::Bool(true)),
        "the full read every 300 ms"
    );
}

#[test]
fn a_gap_in_slvseq_triggers_a_full_read() {
    let mut r = rig(&[(4, Protocol::Modbus, EVENTS)]);
    r.startup();
    r.read_at(1000);
    r.at(1010);
    r.set(0, "X1", true);
    let (_, sent) = r.read_at(1100);
    assert_eq!(sent, [collect(4, 4, 0, 0)], "event 1");
    // 20 variations in one cycle overflow the 16-event queue: the oldest are dropped.
    for k in 0..20u64 {
        r.at(1110 + 2 * k);
        r.set(0, "X1", k % 2 == 1);
    }
    let (f, sent) = r.read_at(1200);
    assert_eq!(
        sent,
        [collect(4, 4, 4, 1), fc2(4)],
        "a full read after the gap"
    );
    assert_eq!(
        value(&f, 0, "X1"),
        Some(Value::Bool(true)),
        "the present state"
    );
    assert_eq!(r.owner.collect_stats().gaps, 1);
}

#[test]
fn event_mode_with_the_text_protocol_and_two_slaves_with_events() {
    // Slaves 3 and 12 both have an event for the same round: on the virtual line they cannot
    // hear each other, so slave 12 answers the first Collect too; the round still ends clean.
    let mut r = rig(&[
        (3, Protocol::Text, EVENTS),
        (12, Protocol::Modbus, EVENTS),
        (7, Protocol::Text, &[]),
    ]);
    r.startup();
    let (f, sent) = r.read_at(1000);
    assert_eq!(sent[0], collect(3, 12, 0, 0));
    assert!(sent.contains(&b"@3?XWORD\r".to_vec()), "text refresh");
    assert!(sent.contains(&b"@7?XWORD\r".to_vec()), "text poll");
    assert!(f.modules.iter().all(|m| m.quality == Quality::Good));
    r.at(1150);
    r.set(0, "X1", true);
    r.set(1, "X2", true);
    let (f, _) = r.read_at(1200);
    assert_eq!(value(&f, 0, "X1"), Some(Value::Bool(true)));
    assert_eq!(value(&f, 1, "X2"), Some(Value::Bool(true)));
    assert!(f
        .modules
        .iter()
        .all(|m| m.quality == Quality::Good && m.last_error.is_none()));
    let (f, sent) = r.read_at(1400);
    assert_eq!(
        sent,
        [collect(3, 12, 12, 1), b"@7?XWORD\r".to_vec()],
        "the line is clean"
    );
    assert!(f.modules.iter().all(|m| m.last_error.is_none()));
    assert_eq!(r.owner.collect_stats().failures, 0);
}

/// Back-to-back idle rounds over 4 members: from the end of one to the end of the next.
fn idle_round_time(specs: &[Spec<'_>]) -> Duration {
    let mut r = rig(specs);
    r.startup();
    r.read_at(1000);
    let (first, sent) = r.read_at(1100);
    assert_eq!(sent.len(), 1, "one silent Collect");
    r.owner.sync(first.finished);
    let second = r.owner.read_inputs();
    second.finished - first.finished
}

#[test]
fn an_idle_round_is_its_floor_and_one_character() {
    let members: Vec<Spec<'_>> = (1..=4).map(|a| (a, Protocol::Modbus, EVENTS)).collect();
    let s = LineSettings::DEFAULT;
    let floor = floor::CollectFloor::over(s, Default::default(), &[1, 2, 3, 4]).unwrap();
    // t3.5 after the last round, 8 characters, 4 slots + 1 ms, and the first-character margin.
    assert_eq!(idle_round_time(&members), floor.idle() + s.char_time());
    assert_eq!(first_char_margin(s), s.char_time());
    // 19.588 ms + 0.573 ms: within 5 % of the floor (the manual's own timeout).
    assert!(floor.idle().mul_f64(1.05) > floor.idle() + s.char_time());
}

/// A MiniMod that starts its Collect replies `late` later in its slot than the simulator.
#[derive(Debug)]
struct LateInSlot {
    inner: Box<dyn SimDevice>,
    late: Duration,
}

impl SimDevice for LateInSlot {
    fn model(&self) -> &'static str {
        self.inner.model()
    }
    fn address(&self) -> u8 {
        self.inner.address()
    }
    fn advance_to(&mut self, t: LineInstant) {
        self.inner.advance_to(t);
    }
    fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply> {
        let mut reply = self.inner.on_frame(frame, t)?;
        if frame.get(1) == Some(&70) {
            reply.delay += self.late;
        }
        Some(reply)
    }
    fn points(&self) -> &'static [crate::point::PointSpec] {
        self.inner.points()
    }
    fn get(&self, point: &str) -> Result<Value, SimError> {
        self.inner.get(point)
    }
    fn set(&mut self, point: &str, value: Value) -> Result<(), SimError> {
        self.inner.set(point, value)
    }
    fn yields_to_earlier_reply(&self, frame: &[u8]) -> bool {
        self.inner.yields_to_earlier_reply(frame)
    }
}

#[test]
fn a_reply_begun_at_the_end_of_the_window_is_heard() {
    // Slave 4 of window 1–4 starts its reply 13 ms after the request, the last instant of
    // 4 slots + 1 ms (the simulator starts 1 ms into the slot, at 10 ms: 3 ms later).
    let members: Vec<Spec<'_>> = (1..=4).map(|a| (a, Protocol::Modbus, EVENTS)).collect();
    let mut r = rig_with(&members, |address, sim| {
        if address == 4 {
            Box::new(LateInSlot {
                inner: sim,
                late: Duration::from_millis(3),
            })
        } else {
            sim
        }
    });
    r.startup();
    r.read_at(1000);
    r.at(1050);
    r.set(3, "X1", true);
    let (f, sent) = r.read_at(1100);
    assert_eq!(sent, [collect(1, 4, 0, 0)], "no poll: the event was heard");
    assert_eq!(value(&f, 3, "X1"), Some(Value::Bool(true)));
    assert!(f.modules.iter().all(|m| m.last_error.is_none()));
    let stats = r.owner.collect_stats();
    assert_eq!((stats.events, stats.failures), (1, 0));
    let (_, sent) = r.read_at(1200);
    assert_eq!(
        sent,
        [collect(1, 4, 4, 1)],
        "acknowledged by the next round"
    );
}

#[test]
fn behind_a_usb_adapter_the_window_waits_for_its_latency_timer() {
    // Slave 4's reply at the window's last instant, held 16 ms more by an FTDI adapter's
    // default latency timer (modelled as a reply that starts 16 ms later on the wire).
    let late = |address, sim: Box<dyn SimDevice>| -> Box<dyn SimDevice> {
        if address == 4 {
            Box::new(LateInSlot {
                inner: sim,
                late: Duration::from_millis(3 + 16),
            })
        } else {
            sim
        }
    };
    let members: Vec<Spec<'_>> = (1..=4).map(|a| (a, Protocol::Modbus, EVENTS)).collect();
    let heard = |adapter_ms: u64| {
        let mut r = rig_on(&members, late, Duration::from_millis(adapter_ms));
        r.startup();
        r.read_at(1000);
        r.at(1050);
        r.set(3, "X1", true);
        let (f, _) = r.read_at(1100);
        value(&f, 3, "X1") == Some(Value::Bool(true)) && r.owner.collect_stats().failures == 0
    };
    assert!(
        heard(16),
        "the owner told of the adapter hears the late slot"
    );
    assert!(
        !heard(0),
        "without it, the reply is still in the adapter when the window ends"
    );
}

/// The frames of `sent` that are full reads (FC 2), by unit.
fn full_reads(sent: &[Vec<u8>]) -> Vec<u8> {
    sent.iter()
        .filter(|f| f.len() == 8 && f[1] == 0x02)
        .map(|f| f[0])
        .collect()
}

#[test]
fn periodic_full_reads_are_spread_one_a_cycle_and_none_waits_past_its_period() {
    // Four idle members and nothing written: every full read is for want of an answer.
    let mut r = rig(&[
        (1, Protocol::Modbus, EVENTS),
        (2, Protocol::Modbus, EVENTS),
        (3, Protocol::Modbus, EVENTS),
        (4, Protocol::Modbus, EVENTS),
    ]);
    assert!(r.startup() < 2000);
    let (_, sent) = r.read_at(2000);
    assert_eq!(full_reads(&sent), [1, 2, 3, 4], "the first cycle reads all");
    let mut last = [2000u64; 4];
    // The first cycle's four full reads take it past 2100 ms.
    for k in 1..=100u64 {
        let t = 2100 + 50 * k;
        let (f, sent) = r.read_at(t);
        assert_eq!(
            f.started,
            LineInstant::after_origin(Duration::from_millis(t)),
            "the line is free at each cycle"
        );
        let reads = full_reads(&sent);
        assert!(reads.len() <= 1, "at {t} ms: {reads:?} in one cycle");
        for unit in reads {
            let i = usize::from(unit - 1);
            assert!(
                t - last[i] >= 750,
                "unit {unit} read again after {} ms",
                t - last[i]
            );
            last[i] = t;
        }
        for (i, l) in last.iter().enumerate() {
            assert!(
                t - l <= 1000,
                "unit {} not read for {} ms at {t}",
                i + 1,
                t - l
            );
        }
    }
    assert!(
        r.owner.collect_stats().refreshes >= 4 + 4 * 5,
        "each about once a second"
    );
}

/// An output frame that sets Y1 of every module to `on` (the only output the program owns).
fn y1(modules: usize, on: bool) -> OutputFrame {
    let model = devices::model("minimod").unwrap();
    let mut desired = vec![None; model.points.len()];
    desired[model.point_index("Y1").unwrap()] = Some(Value::Bool(on));
    OutputFrame {
        modules: vec![desired; modules],
    }
}

#[test]
fn a_member_that_answers_its_writes_is_read_in_full_only_every_resync() {
    let settings = [
        ("events", "true"),
        ("event_resync", "2500ms"),
        ("XLATUP1", "0"),
    ];
    let mut r = rig(&[(4, Protocol::Modbus, &settings)]);
    r.startup();
    let mut reads = Vec::new();
    for k in 0..30u64 {
        let t = 1000 + 100 * k;
        let (_, sent) = r.read_at(t);
        if !full_reads(&sent).is_empty() {
            reads.push(t);
        }
        // Y1 flips every cycle: each write's echo is the module's answer.
        let report = r.owner.write_outputs(&y1(1, k % 2 == 0));
        assert_eq!((report.transactions, report.failures), (1, 0));
        r.clock.advance_to(report.finished.on_scan_clock());
    }
    assert_eq!(
        reads,
        [1000, 2900],
        "the first cycle, then from 1875 ms of the 2.5 s resync"
    );

    // The writes stop: a second without an answer brings the full read back.
    let mut reads = Vec::new();
    for k in 0..20u64 {
        let t = 4000 + 100 * k;
        let (_, sent) = r.read_at(t);
        if !full_reads(&sent).is_empty() {
            reads.push(t);
        }
    }
    assert_eq!(reads, [4700, 5500], "from 750 ms after the last answer");
}

#[test]
fn a_write_that_covers_every_owned_output_is_the_modules_output_refresh() {
    let mut r = rig(&[(1, Protocol::Modbus, &[]), (2, Protocol::Modbus, &[])]);
    r.startup();
    r.at(1000);
    r.owner.sync(r.clock.line_now());
    let mut writes_per_cycle = Vec::new();
    for k in 0..30u64 {
        r.at(1000 + 100 * k);
        r.owner.sync(r.clock.line_now());
        r.log.lock().unwrap().clear();
        // Only module 1's Y1 changes (every cycle); module 2's stays off.
        let mut frame = y1(2, false);
        let i = devices::model("minimod")
            .unwrap()
            .point_index("Y1")
            .unwrap();
        frame.modules[0][i] = Some(Value::Bool(k % 2 == 1));
        let report = r.owner.write_outputs(&frame);
        r.clock.advance_to(report.finished.on_scan_clock());
        let sent = std::mem::take(&mut *r.log.lock().unwrap());
        writes_per_cycle.push(sent.iter().map(|f| f[0]).collect::<Vec<u8>>());
    }
    assert_eq!(
        writes_per_cycle[0],
        [1, 2],
        "the first write is every output"
    );
    for (k, units) in writes_per_cycle.iter().enumerate().skip(1) {
        // Module 1's change is a full write of what it owns: it is never rewritten besides.
        assert_eq!(units.iter().filter(|&&u| u == 1).count(), 1, "cycle {k}");
    }
    let module2: Vec<usize> = (0..30)
        .filter(|&k| writes_per_cycle[k].contains(&2))
        .collect();
    assert_eq!(
        module2,
        [0, 8, 16, 24],
        "module 2 rewritten from 750 ms, once a period"
    );
}

#[test]
fn with_every_module_written_in_turn_only_the_resync_reads_remain_one_a_cycle() {
    // The bench's full-cycle workload (scenario 12) on the virtual clock: four factory-default
    // members, Y1 of one module flipped each cycle in turn. Every write's echo answers for its
    // module and covers every output it owns, so after the first cycle the only extra exchanges
    // are each module's `event_resync` read (30 s, from 22.5 s on), never two in one cycle.
    let members: Vec<Spec<'_>> = (1..=4)
        .map(|a| (a, Protocol::Modbus, &[("events", "true")][..]))
        .collect();
    let mut r = rig(&members);
    r.startup();
    let yi = devices::model("minimod")
        .unwrap()
        .point_index("Y1")
        .unwrap();
    let mut y = [false; 4];
    let mut t = 2000u64;
    let mut first = None;
    let mut resyncs = Vec::new();
    for k in 0..700usize {
        let (f, sent) = r.read_at(t);
        y[k % 4] = !y[k % 4];
        let mut frame = y1(4, false);
        for (m, on) in y.iter().enumerate() {
            frame.modules[m][yi] = Some(Value::Bool(*on));
        }
        r.log.lock().unwrap().clear();
        let report = r.owner.write_outputs(&frame);
        r.clock.advance_to(report.finished.on_scan_clock());
        let writes = r.log.lock().unwrap().len();
        let reads = full_reads(&sent);
        if k == 0 {
            assert_eq!((reads.len(), writes), (4, 4), "the first cycle: everything");
            first = Some(f.started);
        } else {
            assert_eq!(writes, 1, "cycle {k}: the changed output only");
            assert!(reads.len() <= 1, "cycle {k}: {reads:?}");
            for unit in reads {
                resyncs.push((unit, f.started - first.unwrap_or_default()));
            }
        }
        t = report.finished.since_origin().as_millis() as u64 + 1;
    }
    assert!(
        r.clock.now() > ScanInstant::after_origin(Duration::from_secs(30)),
        "the run passes the first resync"
    );
    assert_eq!(
        resyncs.iter().map(|r| r.0).collect::<Vec<_>>(),
        [1, 2, 3, 4],
        "{resyncs:?}"
    );
    for (unit, after) in resyncs {
        let window = Duration::from_millis(22_500)..Duration::from_secs(30);
        assert!(
            window.contains(&after),
            "unit {unit} resynced after {after:?}"
        );
    }
}

#[test]
fn a_short_power_cycle_that_turned_events_off_is_found_and_the_start_up_runs_again() {
    let mut r = rig(&[(4, Protocol::Modbus, FAST_REFRESH)]);
    r.startup();
    r.read_at(1000);
    // A power cycle between two cycles, too short to be seen as a loss: the module is back
    // on its saved settings, without event recording (the start-up enabled it unsaved).
    r.power_cycle_at(1050, 0);
    r.at(1100);
    r.set(0, "X1", true);
    let mut restarted_at = None;
    let mut seen_at = None;
    for k in 0..12u64 {
        let t = 1200 + 100 * k;
        let (f, sent) = r.read_at(t);
        if seen_at.is_none() && value(&f, 0, "X1") == Some(Value::Bool(true)) {
            seen_at = Some(t);
        }
        // The start-up writes the event mask again (FC 16 over XEVMASK, or FC 6).
        let writes_xevmask = sent
            .iter()
            .any(|f| f[0] == 4 && (f[1] == 0x10 || f[1] == 0x06));
        if restarted_at.is_none() && writes_xevmask {
            restarted_at = Some(t);
        }
    }
    let seen = seen_at.expect("the full read brings the change");
    let restarted = restarted_at.expect("the start-up runs again");
    assert!(seen <= 1400, "within event_refresh: {seen}");
    assert_eq!(
        restarted,
        seen + 200,
        "the XEVMASK read-back the next cycle, the start-up the cycle after"
    );
    // Events flow again: the next change comes by the round, with no full read.
    r.at(2500);
    r.set(0, "X1", false);
    let (f, sent) = r.read_at(2600);
    assert_eq!(value(&f, 0, "X1"), Some(Value::Bool(false)));
    assert!(full_reads(&sent).is_empty(), "{sent:?}");
}

/// Frames of a module's start-up: its FC 16 over XEVMASK (holding register 5).
fn startups(sent: &[Vec<u8>], unit: u8) -> usize {
    sent.iter()
        .filter(|f| f.len() > 4 && f[0] == unit && f[1] == 0x10 && f[2..4] == [0x00, 0x05])
        .count()
}

/// Frames reading XEVMASK (FC 3, register 5, one word): a start-up's read-back, or the
/// driver's question after a change no event reported.
fn mask_reads(sent: &[Vec<u8>], unit: u8) -> usize {
    sent.iter()
        .filter(|f| f.len() == 8 && f[0] == unit && f[1] == 0x03 && f[2..6] == [0, 5, 0, 1])
        .count()
}

/// A rig on the default discipline (one retry, 100 ms response timeout) where 30 % of the
/// modules' replies are lost or corrupted (Collect replies included), seeded; the start-up
/// runs on a clean line.
fn lossy_rig(specs: &[Spec<'_>]) -> Rig {
    use crate::sim::fault::{Fault, FaultRule, Frequency};
    let mut r = rig(specs);
    r.owner.discipline = Discipline::default();
    r.startup();
    let mut w = r.world.lock().unwrap();
    // Independent: 1 - (1 - 0.16) * (1 - 0.167) = 0.30 of the replies are hit.
    for (fault, rate) in [(Fault::Silent, 0.16), (Fault::FlipBit, 0.167)] {
        w.faults_mut().add(FaultRule {
            device: None,
            fault,
            frequency: Frequency::Rate(rate),
        });
    }
    drop(w);
    r
}

#[test]
fn a_minute_of_a_lossy_line_never_runs_the_start_up_again() {
    // Manual, "Configuration of Minimod" / "Saving setting permanently": only a power-up
    // loses the unsaved event mask; a lost or corrupted Collect reply loses an event only.
    let mut r = lossy_rig(&[
        (4, Protocol::Modbus, FAST_REFRESH),
        (5, Protocol::Modbus, FAST_REFRESH),
    ]);
    let (mut startups_seen, mut asked, mut wrong_at_end) = (0, 0, 0);
    let mut level = false;
    for k in 0..600u64 {
        let t = 1000 + 100 * k;
        if k % 7 == 3 {
            level = !level;
            r.at(t - 40);
            r.set(0, "X1", level);
            r.set(1, "X1", !level);
        }
        let (f, sent) = r.read_at(t);
        for unit in [4, 5] {
            startups_seen += startups(&sent, unit);
            asked += mask_reads(&sent, unit);
        }
        if k >= 590 && value(&f, 0, "X1") != Some(Value::Bool(level)) {
            wrong_at_end += 1;
        }
    }
    let w = r.world.lock().unwrap();
    let rounds = r.owner.collect_stats().rounds;
    assert!(
        r.clock.now() >= ScanInstant::after_origin(Duration::from_secs(60)),
        "a minute of line time"
    );
    assert!(
        w.faults().applied > rounds / 5,
        "faults hit the replies: {} in {rounds} rounds",
        w.faults().applied
    );
    // Before the driver asked, this run ran the start-up again 33 times.
    assert!(
        asked > 0,
        "lost events made full reads find changes no event reported, and the driver asked"
    );
    assert_eq!(
        startups_seen, 0,
        "no start-up again; {asked} XEVMASK read-backs"
    );
    assert!(wrong_at_end < 10, "the inputs follow the terminals");
}

#[test]
fn a_power_cycle_on_a_lossy_line_is_found_within_its_bound() {
    let mut r = lossy_rig(&[(4, Protocol::Modbus, FAST_REFRESH)]);
    for k in 0..20u64 {
        r.read_at(1000 + 100 * k);
    }
    // Power cycle at 3.05 s, too short to be lost; X1 goes on at 3.1 s with no event.
    r.power_cycle_at(3050, 0);
    r.at(3100);
    r.set(0, "X1", true);
    let mut restarted_at = None;
    for k in 0..100u64 {
        let t = 3200 + 100 * k;
        let (_, sent) = r.read_at(t);
        if startups(&sent, 4) > 0 {
            restarted_at = Some(t);
            break;
        }
    }
    // The bound (devices/minimod/driver/lost_events.rs): the next full read within
    // event_refresh (300 ms here) finds the change, the read-back one cycle later, the
    // start-up the cycle after; on this line a failed exchange is asked again next cycle, so
    // a second allows for a few of them.
    let restarted = restarted_at.expect("the start-up runs again");
    assert!(
        restarted <= 3100 + 300 + 2 * 100 + 1000,
        "at {restarted} ms"
    );
    assert_eq!(
        r.world.lock().unwrap().get(0, "XEVMASK").ok(),
        Some(Value::U16(0b111)),
        "event recording is on again"
    );
}

#[test]
fn a_member_that_waits_longer_for_the_end_of_a_request_is_heard_in_its_late_slot() {
    // RDELAYM = 100: the module takes a request as ended 10 ms after 28 bit times (manual,
    // "Setting the Modbus communication timeout"), so its Collect slot starts 10 ms later;
    // the owner listens that much longer.
    const LATE: &[(&str, &str)] = &[("events", "true"), ("XLATUP1", "0"), ("RDELAYM", "100")];
    let mut r = rig(&[(4, Protocol::Modbus, LATE)]);
    r.startup();
    r.read_at(1000);
    r.at(1050);
    r.set(0, "X1", true);
    let (f, sent) = r.read_at(1100);
    assert_eq!(
        value(&f, 0, "X1"),
        Some(Value::Bool(true)),
        "from the event"
    );
    assert_eq!(
        sent,
        [collect(4, 4, 0, 0)],
        "no full read: the event was heard"
    );
    assert_eq!(r.owner.collect_stats().events, 1);
    // An idle round lasts its floor with the 10 ms, and a character.
    let floor = floor::CollectFloor::over(LineSettings::DEFAULT, Default::default(), &[4])
        .unwrap()
        .with_frame_timeout(Duration::from_millis(10));
    assert_eq!(
        idle_round_time(&[(4, Protocol::Modbus, LATE)]),
        floor.idle() + LineSettings::DEFAULT.char_time()
    );
}

#[test]
fn a_lines_modules_count_every_request_on_its_wire_collect_broadcasts_included() {
    // mm2 polled, mm4 and mm9 in event mode: the broadcasts count on mm4, which opens the
    // window, so the line's requests add up to the frames on the wire.
    let mut r = rig(&[
        (2, Protocol::Modbus, &[]),
        (4, Protocol::Modbus, EVENTS),
        (9, Protocol::Modbus, EVENTS),
    ]);
    r.startup();
    let total = |f: &InputFrame| -> u64 {
        f.modules
            .iter()
            .map(|m| m.counters.requests + m.counters.collect_requests)
            .sum()
    };
    let (first, _) = r.read_at(1000);
    let before = total(&first);
    let mut on_wire = 0;
    let mut last = first;
    for k in 1..30u64 {
        if k % 5 == 2 {
            r.at(1000 + 100 * k - 50);
            r.set(1, "X1", k % 10 == 2);
        }
        let (f, sent) = r.read_at(1000 + 100 * k);
        on_wire += sent.len() as u64;
        last = f;
    }
    let counters: Vec<_> = last.modules.iter().map(|m| m.counters).collect();
    assert_eq!(total(&last) - before, on_wire);
    assert_eq!(
        counters[1].collect_requests,
        r.owner.collect_stats().requests
    );
    assert_eq!(
        (counters[0].collect_requests, counters[2].collect_requests),
        (0, 0)
    );
    assert!(
        counters[1].collect_requests >= 30,
        "a round a cycle, and the events' Collects"
    );
}

#[test]
fn a_late_member_hears_the_collect_that_follows_another_members_event() {
    // Unit 5 waits 28 bit times + 10 ms (RDELAYM = 100) for a request's end; unit 4 answers
    // the first Collect of the round with its event, so the next Collect follows traffic on
    // the line. Unit 5 must hear that Collect as a request of its own and answer its event in
    // the same round, with no full read.
    const LATE: &[(&str, &str)] = &[("events", "true"), ("XLATUP1", "0"), ("RDELAYM", "100")];
    const PROMPT: &[(&str, &str)] = &[("events", "true"), ("XLATUP1", "0")];
    let mut r = rig(&[(4, Protocol::Modbus, PROMPT), (5, Protocol::Modbus, LATE)]);
    r.startup();
    r.read_at(1000);
    r.at(1050);
    r.set(0, "X1", true);
    r.set(1, "X1", true);
    let (f, sent) = r.read_at(1100);
    assert_eq!(value(&f, 0, "X1"), Some(Value::Bool(true)));
    assert_eq!(value(&f, 1, "X1"), Some(Value::Bool(true)), "{sent:02X?}");
    assert!(full_reads(&sent).is_empty(), "from the events: {sent:02X?}");
    assert_eq!(r.owner.collect_stats().events, 2, "{sent:02X?}");
}
