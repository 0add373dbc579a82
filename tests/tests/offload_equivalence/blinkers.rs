//! Blinkers pushed down (MiniMod YLAMPn) against the same program in the scan.
//!
//! A LAMP block means the module's blinker: a 16-step mask on 100 ms steps that run freely,
//! in the scan from the PLC's start, in the module from its power-on. So the two builds play
//! the same mask with the same period and duty, each on its own phase; the pushed-down one
//! edges on the module's 1 ms tick, the central one on scan boundaries (plus the write). After
//! the enable rises the first on-step comes within the mask's longest run of off-steps plus
//! one step after the write, which comes within the central reaction bound. Lamps of one
//! module share its steps, so their edges line up, in the module as in the scan. Start-up,
//! kill -9, bus loss and forcing are run as for the other forms.

use super::*;
use softplc_io::devices::minimod::first_on_within;

/// 400 ms on, 400 ms off.
const FAST: u16 = 0x0F0F;
/// 800 ms on, 800 ms off (the manual's 255, "a slow continuous flashing").
const SLOW: u16 = 0x00FF;

/// Two LAMPs and a BLINK with a free phase on one MiniMod, enabled by X1, in ladder.
fn lamps_case(name: &'static str, modules: &'static [&'static str]) -> Case {
    Case {
        name,
        period_ms: 100,
        tick_ms: 1,
        modules,
        tags: &[
            "name: enable, point: mm1.X1",
            "name: x2, point: mm1.X2",
            "name: warn, point: mm1.Y1, safe: false",
            "name: slow, point: mm1.Y2, safe: false",
            "name: beacon, point: mm1.Y3, safe: false, blink_phase: free",
        ],
        program: "enable -> LAMP w(3855) -> warn\n\
                  enable -> LAMP s(255) -> slow\n\
                  enable -> BLINK b(400ms, 400ms) -> beacon",
        lang: Lang::Ladder,
        inputs: &["mm1.X1", "mm1.X2"],
        outputs: &["mm1.Y1", "mm1.Y2", "mm1.Y3"],
    }
}

/// Polled (a deterministic line: in event mode which cycle carries an input depends on the
/// module's full reads, which differ between the builds).
const POLLED: &[&str] = &["name: mm1, model: minimod, address: 1, settings: {events: false}"];

/// The on-runs (rise, fall) of a trace between `from` and `to`, complete ones only.
fn runs(trace: &[Edge], from: Duration, to: Duration) -> Vec<(Duration, Duration)> {
    pulses(trace, from)
        .into_iter()
        .filter(|&(_, fall)| fall <= to)
        .collect()
}

/// Every complete on-run and off-run between `from` and `to` lasts `on` / `off` within `tol`;
/// returns how many on-runs there were.
fn steady(
    name: &str,
    trace: &[Edge],
    from: Duration,
    to: Duration,
    on: u64,
    off: u64,
    tol: Duration,
) -> usize {
    let r = runs(trace, from, to);
    assert!(r.len() >= 3, "{name}: it blinks: {trace:?}");
    // The first run may start in the middle of an on-step (the enable's, or the write's,
    // moment): only the ones after it are whole.
    for (i, w) in r.windows(2).enumerate() {
        let (rise, fall) = w[1];
        assert!(
            (fall - rise).abs_diff(ms(on)) <= tol,
            "{name}: run {} on for {:?}, not {on} ms",
            i + 1,
            fall - rise
        );
        assert!(
            (rise - w[0].1).abs_diff(ms(off)) <= tol,
            "{name}: off for {:?} before run {}, not {off} ms",
            rise - w[0].1,
            i + 1
        );
    }
    r.len()
}

/// Whether every rise of `of` comes with a rise of `with` (within `tol`).
fn rises_together(of: &[Edge], with: &[Edge], tol: Duration) -> bool {
    of.iter()
        .filter(|e| e.1)
        .all(|e| with.iter().any(|w| w.1 && w.0.abs_diff(e.0) <= tol))
}

#[test]
fn lamps_play_the_same_mask_period_and_duty_in_the_scan_and_in_the_module() {
    let case = lamps_case("lamps", POLLED);
    let (never, auto, bound) = plans(&case);
    assert_eq!(
        pushed(&auto),
        vec![
            ("warn".to_string(), true),
            ("slow".to_string(), true),
            ("beacon".to_string(), true)
        ]
    );
    // Without `blink_phase: free` the BLINK stays central, saying why.
    assert!(pushed(&never).iter().all(|(_, p)| !p));
    // X1 on at 1.05 s for 8 s, X2 untouched.
    let enable_at = ms(1050);
    let inputs = [press(1050, 8000), vec![]];
    let latency = ms(20); // X1's power-on XLATUP
    let write = bound - ms(case.period_ms); // a cycle's write phase, give or take
    let mut traces = Vec::new();
    for project in [never.clone(), auto.clone()] {
        machine::replace();
        let mm1 = module("minimod", 1);
        let clock = Arc::new(VirtualClock::new());
        let mut s = Session::start(&case, project, &clock, &inputs);
        s.run_until(ms(5000));
        // Pushed down, the tag shows the enable (the module's status does not show a blinking
        // output); centrally it shows the lamp.
        let warn = s.plc.image().id("warn").unwrap();
        let pushed_down = s.plc.plan().is_pushed(warn);
        if pushed_down {
            assert_eq!(s.plc.image().get(warn), Value::Bool(true), "the enable");
            assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(FAST)));
            assert_eq!(mm1.get("YLAMP2"), Ok(Value::U16(SLOW)));
            assert_eq!(mm1.get("YLAMP3"), Ok(Value::U16(FAST)), "BLINK 400/400");
        }
        s.run_until(ms(11_000));
        if pushed_down {
            assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(0)), "0 once disabled");
            assert_eq!(s.plc.image().get(warn), Value::Bool(false));
        }
        traces.push(s.trace());
    }
    let end = ms(9050) + latency;
    for (j, (name, on, off, mask)) in [
        ("warn", 400, 400, FAST),
        ("slow", 800, 800, SLOW),
        ("beacon", 400, 400, FAST),
    ]
    .into_iter()
    .enumerate()
    {
        let (central, module) = (&traces[0][j], &traces[1][j]);
        // The module's steps to its tick; the scan's on its boundaries, each written within
        // the write phase of its cycle.
        let n_module = steady(
            &format!("{name} pushed"),
            module,
            enable_at,
            end,
            on,
            off,
            ms(2),
        );
        let n_central = steady(
            &format!("{name} central"),
            central,
            enable_at,
            end,
            on,
            off,
            write,
        );
        assert!(
            n_module.abs_diff(n_central) <= 1,
            "{name}: {n_module} runs pushed down, {n_central} central"
        );
        // The first on-step after the enable: within the enable's way to the write and the
        // mask's longest off-run plus a step (the BLINK's central one is on at once).
        let first = |trace: &[Edge]| trace.iter().find(|e| e.1 && e.0 >= enable_at).map(|e| e.0);
        let within = latency + bound + first_on_within(mask).unwrap();
        for (how, trace) in [("pushed", module), ("central", central)] {
            let t = first(trace).unwrap_or_else(|| panic!("{name} {how}: never on"));
            assert!(
                t - enable_at <= within,
                "{name} {how}: first on at {t:?}, bound {within:?}"
            );
        }
        // Off within a reaction of the enable's fall, in both.
        for (how, trace) in [("pushed", module), ("central", central)] {
            let last = trace.last().unwrap();
            assert!(
                !last.1 && last.0 <= end + bound + ms(2),
                "{name} {how}: off after the enable fell: {last:?}"
            );
        }
    }
    // One phase per module: the slow lamp's rises are the fast one's, in both builds; the
    // pushed-down BLINK is the fast LAMP, edge for edge.
    for (how, t) in [("central", &traces[0]), ("pushed", &traces[1])] {
        assert!(
            rises_together(&t[1], &t[0], ms(2)),
            "{how}: slow {:?} fast {:?}",
            t[1],
            t[0]
        );
    }
    let (warn, beacon) = (&traces[1][0], &traces[1][2]);
    assert_eq!(warn.len(), beacon.len());
    for (w, b) in warn.iter().zip(beacon) {
        assert!(
            w.1 == b.1 && w.0.abs_diff(b.0) <= ms(1),
            "{warn:?}\n{beacon:?}"
        );
    }
}

#[test]
fn a_lamp_after_kill_9_and_a_clean_stop() {
    let case = lamps_case("lamp-restart", POLLED);
    machine::replace();
    let mm1 = module("minimod", 1);
    let clock = Arc::new(VirtualClock::new());
    // Enabled from 0.5 s to past the kill.
    let mut a = Session::start(&case, case.project("auto"), &clock, &[press(500, 5000)]);
    a.run_until(ms(1500));
    assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(FAST)));
    drop(a); // kill -9: the mask stays in the module
    assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(FAST)));
    // The enable is released while no PLC runs.
    mm1.clone().set("X1", Value::Bool(false)).unwrap();
    clock.sleep_until(clock.now() + ms(2000));
    // The restart with the enable off: the start-up clears the blinker, the output stays off.
    let mut b = Session::start(&case, case.project("auto"), &clock, &[press(1000, 1000)]);
    assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(0)), "cleared at start-up");
    b.run_until(ms(900));
    assert!(
        after(&b.trace()[0], ms(0)).is_empty(),
        "off until enabled: {:?}",
        b.trace()[0]
    );
    // Enabled at 1 s: it blinks again, then stops with the enable.
    b.run_until(ms(3000));
    let warn = after(&b.trace()[0], ms(0));
    assert!(warn.iter().filter(|e| e.1).count() >= 2, "{warn:?}");
    assert!(
        warn.last().is_some_and(|e| !e.1 && e.0 <= ms(2300)),
        "{warn:?}"
    );
    // Enabled once more, then a clean stop: the mask is cleared and the output safe (off).
    let mut c = Session::start(&case, case.project("auto"), &clock, &[press(200, 5000)]);
    c.run_until(ms(1000));
    assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(FAST)));
    c.stop();
    assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(0)), "cleared at stop");
    mm1.clone()
        .advance_to(clock.now().on_line_clock() + ms(1600));
    assert!(!level(&mm1, "Y1"), "the safe value");
}

#[test]
fn a_lamp_through_a_bus_loss() {
    // The module's own watchdog is off: this is about the line.
    let case = lamps_case(
        "lamp-bus-loss",
        &["name: mm1, model: minimod, address: 1, settings: { WDTTIME: 0, events: false }"],
    );
    let mut traces = Vec::new();
    for mode in ["never", "auto"] {
        machine::replace();
        let mm1 = module("minimod", 1);
        let clock = Arc::new(VirtualClock::new());
        // Enabled from 1 s to 12 s; the line is dead from 3 s to 5 s.
        let mut s = Session::start(&case, case.project(mode), &clock, &[press(1000, 11_000)]);
        s.run_until(ms(3000));
        s.world(|w| w.faults_mut().set_dead(0, true));
        s.run_until(ms(5000));
        s.world(|w| w.faults_mut().set_dead(0, false));
        s.run_until(ms(14_000));
        if mode == "auto" {
            assert_eq!(
                mm1.get("YLAMP1"),
                Ok(Value::U16(0)),
                "{mode}: disabled at 12 s"
            );
        }
        traces.push(s.trace().remove(0));
    }
    let on_runs = |t: &[Edge], from: u64, to: u64| runs(t, ms(from), ms(to)).len();
    let (central, module) = (&traces[0], &traces[1]);
    // Central: the scan cannot write while the line is dead, so the lamp freezes.
    assert!(
        on_runs(central, 3400, 4800) == 0,
        "central frozen: {central:?}"
    );
    // Pushed down: the module blinks on by itself while the line is dead.
    assert!(
        on_runs(module, 3000, 5000) >= 2,
        "pushed blinks on: {module:?}"
    );
    // After the line is back the module gets its whole start-up again, which clears its
    // blinker; the mask is written again after it (within the reconnect backoff), so the
    // lamp blinks until the enable falls, in both.
    for (how, t) in [("central", central), ("pushed", module)] {
        assert!(on_runs(t, 8000, 12_100) >= 4, "{how}: blinks again: {t:?}");
        assert!(
            t.last().is_some_and(|e| !e.1 && e.0 < ms(12_500)),
            "{how}: {t:?}"
        );
    }
}

#[test]
fn a_force_overrides_a_pushed_down_lamp() {
    let case = lamps_case("lamp-force", POLLED);
    let bound = plans(&case).2;
    let mut traces = Vec::new();
    for mode in ["never", "auto"] {
        machine::replace();
        let mm1 = module("minimod", 1);
        let clock = Arc::new(VirtualClock::new());
        // Enabled from 0.5 s to 9 s; warn forced on from 2 s to 4 s, off from 4 s to 6 s.
        let mut s = Session::start(&case, case.project(mode), &clock, &[press(500, 8500)]);
        s.run_until(ms(2000));
        s.plc
            .force("warn", "1")
            .unwrap_or_else(|e| panic!("{mode}: {e}"));
        s.run_until(ms(4000));
        if mode == "auto" {
            assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(0)), "cleared while forced");
            assert_eq!(mm1.get("YLAMP2"), Ok(Value::U16(SLOW)), "the others run on");
        }
        s.plc.force("warn", "0").unwrap();
        s.run_until(ms(6000));
        s.plc.unforce(Some("warn")).unwrap();
        s.run_until(ms(8000));
        if mode == "auto" {
            assert_eq!(mm1.get("YLAMP1"), Ok(Value::U16(FAST)), "restored");
        }
        traces.push(s.trace().remove(0));
    }
    for (how, t) in [("central", &traces[0]), ("pushed", &traces[1])] {
        let held = |from: u64, to: u64| {
            after(t, ms(from) + bound)
                .into_iter()
                .filter(move |e| e.0 < ms(to))
        };
        assert_eq!(held(2000, 4000).count(), 0, "{how}: on while forced: {t:?}");
        assert!(level_before(t, ms(3900)), "{how}: forced on");
        assert_eq!(
            held(4000, 6000).count(),
            0,
            "{how}: off while forced: {t:?}"
        );
        assert!(!level_before(t, ms(5900)), "{how}: forced off");
        assert!(
            runs(t, ms(6000), ms(8000)).len() >= 2,
            "{how}: blinks after the unforce: {t:?}"
        );
    }
}

#[test]
fn the_warning_lamp_example_blinks_in_its_module_from_ladder_and_rhai() {
    let root = softplc_tests::workspace_root();
    let path = root.join("examples/warning_lamp/project.yaml");
    let ladder = project::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut rhai = ladder.clone();
    let program = softplc::project::ProgramConfig {
        path: root.join("programs/warning_lamp/warning_lamp.rhai"),
        kind: softplc::project::ProgramKind::Rhai,
    };
    rhai.set_programs(0, vec![program]);
    let case = loaded_case("warning-lamp", &["mm1.X1", "mm1.X2"], &["mm1.Y1"]);
    // The level high from 1 s to 7 s.
    let inputs = [press(1000, 6000), vec![]];
    for auto in [ladder, rhai] {
        let language = auto.programs[0].kind;
        assert_eq!(
            pushed(&auto),
            vec![("warning".to_string(), true), ("horn".to_string(), true)],
            "{language:?}"
        );
        let mut never = auto.clone();
        never.offload.mode = softplc::project::OffloadMode::Never;
        for t in &mut never.offload.tags {
            t.mode = None; // the example says `require`
        }
        let central = run(&case, never, &inputs, ms(9000)).remove(0);
        let module = run(&case, auto, &inputs, ms(9000)).remove(0);
        let (from, to) = (ms(1000), ms(7020));
        let name = format!("{language:?}");
        let n = steady(
            &format!("{name} pushed"),
            &module,
            from,
            to,
            400,
            400,
            ms(2),
        );
        let c = steady(
            &format!("{name} central"),
            &central,
            from,
            to,
            400,
            400,
            ms(30),
        );
        assert!(n.abs_diff(c) <= 1, "{name}: {n} vs {c} on-runs");
    }
}
