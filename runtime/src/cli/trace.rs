//! `softplc trace arm | status | save | disarm`: the trace of a running instance, through its
//! control socket (see `crate::service::trace`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;

use super::control::{report, Target};
use super::out::{errln, outln};
use crate::project::trace::RawTrace;
use crate::service::control::{request, Request, Response};
use crate::service::trace::TraceRequest;
use crate::trace::{TraceData, TraceState};

/// The trace subcommands.
#[derive(Debug, clap::Subcommand)]
pub(crate) enum TraceCommand {
    /// Arm the project's trace NAME, or a trace given here with --tags (named NAME, or adhoc).
    Arm(ArmArgs),
    /// Show each trace's state (filling, armed, triggered, complete, recording) and samples.
    Status(StatusArgs),
    /// Write a trace's samples as CSV and/or VCD (a complete repeating trace re-arms).
    Save(SaveArgs),
    /// Stop a trace and forget its samples.
    Disarm(NameArgs),
}

/// Arguments of `softplc trace arm`.
#[derive(Debug, clap::Args)]
pub(crate) struct ArmArgs {
    #[command(flatten)]
    target: Target,
    /// The trace (one of the project's `traces:`, or the name for one given with --tags).
    name: Option<String>,
    /// Signals to record, comma-separated: tags, MODULE.COUNTER, phase.PHASE.
    #[arg(long, value_delimiter = ',')]
    tags: Vec<String>,
    /// `SIGNAL rising|falling|high|low` or `SIGNAL OP NUMBER` (> >= < <= == !=); none: record
    /// continuously.
    #[arg(long, requires = "tags")]
    trigger: Option<String>,
    /// Samples kept before the trigger (default 100).
    #[arg(long, requires = "tags")]
    pre: Option<i64>,
    /// Samples taken after it (default 400).
    #[arg(long, requires = "tags")]
    post: Option<i64>,
    /// `single` or `repeat` (re-armed once saved).
    #[arg(long, requires = "tags")]
    mode: Option<String>,
    /// One sample every N cycles.
    #[arg(long, requires = "tags")]
    every: Option<i64>,
    /// The task whose cycles it samples (a project of several tasks); without it, the task
    /// owning the trigger's signal, or the first signal's.
    #[arg(long, value_name = "NAME")]
    task: Option<String>,
}

/// Arguments of `softplc trace status`.
#[derive(Debug, clap::Args)]
pub(crate) struct StatusArgs {
    #[command(flatten)]
    target: Target,
    /// One trace; all when absent.
    name: Option<String>,
    /// Print the status as JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `softplc trace save`.
#[derive(Debug, clap::Args)]
pub(crate) struct SaveArgs {
    #[command(flatten)]
    target: Target,
    /// The trace.
    name: String,
    /// Write CSV to FILE (`-`: standard output).
    #[arg(long, value_name = "FILE", required_unless_present = "vcd")]
    csv: Option<PathBuf>,
    /// Write VCD (GTKWave, PulseView) to FILE (`-`: standard output).
    #[arg(long, value_name = "FILE")]
    vcd: Option<PathBuf>,
    /// Wait up to this long for the trace to complete first (`10s`, `2m`).
    #[arg(long, value_parser = super::parse_duration)]
    wait: Option<Duration>,
}

/// A trace's name.
#[derive(Debug, clap::Args)]
pub(crate) struct NameArgs {
    #[command(flatten)]
    target: Target,
    /// The trace.
    name: String,
}

pub(super) fn trace(command: TraceCommand) -> anyhow::Result<ExitCode> {
    match command {
        TraceCommand::Arm(a) => arm(a),
        TraceCommand::Status(a) => status(a),
        TraceCommand::Save(a) => save(a),
        TraceCommand::Disarm(a) => {
            let r = ask(&a.target, TraceRequest::Disarm { name: a.name })?;
            report(&r)
        }
    }
}

fn ask(target: &Target, t: TraceRequest) -> anyhow::Result<Response> {
    let path = target.socket()?;
    request(&path, &Request::Trace(t)).with_context(|| format!("no answer from {}", path.display()))
}

fn arm(a: ArmArgs) -> anyhow::Result<ExitCode> {
    let request = if a.tags.is_empty() {
        let Some(name) = a.name else {
            anyhow::bail!("name a trace of the project, or give --tags (and --trigger)");
        };
        TraceRequest::Arm {
            name: Some(name),
            spec: None,
            task: a.task,
        }
    } else {
        TraceRequest::Arm {
            name: None,
            spec: Some(RawTrace {
                name: crate::project::trace::name_or_default(a.name),
                tags: a.tags,
                trigger: a.trigger,
                pre: a.pre,
                post: a.post,
                mode: a.mode,
                every: a.every,
                arm: None,
            }),
            task: a.task,
        }
    };
    let r = ask(&a.target, request)?;
    for s in r.traces.iter().flatten() {
        outln(&s.to_string())?;
    }
    report(&Response { message: None, ..r })
}

fn status(a: StatusArgs) -> anyhow::Result<ExitCode> {
    let r = ask(&a.target, TraceRequest::Status { name: a.name })?;
    let list = r.traces.clone().unwrap_or_default();
    if a.json {
        outln(&serde_json::to_string_pretty(&list)?)?;
    } else if r.ok && list.is_empty() {
        outln("no traces: the project defines none and none is armed")?;
    } else {
        for s in &list {
            outln(&s.to_string())?;
        }
    }
    report(&r)
}

fn save(a: SaveArgs) -> anyhow::Result<ExitCode> {
    if let Some(wait) = a.wait {
        wait_complete(&a.target, &a.name, wait)?;
    }
    let r = ask(&a.target, TraceRequest::Save { name: a.name })?;
    let Some(data) = &r.trace else {
        return report(&r);
    };
    if !matches!(data.state, TraceState::Complete | TraceState::Recording) {
        errln(&format!(
            "warning: trace {} is {}: saving the {} sample(s) it holds",
            data.name,
            data.state,
            data.time_ns.len()
        ));
    }
    if let Some(p) = &a.csv {
        write_to(p, |w| data.write_csv(w).map(drop), data, "CSV")?;
    }
    if let Some(p) = &a.vcd {
        write_to(p, |w| data.write_vcd(w).map(drop), data, "VCD")?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Polls the trace's state until it is complete, or `wait` has passed.
fn wait_complete(target: &Target, name: &str, wait: Duration) -> anyhow::Result<()> {
    let until = Instant::now() + wait;
    loop {
        let r = ask(
            target,
            TraceRequest::Status {
                name: Some(name.to_owned()),
            },
        )?;
        if let Some(e) = r.error {
            anyhow::bail!("{e}");
        }
        let state = r
            .traces
            .and_then(|l| l.into_iter().next())
            .and_then(|s| s.state);
        match state {
            Some(TraceState::Complete | TraceState::Recording) => return Ok(()),
            None => anyhow::bail!("trace {name} is not armed: arm it first"),
            Some(s) if Instant::now() >= until => {
                errln(&format!(
                    "warning: trace {name} is still {s} after {}",
                    crate::scan::fmt_duration(wait)
                ));
                return Ok(());
            }
            Some(_) => std::thread::sleep(Duration::from_millis(100)),
        }
    }
}

fn write_to(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> Result<(), crate::trace::export::ExportError>,
    data: &TraceData,
    what: &str,
) -> anyhow::Result<()> {
    if path == Path::new("-") {
        let stdout = std::io::stdout();
        let mut lock = stdout.lock();
        return write(&mut lock).context("writing to standard output");
    }
    let file =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut out = std::io::BufWriter::new(file);
    write(&mut out).with_context(|| format!("writing {}", path.display()))?;
    out.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    errln(&format!(
        "{what}: {} sample(s) of {} written to {}",
        data.time_ns.len(),
        data.name,
        path.display()
    ));
    Ok(())
}
