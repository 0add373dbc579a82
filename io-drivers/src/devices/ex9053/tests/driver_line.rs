//! The driver through the real bus owner on the virtual line (virtual clock): start-up, a
//! pulse between two polls caught by the latches and counters, the host watchdog's timeout
//! and recovery, synchronized sampling, and a line shared with a MiniMod.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::devices::minimod::line_tests::{Logs, Tap};

use crate::devices::ex9053::points::Point;
use crate::devices::{self, Protocol};
use crate::driver::{DecodeError, Outgoing};
use crate::line::budget::{line_budget, transaction_time};
use crate::line::bus::{BusOwner, Discipline, InputFrame, Module, StartupError, TxError};
use crate::line::{LineSettings, Parity, SerialFormat};
use crate::point::{Quality, Value};
use crate::sim::line::{SharedWorld, SimWorld};
use crate::sim::plant::{Plant, PlantIo};
use crate::time::{Clock, LineInstant, ScanInstant, VirtualClock};

/// DCON's usual line: 9600 8N1 (§1.3).
const DCON_LINE: LineSettings = LineSettings {
    baud: 9600,
    format: SerialFormat {
        data_bits: 8,
        parity: Parity::None,
        stop_bits: 1,
    },
};

struct Spec<'a> {
    model: &'a str,
    address: u8,
    protocol: Protocol,
    settings: &'a [(&'a str, &'a str)],
}

struct Rig {
    clock: Arc<VirtualClock>,
    world: SharedWorld,
    owner: BusOwner,
    /// Every frame the master sent.
    sent: Arc<Mutex<Vec<Vec<u8>>>>,
}

/// A plant and its wiring: per role, the device index and point.
type Wired = (Box<dyn Plant>, Vec<(usize, String)>);

fn rig(line: LineSettings, specs: &[Spec<'_>], plant: Option<Wired>) -> Rig {
    let mut world = SimWorld::new(vec![line]);
    let mut modules = Vec::new();
    for (i, s) in specs.iter().enumerate() {
        let model = devices::model(s.model).expect("in the catalog");
        let mut sim = (model.simulator)(s.address);
        if s.model == "ex9053d-m" && s.protocol == Protocol::Text {
            sim.command(&["protocol", "dcon"]).unwrap();
            sim.command(&["power-cycle"]).unwrap();
        }
        let name = format!("m{i}");
        world.add_device(0, &name, sim);
        let config = model
            .device_config(&name, s.address, s.protocol, s.settings)
            .unwrap();
        let driver = (model.driver)(&config);
        modules.push(Module::new(name, driver));
    }
    if let Some((plant, wires)) = plant {
        world.set_plant(plant, wires);
    }
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    let (port, sent) = Tap::on(&world, line, &clock);
    let discipline = Discipline {
        response_timeout: Duration::from_millis(50),
        retries: 0,
        output_refresh: Duration::from_secs(1),
        fail_limit: 3,
        ..Discipline::default()
    };
    let owner = BusOwner::new("line", Box::new(port), discipline, modules);
    Rig {
        clock,
        world,
        owner,
        sent,
    }
}

impl Rig {
    fn startup(&mut self) -> Result<(), StartupError> {
        self.owner.sync(self.clock.line_now());
        let r = self.owner.startup();
        self.clock
            .advance_to(self.clock.now() + Duration::from_millis(100));
        r
    }

    /// One read cycle; the clock then moves 100 ms past its start.
    fn read(&mut self) -> InputFrame {
        let start = self.clock.now();
        self.owner.sync(start.on_line_clock());
        let frame = self.owner.read_inputs();
        self.clock.advance_to(
            frame
                .finished
                .on_scan_clock()
                .max(start + Duration::from_millis(100)),
        );
        frame
    }

    fn command(&self, device: usize, words: &[&str]) -> String {
        let mut w = self.world.lock().unwrap();
        w.advance_to(self.clock.line_now());
        w.device_mut(device).unwrap().command(words).unwrap()
    }

    fn sim_get(&self, device: usize, point: &str) -> Value {
        self.world.lock().unwrap().get(device, point).unwrap()
    }
}

fn value(frame: &InputFrame, module: usize, point: Point) -> Option<Value> {
    frame.modules[module].values[point.index()]
}

fn b(v: bool) -> Option<Value> {
    Some(Value::Bool(v))
}

fn latch_pulse(model: &str, protocol: Protocol, line: LineSettings) {
    let settings = [("latch", "both"), ("counters", "DI3, DI5")];
    let mut r = rig(
        line,
        &[Spec {
            model,
            address: 1,
            protocol,
            settings: &settings,
        }],
        None,
    );
    r.startup().unwrap();
    let f = r.read();
    assert_eq!(
        f.modules[0].quality,
        Quality::Good,
        "{:?}",
        f.modules[0].last_error
    );
    assert_eq!(value(&f, 0, Point::Input(3)), b(false));
    assert_eq!(value(&f, 0, Point::LatchHigh(3)), b(false));
    assert_eq!(value(&f, 0, Point::Counter(3)), Some(Value::I32(0)));
    assert_eq!(value(&f, 0, Point::Counter(4)), None, "not read");
    // A pulse far shorter than the scan, between two polls.
    r.command(0, &["pulse", "DI3"]);
    let f = r.read();
    assert_eq!(value(&f, 0, Point::Input(3)), b(false), "gone by the poll");
    assert_eq!(value(&f, 0, Point::LatchHigh(3)), b(true), "but latched");
    assert_eq!(value(&f, 0, Point::LatchLow(3)), b(true));
    assert_eq!(value(&f, 0, Point::LatchHigh(2)), b(false));
    assert_eq!(value(&f, 0, Point::Counter(3)), Some(Value::I32(1)));
    let f = r.read();
    assert_eq!(
        value(&f, 0, Point::LatchHigh(3)),
        b(false),
        "cleared after the read"
    );
    // A low pulse on an input that stays high.
    r.command(0, &["inputs", "0020"]);
    let f = r.read();
    assert_eq!(
        value(&f, 0, Point::LatchLow(5)),
        b(true),
        "it was low before rising"
    );
    r.command(0, &["pulse", "DI5", "low"]);
    let f = r.read();
    assert_eq!(value(&f, 0, Point::Input(5)), b(true));
    assert_eq!(value(&f, 0, Point::LatchLow(5)), b(true));
    assert_eq!(value(&f, 0, Point::Counter(5)), Some(Value::I32(1)));
    let f = r.read();
    assert_eq!(value(&f, 0, Point::LatchLow(5)), b(false));
    assert_eq!(f.modules[0].counters.errors(), 0);
}

#[test]
fn latch_catches_a_pulse_between_two_polls_dcon() {
    latch_pulse("ex9053d", Protocol::Text, DCON_LINE);
}

#[test]
fn latch_catches_a_pulse_between_two_polls_modbus() {
    latch_pulse("ex9053d-m", Protocol::Modbus, LineSettings::DEFAULT);
}

#[test]
fn latch_catches_a_pulse_between_two_polls_m_on_dcon() {
    latch_pulse("ex9053d-m", Protocol::Text, DCON_LINE);
}

fn watchdog(model: &str, protocol: Protocol, line: LineSettings) {
    let settings = [("watchdog", "1s")];
    let mut r = rig(
        line,
        &[Spec {
            model,
            address: 1,
            protocol,
            settings: &settings,
        }],
        None,
    );
    // A timeout left over from before this start is cleared at start-up.
    r.command(0, &["status"]);
    r.startup().unwrap();
    assert!(r
        .command(0, &["status"])
        .contains("host watchdog: enabled=on value=10"));
    for _ in 0..30 {
        let f = r.read();
        assert_eq!(value(&f, 0, Point::WdtTimeout), b(false));
    }
    // The host goes silent for 2 s: the module's watchdog expires.
    r.clock.advance_to(r.clock.now() + Duration::from_secs(2));
    let f = r.read();
    assert_eq!(value(&f, 0, Point::WdtTimeout), b(true));
    assert_eq!(f.modules[0].quality, Quality::Good, "the module answered");
    assert_eq!(r.sim_get(0, "WDT_TIMEOUT"), Value::Bool(true));
    // Recovery: the next cycle clears the status and re-arms the watchdog.
    let f = r.read();
    assert_eq!(value(&f, 0, Point::WdtTimeout), b(false));
    assert_eq!(r.sim_get(0, "WDT_TIMEOUT"), Value::Bool(false));
    assert!(r
        .command(0, &["status"])
        .contains("host watchdog: enabled=on value=10"));
    for _ in 0..30 {
        let f = r.read();
        assert_eq!(value(&f, 0, Point::WdtTimeout), b(false));
    }
    assert_eq!(
        r.owner.modules()[0].driver.values()[Point::WdtTimeout.index()],
        b(false)
    );
}

#[test]
fn host_watchdog_timeout_and_recovery_dcon() {
    watchdog("ex9053d", Protocol::Text, DCON_LINE);
}

#[test]
fn host_watchdog_timeout_and_recovery_modbus() {
    watchdog("ex9053d-m", Protocol::Modbus, LineSettings::DEFAULT);
}

/// The line dies for 2 s with a 500 ms host watchdog and comes back: returns the frames sent
/// from the first one the module answered again, and the logs.
fn outage(model: &str, protocol: Protocol, line: LineSettings) -> (Rig, Vec<Vec<u8>>, Logs) {
    let settings = [("watchdog", "500ms")];
    let spec = Spec {
        model,
        address: 1,
        protocol,
        settings: &settings,
    };
    let mut r = rig(line, &[spec], None);
    let logs = Logs::default();
    let sent = tracing::subscriber::with_default(logs.clone(), || {
        r.startup().unwrap();
        for _ in 0..5 {
            let f = r.read();
            assert_eq!(value(&f, 0, Point::WdtTimeout), b(false));
        }
        r.world.lock().unwrap().faults_mut().set_dead(0, true);
        for _ in 0..20 {
            r.read();
        }
        assert_eq!(r.sim_get(0, "WDT_TIMEOUT"), Value::Bool(true), "expired");
        r.world.lock().unwrap().faults_mut().set_dead(0, false);
        r.sent.lock().unwrap().clear();
        let back = (0..60).any(|_| r.read().modules[0].quality == Quality::Good);
        assert!(back, "the module is back");
        let sent = std::mem::take(&mut *r.sent.lock().unwrap());
        for _ in 0..10 {
            let f = r.read();
            assert_eq!(value(&f, 0, Point::WdtTimeout), b(false));
        }
        sent
    });
    assert_eq!(r.sim_get(0, "WDT_TIMEOUT"), Value::Bool(false), "cleared");
    assert!(r
        .command(0, &["status"])
        .contains("host watchdog: enabled=on value=5"));
    (r, sent, logs)
}

/// The frames from the last one that starts a start-up (`first`) on.
fn from(sent: &[Vec<u8>], first: &[u8]) -> Vec<Vec<u8>> {
    let at = sent.iter().rposition(|f| f == first).expect("a restart");
    sent[at..].to_vec()
}

fn assert_back_logged_once(logs: &Logs) {
    assert_eq!(
        logs.matching("host watchdog timeout status"),
        [
            "WARN EX-9053D m0 at address 1 is back with its host watchdog timeout status set: it \
          saw no host OK within the host watchdog timeout while it was away (the output command \
          is ignored until ~AA1, §1.5); clearing it and arming the host watchdog again"
        ]
    );
}

#[test]
fn dcon_module_back_after_its_host_watchdog_expired_is_cleared_and_armed_again() {
    let (_r, sent, logs) = outage("ex9053d", Protocol::Text, DCON_LINE);
    let frames = from(&sent, b"$01M\r");
    let text: Vec<&str> = frames
        .iter()
        .map(|f| std::str::from_utf8(f).unwrap())
        .collect();
    assert_eq!(
        text,
        [
            "$01M\r",    // identity (§2.9)
            "$012\r",    // configuration (§2.4)
            "$015\r",    // reset status (§2.6)
            "~010\r",    // module status: 04, the timeout the outage left (§2.18)
            "~011\r",    // reset module status (§2.19)
            "~013105\r", // enable, 5 × 0.1 s (§2.21)
            "~012\r",    // read back (§2.20)
            "~**\r",     // then the cycle: host OK (§2.17), inputs, status
            "@01\r",
            "~010\r",
        ]
    );
    assert_back_logged_once(&logs);
}

#[test]
fn modbus_module_back_after_its_host_watchdog_expired_is_cleared_and_armed_again() {
    let (_r, sent, logs) = outage("ex9053d-m", Protocol::Modbus, LineSettings::DEFAULT);
    let rtu = |bytes: &[u8]| {
        let mut f = bytes.to_vec();
        crate::modbus::crc::append_crc(&mut f);
        f
    };
    let frames = from(&sent, &rtu(&[0x01, 0x03, 0x01, 0xE2, 0x00, 0x02]));
    assert_eq!(
        frames,
        [
            rtu(&[0x01, 0x03, 0x01, 0xE2, 0x00, 0x02]), // 40483..40484 module name
            rtu(&[0x01, 0x01, 0x01, 0x0D, 0x00, 0x01]), // 00270 WDT timeout status
            rtu(&[0x01, 0x05, 0x01, 0x0D, 0xFF, 0x00]), // clear it
            rtu(&[0x01, 0x06, 0x01, 0xE8, 0x00, 0x05]), // 40489 WDT timeout value = 5
            rtu(&[0x01, 0x05, 0x01, 0x04, 0xFF, 0x00]), // 00261 WDT enable
            rtu(&[0x01, 0x03, 0x01, 0xE8, 0x00, 0x01]), // read back
            rtu(&[0x01, 0x01, 0x01, 0x04, 0x00, 0x01]),
            rtu(&[0x01, 0x04, 0x30, 0x38, 0x00, 0x00]), // then the cycle: host OK
            rtu(&[0x01, 0x02, 0x00, 0x00, 0x00, 0x10]), // 10001..10016
            rtu(&[0x01, 0x01, 0x01, 0x0D, 0x00, 0x01]),
        ]
    );
    assert_back_logged_once(&logs);
}

#[test]
fn a_timeout_from_before_the_start_is_cleared() {
    let settings = [("watchdog", "500ms")];
    let spec = Spec {
        model: "ex9053d",
        address: 1,
        protocol: Protocol::Text,
        settings: &settings,
    };
    let mut r = rig(DCON_LINE, &[spec], None);
    let mut w = r.world.lock().unwrap();
    let sim = w.device_mut(0).unwrap();
    // As if a previous run had armed it and died.
    assert!(sim
        .on_frame(b"~01310A\r", LineInstant::ZERO)
        .is_some_and(|a| a.bytes == b"!01\r"));
    sim.advance_to(LineInstant::after_origin(Duration::from_secs(5)));
    drop(w);
    r.clock
        .advance_to(ScanInstant::after_origin(Duration::from_secs(5)));
    assert_eq!(r.sim_get(0, "WDT_TIMEOUT"), Value::Bool(true));
    r.startup().unwrap();
    assert_eq!(r.sim_get(0, "WDT_TIMEOUT"), Value::Bool(false));
    let f = r.read();
    assert_eq!(value(&f, 0, Point::WdtTimeout), b(false));
}

/// Drives DI0..DI7 of two modules with the low byte of the time in ms, so a sample tells when
/// it was taken.
#[derive(Debug)]
struct TimeBits;

impl Plant for TimeBits {
    fn step(&mut self, t: LineInstant, io: &mut dyn PlantIo) {
        let ms = t.since_origin().as_millis() as u64;
        for role in 0..16 {
            io.write(role, ms & (1 << (role % 8)) != 0);
        }
    }
}

fn low_byte(f: &InputFrame, module: usize) -> u8 {
    (0..8).fold(0u8, |acc, ch| {
        acc | (u8::from(value(f, module, Point::Input(ch)) == b(true)) << ch)
    })
}

fn two_modules(sync: [&str; 2]) -> Rig {
    let lead = [("sync", sync[0])];
    let follow = [("sync", sync[1])];
    let wires = (0..16)
        .map(|role| (role / 8, format!("DI{}", role % 8)))
        .collect();
    rig(
        DCON_LINE,
        &[
            Spec {
                model: "ex9053d",
                address: 1,
                protocol: Protocol::Text,
                settings: &lead,
            },
            Spec {
                model: "ex9053d-m",
                address: 2,
                protocol: Protocol::Text,
                settings: &follow,
            },
        ],
        Some((Box::new(TimeBits), wires)),
    )
}

#[test]
fn synchronized_sampling_takes_every_module_at_the_same_instant() {
    let mut r = two_modules(["lead", "follow"]);
    r.startup().unwrap();
    for _ in 0..5 {
        let f = r.read();
        for m in 0..2 {
            assert_eq!(
                f.modules[m].quality,
                Quality::Good,
                "{:?}",
                f.modules[m].last_error
            );
            assert_eq!(value(&f, m, Point::SyncFirst), b(true));
        }
        assert_eq!(low_byte(&f, 0), low_byte(&f, 1), "one instant for both");
    }
    // Without it, each module is read at its own time (a DCON exchange at 9600 Bd takes ms).
    let mut r = two_modules(["off", "off"]);
    r.startup().unwrap();
    let f = r.read();
    assert_ne!(low_byte(&f, 0), low_byte(&f, 1));
    assert_eq!(value(&f, 0, Point::SyncFirst), None);
}

#[test]
fn a_follower_without_a_new_sample_fails_its_read() {
    let mut r = two_modules(["off", "follow"]);
    r.startup().unwrap();
    let f = r.read();
    assert_eq!(f.modules[0].quality, Quality::Good);
    assert_eq!(f.modules[1].quality, Quality::Stale);
    assert_eq!(value(&f, 1, Point::SyncFirst), b(false));
    assert_eq!(
        value(&f, 1, Point::Input(0)),
        None,
        "no value passed off as a sample"
    );
    assert!(matches!(
        f.modules[1].last_error,
        Some(TxError::Decode(DecodeError::Unexpected { .. }))
    ));
    // A sample taken by anyone (here by hand, as a terminal would) is then read once.
    r.command(1, &["status"]);
    {
        let mut w = r.world.lock().unwrap();
        let now = r.clock.now();
        w.deliver(0, b"#**\r", now.on_line_clock());
    }
    let f = r.read();
    assert_eq!(f.modules[1].quality, Quality::Good);
    assert_eq!(value(&f, 1, Point::SyncFirst), b(true));
}

#[test]
fn start_up_verifies_the_configuration() {
    // DCON: the counter edge is checked, not written.
    let edge = [("count_edge", "rising")];
    let spec = |model, protocol| Spec {
        model,
        address: 1,
        protocol,
        settings: &edge,
    };
    let mut r = rig(DCON_LINE, &[spec("ex9053d", Protocol::Text)], None);
    let logs = Logs::default();
    let e = tracing::subscriber::with_default(logs.clone(), || r.startup().unwrap_err());
    assert!(matches!(
        e.error,
        TxError::Decode(DecodeError::Mismatch {
            expected: 1,
            found: 0,
            ..
        })
    ));
    // DCON without checksum: the differing `$012` answer is asked again before it is
    // believed, and explained once.
    let config_reads = r
        .sent
        .lock()
        .unwrap()
        .iter()
        .filter(|f| f.as_slice() == b"$012\r")
        .count();
    assert_eq!(config_reads, 2);
    assert_eq!(logs.matching("counter edge differs").len(), 1);
    // Modbus: written and read back.
    let mut r = rig(
        LineSettings::DEFAULT,
        &[spec("ex9053d-m", Protocol::Modbus)],
        None,
    );
    r.startup().unwrap();
    assert!(r.command(0, &["status"]).contains("format=80h"));
    // A checksum the module does not have: no reply it can use, so the module starts lost
    // (its points bad, retried), said in the log, and the PLC starts.
    let checksum = [("checksum", "on")];
    let mut r = rig(
        DCON_LINE,
        &[Spec {
            model: "ex9053d",
            address: 1,
            protocol: Protocol::Text,
            settings: &checksum,
        }],
        None,
    );
    let logs = Logs::default();
    tracing::subscriber::with_default(logs.clone(), || r.startup()).unwrap();
    let said = [
        logs.matching("did not answer at start-up"),
        logs.matching("a reply it could not use"),
    ]
    .concat();
    assert_eq!(said.len(), 1, "one line says why: {said:?}");
    let frame = r.owner.read_inputs();
    assert_eq!(
        frame.modules[0].quality,
        Quality::Bad,
        "the module starts lost"
    );
}

#[test]
fn checksum_modules_are_polled_with_checksums() {
    let settings = [("checksum", "on"), ("latch", "high"), ("sync", "lead")];
    let mut r = rig(
        DCON_LINE,
        &[Spec {
            model: "ex9053d",
            address: 0x21,
            protocol: Protocol::Text,
            settings: &settings,
        }],
        None,
    );
    r.command(0, &["init", "on"]);
    r.command(0, &["power-cycle"]);
    {
        let mut w = r.world.lock().unwrap();
        let a = w
            .device_mut(0)
            .unwrap()
            .on_frame(b"%0021400640\r", LineInstant::ZERO);
        assert_eq!(a.map(|a| a.bytes), Some(b"!21\r".to_vec()));
    }
    r.command(0, &["init", "off"]);
    r.command(0, &["power-cycle"]);
    r.startup().unwrap();
    r.command(0, &["inputs", "8001"]);
    let f = r.read();
    assert_eq!(
        f.modules[0].quality,
        Quality::Good,
        "{:?}",
        f.modules[0].last_error
    );
    assert_eq!(value(&f, 0, Point::Input(15)), b(true));
    assert_eq!(value(&f, 0, Point::LatchHigh(0)), b(true));
}

#[test]
fn an_ex9053d_m_shares_a_modbus_line_with_a_minimod() {
    let settings = [("latch", "high"), ("watchdog", "2s"), ("counters", "all")];
    let mut r = rig(
        LineSettings::DEFAULT,
        &[
            Spec {
                model: "minimod",
                address: 2,
                protocol: Protocol::Modbus,
                settings: &[],
            },
            Spec {
                model: "ex9053d-m",
                address: 1,
                protocol: Protocol::Modbus,
                settings: &settings,
            },
        ],
        None,
    );
    r.startup().unwrap();
    r.command(1, &["pulse", "DI7"]);
    for _ in 0..3 {
        let f = r.read();
        assert_eq!(f.modules[0].quality, Quality::Good);
        assert_eq!(
            f.modules[1].quality,
            Quality::Good,
            "{:?}",
            f.modules[1].last_error
        );
        assert_eq!(f.modules[1].counters.errors(), 0);
    }
    assert_eq!(
        r.owner.modules()[1].driver.values()[Point::Counter(7).index()],
        Some(Value::I32(1))
    );
}

#[test]
fn broadcasts_cost_their_characters_and_t3_5_in_the_budget() {
    let tx = crate::driver::Transaction {
        frame: Outgoing::NoReply {
            bytes: b"#**\r".to_vec(),
        },
        tag: 0,
    };
    let t = transaction_time(DCON_LINE, &tx, Duration::from_millis(10));
    assert_eq!(t, DCON_LINE.chars(4) + DCON_LINE.t3_5());
    let model = devices::model("ex9053d").unwrap();
    let config = model
        .device_config(
            "dc",
            1,
            Protocol::Text,
            &[("sync", "lead"), ("watchdog", "1s")],
        )
        .unwrap();
    let driver = (model.driver)(&config);
    let access = model.points.iter().map(|p| p.access).collect();
    let mut drivers = vec![("dc".to_string(), driver, access)];
    let budget = line_budget(DCON_LINE, &mut drivers);
    // #**, ~**, $AA4, ~AA0; nothing to write.
    assert_eq!(budget.modules[0].read_transactions, 4);
    assert_eq!(budget.modules[0].write_transactions, 0);
}
