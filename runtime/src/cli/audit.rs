//! `softplc audit`: the audit file's latest entries (who wrote, forced, unforced or reloaded,
//! and when). Read from the file, so it answers whether or not the instance runs.

use std::path::PathBuf;
use std::process::ExitCode;

use super::out::outln;
use crate::service::audit::{audit_path, read};

/// Arguments of `softplc audit`.
#[derive(Debug, clap::Args)]
pub(crate) struct AuditArgs {
    /// The project file (its audit file is PROJECT.audit.jsonl in its state folder).
    #[arg(long, short = 'p')]
    project: PathBuf,
    /// How many of the latest entries to show.
    #[arg(long, default_value_t = 20)]
    last: usize,
    /// Print the entries as JSON lines, as the file holds them.
    #[arg(long)]
    json: bool,
}

pub(super) fn audit(args: AuditArgs) -> anyhow::Result<ExitCode> {
    let path = audit_path(&args.project);
    let entries = read(&path)?;
    if entries.is_empty() {
        outln(&format!("{}: no entry yet", path.display()))?;
    }
    let from = entries.len().saturating_sub(args.last);
    for e in &entries[from..] {
        if args.json {
            outln(&serde_json::to_string(e)?)?;
        } else {
            outln(&e.to_string())?;
        }
    }
    Ok(ExitCode::SUCCESS)
}
