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

use crate::project;
use crate::recorder::format::short_hex;
use crate::recorder::replay::{compared, CycleOutputs, Difference};
use crate::recorder::{read_record, replay, Record, ReplayOptions, ReplayReport};
use crate::scan::fmt_duration;
use crate::trace::export::{CsvWriter, ExportError, Sample, Signal, VcdWriter};

/// Arguments of `softplc replay`.
#[derive(Debug, clap::Args)]
pub(crate) struct ReplayArgs {
    /// The record: its folder (PROJECT.record, beside the project or in the unit's state
    /// directory) or one segment file.
    record: PathBuf,
    /// The project whose program to replay: the recorded one, or one with a changed program
    /// (its I/O and tags must be the record's).
    project: PathBuf,
    /// Describe every cycle whose outputs differ, not only the first.
    #[arg(long, conflicts_with = "differences")]
    all_differences: bool,
    /// Describe the first N cycles whose outputs differ.
    #[arg(long, value_name = "N")]
    differences: Option<usize>,
    /// Write the outputs of both, cycle by cycle, as CSV (columns rec.TAG and new.TAG).
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Write the outputs of both as a VCD (signals rec.TAG and new.TAG, for GTKWave or
    /// PulseView).
    #[arg(long, value_name = "FILE")]
    vcd: Option<PathBuf>,
}

pub(super) fn replay_cmd(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    let project = match project::load(&args.project) {
        Ok(p) => p,
        Err(errors) => {
            super::out::errln(&errors.to_string());
            return Ok(ExitCode::from(2));
        }
    };
    let record = match read_record(&args.record) {
        Ok(r) => r,
        Err(e) => {
            super::out::errln(&format!("error: {e}"));
            return Ok(ExitCode::from(2));
        }
    };
    let options = ReplayOptions {
        differences: if args.all_differences {
            usize::MAX
        } else {
            args.differences.unwrap_or(1)
        },
    };
    // The signals are known once the record's header is: open the exports lazily.
    let mut exports = Exports::open(&args, &record)?;
    let mut export_error = None;
    let report = replay(&record, &project, options, |c| {
        if export_error.is_none() {
            export_error = exports.write(c).err();
        }
    });
    let report = match report {
        Ok(r) => r,
        Err(e) => {
            super::out::errln(&format!(
                "error: {} cannot be replayed with {}: {e}",
                args.record.display(),
                args.project.display()
            ));
            return Ok(ExitCode::from(2));
        }
    };
    if let Some(e) = export_error {
        return Err(e).context("cannot write the export");
    }
    exports.finish()?;
    super::out::out(&summary(
        &args.record,
        &record,
        &report,
        &project.program_files(),
    ))?;
    Ok(if report.identical() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// The CSV and VCD files asked for.
struct Exports {
    csv: Option<(PathBuf, CsvWriter<BufWriter<File>>)>,
    vcd: Option<(PathBuf, VcdWriter<BufWriter<File>>)>,
    values: Vec<Value>,
}

impl Exports {
    fn open(args: &ReplayArgs, record: &Record) -> anyhow::Result<Self> {
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
        let scope = record
            .segments
            .first()
            .map_or("replay", |s| s.header.project.as_str());
        let csv = match &args.csv {
            Some(p) => Some((p.clone(), CsvWriter::new(create(p)?, &signals)?)),
            None => None,
        };
        let vcd = match &args.vcd {
            Some(p) => Some((p.clone(), VcdWriter::new(create(p)?, scope, &signals)?)),
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
