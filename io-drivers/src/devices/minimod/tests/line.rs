//! The MiniMod driver and simulator through the real bus owner on the virtual line, on a
//! virtual clock: a line that dies for 1.5 s while the module's watchdog is armed, and comes
//! back (Modbus, text protocol, event mode), each on a module that keeps WDTTIME/WDTYMASK
//! where the register table says and on one that follows the coil/register aliasing rule
//! (see `map`); a write refused because the watchdog fired. Every frame the master sends is
//! recorded, so the restart sequence is checked byte by byte.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::devices::minimod::map::WatchdogRegisters;
use crate::devices::minimod::MiniModSim;
use crate::devices::{self, Protocol};
use crate::line::bus::{BusOwner, Discipline, InputFrame, Module, OutputFrame};
use crate::line::transport::{LineError, Transport};
use crate::line::LineSettings;
use crate::modbus::crc::append_crc;
use crate::point::{Quality, Value};
use crate::sim::line::{SharedWorld, SimWorld, VirtualPort};
use crate::time::{Clock, LineInstant, VirtualClock};

const UNIT: u8 = 5;
const PERIOD: Duration = Duration::from_millis(100);

/// The master's end of the line, recording every frame it sends (also used by the EX-9053D's
/// line tests).
#[derive(Debug)]
pub(crate) struct Tap {
    pub(crate) port: VirtualPort,
    pub(crate) sent: Arc<Mutex<Vec<Vec<u8>>>>,
}

impl Tap {
    /// The master's end of line 0 of `world`, and the frames it will have sent.
    pub(crate) fn on(
        world: &SharedWorld,
        line: LineSettings,
        clock: &Arc<VirtualClock>,
    ) -> (Self, Arc<Mutex<Vec<Vec<u8>>>>) {
        let sent = Arc::new(Mutex::new(Vec::new()));
        let tap = Tap {
            port: VirtualPort::new(world.clone(), 0, line, clock.clone()),
            sent: sent.clone(),
        };
        (tap, sent)
    }
}

impl Transport for Tap {
    fn settings(&self) -> LineSettings {
        self.port.settings()
    }

    fn now(&self) -> LineInstant {
        self.port.now()
    }

    fn sync(&mut self, t: LineInstant) {
        self.port.sync(t);
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        self.sent.lock().unwrap().push(frame.to_vec());
        self.port.write_frame(frame)
    }

    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        self.port.read_until(buf, deadline)
    }

    fn wait_until(&mut self, t: LineInstant) {
        self.port.wait_until(t);
    }

    fn flush_input(&mut self) -> Result<usize, LineError> {
        self.port.flush_input()
    }
}

/// Collects the messages of every event logged while it is the default subscriber.
#[derive(Clone, Default)]
pub(crate) struct Logs(Arc<Mutex<Vec<String>>>);

impl tracing::Subscriber for Logs {
    fn enabled(&self, _: &tracing::Metadata<'_>) -> bool {
        true
    }

    fn new_span(&self, _: &tracing::span::Attributes<'_>) -> tracing::span::Id {
        tracing::span::Id::from_u64(1)
    }

    fn record(&self, _: &tracing::span::Id, _: &tracing::span::Record<'_>) {}

    fn record_follows_from(&self, _: &tracing::span::Id, _: &tracing::span::Id) {}

    fn event(&self, event: &tracing::Event<'_>) {
        struct Message(String);
        impl tracing::field::Visit for Message {
            fn record_debug(&mut self, f: &tracing::field::Field, v: &dyn std::fmt::Debug) {
                if f.name() == "message" {
                    self.0 = format!("{v:?}");
                }
            }
        }
        let mut m = Message(String::new());
        event.record(&mut m);
        let line = format!("{} {}", event.metadata().level(), m.0);
        self.0.lock().unwrap().push(line);
    }

    fn enter(&self, _: &tracing::span::Id) {}

    fn exit(&self, _: &tracing::span::Id) {}
}

impl Logs {
    pub(crate) fn matching(&self, needle: &str) -> Vec<String> {
        let logs = self.0.lock().unwrap();
        logs.iter()
            .filter(|l| l.contains(needle))
            .cloned()
            .collect()
    }
}

pub(crate) struct Rig {
    pub(crate) clock: Arc<VirtualClock>,
    pub(crate) world: SharedWorld,
    pub(crate) owner: BusOwner,
    sent: Arc<Mutex<Vec<Vec<u8>>>>,
    y1: usize,
}

pub(crate) fn rig(protocol: Protocol, settings: &[(&str, &str)]) -> Rig {
    rig_on(WatchdogRegisters::Table, protocol, settings)
}

/// A rig whose module keeps WDTTIME and WDTYMASK where `registers` says.
fn rig_on(registers: WatchdogRegisters, protocol: Protocol, settings: &[(&str, &str)]) -> Rig {
    let line = LineSettings::DEFAULT;
    let mut world = SimWorld::new(vec![line]);
    let model = devices::model("minimod").unwrap();
    let sim = MiniModSim::with_watchdog_registers(UNIT, registers);
    world.add_device(0, "mm", Box::new(sim));
    let config = model.device_config("mm", UNIT, protocol, settings).unwrap();
    let driver = (model.driver)(&config);
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
    let owner = BusOwner::new(
        "line",
        Box::new(port),
        discipline,
        vec![Module::new("mm", driver)],
    );
    Rig {
        clock,
        world,
        owner,
        sent,
        y1: model.point_index("Y1").unwrap(),
    }
}

impl Rig {
    pub(crate) fn startup(&mut self) {
        self.owner.sync(self.clock.line_now());
        self.owner.startup().unwrap();
        let now = self.owner.now();
        self.clock.advance_to(now.on_scan_clock());
    }

    /// One scan: read, then write Y1 = `y1`; the next starts a period later.
    pub(crate) fn cycle(&mut self, y1: bool) -> InputFrame {
        let start = self.clock.now();
        self.owner.sync(start.on_line_clock());
        let frame = self.owner.read_inputs();
        let mut desired = vec![None; devices::minimod::map::POINTS.len()];
        desired[self.y1] = Some(Value::Bool(y1));
        self.owner.write_outputs(&OutputFrame {
            modules: vec![desired],
        });
        let end = self.owner.now().on_scan_clock().max(start + PERIOD);
        self.clock.advance_to(end);
        frame
    }

    pub(crate) fn sim(&self, point: &str) -> Value {
        let mut w = self.world.lock().unwrap();
        w.advance_to(self.clock.line_now());
        w.get(0, point).unwrap()
    }

    pub(crate) fn set_dead(&self, dead: bool) {
        self.world.lock().unwrap().faults_mut().set_dead(0, dead);
    }

    pub(crate) fn take_sent(&self) -> Vec<Vec<u8>> {
        std::mem::take(&mut *self.sent.lock().unwrap())
    }
}

pub(crate) fn rtu(bytes: &[u8]) -> Vec<u8> {
    let mut f = bytes.to_vec();
    append_crc(&mut f);
    f
}

/// Y1 on, the line dead for 1.5 s (the module's watchdog fires after 0.5 s and turns Y1 off),
/// the line back: returns the frames sent from the first one the module answered again, and
/// the logs. The module keeps its watchdog registers where `registers` says; the start-up
/// must arm it all the same (read back from the module's state), before and after the
/// outage.
fn outage(
    registers: WatchdogRegisters,
    protocol: Protocol,
    settings: &[(&str, &str)],
) -> (Rig, Vec<Vec<u8>>, Logs) {
    let logs = Logs::default();
    let mut r = rig_on(registers, protocol, settings);
    let frames = tracing::subscriber::with_default(logs.clone(), || {
        r.startup();
        assert_eq!(r.sim("WDTTIME"), Value::U16(50), "armed ({registers:?})");
        assert_eq!(r.sim("WDTYMASK"), Value::U16(0));
        for _ in 0..5 {
            r.cycle(true);
        }
        assert_eq!(r.sim("Y1"), Value::Bool(true));
        assert_eq!(r.sim("WDTFIRED"), Value::Bool(false));
        r.set_dead(true);
        for _ in 0..15 {
            r.cycle(true);
        }
        assert_eq!(
            r.sim("WDTFIRED"),
            Value::Bool(true),
            "fired during the outage"
        );
        assert_eq!(r.sim("WDTCOMM"), Value::Bool(true));
        assert_eq!(r.sim("Y1"), Value::Bool(false), "WDTYMASK = 0: Y1 off");
        r.set_dead(false);
        r.take_sent();
        let mut back = None;
        for k in 0..60 {
            let f = r.cycle(true);
            if f.modules[0].quality == Quality::Good {
                back = Some(k);
                break;
            }
        }
        assert!(back.is_some(), "the module is back");
        // The write phase of that cycle wrote Y1 again.
        let sent = r.take_sent();
        for _ in 0..5 {
            let f = r.cycle(true);
            assert_eq!(f.modules[0].outputs, Quality::Good);
        }
        sent
    });
    assert_eq!(r.sim("WDTFIRED"), Value::Bool(false), "reset");
    assert_eq!(r.sim("WDTTIME"), Value::U16(50), "armed again");
    assert_eq!(r.sim("Y1"), Value::Bool(true), "written again");
    (r, frames, logs)
}

/// The read of WDTFB, WDTCOMM (discrete inputs 24..=25): the second frame of a restart.
fn cause_read() -> Vec<u8> {
    rtu(&[0x05, 0x02, 0x00, 0x18, 0x00, 0x02])
}

/// The frames of the restart the module answered: from the frame before the last cause read
/// on (probes of the dead module before it were answered by nobody).
fn from_restart(sent: &[Vec<u8>]) -> Vec<Vec<u8>> {
    let cause = sent
        .iter()
        .rposition(|f| *f == cause_read())
        .expect("a restart");
    sent[cause - 1..].to_vec()
}

/// The logic tables' part of the start-up (the push-down's area): FC 16 / FC 3 on the
/// condition, blinker and pulser registers 51..=86.
fn is_logic_frame(f: &[u8]) -> bool {
    matches!(f.get(1), Some(0x10 | 0x03))
        && f.get(2..4)
            .is_some_and(|a| (51..=86).contains(&u16::from_be_bytes([a[0], a[1]])))
}

const WATCHDOG: [(&str, &str); 2] = [("WDTTIME", "50"), ("WDTYMASK", "0")];

fn assert_logged_once(logs: &Logs) {
    let fired = logs.matching("its watch-dog had fired");
    assert_eq!(
        fired,
        [
            "WARN MiniMod at address 5 is back: its watch-dog had fired because a connection loss \
          with the computer/PLC (WDTCOMM); its outputs were held in the watch-dog's \
          configuration (WDTYMASK); resetting the watch-dog (WDTFIRED = 0) and writing every \
          output again"
        ],
        "once, with the cause"
    );
}

/// The watchdog armed by name, on either protocol: WDTTIME = 50, WDTMASK = 0, each read back.
fn arming_by_name() -> [Vec<u8>; 4] {
    [
        b"@5>WDTTIME=50\r".to_vec(),
        b"@5?WDTTIME\r".to_vec(),
        b"@5>WDTMASK=0\r".to_vec(),
        b"@5?WDTMASK\r".to_vec(),
    ]
}

#[test]
fn modbus_module_back_after_its_watchdog_fired_is_reset_and_written_again() {
    for registers in WatchdogRegisters::ALL {
        let (_r, sent, logs) = outage(registers, Protocol::Modbus, &WATCHDOG);
        let probe = rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]);
        let frames = from_restart(&sent);
        // The logic tables' start-up (the push-down's) is checked in `driver::logic`.
        let rest: Vec<Vec<u8>> = frames.into_iter().filter(|f| !is_logic_frame(f)).collect();
        let mut expected = vec![
            // Why: WDTFIRED (coil 160), then WDTFB, WDTCOMM (discrete inputs 24..=25).
            probe,
            cause_read(),
        ];
        // The settings again: WDTTIME and WDTYMASK by name, whatever the registers.
        expected.extend(arming_by_name());
        expected.extend([
            // The reset: WDTFIRED = 0, read back.
            rtu(&[0x05, 0x0F, 0x00, 0xA0, 0x00, 0x01, 0x01, 0x00]),
            rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
            // The cycle's read, then Y1 written again (FC 5 coil 0).
            rtu(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]),
            rtu(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00]),
        ]);
        assert_eq!(rest, expected, "{registers:?}");
        assert_logged_once(&logs);
    }
}

#[test]
fn text_module_back_after_its_watchdog_fired_is_reset_and_written_again() {
    for registers in WatchdogRegisters::ALL {
        let (_r, sent, logs) = outage(registers, Protocol::Text, &WATCHDOG);
        let frames = from_restart(&sent);
        let rest: Vec<Vec<u8>> = frames.into_iter().filter(|f| !is_logic_frame(f)).collect();
        let mut expected = vec![b"@5?WFLAGS\r".to_vec(), cause_read()];
        expected.extend(arming_by_name());
        expected.extend([
            rtu(&[0x05, 0x0F, 0x00, 0xA0, 0x00, 0x01, 0x01, 0x00]),
            rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
            b"@5?XWORD\r".to_vec(),
            b"@5>Y1=1\r".to_vec(),
        ]);
        assert_eq!(rest, expected, "{registers:?}");
        assert_logged_once(&logs);
    }
}

#[test]
fn event_mode_module_back_after_its_watchdog_fired_is_reset_and_written_again() {
    let settings = [WATCHDOG[0], WATCHDOG[1], ("events", "true")];
    for registers in WatchdogRegisters::ALL {
        let (r, sent, logs) = outage(registers, Protocol::Modbus, &settings);
        let probe = rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]);
        let frames = from_restart(&sent);
        assert_eq!(frames[..2], [probe, cause_read()]);
        for f in arming_by_name() {
            assert!(
                frames.contains(&f),
                "{registers:?}: {}",
                String::from_utf8_lossy(&f)
            );
        }
        assert!(
            frames.contains(&rtu(&[0x05, 0x0F, 0x00, 0xA0, 0x00, 0x01, 0x01, 0x00])),
            "the reset"
        );
        assert_eq!(
            frames.last(),
            Some(&rtu(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00])),
            "Y1 written again, last"
        );
        assert_logged_once(&logs);
        // An idle event-mode line keeps the watchdog fed: the Collect rounds are commands.
        let mut r = r;
        for _ in 0..30 {
            r.cycle(true);
        }
        assert_eq!(r.sim("WDTFIRED"), Value::Bool(false));
        assert_eq!(r.sim("Y1"), Value::Bool(true));
    }
}

#[test]
fn a_write_refused_with_exception_04_restarts_the_module() {
    let logs = Logs::default();
    let mut r = rig(Protocol::Modbus, &WATCHDOG);
    tracing::subscriber::with_default(logs.clone(), || {
        r.startup();
        r.cycle(true);
        assert_eq!(r.sim("Y1"), Value::Bool(true));
        // Fired by hand (another master, a test button): Y1 off, writes refused.
        r.world
            .lock()
            .unwrap()
            .set(0, "WDTFIRED", Value::Bool(true))
            .unwrap();
        r.take_sent();
        // Within the output refresh (1 s) the driver writes Y1 again, is refused with 04, and
        // the next cycle restarts the module.
        let mut written_back = None;
        for k in 0..15 {
            r.cycle(true);
            if r.sim("Y1") == Value::Bool(true) {
                written_back = Some(k);
                break;
            }
        }
        assert!(written_back.is_some(), "Y1 back on");
    });
    let sent = r.take_sent();
    let refused = rtu(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00]);
    let first = sent.iter().position(|f| *f == refused).unwrap();
    assert_eq!(
        sent[first + 1..first + 3],
        [
            rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
            rtu(&[0x05, 0x02, 0x00, 0x18, 0x00, 0x02]),
        ],
        "after the refusal: why"
    );
    assert_eq!(sent.last(), Some(&refused), "and Y1 written again");
    assert_eq!(r.sim("WDTFIRED"), Value::Bool(false));
    assert_eq!(
        logs.matching("its watch-dog had fired"),
        [
            "WARN MiniMod at address 5 refused an output write: its watch-dog had fired with \
          neither WDTCOMM nor WDTFB set: fired by a master (WDTFIRED or WFLAGS written); its \
          outputs were held in the watch-dog's configuration (WDTYMASK); resetting the \
          watch-dog (WDTFIRED = 0) and writing every output again"
        ]
    );
}

#[test]
fn a_refusal_the_watchdog_does_not_explain_restarts_once_until_a_write_succeeds() {
    use crate::driver::{Driver, Outgoing, Reply};
    use crate::modbus::master::encode_request;
    use crate::modbus::{ExceptionCode, Response, UnitId};

    let logs = Logs::default();
    let mut d = super::MiniModDriver::new(UnitId::new(UNIT), &[]);
    let mut desired = vec![None; devices::minimod::map::POINTS.len()];
    desired[devices::minimod::map::point_index("Y1").unwrap()] = Some(Value::Bool(true));
    let refused = Reply::Modbus(Response::Exception {
        function: 5,
        code: ExceptionCode::ServerDeviceFailure,
    });
    let write_tag = |d: &mut super::MiniModDriver| {
        let mut plan = Vec::new();
        d.plan_write(&desired, true, &mut plan);
        plan[0].tag
    };
    let wire = |tx: &crate::driver::Transaction| match &tx.frame {
        Outgoing::Modbus { unit, request } => {
            let mut out = Vec::new();
            encode_request(unit.get(), request, &mut out).unwrap();
            out
        }
        other => panic!("not Modbus: {other:?}"),
    };
    tracing::subscriber::with_default(logs.clone(), || {
        let tag = write_tag(&mut d);
        assert!(d.on_reply(tag, &refused).is_err());
        assert!(d.wants_restart());
        d.on_restart();
        assert!(!d.wants_restart(), "on_restart clears the request");
        // The settings do not own the watchdog: the restart reads why and resets it itself.
        let mut startup = Vec::new();
        d.plan_startup(&mut startup);
        let head: Vec<Vec<u8>> = startup.iter().take(4).map(wire).collect();
        assert_eq!(
            head,
            [
                rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
                rtu(&[0x05, 0x02, 0x00, 0x18, 0x00, 0x02]),
                rtu(&[0x05, 0x05, 0x00, 0xA0, 0x00, 0x00]),
                rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
            ]
        );
        let answers = [
            Response::ReadCoils(vec![false]),
            Response::ReadDiscreteInputs(vec![false, false]),
            Response::WriteSingleCoil {
                addr: 160,
                value: false,
            },
            Response::ReadCoils(vec![false]),
        ];
        for (tx, answer) in startup.iter().zip(answers) {
            d.on_reply(tx.tag, &Reply::Modbus(answer)).unwrap();
        }
        // Not fired: refused for another reason. Said once; no restart every cycle.
        let tag = write_tag(&mut d);
        assert!(d.on_reply(tag, &refused).is_err());
        assert!(!d.wants_restart());
        // A write that succeeds ends the run: the next refusal asks again.
        let tag = write_tag(&mut d);
        let echo = Reply::Modbus(Response::WriteSingleCoil {
            addr: 0,
            value: true,
        });
        d.on_reply(tag, &echo).unwrap();
        let tag = write_tag(&mut d);
        assert!(d.on_reply(tag, &refused).is_err());
        assert!(d.wants_restart());
    });
    assert_eq!(
        logs.matching("refused an output write"),
        [
            "WARN MiniMod at address 5 refused an output write although its watch-dog had not \
          fired (WDTFIRED = 0); its outputs stay bad until a write succeeds"
        ]
    );
}
