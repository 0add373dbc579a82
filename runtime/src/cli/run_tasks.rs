//! `softplc run` for a project of several tasks: one PLC per task, each scan on a thread of
//! its own at its own real-time priority (virtual clocks: one after the other, in the order
//! of their cycles' starts), the control socket's requests handed to the task they concern.

use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;

use crate::clock::{Clock, MonotonicClock, VirtualClock};
use crate::image::TagId;
use crate::plc::{TaskBuilder, TaskPlc};
use crate::project::task_view::task_file;
use crate::project::Project;
use crate::scan::{fmt_duration, StopReason, TaskControl, TaskOutcome, TaskSet};
use crate::service::boundary::ServiceBoundary;
use crate::service::notify::Notifier;
use crate::service::task_router::{trace_home, TagOwner, TraceRoutes};
use crate::service::task_share::TaskShare;
use crate::service::{Health, PerTask, Service, ServiceState, TaskStatus};
use crate::trace::{TraceLedger, TraceSet};

use super::task_record::TaskRecording;
use super::task_web::TaskWeb;

use super::plant_services::PlantServices;
use super::run::RunArgs;

pub(super) fn run(args: RunArgs, project: Project) -> anyhow::Result<ExitCode> {
    let clock: Option<Arc<dyn Clock>> = match args.virtual_clock {
        true => None,
        false => Some(Arc::new(MonotonicClock::new())),
    };
    super::journal::set_context(&project);
    let trace = match args.trace_bus {
        true => Some(super::trace_bus::start(args.virtual_clock)?),
        false => None,
    };
    let tap = trace.as_ref().map(|(tap, _)| tap.clone() as _);
    let health = Health::new();
    let audit = super::run::start_audit(&args.project, &health);
    let recording = TaskRecording::prepare(&project, &args)?;
    if let Some(r) = &recording {
        health.watch_tasks(Service::Recorder, r.recorders.clone());
    }
    // Each task saves its retained tags in a file of its own, through a writer of its own.
    let retains = PerTask::new();
    health.watch_tasks(Service::Retain, retains.clone());
    let builder = TaskBuilder::new(&project, clock.clone(), tap).context("cannot start the PLC")?;
    // The services see the whole project (every tag, every module at its place); each task's
    // boundary publishes and feeds them its share (the tags it owns, its modules, its
    // forces) at its own cycle end, and the first task's answers for the whole PLC. Their
    // writes reach the owning task through the router.
    let shares = TaskShare::all(&project, builder.ownership());
    let (requests, requests_rx) = crossbeam_channel::bounded(16);
    let services_clock: Arc<dyn Clock> = match &clock {
        Some(c) => c.clone(),
        None => Arc::new(VirtualClock::new()),
    };
    let mut services = PlantServices::start_early(
        &project,
        &services_clock,
        &args.project,
        audit.clone(),
        &health,
        &requests,
    )?;
    let printer = trace.map(|(_, printer)| printer);
    let statuses: Vec<TaskStatus> = project
        .tasks
        .iter()
        .zip(&shares)
        .map(|(t, share)| TaskStatus {
            name: t.name.clone(),
            period: t.scan.period,
            programs: crate::service::status::program_names(&t.programs),
            live: Arc::default(),
            modules: share.modules().to_vec(),
        })
        .collect();
    services.start_network(&project, &requests, &health)?;
    let web_later = project.service.web.is_some() && !args.virtual_clock;
    if project.service.web.is_some() && args.virtual_clock {
        tracing::info!("web page: off on the virtual clock (nobody could watch it)");
    }
    // The page draws every task's programs; it starts once the first task's PLC is built, as
    // a single task's does once its PLC is.
    let web = Arc::new(TaskWeb::new(
        &project,
        &builder,
        web_later.then(|| services.web_starter(&requests, &health, audit.clone())),
    ));
    // Every task answers the control requests about its own tags at its own boundary, and
    // keeps the traces of its own cycles, all against the PLC's one trace budget.
    let ledger = TraceLedger::new();
    // Traces are armed on every task's boundary, as on a single task's.
    health.set(Service::Trace, ServiceState::Running);
    let mut queues = Vec::with_capacity(project.tasks.len());
    let mut boundaries = Vec::with_capacity(project.tasks.len());
    for (i, task) in project.tasks.iter().enumerate() {
        let (tx, rx) = crossbeam_channel::bounded(16);
        queues.push(tx);
        // The project's traces this task samples: each in the task its signals point to.
        let at_start = project
            .traces
            .iter()
            .filter(|t| trace_home(&project, builder.ownership(), t) == i)
            .map(|t| t.name.clone())
            .collect();
        let mut b = ServiceBoundary::new()
            .with_control(rx)
            .with_health(health.clone())
            .with_traces(TraceSet::of_task(
                task.name.clone(),
                ledger.clone(),
                at_start,
            ));
        if let Some(log) = &audit {
            b = b.with_audit(log.clone());
        }
        if i == 0 {
            b = b.with_tasks(statuses.clone());
            let notifier = Notifier::from_env();
            if notifier.enabled() {
                b = b.with_notifier(notifier);
            }
        }
        boundaries.push(b);
    }
    let boundaries = services.attach_tasks(boundaries, shares, web_later, &statuses);
    let control = TaskControl::new();
    let stop = control.stop_flag();
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone()).context("cannot install signal handlers")?;
    }
    let router_stop = Arc::new(AtomicBool::new(false));
    // SIGHUP (`systemctl reload`) reloads every task whose program changed, each at its own
    // cycle boundary, each logging what became of it.
    for b in &boundaries {
        signal_hook::flag::register(signal_hook::consts::SIGHUP, b.reload_flag())
            .context("cannot install the SIGHUP handler")?;
    }
    let tag_index: std::collections::HashMap<String, usize> = project
        .tags
        .iter()
        .enumerate()
        .map(|(i, t)| (t.name.clone(), i))
        .collect();
    let ownership = builder.ownership().clone();
    let router = crate::service::task_router::start(
        requests_rx,
        queues,
        builder.names(),
        move |tag| match tag_index.get(tag) {
            None => TagOwner::Unknown,
            Some(&i) => ownership
                .owner(TagId(i as u32))
                .map_or(TagOwner::Nobody, TagOwner::Task),
        },
        TraceRoutes {
            project: project.clone(),
            ownership: builder.ownership().clone(),
            ledger,
        },
        router_stop.clone(),
    )
    .context("cannot start the control requests' router")?;
    let _control = super::run::open_control(&args, &project.name, &requests)?;
    for t in &project.tasks {
        tracing::info!(
            "{}: task {} every {}",
            project.name,
            t.name,
            fmt_duration(t.scan.period)
        );
    }
    let engine = {
        let control = control.clone();
        let (run_for, statuses) = (args.run_for, statuses.clone());
        let web = web.clone();
        let recording = recording.clone();
        // Each task keeps the forces of its own image, in a file of its own (as it keeps its
        // retained tags), so two task threads never write one file.
        let kept_forces = args
            .keep_forces
            .then(|| crate::plc::forces_path(&args.project));
        move |i: usize, mut plc: TaskPlc, boundary: ServiceBoundary| {
            if let Some(path) = &kept_forces {
                plc.plc.keep_forces(task_file(path, &plc.name));
            }
            if let Some(r) = plc.plc.retainer() {
                retains.add_retain(&plc.name, r.save_failure());
            }
            web.built();
            // Last before its first cycle: the record's first keyframe is the state it sees.
            if let Some(r) = &recording {
                r.start(i, &mut plc);
            }
            let mut engine = control
                .engine(plc)
                .with_status(statuses[i].live.clone())
                .with_boundary(boundary);
            if let Some(d) = run_for {
                engine = engine.run_for(d);
            }
            engine
        }
    };
    let scan = if args.virtual_clock {
        start_virtual(builder, boundaries, engine)?
    } else {
        start_threads(builder, boundaries, engine, control, args.realtime_priority)?
    };
    super::run::watch_live(&scan, !args.quiet && !args.virtual_clock, || {
        Some(live_line(&statuses))
    });
    let outcomes = scan
        .join()
        .map_err(|_| anyhow::anyhow!("a task's thread panicked"))??;
    router_stop.store(true, std::sync::atomic::Ordering::Relaxed);
    drop(router.join());
    services.keep_web(web.take_server());
    services.finish_services();
    if let Some(log) = &audit {
        log.finish(Duration::from_secs(2));
    }
    if let Some(printer) = printer {
        printer.finish(Duration::from_secs(2));
    }
    services.let_web_see_the_end();
    super::out::out(&summary(&outcomes, &project, args.run_for))?;
    if let Some(r) = recording {
        for line in r.finish() {
            super::out::errln(&line);
        }
    }
    let faulted = outcomes
        .iter()
        .any(|o| !matches!(o.outcome.reason, StopReason::Requested | StopReason::TimeUp));
    Ok(if faulted {
        ExitCode::from(3)
    } else {
        ExitCode::SUCCESS
    })
}

/// Builds every task on the calling thread, each on its own virtual clock, and runs them on
/// a thread of their own, cycle after cycle in the order of their starts.
fn start_virtual(
    builder: TaskBuilder,
    boundaries: Vec<ServiceBoundary>,
    engine: impl Fn(usize, TaskPlc, ServiceBoundary) -> crate::scan::ScanEngine + Send + 'static,
) -> anyhow::Result<std::thread::JoinHandle<anyhow::Result<Vec<TaskOutcome>>>> {
    let plcs = (0..builder.names().len())
        .map(|i| builder.build(i))
        .collect::<Result<Vec<_>, _>>()
        .context("cannot start the PLC")?;
    let names = builder.names();
    std::thread::Builder::new()
        .name("tasks".into())
        .spawn(move || {
            let engines = plcs
                .into_iter()
                .zip(boundaries)
                .enumerate()
                .map(|(i, (plc, b))| engine(i, plc, b))
                .collect();
            Ok(TaskSet::from_engines(names, engines).run_virtual())
        })
        .context("cannot start the tasks")
}

/// Builds and runs every task on a thread of its own (`scan-TASK`), at its real-time
/// options: each starts its cycles once its own lines have started. A task that cannot start
/// stops the others, as a fault does.
fn start_threads(
    builder: TaskBuilder,
    boundaries: Vec<ServiceBoundary>,
    engine: impl Fn(usize, TaskPlc, ServiceBoundary) -> crate::scan::ScanEngine + Send + Sync + 'static,
    control: TaskControl,
    default_priority: Option<u8>,
) -> anyhow::Result<std::thread::JoinHandle<anyhow::Result<Vec<TaskOutcome>>>> {
    let builder = Arc::new(builder);
    let engine = Arc::new(engine);
    let mut handles = Vec::new();
    for (i, (name, boundary)) in builder.names().into_iter().zip(boundaries).enumerate() {
        let (builder, engine, control) = (builder.clone(), engine.clone(), control.clone());
        let handle = std::thread::Builder::new()
            .name(format!("scan-{name}"))
            .spawn(move || -> anyhow::Result<TaskOutcome> {
                let mut realtime = builder.realtime(i);
                realtime.priority = realtime.priority.or(default_priority);
                for note in crate::scan::rt::apply(&realtime).notes {
                    if note.applied {
                        tracing::info!("task {name}: {}", note.text);
                    } else {
                        tracing::warn!("task {name}: {}", note.text);
                    }
                }
                let plc = match builder.build(i) {
                    Ok(plc) => plc,
                    Err(e) => {
                        control.fault(&name);
                        return Err(anyhow::Error::new(e)
                            .context(format!("task {name}: cannot start its PLC")));
                    }
                };
                let outcome = engine(i, plc, boundary).run();
                Ok(TaskOutcome { name, outcome })
            })
            .context("cannot start a task's thread")?;
        handles.push(handle);
    }
    std::thread::Builder::new()
        .name("tasks".into())
        .spawn(move || {
            handles
                .into_iter()
                .map(|h| {
                    h.join()
                        .map_err(|_| anyhow::anyhow!("a task's thread panicked"))?
                })
                .collect()
        })
        .context("cannot start the tasks")
}

/// The live status line: each task's cycles, cycle time and overruns.
fn live_line(statuses: &[TaskStatus]) -> String {
    statuses
        .iter()
        .filter_map(|t| {
            let s = t.live.lock().ok()?;
            Some(format!(
                "{}: t={} cycles {} p99 {} max {} overruns {}",
                t.name,
                s.now,
                s.cycles,
                fmt_duration(s.cycle.p99),
                fmt_duration(s.cycle.max),
                s.overruns
            ))
        })
        .collect::<Vec<_>>()
        .join(" | ")
}

/// The end-of-run summary: why the PLC stopped (the fault first), then each task's figures
/// as a run of one task prints them.
fn summary(outcomes: &[TaskOutcome], project: &Project, run_for: Option<Duration>) -> String {
    let first = outcomes
        .iter()
        .find(|o| {
            matches!(
                o.outcome.reason,
                StopReason::LogicFault(_) | StopReason::Watchdog(_)
            )
        })
        .or_else(|| outcomes.first());
    let mut out = String::new();
    for (i, o) in outcomes.iter().enumerate() {
        let period = project
            .tasks
            .get(i)
            .map_or(project.scan.period, |t| t.scan.period);
        let text = super::run::summary(&o.outcome, period, run_for);
        // The first line is why the task stopped: the PLC's reason comes once, at the top.
        let mut lines = text.lines();
        let reason = lines.next().unwrap_or_default();
        if first.is_some_and(|f| std::ptr::eq(f, o)) {
            out.push_str(&format!("{reason}\n"));
        }
        out.push_str(&format!("task {}:\n", o.name));
        for line in lines {
            out.push_str(&format!("  {}\n", line.trim_start_matches("  ")));
        }
    }
    out
}
