//! `softplc replay RECORD PROJECT`: re-runs PROJECT's program on a flight record's inputs, on
//! the virtual clock, and says where its outputs first differ from the recorded ones (see
//! [`crate::recorder::replay`] for what is re-created and what is not).
//!
//! Exit status: 0 when every output matched in every cycle, 1 when they differ (or the
//! replayed program faulted), 2 when the record or the project cannot be used.

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use softplc_io::point::Value;

use crate::project::{self, Project};
use crate::recorder::format::short_hex;
use crate::recorder::replay::{compared, CycleOutputs, Difference};
use crate::recorder::{
    read_record, replay_subject, segments_in, Record, RecordError, ReplayError, ReplayOptions,
    ReplayReport, ReplaySubject,
};
use crate::scan::fmt_duration;
use crate::trace::export::{CsvWriter, ExportError, Sample, Signal, VcdWriter};

/// Arguments of `softplc replay`.
#[derive(Debug, clap::Args)]
pub(crate) struct ReplayArgs {
    /// The record: its folder (PROJECT.record, beside the project or in the unit's state
    /// directory) or one segment file. For a project of several tasks, the record's folder
    /// (every task's record is replayed) or one task's folder in it.
    record: PathBuf,
    /// The project whose program to replay: the recorded one, or one with a changed program
    /// (its I/O and tags must be the record's).
    project: PathBuf,
    /// For a project of several tasks: replay this task's record only (every task's by
    /// default).
    #[arg(long, value_name = "NAME")]
    task: Option<String>,
    /// Describe every cycle whose outputs differ, not only the first.
    #[arg(long, conflicts_with = "differences")]
    all_differences: bool,
    /// Describe the first N cycles whose outputs differ.
    #[arg(long, value_name = "N")]
    differences: Option<usize>,
    /// Write the outputs of both, cycle by cycle, as CSV (columns rec.TAG and new.TAG). With
    /// several tasks replayed, a file per task: FILE with the task's name before its
    /// extension (out.csv: out.press.csv, out.panel.csv).
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write the outputs of both as a VCD (signals rec.TAG and new.TAG, for GTKWave or
    /// PulseView). With several tasks replayed, a file per task, named as the CSV's.
    #[arg(long, value_name = "FILE")]
    vcd: Option<PathBuf>,
}

/// What ends a replay early: the exit status and the message.
struct Refusal(String);

/// One record to replay: where it is, and against what.
struct Target {
    /// The record's path.
    path: PathBuf,
    /// The task, for a project of several tasks.
    task: Option<String>,
}

pub(super) fn replay_cmd(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    let project = match project::load(&args.project) {
        Ok(p) => p,
        Err(errors) => {
            super::out::errln(&errors.to_string());
            return Ok(ExitCode::from(2));
        }
    };
    let targets = match targets(&args, &project) {
        Ok(t) => t,
        Err(Refusal(why)) => {
            super::out::errln(&format!("error: {why}"));
            return Ok(ExitCode::from(2));
        }
    };
    let several = targets.len() > 1;
    let mut all_identical = true;
    let mut unusable = false;
    let mut verdicts = Vec::new();
    for target in &targets {
        let name = target.task.as_deref();
        match replay_one(&args, &project, target, several)? {
            Ok(done) => {
                super::out::out(&for_task(&done.text, done.task.as_deref()))?;
                all_identical &= done.identical;
                verdicts.push(done.verdict);
            }
            Err(Refusal(why)) => {
                super::out::errln(&for_task(&format!("error: {why}"), name));
                unusable = true;
            }
        }
    }
    if several {
        super::out::out(&format!(
            "{} tasks replayed: {}\n",
            verdicts.len(),
            verdicts.join("; ")
        ))?;
    }
    Ok(if unusable {
        ExitCode::from(2)
    } else if all_identical {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
/// The records `args` names for `project`: the record itself for a project of one task;
/// for a project of several, each task's folder in the record's folder (the one `--task`
/// names), or the one task's record the path is.
fn targets(args: &ReplayArgs, project: &Project) -> Result<Vec<Target>, Refusal> {
    let names: Vec<&str> = project.tasks.iter().map(|t| t.name.as_str()).collect();
    if !project.multitask() {
        if let Some(task) = &args.task {
            return Err(Refusal(format!(
                "--task {task}: {} has one task; --task chooses among the tasks of a project \
                 of several",
                args.project.display()
            )));
        }
        return Ok(vec![Target {
            path: args.record.clone(),
            task: None,
        }]);
    }
    if let Some(task) = &args.task {
        if !names.contains(&task.as_str()) {
            return Err(Refusal(format!(
                "--task {task}: {} has no task {task:?}; its tasks: {}",
                args.project.display(),
                names.join(", ")
            )));
        }
    }
    let folders: Vec<&str> = names
        .iter()
        .copied()
        .filter(|name| args.record.join(name).is_dir())
        .collect();
    if folders.is_empty() {
        if args.record.is_dir() && segments_in(&args.record).is_empty() {
            return Err(Refusal(format!(
                "{}: no record of a task here: a project of several tasks keeps a folder per \
                 task in its record's folder ({})",
                args.record.display(),
                names.join(", ")
            )));
        }
        // The path is one task's record (its folder, or a segment file): its header names
        // the task.
        return Ok(vec![Target {
            path: args.record.clone(),
            task: args.task.clone(),
        }]);
    }
    let targets: Vec<Target> = names
        .iter()
        .filter(|name| args.task.as_deref().is_none_or(|t| t == **name))
        .map(|name| Target {
            path: args.record.join(name),
            task: Some((*name).to_string()),
        })
        .collect();
    Ok(targets)
}

/// The sub-folders of `folder` that hold record segments (a record of several tasks), listed;
/// `None` when there are none.
fn task_folders(folder: &Path) -> Option<String> {
    let mut tasks: Vec<String> = std::fs::read_dir(folder)
        .ok()?
        .filter_map(Result::ok)
        .filter(|e| !segments_in(&e.path()).is_empty())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    tasks.sort();
    (!tasks.is_empty()).then(|| tasks.join(", "))
}

/// What replaying one record gave.
struct Replayed {
    /// The summary, as printed.
    text: String,
    /// Whether every output matched in every cycle.
    identical: bool,
    /// One phrase for the last line of several tasks' replay.
    verdict: String,
    /// The task replayed, for a project of several tasks.
    task: Option<String>,
}

/// Replays `target` against `project` (its task's program and view for a project of several
/// tasks); `several`: files are named by task. An export that cannot be written is an
/// error; a record that cannot be used, a refusal.
fn replay_one(
    args: &ReplayArgs,
    project: &Project,
    target: &Target,
    several: bool,
) -> anyhow::Result<Result<Replayed, Refusal>> {
    let record = match read_record(&target.path) {
        Ok(r) => r,
        Err(e @ RecordError::Empty { .. }) => {
            return Ok(Err(Refusal(match task_folders(&target.path) {
                Some(tasks) => format!(
                    "{e}; it holds the records of the tasks {tasks} of a project of several \
                     tasks: replay it with that project"
                ),
                None => e.to_string(),
            })))
        }
        Err(e) => return Ok(Err(Refusal(e.to_string()))),
    };
    let subject = match &target.task {
        Some(task) => ReplaySubject::task(project, task),
        None => ReplaySubject::of_record(&record, project),
    };
    let cannot = |e: ReplayError| {
        Refusal(format!(
            "{} cannot be replayed with {}: {e}",
            target.path.display(),
            args.project.display()
        ))
    };
    let subject = match subject {
        Ok(s) => s,
        Err(e) => return Ok(Err(cannot(e))),
    };
    let options = ReplayOptions {
        differences: if args.all_differences {
            usize::MAX
        } else {
            args.differences.unwrap_or(1)
        },
    };
    let task = subject.task_name().filter(|_| several);
    let named = |p: &Option<PathBuf>| {
        p.as_ref().map(|p| match task {
            Some(task) => crate::project::task_view::task_file(p, task),
            None => p.clone(),
        })
    };
    let scope = subject
        .task_name()
        .unwrap_or(project.name.as_str())
        .to_string();
    // The signals are known once the record's header is: open the exports lazily.
    let mut exports = Exports::open(&record, &scope, named(&args.csv), named(&args.vcd))?;
    let mut export_error = None;
    let report = replay_subject(&record, &subject, options, |c| {
        if export_error.is_none() {
            export_error = exports.write(c).err();
        }
    });
    let report = match report {
        Ok(r) => r,
        Err(e) => return Ok(Err(cannot(e))),
    };
    if let Some(e) = export_error {
        return Err(e).context("cannot write the export");
    }
    exports.finish()?;
    let text = summary(
        &target.path,
        &record,
        &report,
        &subject.project().program_files(),
    );
    let verdict = format!(
        "{}{} cycles, {}",
        subject
            .task_name()
            .map_or(String::new(), |t| format!("{t} ")),
        report.cycles,
        if report.identical() {
            "identical".to_string()
        } else {
            format!("differ in {} cycle(s)", report.differing_cycles.max(1))
        }
    );
    Ok(Ok(Replayed {
        text,
        identical: report.identical(),
        verdict,
        task: report.task.clone(),
    }))
}

/// `text` with each of its lines that is not indented (a detail of the line before) headed
/// by the task's name, for a project of several tasks.
fn for_task(text: &str, task: Option<&str>) -> String {
    let Some(task) = task else {
        return text.to_string();
    };
    let mut out = String::with_capacity(text.len() + 64);
    for line in text.lines() {
        if line.starts_with(' ') {
            out.push_str(line);
        } else {
            let _ = write!(out, "task {task}: {line}");
        }
        out.push('\n');
    }
    out
}

/// The CSV and VCD files asked for.
struct Exports {
    csv: Option<(PathBuf, CsvWriter<BufWriter<File>>)>,
    vcd: Option<(PathBuf, VcdWriter<BufWriter<File>>)>,
    values: Vec<Value>,
}

impl Exports {
    fn open(
        record: &Record,
        scope: &str,
        csv: Option<PathBuf>,
        vcd: Option<PathBuf>,
    ) -> anyhow::Result<Self> {
        let signals: Vec<Signal> = match record.segments.first() {
            Some(seg) => {
                let owned = compared(&seg.header);
                let rec = owned
                    .iter()
                    .map(|t| Signal::new(format!("rec.{}", t.name), t.ty));
                let new = owned
                    .iter()
                    .map(|t| Signal::new(format!("new.{}", t.name), t.ty));
                rec.chain(new).collect()
            }
            None => Vec::new(),
        };
        let create = |p: &Path| {
            File::create(p)
                .map(BufWriter::new)
                .with_context(|| format!("cannot create {}", p.display()))
        };
        let csv = match csv {
            Some(p) => {
                let w = CsvWriter::new(create(&p)?, &signals)?;
                Some((p, w))
            }
            None => None,
        };
        let vcd = match vcd {
            Some(p) => {
                let w = VcdWriter::new(create(&p)?, scope, &signals)?;
                Some((p, w))
            }
            None => None,
        };
        Ok(Self {
            csv,
            vcd,
            values: Vec::with_capacity(signals.len()),
        })
    }

    fn write(&mut self, c: CycleOutputs<'_>) -> Result<(), ExportError> {
        if self.csv.is_none() && self.vcd.is_none() {
            return Ok(());
        }
        self.values.clear();
        self.values.extend_from_slice(c.recorded);
        self.values.extend_from_slice(c.replayed);
        let sample = Sample::new(c.now, c.cycle, &self.values);
        if let Some((_, w)) = self.csv.as_mut() {
            w.write(&sample)?;
        }
        if let Some((_, w)) = self.vcd.as_mut() {
            w.write(&sample)?;
        }
        Ok(())
    }

    fn finish(self) -> anyhow::Result<()> {
        if let Some((p, w)) = self.csv {
            let mut out = w.finish()?;
            out.flush()
                .with_context(|| format!("cannot write {}", p.display()))?;
        }
        if let Some((p, w)) = self.vcd {
            let mut out = w.finish()?;
            out.flush()
                .with_context(|| format!("cannot write {}", p.display()))?;
        }
        Ok(())
    }
}

/// The replay's summary, as printed.
pub(crate) fn summary(path: &Path, record: &Record, r: &ReplayReport, program: &str) -> String {
    let mut out = String::new();
    let runs = {
        let mut ids: Vec<u64> = record.segments.iter().map(|s| s.header.run_id).collect();
        ids.dedup();
        ids.len()
    };
    let _ = writeln!(
        out,
        "record {}: project {}, {} run(s), {} segment(s)",
        path.display(),
        r.project,
        runs,
        record.segments.len()
    );
    let recorded_file = record
        .segments
        .first()
        .map_or(String::new(), |s| s.header.program_file.clone());
    let _ = writeln!(
        out,
        "recorded program sha256 {} ({recorded_file})",
        short_hex(&r.recorded_program)
    );
    let same = r.recorded_program == r.replayed_program;
    let _ = writeln!(
        out,
        "replayed program sha256 {} ({}){}",
        short_hex(&r.replayed_program),
        program,
        if same {
            ": the same program"
        } else {
            ": a different program; what it would have done with the recorded inputs"
        }
    );
    if r.project_file_differs {
        let _ = writeln!(
            out,
            "note: the project file differs from the recorded one (its tags and I/O are the same)"
        );
    }
    for note in &r.notes {
        let _ = writeln!(out, "note: {note}");
    }
    for d in &r.differences {
        let _ = write!(out, "{}", difference(d, r.differences.len() == 1));
    }
    let span = format!(
        "{} cycles, {} of plant time",
        r.cycles,
        fmt_duration(r.plant_time)
    );
    match (&r.fault, r.recorded_fault) {
        (Some((cycle, fault)), recorded) => {
            let _ = writeln!(
                out,
                "the replayed program faulted at cycle {cycle}: {fault}; replay stopped there{}",
                if recorded == Some(*cycle) {
                    ", as the recorded run did"
                } else {
                    ""
                }
            );
        }
        (None, Some(cycle)) => {
            let _ = writeln!(
                out,
                "the recorded program faulted at cycle {cycle}; the replayed one did not"
            );
        }
        (None, None) => {}
    }
    if r.differing_cycles == 0 {
        let _ = writeln!(
            out,
            "{span}, outputs identical{}",
            if r.identical() {
                ""
            } else {
                "; the faults differ (above)"
            }
        );
    } else {
        let _ = writeln!(
            out,
            "{span}, outputs differ in {} cycle(s){}",
            r.differing_cycles,
            if (r.differences.len() as u64) < r.differing_cycles {
                " (--all-differences lists every one)"
            } else {
                ""
            }
        );
    }
    out
}

fn difference(d: &Difference, only_first: bool) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} at cycle {} (t={}):",
        if only_first {
            "first difference"
        } else {
            "difference"
        },
        d.cycle,
        d.now
    );
    let width = d.tags.iter().map(|t| t.tag.len()).max().unwrap_or(0);
    for t in &d.tags {
        let _ = writeln!(
            out,
            "  {:width$}  recorded {}  replayed {}",
            t.tag, t.recorded, t.replayed
        );
    }
    out
}
