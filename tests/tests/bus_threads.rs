//! The bus threads on the real clock: a line on its own OS thread behind a [`LineLink`], as
//! `softplc run` drives it, over simulated MiniMods served in real time. Each test shows that
//! the scan's wait is bounded by its deadline whatever the line does: an answer too late for
//! its cycle, a line that is dead and comes back, a module power-cycled, a full command queue,
//! a port stuck in a read. Times are asserted with generous slack: this machine is noisy, and
//! the point is "bounded by the deadline", not "fast".

use std::sync::Arc;
use std::time::{Duration, Instant};

use softplc_io::devices::{self, Protocol};
use softplc_io::line::{
    BusCommand, BusOwner, BusThread, Discipline, LineError, LineLink, LineSettings, Module,
    OutputFrame, Transport,
};
use softplc_io::point::{Quality, Value};
use softplc_io::sim::{Fault, FaultRule, Frequency, SharedWorld, SimWorld, VirtualPort};
use softplc_io::time::{Clock, LineInstant, MonotonicClock};

/// Slack on every real-time bound.
const SLACK: Duration = Duration::from_millis(150);
const X1: usize = 0;

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

struct Rig {
    clock: Arc<dyn Clock>,
    world: SharedWorld,
    link: LineLink,
}

/// Two MiniMods (1, 2) on a simulated line in real time, behind a bus thread.
fn rig(response_timeout: Duration) -> Rig {
    let model = devices::model("minimod").expect("minimod");
    let settings = LineSettings::DEFAULT;
    let mut world = SimWorld::new(vec![settings]);
    for a in [1u8, 2] {
        world.add_device(0, &format!("mm{a}"), (model.simulator)(a));
    }
    let world = world.shared();
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let port = VirtualPort::new(world.clone(), 0, settings, clock.clone());
    let modules = [1u8, 2]
        .iter()
        .map(|&a| {
            let config = model
                .device_config(&format!("mm{a}"), a, Protocol::Modbus, &[])
                .unwrap();
            let driver = (model.driver)(&config);
            Module::new(format!("mm{a}"), driver)
        })
        .collect();
    let discipline = Discipline {
        response_timeout,
        retries: 1,
        reconnect_min: ms(300),
        reconnect_max: ms(600),
        ..Discipline::default()
    };
    let mut owner = BusOwner::new("line1", Box::new(port), discipline, modules);
    owner.startup().expect("both modules answer");
    let link = LineLink::thread(owner, clock.clone()).expect("a thread");
    Rig { clock, world, link }
}

impl Rig {
    /// One read against a deadline `budget` from now: the frame (if any) and how long the
    /// scan waited.
    fn read(&mut self, budget: Duration) -> (Option<Vec<Quality>>, Duration, Option<Value>) {
        let start = Instant::now();
        let now = self.clock.now();
        self.link.start_read(now);
        let d = self.link.finish_read(now + budget);
        let waited = start.elapsed();
        let x1 = d.answer.as_ref().and_then(|f| f.modules[0].values[X1]);
        (
            d.answer
                .map(|f| f.modules.iter().map(|m| m.quality).collect()),
            waited,
            x1,
        )
    }

    fn set(&self, module: &str, point: &str, value: Value) {
        let mut w = self.world.lock().unwrap();
        let d = w.find(module).unwrap();
        w.set(d, point, value).unwrap();
    }
}

#[test]
fn a_dead_line_never_holds_the_scan_past_its_deadline_and_comes_back() {
    let mut rig = rig(ms(100));
    let (q, _, _) = rig.read(ms(500));
    assert_eq!(q, Some(vec![Quality::Good, Quality::Good]));

    rig.world.lock().unwrap().faults_mut().set_dead(0, true);
    let mut lost = false;
    let began = Instant::now();
    while began.elapsed() < Duration::from_secs(3) {
        let (q, waited, _) = rig.read(ms(90));
        assert!(waited <= ms(90) + SLACK, "waited {waited:?}");
        if q == Some(vec![Quality::Bad, Quality::Bad]) {
            lost = true;
            break;
        }
        std::thread::sleep(ms(10));
    }
    assert!(lost, "both modules lost while the line is dead");

    rig.world.lock().unwrap().faults_mut().set_dead(0, false);
    rig.set("mm1", "X1", Value::Bool(true));
    let began = Instant::now();
    let mut back = None;
    while began.elapsed() < Duration::from_secs(5) {
        let (q, waited, x1) = rig.read(ms(90));
        assert!(waited <= ms(90) + SLACK, "waited {waited:?}");
        if q == Some(vec![Quality::Good, Quality::Good]) {
            back = Some(x1);
            break;
        }
        std::thread::sleep(ms(20));
    }
    assert_eq!(
        back,
        Some(Some(Value::Bool(true))),
        "back, with the inputs as they are now"
    );
}

#[test]
fn an_answer_too_late_for_its_cycle_is_the_next_cycles_input() {
    let mut rig = rig(ms(500));
    let (q, _, _) = rig.read(ms(500));
    assert_eq!(q, Some(vec![Quality::Good, Quality::Good]));
    rig.set("mm1", "X1", Value::Bool(true));
    std::thread::sleep(ms(50)); // the module's 20 ms input latency
    {
        let mut w = rig.world.lock().unwrap();
        let mm1 = w.find("mm1").unwrap();
        w.faults_mut().add(FaultRule {
            device: Some(mm1),
            fault: Fault::Late { by: ms(300) },
            frequency: Frequency::Next(1),
        });
    }
    let (q, waited, _) = rig.read(ms(50));
    assert_eq!(q, None, "nothing by the deadline");
    assert!(waited <= ms(50) + SLACK, "waited {waited:?}");
    std::thread::sleep(ms(400));
    // The next cycle: the late answer is there at once, with the value it read.
    let (q, waited, x1) = rig.read(Duration::ZERO);
    assert_eq!(q, Some(vec![Quality::Good, Quality::Good]));
    assert_eq!(x1, Some(Value::Bool(true)));
    assert!(waited <= SLACK, "waited {waited:?}");
}

#[test]
fn a_power_cycled_module_is_written_again_when_it_is_back() {
    let mut rig = rig(ms(60));
    let model = devices::model("minimod").unwrap();
    let y1 = model.points.iter().position(|p| p.name == "Y1").unwrap();
    let frame = |on: bool| {
        let mut modules = vec![vec![None; model.points.len()]; 2];
        modules[1][y1] = Some(Value::Bool(on));
        OutputFrame { modules }
    };
    let y1_of_mm2 = |rig: &Rig| {
        let w = rig.world.lock().unwrap();
        let d = w.find("mm2").unwrap();
        w.get(d, "Y1").unwrap()
    };
    let cycle = |rig: &mut Rig, on: bool| -> Option<Vec<Quality>> {
        let (q, _, _) = rig.read(ms(90));
        let now = rig.clock.now();
        rig.link.start_write(&frame(on), now);
        rig.link.finish_write(now + ms(90));
        std::thread::sleep(ms(20));
        q
    };
    cycle(&mut rig, true);
    assert_eq!(y1_of_mm2(&rig), Value::Bool(true));

    // mm2 goes off (silent) until it is lost, then comes back from a power cycle: Y1 off.
    {
        let mut w = rig.world.lock().unwrap();
        let mm2 = w.find("mm2").unwrap();
        w.faults_mut().add(FaultRule {
            device: Some(mm2),
            fault: Fault::Silent,
            frequency: Frequency::Always,
        });
    }
    let began = Instant::now();
    while cycle(&mut rig, true).is_none_or(|q| q[1] != Quality::Bad) {
        assert!(began.elapsed() < Duration::from_secs(3), "mm2 lost");
    }
    {
        let mut w = rig.world.lock().unwrap();
        let mm2 = w.find("mm2").unwrap();
        w.faults_mut().clear(Some(mm2));
        w.device_mut(mm2)
            .unwrap()
            .command(&["power-cycle"])
            .unwrap();
    }
    assert_eq!(y1_of_mm2(&rig), Value::Bool(false), "power-on value");
    let began = Instant::now();
    while cycle(&mut rig, true).is_none_or(|q| q[1] != Quality::Good) {
        assert!(began.elapsed() < Duration::from_secs(4), "mm2 back");
    }
    cycle(&mut rig, true);
    assert_eq!(
        y1_of_mm2(&rig),
        Value::Bool(true),
        "written again once back"
    );
}

/// A port that blocks in every read for a long time: an adapter that hangs.
#[derive(Debug)]
struct Stuck {
    clock: Arc<dyn Clock>,
}

impl Transport for Stuck {
    fn settings(&self) -> LineSettings {
        LineSettings::DEFAULT
    }
    fn now(&self) -> LineInstant {
        self.clock.line_now()
    }
    fn write_frame(&mut self, _frame: &[u8]) -> Result<(), LineError> {
        Ok(())
    }
    fn read_until(
        &mut self,
        _buf: &mut Vec<u8>,
        _deadline: LineInstant,
    ) -> Result<usize, LineError> {
        std::thread::sleep(Duration::from_secs(5));
        Ok(0)
    }
    fn wait_until(&mut self, t: LineInstant) {
        self.clock.sleep_until_on_line(t);
    }
    fn flush_input(&mut self) -> Result<usize, LineError> {
        Ok(0)
    }
}

fn stuck_owner(clock: Arc<dyn Clock>) -> BusOwner {
    let model = devices::model("minimod").unwrap();
    let config = model
        .device_config("mm1", 1, Protocol::Modbus, &[])
        .unwrap();
    let driver = (model.driver)(&config);
    BusOwner::new(
        "stuck",
        Box::new(Stuck {
            clock: clock.clone(),
        }),
        Discipline::default(),
        vec![Module::new("mm1", driver)],
    )
}

#[test]
fn a_stuck_port_neither_blocks_the_scan_nor_its_stop() {
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let mut link = LineLink::thread(stuck_owner(clock.clone()), clock.clone()).unwrap();
    let model = devices::model("minimod").unwrap();
    let frame = OutputFrame {
        modules: vec![vec![Some(Value::Bool(true)); model.points.len()]],
    };
    // Twenty cycles of a line that never answers: each phase waits its deadline, no more, and
    // the writes wait in the link (merged) instead of piling up on the line.
    for _ in 0..20 {
        let start = Instant::now();
        let now = clock.now();
        link.start_read(now);
        assert_eq!(link.finish_read(now + ms(10)).answer, None);
        link.start_write(&frame, clock.now());
        assert_eq!(link.finish_write(now + ms(20)).answer, None);
        assert!(start.elapsed() <= ms(20) + SLACK, "{:?}", start.elapsed());
    }
    let start = Instant::now();
    link.stop(ms(200));
    assert!(
        start.elapsed() <= ms(200) + SLACK,
        "stop waits its deadline, not the port: {:?}",
        start.elapsed()
    );
}

#[test]
fn a_full_command_queue_refuses_without_blocking() {
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let mut thread = BusThread::spawn(stuck_owner(clock)).unwrap();
    let start = Instant::now();
    let mut refused = 0;
    for _ in 0..20 {
        if thread.try_send(BusCommand::Read).is_err() {
            refused += 1;
        }
    }
    assert!(start.elapsed() <= SLACK, "{:?}", start.elapsed());
    assert!(
        refused >= 20 - 9,
        "the queue holds 8 (+1 being run): {refused}"
    );
    let start = Instant::now();
    assert!(
        thread.stop(None, ms(100)).is_none(),
        "the stuck thread is left"
    );
    assert!(start.elapsed() <= ms(100) + SLACK);
}
