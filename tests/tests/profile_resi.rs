//! The design check of device profiles: the RESI-32DI written as a profile
//! (`examples/profiles/resi-32di.yaml`) reads, from the same simulated RESI-32DI, exactly what
//! the built-in driver reads, input pattern after input pattern, through a bus owner on a
//! virtual line.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use softplc_io::devices::{self, ModelSpec, Protocol};
use softplc_io::line::{BusOwner, Discipline, LineSettings, Module};
use softplc_io::point::Value;
use softplc_io::sim::{SharedWorld, SimWorld, VirtualPort};
use softplc_io::time::{Clock, ScanInstant, VirtualClock};

const UNIT: u8 = 2;

fn profile_model() -> &'static ModelSpec {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/profiles/resi-32di.yaml");
    let profile = softplc::project::profile::load(&file).unwrap_or_else(|e| panic!("{e}"));
    devices::profile::model_of(profile)
}

fn owner(
    model: &'static ModelSpec,
    settings: &[(&str, &str)],
    world: &SharedWorld,
    clock: &Arc<VirtualClock>,
) -> BusOwner {
    let config = model
        .device_config("resi", UNIT, Protocol::Modbus, settings)
        .expect("a valid configuration");
    let port = VirtualPort::new(world.clone(), 0, LineSettings::DEFAULT, clock.clone());
    let module = Module::new("resi", (model.driver)(&config));
    let mut owner = BusOwner::new("line", Box::new(port), Discipline::default(), vec![module]);
    owner.startup().expect("the module starts");
    owner
}

/// Every point the built-in driver read, by name, with its value.
fn read(owner: &mut BusOwner, model: &ModelSpec, clock: &VirtualClock) -> Vec<(String, Value)> {
    owner.sync(clock.line_now());
    let frame = owner.read_inputs();
    model
        .points
        .iter()
        .zip(&frame.modules[0].values)
        .filter_map(|(p, v)| Some((p.name.to_string(), (*v)?)))
        .collect()
}

#[test]
fn the_resi_32di_as_a_profile_reads_what_the_builtin_driver_reads() {
    let builtin = devices::model("resi-32di").expect("in the catalog");
    let profiled = profile_model();
    let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
    let sim = world.add_device(0, "resi", builtin.simulate(UNIT));
    let world = world.shared();
    let clock = Arc::new(VirtualClock::new());
    // The built-in driver reads DI1..DI32 by default; asked for every input point of the
    // profile too.
    let poll = [("poll", "DI*, DIS1_16, DIS17_32, DIP, DIP*")];
    let mut a = owner(builtin, &poll, &world, &clock);
    let mut b = owner(profiled, &[], &world, &clock);

    // Patterns: nothing, one input, the first and last of each word, alternating, all.
    let patterns: [u32; 6] = [0, 1 << 4, 0x8001_8001, 0xAAAA_5555, 0x0001_0000, u32::MAX];
    let mut compared = 0;
    for (k, pattern) in patterns.iter().enumerate() {
        {
            let mut w = world.lock().unwrap();
            for n in 0..32 {
                let level = pattern & (1 << n) != 0;
                w.set(sim, &format!("DI{}", n + 1), Value::Bool(level))
                    .unwrap();
            }
        }
        // Past the module's 10 ms input sampling.
        clock.advance_to(ScanInstant::after_origin(Duration::from_millis(
            100 * (k as u64 + 1),
        )));
        let builtin_read = read(&mut a, builtin, &clock);
        let profile_read = read(&mut b, profiled, &clock);
        assert!(
            builtin_read.len() == 32 + 3 + 8,
            "the built-in driver polls DI1..DI32, the DIS and DIP words, DIP1..8: {builtin_read:?}"
        );
        for (name, value) in &builtin_read {
            let theirs = profile_read.iter().find(|(n, _)| n == name);
            assert_eq!(
                theirs.map(|(_, v)| *v),
                Some(*value),
                "{name} with inputs {pattern:#010x}"
            );
            compared += 1;
        }
        // And what the inputs are: DIn as set, the DIS words their bits.
        let get = |name: &str| {
            profile_read
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| *v)
        };
        assert_eq!(get("DI5"), Some(Value::Bool(pattern & (1 << 4) != 0)));
        assert_eq!(get("DIS1_16"), Some(Value::U16(*pattern as u16)));
        assert_eq!(get("DIS17_32"), Some(Value::U16((pattern >> 16) as u16)));
    }
    assert_eq!(compared, 6 * 43, "values compared");
}
