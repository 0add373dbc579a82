//! `softplc alarms`: a running instance's current alarms and latest events;
//! `softplc alarms ack NAME|all`: acknowledges them (noted in the audit file as `cli`).

use std::process::ExitCode;

use anyhow::Context;

use super::control::Target;
use super::out::{errln, out, outln};
use crate::service::alarms::{AlarmList, AlarmRequest, AlarmView};
use crate::service::control::{request, Request};

/// Arguments of `softplc alarms`.
#[derive(Debug, clap::Args)]
pub(crate) struct AlarmsArgs {
    #[command(subcommand)]
    action: Option<AlarmsAction>,
    /// The project file of the running instance (its socket is found from the project name).
    #[arg(long, short = 'p', global = true, conflicts_with = "socket")]
    project: Option<std::path::PathBuf>,
    /// The instance's control socket, as `softplc run` printed it.
    #[arg(long, global = true)]
    socket: Option<std::path::PathBuf>,
    /// How many of the latest events (raised, cleared, acknowledged) to show after the list.
    #[arg(long, default_value_t = 10)]
    history: usize,
    /// Print the answer as JSON (the list, the counts and the events).
    #[arg(long)]
    json: bool,
}

#[derive(Debug, clap::Subcommand)]
enum AlarmsAction {
    /// Acknowledge an alarm (its name: the tag's, or lost.MODULE), or `all` of those waiting.
    Ack(AckArgs),
}

#[derive(Debug, clap::Args)]
struct AckArgs {
    /// The alarm, or `all`.
    alarm: String,
}

pub(super) fn alarms(args: AlarmsArgs) -> anyhow::Result<ExitCode> {
    let asked = match args.action {
        Some(AlarmsAction::Ack(a)) => AlarmRequest::Ack { alarm: a.alarm },
        None => AlarmRequest::List {
            history: Some(args.history),
        },
    };
    let path = Target::of(args.project, args.socket).socket()?;
    let response = request(&path, &Request::Alarms(asked))
        .with_context(|| format!("no answer from {}", path.display()))?;
    match &response.alarms {
        Some(list) if args.json => outln(&serde_json::to_string_pretty(list)?)?,
        Some(list) => out(&describe(list))?,
        None => return super::control::report(&response),
    }
    if let Some(e) = &response.error {
        errln(&format!("error: {e}"));
    }
    Ok(ExitCode::SUCCESS)
}

/// The list as a table, then the events.
fn describe(list: &AlarmList) -> String {
    use std::fmt::Write;
    let c = &list.counts;
    let mut s = format!(
        "{} active (urgent {}, high {}, medium {}, low {}), {} waiting for acknowledgement\n",
        c.active.iter().sum::<u64>(),
        c.active[3],
        c.active[2],
        c.active[1],
        c.active[0],
        c.unacknowledged
    );
    if !list.current.is_empty() {
        let _ = writeln!(
            s,
            "\n  {:<6} {:<8} {:<7} {:<20} {:<32} RAISED",
            "ACK", "STATE", "LEVEL", "NAME", "TEXT"
        );
    }
    for a in &list.current {
        let _ = writeln!(s, "  {}", row(a));
    }
    if !list.history.is_empty() {
        s.push_str("\nlatest events (newest first):\n");
        for e in &list.history {
            let _ = writeln!(s, "  {e}");
        }
    }
    s
}

fn row(a: &AlarmView) -> String {
    format!(
        "{:<6} {:<8} {:<7} {:<20} {:<32} {}",
        if a.acknowledged { "yes" } else { "NO" },
        if a.active { "active" } else { "cleared" },
        a.level,
        a.name,
        a.text,
        a.raised
            .as_ref()
            .map(|r| format!("{} (cycle {})", r.utc, r.cycle))
            .unwrap_or_default()
    )
}
