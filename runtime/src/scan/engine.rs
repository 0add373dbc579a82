//! The scan loop.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};

use crate::logic::{LogicFault, ScanContext};
use crate::plc::{ModuleStatus, Plc, PreparedReload};
use crate::scan::overrun::OverrunLog;
use crate::scan::stats::{Percentiles, ScanStats};
use crate::scan::watchdog::{TaskWatchdog, WatchdogTrip};
use crate::service::control::{Envelope, Request, Response};
use crate::service::notify::Notifier;
use crate::service::snapshot::Publisher;

/// Why a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum StopReason {
    /// Asked to stop (signal, `--for` elapsed, cycle limit).
    Requested,
    /// The program faulted; outputs went to their safe values.
    LogicFault(LogicFault),
    /// The task watchdog fired; outputs went to their safe values.
    Watchdog(WatchdogTrip),
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
    pub now: Duration,
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
    /// Requests from the control interface, applied at cycle boundaries.
    control: Option<Receiver<Envelope>>,
    /// Set by SIGHUP: reload the program at the next cycle boundary.
    reload: Arc<AtomicBool>,
    /// systemd's notification socket.
    notifier: Option<Notifier>,
    /// The snapshot for the metrics endpoint and the Modbus TCP server.
    publisher: Option<Publisher>,
    /// A reload being compiled off the scan thread.
    reload_job: Option<Receiver<Result<PreparedReload, String>>>,
    /// Control clients waiting for that reload's outcome.
    reload_waiters: Vec<Sender<Response>>,
    /// End the run as a `kill -9` would: no safe state, module tables left as they are.
    abandon: bool,
}

impl std::fmt::Debug for ScanEngine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScanEngine")
            .field("plc", &self.plc)
            .field("run_for", &self.run_for)
            .field("max_cycles", &self.max_cycles)
            .field("on_cycle", &self.on_cycle.is_some())
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
            control: None,
            reload: Arc::new(AtomicBool::new(false)),
            notifier: None,
            publisher: None,
            reload_job: None,
            reload_waiters: Vec::new(),
            abandon: false,
        }
    }

    /// Takes control requests from `requests` (see [`crate::service::control`]).
    pub fn with_control(mut self, requests: Receiver<Envelope>) -> Self {
        self.control = Some(requests);
        self
    }

    /// Publishes a snapshot for the services at every cycle boundary (see
    /// [`crate::service::snapshot`]).
    pub fn with_publisher(mut self, publisher: Publisher) -> Self {
        self.publisher = Some(publisher);
        self
    }

    /// Reports to systemd through `notifier`.
    pub fn with_notifier(mut self, notifier: Notifier) -> Self {
        self.notifier = Some(notifier);
        self
    }

    /// The flag that reloads the program at the next cycle boundary (give it to SIGHUP).
    pub fn reload_flag(&self) -> Arc<AtomicBool> {
        self.reload.clone()
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
        let clock = self.plc.clock().clone();
        let period = self.plc.project().scan.period;
        let mut watchdog = TaskWatchdog::new(self.plc.project().scan.watchdog);
        let mut stats = ScanStats::default();
        let begin = clock.now();
        let end_at = self.run_for.map(|d| begin + d);
        let mut deadline = begin;
        let mut previous: Option<Duration> = None;
        let mut last_published = begin;
        let mut overruns = OverrunLog::new(period);
        let reason = loop {
            self.poll_reload();
            if self.stop.load(Ordering::Relaxed) {
                break StopReason::Requested;
            }
            if end_at.is_some_and(|end| deadline >= end)
                || self.max_cycles.is_some_and(|n| stats.cycles >= n)
            {
                break StopReason::Requested;
            }
            clock.sleep_until(deadline);
            let start = clock.now();
            stats.lateness.record(start.saturating_sub(deadline));

            self.plc.read_inputs();
            let read_end = clock.now();
            let ctx = ScanContext {
                now: deadline,
                delta: previous.map_or(period, |p| deadline - p),
                cycle: stats.cycles,
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
                                file: self.plc.project().program.path.clone(),
                                line: 0,
                                column: 0,
                            },
                        })
                    });
            let logic_end = clock.now();
            if let Err(fault) = logic {
                break StopReason::LogicFault(fault);
            }
            self.plc.write_outputs();
            let end = clock.now();

            stats.read.record(read_end - start);
            stats.logic.record(logic_end - read_end);
            stats.write.record(end - logic_end);
            let cycle = end - start;
            stats.cycle.record(cycle);
            stats.cycles += 1;
            stats.bus_errors = self.plc.bus_errors();
            if let Some(hook) = self.on_cycle.as_mut() {
                hook(&self.plc, &ctx);
            }
            // The scan's own work: waits for lines are bounded by the period and never trip it,
            // so a dead line cannot stop the PLC.
            if let Err(trip) = watchdog.check(cycle.saturating_sub(self.plc.io_wait())) {
                break StopReason::Watchdog(trip);
            }
            self.between_cycles(&stats, end);

            previous = Some(deadline);
            deadline += period;
            if end > deadline {
                // Skip every deadline already passed; the next cycle starts on the grid.
                let behind = (end - deadline).as_nanos() / period.as_nanos().max(1) + 1;
                stats.overruns = stats
                    .overruns
                    .saturating_add(u64::try_from(behind).unwrap_or(u64::MAX));
                let skip = period.as_nanos().saturating_mul(behind);
                deadline += Duration::from_nanos(u64::try_from(skip).unwrap_or(u64::MAX));
                overruns.note(
                    end,
                    behind,
                    [
                        ("inputs", read_end - start),
                        ("logic", logic_end - read_end),
                        ("outputs", end - logic_end),
                    ],
                );
            }
            if end.saturating_sub(last_published) >= Duration::from_millis(200) {
                last_published = end;
                self.publish(&stats, end);
            }
        };
        if let Some(n) = &self.notifier {
            n.notify("STOPPING=1");
        }
        if self.abandon {
            return RunOutcome {
                reason,
                stats,
                modules: self.plc.module_status().to_vec(),
            };
        }
        self.plc.shutdown();
        if let Some(p) = &mut self.publisher {
            p.set_stop_reason(match &reason {
                StopReason::Requested => "stopped on request".to_string(),
                StopReason::LogicFault(f) => format!("program error: {f}"),
                StopReason::Watchdog(w) => format!("task watchdog: {w}"),
            });
            p.publish(&self.plc, &stats, clock.now(), true);
        }
        self.publish(&stats, clock.now());
        RunOutcome {
            reason,
            stats,
            modules: self.plc.module_status().to_vec(),
        }
    }

    /// Work done at a cycle boundary, never inside a scan: control requests, reload, systemd.
    fn between_cycles(&mut self, stats: &ScanStats, now: Duration) {
        if let Some(requests) = self.control.clone() {
            while let Ok(env) = requests.try_recv() {
                if env.expired() {
                    // Its client was already told it failed; carrying it out now would surprise.
                    continue;
                }
                let response = match env.request {
                    Request::Status => Response {
                        ok: true,
                        status: Some(self.plc.status_report(stats)),
                        ..Response::default()
                    },
                    Request::Force { tag, value } => match self.plc.force(&tag, &value) {
                        Ok(v) => Response::done(format!("{tag} forced to {v}")),
                        Err(e) => Response::refused(e),
                    },
                    Request::Unforce { tag } => match self.plc.unforce(tag.as_deref()) {
                        Ok(n) => Response::done(format!("{n} force(s) removed")),
                        Err(e) => Response::refused(e),
                    },
                    Request::Reload => {
                        // Compiled off the scan thread; answered when it is swapped in.
                        self.start_reload(Some(env.reply));
                        continue;
                    }
                    Request::Write { values } => match self.plc.write_tags(&values) {
                        Ok(m) => Response::done(m),
                        Err(e) => Response::refused(e),
                    },
                };
                let _ = env.reply.send(response);
            }
        }
        if self.reload.swap(false, Ordering::Relaxed) {
            self.start_reload(None);
        }
        if let Some(p) = &mut self.publisher {
            p.publish(&self.plc, stats, now, false);
        }
        if let Some(n) = &mut self.notifier {
            // Only a completed scan feeds systemd's watchdog: a hung scan gets restarted.
            if stats.cycles == 1 {
                n.notify("READY=1");
            }
            n.watchdog();
            if stats.cycles % 50 == 1 {
                let c = stats.cycle.percentiles();
                n.notify(&format!(
                    "STATUS=scans {} overruns {} cycle p50 {}us p99 {}us bus errors {} at {}s",
                    stats.cycles,
                    stats.overruns,
                    c.p50.as_micros(),
                    c.p99.as_micros(),
                    stats.bus_errors,
                    now.as_secs()
                ));
            }
        }
    }

    /// Starts compiling the project's program again on a thread of its own; `reply` is told
    /// the outcome once it is swapped in (or refused). A reload already under way answers for
    /// this one too.
    fn start_reload(&mut self, reply: Option<Sender<Response>>) {
        if let Some(r) = reply {
            self.reload_waiters.push(r);
        }
        if self.reload_job.is_some() {
            return;
        }
        let job = self.plc.reload_job();
        let (tx, rx) = crossbeam_channel::bounded(1);
        let spawned = std::thread::Builder::new()
            .name("reload".into())
            .spawn(move || {
                let _ = tx.send(job.prepare());
            });
        match spawned {
            Ok(_) => self.reload_job = Some(rx),
            Err(e) => self.finish_reload(Err(format!("reload refused: no thread for it: {e}"))),
        }
    }

    /// At a cycle boundary: swaps in a program whose compilation has finished.
    fn poll_reload(&mut self) {
        let Some(rx) = &self.reload_job else { return };
        let outcome = match rx.try_recv() {
            Ok(result) => result.map(|prepared| self.plc.apply_reload(prepared)),
            Err(crossbeam_channel::TryRecvError::Empty) => return,
            Err(crossbeam_channel::TryRecvError::Disconnected) => {
                Err("reload refused: its compilation ended without a result".into())
            }
        };
        self.reload_job = None;
        self.finish_reload(outcome);
    }

    fn finish_reload(&mut self, outcome: Result<String, String>) {
        if let Err(e) = &outcome {
            tracing::error!("{e}");
        }
        for reply in self.reload_waiters.drain(..) {
            let _ = reply.send(match &outcome {
                Ok(m) => Response::done(m.clone()),
                Err(e) => Response::refused(e.clone()),
            });
        }
    }

    fn publish(&self, stats: &ScanStats, now: Duration) {
        // Never block the scan on a reader: skip this refresh if the lock is busy.
        if let Ok(mut s) = self.status.try_lock() {
            *s = StatusSnapshot {
                cycles: stats.cycles,
                overruns: stats.overruns,
                cycle: stats.cycle.percentiles(),
                lateness: stats.lateness.percentiles(),
                bus_errors: stats.bus_errors,
                now,
            };
        }
    }
}
