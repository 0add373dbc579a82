//! RESI ASCII has no checksum ("No LF, no checksum, no escapes"): a start-up read-back whose
//! answer was garbled on the wire into another number is asked again before it is believed
//! (`crate::line::read_back`). A 16DI8RO's driver and simulator through the real bus owner on
//! the virtual line, on a virtual clock, with `retries: 0`.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::models::m16di8ro;
use crate::devices::minimod::line_tests::{Logs, Tap};
use crate::devices::Protocol;
use crate::driver::DecodeError;
use crate::line::bus::{BusOwner, Discipline, Module, StartupError, TxError};
use crate::line::LineSettings;
use crate::sim::line::{SharedWorld, SimWorld};
use crate::sim::{Fault, FaultRule, Frequency};
use crate::time::{Clock, LineInstant, VirtualClock};

const SETTINGS: [(&str, &str); 2] = [("PULSE_RO4", "3"), ("PULSE_TIME_RO4", "300")];

struct Rig {
    owner: BusOwner,
    world: SharedWorld,
    clock: Arc<VirtualClock>,
    sent: Arc<Mutex<Vec<Vec<u8>>>>,
}

fn rig() -> Rig {
    let spec = &m16di8ro::SPEC;
    let line = LineSettings::DEFAULT;
    let mut world = SimWorld::new(vec![line]);
    world.add_device(0, "lights", (spec.simulator)(1));
    let config = spec
        .device_config("lights", 1, Protocol::Text, &SETTINGS)
        .unwrap();
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    let (port, sent) = Tap::on(&world, line, &clock);
    let discipline = Discipline {
        response_timeout: Duration::from_millis(50),
        retries: 0,
        ..Discipline::default()
    };
    let owner = BusOwner::new(
        "house",
        Box::new(port),
        discipline,
        vec![Module::new("lights", (spec.driver)(&config))],
    );
    Rig {
        owner,
        world,
        clock,
        sent,
    }
}

impl Rig {
    fn startup(&mut self) -> Result<(), StartupError> {
        self.owner.sync(self.clock.line_now());
        self.owner.startup()
    }

    fn sent(&self) -> Vec<Vec<u8>> {
        self.sent.lock().unwrap().clone()
    }
}

/// The start-up's answer that reads PULSE_TIME_RO4 back (`#1,GPTIME4:300,0x12C`): which
/// reply of the module it is (1: the first), the request it answers, and the offset of the
/// last digit of `300`. Found by replaying a sound start-up's requests to a fresh simulator.
fn pulse_time_read_back() -> (u32, Vec<u8>, u8) {
    let mut r = rig();
    r.startup().unwrap();
    let mut sim = (m16di8ro::SPEC.simulator)(1);
    let mut replies = 0;
    for frame in r.sent() {
        let Some(reply) = sim.on_frame(&frame, LineInstant::ZERO) else {
            continue;
        };
        replies += 1;
        if let Some(at) = reply.bytes.windows(5).position(|w| w == b":300,") {
            return (replies, frame, u8::try_from(at + 3).unwrap());
        }
    }
    panic!("no answer reads 300");
}

/// Garbles the `n`-th next reply: bit 0 of byte `digit`, the last `0` of `300`, so it reads
/// `301`.
fn garble(r: &Rig, n: u32, digit: u8) {
    r.world.lock().unwrap().faults_mut().add(FaultRule {
        device: Some(0),
        fault: Fault::FlipBitAt {
            byte: digit,
            bit: 0,
        },
        frequency: Frequency::Nth(n),
    });
}

/// How often `request` was sent after the write of 300 (an earlier `GPTIME4` reads back the
/// 0 the start-up writes first).
fn asks_after_the_write(r: &Rig, request: &[u8]) -> usize {
    let sent = r.sent();
    let write = sent
        .iter()
        .position(|f| f == b"#1,SPTIME4:300\r")
        .expect("the write");
    sent[write..].iter().filter(|f| *f == request).count()
}

#[test]
fn an_ascii_read_back_garbled_once_is_asked_again_and_the_start_goes_on() {
    let (n, request, digit) = pulse_time_read_back();
    let logs = Logs::default();
    let mut r = rig();
    garble(&r, n, digit);
    let result = tracing::subscriber::with_default(logs.clone(), || r.startup());
    assert_eq!(result.map_err(|e| e.error), Ok(()));
    assert_eq!(asks_after_the_write(&r, &request), 2, "asked again once");
    assert_eq!(r.owner.modules[0].counters.decode_errors, 1);
    assert_eq!(logs.matching("ERROR"), Vec::<String>::new());
}

#[test]
fn the_same_garbled_ascii_read_back_twice_stops_the_start() {
    let (n, request, digit) = pulse_time_read_back();
    let mut r = rig();
    garble(&r, n, digit);
    garble(&r, n + 1, digit);
    let e = r.startup().expect_err("believed when it repeats");
    assert!(
        matches!(
            e.error,
            TxError::Decode(DecodeError::Mismatch {
                expected: 300,
                found: 301,
                ..
            })
        ),
        "{e}"
    );
    assert_eq!(asks_after_the_write(&r, &request), 2, "no third ask");
}
