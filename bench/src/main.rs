//! softplc-bench: the benchmark harness (issue #8, DESIGN.md principle 8).
//!
//! Runs each scenario (one file each in `scenarios/`), prints the results table, and writes
//! into the results folder: `latest.json` (machine-readable, committed so a later run can be
//! compared with it), `latest.md` (the table) and one SVG per plot.
//!
//! ```sh
//! cargo run --release -p softplc-bench                    # every scenario, a few minutes
//! cargo run --release -p softplc-bench -- --quick         # under a minute
//! cargo run --release -p softplc-bench -- --only bus-cycle --only scale
//! ```

mod compare;
mod cpu_load;
mod json;
mod machine;
mod mbpoll;
mod plot;
mod project_file;
mod python;
mod report;
mod scenarios;
mod sequence;
mod sim_line;
mod sim_scan;
mod softplc_sim;
mod table;
mod terminal;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::Parser;

use crate::report::{Plot, Row};
use crate::scenarios::{Ctx, ScenarioResult};

/// softplc's benchmark harness: scan latency against the manuals' cycle-time figures and the
/// physical floor.
#[derive(Debug, Parser)]
#[command(name = "softplc-bench", version)]
struct Args {
    /// Short runs: every scenario in under a minute (fewer samples, wider percentiles).
    #[arg(long)]
    quick: bool,
    /// Run only this scenario (repeatable; an unknown name is refused with the list):
    /// scheduler, logic-cost, bus-cycle, collect, reaction, pulse, serial-path, scale,
    /// trace-cost, peer, plant-services, full-cycle, virtual-truth, plant-load, blink,
    /// footprint, tasks.
    #[arg(long, value_name = "NAME")]
    only: Vec<String>,
    /// Results folder [default: bench/results for a full run, bench/results/partial for
    /// --quick or --only, so a partial run never replaces the committed results].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// With --only: also put this run's scenarios into the committed bench/results/latest.json,
    /// in place of their earlier entries, keeping every other scenario's entry as it was (each
    /// merged entry says its own run's date, revision and command).
    #[arg(long, requires = "only", conflicts_with = "quick")]
    merge: bool,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let all = scenarios::all();
    for name in &args.only {
        if !all.iter().any(|s| s.name == name) {
            let names: Vec<_> = all.iter().map(|s| s.name).collect();
            anyhow::bail!(
                "no scenario {name:?}; the scenarios are {}",
                names.join(", ")
            );
        }
    }
    let partial = args.quick || !args.only.is_empty();
    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("results");
    let out = args.out.clone().unwrap_or_else(|| {
        if partial {
            committed.join("partial")
        } else {
            committed.clone()
        }
    });
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let scratch = std::env::temp_dir().join(format!("softplc-bench-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)
        .with_context(|| format!("cannot create {}", scratch.display()))?;
    let ctx = Ctx {
        quick: args.quick,
        scratch: scratch.clone(),
    };

    let machine = machine::Machine::describe();
    let command = command_line();
    eprintln!("softplc-bench on {}; {}", machine.summary(), machine.date);
    let started = Instant::now();
    let mut results = Vec::new();
    let mut plots: Vec<Plot> = Vec::new();
    for s in all
        .iter()
        .filter(|s| args.only.is_empty() || args.only.iter().any(|n| n == s.name))
    {
        eprintln!("[{}] {} ...", s.number, s.name);
        let t0 = Instant::now();
        let rows = match (s.run)(&ctx) {
            Ok(outcome) => {
                plots.extend(outcome.plots);
                outcome.rows
            }
            Err(e) => vec![Row::unavailable(
                "—",
                "—",
                format!("the scenario failed: {e:#}"),
            )],
        };
        let took = t0.elapsed();
        eprintln!(
            "[{}] {} done in {:.1} s",
            s.number,
            s.name,
            took.as_secs_f64()
        );
        results.push(ScenarioResult {
            number: s.number,
            name: s.name,
            title: s.title,
            summary: s.summary,
            rows,
            took,
        });
    }
    // Best effort: the scratch folder is under the system temporary folder; a leftover
    // one does not change the results.
    drop(std::fs::remove_dir_all(&scratch));

    let load_at_end = machine::load_average();
    let doc = json::document(&machine, load_at_end, &command, args.quick, &results);
    let text = table::markdown(&results);
    let header = format!(
        "Machine: {}; load average {:.2} at the start, {load_at_end:.2} at the end. \
         Date: {}. Revision: {}. Command: `{command}` ({:.0} s).\n\n",
        machine.summary(),
        machine.load_at_start,
        machine.date,
        machine.revision,
        started.elapsed().as_secs_f64()
    );
    println!("{header}{text}");

    let previous = std::fs::read_to_string(committed.join("latest.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
    if let Some(before) = previous {
        let report = compare::changes(&before, &doc);
        if !report.is_empty() {
            println!("{report}");
        }
    }

    let write = |name: &str, contents: &str| -> anyhow::Result<()> {
        let path = out.join(name);
        std::fs::write(&path, contents).with_context(|| format!("cannot write {}", path.display()))
    };
    write("latest.json", &(serde_json::to_string_pretty(&doc)? + "\n"))?;
    write("latest.md", &format!("{header}{text}"))?;
    for p in &plots {
        write(&p.file, &plot::svg(p))?;
    }
    if args.merge {
        let path = committed.join("latest.json");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read {} to merge into", path.display()))?;
        let before: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{} is not a results document", path.display()))?;
        let merged = json::merge(&before, &doc)
            .with_context(|| format!("cannot merge into {}", path.display()))?;
        std::fs::write(&path, serde_json::to_string_pretty(&merged)? + "\n")
            .with_context(|| format!("cannot write {}", path.display()))?;
        for p in &plots {
            let file = committed.join(&p.file);
            std::fs::write(&file, plot::svg(p))
                .with_context(|| format!("cannot write {}", file.display()))?;
        }
        eprintln!("merged into {}", path.display());
    }
    eprintln!("results in {}", out.display());
    Ok(())
}

/// The command as a user would type it.
fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).collect();
    // A debug build of the harness is enough for a scenario that builds and measures release
    // binaries (footprint); the command says which one ran.
    let mut cmd = if cfg!(debug_assertions) {
        "cargo run -p softplc-bench".to_string()
    } else {
        "cargo run --release -p softplc-bench".to_string()
    };
    if !args.is_empty() {
        cmd.push_str(" -- ");
        cmd.push_str(&args.join(" "));
    }
    cmd
}
