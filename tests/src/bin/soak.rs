//! The soak: a project on the virtual line with faults injected at a steady rate, for as long
//! as asked (an hour of scan time by default; on the virtual clock that takes a few minutes).
//! At the end it checks: no wrong value ever reached the process image with good quality, no
//! output change was lost, and memory stayed flat.
//!
//! ```text
//! cargo run --release -p softplc-tests --bin soak -- --for 1h --fault-rate 0.02
//! ```
//!
//! Each MiniMod's X1 is toggled by the soak every 12 s; the program copies it to Y1
//! (`out_k = in_k`). Faults (every kind of `softplc_io::sim::fault`) hit each reply with the
//! given probability. On top of them, the transients a machine meets: the whole line dies for
//! 3 s every 3 minutes, a module is power-cycled every 47 s, and every 10 minutes the PLC is
//! killed as `kill -9` would (no safe state) and started again on the same modules 2 s later.
//! The PLC must never stop on its own.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use softplc::clock::{Clock, VirtualClock};
use softplc::image::TagId;
use softplc::plc::Plc;
use softplc::project;
use softplc::scan::ScanEngine;
use softplc_io::point::{Quality, Value};
use softplc_io::sim::{Fault, FaultRule, Frequency};

const TOGGLE_EVERY: Duration = Duration::from_secs(12);
/// Longest time an input change may take to show as a good value: the module's 20 ms input
/// latency plus two cycles (one may fail and be retried next cycle).
const SETTLE: Duration = Duration::from_millis(20 + 2 * 100 + 100);
/// The same where a line in event mode (the MiniMods' default plan) hears silence it cannot
/// tell from an idle round (docs/buses.md, "Event mode"): a change while the line is dead shows as
/// stale only at the next write or full read, within `event_refresh` (1 s); and after a power
/// cycle too short to be seen as a loss the module is back on its saved settings, event
/// recording off, so its next change shows at its next full read, within `event_refresh`.
/// The start-up then runs again only on the module's own evidence of a power-up (its XEVMASK
/// read back the next cycle at the power-on value, `devices/minimod/driver/lost_events.rs`),
/// two cycles after that read, so it never holds the value back: the bound is the latency,
/// `event_refresh`, and three cycles in which a faulty line may fail that full read and its
/// repeat. That is the bound of event mode, checked here; the same change on a line that
/// merely lost the event is repaired by the same full read, with no start-up.
const SETTLE_IN_SILENCE: Duration = Duration::from_millis(20 + 1000 + 3 * 100 + 100);
/// Longest time an output change may take to reach the module under faults: a lost module is
/// retried after at most a few seconds of backoff at these rates.
const DELIVER: Duration = Duration::from_secs(10);
/// The line dies for [`LINE_DEAD_FOR`] this often.
const LINE_DEATH_EVERY: Duration = Duration::from_secs(180);
const LINE_DEAD_FOR: Duration = Duration::from_secs(3);
/// One module is power-cycled this often (in turn).
const POWER_CYCLE_EVERY: Duration = Duration::from_secs(47);
/// The PLC is killed and restarted this often, after [`RESTART_GAP`] with no host.
const RESTART_EVERY: Duration = Duration::from_secs(600);
const RESTART_GAP: Duration = Duration::from_secs(2);

struct Args {
    run_for: Duration,
    rate: f64,
    modules: usize,
}

fn args() -> anyhow::Result<Args> {
    let mut a = Args {
        run_for: Duration::from_secs(3600),
        rate: 0.02,
        modules: 4,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let value = it.next().with_context(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--for" => {
                a.run_for = softplc::cli::parse_duration(&value).map_err(anyhow::Error::msg)?
            }
            "--fault-rate" => {
                a.rate = value
                    .parse()
                    .context("--fault-rate takes a probability 0..1")?
            }
            "--modules" => a.modules = value.parse().context("--modules takes a number 1..16")?,
            _ => bail!("unknown option {flag}; options: --for 1h --fault-rate 0.02 --modules 4"),
        }
    }
    if !(0.0..=1.0).contains(&a.rate) || !(1..=16).contains(&a.modules) {
        bail!("--fault-rate must be 0..1 and --modules 1..16");
    }
    Ok(a)
}

fn project_text(modules: usize) -> String {
    let mut s = String::from(
        "project: soak\nscan: { period: 100ms, watchdog: { time: 2s, sensitivity: 5 } }\n\
         buses:\n  - { name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }\nmodules:\n",
    );
    for k in 1..=modules {
        s += &format!("  - {{ name: mm{k}, bus: line1, model: minimod, address: {k} }}\n");
    }
    s += "tags:\n";
    for k in 1..=modules {
        s += &format!("  - {{ name: in{k}, point: mm{k}.X1 }}\n  - {{ name: out{k}, point: mm{k}.Y1, safe: false }}\n");
    }
    s += "program: { file: soak.expr, kind: expr }\n";
    s
}

fn rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| {
            s.split_whitespace()
                .nth(1)
                .and_then(|p| p.parse::<u64>().ok())
        })
        .map_or(0, |pages| pages * 4)
}

/// An output change to check: module, level, when to check, when it was made.
type Due = (usize, bool, Duration, Duration);

#[derive(Default)]
struct Tally {
    cycles: u64,
    checked_values: u64,
    wrong_values: u64,
    output_changes: u64,
    lost_changes: u64,
    rss_early: u64,
}

fn main() -> anyhow::Result<()> {
    let args = args()?;
    let dir = std::env::temp_dir().join(format!("softplc-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let program: String = (1..=args.modules)
        .map(|k| format!("out{k} = in{k}\n"))
        .collect();
    std::fs::write(dir.join("soak.expr"), program)?;
    let file = dir.join("project.yaml");
    std::fs::write(&file, project_text(args.modules))?;
    let project = project::load(&file).map_err(|e| anyhow::anyhow!("{e}"))?;
    let clock = Arc::new(VirtualClock::new());
    let plc = Plc::build(project.clone(), clock.clone()).context("building the soak PLC")?;
    let world = plc.world().context("the soak runs on port: sim")?.clone();
    {
        let mut w = world.lock().unwrap_or_else(|e| e.into_inner());
        let kinds = [
            Fault::FlipBit,
            Fault::Truncate { keep: 3 },
            Fault::Late {
                by: Duration::from_millis(80),
            },
            Fault::Duplicate,
            Fault::WrongAddress { unit: 99 },
            Fault::Garbage { bytes: 6 },
            Fault::Babble { bytes: 10 },
            Fault::Silent,
        ];
        for fault in kinds {
            let rate = args.rate / kinds.len() as f64;
            w.faults_mut().add(FaultRule {
                device: None,
                fault,
                frequency: Frequency::Rate(rate),
            });
        }
    }
    let ids: Vec<(TagId, TagId)> = (1..=args.modules)
        .map(|k| {
            let id = |n: String| plc.image().id(&n).expect("tag from the generated project");
            (id(format!("in{k}")), id(format!("out{k}")))
        })
        .collect();

    let tally = Arc::new(Mutex::new(Tally::default()));
    // Per module: the level set, when it was set, the level before; and output changes due.
    let levels = Arc::new(Mutex::new(vec![
        (false, Duration::ZERO, false);
        args.modules
    ]));
    // Output changes to check: module, level, when, and when it was made.
    let due: Arc<Mutex<VecDeque<Due>>> = Arc::new(Mutex::new(VecDeque::new()));
    // Per module: when it was last power-cycled.
    let cycled = Arc::new(Mutex::new(vec![None::<Duration>; args.modules]));
    let run_for = args.run_for;
    let modules = args.modules;
    let transients = Arc::new(Mutex::new((0u64, 0u64)));
    let make_hook = |tally: Arc<Mutex<Tally>>| {
        let levels = levels.clone();
        let due = due.clone();
        let ids = ids.clone();
        let transients = transients.clone();
        let cycled = cycled.clone();
        Box::new(move |plc: &Plc, ctx: &softplc::logic::ScanContext| {
            let hook_tally = &tally;
            // The soak keeps its bookkeeping as time since the PLC's start.
            let now = ctx.now.since_origin();
            let mut t = hook_tally.lock().unwrap_or_else(|e| e.into_inner());
            let mut lv = levels.lock().unwrap_or_else(|e| e.into_inner());
            let mut due = due.lock().unwrap_or_else(|e| e.into_inner());
            t.cycles += 1;
            if t.rss_early == 0 && now >= run_for / 10 {
                t.rss_early = rss_kib();
            }
            let Some(world) = plc.world() else { return };
            let mut w = world.lock().unwrap_or_else(|e| e.into_inner());
            // The transients, for the next cycle.
            let next = now + Duration::from_millis(100);
            let in_death = next.as_millis() % LINE_DEATH_EVERY.as_millis() >= 60_000
                && next.as_millis() % LINE_DEATH_EVERY.as_millis()
                    < 60_000 + LINE_DEAD_FOR.as_millis();
            if in_death != w.faults().is_dead(0) {
                w.faults_mut().set_dead(0, in_death);
                if in_death {
                    transients.lock().unwrap_or_else(|e| e.into_inner()).0 += 1;
                }
            }
            if next.as_millis() % POWER_CYCLE_EVERY.as_millis() < 100 {
                let k = (next.as_millis() / POWER_CYCLE_EVERY.as_millis()) as usize % modules;
                let before = w.get(k, "X1");
                if let Some(d) = w.device_mut(k) {
                    d.command(&["power-cycle"])
                        .expect("a MiniMod simulator takes power-cycle");
                    if std::env::var_os("SOAK_DEBUG").is_some() {
                        eprintln!(
                            "power-cycle mm{} at {now:?}: X1 {before:?} -> {:?}",
                            k + 1,
                            d.get("X1")
                        );
                    }
                    cycled.lock().unwrap_or_else(|e| e.into_inner())[k] = Some(next);
                    transients.lock().unwrap_or_else(|e| e.into_inner()).1 += 1;
                }
            }
            for (k, (in_id, _)) in ids.iter().enumerate() {
                let slot = plc.image().slot(*in_id);
                let (level, since, before) = lv[k];
                // For its input latency after a power cycle the module itself reports its
                // inputs off ("Digital inputs, latencies and counters": 20 ms at power-on):
                // what it says then is right, whatever the terminal.
                let powering_up = cycled.lock().unwrap_or_else(|e| e.into_inner())[k]
                    .is_some_and(|t| now.saturating_sub(t) < SETTLE);
                if slot.quality == Quality::Good && !powering_up {
                    t.checked_values += 1;
                    // The first change after the module's last power cycle (the next toggle
                    // comes within TOGGLE_EVERY) or while the line is dead may take longer.
                    let after_cycle = cycled.lock().unwrap_or_else(|e| e.into_inner())[k]
                        .is_some_and(|c| since >= c && since - c < TOGGLE_EVERY);
                    let in_death = (since.as_millis() % LINE_DEATH_EVERY.as_millis())
                        .checked_sub(60_000)
                        .is_some_and(|into| into < LINE_DEAD_FOR.as_millis());
                    let settle = if after_cycle || in_death {
                        SETTLE_IN_SILENCE
                    } else {
                        SETTLE
                    };
                    let ok = slot.value == Value::Bool(level)
                        || (now.saturating_sub(since) < settle
                            && slot.value == Value::Bool(before));
                    if !ok {
                        t.wrong_values += 1;
                        eprintln!(
                            "wrong: mm{} X1 {:?} at {now:?}, the terminal {level} since {since:?}: {slot:?} {:?}",
                            k + 1,
                            slot.value,
                            plc.module_status()[k]
                        );
                    }
                }
                // Staggered toggles, so the modules do not all change in one cycle.
                let phase = TOGGLE_EVERY * k as u32 / ids.len().max(1) as u32;
                if now >= phase && now.saturating_sub(since) >= TOGGLE_EVERY {
                    let new = !level;
                    w.set(k, "X1", Value::Bool(new))
                        .expect("the generated MiniMods have an X1 terminal");
                    // On the virtual clock a busy line (restarting modules after an outage)
                    // runs ahead of the scan: the terminal changes at the world's time.
                    lv[k] = (new, now.max(w.now().since_origin()), level);
                    due.push_back((k, new, now + DELIVER, now));
                    t.output_changes += 1;
                }
            }
            let mut later = Vec::new();
            while let Some(&(k, level, deadline, made)) = due.front() {
                if now < deadline {
                    break;
                }
                due.pop_front();
                // A newer change of the module supersedes this one (a check put off by an
                // outage or a power cycle can come after the next toggle).
                if made < lv[k].1 {
                    continue;
                }
                // A module that is not good now (lost in an outage, restarting) or was
                // power-cycled in the last output refresh period cannot hold it yet: check
                // again later, for at most a minute after the change.
                let just_cycled = cycled.lock().unwrap_or_else(|e| e.into_inner())[k]
                    .is_some_and(|t| now.saturating_sub(t) < Duration::from_secs(2));
                let unsettled = plc.module_status()[k].quality != Quality::Good || just_cycled;
                if unsettled && now.saturating_sub(made) < Duration::from_secs(60) {
                    later.push((k, level, now + Duration::from_secs(5), made));
                    continue;
                }
                // By now the program's copy of the input must be on the module's terminal.
                if w.get(k, "Y1").ok() != Some(Value::Bool(level)) {
                    t.lost_changes += 1;
                    eprintln!(
                        "lost: mm{} Y1 {level} due {deadline:?}, at {now:?}; in {:?} out {:?} X1 {:?} Y1 {:?}; {:?}",
                        k + 1,
                        plc.image().slot(ids[k].0),
                        plc.image().slot(ids[k].1),
                        w.get(k, "X1"),
                        w.get(k, "Y1"),
                        plc.module_status()[k]
                    );
                }
            }
            // A newer change of the same module supersedes a re-checked one.
            for item in later {
                if !due.iter().any(|d| d.0 == item.0) {
                    due.push_back(item);
                }
            }
        }) as softplc::scan::CycleHook
    };
    let started = Instant::now();
    // Segments between kills: each ends as kill -9 would, the next starts on the same modules.
    let mut plc = plc;
    let mut restarts = 0u64;
    let outcome = loop {
        let segment = RESTART_EVERY.min(args.run_for.saturating_sub(clock.now().since_origin()));
        let last = clock.now().since_origin() + segment >= args.run_for;
        let mut engine = ScanEngine::new(plc)
            .run_for(segment)
            .on_cycle(make_hook(tally.clone()));
        if !last {
            engine = engine.abandon_at_end();
        }
        let outcome = engine.run();
        if outcome.reason != softplc::scan::StopReason::TimeUp {
            bail!("the PLC stopped on its own: {:?}", outcome.reason);
        }
        if last {
            break outcome;
        }
        drop(engine);
        restarts += 1;
        let resume = clock.now() + RESTART_GAP;
        world
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .advance_to(resume.on_line_clock());
        clock.advance_to(resume);
        plc = Plc::build_on(project.clone(), clock.clone(), Some(world.clone()))
            .context("restarting the soak PLC after its kill")?;
    };
    let rss_end = rss_kib();
    let t = tally.lock().unwrap_or_else(|e| e.into_inner());
    let applied = world
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .faults()
        .applied;
    // Best effort: the soak's scratch folder.
    drop(std::fs::remove_dir_all(&dir));
    let growth = if t.rss_early > 0 {
        rss_end as f64 / t.rss_early as f64 - 1.0
    } else {
        0.0
    };
    println!(
        "soak: {} of scan time in {:.1?} ({} modules, fault rate {}): {} cycles, {} faults injected, {} bus errors counted",
        clock.now(),
        started.elapsed(),
        args.modules,
        args.rate,
        t.cycles,
        applied,
        outcome.stats.bus_errors
    );
    let (deaths, cycles) = *transients.lock().unwrap_or_else(|e| e.into_inner());
    println!(
        "  transients: {deaths} line deaths of {}, {cycles} module power cycles, {restarts} kill -9 and restarts",
        softplc::scan::fmt_duration(LINE_DEAD_FOR)
    );
    println!(
        "  values checked {}  wrong {}   output changes {}  lost {}   memory {} KiB at 10% → {} KiB at the end ({:+.1}%)",
        t.checked_values, t.wrong_values, t.output_changes, t.lost_changes, t.rss_early, rss_end, growth * 100.0
    );
    for m in &outcome.modules {
        let c = &m.counters;
        println!(
            "  {}: {} requests, {} timeouts, {} crc, {} bad replies, {} dropped bytes",
            m.name, c.requests, c.timeouts, c.crc_errors, c.bad_replies, c.dropped_bytes
        );
    }
    if t.wrong_values > 0 || t.lost_changes > 0 || growth > 0.10 {
        bail!("soak failed");
    }
    println!("soak passed");
    Ok(())
}
