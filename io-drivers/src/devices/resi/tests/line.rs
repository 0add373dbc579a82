//! The drivers and simulators of a 16DI8RO, a 32DI and an 8CO on one virtual RS-485 line with a
//! bus owner, on a virtual clock: the stairway light the driver pushes down into the 16DI8RO
//! runs for its 30 s with nobody on the line.

use std::sync::Arc;
use std::time::Duration;

use super::models::{m16di8ro, m32di, m8co};
use crate::devices::{DeviceConfig, ModelSpec, Protocol};
use crate::line::bus::{BusOwner, Discipline, Module, OutputFrame};
use crate::line::LineSettings;
use crate::point::Value;
use crate::sim::line::{SharedWorld, SimWorld, VirtualPort};
use crate::time::{Clock, ScanInstant, VirtualClock};

fn config(
    spec: &ModelSpec,
    name: &str,
    address: u8,
    protocol: Protocol,
    settings: &[(&str, &str)],
) -> DeviceConfig {
    spec.device_config(name, address, protocol, settings)
        .unwrap()
}

/// A module on the line: model, name, address, settings.
type Placed<'a> = (&'static ModelSpec, &'a str, u8, Vec<(&'a str, &'a str)>);

fn house(protocol: Protocol) -> (BusOwner, SharedWorld, Arc<VirtualClock>) {
    let settings = LineSettings::DEFAULT;
    let mut world = SimWorld::new(vec![settings]);
    let specs: [Placed; 3] = [
        (
            &m16di8ro::SPEC,
            "lights",
            1,
            vec![
                ("CLEAR_ALL_LOGIC_FUNCTIONS", "1"),
                ("PULSE_RO4", "3"),
                ("PULSE_TIME_RO4", "300"),
                ("ENABLE_LOGIC_FUNCTIONS", "1"),
            ],
        ),
        (&m32di::SPEC, "doors", 2, vec![]),
        (&m8co::SPEC, "outside", 3, vec![]),
    ];
    let mut modules = Vec::new();
    for (spec, name, address, s) in &specs {
        world.add_device(0, name, (spec.simulator)(*address));
        modules.push(Module::new(
            *name,
            (spec.driver)(&config(spec, name, *address, protocol, s)),
        ));
    }
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    let port = VirtualPort::new(world.clone(), 0, settings, clock.clone());
    let owner = BusOwner::new("house", Box::new(port), Discipline::default(), modules);
    (owner, world, clock)
}

fn point(owner: &mut BusOwner, clock: &VirtualClock, t: u64, module: usize, name: &str) -> Value {
    clock.advance_to(ScanInstant::after_origin(Duration::from_millis(t)));
    owner.sync(clock.line_now());
    let frame = owner.read_inputs();
    let spec = [&m16di8ro::SPEC, &m32di::SPEC, &m8co::SPEC][module];
    let i = spec.point_index(name).unwrap();
    frame.modules[module].values[i].unwrap()
}

fn press(world: &SharedWorld, name: &str, point: &str, level: bool) {
    let mut w = world.lock().unwrap();
    let i = w.find(name).unwrap();
    w.set(i, point, Value::Bool(level)).unwrap();
}

#[test]
fn stairway_light_pushed_down_into_the_16di8ro() {
    for protocol in [Protocol::Modbus, Protocol::Text] {
        let (mut owner, world, clock) = house(protocol);
        owner.startup().unwrap();
        // The start-up (its logic tables cleared and read back) takes its own time on the line.
        clock.advance_to(owner.now().on_scan_clock());
        let start = clock.now().since_origin().as_millis() as u64;
        let t0 = start + 100;
        assert_eq!(point(&mut owner, &clock, t0, 0, "RO4"), Value::Bool(false));
        press(&world, "lights", "DI2", true);
        assert_eq!(
            point(&mut owner, &clock, t0 + 100, 0, "RO4"),
            Value::Bool(true)
        );
        press(&world, "lights", "DI2", false);
        // Nobody talks for 29 s; the module keeps the light on by itself.
        assert_eq!(
            point(&mut owner, &clock, t0 + 29_000, 0, "RO4"),
            Value::Bool(true),
            "{protocol:?}"
        );
        assert_eq!(
            point(&mut owner, &clock, t0 + 31_000, 0, "RO4"),
            Value::Bool(false),
            "{protocol:?}"
        );
        // The program's outputs on the 8CO and the 32DI's inputs on the same line.
        press(&world, "doors", "DI32", true);
        let mut out = OutputFrame {
            modules: vec![vec![None; 130], vec![None; 130], vec![None; 30]],
        };
        out.modules[2][m8co::SPEC.point_index("RO2").unwrap()] = Some(Value::Bool(true));
        let report = owner.write_outputs(&out);
        assert_eq!(
            (report.transactions, report.failures),
            (1, 0),
            "{protocol:?}"
        );
        assert_eq!(
            point(&mut owner, &clock, t0 + 32_000, 2, "RO2"),
            Value::Bool(true)
        );
        assert_eq!(
            point(&mut owner, &clock, t0 + 32_100, 1, "DI32"),
            Value::Bool(true)
        );
    }
}
