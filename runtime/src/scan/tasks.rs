//! Several tasks, each a scan engine on its own PLC: on the real clock each on a thread of its
//! own at its own real-time priority; on virtual clocks one after the other on the calling
//! thread, in the order of their cycles' starts, so a run is deterministic.
//!
//! The tasks stop together: a stop request (the shared stop flag) stops each at its next
//! cycle boundary, and a fault of one task (its program, its watchdog) stops every other at
//! its next boundary with [`StopReason::TaskFault`]; each writes its outputs' safe values.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use crate::plc::TaskPlc;
use crate::scan::engine::{Run, RunOutcome, ScanEngine, StatusSnapshot, TaskHalt};
use crate::scan::ScanInstant;

/// One task's engine and name.
#[derive(Debug)]
pub struct Task {
    /// The task's name.
    pub name: String,
    /// Its engine (configure it before the run: run time, hooks, boundaries).
    pub engine: ScanEngine,
}

/// The tasks of one PLC.
#[derive(Debug)]
pub struct TaskSet {
    tasks: Vec<Task>,
    stop: Arc<AtomicBool>,
}

/// How one task's run ended.
#[derive(Debug, Clone)]
pub struct TaskOutcome {
    /// The task.
    pub name: String,
    /// Its run.
    pub outcome: RunOutcome,
}

/// What the tasks of one PLC share to stop together: the stop flag (signals, `--for`'s
/// end is each engine's own) and the halt a faulting task pulls.
#[derive(Debug, Clone, Default)]
pub struct TaskControl {
    stop: Arc<AtomicBool>,
    halt: Arc<TaskHalt>,
}

impl TaskControl {
    /// A control no task has used.
    pub fn new() -> Self {
        Self::default()
    }

    /// The engine of one task's PLC, stopping with the others.
    pub fn engine(&self, task: TaskPlc) -> ScanEngine {
        ScanEngine::new(task.plc)
            .with_stop_flag(self.stop.clone())
            .in_task_set(task.name, self.halt.clone())
    }

    /// The flag that stops every task at its next cycle boundary.
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// Stops every task as a fault of `task` does (it could not start).
    pub fn fault(&self, task: &str) {
        self.halt.fault(task);
    }
}

impl TaskSet {
    /// An engine per task's PLC, sharing one stop flag and one halt.
    pub fn new(plcs: Vec<TaskPlc>) -> Self {
        let control = TaskControl::new();
        let tasks = plcs
            .into_iter()
            .map(|t| Task {
                name: t.name.clone(),
                engine: control.engine(t),
            })
            .collect();
        Self {
            tasks,
            stop: control.stop_flag(),
        }
    }

    /// A set of engines made by [`TaskControl::engine`] (one control for all), named.
    pub fn from_engines(names: Vec<String>, engines: Vec<ScanEngine>) -> Self {
        let stop = engines.first().map_or_else(Arc::default, |e| e.stop_flag());
        let tasks = names
            .into_iter()
            .zip(engines)
            .map(|(name, engine)| Task { name, engine })
            .collect();
        Self { tasks, stop }
    }

    /// The tasks, in project order.
    pub fn tasks(&self) -> &[Task] {
        &self.tasks
    }

    /// Changes every task's engine with `f` (run time, boundaries, hooks).
    pub fn configure(mut self, mut f: impl FnMut(usize, ScanEngine) -> ScanEngine) -> Self {
        self.tasks = self
            .tasks
            .into_iter()
            .enumerate()
            .map(|(i, t)| Task {
                name: t.name,
                engine: f(i, t.engine),
            })
            .collect();
        self
    }

    /// The flag that stops every task at its next cycle boundary.
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// Each task's live status, in project order.
    pub fn statuses(&self) -> Vec<(String, Arc<Mutex<StatusSnapshot>>)> {
        self.tasks
            .iter()
            .map(|t| (t.name.clone(), t.engine.status()))
            .collect()
    }

    /// Runs every task on the calling thread, each on its own virtual clock: always the
    /// cycle that starts first next (the higher real-time priority first at one instant,
    /// then project order), until every task has stopped.
    pub fn run_virtual(mut self) -> Vec<TaskOutcome> {
        let mut runs: Vec<Option<Run>> = self
            .tasks
            .iter_mut()
            .map(|t| Some(t.engine.start()))
            .collect();
        let mut outcomes: Vec<Option<RunOutcome>> = vec![None; self.tasks.len()];
        let priority: Vec<u8> = self
            .tasks
            .iter()
            .map(|t| t.engine.plc().project().scan.realtime.priority.unwrap_or(0))
            .collect();
        loop {
            let next = runs
                .iter()
                .enumerate()
                .filter_map(|(i, r)| r.as_ref().map(|r| (i, ScanEngine::next_deadline(r))))
                .min_by_key(|&(i, at): &(usize, ScanInstant)| {
                    (at, std::cmp::Reverse(priority[i]), i)
                });
            let Some((i, _)) = next else { break };
            let engine = &mut self.tasks[i].engine;
            let Some(run) = runs[i].as_mut() else { break };
            if let Some(reason) = engine.step(run) {
                if let Some(run) = runs[i].take() {
                    outcomes[i] = Some(engine.finish(run, reason));
                }
            }
        }
        self.outcomes(outcomes)
    }

    fn outcomes(self, outcomes: Vec<Option<RunOutcome>>) -> Vec<TaskOutcome> {
        self.tasks
            .into_iter()
            .zip(outcomes)
            .filter_map(|(t, o)| {
                o.map(|outcome| TaskOutcome {
                    name: t.name,
                    outcome,
                })
            })
            .collect()
    }
}
