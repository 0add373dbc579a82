//! Client commands for a running instance: `softplc status | force | write | unforce | reload`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use super::out::{errln, out, outln};

use crate::project;
use crate::service::control::{default_socket_path, request, Request, Response, TagValue};

/// Which running instance to talk to.
#[derive(Debug, clap::Args)]
pub(crate) struct Target {
    /// The project file of the running instance (its socket is found from the project name).
    #[arg(long, short = 'p', conflicts_with = "socket")]
    project: Option<PathBuf>,
    /// The instance's control socket, as `softplc run` printed it.
    #[arg(long)]
    socket: Option<PathBuf>,
}

impl Target {
    /// The instance named by its project file or its socket.
    pub(super) fn of(project: Option<PathBuf>, socket: Option<PathBuf>) -> Self {
        Self { project, socket }
    }

    pub(super) fn socket(&self) -> anyhow::Result<PathBuf> {
        if let Some(s) = &self.socket {
            return Ok(s.clone());
        }
        let Some(p) = &self.project else {
            anyhow::bail!("name the instance with --project PROJECT.yaml or --socket PATH");
        };
        let project = project::load(p).map_err(|e| anyhow::anyhow!("{e}"))?;
        Ok(default_socket_path(&project.name))
    }
}

/// Arguments of `softplc status`.
#[derive(Debug, clap::Args)]
pub(crate) struct StatusArgs {
    #[command(flatten)]
    target: Target,
    /// Print the status as JSON.
    #[arg(long)]
    json: bool,
}

/// Arguments of `softplc force` and `softplc write`: a tag and its value.
#[derive(Debug, clap::Args)]
pub(crate) struct TagValueArgs {
    #[command(flatten)]
    target: Target,
    /// The tag.
    tag: String,
    /// The value (1/0, true/false, a number).
    value: String,
}

/// Arguments of `softplc unforce`.
#[derive(Debug, clap::Args)]
pub(crate) struct UnforceArgs {
    #[command(flatten)]
    target: Target,
    /// The tag.
    #[arg(required_unless_present = "all")]
    tag: Option<String>,
    /// Remove every force.
    #[arg(long, conflicts_with = "tag")]
    all: bool,
}

/// Arguments of `softplc reload`.
#[derive(Debug, clap::Args)]
pub(crate) struct ReloadArgs {
    #[command(flatten)]
    target: Target,
    /// Reload only this task's program (a project of several tasks); without it, every task
    /// whose program changed.
    #[arg(long, value_name = "NAME")]
    task: Option<String>,
}

fn send(target: &Target, req: &Request) -> anyhow::Result<ExitCode> {
    let path = target.socket()?;
    let response =
        request(&path, req).with_context(|| format!("no answer from {}", path.display()))?;
    report(&response)
}

/// Prints a response's message and error; the exit status it stands for.
pub(super) fn report(response: &Response) -> anyhow::Result<ExitCode> {
    if let Some(m) = &response.message {
        outln(m)?;
    }
    if let Some(e) = &response.error {
        errln(&format!("error: {e}"));
    }
    Ok(if response.ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

pub(super) fn status(args: StatusArgs) -> anyhow::Result<ExitCode> {
    let path = args.target.socket()?;
    let response = request(&path, &Request::Status)
        .with_context(|| format!("no answer from {}", path.display()))?;
    match (&response.status, args.json) {
        (Some(s), true) => outln(&serde_json::to_string_pretty(s)?)?,
        (Some(s), false) => out(&s.to_string())?,
        (None, _) => errln(&format!("error: {}", response.error.unwrap_or_default())),
    }
    Ok(if response.ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

pub(super) fn force(args: TagValueArgs) -> anyhow::Result<ExitCode> {
    send(
        &args.target,
        &Request::Force {
            tag: args.tag,
            value: args.value,
        },
    )
}

pub(super) fn write(args: TagValueArgs) -> anyhow::Result<ExitCode> {
    send(
        &args.target,
        &Request::Write {
            values: vec![TagValue {
                tag: args.tag,
                value: args.value,
            }],
        },
    )
}

pub(super) fn unforce(args: UnforceArgs) -> anyhow::Result<ExitCode> {
    let tag = if args.all { None } else { args.tag };
    send(&args.target, &Request::Unforce { tag })
}

pub(super) fn reload(args: ReloadArgs) -> anyhow::Result<ExitCode> {
    send(&args.target, &Request::Reload { task: args.task })
}
