//! `echo: discard` on the virtual line, with a simulated adapter that echoes (virtual clock).

use std::sync::Arc;
use std::time::Duration;

use super::*;
use crate::devices::{self, Protocol};
use crate::line::bus::{BusOwner, Discipline, Module, TxError};
use crate::point::Quality;
use crate::sim::line::{SharedWorld, SimWorld, VirtualPort};
use crate::time::{Clock, VirtualClock};

const LINE: LineSettings = LineSettings::DEFAULT;

/// A MiniMod at address 5 on line 0, its adapter echoing or not.
fn world(echo: bool) -> SharedWorld {
    let model = devices::model("minimod").unwrap();
    let mut world = SimWorld::new(vec![LINE]);
    world.add_device(0, "mm", (model.simulator)(5));
    world.set_echo(0, echo);
    world.shared()
}

/// A bus owner for the MiniMod on `world` (Modbus RTU), discarding echoes or not; started up.
fn owner(world: &SharedWorld, discard: bool, clock: &Arc<VirtualClock>) -> BusOwner {
    owner_speaking(world, discard, clock, Protocol::Modbus)
}

/// [`owner`], in `protocol`.
fn owner_speaking(
    world: &SharedWorld,
    discard: bool,
    clock: &Arc<VirtualClock>,
    protocol: Protocol,
) -> BusOwner {
    let model = devices::model("minimod").unwrap();
    let config = model.device_config("mm", 5, protocol, &[]).unwrap();
    let driver = (model.driver)(&config);
    let port: Box<dyn Transport> =
        Box::new(VirtualPort::new(world.clone(), 0, LINE, clock.clone()));
    let port: Box<dyn Transport> = if discard {
        Box::new(EchoDiscard::new(port, echo_margin(LINE, Duration::ZERO)))
    } else {
        port
    };
    let mut owner = BusOwner::new(
        "line1",
        port,
        Discipline::default(),
        vec![Module::new("mm", driver)],
    );
    owner.sync(clock.line_now());
    owner.startup().unwrap();
    clock.advance_to(owner.now().on_scan_clock());
    owner
}

/// Runs `n` read cycles 20 ms apart; the last frame's snapshot of the module.
fn cycles(
    owner: &mut BusOwner,
    clock: &VirtualClock,
    n: usize,
) -> crate::line::bus::ModuleSnapshot {
    let mut last = None;
    for _ in 0..n {
        clock.advance_to(owner.now().on_scan_clock().max(clock.now()) + Duration::from_millis(20));
        owner.sync(clock.line_now());
        last = Some(owner.read_inputs().modules.remove(0));
    }
    last.unwrap()
}

#[test]
fn echo_discard_reads_back_every_request_and_every_exchange_works() {
    let clock = Arc::new(VirtualClock::new());
    let world = world(true);
    let mut owner = owner(&world, true, &clock);
    let m = cycles(&mut owner, &clock, 10);
    assert_eq!(m.quality, Quality::Good, "{:?}", m.last_error);
    assert_eq!(m.counters.errors(), 0, "{:?}", m.counters);
    assert_eq!(m.counters.echo_errors, 0);
    assert!(m.counters.requests >= 10);
    // Nothing of the echoes is left over for the next request to drop.
    assert_eq!(m.counters.dropped_bytes, 0);
}

#[test]
fn an_echoing_line_without_echo_discard_says_what_to_set() {
    let clock = Arc::new(VirtualClock::new());
    let world = world(true);
    let mut owner = owner(&world, false, &clock);
    let m = cycles(&mut owner, &clock, 3);
    assert_ne!(m.quality, Quality::Good);
    assert!(m.counters.echo_errors >= 2, "{:?}", m.counters);
    let e = m.last_error.unwrap();
    assert_eq!(e, TxError::Echo(EchoFault::Unexpected));
    assert_eq!(
        e.to_string(),
        "line error: the reply began with the request's own bytes: the adapter hears its own \
         transmission (set echo: discard on this bus)"
    );
}

#[test]
fn a_corrupted_echo_is_one_line_error_and_the_retry_goes_through() {
    let clock = Arc::new(VirtualClock::new());
    let world = world(true);
    let mut owner = owner(&world, true, &clock);
    cycles(&mut owner, &clock, 2);
    world.lock().unwrap().corrupt_next_echoes(0, 1);
    let m = cycles(&mut owner, &clock, 1);
    assert_eq!(m.counters.echo_errors, 1, "{:?}", m.counters);
    assert_eq!(m.counters.errors(), 1);
    // The line's one retry got the reply: the module's inputs are fresh.
    assert_eq!(m.quality, Quality::Good);
    let m = cycles(&mut owner, &clock, 3);
    assert_eq!(m.counters.echo_errors, 1);
    assert_eq!(m.last_error, None);
}

#[test]
fn a_corrupted_echo_with_no_retry_left_names_the_byte() {
    let clock = Arc::new(VirtualClock::new());
    let world = world(true);
    let mut owner = owner(&world, true, &clock);
    world.lock().unwrap().corrupt_next_echoes(0, 2);
    let m = cycles(&mut owner, &clock, 1);
    assert_eq!(m.counters.echo_errors, 2, "{:?}", m.counters);
    // An 8-byte Modbus read request, flipped in its middle byte.
    assert_eq!(
        m.last_error,
        Some(TxError::Echo(EchoFault::Mismatch { offset: 4 }))
    );
    assert_eq!(
        m.last_error.unwrap().to_string(),
        "line error: echo differs from the request at byte 4 (a collision or noise on the line)"
    );
}

#[test]
fn echo_discard_on_an_adapter_that_does_not_echo_reports_the_missing_echo() {
    let clock = Arc::new(VirtualClock::new());
    let world = world(false);
    let mut owner = owner(&world, true, &clock);
    let m = cycles(&mut owner, &clock, 1);
    assert_ne!(m.quality, Quality::Good);
    let e = m.last_error.unwrap();
    assert!(
        matches!(e, TxError::Echo(EchoFault::Missing { got: 0, .. })),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .starts_with("line error: echo missing: 0 of the request's "),
        "{e}"
    );
}

#[test]
fn verify_compares_byte_for_byte() {
    let sent = [0x05, 0x02, 0x00, 0x00, 0x00, 0x0A, 0xF9, 0x89];
    assert_eq!(verify(&sent, &sent), Ok(()));
    let mut heard = sent;
    heard[6] ^= 0x80;
    assert_eq!(
        verify(&sent, &heard),
        Err(EchoFault::Mismatch { offset: 6 })
    );
    assert_eq!(
        verify(&sent, &sent[..5]),
        Err(EchoFault::Missing { got: 5, sent: 8 })
    );
    // A reply to the read would start 05 02 02: not the request coming back.
    assert!(!begins_with_request(&sent, &[0x05, 0x02, 0x02, 0x01, 0x00]));
    assert!(begins_with_request(&sent, &sent[..3]));
    assert!(begins_with_request(
        &sent,
        &[&sent[..], &[0x05, 0x02]].concat()
    ));
    assert_eq!("discard".parse::<EchoMode>(), Ok(EchoMode::Discard));
    assert_eq!("on".parse::<EchoMode>(), Err(BadEchoMode));
}

#[test]
fn the_text_protocol_reads_its_echo_back_too_and_names_it_without_discard() {
    // A MiniMod spoken to in its text protocol: every command line comes back before the reply.
    let clock = Arc::new(VirtualClock::new());
    let heard = world(true);
    heard
        .lock()
        .unwrap()
        .set(0, "X1", crate::point::Value::Bool(true))
        .unwrap();
    let mut owner = owner_speaking(&heard, true, &clock, Protocol::Text);
    let m = cycles(&mut owner, &clock, 5);
    assert_eq!(m.quality, Quality::Good, "{:?}", m.last_error);
    assert_eq!(m.counters.errors(), 0, "{:?}", m.counters);
    assert_eq!(m.values[0], Some(crate::point::Value::Bool(true)));

    // Without echo: discard the command line itself would be taken for the answer.
    let clock = Arc::new(VirtualClock::new());
    let echoing = world(true);
    let mut owner = owner_speaking(&echoing, false, &clock, Protocol::Text);
    let m = cycles(&mut owner, &clock, 2);
    assert_eq!(m.last_error, Some(TxError::Echo(EchoFault::Unexpected)));
}
