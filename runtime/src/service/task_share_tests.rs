//! Two tasks on virtual clocks, each boundary with its share of the services wired as
//! `softplc run` wires them: a consumer of the change feed sees every change of every task's
//! tags at its task's own cycle ends, the alarms see a module of a task other than the first
//! lost, and the snapshot shows every task's forces and modules.

use std::path::PathBuf;
use std::time::Duration;

use softplc_io::point::{Quality, Value};
use softplc_io::sim::{Fault, FaultRule, Frequency};

use super::TaskShare;
use crate::plc::TaskBuilder;
use crate::scan::{TaskControl, TaskSet};
use crate::service::alarms::book::AlarmBook;
use crate::service::boundary::ServiceBoundary;
use crate::service::changes::{ChangeFeed, Delivery};
use crate::service::snapshot::{Publisher, SnapshotCell};

/// The first task is the slow one (100 ms); the fast one (10 ms) counts and toggles every
/// cycle. The fast task's module comes first in the project, so module places differ from
/// each task's own; its second module `fx` never answers (the test silences it).
const PROJECT: &str = "\
project: shares
tasks:
  - { name: slow, period: 100ms, program: { file: slow.rhai, kind: rhai }, buses: [slow_line] }
  - { name: fast, period: 10ms, program: { file: fast.rhai, kind: rhai }, buses: [fast_line] }
buses:
  - { name: slow_line, port: sim, baud: 57600, response_timeout: 20ms, tune: reply_delay }
  - { name: fast_line, port: sim, baud: 57600, response_timeout: 20ms, tune: reply_delay }
modules:
  - { name: fm, bus: fast_line, model: minimod, address: 1 }
  - { name: sm, bus: slow_line, model: minimod, address: 1 }
  - { name: fx, bus: fast_line, model: minimod, address: 2 }
tags:
  - { name: count, type: u16 }
  - { name: toggle, type: bool }
  - { name: slow_toggle, type: bool }
  - { name: fast_lamp, point: fm.Y1, safe: false }
  - { name: slow_lamp, point: sm.Y1, safe: false }
  - { name: held, type: bool }
";

/// The project, in a scratch folder removed when the returned guard goes.
fn project(case: &str) -> (crate::project::Project, Scratch) {
    let dir: PathBuf =
        std::env::temp_dir().join(format!("softplc-shares-{case}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    std::fs::write(dir.join("project.yaml"), PROJECT).expect("the project");
    std::fs::write(
        dir.join("fast.rhai"),
        "count += 1;\ntoggle = !toggle;\nfast_lamp = toggle;\nheld = toggle;\n",
    )
    .expect("fast.rhai");
    std::fs::write(
        dir.join("slow.rhai"),
        "slow_toggle = !slow_toggle;\nslow_lamp = slow_toggle;\n",
    )
    .expect("slow.rhai");
    let project = crate::project::load(&dir.join("project.yaml")).expect("the project loads");
    (project, Scratch(dir))
}

/// A scratch folder, removed when dropped.
struct Scratch(PathBuf);

impl Drop for Scratch {
    fn drop(&mut self) {
        // Nothing to do when it is gone already.
        drop(std::fs::remove_dir_all(&self.0));
    }
}

#[test]
fn every_tasks_boundary_feeds_and_publishes_its_own_share() {
    let (project, _scratch) = project("feed");
    let builder = TaskBuilder::new(&project, None, None).expect("it builds");
    let mut feed = ChangeFeed::new();
    let stream = feed.subscribe("test", 100_000);
    let cell = SnapshotCell::new();
    let control = TaskControl::new();
    let mut engines = Vec::new();
    for i in 0..2 {
        let share = TaskShare::of(&project, builder.ownership(), i);
        let boundary = ServiceBoundary::new()
            .with_feed(feed.share(share.clone()))
            .with_publisher(Publisher::new(cell.clone()).with_share(share, i == 0));
        let mut plc = builder.build(i).expect("the task builds");
        if i == 1 {
            // Forced in the fast task, which owns it.
            plc.plc.force("held", "1").expect("a force");
            let world = plc.plc.world().expect("a simulated line");
            let mut world = world.lock().expect("the world");
            let fx = world.find("fx").expect("fx is simulated");
            world.faults_mut().add(FaultRule {
                device: Some(fx),
                fault: Fault::Silent,
                frequency: Frequency::Always,
            });
        }
        engines.push(
            control
                .engine(plc)
                .with_boundary(boundary)
                .run_for(Duration::from_secs(2)),
        );
    }
    drop(feed);
    let outcomes = TaskSet::from_engines(builder.names(), engines).run_virtual();
    let cycles: Vec<u64> = outcomes.iter().map(|o| o.outcome.stats.cycles).collect();
    assert!(cycles[1] >= 150 && cycles[0] <= 20, "{cycles:?}");
    let deliveries: Vec<Delivery> = stream.receiver().try_iter().collect();
    assert_eq!(stream.lost(), 0);
    let changes_of = |tag: usize| -> Vec<(usize, u64, Duration, Value)> {
        deliveries
            .iter()
            .flat_map(|d| {
                d.all()
                    .filter(move |(c, _)| c.tag == tag)
                    .map(move |(c, _)| {
                        (
                            d.cycle.task,
                            d.cycle.cycle,
                            d.cycle.at.since_origin(),
                            c.value,
                        )
                    })
            })
            .collect()
    };
    // Every count of the fast task, once each, at its own cycles (the safe state's
    // publication last changes no count).
    let count = changes_of(0);
    assert_eq!(count.len() as u64, cycles[1], "{count:?}");
    for (n, (task, cycle, _, value)) in count.iter().enumerate() {
        assert_eq!(
            (*task, *cycle, *value),
            (1, n as u64 + 1, Value::U16(n as u16 + 1))
        );
    }
    // Stamped with the fast task's cycle ends: a period apart, give or take the time a cycle
    // took (its silent module's timeouts), never the slow task's 100 ms.
    assert!(
        count.windows(2).all(|w| {
            let gap = w[1].2.saturating_sub(w[0].2);
            gap > Duration::from_millis(5) && gap < Duration::from_millis(15)
        }),
        "{count:?}"
    );
    // Every toggle too (a change every cycle), and the slow task's, at its own boundaries.
    assert_eq!(changes_of(1).len() as u64, cycles[1]);
    let slow = changes_of(2);
    assert_eq!(slow.len() as u64, cycles[0], "{slow:?}");
    assert!(slow.iter().all(|(task, ..)| *task == 0), "{slow:?}");
    // Each module's quality from its own task, at its place in the project.
    let modules: Vec<(usize, usize)> = deliveries
        .iter()
        .flat_map(|d| d.cycle.modules.iter().map(move |(m, _)| (d.cycle.task, *m)))
        .collect();
    for place in [(1, 0), (0, 1), (1, 2)] {
        assert!(modules.contains(&place), "{place:?} in {modules:?}");
    }
    assert!(
        modules.iter().all(|&(t, m)| (t == 0) == (m == 1)),
        "{modules:?}"
    );
    // The alarms, fed the same deliveries: the fast task's lost module, at its cycle.
    let mut book = AlarmBook::new(&project, std::time::SystemTime::UNIX_EPOCH);
    for d in &deliveries {
        book.apply(d);
    }
    let lost: Vec<(String, bool)> = book
        .all()
        .into_iter()
        .filter(|a| a.name.starts_with("lost."))
        .map(|a| (a.name, a.active))
        .collect();
    assert_eq!(
        lost,
        [
            ("lost.fm".to_owned(), false),
            ("lost.sm".to_owned(), false),
            ("lost.fx".to_owned(), true)
        ]
    );
    // The snapshot: the fast task's force and values as it published them, both modules.
    let snap = cell.get();
    assert!(snap.stopped, "every task published its last state");
    assert_eq!(snap.forced, [false, false, false, false, false, true]);
    assert_eq!(snap.values[0], Value::U16(cycles[1] as u16));
    assert_eq!(snap.task_cycles, cycles);
    assert_eq!(snap.cycles, cycles[0], "the first task's figures");
    let modules: Vec<(Quality, bool)> = snap
        .modules
        .iter()
        .map(|m| (m.quality, m.counters.requests > 0))
        .collect();
    assert_eq!(
        modules,
        [
            (Quality::Good, true),
            (Quality::Good, true),
            (Quality::Bad, true)
        ]
    );
}
