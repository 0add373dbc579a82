//! Runs a scenario on a virtual clock against the project's simulated modules.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc_io::point::Value;
use softplc_io::sim::plant::{PlantHealth, StateValue};
use softplc_io::sim::SharedWorld;

use super::scenario::{Expect, FaultStep, PlantExpect, ProgramSpec, Scenario, SetInput};
use super::trace::Change;
use crate::clock::VirtualClock;
use crate::plc::Plc;
use crate::project::ProgramConfig;
use crate::scan::{ScanEngine, StopReason};

/// What one run found.
#[derive(Debug, Clone, Default)]
pub(crate) struct RunResult {
    /// The trace of the watched tags.
    pub trace: Vec<Change>,
    /// Failed expectations and other failures, one line each.
    pub failures: Vec<String>,
    /// Expectations checked.
    pub checked: usize,
    /// Scans run.
    pub scans: u64,
}

/// Scenario state shared with the cycle hook.
struct HookState {
    sets: Vec<(SetInput, Option<usize>)>,
    next_set: usize,
    expects: Vec<Expect>,
    next_expect: usize,
    watch: Vec<(usize, String)>,
    last: Vec<Option<Value>>,
    result: RunResult,
    world: Option<SharedWorld>,
    period: Duration,
    faults: Vec<FaultStep>,
    next_fault: usize,
    plant_expects: Vec<PlantExpect>,
    next_plant_expect: usize,
    watch_states: Vec<String>,
    last_states: Vec<Option<Value>>,
    /// The plant stopped on an error (reported once).
    plant_stopped: bool,
}

impl HookState {
    /// Applies every input due at or before `t`.
    fn apply_sets(&mut self, t: Duration) {
        while let Some((s, dev)) = self.sets.get(self.next_set) {
            if s.at > t {
                break;
            }
            let done = match (self.world.as_ref(), dev) {
                (Some(w), Some(d)) => {
                    let mut w = w.lock().unwrap_or_else(|p| p.into_inner());
                    w.set(*d, &s.point, s.value).map_err(|e| e.to_string())
                }
                _ => Err("no simulated module".to_string()),
            };
            if let Err(e) = done {
                let msg = format!("at {}: cannot set {}: {e}", secs(s.at), s.tag);
                self.result.failures.push(msg);
            }
            self.next_set += 1;
        }
    }

    /// Switches every plant fault due at or before `t`.
    fn apply_faults(&mut self, t: Duration) {
        while let Some(f) = self.faults.get(self.next_fault) {
            if f.at > t {
                break;
            }
            let done = match self.world.as_ref() {
                Some(w) => {
                    let mut w = w.lock().unwrap_or_else(|p| p.into_inner());
                    match w.plant_mut() {
                        Some(plant) => plant.set_fault(&f.fault, f.on).map_err(|e| e.to_string()),
                        None => Err("no plant".to_string()),
                    }
                }
                None => Err("no simulated world".to_string()),
            };
            if let Err(e) = done {
                let msg = format!("at {}: cannot switch fault {}: {e}", secs(f.at), f.fault);
                self.result.failures.push(msg);
            }
            self.next_fault += 1;
        }
    }

    /// The plant's states, its health, as the world holds them now.
    fn plant_now(&self) -> Option<(Vec<(String, StateValue)>, PlantHealth)> {
        let w = self
            .world
            .as_ref()?
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        let plant = w.plant()?;
        Some((plant.states(), plant.health()))
    }

    /// Plant states into the trace, plant expectations due before `next`, a stopped plant.
    fn plant_cycle(&mut self, now: Duration, next: Duration) {
        let Some((states, health)) = self.plant_now() else {
            return;
        };
        let value_of = |name: &str| states.iter().find(|(n, _)| n == name).map(|(_, v)| *v);
        for (k, name) in self.watch_states.iter().enumerate() {
            let v = value_of(name).map(state_as_value);
            if self.last_states[k] != v {
                self.last_states[k] = v;
                if let Some(value) = v {
                    self.result.trace.push(Change {
                        at: now,
                        tag: format!("plant.{name}"),
                        value,
                    });
                }
            }
        }
        while let Some(e) = self.plant_expects.get(self.next_plant_expect) {
            if e.at >= next {
                break;
            }
            self.result.checked += 1;
            match value_of(&e.state) {
                Some(v) if e.cmp.holds(v) => {}
                got => self.result.failures.push(format!(
                    "at {} (line {}): plant.{} expected {}, got {}",
                    secs(e.at),
                    e.line,
                    e.state,
                    e.cmp,
                    got.map_or_else(|| "nothing".to_owned(), |v| v.to_string())
                )),
            }
            self.next_plant_expect += 1;
        }
        if let (PlantHealth::Stopped(why), false) = (health, self.plant_stopped) {
            self.plant_stopped = true;
            self.result
                .failures
                .push(format!("at {}: the plant stopped: {why}", secs(now)));
        }
    }

    fn cycle(&mut self, plc: &Plc, now: Duration) {
        self.result.scans += 1;
        let image = plc.image();
        for (k, (t, name)) in self.watch.iter().enumerate() {
            let v = image.get(crate::image::TagId(*t as u32));
            if self.last[k] != Some(v) {
                self.last[k] = Some(v);
                self.result.trace.push(Change {
                    at: now,
                    tag: name.clone(),
                    value: v,
                });
            }
        }
        // The state at time T is the state after the last scan that starts at or before T.
        let next = now + self.period;
        while let Some(e) = self.expects.get(self.next_expect) {
            if e.at >= next {
                break;
            }
            let got = image.get(crate::image::TagId(e.tag as u32));
            self.result.checked += 1;
            if got != e.value {
                let name = image.name(crate::image::TagId(e.tag as u32)).to_string();
                let since = self
                    .result
                    .trace
                    .iter()
                    .rev()
                    .find(|c| c.tag == name)
                    .map(|c| format!(" (since {})", secs(c.at)))
                    .unwrap_or_default();
                self.result.failures.push(format!(
                    "at {} (line {}): {name} expected {}, got {got}{since}",
                    secs(e.at),
                    e.line,
                    e.value
                ));
            }
            self.next_expect += 1;
        }
        self.plant_cycle(now, next);
        self.apply_sets(next);
        self.apply_faults(next);
    }
}

/// A plant state as a trace shows it (a float state as the f32 a tag would hold).
fn state_as_value(v: StateValue) -> Value {
    match v {
        StateValue::Bool(b) => Value::Bool(b),
        StateValue::Int(i) => Value::I32(i.clamp(i32::MIN.into(), i32::MAX.into()) as i32),
        StateValue::Float(x) => Value::F32(x as f32),
    }
}

/// `12.3s`.
pub(crate) fn secs(d: Duration) -> String {
    format!("{}s", d.as_secs_f64())
}

/// A retain file path of our own, so a test never touches the project's file.
fn temp_retain() -> PathBuf {
    static N: AtomicU64 = AtomicU64::new(0);
    std::env::temp_dir().join(format!(
        "softplc-test-{}-{}.retain.json",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ))
}

/// Runs `sc` with `program` (or the project's own).
pub(crate) fn run(sc: &Scenario, program: Option<&ProgramSpec>) -> RunResult {
    let mut project = sc.project.clone();
    if let Some(p) = program {
        project.program = ProgramConfig {
            path: p.path.clone(),
            kind: p.kind,
        };
    }
    if !sc.plant {
        project.plant = None;
    }
    let retain_file = temp_retain();
    // Best effort: a scratch retain file, absent unless the scenario retained values.
    drop(std::fs::remove_file(&retain_file));
    project.retain.file = retain_file.clone();
    let period = project.scan.period;
    let watch = sc
        .watch
        .iter()
        .map(|&t| (t, project.tags[t].name.clone()))
        .collect::<Vec<_>>();
    let plc = match Plc::build(project, Arc::new(VirtualClock::new())) {
        Ok(p) => p,
        Err(e) => {
            return RunResult {
                failures: vec![format!("cannot start: {e}")],
                ..RunResult::default()
            }
        }
    };
    // Scenario time starts with the first scan, however long the modules' start-up took.
    let origin = plc.clock().now();
    let world = plc.world().cloned();
    let sets = sc
        .sets
        .iter()
        .map(|s| {
            let dev = world
                .as_ref()
                .and_then(|w| w.lock().unwrap_or_else(|p| p.into_inner()).find(&s.module));
            (s.clone(), dev)
        })
        .collect();
    let mut state = HookState {
        sets,
        next_set: 0,
        expects: sc.expects.clone(),
        next_expect: 0,
        last: vec![None; watch.len()],
        watch,
        result: RunResult::default(),
        world,
        period,
        faults: sc.faults.clone(),
        next_fault: 0,
        plant_expects: sc.plant_expects.clone(),
        next_plant_expect: 0,
        last_states: vec![None; sc.watch_states.len()],
        watch_states: sc.watch_states.clone(),
        plant_stopped: false,
    };
    state.apply_sets(Duration::ZERO);
    state.apply_faults(Duration::ZERO);
    let state = Arc::new(Mutex::new(state));
    let hook_state = state.clone();
    let mut engine = ScanEngine::new(plc)
        .run_for(sc.until)
        .on_cycle(Box::new(move |plc, ctx| {
            hook_state
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .cycle(plc, ctx.now.saturating_duration_since(origin));
        }));
    let outcome = engine.run();
    drop(engine);
    let mut st = state.lock().unwrap_or_else(|p| p.into_inner());
    let mut result = std::mem::take(&mut st.result);
    match outcome.reason {
        StopReason::Requested | StopReason::TimeUp => {}
        other => result.failures.push(format!("the PLC stopped: {other:?}")),
    }
    let plant_left = st
        .plant_expects
        .iter()
        .skip(st.next_plant_expect)
        .map(|e| (e.at, e.line));
    let left: Vec<(Duration, usize)> = st
        .expects
        .iter()
        .skip(st.next_expect)
        .map(|e| (e.at, e.line))
        .chain(plant_left)
        .collect();
    for (at, line) in left {
        result.failures.push(format!(
            "at {} (line {line}): not reached (the run ends at {})",
            secs(at),
            secs(sc.until)
        ));
    }
    if !sc.retained.is_empty() {
        check_retained(sc, &retain_file, &mut result);
    }
    // Best effort: a scratch retain file, absent unless the scenario retained values.
    drop(std::fs::remove_file(&retain_file));
    result
}

/// Compares the retain file written at stop with the expected values.
fn check_retained(sc: &Scenario, file: &std::path::Path, result: &mut RunResult) {
    let text = std::fs::read_to_string(file).unwrap_or_default();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
    for (name, want) in &sc.retained {
        let got = doc.get("values").and_then(|v| v.get(name));
        let got_text = got.map_or_else(|| "nothing".to_string(), ToString::to_string);
        let want_text = match want {
            Value::Bool(b) => b.to_string(),
            other => other.to_string(),
        };
        if got_text != want_text {
            result.failures.push(format!(
                "retained {name}: expected {want_text}, the file holds {got_text}"
            ));
        }
    }
}
