//! A start-up read-back over the text protocol, which has no check of its own, on a line that
//! garbles a character now and then: the bus owner asks again before it believes a value that
//! differs (see `crate::line::read_back`). The MiniMod driver and simulator through the real
//! bus owner on the virtual line, on a virtual clock; the faults are the simulator's own.

use super::line_tests::{rig, rtu, Logs, Rig};
use crate::devices::Protocol;
use crate::driver::DecodeError;
use crate::line::bus::TxError;
use crate::point::{Quality, Value};
use crate::sim::{Fault, FaultRule, Frequency, LineFaults};
use crate::time::Clock;

/// The watchdog as the long day's project arms it: `?WDTTIME` is answered `WDTTIME=00133`.
const WATCHDOG: [(&str, &str); 2] = [("WDTTIME", "133"), ("WDTYMASK", "0")];

/// The last `3` of `WDTTIME=00133` (byte 12) with bit 1 flipped reads `1` (0x33 → 0x31).
const GARBLE_133_TO_131: Fault = Fault::FlipBitAt { byte: 12, bit: 1 };

const READ_WDTTIME: &[u8] = b"@5?WDTTIME\r";

/// Which reply of the module's start-up answers `?WDTTIME` (1: the first): every request of
/// a start-up on a sound line is answered, so it is the request's place among those sent.
fn wdttime_reply(protocol: Protocol) -> u32 {
    let mut r = rig(protocol, &WATCHDOG);
    r.startup();
    let sent = r.take_sent();
    let at = sent
        .iter()
        .position(|f| f == READ_WDTTIME)
        .expect("the start-up reads WDTTIME back by name");
    u32::try_from(at + 1).unwrap()
}

/// Garbles the `n`-th next reply of the module as `?WDTTIME`'s.
fn garble(r: &Rig, n: u32) {
    r.world.lock().unwrap().faults_mut().add(FaultRule {
        device: Some(0),
        fault: GARBLE_133_TO_131,
        frequency: Frequency::Nth(n),
    });
}

fn asks(sent: &[Vec<u8>]) -> usize {
    sent.iter().filter(|f| *f == READ_WDTTIME).count()
}

#[test]
fn a_read_back_garbled_once_is_asked_again_and_the_watchdog_is_armed() {
    for protocol in [Protocol::Modbus, Protocol::Text] {
        let n = wdttime_reply(protocol);
        let logs = Logs::default();
        let mut r = rig(protocol, &WATCHDOG);
        garble(&r, n);
        tracing::subscriber::with_default(logs.clone(), || {
            // The rig runs with `retries: 0`: the confirming ask is made all the same.
            r.startup();
            for _ in 0..5 {
                let f = r.cycle(true);
                assert_eq!(f.modules[0].quality, Quality::Good, "{protocol:?}");
                assert_eq!(f.modules[0].counters.decode_errors, 1, "the noise, counted");
            }
        });
        assert_eq!(asks(&r.take_sent()), 2, "{protocol:?}: asked again once");
        assert_eq!(r.sim("WDTTIME"), Value::U16(133), "{protocol:?}: armed");
        assert_eq!(r.sim("Y1"), Value::Bool(true));
        assert_eq!(logs.matching("ERROR"), Vec::<String>::new(), "{protocol:?}");
        assert!(r.world.lock().unwrap().faults_mut().rules().is_empty());
    }
}

#[test]
fn the_same_wrong_read_back_twice_in_a_row_stops_the_start_naming_the_register() {
    let n = wdttime_reply(Protocol::Modbus);
    let logs = Logs::default();
    let mut r = rig(Protocol::Modbus, &WATCHDOG);
    // The first ask and the confirming one (the next reply) both read 131.
    garble(&r, n);
    garble(&r, n + 1);
    let result = tracing::subscriber::with_default(logs.clone(), || {
        r.owner.sync(r.clock.line_now());
        r.owner.startup()
    });
    let e = result.expect_err("a read-back that differs twice is the module's");
    assert_eq!(e.module, "mm");
    assert_eq!(
        e.error,
        TxError::Decode(DecodeError::Mismatch {
            register: "WDTTIME",
            expected: 133,
            found: 131,
        })
    );
    assert_eq!(asks(&r.take_sent()), 2, "no third ask with retries: 0");
    let said = logs.matching("watch-dog is not armed");
    assert_eq!(said.len(), 1, "said once: {said:?}");
    assert!(
        said[0].starts_with(
            "ERROR MiniMod at address 5: its watch-dog is not armed as the project says: \
             WDTTIME read back by name (?WDTTIME) is 131, not 133."
        ),
        "{said:?}"
    );
}

#[test]
fn a_modbus_read_back_that_differs_stops_the_start_at_once() {
    // An enabled feedback that holds (an open output) fires the watchdog again as soon as it
    // is reset: WDTFIRED reads back 1 over Modbus, whose CRC leaves no doubt.
    let logs = Logs::default();
    let mut r = rig(Protocol::Modbus, &[("FBENABLE", "1")]);
    r.world
        .lock()
        .unwrap()
        .device_mut(0)
        .unwrap()
        .command(&["fault", "Y1", "open"])
        .unwrap();
    let result = tracing::subscriber::with_default(logs.clone(), || {
        r.owner.sync(r.clock.line_now());
        r.owner.startup()
    });
    assert_eq!(
        result.expect_err("WDTFIRED reads back 1").error,
        TxError::Decode(DecodeError::Mismatch {
            register: "WDTFIRED",
            expected: 0,
            found: 1,
        })
    );
    let sent = r.take_sent();
    let read_wdtfired = rtu(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]);
    assert_eq!(sent.last(), Some(&read_wdtfired), "the start stops there");
    assert_eq!(
        sent.iter().filter(|f| **f == read_wdtfired).count(),
        2,
        "the status read before the reset, and one read-back: never asked again"
    );
}

#[test]
fn a_module_back_after_line_deaths_on_a_noisy_line_is_never_refused() {
    // Twenty minutes of virtual time, 2 % of the module's replies with a bit flipped, the
    // line dead for 2 s every 10 s: the module's watchdog (1.33 s) fires in each outage and
    // its start-up, with both read-backs by name, runs again each time it is back (some of
    // those read-backs garbled into another number).
    let logs = Logs::default();
    let mut r = rig(Protocol::Modbus, &WATCHDOG);
    // A seed whose run garbles two read-backs into another number (the flips land anywhere
    // in any reply, most of them on the Modbus frames' CRC).
    *r.world.lock().unwrap().faults_mut() = LineFaults::new(6);
    r.world.lock().unwrap().faults_mut().add(FaultRule {
        device: Some(0),
        fault: Fault::FlipBit,
        frequency: Frequency::Rate(0.02),
    });
    let cycles = 20 * 60 * 10;
    let tail = tracing::subscriber::with_default(logs.clone(), || {
        r.startup();
        for k in 0..cycles {
            let in_outage = (50..70).contains(&(k % 100));
            r.set_dead(in_outage);
            r.cycle(k % 20 < 10);
        }
        // Then 10 s of a live line (the backoff after the last outage is at most 8 s).
        r.set_dead(false);
        (0..100).map(|_| r.cycle(true)).collect::<Vec<_>>()
    });
    let after = tail
        .iter()
        .skip_while(|f| f.modules[0].quality != Quality::Good);
    let good_at_end = after
        .filter(|f| f.modules[0].quality == Quality::Good)
        .count();
    let noise = r.owner.modules[0].counters;
    assert!(noise.crc_errors > 0, "the line was noisy: {noise:?}");
    assert_eq!(logs.matching("refused"), Vec::<String>::new());
    assert_eq!(logs.matching("not armed"), Vec::<String>::new());
    let back = logs.matching("its watch-dog had fired").len();
    // With `retries: 0` a read-back by name sent twice in a row is a confirming ask: a
    // garbled number was asked again.
    let sent = r.take_sent();
    let asked_again = sent
        .windows(2)
        .filter(|w| w[0] == w[1] && [READ_WDTTIME, b"@5?WDTMASK\r"].contains(&&w[0][..]))
        .count();
    assert!(back >= 100, "{back} returns after a fired watchdog");
    assert_eq!(asked_again, 2, "garbled read-backs asked again");
    assert!(good_at_end >= 20, "{good_at_end} good cycles at the end");
    assert_eq!(r.sim("WDTTIME"), Value::U16(133), "armed at the end");
}

#[test]
fn a_first_start_on_a_noisy_line_is_never_stopped_by_noise() {
    // The first start of the PLC beside a line garbling a reply in ten: a reply the module
    // cannot be understood in (even after the retries) leaves it lost and retried, said in
    // the log, never the PLC refusing to start; it is good once a start-up goes through.
    for seed in 0..40 {
        let logs = Logs::default();
        let mut r = rig(Protocol::Text, &WATCHDOG);
        *r.world.lock().unwrap().faults_mut() = LineFaults::new(seed);
        r.world.lock().unwrap().faults_mut().add(FaultRule {
            device: Some(0),
            fault: Fault::FlipBit,
            frequency: Frequency::Rate(0.1),
        });
        let good = tracing::subscriber::with_default(logs.clone(), || {
            r.startup();
            r.world.lock().unwrap().faults_mut().clear(Some(0));
            // The line is sound again: the lost module's probe (1 s at first) brings it back.
            (0..40).any(|_| r.cycle(true).modules[0].quality == Quality::Good)
        });
        assert!(
            good,
            "seed {seed}: the module is good once the line is sound"
        );
        assert_eq!(
            logs.matching("refused"),
            Vec::<String>::new(),
            "seed {seed}"
        );
    }
}
