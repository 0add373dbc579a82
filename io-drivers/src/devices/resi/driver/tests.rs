//! The driver against the simulator, over both protocols, as a bus owner would run it.

use super::*;
use crate::devices::resi::models::{m16di8ro, m1ro, m2rtd, m32di, m8co};
use crate::devices::resi::sim::ResiSim;
use crate::modbus::crc::append_crc;
use crate::modbus::master::{encode_request, Progress, ReplyAssembler};
use crate::modbus::ExceptionCode;
use crate::sim::SimDevice;
use crate::time::LineInstant;

const ADDR: u8 = 5;

fn driver(model: &'static Model, protocol: Protocol, settings: &[(&str, &str)]) -> ResiDriver {
    let parsed: Vec<Setting> = settings
        .iter()
        .map(|(k, v)| settings::parse(model, k, v).unwrap())
        .collect();
    ResiDriver::new(model, protocol, ADDR, &parsed)
}

fn wire(tx: &Transaction) -> Vec<u8> {
    match &tx.frame {
        Outgoing::Modbus { unit, request } => {
            let mut out = Vec::new();
            encode_request(unit.get(), request, &mut out).unwrap();
            out
        }
        Outgoing::Text { line, .. } => line.clone(),
        Outgoing::NoReply { bytes } => bytes.clone(),
    }
}

fn frame(bytes: &[u8]) -> Vec<u8> {
    let mut f = bytes.to_vec();
    append_crc(&mut f);
    f
}

/// Runs a transaction against the simulator at `t` ms, as a bus owner would.
fn exchange(
    d: &mut ResiDriver,
    s: &mut ResiSim,
    tx: &Transaction,
    t: u64,
) -> Result<(), DecodeError> {
    let at = LineInstant::after_origin(Duration::from_millis(t));
    let reply = s.on_frame(&wire(tx), at).expect("an answer");
    let reply = match &tx.frame {
        Outgoing::Modbus { unit, request } => {
            let mut asm = ReplyAssembler::new(unit.get(), request);
            let Progress::Complete { response, extra: 0 } = asm.push(&reply.bytes) else {
                panic!("reply not verified: {:02X?}", reply.bytes)
            };
            Reply::Modbus(response)
        }
        Outgoing::Text { terminator, .. } => {
            let end = reply.bytes.iter().position(|b| b == terminator).unwrap();
            Reply::Text(reply.bytes[..end].to_vec())
        }
        Outgoing::NoReply { .. } => panic!("the RESI driver always waits for an answer"),
    };
    d.on_reply(tx.tag, &reply)
}

fn run(d: &mut ResiDriver, s: &mut ResiSim, plan: &[Transaction], t: u64) {
    for tx in plan {
        exchange(d, s, tx, t).unwrap();
    }
}

fn startup(d: &mut ResiDriver, s: &mut ResiSim) -> Vec<Transaction> {
    let mut plan = Vec::new();
    d.plan_startup(&mut plan);
    run(d, s, &plan, 0);
    plan
}

fn read(d: &mut ResiDriver, s: &mut ResiSim, t: u64) -> Vec<Transaction> {
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    run(d, s, &plan, t);
    plan
}

fn write(
    d: &mut ResiDriver,
    s: &mut ResiSim,
    outputs: &[(&str, Value)],
    refresh: bool,
    t: u64,
) -> Vec<Transaction> {
    let mut want = vec![None; d.model.points.len()];
    for (name, v) in outputs {
        want[d.model.point_index(name).unwrap()] = Some(*v);
    }
    let mut plan = Vec::new();
    d.plan_write(&want, refresh, &mut plan);
    run(d, s, &plan, t);
    plan
}

fn value(d: &ResiDriver, name: &str) -> Option<Value> {
    d.values()[d.model.point_index(name).unwrap()]
}

fn text(plan: &[Transaction]) -> Vec<String> {
    plan.iter()
        .map(|tx| String::from_utf8(wire(tx)).unwrap())
        .collect()
}

const ON: Value = Value::Bool(true);
const OFF: Value = Value::Bool(false);

#[test]
fn modbus_reads_inputs_and_relays_in_one_fc1() {
    let mut d = driver(&m16di8ro::MODEL, Protocol::Modbus, &[]);
    let mut s = ResiSim::new(&m16di8ro::MODEL, ADDR);
    s.set("DI16", ON).unwrap();
    s.set("RO3", ON).unwrap();
    assert_eq!(value(&d, "DI16"), None);
    let plan = read(&mut d, &mut s, 10);
    assert_eq!(plan.len(), 1);
    assert_eq!(wire(&plan[0]), frame(&[0x05, 0x01, 0x00, 0x00, 0x00, 0x18]));
    assert_eq!(value(&d, "DI16"), Some(ON));
    assert_eq!(value(&d, "DI1"), Some(OFF));
    assert_eq!(value(&d, "RO3"), Some(ON));
    assert_eq!(value(&d, "RISE_DI1"), None, "not polled");
}

#[test]
fn ascii_reads_with_word_commands() {
    let mut d = driver(
        &m16di8ro::MODEL,
        Protocol::Text,
        &[("poll", "DI*, RO*, RISE_DI16, COUNTER_RO3, DIS")],
    );
    let mut s = ResiSim::new(&m16di8ro::MODEL, ADDR);
    s.set("DI16", ON).unwrap();
    s.set("RO3", ON).unwrap();
    let plan = read(&mut d, &mut s, 10);
    assert_eq!(
        text(&plan),
        ["#5,GDIS\r", "#5,GROS\r", "#5,RDI16\r", "#5,GCRO3\r"]
    );
    assert_eq!(value(&d, "DI16"), Some(ON));
    assert_eq!(value(&d, "DIS"), Some(Value::U16(0x8000)));
    assert_eq!(value(&d, "RO3"), Some(ON));
    assert_eq!(value(&d, "RISE_DI16"), Some(Value::U16(1)));
    assert_eq!(value(&d, "COUNTER_RO3"), Some(Value::I32(1)));
}

#[test]
fn modbus_startup_writes_the_logic_tables_and_reads_them_back() {
    let settings = [
        ("CLEAR_ALL_LOGIC_FUNCTIONS", "1"),
        ("ENABLE_LOGIC_FUNCTIONS", "1"),
        ("SWITCH ON RO1", "0x8000"),
        ("SWITCH_ON_RO2", "0x8000"),
        ("SWITCH_OFF_RO1", "0x4000"),
        ("PULSE_RO4", "3"),
        ("PULSE_TIME_RO4", "300"),
    ];
    let mut d = driver(&m16di8ro::MODEL, Protocol::Modbus, &settings);
    let mut s = ResiSim::new(&m16di8ro::MODEL, ADDR);
    let plan = startup(&mut d, &mut s);
    let frames: Vec<Vec<u8>> = plan.iter().map(wire).collect();
    assert_eq!(
        frames.len(),
        1 + 2 * 3 + 2 * 5,
        "CLEAR ALL, the disarm (ENABLE, masks, PULSE TIMEs), then five runs, each read back"
    );
    assert_eq!(frames[0], frame(&[0x05, 0x06, 0x52, 0x09, 0x00, 0x01]));
    // From here on as before the disarm (frames 1..=6) came in.
    let frames = &frames[6..];
    let plan = &plan[6..];
    assert_eq!(
        frames[1],
        frame(&[0x05, 0x10, 0x4E, 0x30, 0x00, 0x02, 0x04, 0x80, 0x00, 0x80, 0x00])
    );
    assert_eq!(frames[2], frame(&[0x05, 0x03, 0x4E, 0x30, 0x00, 0x02]));
    assert_eq!(
        frames[5],
        frame(&[0x05, 0x10, 0x4E, 0x43, 0x00, 0x01, 0x02, 0x00, 0x03])
    );
    assert_eq!(
        frames[7],
        frame(&[0x05, 0x10, 0x4E, 0x66, 0x00, 0x02, 0x04, 0x00, 0x00, 0x01, 0x2C]),
        "PULSE TIME RO4, high word first"
    );
    assert_eq!(frames[8], frame(&[0x05, 0x03, 0x4E, 0x66, 0x00, 0x02]));
    assert_eq!(
        frames[9],
        frame(&[0x05, 0x10, 0x52, 0x08, 0x00, 0x01, 0x02, 0x00, 0x01])
    );
    assert_eq!(s.get("ENABLE_LOGIC_FUNCTIONS"), Ok(Value::U16(1)));
    assert_eq!(s.get("PULSE_TIME_RO4"), Ok(Value::I32(300)));
    // A module that holds something else stops the start.
    s.set("PULSE_RO4", Value::U16(7)).unwrap();
    assert_eq!(
        exchange(&mut d, &mut s, &plan[6], 0),
        Err(DecodeError::Mismatch {
            register: "PULSE_RO4",
            expected: 3,
            found: 7
        })
    );
    // The logic the driver configured runs: DI16 switches RO1 and RO2 on.
    s.set("DI16", ON).unwrap();
    read(&mut d, &mut s, 20);
    assert_eq!((value(&d, "RO1"), value(&d, "RO2")), (Some(ON), Some(ON)));
}

#[test]
fn ascii_startup_and_mismatch() {
    let settings = [
        ("CLEAR_ALL_LOGIC_FUNCTIONS", "1"),
        ("TOGGLE_RO4", "3"),
        ("ENABLE_LOGIC_FUNCTIONS", "1"),
    ];
    let mut d = driver(&m16di8ro::MODEL, Protocol::Text, &settings);
    let mut s = ResiSim::new(&m16di8ro::MODEL, ADDR);
    let plan = startup(&mut d, &mut s);
    let sent = text(&plan);
    // The disarm: RESET SPECIAL MODE, GSMODE and the 40 mask gets, 8 × SPTIMEx:0 and GPTIMEx.
    assert_eq!(
        sent[..4],
        [
            "#5,RSTSPCMODE\r",
            "#5,RSTSPCMODE\r",
            "#5,GSMODE\r",
            "#5,GSWITCH1\r"
        ]
    );
    assert_eq!(
        sent[42..45],
        ["#5,GPULSE8\r", "#5,SPTIME1:0\r", "#5,GPTIME1\r"]
    );
    assert_eq!(
        sent[59..],
        [
            "#5,STOGGLE4:3\r",
            "#5,GTOGGLE4\r",
            "#5,SSMODE:1\r",
            "#5,GSMODE\r"
        ]
    );
    s.set("ENABLE_LOGIC_FUNCTIONS", Value::U16(0)).unwrap();
    assert_eq!(
        exchange(&mut d, &mut s, &plan[62], 0),
        Err(DecodeError::Mismatch {
            register: "ENABLE_LOGIC_FUNCTIONS",
            expected: 1,
            found: 0
        })
    );
}

#[test]
fn modbus_writes_owned_relays_on_change_and_on_refresh() {
    let mut d = driver(&m16di8ro::MODEL, Protocol::Modbus, &[]);
    let mut s = ResiSim::new(&m16di8ro::MODEL, ADDR);
    let plan = write(&mut d, &mut s, &[("RO3", ON)], false, 0);
    assert_eq!(
        plan.iter().map(wire).collect::<Vec<_>>(),
        [frame(&[0x05, 0x05, 0x00, 0x12, 0xFF, 0x00])]
    );
    assert!(write(&mut d, &mut s, &[("RO3", ON)], false, 1).is_empty());
    let all: Vec<(&str, Value)> = ["RO1", "RO2", "RO3", "RO4", "RO5", "RO6", "RO7", "RO8"]
        .iter()
        .map(|n| (*n, if *n == "RO8" { ON } else { OFF }))
        .collect();
    let plan = write(&mut d, &mut s, &all, true, 2);
    assert_eq!(
        plan.iter().map(wire).collect::<Vec<_>>(),
        [frame(&[0x05, 0x0F, 0x00, 0x10, 0x00, 0x08, 0x01, 0x80])]
    );
    assert_eq!(s.get("ROS"), Ok(Value::U16(0x80)));
    assert_eq!(value(&d, "RO8"), Some(ON));
    // Two owned relays apart: two FC 5.
    let plan = write(&mut d, &mut s, &[("RO1", ON), ("RO3", ON)], true, 3);
    assert_eq!(plan.len(), 2);
}

#[test]
fn ascii_writes_sros_or_srox() {
    let mut d = driver(&m16di8ro::MODEL, Protocol::Text, &[]);
    let mut s = ResiSim::new(&m16di8ro::MODEL, ADDR);
    let plan = write(&mut d, &mut s, &[("RO3", ON), ("RO4", OFF)], false, 0);
    assert_eq!(text(&plan), ["#5,SRO3:1\r", "#5,SRO4:0\r"]);
    let all: Vec<(&str, Value)> = ["RO1", "RO2", "RO3", "RO4", "RO5", "RO6", "RO7", "RO8"]
        .iter()
        .map(|n| (*n, if *n == "RO1" || *n == "RO8" { ON } else { OFF }))
        .collect();
    let plan = write(&mut d, &mut s, &all, true, 1);
    assert_eq!(text(&plan), ["#5,SROS:129\r"]);
    assert_eq!(s.get("ROS"), Ok(Value::U16(0x81)));
}

#[test]
fn eight_co_pulses_are_written_once() {
    let mut d = driver(&m8co::MODEL, Protocol::Modbus, &[]);
    let mut s = ResiSim::new(&m8co::MODEL, ADDR);
    let plan = write(&mut d, &mut s, &[("PULSE_RO2", Value::U16(20))], false, 0);
    assert_eq!(
        plan.iter().map(wire).collect::<Vec<_>>(),
        [frame(&[0x05, 0x06, 0x00, 0xC9, 0x00, 0x14])]
    );
    assert!(
        write(&mut d, &mut s, &[("PULSE_RO2", Value::U16(20))], true, 1000).is_empty(),
        "a refresh would restart the pulse"
    );
    read(&mut d, &mut s, 1000);
    assert_eq!(value(&d, "RO2"), Some(ON));
    read(&mut d, &mut s, 2000);
    assert_eq!(value(&d, "RO2"), Some(OFF));
    let mut a = driver(&m8co::MODEL, Protocol::Text, &[]);
    let plan = write(
        &mut a,
        &mut s,
        &[("PULSE_RO2", Value::U16(20))],
        false,
        3000,
    );
    assert_eq!(text(&plan), ["#5,PRO2:20\r"]);
}

#[test]
fn one_ro_watchdog_keeps_the_relay_only_while_the_host_writes() {
    for protocol in [Protocol::Modbus, Protocol::Text] {
        let mut d = driver(&m1ro::MODEL, protocol, &[("SOFFDLY", "5000")]);
        let mut s = ResiSim::new(&m1ro::MODEL, ADDR);
        let plan = write(&mut d, &mut s, &[("DO1", ON)], false, 0);
        if protocol == Protocol::Text {
            assert_eq!(text(&plan), ["#5,SDO1:0\r", "#5,SOFFDLY:5000\r"]);
        } else {
            assert_eq!(
                plan.iter().map(wire).collect::<Vec<_>>(),
                [
                    frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x00]),
                    frame(&[0x05, 0x06, 0x00, 0x04, 0x13, 0x88])
                ]
            );
        }
        for t in [1000, 2000, 3000, 4000] {
            assert_eq!(write(&mut d, &mut s, &[("DO1", ON)], false, t).len(), 1);
        }
        read(&mut d, &mut s, 8999);
        assert_eq!(value(&d, "TDO1"), Some(ON), "{protocol:?}");
        assert_eq!(value(&d, "DO1"), Some(OFF));
        // The host stops: 5 s after its last write the relay drops.
        read(&mut d, &mut s, 9000);
        assert_eq!(value(&d, "TDO1"), Some(OFF), "{protocol:?}");
        write(&mut d, &mut s, &[("DO1", ON)], false, 10_000);
        let plan = write(&mut d, &mut s, &[("DO1", OFF)], false, 11_000);
        assert_eq!(plan.len(), 2, "end the off-delay, clear DO1");
        read(&mut d, &mut s, 11_001);
        assert_eq!(value(&d, "TDO1"), Some(OFF));
    }
}

#[test]
fn exceptions_and_unexpected_answers() {
    let mut d = driver(&m16di8ro::MODEL, Protocol::Modbus, &[]);
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    let tag = plan[0].tag;
    let exception = Reply::Modbus(Response::Exception {
        function: 1,
        code: ExceptionCode::IllegalDataAddress,
    });
    assert_eq!(
        d.on_reply(tag, &exception),
        Err(DecodeError::Exception(ExceptionCode::IllegalDataAddress))
    );
    let short = Reply::Modbus(Response::ReadCoils(vec![true; 3]));
    assert_eq!(
        d.on_reply(tag, &short),
        Err(DecodeError::Unexpected { tag })
    );
    assert_eq!(
        d.on_reply(0xFFFF_FFFF, &short),
        Err(DecodeError::Unexpected { tag: 0xFFFF_FFFF })
    );
    let mut a = driver(&m16di8ro::MODEL, Protocol::Text, &[]);
    let mut plan = Vec::new();
    a.plan_read(&mut plan);
    let tag = plan[0].tag;
    for bad in [
        &b"#5,GROS:1,0x1"[..],
        b"#6,GDIS:1,0x1",
        b"#5,GDIS",
        b"#5,GDIS:x",
        b"\xFF",
    ] {
        assert_eq!(
            a.on_reply(tag, &Reply::Text(bad.to_vec())),
            Err(DecodeError::Unexpected { tag }),
            "{bad:?}"
        );
    }
    assert_eq!(
        a.on_reply(tag, &Reply::Text(b"#5,GDIS:3,0x3".to_vec())),
        Ok(())
    );
    assert_eq!(value(&a, "DI2"), Some(ON));
}

#[test]
fn analog_and_wide_inputs() {
    let mut s = ResiSim::new(&m2rtd::MODEL, ADDR);
    s.command(&["temp", "2", "-12.5"]).unwrap();
    for protocol in [Protocol::Modbus, Protocol::Text] {
        let mut d = driver(&m2rtd::MODEL, protocol, &[("CH1_ZERO_OFFSET", "0.25")]);
        startup(&mut d, &mut s);
        read(&mut d, &mut s, 0);
        assert_eq!(
            value(&d, "CH2_VALID_TEMP"),
            Some(Value::F32(-12.5)),
            "{protocol:?}"
        );
        assert_eq!(value(&d, "CH1_STATUS"), Some(Value::I32(1)));
    }
    let mut d = driver(&m32di::MODEL, Protocol::Text, &[("poll", "DI*, DIS17_32")]);
    let mut s = ResiSim::new(&m32di::MODEL, ADDR);
    s.set("DI32", ON).unwrap();
    let plan = read(&mut d, &mut s, 10);
    assert_eq!(text(&plan), ["#5,GDIS\r"]);
    assert_eq!(value(&d, "DI32"), Some(ON));
    assert_eq!(value(&d, "DIS17_32"), Some(Value::U16(0x8000)));
}

#[test]
fn bad_address_plans_nothing_and_budget_delay() {
    let mut d = ResiDriver::new(&m16di8ro::MODEL, Protocol::Modbus, 0, &[]);
    let mut plan = Vec::new();
    d.plan_read(&mut plan);
    d.plan_startup(&mut plan);
    d.plan_write(&[Some(ON); 130], true, &mut plan);
    assert!(plan.is_empty());
    let d = driver(&m16di8ro::MODEL, Protocol::Modbus, &[("reply_delay", "5")]);
    assert_eq!(d.reply_delay(), Duration::from_millis(5));
    assert_eq!(d.address(), ADDR);
}

#[test]
fn no_answer_makes_it_panic() {
    let answers: [&[u8]; 12] = [
        b"",
        b"#",
        b"#5,",
        b"#5,GDIS:",
        b"#5,GDIS:,",
        b"#5,GDIS:99999999999999999999999,0x1",
        b"#5,GDIS:-1,0x1",
        b"#5,GDIS:0xFFFFFFFFFFFFFFFF,1",
        b"#5,OK:1",
        b"#,OK",
        b"#5,GT1:nan",
        b"\xFF\xFE#5,GROS:1,0x1",
    ];
    for protocol in [Protocol::Modbus, Protocol::Text] {
        for model in [&m16di8ro::MODEL, &m2rtd::MODEL, &m1ro::MODEL] {
            let mut d = driver(model, protocol, &[("reply_delay", "1")]);
            let mut plan = Vec::new();
            d.plan_read(&mut plan);
            for tx in &plan {
                for a in answers {
                    let _ = d.on_reply(tx.tag, &Reply::Text(a.to_vec()));
                }
                for resp in [
                    Response::ReadCoils(vec![]),
                    Response::ReadHoldingRegisters(vec![0; 3]),
                    Response::ReadHoldingRegisters(vec![0xFFFF; 125]),
                    Response::WriteSingleCoil {
                        addr: 0,
                        value: true,
                    },
                ] {
                    let _ = d.on_reply(tx.tag, &Reply::Modbus(resp));
                }
            }
        }
    }
}

/// What a run that pushed a TOGGLE on RO4 (DI1, DI2) and a SWITCH on RO1 (DI3) down and was
/// killed leaves in the module's FRAM: its tables, the logic on, RO4 on.
fn crashed_16di8ro() -> ResiSim {
    let mut s = ResiSim::new(&m16di8ro::MODEL, ADDR);
    for (point, v) in [
        ("TOGGLE_RO4", Value::U16(3)),
        ("SWITCH_RO1", Value::U16(4)),
        ("PULSE_RO2", Value::U16(1)),
        ("PULSE_TIME_RO2", Value::I32(50)),
        ("ENABLE_LOGIC_FUNCTIONS", Value::U16(1)),
        ("RO4", ON),
    ] {
        s.set(point, v).unwrap();
    }
    s
}

/// Every mask and PULSE TIME of the 16DI8RO, and ENABLE LOGIC FUNCTIONS, as the simulator holds
/// them.
fn logic_registers(s: &ResiSim) -> Vec<(String, Value)> {
    let mut names = vec!["ENABLE_LOGIC_FUNCTIONS".to_string()];
    for f in [
        "SWITCH",
        "TOGGLE",
        "SWITCH_ON",
        "SWITCH_OFF",
        "PULSE",
        "PULSE_TIME",
    ] {
        for r in 1..=8 {
            names.push(format!("{f}_RO{r}"));
        }
    }
    names
        .into_iter()
        .map(|n| {
            let v = s.get(&n).unwrap();
            (n, v)
        })
        .filter(|(_, v)| v.as_bool())
        .collect()
}

#[test]
fn stale_tables_in_fram_are_cleared_and_read_back_on_both_protocols() {
    for protocol in [Protocol::Modbus, Protocol::Text] {
        let mut s = crashed_16di8ro();
        // FRAM keeps them across a power cycle (L16434).
        s.command(&["power-cycle"]).unwrap();
        assert_eq!(logic_registers(&s).len(), 5, "{protocol:?}: still there");
        let mut d = driver(&m16di8ro::MODEL, protocol, &[]);
        startup(&mut d, &mut s);
        assert_eq!(logic_registers(&s), [], "{protocol:?}: all cleared");
        // DI1 no longer toggles RO4, DI3 no longer switches RO1.
        s.set("DI1", ON).unwrap();
        s.set("DI3", ON).unwrap();
        s.advance_to(LineInstant::after_origin(Duration::from_millis(5_000)));
        assert_eq!(
            s.get("RO4"),
            Ok(ON),
            "{protocol:?}: left as it was, for the program"
        );
        assert_eq!(s.get("RO1"), Ok(OFF), "{protocol:?}");
        // A table that does not read back cleared stops the start, by name.
        let mut plan = Vec::new();
        d.plan_startup(&mut plan);
        s.set("SWITCH_RO1", Value::U16(4)).unwrap();
        let verify = plan.iter().position(|tx| {
            let w = wire(tx);
            match protocol {
                // FC 3 of the 40 masks at 20000.
                Protocol::Modbus => w == frame(&[0x05, 0x03, 0x4E, 0x20, 0x00, 0x28]),
                Protocol::Text => w == b"#5,GSWITCH1\r",
            }
        });
        assert_eq!(
            exchange(&mut d, &mut s, &plan[verify.unwrap()], 6_000),
            Err(DecodeError::Mismatch {
                register: "SWITCH_RO1",
                expected: 0,
                found: 4
            }),
            "{protocol:?}"
        );
    }
}

#[test]
fn a_pushed_toggle_starts_from_its_initial_value_then_is_armed() {
    for protocol in [Protocol::Modbus, Protocol::Text] {
        let mut s = crashed_16di8ro();
        let settings = [
            ("TOGGLE_RO4", "3"),
            ("ENABLE_LOGIC_FUNCTIONS", "1"),
            ("initial_RO4", "0"),
        ];
        let mut d = driver(&m16di8ro::MODEL, protocol, &settings);
        let plan = startup(&mut d, &mut s);
        let sent: Vec<Vec<u8>> = plan.iter().map(wire).collect();
        let at = |w: &[u8]| sent.iter().position(|s| s == w).unwrap();
        let (disarm, relay, arm) = match protocol {
            Protocol::Modbus => (
                at(&frame(&[
                    0x05, 0x10, 0x52, 0x08, 0x00, 0x01, 0x02, 0x00, 0x00,
                ])),
                at(&frame(&[0x05, 0x05, 0x00, 0x13, 0x00, 0x00])),
                at(&frame(&[
                    0x05, 0x10, 0x52, 0x08, 0x00, 0x01, 0x02, 0x00, 0x01,
                ])),
            ),
            Protocol::Text => (
                at(b"#5,RSTSPCMODE\r"),
                at(b"#5,SRO4:0\r"),
                at(b"#5,SSMODE:1\r"),
            ),
        };
        assert!(disarm < relay && relay < arm, "{protocol:?}: {sent:?}");
        assert_eq!(
            s.get("RO4"),
            Ok(OFF),
            "{protocol:?}: the toggle left on by the crashed run starts off, as the central rung"
        );
        assert_eq!(s.get("TOGGLE_RO4"), Ok(Value::U16(3)));
        // Armed: a press of DI2 toggles it on.
        s.set("DI2", ON).unwrap();
        s.advance_to(LineInstant::after_origin(Duration::from_millis(50)));
        assert_eq!(s.get("RO4"), Ok(ON), "{protocol:?}");
    }
}
