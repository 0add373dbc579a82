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
use crate::project::Project;
use crate::scan::{fmt_duration, StopReason, TaskControl, TaskOutcome, TaskSet};
use crate::service::boundary::ServiceBoundary;
use crate::service::notify::Notifier;
use crate::service::web::WebServer;
use crate::service::{Health, TaskStatus};

use super::plant_services::PlantServices;
use super::run::RunArgs;

/// What a run of several tasks does not offer yet, said before anything starts.
fn unsupported(project: &Project, args: &RunArgs) -> Option<String> {
    let what = if project.recorder.is_some() || args.record.is_some() {
        "the flight recorder"
    } else if args.keep_forces {
        "--keep-forces"
    } else {
        return None;
    };
    Some(format!(
        "{}: {what} is not offered for a project of several tasks yet; run it without, or \
         with one task (`scan:` and `program:`)",
        project.source.display()
    ))
}

pub(super) fn run(args: RunArgs, project: Project) -> anyhow::Result<ExitCode> {
    if let Some(why) = unsupported(&project, &args) {
        super::out::errln(&why);
        return Ok(ExitCode::FAILURE);
    }
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
    let builder = TaskBuilder::new(&project, clock.clone(), tap).context("cannot start the PLC")?;
    // The services live on the first task's boundary: its image holds every tag (it copies
    // every tag another task owns at its cycle's start), and their writes reach the owning
    // task through the router. They see the first task's view of the project: every tag at
    // its index, the first task's modules (the ones its snapshot reports).
    let view = {
        let ownership = builder.ownership();
        let mut view = project.task_view(0, |t| ownership.owner(TagId(t as u32)) == Some(0));
        // Every task, for the services' per-task figures (OPC UA's PLC/Tasks, Sparkplug's).
        view.tasks = project.tasks.clone();
        view
    };
    let (requests, requests_rx) = crossbeam_channel::bounded(16);
    let services_clock: Arc<dyn Clock> = match &clock {
        Some(c) => c.clone(),
        None => Arc::new(VirtualClock::new()),
    };
    let mut services = PlantServices::start_early(
        &view,
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
        .map(|t| TaskStatus {
            name: t.name.clone(),
            period: t.scan.period,
            programs: crate::service::status::program_names(&t.programs),
            live: Arc::default(),
        })
        .collect();
    services.start_network(&view, &requests, &health)?;
    let web_later = view.service.web.is_some() && !args.virtual_clock;
    if view.service.web.is_some() && args.virtual_clock {
        tracing::info!("web page: off on the virtual clock (nobody could watch it)");
    }
    // The page starts on the first task's thread once its PLC is built, as a single task's
    // does once its PLC is.
    let web_starter = std::sync::Mutex::new(
        web_later.then(|| services.web_starter(&requests, &health, audit.clone())),
    );
    let web_server: Arc<std::sync::Mutex<Option<WebServer>>> = Arc::default();
    // Every task answers the control requests about its own tags at its own boundary.
    let mut queues = Vec::with_capacity(project.tasks.len());
    let mut boundaries = Vec::with_capacity(project.tasks.len());
    for i in 0..project.tasks.len() {
        let (tx, rx) = crossbeam_channel::bounded(16);
        queues.push(tx);
        let mut b = ServiceBoundary::new()
            .with_control(rx)
            .with_health(health.clone());
        if let Some(log) = &audit {
            b = b.with_audit(log.clone());
        }
        if i == 0 {
            b = b.with_tasks(statuses.clone());
            let notifier = Notifier::from_env();
            if notifier.enabled() {
                b = b.with_notifier(notifier);
            }
            b = services.attach(b, web_later, &statuses);
        }
        boundaries.push(b);
    }
    let control = TaskControl::new();
    let stop = control.stop_flag();
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone()).context("cannot install signal handlers")?;
    }
    let router_stop = Arc::new(AtomicBool::new(false));
    // SIGHUP (`systemctl reload`) must not end the process: it is answered in the log.
    let reload = Arc::new(AtomicBool::new(false));
    signal_hook::flag::register(signal_hook::consts::SIGHUP, reload.clone())
        .context("cannot install the SIGHUP handler")?;
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
        move |tag| {
            let i = *tag_index.get(tag)?;
            ownership.owner(TagId(i as u32))
        },
        router_stop.clone(),
        reload,
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
        let (run_for, statuses, health) = (args.run_for, statuses.clone(), health.clone());
        let web_server = web_server.clone();
        move |i: usize, plc: TaskPlc, boundary: ServiceBoundary| {
            if let Some(r) = plc.plc.retainer() {
                health.watch_retain(r.save_failure());
            }
            let starter = match i {
                0 => web_starter.lock().ok().and_then(|mut s| s.take()),
                _ => None,
            };
            if let Some(starter) = starter {
                let web = starter.start(&plc.plc);
                if let Ok(mut slot) = web_server.lock() {
                    *slot = web;
                }
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
    services.keep_web(web_server.lock().ok().and_then(|mut w| w.take()));
    services.finish_services();
    if let Some(log) = &audit {
        log.finish(Duration::from_secs(2));
    }
    if let Some(printer) = printer {
        printer.finish(Duration::from_secs(2));
    }
    services.let_web_see_the_end();
    super::out::out(&summary(&outcomes, &project, args.run_for))?;
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
