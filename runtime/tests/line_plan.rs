//! What softplc plans for a line, as it runs on the virtual clock: a line of factory MiniMods
//! reads its inputs by Collect without being told, and `tune: reply_delay` sets the modules'
//! reply delay at start-up, again after a power cycle, and never saves it.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::clock::{Clock, VirtualClock};
use softplc::plc::Plc;
use softplc::project::parse_str;
use softplc::scan::{ScanEngine, StopReason};
use softplc_io::point::Value;
use softplc_io::sim::{Fault, FaultRule, Frequency, SharedWorld};

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A project of MiniMods 1..=`n` on one simulated bus (`bus_extra` added to it); `y`, on the
/// last module's Y1, follows `x`, on mm1.X1.
fn project(tag: &str, n: u8, bus_extra: &str) -> softplc::project::Project {
    let dir = std::env::temp_dir().join(format!("softplc-line-plan-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("follow.expr"), "y = x\n").unwrap();
    let mut modules = String::new();
    for a in 1..=n {
        modules.push_str(&format!(
            "  - {{ name: mm{a}, bus: line1, model: minimod, address: {a} }}\n"
        ));
    }
    let text = format!(
        "project: line-plan
scan: {{ period: 100ms }}
buses:
  - {{ name: line1, port: sim{bus_extra} }}
modules:
{modules}tags:
  - {{ name: x, point: mm1.X1 }}
  - {{ name: y, point: mm{n}.Y1, safe: false }}
program: {{ file: follow.expr, kind: expr }}
"
    );
    // The folder stays: the PLC reads the program when it is built.
    parse_str(&text, &dir.join("project.yaml")).unwrap_or_else(|e| panic!("{e}"))
}

/// What to do to the world before the cycle starting at a time (from the run's start).
type Script = Box<dyn FnMut(Duration, &SharedWorld) + Send>;

/// Runs `plc` for `run_for`; per cycle: its time, mm1's requests so far, and `y`'s terminal.
fn run(plc: Plc, run_for: Duration, mut script: Script) -> Vec<(Duration, u64, bool)> {
    let world = plc.world().expect("a simulated line").clone();
    let seen = Arc::new(Mutex::new(Vec::new()));
    let sink = seen.clone();
    let begin = plc.clock().now();
    let last = plc.project().modules.len() - 1;
    script(Duration::ZERO, &world);
    let mut engine = ScanEngine::new(plc)
        .run_for(run_for)
        .on_cycle(Box::new(move |plc, ctx| {
            let y = {
                let w = world.lock().unwrap();
                w.get(last, "Y1").map(|v| v.as_bool()).unwrap_or(false)
            };
            let requests = plc.module_status()[0].counters.requests;
            sink.lock().unwrap().push((ctx.now - begin, requests, y));
            script(ctx.now - begin + ms(100), &world);
        }));
    assert_eq!(engine.run().reason, StopReason::TimeUp);
    let seen = seen.lock().unwrap().clone();
    seen
}

fn status(world: &SharedWorld, module: usize) -> String {
    world
        .lock()
        .unwrap()
        .device_mut(module)
        .unwrap()
        .command(&["status"])
        .unwrap()
}

#[test]
fn a_line_of_factory_minimods_reads_its_inputs_by_collect_by_default() {
    let project = project("collect", 4, "");
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project, clock).expect("builds");
    let cycles = run(
        plc,
        Duration::from_secs(3),
        Box::new(|next, world| {
            let mut w = world.lock().unwrap();
            let mm1 = w.find("mm1").unwrap();
            w.set(mm1, "X1", Value::Bool(next >= ms(1000))).unwrap();
        }),
    );
    let at = |t: Duration| *cycles.iter().find(|c| c.0 >= t).unwrap();
    // The press reaches the program through an event: mm1's own requests do not grow with
    // the cycles (polled, each cycle would add its FC 2), only with the 1 s refresh.
    assert!(!at(ms(900)).2);
    assert!(at(ms(1300)).2, "{cycles:?}");
    let (from, to) = (at(ms(1500)).1, at(ms(2500)).1);
    assert!(
        to - from <= 2,
        "10 cycles, {} requests of mm1's own: {cycles:?}",
        to - from
    );
}

#[test]
fn tuned_reply_delays_are_set_at_start_up_again_after_a_power_cycle_and_never_saved() {
    let project = project("tuned", 2, ", baud: 57600, tune: reply_delay");
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project, clock).expect("builds");
    let world = plc.world().unwrap().clone();
    // Started: both modules answer at once.
    assert!(
        status(&world, 0).contains("RDELAYT=0"),
        "{}",
        status(&world, 0)
    );
    assert!(status(&world, 1).contains("RDELAYT=0"));
    let seen = Arc::new(Mutex::new(Vec::<(Duration, String)>::new()));
    let log = seen.clone();
    run(
        plc,
        Duration::from_secs(5),
        Box::new(move |next, world| {
            let mut w = world.lock().unwrap();
            let mm2 = w.find("mm2").unwrap();
            // Off for 1.5 s (lost), then on again with what its flash holds.
            if next == ms(1000) {
                w.faults_mut().add(FaultRule {
                    device: Some(mm2),
                    fault: Fault::Silent,
                    frequency: Frequency::Always,
                });
            }
            if next == ms(2500) {
                w.faults_mut().clear(Some(mm2));
                let device = w.device_mut(mm2).unwrap();
                device.command(&["power-cycle"]).unwrap();
                log.lock()
                    .unwrap()
                    .push((next, device.command(&["status"]).unwrap()));
            }
            if next == ms(4500) {
                let device = w.device_mut(mm2).unwrap();
                log.lock()
                    .unwrap()
                    .push((next, device.command(&["status"]).unwrap()));
            }
        }),
    );
    let seen = seen.lock().unwrap().clone();
    assert_eq!(seen.len(), 2, "{seen:?}");
    assert!(
        seen[0].1.contains("RDELAYT=1"),
        "the flash kept the factory delay: {seen:?}"
    );
    assert!(
        seen[1].1.contains("RDELAYT=0"),
        "set again once it answered: {seen:?}"
    );
}
