//! `softplc run PROJECT`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;

use crate::clock::{Clock, MonotonicClock, VirtualClock};
use crate::plc::Plc;
use crate::recorder::{RecorderHandle, Settings, WriterOutcome};
use crate::scan::{fmt_duration, rt, RunOutcome, ScanEngine, StopReason};
use crate::service::alarms::AlarmService;
use crate::service::boundary::ServiceBoundary;
use crate::service::changes::ChangeFeed;
use crate::service::control::{default_socket_path, ControlServer};
use crate::service::notify::Notifier;
use crate::service::{Health, Service, ServiceState};

use super::plant_services::PlantServices;

/// Arguments of `softplc run`.
#[derive(Debug, clap::Args)]
pub(crate) struct RunArgs {
    /// The project file.
    pub(super) project: PathBuf,
    /// Stop by itself after this long (e.g. 10s, 2m); the safe state is written as on SIGINT.
    #[arg(long = "for", value_parser = super::parse_duration)]
    pub(super) run_for: Option<Duration>,
    /// Run on a virtual clock, as fast as the machine allows (needs --for). Deterministic:
    /// two runs give the same trace.
    #[arg(long = "virtual", requires = "run_for")]
    pub(super) virtual_clock: bool,
    /// No live status line.
    #[arg(long)]
    pub(super) quiet: bool,
    /// The control socket (status, force, reload); default: from the project name, under
    /// $RUNTIME_DIRECTORY, $XDG_RUNTIME_DIR/softplc or /tmp/softplc-UID.
    /// The same flag as `status`, `force`, `reload` take (`--control` is the older name,
    /// still accepted).
    #[arg(long = "socket", alias = "control")]
    pub(super) control: Option<PathBuf>,
    /// Keep forces across restarts, in PROJECT.forces.json beside the project file (with
    /// several tasks, PROJECT.forces.TASK.json per task; by default a restart clears every
    /// force).
    #[arg(long)]
    pub(super) keep_forces: bool,
    /// Keep a flight record of at least this much scan time (e.g. 10m), in PROJECT.record
    /// beside the project file (the state directory under systemd; a folder per task in it
    /// for a project of several tasks); the project's
    /// `recorder:` section gives its other settings (and turns it on without this flag).
    #[arg(long, value_name = "KEEP", value_parser = super::parse_duration)]
    pub(super) record: Option<Duration>,
    /// Run the scan thread at SCHED_FIFO with this priority (1..=99) when the project's
    /// `scan.realtime.priority` does not say; the service unit passes 50. Best effort: a
    /// refusal (no CAP_SYS_NICE, an RLIMIT_RTPRIO too low) is a warning in the log.
    #[arg(long, value_name = "PRIORITY", value_parser = clap::value_parser!(u8).range(1..=99))]
    pub(super) realtime_priority: Option<u8>,
    /// Do not open a control socket.
    #[arg(long = "no-socket", alias = "no-control", conflicts_with = "control")]
    pub(super) no_control: bool,
    /// Print every frame each bus sends and receives (and every timeout and discarded byte)
    /// on stdout, with the line's time, hex and decoding (docs/buses.md, "Seeing the wire").
    #[arg(long)]
    pub(super) trace_bus: bool,
}

pub(super) fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    let project = match super::built_services::load(&args.project) {
        Ok(p) => p,
        Err(errors) => {
            super::out::errln(&errors);
            return Ok(ExitCode::FAILURE);
        }
    };
    if project.multitask() {
        return super::run_tasks::run(args, project);
    }
    let clock: Arc<dyn Clock> = if args.virtual_clock {
        Arc::new(VirtualClock::new())
    } else {
        Arc::new(MonotonicClock::new())
    };
    // From now on every journal entry names the project (and modules by bus and address).
    super::journal::set_context(&project);
    let mut realtime = project.scan.realtime;
    // The project's own priority wins; the flag is the service unit's default.
    if realtime.priority.is_none() {
        realtime.priority = args.realtime_priority;
    }
    let name = project.name.clone();
    let period = project.scan.period;
    let trace = match args.trace_bus {
        true => Some(super::trace_bus::start(args.virtual_clock)?),
        false => None,
    };
    let tap = trace.as_ref().map(|(tap, _)| tap.clone() as _);
    // Every service's state, for status, metrics and the page.
    let health = Health::new();
    // Requests to the scan: from the control socket and from the Modbus TCP server's writes.
    let (requests, requests_rx) = crossbeam_channel::bounded(16);
    let audit = start_audit(&args.project, &health);
    let mut services = PlantServices::start_early(
        &project,
        &clock,
        &args.project,
        audit.clone(),
        &health,
        &requests,
    )?;
    let mut plc = Plc::build_traced(project, clock, None, tap).context("cannot start the PLC")?;
    let printer = trace.map(|(_, printer)| printer);
    if args.keep_forces {
        plc.keep_forces(crate::plc::forces_path(&args.project));
    }
    // After the kept forces: the record's first keyframe is the state the first cycle sees.
    let recorder = match Settings::for_run(plc.project(), args.record) {
        Some(settings) => {
            tracing::info!(
                "flight recorder: {} (keeps {}, at most {} MiB)",
                settings.folder.display(),
                fmt_duration(settings.keep),
                settings.max_bytes >> 20
            );
            let handle = plc.record(settings)?;
            health.watch_recorder(handle.state_cell());
            Some(handle)
        }
        None => None,
    };
    if let Some(r) = plc.retainer() {
        health.watch_retain(r.save_failure());
    }
    health.set(Service::Trace, ServiceState::Running);
    let mut engine = ScanEngine::new(plc);
    if let Some(d) = args.run_for {
        engine = engine.run_for(d);
    }
    let stop = engine.stop_flag();
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, stop.clone()).context("cannot install signal handlers")?;
    }
    let mut boundary = ServiceBoundary::new()
        .with_control(requests_rx)
        .with_health(health.clone());
    if let Some(log) = &audit {
        boundary = boundary.with_audit(log.clone());
    }
    signal_hook::flag::register(signal_hook::consts::SIGHUP, boundary.reload_flag())
        .context("cannot install the SIGHUP handler")?;
    let _control = open_control(&args, &name, &requests)?;
    services.start_network(engine.plc().project(), &requests, &health)?;
    if args.virtual_clock {
        if engine.plc().project().service.web.is_some() {
            tracing::info!("web page: off on the virtual clock (nobody could watch it)");
        }
    } else {
        let web = services.web_starter(&requests, &health, audit.clone());
        services.keep_web(web.start(engine.plc()));
    }
    boundary = services.attach(boundary, false);
    let notifier = Notifier::from_env();
    if notifier.enabled() {
        boundary = boundary.with_notifier(notifier);
    }
    engine = engine.with_boundary(boundary);
    let status = engine.status();
    tracing::info!(
        "{name}: scanning every {}{}",
        fmt_duration(period),
        args.run_for
            .map(|d| format!(" for {}", fmt_duration(d)))
            .unwrap_or_default()
    );
    let scan = std::thread::Builder::new()
        .name("scan".into())
        .spawn(move || {
            for note in rt::apply(&realtime).notes {
                if note.applied {
                    tracing::info!("{}", note.text);
                } else {
                    tracing::warn!("{}", note.text);
                }
            }
            engine.run()
        })
        .context("cannot start the scan thread")?;

    watch_live(&scan, !args.quiet && !args.virtual_clock, || {
        let s = status.lock().ok()?;
        Some(format!(
            "t={:>7} scans {:>6}  cycle p50 {} p99 {} max {}  overruns {}  bus errors {}",
            s.now,
            s.cycles,
            fmt_duration(s.cycle.p50),
            fmt_duration(s.cycle.p99),
            fmt_duration(s.cycle.max),
            s.overruns,
            s.bus_errors
        ))
    });
    let outcome = scan
        .join()
        .map_err(|_| anyhow::anyhow!("the scan thread panicked"))?;
    services.finish_services();
    if let Some(log) = &audit {
        // The last actions (a reload just before the stop) reach the file before the process
        // ends.
        log.finish(Duration::from_secs(2));
    }
    if let Some(printer) = printer {
        // The trace's last lines (the safe state written) come before the summary.
        printer.finish(Duration::from_secs(2));
    }
    services.let_web_see_the_end();
    super::out::out(&summary(&outcome, period, args.run_for))?;
    if let Some(r) = recorder {
        for line in recorder_end(None, r) {
            super::out::errln(&line);
        }
    }
    Ok(match outcome.reason {
        StopReason::Requested | StopReason::TimeUp => ExitCode::SUCCESS,
        _ => ExitCode::from(3),
    })
}

/// Waits for a recorder's writer once its PLC is gone (the writer then has its last
/// records) and says what the record misses; `task` names the task whose record it is, for
/// a project of several tasks.
pub(super) fn recorder_end(task: Option<&str>, recorder: RecorderHandle) -> Vec<String> {
    let dropped = recorder.dropped();
    let outcome = recorder.finish();
    record_misses(task, dropped, &outcome)
}

/// What a record misses, as the run's end says it: the writer's error, its gaps, the records
/// dropped.
fn record_misses(task: Option<&str>, dropped: u64, outcome: &WriterOutcome) -> Vec<String> {
    let who = match task {
        Some(task) => format!("flight recorder, task {task}"),
        None => "flight recorder".to_string(),
    };
    let mut lines = Vec::new();
    if let Some(e) = &outcome.error {
        lines.push(match task {
            Some(task) => format!("task {task}: {e}"),
            None => e.clone(),
        });
    }
    if outcome.gaps > 0 {
        lines.push(format!(
            "{who}: {} cycle(s) not recorded in {} gap(s) (the disk was full); replay names \
             them",
            outcome.lost, outcome.gaps
        ));
    }
    if dropped > 0 {
        lines.push(format!(
            "{who}: {dropped} cycle record(s) dropped (the disk did not keep up); replay \
             reports the gaps"
        ));
    }
    lines
}

/// Starts the alarm thread on its share of `feed`, with its history beside the project; a
/// thread that cannot start is logged and the PLC runs without alarms.
pub(super) fn start_alarms(
    project: &crate::project::Project,
    clock: &Arc<dyn Clock>,
    project_file: &std::path::Path,
    feed: &mut ChangeFeed,
    audit: Option<crate::service::audit::AuditLog>,
    health: &Health,
) -> Option<AlarmService> {
    let path = crate::service::alarms::history_path(project_file);
    let stream = feed.subscribe("alarms", crate::service::changes::QUEUE_CYCLES);
    let wall = crate::service::alarms::book::wall_origin(clock.now());
    match AlarmService::start(project, stream, path.clone(), wall, audit) {
        Ok(service) => {
            tracing::info!("alarm history {}", path.display());
            let probe = service.alarms().clone();
            health.watch(Service::Alarms, move || probe.state());
            Some(service)
        }
        Err(e) => {
            tracing::error!("alarms: cannot start their thread ({e}); no alarm is evaluated");
            health.set(Service::Alarms, ServiceState::Stopped(e.to_string()));
            None
        }
    }
}

/// The control socket (`--socket`, else the default path for project `name`) feeding
/// `requests`; `None` with `--no-socket`.
pub(super) fn open_control(
    args: &RunArgs,
    name: &str,
    requests: &crossbeam_channel::Sender<crate::service::control::Envelope>,
) -> anyhow::Result<Option<ControlServer>> {
    if args.no_control {
        return Ok(None);
    }
    let path = args
        .control
        .clone()
        .unwrap_or_else(|| default_socket_path(name));
    let server = ControlServer::start(&path, requests.clone())
        .with_context(|| format!("cannot open the control socket {}", path.display()))?;
    tracing::info!("control socket {}", server.path().display());
    Ok(Some(server))
}

/// The audit file's writer for the project at `project`, its state watched by `health`;
/// `None` (said in the log and the status) when it cannot start: the PLC runs without it.
pub(super) fn start_audit(
    project: &std::path::Path,
    health: &Health,
) -> Option<crate::service::audit::AuditLog> {
    let audit_file = crate::service::audit::audit_path(project);
    match crate::service::audit::AuditLog::start(audit_file.clone()) {
        Ok(log) => {
            tracing::info!("audit file {}", audit_file.display());
            let probe = log.clone();
            health.watch(Service::Audit, move || probe.state());
            Some(log)
        }
        Err(e) => {
            tracing::error!("audit: cannot start its writer ({e}); nothing is audited");
            health.set(Service::Audit, ServiceState::Stopped(e.to_string()));
            None
        }
    }
}

/// Until `scan` ends, prints `line()` on stderr when `live`: every 500 ms over itself on a
/// terminal, every 2 s as a line of its own otherwise.
pub(super) fn watch_live<T>(
    scan: &std::thread::JoinHandle<T>,
    live: bool,
    line: impl Fn() -> Option<String>,
) {
    let tty = std::io::stderr().is_terminal();
    let mut last_print = std::time::Instant::now();
    while !scan.is_finished() {
        std::thread::sleep(Duration::from_millis(100));
        if live && last_print.elapsed() >= Duration::from_millis(if tty { 500 } else { 2000 }) {
            last_print = std::time::Instant::now();
            let Some(line) = line() else { continue };
            // Best effort: a closed stderr must not stop the PLC.
            if tty {
                super::out::err(&format!("\r\x1b[2K{line}"));
            } else {
                super::out::errln(&line);
            }
        }
    }
    if live && tty {
        super::out::errln("");
    }
}

/// The end-of-run summary.
pub(crate) fn summary(outcome: &RunOutcome, period: Duration, run_for: Option<Duration>) -> String {
    use std::fmt::Write;
    let s = &outcome.stats;
    let mut out = String::new();
    let reason = match &outcome.reason {
        StopReason::Requested => "stopped on request; outputs set to their safe values".to_string(),
        StopReason::TimeUp => match run_for {
            Some(d) => format!(
                "stopped after its run time (--for {}); outputs set to their safe values",
                fmt_duration(d)
            ),
            None => "stopped at its cycle limit; outputs set to their safe values".to_string(),
        },
        StopReason::LogicFault(f) => {
            format!("FAULT: program error: {f}; outputs set to their safe values")
        }
        StopReason::Watchdog(w) => {
            format!("FAULT: task watchdog: {w}; outputs set to their safe values")
        }
        StopReason::TaskFault { task } => {
            format!(
                "FAULT: task {task} faulted; every task stopped, outputs set to their safe values"
            )
        }
    };
    let _ = writeln!(out, "{reason}");
    let _ = writeln!(
        out,
        "scans {}  overruns {}  period {}",
        s.cycles,
        s.overruns,
        fmt_duration(period)
    );
    let _ = writeln!(out, "  cycle     {}", s.cycle.percentiles());
    let _ = writeln!(out, "  inputs    {}", s.read.percentiles());
    let _ = writeln!(out, "  logic     {}", s.logic.percentiles());
    let _ = writeln!(out, "  outputs   {}", s.write.percentiles());
    let _ = writeln!(out, "  boundary  {}", s.boundary.percentiles());
    let _ = writeln!(out, "  lateness  {}", s.lateness.percentiles());
    for m in &outcome.modules {
        let c = &m.counters;
        let _ = writeln!(
            out,
            "  module {} ({}): {}  requests {} timeouts {} crc {} bad replies {} exceptions {} last round trip {}",
            m.name,
            m.bus,
            m.quality,
            c.requests,
            c.timeouts,
            c.crc_errors,
            c.bad_replies,
            c.exceptions,
            fmt_duration(c.last_round_trip)
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_a_record_misses_names_the_task_of_several_and_reads_as_before_for_one() {
        let outcome = WriterOutcome {
            gaps: 1,
            lost: 12,
            error: Some("flight recorder: cannot write to p.record/panel: gone".into()),
            ..WriterOutcome::default()
        };
        assert_eq!(
            record_misses(Some("panel"), 3, &outcome),
            [
                "task panel: flight recorder: cannot write to p.record/panel: gone",
                "flight recorder, task panel: 12 cycle(s) not recorded in 1 gap(s) (the disk \
                 was full); replay names them",
                "flight recorder, task panel: 3 cycle record(s) dropped (the disk did not keep \
                 up); replay reports the gaps",
            ]
        );
        assert_eq!(
            record_misses(
                None,
                0,
                &WriterOutcome {
                    gaps: 2,
                    lost: 5,
                    ..WriterOutcome::default()
                }
            ),
            [
                "flight recorder: 5 cycle(s) not recorded in 2 gap(s) (the disk was full); replay \
              names them"
            ]
        );
        assert!(record_misses(None, 0, &WriterOutcome::default()).is_empty());
    }
}
