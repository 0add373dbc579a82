//! The scan loop.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::logic::{LogicFault, ScanContext};
use crate::plc::{CycleWork, ModuleStatus, Plc};
use crate::scan::boundary::CycleBoundary;
use crate::scan::overrun::OverrunLog;
use crate::scan::stats::{LastCycle, Percentiles, ScanInstant, ScanStats};
use crate::scan::watchdog::{TaskWatchdog, WatchdogTrip};

/// Why a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum StopReason {
    /// Asked to stop: a signal (SIGINT, SIGTERM) or a stop flag.
    Requested,
    /// The run's own limit was reached (`--for` elapsed, a cycle limit): it ended as planned,
    /// which an operator reading the log must not take for someone's stop.
    TimeUp,
    /// The program faulted; outputs went to their safe values.
    LogicFault(LogicFault),
    /// The task watchdog fired; outputs went to their safe values.
    Watchdog(WatchdogTrip),
    /// Another task of the PLC faulted (its program or its watchdog): every task stopped,
    /// outputs at their safe values.
    TaskFault {
        /// The task that faulted.
        task: String,
    },
}

/// What a run leaves behind.
#[derive(Debug, Clone)]
pub struct RunOutcome {
    /// Why it ended.
    pub reason: StopReason,
    /// Everything measured.
    pub stats: ScanStats,
    /// Modules as last seen.
    pub modules: Vec<ModuleStatus>,
}

/// A copy of the figures for the live status line, refreshed by the scan without blocking.
#[derive(Debug, Clone, Default)]
pub struct StatusSnapshot {
    /// Completed cycles.
    pub cycles: u64,
    /// Overruns.
    pub overruns: u64,
    /// Cycle time percentiles.
    pub cycle: Percentiles,
    /// Wake-up lateness percentiles.
    pub lateness: Percentiles,
    /// Bus errors.
    pub bus_errors: u64,
    /// Scan time.
    pub now: ScanInstant,
    /// The task's modules as last seen (the status of a PLC of several tasks shows every
    /// task's).
    pub modules: Vec<ModuleStatus>,
    /// The tags forced in the task's image and their forced values (the status of a PLC of
    /// several tasks marks every task's forces).
    pub forces: Vec<(crate::image::TagId, softplc_io::point::Value)>,
}

/// The scan engine: owns the PLC for the duration of a run.
pub struct ScanEngine {
    plc: Plc,
    stop: Arc<AtomicBool>,
    status: Arc<Mutex<StatusSnapshot>>,
    /// Stop after this much scan time (on the PLC's clock).
    run_for: Option<Duration>,
    /// Stop after this many cycles.
    max_cycles: Option<u64>,
    /// A hook called after every cycle (tests record traces with it).
    on_cycle: Option<CycleHook>,
    /// What runs at cycle boundaries (the service: control requests, reload, systemd, the
    /// snapshot for the network services), in the order given.
    boundaries: Vec<Box<dyn CycleBoundary>>,
    /// End the run as a `kill -9` would: no safe state, module tables left as they are.
    abandon: bool,
    /// The task this engine runs, and the halt it shares with the other tasks.
    task: Option<(String, Arc<TaskHalt>)>,
}

impl std::fmt::Debug for ScanEngine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScanEngine")
            .field("plc", &self.plc)
            .field("run_for", &self.run_for)
            .field("max_cycles", &self.max_cycles)
            .field("on_cycle", &self.on_cycle.is_some())
            .field("boundaries", &self.boundaries.len())
            .finish()
    }
}

/// Called after each cycle with the PLC and the cycle's context.
pub type CycleHook = Box<dyn FnMut(&Plc, &ScanContext) + Send>;

impl ScanEngine {
    /// An engine for `plc`.
    pub fn new(plc: Plc) -> Self {
        Self {
            plc,
            stop: Arc::new(AtomicBool::new(false)),
            status: Arc::new(Mutex::new(StatusSnapshot::default())),
            run_for: None,
            max_cycles: None,
            on_cycle: None,
            boundaries: Vec::new(),
            abandon: false,
            task: None,
        }
    }

    /// Runs `boundary` at every cycle boundary, at the start and at the end of the run (after
    /// the boundaries given before it).
    pub fn with_boundary(mut self, boundary: impl CycleBoundary + 'static) -> Self {
        self.boundaries.push(Box::new(boundary));
        self
    }

    /// Refreshes `status` (every 200 ms) instead of a status of its own.
    pub fn with_status(mut self, status: Arc<Mutex<StatusSnapshot>>) -> Self {
        self.status = status;
        self
    }

    /// Stops the run when `flag` is set (a flag several tasks' engines share).
    pub fn with_stop_flag(mut self, flag: Arc<AtomicBool>) -> Self {
        self.stop = flag;
        self
    }

    /// The flag that stops the run at the next cycle boundary (give it to signal handlers).
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// The live status the scan refreshes.
    pub fn status(&self) -> Arc<Mutex<StatusSnapshot>> {
        self.status.clone()
    }

    /// Stops after `d` of scan time.
    pub fn run_for(mut self, d: Duration) -> Self {
        self.run_for = Some(d);
        self
    }

    /// Stops after `n` cycles.
    pub fn max_cycles(mut self, n: u64) -> Self {
        self.max_cycles = Some(n);
        self
    }

    /// Ends the run the way `kill -9` ends a process: the outputs are not driven to their safe
    /// values and the module tables stay as they are, so a test can show what the modules'
    /// own watchdogs and the next start do with what a crash leaves behind.
    pub fn abandon_at_end(mut self) -> Self {
        self.abandon = true;
        self
    }

    /// Calls `hook` after every cycle.
    pub fn on_cycle(mut self, hook: CycleHook) -> Self {
        self.on_cycle = Some(hook);
        self
    }

    /// The PLC (between runs).
    pub fn plc(&self) -> &Plc {
        &self.plc
    }

    /// Runs cycles until stopped, then drives the outputs to their safe state.
    pub fn run(&mut self) -> RunOutcome {
        let mut run = self.start();
        let reason = loop {
            if let Some(reason) = self.step(&mut run) {
                break reason;
            }
        };
        self.finish(run, reason)
    }

    /// Names the engine's task and shares `halt` with the other tasks' engines: a fault of
    /// this task (its program, its watchdog) stops every task, each in its safe state, and a
    /// fault of another stops this one at its next cycle boundary.
    pub fn in_task_set(mut self, task: String, halt: Arc<TaskHalt>) -> Self {
        self.task = Some((task, halt));
        self
    }

    /// Starts a run: the boundaries' `started`, the first deadline now.
    pub fn start(&mut self) -> Run {
        let clock = self.plc.clock().clone();
        let period = self.plc.project().scan.period;
        let begin = clock.now();
        let run = Run {
            watchdog: TaskWatchdog::new(self.plc.project().scan.watchdog),
            stats: ScanStats::default(),
            end_at: self.run_for.map(|d| begin + d),
            deadline: begin,
            previous: None,
            last_published: begin,
            overruns: OverrunLog::new(period),
            open: std::collections::VecDeque::new(),
            ends: Vec::new(),
            clock,
            period,
        };
        for b in &mut self.boundaries {
            b.started(&mut self.plc);
        }
        run
    }

    /// When the run's next cycle starts (its deadline on the grid).
    pub fn next_deadline(run: &Run) -> ScanInstant {
        run.deadline
    }

    /// Runs the next cycle (sleeping to its deadline first), or says why the run ends.
    pub fn step(&mut self, run: &mut Run) -> Option<StopReason> {
        // With several tasks, every log line of the cycle names its task. The span is at the
        // error level so that it is there at every level the log is filtered to.
        let _task = self
            .task
            .as_ref()
            .map(|(name, _)| tracing::error_span!("task", name = %name).entered());
        let reason = self.cycle(run);
        if let (Some(StopReason::LogicFault(_) | StopReason::Watchdog(_)), Some((task, halt))) =
            (&reason, &self.task)
        {
            halt.fault(task);
        }
        reason
    }

    fn cycle(&mut self, run: &mut Run) -> Option<StopReason> {
        let clock = run.clock.clone();
        let period = run.period;
        let (mut deadline, mut previous, mut last_published) =
            (run.deadline, run.previous, run.last_published);
        let Run {
            watchdog,
            stats,
            end_at,
            overruns,
            open,
            ends,
            ..
        } = run;
        if let Some(task) = self.task.as_ref().and_then(|(_, halt)| halt.faulted()) {
            return Some(StopReason::TaskFault { task });
        }
        if self.stop.load(Ordering::Relaxed) {
            return Some(StopReason::Requested);
        }
        if end_at.is_some_and(|end| deadline >= end)
            || self.max_cycles.is_some_and(|n| stats.cycles >= n)
        {
            return Some(StopReason::TimeUp);
        }
        clock.sleep_until(deadline);
        let start = clock.now();
        self.plc.begin_cycle(deadline);
        stats.lateness.record(start - deadline);

        self.plc.read_inputs();
        let read_end = clock.now();
        // Cycles before that ran past their period on a line's thread: each one's time is
        // known once that line has answered its write.
        self.plc.late_work_ends(read_end, false, ends);
        for work_end in ends.drain(..) {
            if let Some(phases) = open.pop_front() {
                phases.record(stats, work_end);
            }
        }
        let ctx = ScanContext {
            now: deadline,
            delta: previous.map_or(period, |p| deadline - p),
            // The N-th scan is cycle N (the first is 1): the scan count once it is done,
            // the number status, trace, record, replay and the services all give it.
            cycle: stats.cycles + 1,
        };
        // A panic in a program engine is a bug, but the machine still gets its safe state.
        let logic =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.plc.run_logic(&ctx)))
                .unwrap_or_else(|panic| {
                    let what = panic
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| panic.downcast_ref::<String>().cloned())
                        .unwrap_or_else(|| "unknown".into());
                    Err(LogicFault {
                        message: format!("the program engine panicked: {what}"),
                        pos: crate::logic::SourcePos {
                            file: self.plc.project().program_files().into(),
                            line: 0,
                            column: 0,
                        },
                    })
                });
        let logic_end = clock.now();
        if let Err(fault) = logic {
            return Some(StopReason::LogicFault(fault));
        }
        self.plc.write_outputs();
        let outputs_end = clock.now();

        stats.last = LastCycle {
            start: deadline,
            read: read_end - start,
            logic: logic_end - read_end,
            write: outputs_end - logic_end,
            cycle: outputs_end - start,
        };
        let work = self.plc.cycle_work();
        stats.cycles += 1;
        stats.bus_errors = self.plc.bus_errors();
        if let Some(hook) = self.on_cycle.as_mut() {
            hook(&self.plc, &ctx);
        }
        // The boundary (traces, control answers, the services' feed, the reload poll, the
        // status refresh) is the cycle's last phase: timed, and counted by the watchdog and
        // the overrun check like the others, since it is time the next cycle does not have.
        for b in &mut self.boundaries {
            b.between_cycles(&mut self.plc, stats, outputs_end);
        }
        if outputs_end - last_published >= Duration::from_millis(200) {
            last_published = outputs_end;
            self.publish(stats, outputs_end);
        } else {
            self.publish_counts(stats);
        }
        let end = clock.now();

        let phases = Phases {
            start,
            read_end,
            logic_end,
            outputs_end,
            end,
        };
        match work {
            CycleWork::Done => phases.record(stats, outputs_end),
            CycleWork::At(t) => phases.record(stats, t),
            CycleWork::Later => open.push_back(phases),
        }
        // The scan's own work: waits for lines are bounded by the period and never trip it,
        // so a dead line cannot stop the PLC.
        if let Err(trip) = watchdog.check((end - start).saturating_sub(self.plc.io_wait())) {
            return Some(StopReason::Watchdog(trip));
        }

        let cycle_deadline = deadline;
        previous = Some(deadline);
        deadline += period;
        // A cycle whose writes were still running at its period's end overran, even when
        // the scan itself went on in time (CycleWork): so both clocks count it alike.
        let work_late = match work {
            CycleWork::Done => false,
            CycleWork::At(t) => t > deadline,
            CycleWork::Later => true,
        };
        if end > deadline || work_late {
            // Skip every deadline the scan itself has passed; the next cycle starts on the
            // grid. One it only waited at for a line still writing (and woke on, or just
            // after, by its clock's lateness) is not passed: the next cycle starts then.
            let past = (end - deadline).as_nanos() / period.as_nanos().max(1);
            let skipped = if work_late || end <= deadline {
                past
            } else {
                past + 1
            };
            stats.overruns = stats
                .overruns
                .saturating_add(u64::try_from(skipped.max(1)).unwrap_or(u64::MAX));
            let skip = period.as_nanos().saturating_mul(skipped);
            deadline += Duration::from_nanos(u64::try_from(skip).unwrap_or(u64::MAX));
            // The writes may end after the boundary (on a line's thread): the boundary's
            // share is what it took beyond them, so the phases add up to the cycle.
            let writes_end = match work {
                CycleWork::At(t) => t.max(outputs_end),
                CycleWork::Done | CycleWork::Later => outputs_end,
            };
            overruns.note(
                end,
                skipped,
                start - cycle_deadline,
                [
                    ("inputs", read_end - start),
                    ("logic", logic_end - read_end),
                    ("outputs", writes_end - logic_end),
                    ("boundary", end - writes_end),
                ],
            );
        }
        (run.deadline, run.previous, run.last_published) = (deadline, previous, last_published);
        None
    }

    /// Ends a run for `reason`: the boundaries' `stopping`, the safe state (unless the run is
    /// abandoned), their `stopped`, the last status.
    pub fn finish(&mut self, run: Run, reason: StopReason) -> RunOutcome {
        let Run {
            clock,
            mut stats,
            mut open,
            mut ends,
            ..
        } = run;
        self.plc.late_work_ends(clock.now(), true, &mut ends);
        for (phases, work_end) in open.drain(..).zip(ends.drain(..)) {
            phases.record(&mut stats, work_end);
        }
        for b in &mut self.boundaries {
            b.stopping(&reason);
        }
        if self.abandon {
            return RunOutcome {
                reason,
                stats,
                modules: self.plc.module_status().to_vec(),
            };
        }
        self.plc.shutdown();
        let now = clock.now();
        for b in &mut self.boundaries {
            b.stopped(&self.plc, &stats, &reason, now);
        }
        self.publish(&stats, now);
        RunOutcome {
            reason,
            stats,
            modules: self.plc.module_status().to_vec(),
        }
    }

    /// The counts alone, every cycle between two refreshes: another task's status reads
    /// them beside the tags this task published at this cycle's end, so its `scans` is the
    /// cycle its values come from (a fast task's were up to 200 ms behind).
    fn publish_counts(&self, stats: &ScanStats) {
        // Never block the scan on a reader: a busy lock keeps the last counts a cycle more.
        if let Ok(mut s) = self.status.try_lock() {
            s.cycles = stats.cycles;
            s.overruns = stats.overruns;
        }
    }

    fn publish(&self, stats: &ScanStats, now: ScanInstant) {
        // Never block the scan on a reader: skip this refresh if the lock is busy.
        if let Ok(mut s) = self.status.try_lock() {
            *s = StatusSnapshot {
                cycles: stats.cycles,
                overruns: stats.overruns,
                cycle: stats.cycle.percentiles(),
                lateness: stats.lateness.percentiles(),
                bus_errors: stats.bus_errors,
                now,
                modules: self.plc.module_status().to_vec(),
                forces: self.plc.image().forces().collect(),
            };
        }
    }
}

/// A run in progress: what [`ScanEngine::step`] carries from one cycle to the next.
pub struct Run {
    clock: Arc<dyn crate::clock::Clock>,
    period: Duration,
    watchdog: TaskWatchdog,
    stats: ScanStats,
    end_at: Option<ScanInstant>,
    deadline: ScanInstant,
    previous: Option<ScanInstant>,
    last_published: ScanInstant,
    overruns: OverrunLog,
    /// Cycles whose work outlasted them on a line's thread, until that line answers.
    open: std::collections::VecDeque<Phases>,
    ends: Vec<ScanInstant>,
}

impl std::fmt::Debug for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Run")
            .field("deadline", &self.deadline)
            .field("cycles", &self.stats.cycles)
            .finish_non_exhaustive()
    }
}

impl Run {
    /// The run's figures so far.
    pub fn stats(&self) -> &ScanStats {
        &self.stats
    }
}

/// What the tasks of one PLC share to stop together: the first task whose program or watchdog
/// faults names itself here, and every other task stops at its next cycle boundary, writing
/// its safe state.
#[derive(Debug, Default)]
pub struct TaskHalt {
    faulted: Mutex<Option<String>>,
}

impl TaskHalt {
    /// A halt no task has pulled.
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// `task` faulted (the first one to say so is kept).
    pub fn fault(&self, task: &str) {
        let mut faulted = self.faulted.lock().unwrap_or_else(|p| p.into_inner());
        if faulted.is_none() {
            *faulted = Some(task.to_owned());
        }
    }

    /// The task that faulted, when one has.
    pub fn faulted(&self) -> Option<String> {
        self.faulted
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}

/// When a cycle's phases ended, on the PLC's clock.
#[derive(Debug, Clone, Copy)]
struct Phases {
    start: ScanInstant,
    read_end: ScanInstant,
    logic_end: ScanInstant,
    /// When the scan had handed out its writes.
    outputs_end: ScanInstant,
    /// When the boundary was done and the scan went on to the next cycle.
    end: ScanInstant,
}

impl Phases {
    /// Records the cycle, whose writes (its lines' acknowledgements included) ended at
    /// `writes_end`: the output phase runs until then and the cycle until the later of its
    /// writes and its boundary, so a cycle that outlasted its period shows its real length,
    /// not the period it was cut at.
    fn record(&self, stats: &mut ScanStats, writes_end: ScanInstant) {
        let writes_end = writes_end.max(self.outputs_end);
        stats.read.record(self.read_end - self.start);
        stats.logic.record(self.logic_end - self.read_end);
        stats.write.record(writes_end - self.logic_end);
        stats.boundary.record(self.end - self.outputs_end);
        stats.cycle.record(writes_end.max(self.end) - self.start);
    }
}
