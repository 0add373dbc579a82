//! The paths a machine takes first, on the virtual clock: a dead line, modules absent at
//! start, a lost module's probes, a module power cycle. The quick start's scan settings
//! (period 100 ms, task watchdog 500 ms × 3) with a line whose every failed request costs
//! 100 ms + a 50 ms guard, twice: the PLC keeps its grid, its outputs and its other modules.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::clock::{Clock, VirtualClock};
use softplc::plc::{CycleWork, Plc};
use softplc::project::parse_str;
use softplc::scan::{ScanEngine, StopReason};
use softplc_io::point::{Quality, Value};
use softplc_io::sim::{Fault, FaultRule, Frequency, SharedWorld};

const PERIOD: Duration = Duration::from_millis(100);

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// Two MiniMods: `x` on mm1.X1 drives `y` on mm2.Y1 (and `y1` on mm1.Y1 follows it too).
fn project() -> softplc::project::Project {
    // A folder per call: tests run in parallel and one of them rewrites its program.
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("softplc-transients-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("follow.expr"), "y = x\ny1 = x\n").unwrap();
    let text = "project: transients
scan:
  period: 100ms
  watchdog: { time: 500ms, sensitivity: 3 }
buses:
  - { name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 100ms, retries: 1 }
modules:
  # Polled, pinned: the paths of a polled line (a silent module is seen in the next cycle;
  # in event mode, the default here, only at its refresh).
  - { name: mm1, bus: line1, model: minimod, address: 1, settings: { events: false } }
  - { name: mm2, bus: line1, model: minimod, address: 2, settings: { events: false } }
tags:
  - { name: x, point: mm1.X1 }
  - { name: y1, point: mm1.Y1, safe: false }
  - { name: y, point: mm2.Y1, safe: false }
program: { file: follow.expr, kind: expr }
";
    // On disk too: a reload reads it again.
    std::fs::write(dir.join("project.yaml"), text).unwrap();
    parse_str(text, &dir.join("project.yaml")).unwrap_or_else(|e| panic!("valid:\n{e}"))
}

/// One cycle as the hook saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cycle {
    now: Duration,
    /// Quality of `x` after the input phase, and of the two modules.
    x: Quality,
    mm1: Quality,
    mm2: Quality,
    /// The mm2.Y1 terminal after the output phase.
    y_terminal: bool,
    /// The time the cycle spent waiting for its line.
    io_wait: Duration,
    /// mm1's requests so far.
    mm1_requests: u64,
    /// Whether mm2 holds what the program asked of its outputs.
    mm2_outputs: Quality,
    /// Whether the line was still writing when the cycle's period ended: the cycle overran
    /// (the scan itself kept its grid).
    writes_late: bool,
}

/// What to do to the world before the cycle starting at a time.
type Script = Box<dyn FnMut(Duration, &SharedWorld) + Send>;

/// Runs `plc` for `run_for` with `script` acting on its world before each cycle.
fn run(plc: Plc, run_for: Duration, mut script: Script) -> (Vec<Cycle>, StopReason, u64) {
    let world = plc.world().expect("a simulated line").clone();
    let (mm1, mm2) = {
        let w = world.lock().unwrap();
        (w.find("mm1").unwrap(), w.find("mm2").unwrap())
    };
    let x = plc.image().id("x").unwrap();
    let cycles = Arc::new(Mutex::new(Vec::new()));
    let sink = cycles.clone();
    let begin = plc.clock().now();
    script(Duration::ZERO, &world);
    let mut engine = ScanEngine::new(plc)
        .run_for(run_for)
        .on_cycle(Box::new(move |plc, ctx| {
            let status = plc.module_status();
            let y_terminal = {
                let w = world.lock().unwrap();
                w.get(mm2, "Y1").map(|v| v.as_bool()).unwrap_or(false)
            };
            let _ = mm1;
            sink.lock().unwrap().push(Cycle {
                now: ctx.now - begin,
                x: plc.image().slot(x).quality,
                mm1: status[0].quality,
                mm2: status[1].quality,
                y_terminal,
                io_wait: plc.io_wait(),
                mm1_requests: status[0].counters.requests,
                mm2_outputs: status[1].outputs,
                writes_late: match plc.cycle_work() {
                    CycleWork::Done => false,
                    CycleWork::At(t) => t > ctx.now + PERIOD,
                    CycleWork::Later => true,
                },
            });
            script(ctx.now - begin + PERIOD, &world);
        }));
    let outcome = engine.run();
    let cycles = cycles.lock().unwrap().clone();
    if std::env::var_os("TRANSIENTS_DEBUG").is_some() {
        for c in &cycles {
            eprintln!("{c:?}");
        }
    }
    (cycles, outcome.reason, outcome.stats.overruns)
}

/// The times of the cycles that overran, after checking that every overrun counted is one
/// of them: a cycle whose line was still writing (retries, probes, time-outs) when its period
/// ended. The scan itself never falls behind its grid on a line fault.
fn overran(cycles: &[Cycle], overruns: u64) -> Vec<Duration> {
    let late: Vec<Duration> = cycles
        .iter()
        .filter(|c| c.writes_late)
        .map(|c| c.now)
        .collect();
    assert_eq!(overruns, late.len() as u64, "every overrun is a late write");
    late
}

fn set(world: &SharedWorld, module: &str, point: &str, on: bool) {
    let mut w = world.lock().unwrap();
    let d = w.find(module).unwrap();
    w.set(d, point, Value::Bool(on)).unwrap();
}

#[test]
fn a_dead_line_leaves_the_scan_on_its_grid_and_its_modules_come_back() {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project(), clock).expect("builds");
    let (dead_from, dead_until) = (Duration::from_secs(2), Duration::from_secs(6));
    let (cycles, reason, overruns) = run(
        plc,
        Duration::from_secs(12),
        Box::new(move |next, world| {
            let mut w = world.lock().unwrap();
            w.faults_mut()
                .set_dead(0, next >= dead_from && next < dead_until);
            drop(w);
            // The operator presses x at 1 s, releases it during the outage, presses it again.
            let x = (next >= ms(1000) && next < ms(3000)) || next >= ms(9000);
            set(world, "mm1", "X1", x);
        }),
    );
    assert_eq!(
        reason,
        StopReason::TimeUp,
        "the PLC never stops on a line fault"
    );
    // The line's time-outs and probes outlast the period, so the cycles that carry them
    // overrun (their writes end after it), during the outage and its recovery only; the scan
    // keeps every deadline all the same.
    let late = overran(&cycles, overruns);
    assert!(!late.is_empty(), "an outage costs the line its period");
    assert!(
        late.iter()
            .all(|&t| t >= dead_from && t < dead_until + Duration::from_secs(4)),
        "overruns only during the outage and the modules' return: {late:?}"
    );
    assert_eq!(cycles.len(), 120, "one cycle per period for 12 s");
    for (k, c) in cycles.iter().enumerate() {
        assert_eq!(c.now, PERIOD * k as u32, "on the grid: {c:?}");
        assert!(
            c.io_wait <= PERIOD,
            "the wait for the line is bounded: {c:?}"
        );
    }
    let at = |t: Duration| cycles.iter().find(|c| c.now >= t).copied().unwrap();
    // Before: good, and x reaches mm2.
    assert_eq!(at(ms(1500)).x, Quality::Good);
    assert!(at(ms(1500)).y_terminal);
    // During the outage: stale at first, then bad once the modules are lost.
    let during: Vec<&Cycle> = cycles
        .iter()
        .filter(|c| c.now >= dead_from && c.now < dead_until)
        .collect();
    assert!(during.iter().all(|c| c.x != Quality::Good), "{during:#?}");
    assert_eq!(during[0].x, Quality::Stale, "{during:#?}");
    let lost = during
        .iter()
        .position(|c| c.mm1 == Quality::Bad && c.mm2 == Quality::Bad)
        .expect("both modules lost during the outage");
    assert!(
        during[..lost].iter().all(|c| c.x == Quality::Stale),
        "{during:#?}"
    );
    assert!(
        during[lost..].iter().all(|c| c.x == Quality::Bad),
        "{during:#?}"
    );
    assert!(
        during[lost..]
            .iter()
            .all(|c| c.mm2_outputs == Quality::Stale),
        "a lost module's outputs are its last acknowledged values, unconfirmed: {during:#?}"
    );
    // Three failed reads (fail limit 3), each 2 attempts × (request + 100 ms + 50 ms guard):
    // the first one for both modules, the next ones after the line's answer to the scan.
    assert!(
        during[lost].now <= dead_from + ms(2500),
        "lost within three failed reads: {:?}",
        during[lost]
    );
    // After: back within the reconnect backoff (at most 4 s after 4 s lost), good, and
    // pressing x again drives mm2 again.
    let back = cycles
        .iter()
        .find(|c| c.now >= dead_until && c.mm1 == Quality::Good && c.mm2 == Quality::Good)
        .expect("both modules back");
    assert!(back.now <= dead_until + Duration::from_secs(4), "{back:?}");
    assert_eq!(at(ms(9500)).x, Quality::Good);
    assert_eq!(at(ms(9500)).mm2_outputs, Quality::Good);
    assert!(
        at(ms(9500)).y_terminal,
        "outputs written again after the outage"
    );
    assert!(!at(ms(8500)).y_terminal, "x released: y off");
}

#[test]
fn modules_absent_at_start_are_lost_not_fatal_and_start_up_when_they_answer() {
    let project = project();
    // A world whose line is dead before the PLC starts: no module answers its start-up.
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let probe = Plc::build(project.clone(), clock).expect("builds");
    let world = probe.world().unwrap().clone();
    drop(probe);
    world.lock().unwrap().faults_mut().set_dead(0, true);
    let clock = Arc::new(VirtualClock::new());
    clock.advance_to(world.lock().unwrap().now().on_scan_clock());
    let plc = Plc::build_on(project, clock, Some(world.clone()))
        .expect("a module that does not answer does not stop the start");
    assert!(plc
        .module_status()
        .iter()
        .all(|m| m.quality == Quality::Bad));
    let (cycles, reason, overruns) = run(
        plc,
        Duration::from_secs(8),
        Box::new(move |next, world| {
            world
                .lock()
                .unwrap()
                .faults_mut()
                .set_dead(0, next < Duration::from_secs(3));
            set(world, "mm1", "X1", next >= ms(5000));
        }),
    );
    assert_eq!(reason, StopReason::TimeUp);
    let late = overran(&cycles, overruns);
    let start = cycles.first().unwrap();
    assert_eq!(start.x, Quality::Bad, "bad from the first cycle: {start:?}");
    let back = cycles
        .iter()
        .find(|c| c.mm1 == Quality::Good && c.mm2 == Quality::Good)
        .expect("both modules start up once the line is alive");
    // Each is probed at its backoff (1 s, then doubling): mm1 failed its probes at 0.8 s and
    // 2.8 s, so the next is 4 s later.
    assert!(back.now >= ms(3000) && back.now <= ms(7500), "{back:?}");
    let last = cycles.last().unwrap();
    assert_eq!(last.x, Quality::Good);
    assert!(last.y_terminal, "x drives mm2 once it is up");
    assert!(
        late.iter().all(|&t| t <= back.now),
        "overruns only while the modules are probed: {late:?}"
    );
    assert_eq!(cycles.len(), 80, "the scan keeps its grid");
}

#[test]
fn a_lost_module_costs_its_line_one_request_per_probe() {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project(), clock).expect("builds");
    let (cycles, reason, overruns) = run(
        plc,
        Duration::from_secs(20),
        Box::new(|next, world| {
            if next == Duration::from_secs(1) {
                let mut w = world.lock().unwrap();
                let mm1 = w.find("mm1").unwrap();
                w.faults_mut().add(FaultRule {
                    device: Some(mm1),
                    fault: Fault::Silent,
                    frequency: Frequency::Always,
                });
            }
            set(world, "mm1", "X1", false);
        }),
    );
    assert_eq!(reason, StopReason::TimeUp);
    let late = overran(&cycles, overruns);
    assert_eq!(cycles.len(), 200, "the scan keeps its grid");
    // mm2 keeps being scanned: mm1's first failed read delays the line once (stale), then
    // mm1 is read after mm2's inputs have gone to the scan, and its probes never delay them.
    let lost_at = cycles
        .iter()
        .position(|c| c.mm1 == Quality::Bad)
        .expect("mm1 lost");
    // A probe (one attempt: request + 100 ms + 50 ms guard) holds the line longer than the
    // period, so the cycle after it sees mm2's read late, stale; it is never bad.
    assert!(cycles.iter().all(|c| c.mm2 != Quality::Bad), "{cycles:#?}");
    let late_after_loss = cycles[lost_at..]
        .iter()
        .filter(|c| c.mm2 != Quality::Good)
        .count();
    assert!(
        late_after_loss * 10 <= cycles.len() - lost_at,
        "mm2 good in nine cycles of ten once mm1 is lost: {late_after_loss}"
    );
    // From then on every probe is one request (no retries), at a backoff doubling from 1 s.
    let probes: Vec<(Duration, u64)> = cycles[lost_at..]
        .windows(2)
        .filter(|w| w[1].mm1_requests != w[0].mm1_requests)
        .map(|w| (w[1].now, w[1].mm1_requests - w[0].mm1_requests))
        .collect();
    assert!(probes.len() >= 3, "{probes:?}");
    assert!(probes.iter().all(|(_, n)| *n == 1), "{probes:?}");
    let gaps: Vec<Duration> = probes.windows(2).map(|w| w[1].0 - w[0].0).collect();
    for pair in gaps.windows(2) {
        assert!(pair[1] > pair[0], "the backoff grows: {gaps:?}");
    }
    // Each probe's cycle (or its failed reads before the loss) overran, and no other.
    let probe_cycles = cycles[lost_at..].iter().filter(|c| c.writes_late).count();
    assert!(
        probe_cycles <= probes.len(),
        "one overrun at most per probe: {late:?} {probes:?}"
    );
}

#[test]
fn a_power_cycled_module_gets_its_start_up_again_and_its_outputs_back() {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project(), clock).expect("builds");
    let (cycles, reason, _) = run(
        plc,
        Duration::from_secs(10),
        Box::new(|next, world| {
            set(world, "mm1", "X1", next >= ms(500));
            let mut w = world.lock().unwrap();
            let mm2 = w.find("mm2").unwrap();
            // Off for 1.5 s (lost), then on again with its power-on values: Y1 off.
            if next == ms(2000) {
                w.faults_mut().add(FaultRule {
                    device: Some(mm2),
                    fault: Fault::Silent,
                    frequency: Frequency::Always,
                });
            }
            if next == ms(3500) {
                w.faults_mut().clear(Some(mm2));
                w.device_mut(mm2)
                    .unwrap()
                    .command(&["power-cycle"])
                    .unwrap();
            }
        }),
    );
    assert_eq!(reason, StopReason::TimeUp);
    let at = |t: Duration| cycles.iter().find(|c| c.now >= t).copied().unwrap();
    assert!(at(ms(1500)).y_terminal);
    assert!(at(ms(3000)).mm2 == Quality::Bad, "lost while off");
    let back = cycles
        .iter()
        .find(|c| c.now >= ms(3500) && c.mm2 == Quality::Good)
        .expect("back after the power cycle");
    assert!(
        back.y_terminal,
        "the output is written again in the cycle the module is back: {back:?}"
    );
    assert!(at(ms(9000)).y_terminal);
}

#[test]
fn a_module_power_cycled_between_two_reads_gets_its_outputs_back_within_the_refresh() {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project(), clock).expect("builds");
    let (cycles, reason, _) = run(
        plc,
        Duration::from_secs(6),
        Box::new(|next, world| {
            set(world, "mm1", "X1", next >= ms(500));
            if next == ms(2000) {
                let mut w = world.lock().unwrap();
                let mm2 = w.find("mm2").unwrap();
                w.device_mut(mm2)
                    .unwrap()
                    .command(&["power-cycle"])
                    .unwrap();
            }
        }),
    );
    assert_eq!(reason, StopReason::TimeUp);
    let at = |t: Duration| cycles.iter().find(|c| c.now >= t).copied().unwrap();
    assert!(at(ms(1500)).y_terminal);
    // The 1 s output refresh writes it again (the module answers throughout: it was never
    // lost, so nothing else tells the PLC it lost its outputs).
    assert!(at(ms(3100)).y_terminal, "{cycles:#?}");
}

#[test]
fn a_reload_compiles_off_the_scan_and_swaps_at_a_cycle_boundary() {
    use softplc::service::control::{Envelope, Request};
    use softplc::service::ServiceBoundary;
    let project = project();
    let program = project.programs[0].path.clone();
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build(project, clock).expect("builds");
    let world = plc.world().unwrap().clone();
    let (requests, rx) = crossbeam_channel::unbounded();
    let (reply_tx, replies) = crossbeam_channel::unbounded();
    let sent = Arc::new(Mutex::new(None::<u64>));
    let seen = Arc::new(Mutex::new(Vec::new()));
    let (sent_in, seen_in) = (sent.clone(), seen.clone());
    let mut engine = ScanEngine::new(plc)
        .with_boundary(ServiceBoundary::new().with_control(rx))
        .run_for(Duration::from_secs(30))
        .on_cycle(Box::new(move |plc, ctx| {
            set(&world, "mm1", "X1", true);
            let y = {
                let w = world.lock().unwrap();
                let d = w.find("mm2").unwrap();
                w.get(d, "Y1").map(|v| v.as_bool()).unwrap_or(false)
            };
            seen_in.lock().unwrap().push((ctx.cycle, y));
            if ctx.cycle == 20 {
                // The new program: y follows !x.
                std::fs::write(&program, "y = !x\ny1 = x\n").unwrap();
                requests
                    .send(Envelope::new(
                        Request::Reload { task: None },
                        reply_tx.clone(),
                        Duration::from_secs(60),
                        softplc::service::audit::Origin::Cli,
                    ))
                    .unwrap();
                *sent_in.lock().unwrap() = Some(ctx.cycle);
            }
            let _ = plc;
        }));
    let outcome = engine.run();
    assert_eq!(outcome.reason, StopReason::TimeUp);
    assert_eq!(outcome.stats.overruns, 0, "the compile never held a cycle");
    let reply = replies.try_recv().expect("the reload was answered");
    assert!(reply.ok, "{reply:?}");
    assert!(
        reply
            .message
            .as_deref()
            .is_some_and(|m| m.contains("reloaded")),
        "{reply:?}"
    );
    let seen = seen.lock().unwrap().clone();
    // Before the reload y follows x (on); some cycles after it, !x (off), and it stays so.
    assert!(seen[10..20].iter().all(|(_, y)| *y), "{seen:?}");
    let swapped = seen
        .iter()
        .position(|(c, y)| *c > 20 && !*y)
        .expect("the new program runs");
    assert!(seen[swapped..].iter().all(|(_, y)| !*y), "{seen:?}");
}
