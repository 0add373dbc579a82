//! The driver against the simulator, transaction by transaction.

use super::*;
use crate::line::collect;
use crate::modbus::crc::append_crc;
use crate::modbus::master::{encode_request, Progress, ReplyAssembler};
use crate::modbus::ExceptionCode;
use crate::sim::SimDevice;

use super::super::map::WatchdogRegisters;
use super::super::sim::MiniModSim;
use crate::time::LineInstant;

const UNIT: u8 = 5;

fn unit() -> UnitId {
    UnitId::new(UNIT).unwrap()
}

fn driver(settings: &[(&str, &str)]) -> MiniModDriver {
    let settings: Vec<Setting> = settings
        .iter()
        .map(|(k, v)| Setting::parse(k, v).unwrap())
        .collect();
    MiniModDriver::new(Some(unit()), &settings)
}

fn frame(bytes: &[u8]) -> Vec<u8> {
    let mut f = bytes.to_vec();
    append_crc(&mut f);
    f
}

fn wire(tx: &Transaction) -> Vec<u8> {
    let Outgoing::Modbus { unit, request } = &tx.frame else {
        panic!("not modbus")
    };
    let mut out = Vec::new();
    encode_request(unit.get(), request, &mut out).unwrap();
    out
}

/// Runs a transaction against the simulator at time `t`, as a bus owner would.
fn exchange(
    d: &mut MiniModDriver,
    sim: &mut MiniModSim,
    tx: &Transaction,
    t: Duration,
) -> Result<(), DecodeError> {
    let (unit, request) = match &tx.frame {
        Outgoing::Modbus { unit, request } => (unit, request),
        Outgoing::Text {
            line, terminator, ..
        } => {
            let reply = sim
                .on_frame(line, LineInstant::after_origin(t))
                .expect("a text reply");
            let end = reply.bytes.iter().position(|b| b == terminator).unwrap();
            return d.on_reply(tx.tag, &Reply::Text(reply.bytes[..end].to_vec()));
        }
        Outgoing::NoReply { .. } => panic!("the MiniMod driver plans no unanswered frame"),
    };
    let reply = sim
        .on_frame(&wire(tx), LineInstant::after_origin(t))
        .expect("a reply");
    let mut asm = ReplyAssembler::new(unit.get(), request);
    let Progress::Complete { response, extra: 0 } = asm.push(&reply.bytes) else {
        panic!("reply not verified: {:?}", reply.bytes)
    };
    d.on_reply(tx.tag, &Reply::Modbus(response))
}

fn value(d: &MiniModDriver, name: &str) -> Option<Value> {
    map::point_index(name).and_then(|i| d.values()[i])
}

fn desired(outputs: &[(&str, bool)]) -> Vec<Option<Value>> {
    let mut v = vec![None; POINTS.len()];
    for (name, on) in outputs {
        v[map::point_index(name).unwrap()] = Some(Value::Bool(*on));
    }
    v
}

#[test]
fn point_indexes_match_the_table() {
    for (name, i) in [
        ("X1", IDX_X[0]),
        ("X3", IDX_X[2]),
        ("X9", IDX_X9),
        ("X10", IDX_X10),
    ] {
        assert_eq!(map::point_index(name), Some(i));
    }
    assert_eq!(map::point_index("FB1"), Some(IDX_FB1));
    assert_eq!(map::point_index("FB2"), Some(IDX_FB2));
    assert_eq!(map::point_index("Y1"), Some(IDX_Y[0]));
    assert_eq!(map::point_index("Y4"), Some(IDX_Y[3]));
    assert_eq!(map::point_index("YWORD"), Some(IDX_YWORD));
}

#[test]
fn read_plan_is_one_fc2_byte_exact() {
    let mut d = driver(&[]);
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    assert_eq!(plan.len(), 1);
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]));
    assert_eq!(
        wire(&plan[0]),
        [0x05, 0x02, 0x00, 0x00, 0x00, 0x0A, 0xF9, 0x89]
    );
}

#[test]
fn reads_inputs_from_the_simulator() {
    let mut d = driver(&[]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("X1", Value::Bool(true)).unwrap();
    sim.set("X3", Value::Bool(true)).unwrap();
    sim.command(&["fault", "Y4", "open"]).unwrap();
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    assert_eq!(value(&d, "X1"), None, "nothing before the first read");
    exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(20)).unwrap();
    assert_eq!(value(&d, "X1"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "X2"), Some(Value::Bool(false)));
    assert_eq!(value(&d, "X3"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "X9"), Some(Value::Bool(false)));
    assert_eq!(value(&d, "X10"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "FB2"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "Y1"), None, "no read-back by default");
    assert_eq!(value(&d, "XCOUNT1"), None);
}

#[test]
fn writes_yword_on_change_only_and_records_the_echo() {
    let mut d = driver(&[]);
    let mut sim = MiniModSim::new(UNIT);
    let want = desired(&[("Y1", true), ("Y2", false), ("Y3", true), ("Y4", false)]);
    let mut plan = Vec::new();
    d.plan_write(&want, false, &mut plan);
    assert_eq!(plan.len(), 1);
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x05]));
    exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
    assert_eq!(value(&d, "Y1"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "Y2"), Some(Value::Bool(false)));
    assert_eq!(value(&d, "YWORD"), Some(Value::U16(5)));
    assert_eq!(sim.get("Y3"), Ok(Value::Bool(true)));
    plan.clear();
    d.plan_write(&want, false, &mut plan);
    assert!(plan.is_empty(), "no change, no write");
    d.plan_write(&want, true, &mut plan);
    assert_eq!(plan.len(), 1, "refresh writes again");
}

#[test]
fn a_read_write_register_is_a_command_written_once() {
    let mut d = driver(&[]);
    let mut sim = MiniModSim::new(UNIT);
    let mut want = vec![None; POINTS.len()];
    want[map::point_index("YPULSE2").unwrap()] = Some(Value::U16(50));
    let mut plan = Vec::new();
    d.plan_write(&want, false, &mut plan);
    // FC 6 on holding register 84 (40085, YPULSE2) = 50.
    assert_eq!(plan.len(), 1);
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x06, 0x00, 0x54, 0x00, 0x32]));
    exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
    assert_eq!(sim.get("Y2"), Ok(Value::Bool(true)), "the pulser runs");
    assert_eq!(value(&d, "YPULSE2"), Some(Value::U16(50)));
    plan.clear();
    d.plan_write(&vec![None; POINTS.len()], false, &mut plan);
    assert!(plan.is_empty(), "written only while the scan asks");
}

#[test]
fn a_blinker_mask_is_written_when_it_changes_and_after_a_restart() {
    let mut d = driver(&[]);
    let mut sim = MiniModSim::new(UNIT);
    let lamp = map::point_index("YLAMP3").unwrap();
    let mut want = vec![None; POINTS.len()];
    want[lamp] = Some(Value::U16(0x0F0F));
    let mut plan = Vec::new();
    d.plan_write(&want, false, &mut plan);
    // FC 6 on holding register 77 (40078, YLAMP3) = 0x0F0F.
    assert_eq!(plan.len(), 1);
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x06, 0x00, 0x4D, 0x0F, 0x0F]));
    exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
    assert_eq!(sim.get("YLAMP3"), Ok(Value::U16(0x0F0F)));
    // Asked for again every cycle: no write until it changes (the module blinks by itself).
    for _ in 0..3 {
        plan.clear();
        d.plan_write(&want, false, &mut plan);
        assert!(plan.is_empty(), "the same mask, no write");
    }
    want[lamp] = Some(Value::U16(0));
    d.plan_write(&want, false, &mut plan);
    assert_eq!(plan.len(), 1, "the enable fell: 0");
    // Not with the periodic rewrite of the outputs; after a restart (whose start-up clears
    // the blinkers), again.
    plan.clear();
    d.plan_write(&want, true, &mut plan);
    assert!(plan.is_empty(), "the refresh leaves it");
    d.on_restart();
    d.plan_write(&want, false, &mut plan);
    assert!(
        plan.iter()
            .any(|tx| wire(tx) == frame(&[0x05, 0x06, 0x00, 0x4D, 0x00, 0x00])),
        "after a restart"
    );
}

#[test]
fn readback_shows_a_pulse_while_it_runs_and_off_after_it() {
    let mut d = driver(&[("readback", "every")]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("Y2", Value::Bool(true)).unwrap(); // on before the pulse
    let mut want = vec![None; POINTS.len()];
    want[map::point_index("YPULSE2").unwrap()] = Some(Value::U16(100));
    let mut plan = Vec::new();
    d.plan_write(&want, false, &mut plan);
    exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(10)).unwrap();
    let mut read = Vec::new();
    d.plan_read(&mut read);
    assert_eq!(wire(&read[1]), frame(&[0x05, 0x01, 0x00, 0x00, 0x00, 0x04]));
    let coils = |sim: &mut MiniModSim, t: u64| {
        sim.on_frame(
            &wire(&read[1]),
            LineInstant::after_origin(Duration::from_millis(t)),
        )
        .unwrap()
        .bytes
    };
    // During the pulse the coils read Y2 on; the driver's image agrees.
    assert_eq!(coils(&mut sim, 60), frame(&[0x05, 0x01, 0x01, 0x02]));
    exchange(&mut d, &mut sim, &read[1], Duration::from_millis(61)).unwrap();
    assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "YWORD"), Some(Value::U16(0b0010)));
    // After 100 ms: off, although it was on before.
    assert_eq!(coils(&mut sim, 110), frame(&[0x05, 0x01, 0x01, 0x00]));
    exchange(&mut d, &mut sim, &read[1], Duration::from_millis(111)).unwrap();
    assert_eq!(value(&d, "Y2"), Some(Value::Bool(false)));
    assert_eq!(value(&d, "YWORD"), Some(Value::U16(0)));
}

#[test]
fn partial_ownership_writes_only_owned_outputs() {
    let mut d = driver(&[]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("Y4", Value::Bool(true)).unwrap(); // set by the module's own logic
                                               // Two owned outputs to write: one FC 22 on YWORD.
    let want = desired(&[("Y1", true), ("Y2", false)]);
    let mut plan = Vec::new();
    d.plan_write(&want, false, &mut plan);
    assert_eq!(
        wire(&plan[0]),
        frame(&[0x05, 0x16, 0x00, 0x00, 0xFF, 0xFC, 0x00, 0x01])
    );
    exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
    assert_eq!(sim.get("YWORD"), Ok(Value::U16(0b1001)), "Y4 untouched");
    assert_eq!(value(&d, "Y1"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "Y4"), None);
    // One changed: FC 5 on its coil.
    let want = desired(&[("Y1", true), ("Y2", true)]);
    plan.clear();
    d.plan_write(&want, false, &mut plan);
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x05, 0x00, 0x01, 0xFF, 0x00]));
    exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
    assert_eq!(sim.get("YWORD"), Ok(Value::U16(0b1011)));
    assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
    // Refresh: both owned again, still one transaction.
    plan.clear();
    d.plan_write(&want, true, &mut plan);
    assert_eq!(
        wire(&plan[0]),
        frame(&[0x05, 0x16, 0x00, 0x00, 0xFF, 0xFC, 0x00, 0x03])
    );
}

#[test]
fn a_failed_write_is_planned_again() {
    let mut d = driver(&[]);
    let want = desired(&[("Y1", true), ("Y2", true), ("Y3", true), ("Y4", true)]);
    let mut plan = Vec::new();
    d.plan_write(&want, false, &mut plan);
    d.on_failure(plan[0].tag);
    plan.clear();
    d.plan_write(&want, false, &mut plan);
    assert_eq!(plan.len(), 1);
    // An exception counts as failed too (the bus reports it and calls on_failure).
    let exception = Reply::Modbus(Response::Exception {
        function: 6,
        code: ExceptionCode::ServerDeviceFailure,
    });
    assert_eq!(
        d.on_reply(plan[0].tag, &exception),
        Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure))
    );
}

#[test]
fn readback_every_nth_cycle() {
    let mut d = driver(&[("readback", "3")]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("Y2", Value::Bool(true)).unwrap();
    let mut counts = Vec::new();
    for cycle in 0..6u64 {
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        counts.push(plan.len());
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::from_millis(cycle * 50)).unwrap();
        }
    }
    assert_eq!(counts, [2, 1, 1, 2, 1, 1]);
    assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "Y1"), Some(Value::Bool(false)));
    let mut plan = Vec::new();
    driver(&[("readback", "every")]).plan_read(&mut plan);
    assert_eq!(wire(&plan[1]), frame(&[0x05, 0x01, 0x00, 0x00, 0x00, 0x04]));
}

#[test]
fn unexpected_replies_are_typed_errors() {
    let mut d = driver(&[]);
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    let tag = plan[0].tag;
    let short = Reply::Modbus(Response::ReadDiscreteInputs(vec![true; 3]));
    assert_eq!(
        d.on_reply(tag, &short),
        Err(DecodeError::Unexpected { tag })
    );
    let other = Reply::Modbus(Response::ReadCoils(vec![true; 10]));
    assert_eq!(
        d.on_reply(tag, &other),
        Err(DecodeError::Unexpected { tag })
    );
    let text = Reply::Text(b"X1=1".to_vec());
    assert_eq!(d.on_reply(tag, &text), Err(DecodeError::Unexpected { tag }));
    assert_eq!(
        d.on_reply(0xDEAD_BEEF, &short),
        Err(DecodeError::Unexpected { tag: 0xDEAD_BEEF })
    );
    let echo = Reply::Modbus(Response::WriteSingleRegister { addr: 7, value: 1 });
    let wtag = Tag::WriteOutputs.encode();
    assert_eq!(
        d.on_reply(wtag, &echo),
        Err(DecodeError::Unexpected { tag: wtag })
    );
}

#[test]
fn startup_writes_and_verifies_settings() {
    let mut d = driver(&[
        ("XLATUP1", "5"),
        ("XLATUP2", "0x10"),
        ("XLATDN1", "500"),
        ("Y1AON1", "X1-X2"),
        ("readback", "off"),
    ]);
    let mut sim = MiniModSim::new(UNIT);
    let mut plan = Vec::new();
    d.plan_startup(&mut plan);
    assert_eq!(
        plan.len(),
        10,
        "runs 19..20 and 35, the logic clear (51..=78, 83..=86), then 51"
    );
    assert_eq!(
        wire(&plan[0]),
        frame(&[0x05, 0x10, 0x00, 0x13, 0x00, 0x02, 0x04, 0x00, 0x05, 0x00, 0x10])
    );
    assert_eq!(wire(&plan[1]), frame(&[0x05, 0x03, 0x00, 0x13, 0x00, 0x02]));
    for tx in &plan {
        exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
    }
    assert_eq!(sim.get("XLATDN1"), Ok(Value::U16(500)));
    assert_eq!(sim.get("Y1AON1"), Ok(Value::U16(0x0203)));
    // A module that holds something else is a mismatch.
    sim.set("XLATUP2", Value::U16(7)).unwrap();
    assert_eq!(
        exchange(&mut d, &mut sim, &plan[1], Duration::ZERO),
        Err(DecodeError::Mismatch {
            register: "XLATUP2",
            expected: 16,
            found: 7
        })
    );
}

#[test]
fn reply_delay_follows_the_settings() {
    assert_eq!(
        driver(&[("RDELAYT", "5")]).reply_delay(),
        Duration::from_millis(50)
    );
    assert_eq!(
        driver(&[("RDELAYT", "0"), ("RDELAYM", "15")]).reply_delay(),
        Duration::from_micros(1500)
    );
    assert_eq!(driver(&[]).reply_delay(), Duration::from_millis(10));
}

#[test]
fn catalog_entry() {
    let m = crate::devices::model("minimod").unwrap();
    assert_eq!(m.protocols, [Protocol::Modbus, Protocol::Text]);
    assert_eq!(m.max_baud, 57600);
    assert_eq!(m.default_reply_delay, Duration::from_millis(10));
    let config = m
        .device_config("mm1", UNIT, Protocol::Modbus, &[("readback", "every")])
        .unwrap();
    let mut d = (m.driver)(&config);
    assert_eq!(d.address(), UNIT);
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    assert_eq!(plan.len(), 2);
    assert_eq!((m.simulator)(UNIT).address(), UNIT);
}

/// Polls X1 every 100 ms around a 30 ms pulse at 130..160 ms; returns the polls that saw
/// it.
fn polls_seeing_a_30_ms_pulse(settings: &[(&str, &str)]) -> Vec<u64> {
    let mut d = driver(settings);
    let mut sim = MiniModSim::new(UNIT);
    let mut setup = Vec::new();
    d.plan_startup(&mut setup);
    for tx in &setup {
        exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
    }
    let mut seen = Vec::new();
    for t in (100..=900).step_by(100) {
        if t == 200 {
            sim.advance_to(LineInstant::after_origin(Duration::from_millis(130)));
            sim.set("X1", Value::Bool(true)).unwrap();
            sim.advance_to(LineInstant::after_origin(Duration::from_millis(160)));
            sim.set("X1", Value::Bool(false)).unwrap();
        }
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(t)).unwrap();
        if value(&d, "X1") == Some(Value::Bool(true)) {
            seen.push(t);
        }
    }
    seen
}

#[test]
fn a_500_ms_falling_latency_lets_a_100_ms_scan_see_a_30_ms_pulse() {
    assert_eq!(
        polls_seeing_a_30_ms_pulse(&[]),
        Vec::<u64>::new(),
        "20 ms latencies: the pulse falls between two polls"
    );
    assert_eq!(
        polls_seeing_a_30_ms_pulse(&[("XLATDN1", "500")]),
        [200, 300, 400, 500, 600],
        "cooked from 150 ms to 659 ms"
    );
}

fn text_driver(settings: &[(&str, &str)]) -> MiniModDriver {
    let settings: Vec<Setting> = settings
        .iter()
        .map(|(k, v)| Setting::parse(k, v).unwrap())
        .collect();
    MiniModDriver::with_protocol(Some(unit()), Protocol::Text, &settings)
}

fn line(tx: &Transaction) -> &[u8] {
    match &tx.frame {
        Outgoing::Text {
            line, terminator, ..
        } => {
            assert_eq!(*terminator, b'\r');
            line
        }
        _ => panic!("not text"),
    }
}

#[test]
fn text_protocol_reads_and_writes_the_same_points() {
    let mut d = text_driver(&[("readback", "every")]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("X2", Value::Bool(true)).unwrap();
    sim.command(&["fault", "Y1", "open"]).unwrap();
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    assert_eq!(line(&plan[0]), b"@5?XWORD\r");
    assert_eq!(line(&plan[1]), b"@5?YWORD\r");
    for tx in &plan {
        exchange(&mut d, &mut sim, tx, Duration::from_millis(20)).unwrap();
    }
    assert_eq!(value(&d, "X1"), Some(Value::Bool(false)));
    assert_eq!(value(&d, "X2"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "X9"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "FB1"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "XWORD"), Some(Value::U16(0x0102)));
    assert_eq!(value(&d, "YWORD"), Some(Value::U16(0)));
    // All four owned: one >YWORD=.
    let want = desired(&[("Y1", true), ("Y2", false), ("Y3", true), ("Y4", false)]);
    plan.clear();
    d.plan_write(&want, false, &mut plan);
    assert_eq!(plan.len(), 1);
    assert_eq!(line(&plan[0]), b"@5>YWORD=5\r");
    exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(30)).unwrap();
    assert_eq!(sim.get("YWORD"), Ok(Value::U16(5)));
    assert_eq!(value(&d, "Y3"), Some(Value::Bool(true)));
    // Two owned, both changed: one >Yn= each.
    let mut d = text_driver(&[]);
    let want = desired(&[("Y2", true), ("Y4", false)]);
    plan.clear();
    d.plan_write(&want, false, &mut plan);
    let lines: Vec<&[u8]> = plan.iter().map(line).collect();
    assert_eq!(lines, [&b"@5>Y2=1\r"[..], b"@5>Y4=0\r"]);
    for tx in &plan {
        exchange(&mut d, &mut sim, tx, Duration::from_millis(40)).unwrap();
    }
    assert_eq!(sim.get("YWORD"), Ok(Value::U16(0b0111)), "Y1, Y3 untouched");
    assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "Y1"), None);
}

#[test]
fn text_write_refused_while_the_watchdog_fires_is_planned_again() {
    let mut d = text_driver(&[]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("WDTFIRED", Value::Bool(true)).unwrap();
    let want = desired(&[("Y1", true)]);
    let mut plan = Vec::new();
    d.plan_write(&want, false, &mut plan);
    let r = exchange(&mut d, &mut sim, &plan[0], Duration::ZERO);
    assert_eq!(
        r,
        Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure)),
        "Error: the module said no, as exception 04 does"
    );
    assert!(
        d.wants_restart(),
        "a fired watchdog: the start-up must run again"
    );
    d.on_failure(plan[0].tag);
    plan.clear();
    d.plan_write(&want, false, &mut plan);
    assert_eq!(plan.len(), 1);
}

#[test]
fn modbus_write_refused_while_the_watchdog_fires() {
    let mut d = driver(&[]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("WDTFIRED", Value::Bool(true)).unwrap();
    let mut plan = Vec::new();
    d.plan_write(&desired(&[("Y1", true)]), false, &mut plan);
    assert_eq!(
        exchange(&mut d, &mut sim, &plan[0], Duration::ZERO),
        Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure))
    );
}

#[test]
fn watchdog_and_event_masks_at_start_up() {
    let mut d = driver(&[
        ("WDTTIME", "50"),
        ("WDTMASK", "0b1000"),
        ("FBENABLE", "3"),
        ("XEVMASK", "7"),
        ("YEVMASK", "0xF"),
        ("RDELAYT", "2"),
    ]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("WDTFIRED", Value::Bool(true)).unwrap(); // left by the last run
    let mut plan = Vec::new();
    d.plan_startup(&mut plan);
    let mut wires: Vec<Vec<u8>> = plan
        .iter()
        .map(|tx| match &tx.frame {
            Outgoing::Text { line, .. } => line.clone(),
            _ => wire(tx),
        })
        .collect();
    // The logic registers are cleared after the watchdog reset (see `logic`).
    let clear: Vec<Vec<u8>> = wires.drain(12..16).collect();
    assert_eq!(clear, logic::tests::clear_frames(UNIT));
    assert_eq!(
        wires,
        [
            // Why it fired, before anything resets it (see `restart`): WDTFIRED (coil
            // 160), WDTFB and WDTCOMM (discrete inputs 24..=25).
            frame(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
            frame(&[0x05, 0x02, 0x00, 0x18, 0x00, 0x02]),
            frame(&[0x05, 0x10, 0x00, 0x05, 0x00, 0x02, 0x04, 0x00, 0x07, 0x00, 0x0F]),
            frame(&[0x05, 0x03, 0x00, 0x05, 0x00, 0x02]),
            // The watchdog by name, on the Modbus driver too (see `watchdog`).
            b"@5>WDTTIME=50\r".to_vec(),
            b"@5?WDTTIME\r".to_vec(),
            b"@5>WDTMASK=8\r".to_vec(),
            b"@5?WDTMASK\r".to_vec(),
            frame(&[0x05, 0x0F, 0x00, 0x70, 0x00, 0x02, 0x01, 0x03]),
            frame(&[0x05, 0x01, 0x00, 0x70, 0x00, 0x02]),
            frame(&[0x05, 0x0F, 0x00, 0xA0, 0x00, 0x01, 0x01, 0x00]),
            frame(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
            b"@5>RDELAYT=2\r".to_vec(),
        ]
    );
    // Armed under either reading of the manual (see `map`).
    let mut aliased = MiniModSim::with_watchdog_registers(UNIT, WatchdogRegisters::Aliased);
    aliased.set("WDTFIRED", Value::Bool(true)).unwrap();
    let mut d_aliased = d.clone();
    for tx in &plan {
        exchange(&mut d_aliased, &mut aliased, tx, Duration::ZERO).unwrap();
    }
    assert_eq!(aliased.get("WDTTIME"), Ok(Value::U16(50)));
    assert_eq!(aliased.get("WDTYMASK"), Ok(Value::U16(8)));
    assert_eq!(aliased.get("WDTFIRED"), Ok(Value::Bool(false)));
    for tx in &plan {
        exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
    }
    assert_eq!(sim.get("WDTTIME"), Ok(Value::U16(50)));
    assert_eq!(sim.get("WDTYMASK"), Ok(Value::U16(8)));
    assert_eq!(sim.get("WDTFB2"), Ok(Value::Bool(true)));
    assert_eq!(sim.get("WDTFIRED"), Ok(Value::Bool(false)), "reset");
    assert_eq!(sim.state().rdelayt(), 2);
    assert_eq!(value(&d, "WDTTIME"), Some(Value::U16(50)));
    assert_eq!(value(&d, "WDTFB1"), Some(Value::Bool(true)));
    // A module that holds something else names the register.
    sim.set("WDTFB1", Value::Bool(false)).unwrap();
    assert_eq!(
        exchange(&mut d, &mut sim, &plan[9], Duration::ZERO),
        Err(DecodeError::Mismatch {
            register: "WDTFB1",
            expected: 1,
            found: 0
        })
    );
    // An enabled feedback that holds fires it again at once: the start stops, by name.
    sim.set("WDTFB1", Value::Bool(true)).unwrap();
    sim.command(&["fault", "Y1", "open"]).unwrap();
    exchange(&mut d, &mut sim, &plan[10], Duration::from_millis(10)).unwrap();
    assert_eq!(
        exchange(&mut d, &mut sim, &plan[11], Duration::from_millis(11)),
        Err(DecodeError::Mismatch {
            register: "WDTFIRED",
            expected: 0,
            found: 1
        })
    );
}

#[test]
fn a_watchdog_read_back_otherwise_by_name_stops_the_start_naming_both_readings() {
    let logs = super::super::line_tests::Logs::default();
    let mut d = driver(&[("WDTTIME", "50"), ("WDTYMASK", "2")]);
    let mut sim = MiniModSim::new(UNIT);
    let mut plan = Vec::new();
    d.plan_startup(&mut plan);
    let verify = plan
        .iter()
        .position(|tx| matches!(&tx.frame, Outgoing::Text { line, .. } if line == b"@5?WDTTIME\r"))
        .unwrap();
    let result = tracing::subscriber::with_default(logs.clone(), || {
        for tx in &plan[..verify] {
            exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
        }
        // The module lost it between the write and its read-back (or never took it).
        sim.set("WDTTIME", Value::U16(0)).unwrap();
        let result = exchange(&mut d, &mut sim, &plan[verify], Duration::ZERO);
        // The text reply has no check: nothing is said until the bus owner believes it.
        assert!(logs.matching("watch-dog is not armed").is_empty());
        if let Err(mismatch) = result {
            d.on_confirmed_mismatch(plan[verify].tag, mismatch);
        }
        result
    });
    assert_eq!(
        result,
        Err(DecodeError::Mismatch {
            register: "WDTTIME",
            expected: 50,
            found: 0
        })
    );
    assert_eq!(
        logs.matching("watch-dog is not armed"),
        [
            "ERROR MiniMod at address 5: its watch-dog is not armed as the project says: WDTTIME \
             read back by name (?WDTTIME) is 0, not 50. The manual places the watch-dog's \
             registers two ways (the register table: WDTTIME holding register 128 (40129), \
             WDTYMASK 144 (40145); the coil/register aliasing rule: WDTTIME holding register 8 \
             (40009), WDTYMASK 9 (40010)); the name depends on neither, so the module refused \
             or lost the value"
        ]
    );
}

#[test]
fn a_program_command_to_wdttime_or_wdtymask_goes_by_name() {
    for registers in WatchdogRegisters::ALL {
        let mut d = driver(&[]);
        let mut sim = MiniModSim::with_watchdog_registers(UNIT, registers);
        let mut want = vec![None; POINTS.len()];
        want[map::point_index("WDTTIME").unwrap()] = Some(Value::U16(30));
        want[map::point_index("WDTYMASK").unwrap()] = Some(Value::U16(4));
        want[map::point_index("YPULSE1").unwrap()] = Some(Value::U16(100));
        let mut plan = Vec::new();
        d.plan_write(&want, false, &mut plan);
        let lines: Vec<Vec<u8>> = plan
            .iter()
            .map(|tx| match &tx.frame {
                Outgoing::Text { line, .. } => line.clone(),
                _ => wire(tx),
            })
            .collect();
        assert_eq!(
            lines,
            [
                // The pulser by its register (the same in both readings), FC 6.
                frame(&[0x05, 0x06, 0x00, 0x53, 0x00, 0x64]),
                b"@5>WDTTIME=30\r".to_vec(),
                b"@5>WDTMASK=4\r".to_vec(),
            ]
        );
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
        }
        assert_eq!(sim.get("WDTTIME"), Ok(Value::U16(30)), "{registers:?}");
        assert_eq!(sim.get("WDTYMASK"), Ok(Value::U16(4)), "{registers:?}");
        assert_eq!(value(&d, "WDTTIME"), Some(Value::U16(30)));
        assert_eq!(value(&d, "WDTYMASK"), Some(Value::U16(4)));
    }
}

#[test]
fn text_start_up_uses_text_where_the_tables_allow() {
    let mut d = text_driver(&[
        ("X1LATUP", "5"),
        ("Y3AON2", "X2-X3"),
        ("Y1AON1", "0x0100"), // conditions go through Modbus, read back
        ("FBENABLE", "2"),
        ("XCOUNT1", "100"),
        ("XEVMASK", "1"), // no text identifier: Modbus
    ]);
    let mut sim = MiniModSim::new(UNIT);
    let mut plan = Vec::new();
    d.plan_startup(&mut plan);
    let texts: Vec<&[u8]> = plan
        .iter()
        .filter_map(|tx| match &tx.frame {
            Outgoing::Text { line, .. } => Some(line.as_slice()),
            _ => None,
        })
        .collect();
    assert_eq!(
        texts,
        [
            &b"@5?WFLAGS\r"[..], // why the watchdog fired, before the reset (`restart`)
            b"@5>XCOUNT1=100\r",
            b"@5>X1LATUP=5\r",
            b"@5?X1LATUP\r",
            b"@5>FBENABLE=2\r",
            b"@5?FBENABLE\r",
        ]
    );
    assert_eq!(
        plan.len(),
        texts.len() + 13,
        "Modbus: WDTFB/WDTCOMM (why the watchdog fired), XEVMASK, WDTFIRED (the watchdog \
         reset), the logic clear (two runs), then Y1AON1 and Y3AON2 (conditions cannot be \
         read back in text, see `logic`)"
    );
    for tx in &plan {
        exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
    }
    assert_eq!(sim.get("Y3AON2"), Ok(Value::U16(0x0406)));
    assert_eq!(sim.get("Y1AON1"), Ok(Value::U16(0x0100)));
    assert_eq!(sim.get("XEVMASK"), Ok(Value::U16(1)));
    assert_eq!(sim.get("WDTFB2"), Ok(Value::Bool(true)));
    assert_eq!(value(&d, "XLATUP1"), Some(Value::U16(5)));
    sim.set("XLATUP1", Value::U16(9)).unwrap();
    let verify = plan
        .iter()
        .find(|tx| matches!(&tx.frame, Outgoing::Text { line, .. } if line == b"@5?X1LATUP\r"))
        .unwrap();
    assert_eq!(
        exchange(&mut d, &mut sim, verify, Duration::ZERO),
        Err(DecodeError::Mismatch {
            register: "XLATUP1",
            expected: 5,
            found: 9
        })
    );
}

#[test]
fn counters_and_status_every_nth_cycle() {
    let mut d = driver(&[("counters", "2"), ("status", "every")]);
    let mut sim = MiniModSim::new(UNIT);
    sim.set("XLATUP1", Value::U16(0)).unwrap();
    sim.set("XLATDN1", Value::U16(0)).unwrap();
    for k in 0..3u64 {
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(LineInstant::after_origin(Duration::from_millis(10 * k + 5)));
        sim.set("X1", Value::Bool(false)).unwrap();
        sim.advance_to(LineInstant::after_origin(Duration::from_millis(
            10 * k + 10,
        )));
    }
    sim.set("SW4", Value::Bool(true)).unwrap();
    sim.command(&["flash", "broken"]).unwrap();
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    assert_eq!(plan.len(), 4, "status (2), counters, inputs");
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x02, 0x00, 0x11, 0x00, 0x71]));
    for tx in &plan {
        exchange(&mut d, &mut sim, tx, Duration::from_millis(40)).unwrap();
    }
    assert_eq!(value(&d, "XCOUNT1"), Some(Value::U16(3)));
    assert_eq!(value(&d, "SW4"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "FLASHFAIL"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "WDTFIRED"), Some(Value::Bool(false)));
    plan.clear();
    d.plan_read(&mut plan);
    assert_eq!(plan.len(), 3, "no counters in the second cycle");
    // Text: ?WFLAGS and ?XCOUNTn.
    let mut t = text_driver(&[("counters", "every"), ("status", "every")]);
    sim.set("WDTFIRED", Value::Bool(true)).unwrap();
    plan.clear();
    t.plan_read(&mut plan);
    assert_eq!(line(&plan[0]), b"@5?WFLAGS\r");
    assert_eq!(line(&plan[3]), b"@5?XCOUNT3\r");
    for tx in &plan {
        exchange(&mut t, &mut sim, tx, Duration::from_millis(50)).unwrap();
    }
    assert_eq!(value(&t, "WDTFIRED"), Some(Value::Bool(true)));
    assert_eq!(value(&t, "XCOUNT1"), Some(Value::U16(3)));
}

#[test]
fn event_mode_plans_a_membership_then_the_refresh() {
    let mut d = driver(&[("events", "true"), ("event_refresh", "250ms")]);
    assert!(d.event_mode());
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    d.plan_refresh(&mut plan);
    assert_eq!(plan.len(), 1);
    assert_eq!(
        d.collect_membership().map(|m| (m.unit, m.answer_within)),
        Some((unit(), Duration::from_millis(250)))
    );
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]));
    // Start-up enables the input events.
    let mut setup = Vec::new();
    d.plan_startup(&mut setup);
    let mut sim = MiniModSim::new(UNIT);
    for tx in &setup {
        exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
    }
    assert_eq!(sim.get("XEVMASK"), Ok(Value::U16(7)));
    assert_eq!(sim.get("EVFB1"), Ok(Value::Bool(true)));
    assert_eq!(sim.get("EVFB2"), Ok(Value::Bool(true)));
    // Events arrive under the Collect round's tag.
    let event = Reply::Modbus(Response::Collect {
        slave: UNIT,
        seq: 1,
        kind: 2,
        data: 0x0205,
    });
    d.on_reply(collect::EVENT_TAG, &event).unwrap();
    assert_eq!(value(&d, "X1"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "X2"), Some(Value::Bool(false)));
    assert_eq!(value(&d, "X3"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "X10"), Some(Value::Bool(true)));
    assert_eq!(value(&d, "FB2"), Some(Value::Bool(true)));
    let outputs = Reply::Modbus(Response::Collect {
        slave: UNIT,
        seq: 2,
        kind: 1,
        data: 0b0010,
    });
    d.on_reply(collect::EVENT_TAG, &outputs).unwrap();
    assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
    let bad = Reply::Modbus(Response::Collect {
        slave: UNIT,
        seq: 3,
        kind: 9,
        data: 0,
    });
    assert!(d.on_reply(collect::EVENT_TAG, &bad).is_err());
    // A write is still planned from the program's desire: output events never feed it.
    let mut w = Vec::new();
    d.plan_write(&desired(&[("Y2", true)]), false, &mut w);
    assert_eq!(w.len(), 1);
}
