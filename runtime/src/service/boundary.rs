//! What the service does at the scan's cycle boundaries: it answers control requests, runs
//! reloads (compiled off the scan thread, swapped in at a boundary), reports to systemd and
//! publishes the snapshot the network services read.
//!
//! The scan calls this through [`CycleBoundary`] and knows none of it: the JSON protocol, the
//! reload's thread and systemd's states are the service's.

use crossbeam_channel::{Receiver, Sender, TryRecvError};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::plc::{Plc, Prepared, ReloadError};
use crate::scan::{CycleBoundary, ScanStats, StopReason};
use crate::service::audit::{Action, AuditLog, Entry, Origin};
use crate::service::changes::ChangeFeed;
use crate::service::control::{Envelope, Request, Response};
use crate::service::notify::Notifier;
use crate::service::snapshot::Publisher;
use crate::service::status::{LostChanges, StatusReport};
use softplc_io::time::ScanInstant;

/// The service's side of the scan's cycle boundary (see the module docs).
#[derive(Debug, Default)]
pub struct ServiceBoundary {
    /// Requests from the control interface and the network services.
    control: Option<Receiver<Envelope>>,
    /// Set by SIGHUP: reload the program at the next cycle boundary.
    reload: Arc<AtomicBool>,
    /// systemd's notification socket.
    notifier: Option<Notifier>,
    /// The snapshot for the metrics endpoint, the Modbus TCP server and the web page.
    publisher: Option<Publisher>,
    /// A reload being compiled off the scan thread.
    reload_job: Option<Receiver<Result<Prepared, ReloadError>>>,
    /// Who waits for that reload's outcome (no reply: SIGHUP's).
    reload_waiters: Vec<(Option<Sender<Response>>, Origin)>,
    /// The audit file: every write, force, unforce and reload, with who and when.
    audit: Option<AuditLog>,
    /// Armed traces, sampled at every boundary (see [`crate::trace`]).
    traces: crate::trace::TraceSet,
    /// The services' states, for the status report.
    health: Option<super::health::Health>,
    /// Every cycle's changes, for the services that take them all (OPC UA, MQTT, alarms).
    feed: ChangeFeed,
    /// The alarm thread's requests (acknowledgements, lists) and its figures for the status.
    alarms: Option<(
        Sender<crate::service::alarms::Job>,
        crate::service::alarms::Alarms,
    )>,
    /// With several tasks, each task's live figures for the status.
    tasks: Vec<super::status::TaskStatus>,
}

impl ServiceBoundary {
    /// A boundary that does nothing until given its parts.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes control requests from `requests` (see [`crate::service::control`]).
    pub fn with_control(mut self, requests: Receiver<Envelope>) -> Self {
        self.control = Some(requests);
        self
    }

    /// Publishes a snapshot for the services at every cycle boundary (see
    /// `crate::service::snapshot`).
    pub fn with_publisher(mut self, publisher: Publisher) -> Self {
        self.publisher = Some(publisher);
        self
    }

    /// Offers every cycle's changes to the consumers of `feed` (see `crate::service::changes`).
    pub(crate) fn with_feed(mut self, feed: ChangeFeed) -> Self {
        self.feed = feed;
        self
    }

    /// Hands alarm requests to the alarm thread of `service` and reports its figures in the
    /// status.
    pub fn with_alarms(mut self, service: &crate::service::alarms::AlarmService) -> Self {
        self.alarms = Some((service.jobs(), service.alarms().clone()));
        self
    }

    /// Hands an alarm request to the alarm thread, which answers; refused when there is
    /// none or it is behind (the scan never waits for it).
    fn alarm_job(
        &self,
        request: crate::service::alarms::AlarmRequest,
        reply: Sender<Response>,
        origin: Origin,
        stats: &ScanStats,
        now: ScanInstant,
    ) {
        let Some((jobs, _)) = &self.alarms else {
            drop(reply.send(Response::refused("this instance runs no alarm service")));
            return;
        };
        let job = crate::service::alarms::Job {
            request,
            reply,
            origin,
            cycle: stats.cycles,
            at: now,
        };
        if let Err(e) = jobs.try_send(job) {
            let job = e.into_inner();
            // A client that gave up meanwhile has nobody left to tell.
            drop(
                job.reply
                    .send(Response::refused("the alarm service is behind; try again")),
            );
        }
    }

    /// Reports to systemd through `notifier`.
    pub fn with_notifier(mut self, notifier: Notifier) -> Self {
        self.notifier = Some(notifier);
        self
    }

    /// Notes every write, force, unforce and reload in `audit`.
    pub fn with_audit(mut self, audit: AuditLog) -> Self {
        self.audit = Some(audit);
        self
    }

    /// Notes what `origin` asked and what became of it in the audit file, if there is one.
    fn audit(&self, cycle: u64, origin: &Origin, action: Action, what: String, r: &Response) {
        let Some(log) = &self.audit else { return };
        let result = if r.ok { &r.message } else { &r.error };
        log.note(Entry::now(
            cycle,
            origin,
            action,
            what,
            r.ok,
            result.clone().unwrap_or_default(),
        ));
    }

    /// Keeps the traces in `traces` (one task's of several: see [`crate::trace::TraceSet::of_task`]).
    pub fn with_traces(mut self, traces: crate::trace::TraceSet) -> Self {
        self.traces = traces;
        self
    }

    /// Reports every task's figures in the status (a PLC of several tasks).
    pub fn with_tasks(mut self, tasks: Vec<super::status::TaskStatus>) -> Self {
        self.tasks = tasks;
        self
    }

    /// Reports the states `health` holds in the status.
    pub fn with_health(mut self, health: super::health::Health) -> Self {
        self.health = Some(health);
        self
    }

    /// The flag that reloads the program at the next cycle boundary (give it to SIGHUP).
    pub fn reload_flag(&self) -> Arc<AtomicBool> {
        self.reload.clone()
    }

    fn answer(&mut self, plc: &mut Plc, stats: &ScanStats, now: ScanInstant) {
        let Some(requests) = self.control.clone() else {
            return;
        };
        while let Ok(env) = requests.try_recv() {
            if env.expired() {
                // Its client was already told it failed; carrying it out now would surprise.
                continue;
            }
            let audited = match &env.request {
                Request::Write { values } => Some((
                    Action::Write,
                    values
                        .iter()
                        .map(|v| format!("{}={}", v.tag, v.value))
                        .collect::<Vec<_>>()
                        .join(" "),
                )),
                Request::Force { tag, value } => Some((Action::Force, format!("{tag}={value}"))),
                Request::Unforce { tag } => {
                    Some((Action::Unforce, tag.clone().unwrap_or_else(|| "*".into())))
                }
                // Noted when it is swapped in or refused; an acknowledgement by the alarm
                // thread.
                Request::Reload { .. }
                | Request::Status
                | Request::Trace(_)
                | Request::Alarms(_) => None,
            };
            let response = match env.request {
                Request::Status => {
                    let mut status = StatusReport::of(plc, stats).with_tasks(&self.tasks);
                    status.services = self
                        .health
                        .as_ref()
                        .map(super::health::Health::report)
                        .unwrap_or_default();
                    status.lost_changes = self
                        .feed
                        .counts()
                        .into_iter()
                        .map(|(service, c)| LostChanges {
                            service: service.into(),
                            lost: c.lost(),
                        })
                        .collect();
                    status.alarms = self.alarms.as_ref().map(|(_, a)| a.counts());
                    Response {
                        ok: true,
                        status: Some(status),
                        ..Response::default()
                    }
                }
                Request::Force { tag, value } => match plc.force(&tag, &value) {
                    Ok(v) => Response::done(format!("{tag} forced to {v}")),
                    Err(e) => Response::refused(e.to_string()),
                },
                Request::Unforce { tag } => match plc.unforce(tag.as_deref()) {
                    Ok(n) => Response::done(format!("{n} force(s) removed")),
                    Err(e) => Response::refused(e.to_string()),
                },
                Request::Trace(t) => crate::service::trace::answer(&mut self.traces, plc, t),
                Request::Alarms(request) => {
                    // Answered by the alarm thread.
                    self.alarm_job(request, env.reply, env.origin, stats, now);
                    continue;
                }
                Request::Reload { task: Some(task) } if !runs_task(plc, &task) => {
                    Response::refused(format!(
                        "no task {task}: this PLC runs task {}",
                        plc.project()
                            .tasks
                            .first()
                            .map_or("main", |t| t.name.as_str())
                    ))
                }
                Request::Reload { .. } => {
                    // Compiled off the scan thread; answered when it is swapped in.
                    self.start_reload(plc, Some(env.reply), env.origin, stats.cycles);
                    continue;
                }
                Request::Write { values } => {
                    match plc.write_tags(values.iter().map(|v| (v.tag.as_str(), v.value.as_str())))
                    {
                        Ok(n) => Response {
                            applied_at: Some(stats.cycles),
                            ..Response::done(written(&values, n, stats.cycles))
                        },
                        Err(e) => Response {
                            locked: matches!(e, crate::plc::TagError::Forced { .. }),
                            ..Response::refused(e.to_string())
                        },
                    }
                }
            };
            if let Some((action, what)) = audited {
                self.audit(stats.cycles, &env.origin, action, what, &response);
            }
            // A client that gave up meanwhile has nobody left to tell.
            drop(env.reply.send(response));
        }
    }

    /// Starts compiling the project's program again on a thread of its own; `reply` is told
    /// the outcome once it is swapped in (or refused). A reload already under way answers for
    /// this one too.
    fn start_reload(
        &mut self,
        plc: &Plc,
        reply: Option<Sender<Response>>,
        origin: Origin,
        cycle: u64,
    ) {
        self.reload_waiters.push((reply, origin));
        if self.reload_job.is_some() {
            return;
        }
        let job = plc.reload_job();
        let (tx, rx) = crossbeam_channel::bounded(1);
        let spawned = std::thread::Builder::new()
            .name("reload".into())
            .spawn(move || {
                // The scan may have ended meanwhile: then nobody waits for the result.
                drop(tx.send(job.prepare()));
            });
        match spawned {
            Ok(_) => self.reload_job = Some(rx),
            Err(e) => {
                self.finish_reload(Err(format!("reload refused: no thread for it: {e}")), cycle)
            }
        }
    }

    /// At a cycle boundary: swaps in a program whose compilation has finished.
    fn poll_reload(&mut self, plc: &mut Plc, cycle: u64) {
        let Some(rx) = &self.reload_job else { return };
        let outcome = match rx.try_recv() {
            Ok(Ok(Prepared::Program(prepared))) => {
                plc.apply_reload(prepared);
                Ok(format!(
                    "program {} reloaded",
                    plc.project().program_files()
                ))
            }
            Ok(Ok(Prepared::Unchanged)) => {
                let text = format!("program {} unchanged", plc.project().program_files());
                tracing::info!("{text}");
                Ok(text)
            }
            Ok(Err(e)) => Err(e.to_string()),
            Err(TryRecvError::Empty) => return,
            Err(TryRecvError::Disconnected) => {
                Err("reload refused: its compilation ended without a result".into())
            }
        };
        self.reload_job = None;
        self.finish_reload(outcome, cycle);
    }

    fn finish_reload(&mut self, outcome: Result<String, String>, cycle: u64) {
        if let Err(e) = &outcome {
            tracing::error!("{e}");
        }
        let response = match &outcome {
            Ok(m) => Response::done(m.clone()),
            Err(e) => Response::refused(e.clone()),
        };
        for (reply, origin) in std::mem::take(&mut self.reload_waiters) {
            self.audit(cycle, &origin, Action::Reload, String::new(), &response);
            if let Some(reply) = reply {
                // A client that gave up meanwhile has nobody left to tell.
                drop(reply.send(response.clone()));
            }
        }
    }

    fn notify(&mut self, stats: &ScanStats, now: ScanInstant) {
        let Some(n) = &mut self.notifier else { return };
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
                now.since_origin().as_secs()
            ));
        }
    }
}

/// Whether `plc` runs the task named `task` (a PLC of one task runs `main`, or its one task).
fn runs_task(plc: &Plc, task: &str) -> bool {
    plc.project().tasks.first().is_some_and(|t| t.name == task)
}

/// A module's quality as the change feed offers it: one its line has not reported on yet
/// (its start-up may take the first cycles) is stale, not bad, so its `lost.` alarm is not
/// raised before it was ever asked.
pub(crate) fn feed_quality(m: &crate::plc::ModuleStatus) -> softplc_io::point::Quality {
    if m.reported {
        m.quality
    } else {
        softplc_io::point::Quality::Stale
    }
}

/// Offers what cycle `cycle` of `plc` (ended at `at`) changed to the consumers of `feed`: its
/// image and its modules' qualities. The one way a boundary feeds the services, and a
/// scenario feeds its alarm book, so both see the same changes.
pub(crate) fn offer_cycle(feed: &mut ChangeFeed, plc: &Plc, cycle: u64, at: ScanInstant) {
    feed.offer(
        plc.image(),
        plc.module_status().iter().map(feed_quality),
        cycle,
        at,
    );
}

/// What a write's client is told: the value itself when it was one tag (an operator's), the
/// count otherwise, and the cycle boundary it was applied at.
fn written(values: &[crate::service::control::TagValue], n: usize, cycle: u64) -> String {
    match values {
        [one] => format!(
            "{} written: {} (at cycle {cycle}; the program may change it from its next scan)",
            one.tag, one.value
        ),
        _ => format!("{n} tag(s) written (at cycle {cycle})"),
    }
}

impl CycleBoundary for ServiceBoundary {
    fn started(&mut self, plc: &mut Plc) {
        let n = self.traces.arm_at_start(plc.project());
        if n > 0 {
            tracing::info!("{n} trace(s) of the project armed at start");
        }
    }

    fn between_cycles(&mut self, plc: &mut Plc, stats: &ScanStats, now: ScanInstant) {
        // First, so a sample shows the cycle just ended, before any request changes the PLC.
        self.traces.sample(plc, stats);
        self.answer(plc, stats, now);
        // After the requests: a write applied at this boundary is part of what the services
        // see of it, even when the next scan overwrites it.
        offer_cycle(&mut self.feed, plc, stats.cycles, now);
        if self.reload.swap(false, Ordering::Relaxed) {
            self.start_reload(plc, None, Origin::Signal, stats.cycles);
        }
        if let Some(p) = &mut self.publisher {
            p.publish(plc, stats, now, false);
        }
        self.notify(stats, now);
        // Last, as the scan did before its next cycle: a compilation finished by now is
        // swapped in before that cycle runs.
        self.poll_reload(plc, stats.cycles);
    }

    fn stopping(&mut self, _reason: &StopReason) {
        if let Some(n) = &self.notifier {
            n.notify("STOPPING=1");
        }
    }

    fn stopped(&mut self, plc: &Plc, stats: &ScanStats, reason: &StopReason, now: ScanInstant) {
        // The safe state the outputs were left in, before the publication that tells the
        // services the run is over.
        offer_cycle(&mut self.feed, plc, stats.cycles, now);
        if let Some(p) = &mut self.publisher {
            p.set_stop_reason(match reason {
                StopReason::Requested => "stopped on request".to_string(),
                StopReason::TimeUp => "stopped at the end of its run time".to_string(),
                StopReason::LogicFault(f) => format!("program error: {f}"),
                StopReason::Watchdog(w) => format!("task watchdog: {w}"),
                StopReason::TaskFault { task } => format!("task {task} faulted"),
            });
            p.publish(plc, stats, now, true);
        }
    }
}
