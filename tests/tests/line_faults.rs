//! Every injected line fault, through the real bus owner and MiniMod driver on the virtual line
//! (virtual clock): the fault is detected and counted per module, no wrong value reaches the
//! image, and the module recovers on the next cycle without a restart.

use std::sync::Arc;
use std::time::Duration;

use softplc_io::devices::{self, Protocol};
use softplc_io::line::{BusOwner, Counters, Discipline, LineSettings, Module};
use softplc_io::point::{Quality, Value};
use softplc_io::sim::{Fault, FaultRule, Frequency, SharedWorld, SimWorld, VirtualPort};
use softplc_io::time::{Clock, VirtualClock};

const X1: usize = 0;

struct Rig {
    clock: Arc<VirtualClock>,
    world: SharedWorld,
    owner: BusOwner,
    device: usize,
}

fn rig(retries: u8) -> Rig {
    let model = devices::model("minimod").expect("minimod is in the catalog");
    let settings = LineSettings::DEFAULT;
    let mut world = SimWorld::new(vec![settings]);
    let device = world.add_device(0, "mm5", (model.simulator)(5));
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    let port = VirtualPort::new(world.clone(), 0, settings, clock.clone());
    let config = model
        .device_config("mm5", 5, Protocol::Modbus, &[])
        .unwrap();
    let driver = (model.driver)(&config);
    let discipline = Discipline {
        response_timeout: Duration::from_millis(50),
        retries,
        output_refresh: Duration::from_secs(1),
        fail_limit: 3,
        ..Discipline::default()
    };
    let owner = BusOwner::new(
        "line",
        Box::new(port),
        discipline,
        vec![Module::new("mm5", driver)],
    );
    Rig {
        clock,
        world,
        owner,
        device,
    }
}

impl Rig {
    /// One read cycle starting at the clock's time; the clock then moves past it.
    fn read(&mut self) -> (Option<Value>, Quality, Counters) {
        self.owner.sync(self.clock.line_now());
        let frame = self.owner.read_inputs();
        self.clock
            .advance_to(frame.finished.on_scan_clock() + Duration::from_millis(100));
        let m = &frame.modules[0];
        (m.values[X1], m.quality, m.counters)
    }

    /// Sets the X1 terminal and lets the module's 20 ms input latency pass.
    fn set_x1(&mut self, on: bool) {
        let mut w = self.world.lock().unwrap();
        w.set(self.device, "X1", Value::Bool(on)).unwrap();
        drop(w);
        self.clock
            .advance_to(self.clock.now() + Duration::from_millis(100));
    }

    fn inject(&mut self, fault: Fault, n: u32) {
        let mut w = self.world.lock().unwrap();
        w.faults_mut().add(FaultRule {
            device: Some(self.device),
            fault,
            frequency: Frequency::Next(n),
        });
    }
}

/// Reads with X1 on, then injects `fault` into every attempt of one cycle while X1 turns off:
/// the cycle fails (Stale, value held), then the next one reads the truth.
fn fault_is_survived(fault: Fault, counted: impl Fn(&Counters) -> u64) {
    let mut rig = rig(1);
    rig.set_x1(true);
    let (v, q, before) = rig.read();
    assert_eq!(
        (v, q),
        (Some(Value::Bool(true)), Quality::Good),
        "{fault}: first read"
    );

    rig.set_x1(false);
    rig.inject(fault, 2); // the attempt and its retry
    let (v, q, during) = rig.read();
    assert_eq!(q, Quality::Stale, "{fault}: the failed cycle is stale");
    assert_eq!(
        v,
        Some(Value::Bool(true)),
        "{fault}: the last good value is held, nothing else"
    );
    assert!(
        counted(&during) > counted(&before),
        "{fault}: counted: {during:?}"
    );

    let (v, q, _) = rig.read();
    assert_eq!(
        (v, q),
        (Some(Value::Bool(false)), Quality::Good),
        "{fault}: recovered"
    );
}

#[test]
fn crc_errors_are_counted_and_survived() {
    fault_is_survived(Fault::FlipBit, |c| c.crc_errors + c.bad_replies);
}

/// Part of a reply, then silence: counted as a bad (cut) reply, not as a missing one.
#[test]
fn truncated_replies_are_bad_replies() {
    fault_is_survived(Fault::Truncate { keep: 4 }, |c| c.bad_replies);
}

#[test]
fn a_silent_device_times_out() {
    fault_is_survived(Fault::Silent, |c| c.timeouts);
}

#[test]
fn a_reply_for_another_address_is_refused() {
    fault_is_survived(Fault::WrongAddress { unit: 9 }, |c| c.bad_replies);
}

#[test]
fn garbage_before_the_reply_is_refused() {
    fault_is_survived(Fault::Garbage { bytes: 5 }, |c| {
        c.bad_replies + c.crc_errors
    });
}

#[test]
fn a_babbling_device_garbles_its_reply() {
    fault_is_survived(Fault::Babble { bytes: 12 }, |c| {
        c.bad_replies + c.crc_errors + c.timeouts
    });
}

/// A reply later than the response timeout is never taken as the answer to the retry: the
/// guard time and flush drop it, and the retry's own reply is the one used.
#[test]
fn a_late_reply_is_flushed_not_taken_for_the_next() {
    let mut rig = rig(1);
    rig.set_x1(true);
    rig.read();
    rig.set_x1(false);
    rig.inject(
        Fault::Late {
            by: Duration::from_millis(60),
        },
        1,
    );
    let (v, q, c) = rig.read();
    assert_eq!(c.timeouts, 1);
    assert!(c.dropped_bytes > 0, "the late reply was flushed: {c:?}");
    assert_eq!(
        (v, q),
        (Some(Value::Bool(false)), Quality::Good),
        "the retry's own reply"
    );
}

/// A duplicated reply: the first copy is the answer; the second is dropped before the next
/// request, so it cannot answer it.
#[test]
fn a_duplicated_reply_is_dropped_before_the_next_request() {
    let mut rig = rig(0);
    rig.set_x1(true);
    rig.inject(Fault::Duplicate, 1);
    let (v, q, _) = rig.read();
    assert_eq!((v, q), (Some(Value::Bool(true)), Quality::Good));
    rig.set_x1(false);
    let (v, q, c) = rig.read();
    assert_eq!((v, q), (Some(Value::Bool(false)), Quality::Good));
    assert!(c.dropped_bytes >= 7, "the copy was flushed: {c:?}");
}

/// A dead line: the module goes stale, then is lost (bad) after the fail limit and polled only
/// at its reconnect backoff, so it costs the line no timeouts meanwhile; it comes back good
/// when the line does, with no restart.
#[test]
fn a_dead_line_turns_points_bad_then_recovers() {
    let mut rig = rig(0);
    rig.set_x1(true);
    assert_eq!(rig.read().1, Quality::Good);
    rig.world.lock().unwrap().faults_mut().set_dead(0, true);
    let qualities: Vec<Quality> = (0..4).map(|_| rig.read().1).collect();
    assert_eq!(
        qualities,
        [Quality::Stale, Quality::Stale, Quality::Bad, Quality::Bad]
    );
    let (_, _, c) = rig.read();
    assert_eq!(
        c.timeouts, 3,
        "a lost module is not polled before its backoff: {c:?}"
    );
    rig.world.lock().unwrap().faults_mut().set_dead(0, false);
    rig.clock
        .advance_to(rig.clock.now() + Duration::from_secs(1));
    let (v, q, c) = rig.read();
    assert_eq!((v, q), (Some(Value::Bool(true)), Quality::Good));
    assert_eq!(c.timeouts, 3);
}
