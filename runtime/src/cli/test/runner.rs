//! Runs a scenario on a virtual clock against the project's simulated modules.

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc_io::point::Value;
use softplc_io::sim::plant::{PlantHealth, StateValue};
use softplc_io::sim::{Fault, FaultRule, Frequency, SharedWorld};

use super::alarms::ScenarioAlarms;
use super::scenario::{Expect, FaultStep, ModuleStep, PlantExpect, Scenario, SetInput};
use super::trace::Change;
use super::variants::ProgramVariant;
use crate::clock::VirtualClock;
use crate::logic::ScanContext;
use crate::plc::Plc;
use crate::scan::{ScanEngine, StopReason};
use crate::service::task_share::TaskShare;

/// What one run found.
#[derive(Debug, Clone, Default)]
pub(crate) struct RunResult {
    /// The trace of the watched tags.
    pub trace: Vec<Change>,
    /// Failed expectations and other failures, one line each.
    pub failures: Vec<String>,
    /// Expectations checked.
    pub checked: usize,
    /// Scans run (the first task's, with several tasks).
    pub scans: u64,
    /// With several tasks: each task's name and the scans it ran, in task order.
    pub task_scans: Vec<(String, u64)>,
}

/// Scenario state shared with the cycle hook.
struct HookState {
    /// Each input with the world and the device it is set on.
    sets: Vec<(SetInput, Option<(SharedWorld, usize)>)>,
    next_set: usize,
    expects: Vec<Expect>,
    next_expect: usize,
    watch: Vec<(usize, String)>,
    last: Vec<Option<Value>>,
    result: RunResult,
    period: Duration,
    /// The world the plant runs in, if any (faults, states, health).
    world: Option<SharedWorld>,
    faults: Vec<FaultStep>,
    next_fault: usize,
    plant_expects: Vec<PlantExpect>,
    next_plant_expect: usize,
    watch_states: Vec<String>,
    last_states: Vec<Option<Value>>,
    /// The plant stopped on an error (reported once).
    plant_stopped: bool,
    /// With several tasks: each tag's owning task (its value is read from that task's
    /// image, its expectations checked at that task's cycles), and each expectation checked.
    owners: Option<Vec<usize>>,
    checked: Vec<bool>,
    /// The tasks' names, in project order.
    task_names: Vec<String>,
    /// Modules silenced or answering again, with the world and the device.
    module_steps: Vec<(ModuleStep, Option<(SharedWorld, usize)>)>,
    next_module_step: usize,
    /// The alarm book and the scenario's alarm steps.
    alarms: Option<ScenarioAlarms>,
    /// With several tasks: per task, when its next cycle starts at the earliest (scenario
    /// time; `None` before its first cycle).
    next_starts: Vec<Option<Duration>>,
}

impl HookState {
    /// The state of a run of `sc` on the simulators in `worlds`, tracing `watch`, its
    /// inputs set ahead of the scans `period` apart.
    fn new(
        sc: &Scenario,
        worlds: &[SharedWorld],
        watch: Vec<(usize, String)>,
        period: Duration,
    ) -> Self {
        Self {
            sets: sc
                .sets
                .iter()
                .map(|s| (s.clone(), device_of(worlds, &s.module)))
                .collect(),
            next_set: 0,
            module_steps: sc
                .module_steps
                .iter()
                .map(|m| (m.clone(), device_of(worlds, &m.module)))
                .collect(),
            next_module_step: 0,
            expects: sc.expects.clone(),
            next_expect: 0,
            last: vec![None; watch.len()],
            watch,
            result: RunResult::default(),
            period,
            // With several tasks, the world of the task whose lines the plant is wired to.
            world: worlds
                .iter()
                .find(|w| {
                    w.lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .plant()
                        .is_some()
                })
                .or(worlds.first())
                .cloned(),
            faults: sc.faults.clone(),
            next_fault: 0,
            plant_expects: sc.plant_expects.clone(),
            next_plant_expect: 0,
            last_states: vec![None; sc.watch_states.len()],
            watch_states: sc.watch_states.clone(),
            plant_stopped: false,
            owners: None,
            checked: Vec::new(),
            task_names: Vec::new(),
            alarms: None,
            next_starts: Vec::new(),
        }
    }

    /// Applies every input due at or before `t`.
    fn apply_sets(&mut self, t: Duration) {
        while let Some((s, dev)) = self.sets.get(self.next_set) {
            if s.at > t {
                break;
            }
            let done = match dev {
                Some((w, d)) => {
                    let mut w = w.lock().unwrap_or_else(|p| p.into_inner());
                    w.set(*d, &s.point, s.value).map_err(|e| e.to_string())
                }
                None => Err("no simulated module".to_string()),
            };
            if let Err(e) = done {
                let msg = format!("at {}: cannot set {}: {e}", secs(s.at), s.tag);
                self.result.failures.push(msg);
            }
            self.next_set += 1;
        }
    }

    /// Silences or wakes every module due at or before `t`: a silent module answers nothing
    /// until it answers again.
    fn apply_module_steps(&mut self, t: Duration) {
        while let Some((m, dev)) = self.module_steps.get(self.next_module_step) {
            if m.at > t {
                break;
            }
            match dev {
                Some((w, d)) => {
                    let mut w = w.lock().unwrap_or_else(|p| p.into_inner());
                    let faults = w.faults_mut();
                    faults.clear(Some(*d));
                    if m.silent {
                        faults.add(FaultRule {
                            device: Some(*d),
                            fault: Fault::Silent,
                            frequency: Frequency::Always,
                        });
                    }
                }
                None => self.result.failures.push(format!(
                    "at {}: no simulated module {}",
                    secs(m.at),
                    m.module
                )),
            }
            self.next_module_step += 1;
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
                        value: value.into(),
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

    fn cycle(&mut self, plc: &Plc, ctx: &ScanContext, now: Duration) {
        if self.owners.is_some() {
            return self.task_cycle(plc, ctx, now);
        }
        self.result.scans += 1;
        let image = plc.image();
        for (k, (t, name)) in self.watch.iter().enumerate() {
            let v = image.get(crate::image::TagId(*t as u32));
            if self.last[k] != Some(v) {
                self.last[k] = Some(v);
                self.result.trace.push(Change {
                    at: now,
                    tag: name.clone(),
                    value: v.into(),
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
        if let Some(alarms) = &mut self.alarms {
            alarms.cycle(0, plc, ctx, now, next, &mut self.result);
        }
        self.apply_sets(next);
        self.apply_faults(next);
        self.apply_module_steps(next);
    }

    /// A cycle of task `plc` (several tasks) starting at `now`: the tags it owns are traced
    /// and checked from its image; the inputs due before the fastest task's next cycle are set.
    fn task_cycle(&mut self, plc: &Plc, ctx: &ScanContext, now: Duration) {
        let name = plc.project().tasks.first().map_or("", |t| t.name.as_str());
        let task = self.task_names.iter().position(|n| n == name).unwrap_or(0);
        let owners = self.owners.take().unwrap_or_default();
        let mine = |t: usize| owners.get(t).copied().unwrap_or(0) == task;
        if task == 0 {
            self.result.scans += 1;
        }
        let image = plc.image();
        for (k, (t, name)) in self.watch.iter().enumerate() {
            let v = image.get(crate::image::TagId(*t as u32));
            if mine(*t) && self.last[k] != Some(v) {
                self.last[k] = Some(v);
                self.result.trace.push(Change {
                    at: now,
                    tag: name.clone(),
                    value: v.into(),
                });
            }
        }
        let next = now + plc.project().scan.period;
        for (i, e) in self.expects.iter().enumerate() {
            if self.checked[i] || !mine(e.tag) || e.at >= next {
                continue;
            }
            self.checked[i] = true;
            self.result.checked += 1;
            let got = image.get(crate::image::TagId(e.tag as u32));
            if got != e.value {
                self.result.failures.push(format!(
                    "at {} (line {}): {} expected {}, got {got} (task {})",
                    secs(e.at),
                    e.line,
                    image.name(crate::image::TagId(e.tag as u32)),
                    e.value,
                    name
                ));
            }
        }
        self.owners = Some(owners);
        if let Some(alarms) = &mut self.alarms {
            // The book takes this cycle's share as the task's boundary feeds it in `softplc
            // run`; a step is taken once no cycle of any task that starts at or before its
            // time is left: before the first cycle that starts after it, or after this one
            // when every task's next cycle starts after it (a task's next cycle starts a
            // period after this one at the earliest; one not started yet may start now).
            alarms.steps_before(now, &mut self.result);
            if let Some(start) = self.next_starts.get_mut(task) {
                *start = Some(next);
            }
            let next_any = self
                .next_starts
                .iter()
                .map(|s| s.unwrap_or(now))
                .min()
                .unwrap_or(next);
            alarms.cycle(task, plc, ctx, now, next_any, &mut self.result);
        }
        self.plant_cycle(now, now + self.period);
        self.apply_sets(now + self.period);
        self.apply_faults(now + self.period);
        self.apply_module_steps(now + self.period);
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

/// The world and device of the simulated module `module` (`None`: no simulator of that name).
fn device_of(worlds: &[SharedWorld], module: &str) -> Option<(SharedWorld, usize)> {
    worlds.iter().find_map(|w| {
        let d = w.lock().unwrap_or_else(|p| p.into_inner()).find(module)?;
        Some((w.clone(), d))
    })
}

/// Runs `sc` with the programs of `variant` (or the project's own).
pub(crate) fn run(sc: &Scenario, variant: Option<&ProgramVariant>) -> RunResult {
    let mut project = sc.project.clone();
    if let Some(v) = variant {
        v.apply(&mut project);
    }
    if project.multitask() {
        return run_tasks(sc, project);
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
    let worlds: Vec<SharedWorld> = plc.world().cloned().into_iter().collect();
    let mut state = HookState::new(sc, &worlds, watch, period);
    state.alarms = Some(ScenarioAlarms::new(plc.project(), sc.alarm_steps.clone()));
    state.apply_sets(Duration::ZERO);
    state.apply_faults(Duration::ZERO);
    state.apply_module_steps(Duration::ZERO);
    let state = Arc::new(Mutex::new(state));
    let hook_state = state.clone();
    let mut engine = ScanEngine::new(plc)
        .run_for(sc.until)
        .on_cycle(Box::new(move |plc, ctx| {
            hook_state.lock().unwrap_or_else(|p| p.into_inner()).cycle(
                plc,
                ctx,
                ctx.now.saturating_duration_since(origin),
            );
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
    let alarms_left = st.alarms.iter().flat_map(ScenarioAlarms::left);
    let left = st
        .expects
        .iter()
        .skip(st.next_expect)
        .map(|e| (e.at, e.line))
        .chain(plant_left)
        .chain(alarms_left);
    not_reached(left, sc, &mut result);
    if !sc.retained.is_empty() {
        check_retained(sc, |_| retain_file.clone(), &mut result);
    }
    // Best effort: a scratch retain file, absent unless the scenario retained values.
    drop(std::fs::remove_file(&retain_file));
    result
}

/// Runs `sc` on a project of several tasks, each on its own virtual clock; scenario time
/// starts with the earliest first scan of any task.
fn run_tasks(sc: &Scenario, mut project: crate::project::Project) -> RunResult {
    if !sc.plant {
        project.plant = None;
    }
    let retain_file = temp_retain();
    project.retain.file = retain_file.clone();
    let plcs = match crate::plc::TaskBuilder::new(&project, None, None).and_then(|b| {
        let owners = (0..project.tags.len())
            .map(|t| {
                b.ownership()
                    .owner(crate::image::TagId(t as u32))
                    .unwrap_or(0)
            })
            .collect::<Vec<_>>();
        let shares = TaskShare::all(&project, b.ownership());
        let plcs = (0..project.tasks.len())
            .map(|i| b.build(i))
            .collect::<Result<Vec<_>, _>>()?;
        Ok((plcs, owners, shares))
    }) {
        Ok(p) => p,
        Err(e) => {
            return RunResult {
                failures: vec![format!("cannot start: {e}")],
                ..RunResult::default()
            }
        }
    };
    let (plcs, owners, shares) = plcs;
    let origin = plcs
        .iter()
        .map(|t| t.plc.clock().now())
        .min()
        .unwrap_or_default();
    let worlds: Vec<SharedWorld> = plcs.iter().filter_map(|t| t.plc.world().cloned()).collect();
    let watch = sc
        .watch
        .iter()
        .map(|&t| (t, project.tags[t].name.clone()))
        .collect::<Vec<_>>();
    let fastest = project.tasks.iter().map(|t| t.scan.period).min();
    let mut state = HookState::new(sc, &worlds, watch, fastest.unwrap_or_default());
    state.owners = Some(owners);
    state.checked = vec![false; sc.expects.len()];
    state.task_names = project.tasks.iter().map(|t| t.name.clone()).collect();
    // The alarms as `softplc run` evaluates them: one book of the whole project, fed by
    // every task's share (the tags it owns, its modules) at that task's own cycles.
    state.alarms = Some(ScenarioAlarms::of_tasks(
        &project,
        shares,
        sc.alarm_steps.clone(),
    ));
    state.next_starts = vec![None; project.tasks.len()];
    state.apply_sets(Duration::ZERO);
    state.apply_faults(Duration::ZERO);
    state.apply_module_steps(Duration::ZERO);
    let state = Arc::new(Mutex::new(state));
    let until = sc.until;
    let tasks = crate::scan::TaskSet::new(plcs).configure(|_, engine| {
        let hook_state = state.clone();
        let end = origin + until;
        let run_for = end.saturating_duration_since(engine.plc().clock().now());
        engine.run_for(run_for).on_cycle(Box::new(move |plc, ctx| {
            hook_state.lock().unwrap_or_else(|p| p.into_inner()).cycle(
                plc,
                ctx,
                ctx.now.saturating_duration_since(origin),
            );
        }))
    });
    let outcomes = tasks.run_virtual();
    let mut st = state.lock().unwrap_or_else(|p| p.into_inner());
    let mut result = std::mem::take(&mut st.result);
    result.task_scans = outcomes
        .iter()
        .map(|o| (o.name.clone(), o.outcome.stats.cycles))
        .collect();
    for o in &outcomes {
        match &o.outcome.reason {
            StopReason::Requested | StopReason::TimeUp => {}
            other => result
                .failures
                .push(format!("task {}: the PLC stopped: {other:?}", o.name)),
        }
    }
    let plant_left = st
        .plant_expects
        .iter()
        .skip(st.next_plant_expect)
        .map(|e| (e.at, e.line));
    let unchecked = st.expects.iter().zip(&st.checked).filter(|(_, c)| !**c);
    let alarms_left = st.alarms.iter().flat_map(ScenarioAlarms::left);
    let left = unchecked
        .map(|(e, _)| (e.at, e.line))
        .chain(plant_left)
        .chain(alarms_left);
    not_reached(left, sc, &mut result);
    if !sc.retained.is_empty() {
        // Each retained tag is in the file of the task owning it.
        let owners = st.owners.clone().unwrap_or_default();
        let file_of = |tag: &str| {
            let owner = project
                .tags
                .iter()
                .position(|t| t.name == tag)
                .and_then(|t| owners.get(t).copied())
                .unwrap_or(0);
            let task = project.tasks.get(owner).map_or("", |t| t.name.as_str());
            crate::project::task_view::task_file(&retain_file, task)
        };
        check_retained(sc, file_of, &mut result);
    }
    // Best effort: each task's scratch retain file, absent unless it retained values.
    for t in &project.tasks {
        drop(std::fs::remove_file(crate::project::task_view::task_file(
            &retain_file,
            &t.name,
        )));
    }
    result
}

/// Each expectation left (its time and line) is a failure: the run ended before its time.
fn not_reached(
    left: impl Iterator<Item = (Duration, usize)>,
    sc: &Scenario,
    result: &mut RunResult,
) {
    for (at, line) in left {
        result.failures.push(format!(
            "at {} (line {line}): not reached (the run ends at {})",
            secs(at),
            secs(sc.until)
        ));
    }
}

/// Compares the retain files written at stop with the expected values; `file_of(tag)`: the
/// file that keeps the tag.
fn check_retained(sc: &Scenario, file_of: impl Fn(&str) -> PathBuf, result: &mut RunResult) {
    for (name, want) in &sc.retained {
        let text = std::fs::read_to_string(file_of(name)).unwrap_or_default();
        let doc: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
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
