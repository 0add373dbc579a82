//! `softplc test PROJECT_OR_SCENARIO`: runs scenario files on a virtual clock against the
//! simulated modules and checks the outputs at the given times; with several programs, checks
//! that they give the same trace. Exit status 1 when anything fails.

pub(crate) mod alarms;
pub(crate) mod runner;
pub(crate) mod scenario;
pub(crate) mod trace;
pub(crate) mod variants;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Arguments of `softplc test`.
#[derive(Debug, clap::Args)]
pub(crate) struct TestArgs {
    /// A scenario file (`*.scenario.yaml`), a folder (every scenario under it) or a project
    /// file (the scenarios beside it and its program that use it).
    path: PathBuf,
    /// Print every run's trace, not only the failing ones.
    #[arg(long)]
    verbose: bool,
}

/// The scenarios `path` names.
pub(crate) fn find(path: &Path) -> std::io::Result<Vec<PathBuf>> {
    if path.is_dir() {
        let mut out = Vec::new();
        walk(path, &mut out)?;
        out.sort();
        return Ok(out);
    }
    if is_scenario(path) {
        return Ok(vec![path.to_path_buf()]);
    }
    // A project: the scenarios near it and near its program that name it.
    let project = std::fs::canonicalize(path)?;
    let mut dirs = vec![project.parent().map(Path::to_path_buf).unwrap_or_default()];
    if let Ok(p) = crate::project::load(path) {
        // Every program's folder, unless it is the project's own (then walked once).
        let folders = p.tasks.iter().flat_map(|t| &t.programs);
        for d in folders.filter_map(|p| std::fs::canonicalize(p.path.parent()?).ok()) {
            if !dirs.contains(&d) {
                dirs.push(d);
            }
        }
    }
    let mut out = Vec::new();
    for d in dirs {
        let mut found = Vec::new();
        walk(&d, &mut found)?;
        for f in found {
            let text = std::fs::read_to_string(&f).unwrap_or_default();
            let named = text
                .lines()
                .find_map(|l| l.strip_prefix("project:"))
                .map(|p| {
                    let p = p.split('#').next().unwrap_or("").trim();
                    f.parent().unwrap_or(Path::new("")).join(p)
                });
            if named.and_then(|n| std::fs::canonicalize(n).ok()) == Some(project.clone())
                && !out.contains(&f)
            {
                out.push(f);
            }
        }
    }
    out.sort();
    Ok(out)
}

fn is_scenario(path: &Path) -> bool {
    path.to_str().is_some_and(|s| s.ends_with(".scenario.yaml"))
}

fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            walk(&path, out)?;
        } else if is_scenario(&path) {
            out.push(path);
        }
    }
    Ok(())
}

/// Runs every scenario of `path`; the report and whether all passed.
pub(crate) fn run_path(path: &Path, verbose: bool) -> (String, bool) {
    use std::fmt::Write;
    let mut out = String::new();
    let files = match find(path) {
        Ok(f) => f,
        Err(e) => return (format!("error: {}: {e}\n", path.display()), false),
    };
    if files.is_empty() {
        return (
            format!(
                "error: no scenario (*.scenario.yaml) found for {}\n",
                path.display()
            ),
            false,
        );
    }
    let (mut passed, mut failed) = (0, 0);
    for file in files {
        let sc = match scenario::load(&file) {
            Ok(s) => s,
            Err(e) => {
                let _ = writeln!(out, "{e}");
                failed += 1;
                continue;
            }
        };
        let programs: Vec<Option<&variants::ProgramVariant>> = if sc.programs.is_empty() {
            vec![None]
        } else {
            sc.programs.iter().map(Some).collect()
        };
        let mut traces = Vec::new();
        for p in programs {
            let label = p.map_or_else(|| variants::own_label(&sc.project), |p| p.label.clone());
            let r = runner::run(&sc, p);
            if r.failures.is_empty() {
                passed += 1;
                let _ = writeln!(
                    out,
                    "ok   {} [{label}]: {} ({} expectations, {})",
                    file.display(),
                    sc.name,
                    r.checked,
                    scans_text(&r)
                );
                if verbose {
                    out.push_str(&trace::render(&r.trace));
                }
            } else {
                failed += 1;
                let _ = writeln!(out, "FAIL {} [{label}]: {}", file.display(), sc.name);
                for f in &r.failures {
                    let _ = writeln!(out, "    {f}");
                }
                let _ = writeln!(out, "    trace (changes of the watched tags):");
                out.push_str(&trace::render(&r.trace));
            }
            if sc.plant {
                // A plant closes the loop: the machine's own story must replay exactly too.
                let again = runner::run(&sc, p).trace;
                if again == r.trace {
                    let _ = writeln!(
                        out,
                        "same {} [{label}]: two runs give the same trace ({} changes)",
                        file.display(),
                        again.len()
                    );
                } else {
                    failed += 1;
                    let _ = writeln!(
                        out,
                        "FAIL {} [{label}]: a second run gives another trace (-: first, +: second):",
                        file.display()
                    );
                    out.push_str(&trace::diff(&r.trace, &again));
                }
            }
            traces.push((label, r.trace));
        }
        if let Some((first, rest)) = traces.split_first() {
            for other in rest {
                if other.1 != first.1 {
                    failed += 1;
                    let _ = writeln!(
                        out,
                        "FAIL {}: traces differ between {} (-) and {} (+):",
                        file.display(),
                        first.0,
                        other.0
                    );
                    out.push_str(&trace::diff(&first.1, &other.1));
                } else {
                    let _ = writeln!(
                        out,
                        "same {}: {} and {} give the same trace ({} changes)",
                        file.display(),
                        first.0,
                        other.0,
                        other.1.len()
                    );
                }
            }
        }
    }
    let _ = writeln!(out, "{passed} passed, {failed} failed");
    (out, failed == 0)
}

pub(super) fn test(args: TestArgs) -> anyhow::Result<ExitCode> {
    let (report, ok) = run_path(&args.path, args.verbose);
    super::out::out(&report)?;
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The scans a run made: `500 scans`, or each task's (`press 667 scans, panel 40 scans`).
fn scans_text(r: &runner::RunResult) -> String {
    if r.task_scans.is_empty() {
        return format!("{} scans", r.scans);
    }
    r.task_scans
        .iter()
        .map(|(task, scans)| format!("{task} {scans} scans"))
        .collect::<Vec<_>>()
        .join(", ")
}
