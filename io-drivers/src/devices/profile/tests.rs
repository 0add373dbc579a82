//! The profile driver and simulator: word orders, reads coalesced within the device's limits
//! (byte-exact requests), poll groups at their own period, writes on change and cyclic, bit
//! fields, and a drive whose output follows its setpoint with a lag, on a virtual line.

use std::sync::Arc;
use std::time::Duration;

use super::plan::reads;
use super::*;
use crate::devices::{ModelSpec, Protocol};
use crate::driver::{Driver, Outgoing, Reply};
use crate::line::bus::{BusOwner, Discipline, Module, OutputFrame};
use crate::line::LineSettings;
use crate::modbus::master::encode_request;
use crate::modbus::{Request, Response};
use crate::point::Value;
use crate::sim::line::{SimWorld, VirtualPort};
use crate::time::{Clock, LineInstant, ScanInstant, VirtualClock};

fn point(name: &str, table: Table, address: u16, data: DataType) -> ProfilePoint {
    ProfilePoint {
        name: name.into(),
        table,
        address,
        data,
        order: WordOrder::Abcd,
        scaling: None,
        unit: None,
        range: None,
        access: PointAccess::Read,
        manual: None,
        group: 0,
        write: WriteMode::OnChange,
        bits: Vec::new(),
        initial: 0.0,
    }
}

fn profile(points: Vec<ProfilePoint>) -> Profile {
    Profile {
        model: "test-device".into(),
        summary: "a test".into(),
        source: "this file".into(),
        addresses: 1..=247,
        max_baud: 115_200,
        points,
        groups: vec![
            PollGroup {
                name: "fast".into(),
                period: None,
            },
            PollGroup {
                name: "slow".into(),
                period: Some(Duration::from_secs(1)),
            },
        ],
        limits: RequestLimits::default(),
        timing: DeviceTiming {
            reply_timeout: None,
            frame_gap: None,
            reply_delay: Duration::from_millis(5),
        },
        behaviours: Vec::new(),
    }
}

/// A drive: command word (write), setpoint 0.01 Hz (read/write, cyclic), status with bit
/// fields, output frequency following the setpoint, an i32 CDAB counter in the slow group.
fn drive() -> &'static ModelSpec {
    let mut command = point("command", Table::Holding, 0x2000, DataType::U16);
    command.access = PointAccess::Write;
    let mut setpoint = point("setpoint", Table::Holding, 0x2001, DataType::U16);
    setpoint.access = PointAccess::ReadWrite;
    setpoint.scaling = Some(Scaling {
        scale: 0.01,
        offset: 0.0,
    });
    setpoint.write = WriteMode::Cyclic;
    let mut status = point("status", Table::Holding, 0x2101, DataType::U16);
    status.bits = vec![
        BitField {
            name: "running".into(),
            bit: 0,
            width: 1,
            manual: None,
        },
        BitField {
            name: "mode".into(),
            bit: 3,
            width: 2,
            manual: None,
        },
    ];
    status.initial = f64::from(0b1_1001u16);
    let mut output = point("output", Table::Holding, 0x2103, DataType::U16);
    output.scaling = setpoint.scaling;
    let mut hours = point("hours", Table::Holding, 0x2200, DataType::I32);
    hours.order = WordOrder::Cdab;
    hours.group = 1;
    hours.initial = -70000.0;
    let mut p = profile(vec![command, setpoint, status, output, hours]);
    p.behaviours = vec![Behaviour::Follow {
        point: 3,
        source: 1,
        time_constant: Duration::from_secs(1),
    }];
    p.limits.max_registers = 8;
    p.timing.frame_gap = Some(Duration::from_millis(10));
    model_of(p)
}

#[test]
fn word_orders_place_the_bytes_as_named() {
    let bits = 230.0f32.to_bits(); // 0x4366_0000
    assert_eq!(WordOrder::Abcd.split(bits), [0x4366, 0x0000]);
    assert_eq!(WordOrder::Cdab.split(bits), [0x0000, 0x4366]);
    assert_eq!(WordOrder::Badc.split(0x1122_3344), [0x2211, 0x4433]);
    assert_eq!(WordOrder::Dcba.split(0x1122_3344), [0x4433, 0x2211]);
    for order in WordOrder::ALL {
        let [a, b] = order.split(0x1122_3344);
        assert_eq!(order.join(a, b), 0x1122_3344, "{order:?}");
    }
    let mut p = point("x", Table::Holding, 0, DataType::I16);
    p.scaling = Some(Scaling {
        scale: 0.1,
        offset: -40.0,
    });
    assert_eq!(value::encode(&p, -45.0), vec![(-50i16) as u16]);
    let (raw, _) = value::raw(&p, &[(-50i16) as u16]).unwrap();
    assert_eq!(
        value::to_value(&p, value::engineering(&p, raw)),
        Value::F32(-45.0)
    );
    // Saturated at the raw type's range, never wrapped.
    let u = point("u", Table::Holding, 0, DataType::U16);
    assert_eq!(value::encode(&u, 70000.0), vec![u16::MAX]);
    assert_eq!(value::encode(&u, -3.0), vec![0]);
}

#[test]
fn reads_are_coalesced_within_the_devices_limits() {
    let meter = |gaps: bool, max: u16| {
        let mut p = profile(vec![
            point("v", Table::Input, 0, DataType::F32),
            point("a", Table::Input, 6, DataType::F32),
            point("w", Table::Input, 8, DataType::F32),
            point("hz", Table::Input, 70, DataType::F32),
            point("on", Table::Coil, 3, DataType::Bool),
            point("di", Table::Discrete, 3, DataType::Bool),
        ]);
        p.limits.read_gaps = gaps;
        p.limits.max_registers = max;
        p
    };
    let spans = |p: &Profile| -> Vec<(Table, u16, u16)> {
        reads(p, |_| true)
            .iter()
            .map(|r| (r.table, r.addr, r.count))
            .collect()
    };
    // No gaps: 0..2, then 6..10 (contiguous), then 70..72.
    assert_eq!(
        spans(&meter(false, 125)),
        [
            (Table::Coil, 3, 1),
            (Table::Discrete, 3, 1),
            (Table::Input, 0, 2),
            (Table::Input, 6, 4),
            (Table::Input, 70, 2)
        ]
    );
    // Gaps allowed: one read while it stays within the maximum.
    assert_eq!(spans(&meter(true, 125))[2..], [(Table::Input, 0, 72)]);
    assert_eq!(
        spans(&meter(true, 60))[2..],
        [(Table::Input, 0, 10), (Table::Input, 70, 2)]
    );
    // Byte-exact: FC 04 from 0, 10 registers, unit 3.
    let first = &reads(&meter(true, 60), |_| true)[2];
    let mut frame = Vec::new();
    encode_request(3, &first.request(), &mut frame).unwrap();
    assert_eq!(frame, [0x03, 0x04, 0x00, 0x00, 0x00, 0x0A, 0x71, 0xEF]);
}

#[test]
fn a_slow_group_is_read_at_its_period_and_again_after_a_failure() {
    let model = drive();
    let config = model
        .device_config("vfd", 2, Protocol::Modbus, &[])
        .unwrap();
    let mut d = (model.driver)(&config);
    // Plans the cycle at `t`; answers its reads unless `answer` is false.
    let cycle = |d: &mut Box<dyn Driver>, t: u64, answer: bool| {
        d.advance_to(LineInstant::after_origin(Duration::from_millis(t)));
        let mut out = Vec::new();
        d.plan_read(&mut out);
        if answer {
            for tx in &out {
                let Outgoing::Modbus {
                    request: Request::ReadHoldingRegisters { count, .. },
                    ..
                } = tx.frame
                else {
                    panic!("{tx:?}");
                };
                let reply = Reply::Modbus(Response::ReadHoldingRegisters(vec![0; count.into()]));
                d.on_reply(tx.tag, &reply).unwrap();
            }
        }
        out.len()
    };
    // Fast: the setpoint, the status, the output (apart: three reads); slow: the hours.
    assert_eq!(
        cycle(&mut d, 0, true),
        4,
        "the first cycle reads every group"
    );
    assert_eq!(cycle(&mut d, 100, true), 3);
    assert_eq!(cycle(&mut d, 900, true), 3);
    assert_eq!(cycle(&mut d, 1000, false), 4, "1 s after the first");
    // The last cycle's reads got no answer: the slow group is asked for again at once.
    assert_eq!(cycle(&mut d, 1100, true), 4);
    assert_eq!(cycle(&mut d, 1200, true), 3);
}

#[test]
fn a_profiled_drive_on_a_virtual_line() {
    let model = drive();
    let settings = LineSettings::DEFAULT;
    let mut world = SimWorld::new(vec![settings]);
    let sim = world.add_device(0, "vfd", model.simulate(2));
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    let port = VirtualPort::new(world.clone(), 0, settings, clock.clone());
    let config = model
        .device_config("vfd", 2, Protocol::Modbus, &[])
        .unwrap();
    let module = Module::new("vfd", (model.driver)(&config));
    let mut owner = BusOwner::new("line", Box::new(port), Discipline::default(), vec![module]);
    owner.startup().unwrap();
    let index = |name: &str| model.point_index(name).unwrap();
    let read = |owner: &mut BusOwner, t: u64| {
        clock.advance_to(ScanInstant::after_origin(Duration::from_millis(t)));
        owner.sync(clock.line_now());
        owner.read_inputs().modules[0].values.clone()
    };

    let v = read(&mut owner, 0);
    assert_eq!(v[index("status")], Some(Value::U16(0b1_1001)));
    assert_eq!(v[index("running")], Some(Value::Bool(true)));
    assert_eq!(v[index("mode")], Some(Value::U16(0b11)));
    assert_eq!(v[index("hours")], Some(Value::I32(-70000)));
    assert_eq!(v[index("output")], Some(Value::F32(0.0)));

    // The program sets 50 Hz and a run command.
    let mut desired = vec![None; model.points.len()];
    desired[index("command")] = Some(Value::U16(0x12));
    desired[index("setpoint")] = Some(Value::F32(50.0));
    let frame = OutputFrame {
        modules: vec![desired],
    };
    let first = owner.write_outputs(&frame);
    assert_eq!(first.transactions, 2);
    {
        let w = world.lock().unwrap();
        assert_eq!(w.get(sim, "setpoint").unwrap(), Value::F32(50.0));
        assert_eq!(w.get(sim, "command").unwrap(), Value::U16(0x12));
    }
    // Unchanged: the command is not written again, the cyclic setpoint is.
    let again = owner.write_outputs(&frame);
    assert_eq!(again.transactions, 1);

    // The output follows with a 1 s lag, from the write (a few frames after 0 s) to the read
    // (a few frames after 1 s, 3 s): 50 Hz × (1 − e^−t) for t a little under 1 s, 3 s.
    let hz = |v: &[Option<Value>]| match v[index("output")] {
        Some(Value::F32(f)) => f,
        other => panic!("{other:?}"),
    };
    let after_1s = hz(&read(&mut owner, 1000));
    assert!((29.6..=31.7).contains(&after_1s), "{after_1s}");
    let after_3s = hz(&read(&mut owner, 3000));
    assert!((47.2..=47.6).contains(&after_3s), "{after_3s}");
    // The sim console sets a point in engineering units.
    world
        .lock()
        .unwrap()
        .set(sim, "hours", Value::I32(123_456))
        .unwrap();
    assert_eq!(
        read(&mut owner, 4100)[index("hours")],
        Some(Value::I32(123_456))
    );
}

#[test]
fn the_simulator_refuses_what_the_device_would() {
    let model = drive();
    let mut sim = model.simulate(2);
    // FC 03 of 0x2002, which no point names: exception 02.
    let mut frame = Vec::new();
    let req = crate::modbus::Request::ReadHoldingRegisters {
        addr: 0x2002,
        count: 1,
    };
    encode_request(2, &req, &mut frame).unwrap();
    let reply = sim.on_frame(&frame, LineInstant::ZERO).unwrap();
    assert_eq!(reply.bytes[..3], [0x02, 0x83, 0x02]);
    // FC 06 to the read-only status: exception 02.
    frame.clear();
    let req = crate::modbus::Request::WriteSingleRegister {
        addr: 0x2101,
        value: 1,
    };
    encode_request(2, &req, &mut frame).unwrap();
    let reply = sim.on_frame(&frame, LineInstant::ZERO).unwrap();
    assert_eq!(reply.bytes[..3], [0x02, 0x86, 0x02]);
    // Another unit: silence.
    frame.clear();
    encode_request(3, &req, &mut frame).unwrap();
    assert!(sim.on_frame(&frame, LineInstant::ZERO).is_none());
    assert!(matches!(
        sim.get("nothing"),
        Err(crate::sim::SimError::UnknownPoint { .. })
    ));
}

#[test]
fn a_profile_is_interned_by_content() {
    let a = drive();
    let b = drive();
    assert!(std::ptr::eq(a, b), "the same content, the same model");
    assert_eq!(a.points.len(), 7, "5 points and 2 bit fields");
    assert_eq!(a.name, "test-device");
    let mut other = a.profile.unwrap().clone();
    other.model = "another".into();
    assert!(!std::ptr::eq(model_of(other), a));
}

/// How long one full read of a slow device takes on the line, and whether it was good, with
/// the profile's `reply_timeout` and `frame_gap` as given.
fn slow_device_read(
    reply_timeout: Option<Duration>,
    frame_gap: Option<Duration>,
) -> (Duration, crate::point::Quality) {
    let mut p = profile(vec![
        point("a", Table::Holding, 0, DataType::U16),
        point("b", Table::Holding, 10, DataType::U16),
    ]);
    // It answers after 150 ms: past the line's 100 ms response timeout.
    p.timing.reply_delay = Duration::from_millis(150);
    p.timing.reply_timeout = reply_timeout;
    p.timing.frame_gap = frame_gap;
    let model = model_of(p);
    let settings = LineSettings::DEFAULT;
    let mut world = SimWorld::new(vec![settings]);
    world.add_device(0, "slow", model.simulate(1));
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    let port = VirtualPort::new(world.clone(), 0, settings, clock.clone());
    let config = model
        .device_config("slow", 1, Protocol::Modbus, &[])
        .unwrap();
    let module = Module::new("slow", (model.driver)(&config));
    let mut owner = BusOwner::new("line", Box::new(port), Discipline::default(), vec![module]);
    drop(owner.startup());
    // A second cycle, after the first: the gap counts between frames of a running line.
    owner.read_inputs();
    clock.advance_to(ScanInstant::after_origin(Duration::from_secs(5)));
    owner.sync(clock.line_now());
    let started = owner.now();
    let frame = owner.read_inputs();
    (frame.finished - started, frame.modules[0].quality)
}

#[test]
fn a_devices_reply_timeout_and_frame_gap_are_the_bus_owners() {
    use crate::point::Quality;
    let (_, quality) = slow_device_read(None, None);
    assert_ne!(
        quality,
        Quality::Good,
        "the line's 100 ms is too short for it"
    );
    let (plain, quality) = slow_device_read(Some(Duration::from_millis(300)), None);
    assert_eq!(quality, Quality::Good, "its own 300 ms is long enough");
    let (gapped, quality) = slow_device_read(
        Some(Duration::from_millis(300)),
        Some(Duration::from_millis(50)),
    );
    assert_eq!(quality, Quality::Good);
    // Two reads, each after 50 ms of silence instead of t3.5 (2 ms at 19200 Bd).
    let t3_5 = LineSettings::DEFAULT.t3_5();
    let extra = gapped - plain;
    assert!(
        extra >= (Duration::from_millis(50) - t3_5)
            && extra <= 2 * (Duration::from_millis(50) - t3_5),
        "{extra:?} more with the gap"
    );
}
