//! Replay: the project's program re-run on the recorded inputs at the recorded times.
//!
//! Logic sees only the process image and the scan's time (DESIGN principle 2), so a cycle is
//! re-created exactly from what the record holds: the cycle's timestamp and number (`now`,
//! `delta`, `cycle` as the scan gave them), the image at the start of the logic, and the
//! control requests applied before it. For each cycle, in order:
//!
//! 1. the recorded requests are applied as the PLC applied them: forces, unforces, writes;
//! 2. the recorded image is applied: tags the program does not compute (inputs, pushed-down
//!    outputs) take their recorded value and quality; tags it computes (outputs, memory) take
//!    only their recorded quality (a module's refusal, a lost line), their value is the
//!    replayed program's own;
//! 3. forces are applied, the program runs, forces are applied again (as the output phase
//!    does);
//! 4. every output and memory tag is compared with what the recorded scan wrote.
//!
//! A cycle whose recorded program faulted is in the record as it started; replay expects the
//! replayed program to fault there too (a changed program that does not, or one that faults
//! elsewhere, is a difference).
//!
//! What replay does not re-create: module-side behaviour. A pushed-down rung runs in its
//! module, so the value the module reported is an input to replay (its tag is not compared);
//! a changed program is replayed with the record's placement. The lines, their timing and the
//! plant are not simulated: the recorded inputs stand for them, so a changed program's
//! outputs do not feed back into its inputs (the answer is "what the new program would have
//! done with these inputs", not "what the machine would then have done"). A record whose
//! oldest segments were rotated out starts from the image its first keyframe holds, but the
//! program's function blocks (timers, counters, edge memories) start fresh there; the summary
//! says so. Records dropped by a writer that fell behind are gaps: replay goes on across them
//! (the program sees one long cycle) and lists them. Cycles the writer could not write at all
//! (a full disk, longer than it could hold them) are a gap block before a new keyframe: replay
//! reports "no record from cycle A to B" and starts afresh from that keyframe.

use std::time::Duration;

use softplc_io::point::{Access, Quality, Value};

use crate::image::{ProcessImage, TagId};
use crate::logic::{load, LogicEngine, ScanContext};
use crate::project::{Binding, Project};
use crate::recorder::format::{self, Digest, Event, Header, TagInfo, TagRole};
use crate::recorder::reader::{Record, Segment};
use crate::recorder::tap::same;
use softplc_io::time::ScanInstant;

/// How much replay reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplayOptions {
    /// How many differing cycles to describe (every one is counted).
    pub differences: usize,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        Self { differences: 1 }
    }
}

/// One tag whose replayed value differs from the recorded one.
#[derive(Debug, Clone, PartialEq)]
pub struct TagDifference {
    /// The tag.
    pub tag: String,
    /// What the recorded scan wrote.
    pub recorded: Value,
    /// What the replayed program wrote.
    pub replayed: Value,
}

/// A cycle whose outputs differ.
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    /// The cycle number, as the recorded run counted it.
    pub cycle: u64,
    /// Its timestamp (scan time of the recorded run).
    pub now: ScanInstant,
    /// The tags that differ, in tag order.
    pub tags: Vec<TagDifference>,
}

/// The compared tags' values after one cycle, recorded and replayed (for CSV/VCD).
#[derive(Debug, Clone, Copy)]
pub struct CycleOutputs<'a> {
    /// The cycle number.
    pub cycle: u64,
    /// Its timestamp.
    pub now: ScanInstant,
    /// Recorded values, in [`ReplayReport::compared`] order.
    pub recorded: &'a [Value],
    /// Replayed values, in the same order.
    pub replayed: &'a [Value],
}

/// What replay found.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayReport {
    /// The recorded project's name.
    pub project: String,
    /// The task replayed, for a project of several tasks.
    pub task: Option<String>,
    /// Cycles replayed.
    pub cycles: u64,
    /// Scan time they cover.
    pub plant_time: Duration,
    /// The tags compared (outputs and memory tags), in tag order.
    pub compared: Vec<TagInfo>,
    /// Cycles whose outputs differ.
    pub differing_cycles: u64,
    /// The first [`ReplayOptions::differences`] of them.
    pub differences: Vec<Difference>,
    /// The recorded program's identity (at the record's start).
    pub recorded_program: Digest,
    /// The replayed program's identity.
    pub replayed_program: Digest,
    /// Whether the project files differ (beyond the program; a comment counts).
    pub project_file_differs: bool,
    /// The replayed program faulted: the cycle and the fault. Replay stops there.
    pub fault: Option<(u64, String)>,
    /// The recorded run's program faulted in this cycle (the run stopped there).
    pub recorded_fault: Option<u64>,
    /// What the reader of the summary must know: gaps, reloads, restarts, torn tails.
    pub notes: Vec<String>,
}

impl ReplayReport {
    /// Whether every compared output matched in every cycle.
    pub fn identical(&self) -> bool {
        self.differing_cycles == 0 && self.fault.as_ref().map(|f| f.0) == self.recorded_fault
    }
}

/// Why a record cannot be replayed against a project.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReplayError {
    /// The record holds no cycle.
    #[error("the record holds no cycle")]
    Empty,
    /// The record is of another project.
    #[error("the record is of project {record:?}, the project file is {project:?}")]
    Project {
        /// The record's.
        record: String,
        /// The project's.
        project: String,
    },
    /// The tag tables differ in length.
    #[error(
        "the record's tag table has {record} tags, the project's {project}: replay needs the \
         same tags (a changed program is fine, changed I/O is not)"
    )]
    TagCount {
        /// The record's.
        record: usize,
        /// The project's.
        project: usize,
    },
    /// A tag differs.
    #[error("tag {index}: the record has {record}, the project has {project}")]
    Tag {
        /// Its place in the table (0-based).
        index: usize,
        /// The record's tag.
        record: String,
        /// The project's tag.
        project: String,
    },
    /// The project's program does not compile.
    #[error("{0}")]
    Program(String),
    /// A record of one task, replayed against a project of several tasks.
    #[error(
        "the record is of a project of one task, the project has the tasks {tasks}: replay \
         each task's record (the folder TASK in the record's folder)"
    )]
    NotATask {
        /// The project's tasks, listed.
        tasks: String,
    },
    /// A task's record, replayed against a project of one task.
    #[error(
        "the record is of task {task} of a project of several tasks, the project has one task"
    )]
    OneTask {
        /// The record's task.
        task: String,
    },
    /// A task the project does not have.
    #[error("the project has no task {task:?}; its tasks: {tasks}")]
    UnknownTask {
        /// The task asked for.
        task: String,
        /// The project's tasks, listed.
        tasks: String,
    },
    /// A record of another task than the one asked for.
    #[error("the record is of task {record}, not of task {asked}")]
    OtherTask {
        /// The record's task.
        record: String,
        /// The task asked for.
        asked: String,
    },
}

/// The role of each of `project`'s tags, given which outputs are pushed down and which tags
/// another task owns (`copied`: the task copies them in at its cycle's start, so to its record
/// and its replay they are inputs, whatever they are to the task owning them).
pub(crate) fn tag_table(
    project: &Project,
    pushed: impl Fn(TagId) -> bool,
    copied: impl Fn(TagId) -> bool,
) -> Vec<TagInfo> {
    project
        .tags
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let id = TagId(i as u32);
            let role = match t.binding {
                _ if copied(id) => TagRole::Input,
                Binding::Memory => TagRole::Memory,
                Binding::Point { module, point } => {
                    match project.modules[module].model.points[point].access {
                        Access::Output if pushed(id) => TagRole::Pushed,
                        Access::Output => TagRole::Output,
                        Access::Input | Access::ReadWrite => TagRole::Input,
                    }
                }
            };
            TagInfo {
                name: t.name.clone(),
                ty: t.ty,
                role,
            }
        })
        .collect()
}

/// The program a record names and replay compares: the digest of its source and its file as
/// the project names it. The one place that asks a project (or a task's view) for its
/// program, for the recorder's header and for replay alike.
pub(crate) fn program_identity(project: &Project) -> std::io::Result<(Digest, String)> {
    let source = project.program_source()?;
    Ok((format::digest(&source), project.program_files()))
}

/// The tags replay compares (outputs and memory tags: what the program computes), in tag
/// order.
pub(crate) fn compared(header: &Header) -> Vec<TagInfo> {
    header
        .tags
        .iter()
        .filter(|t| t.role.program_owned())
        .cloned()
        .collect()
}

/// What a record is replayed against: a project of one task, or one task of a project of
/// several (that task's view of the project, and the tags it copies in from the others,
/// which its record holds as inputs).
#[derive(Debug, Clone)]
pub struct ReplaySubject {
    /// The project, or the task's view of it.
    project: Project,
    /// The task, for a project of several tasks.
    task: Option<String>,
    /// Per tag: copied in from another task.
    copied: Vec<bool>,
    /// The project's tasks, listed (for a project of several tasks).
    tasks: String,
}

impl ReplaySubject {
    /// A project of one task.
    fn whole(project: &Project) -> Self {
        Self {
            project: project.clone(),
            task: None,
            copied: vec![false; project.tags.len()],
            tasks: String::new(),
        }
    }

    /// Task `name` of `project` (a project of several tasks): its view of the project, the
    /// tags it copies in as every task's program says (the programs are compiled to know).
    pub fn task(project: &Project, name: &str) -> Result<Self, ReplayError> {
        let Some(i) = project.tasks.iter().position(|t| t.name == name) else {
            return Err(ReplayError::UnknownTask {
                task: name.to_string(),
                tasks: task_list(project),
            });
        };
        let image = ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
        let (_, ownership) =
            load::load_tasks(project, &image).map_err(|e| ReplayError::Program(e.to_string()))?;
        let owner = |t: usize| ownership.owner(TagId(t as u32));
        Ok(Self {
            project: project.task_view(i, |t| owner(t) == Some(i)),
            task: Some(name.to_string()),
            copied: (0..project.tags.len())
                .map(|t| owner(t).is_some_and(|o| o != i))
                .collect(),
            tasks: task_list(project),
        })
    }

    /// What `record` is replayed against in `project`: the project itself when it has one
    /// task, else the task the record's header names.
    pub fn of_record(record: &Record, project: &Project) -> Result<Self, ReplayError> {
        if !project.multitask() {
            return Ok(Self::whole(project));
        }
        let header = &record.segments.first().ok_or(ReplayError::Empty)?.header;
        match &header.task {
            Some(task) => Self::task(project, task),
            None => Err(ReplayError::NotATask {
                tasks: task_list(project),
            }),
        }
    }

    /// The task's name, for a project of several tasks.
    pub fn task_name(&self) -> Option<&str> {
        self.task.as_deref()
    }

    /// The project, or the task's view of it.
    pub fn project(&self) -> &Project {
        &self.project
    }
}

/// The project's tasks, as an error lists them.
fn task_list(project: &Project) -> String {
    project
        .tasks
        .iter()
        .map(|t| t.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Checks that `header` is a record of `subject` but for its program.
pub(crate) fn check_compatible(
    header: &Header,
    subject: &ReplaySubject,
) -> Result<(), ReplayError> {
    let project = &subject.project;
    if header.project != project.name {
        return Err(ReplayError::Project {
            record: header.project.clone(),
            project: project.name.clone(),
        });
    }
    match (&header.task, &subject.task) {
        (Some(record), Some(asked)) if record != asked => {
            return Err(ReplayError::OtherTask {
                record: record.clone(),
                asked: asked.clone(),
            })
        }
        (Some(task), None) => return Err(ReplayError::OneTask { task: task.clone() }),
        (None, Some(_)) => {
            return Err(ReplayError::NotATask {
                tasks: subject.tasks.clone(),
            })
        }
        _ => {}
    }
    let ours = tag_table(project, |_| false, |id| subject.copied[id.index()]);
    if ours.len() != header.tags.len() {
        return Err(ReplayError::TagCount {
            record: header.tags.len(),
            project: ours.len(),
        });
    }
    // A pushed-down output is an output wherever its rung runs: a new program may move it.
    let class = |r: TagRole| {
        if r == TagRole::Pushed {
            TagRole::Output
        } else {
            r
        }
    };
    let describe = |t: &TagInfo| format!("{} ({}, {})", t.name, t.ty, t.role.word());
    for (index, (rec, new)) in header.tags.iter().zip(&ours).enumerate() {
        if rec.name != new.name || rec.ty != new.ty || class(rec.role) != new.role {
            return Err(ReplayError::Tag {
                index,
                record: describe(rec),
                project: describe(new),
            });
        }
    }
    Ok(())
}

/// Replays `record` against `project`'s program (for a project of several tasks, the program
/// of the task the record is of); `sink` gets every cycle's compared values.
pub fn replay(
    record: &Record,
    project: &Project,
    options: ReplayOptions,
    sink: impl FnMut(CycleOutputs<'_>),
) -> Result<ReplayReport, ReplayError> {
    let subject = ReplaySubject::of_record(record, project)?;
    replay_subject(record, &subject, options, sink)
}

/// Replays `record` against `subject`: a project of one task, or one task of several.
pub fn replay_subject(
    record: &Record,
    subject: &ReplaySubject,
    options: ReplayOptions,
    mut sink: impl FnMut(CycleOutputs<'_>),
) -> Result<ReplayReport, ReplayError> {
    let project = &subject.project;
    let parts = record.parts();
    let first = parts
        .first()
        .and_then(|p| p.first())
        .filter(|_| record.cycles().next().is_some())
        .ok_or(ReplayError::Empty)?;
    for seg in &record.segments {
        check_compatible(&seg.header, subject)?;
    }
    let replayed_program =
        program_identity(project).map_or_else(|_| format::digest(&[]), |(digest, _)| digest);
    let project_file = std::fs::read(&project.source).unwrap_or_default();
    let mut report = ReplayReport {
        project: first.header.project.clone(),
        task: subject.task.clone(),
        cycles: 0,
        plant_time: Duration::ZERO,
        compared: compared(&first.header),
        differing_cycles: 0,
        differences: Vec::new(),
        recorded_program: first.header.program_hash,
        replayed_program,
        project_file_differs: first.header.project_hash != format::digest(&project_file),
        fault: None,
        recorded_fault: None,
        notes: Vec::new(),
    };
    for (n, part) in parts.iter().enumerate() {
        for seg in part.iter() {
            if let Some(t) = seg.torn {
                report.notes.push(format!(
                    "{}: torn tail at byte {} ({} bytes after the last good block ignored)",
                    seg.path.display(),
                    t.offset,
                    t.ignored
                ));
            }
        }
        if n > 0 && part[0].header.run_id != parts[n - 1][0].header.run_id {
            report.notes.push(format!(
                "cycle {}: the PLC restarted (a new run); the program starts afresh there",
                part[0].keyframe.next_cycle
            ));
        }
        if let Some(gap) = part[0].gap {
            report.notes.push(format!(
                "no record from cycle {} to {}: the recorder could not write them (a full \
                 disk); replay goes on from cycle {}, where the program's function blocks \
                 (timers, counters, edges) start fresh",
                gap.first, gap.last, part[0].keyframe.next_cycle
            ));
        }
        let mut run = PartReplay::new(part, project, &mut report)?;
        if !run.go(options, &mut report, &mut sink) {
            break;
        }
    }
    Ok(report)
}

/// One part of a record (consecutive segments of one run) being replayed.
struct PartReplay<'a> {
    part: &'a [Segment],
    image: ProcessImage,
    logic: Box<dyn LogicEngine>,
    /// The recorded state, after the last record.
    recorded: Vec<(Value, Quality)>,
    owned: Vec<bool>,
    period: Duration,
}

impl<'a> PartReplay<'a> {
    fn new(
        part: &'a [Segment],
        project: &Project,
        report: &mut ReplayReport,
    ) -> Result<Self, ReplayError> {
        let seg = &part[0];
        let mut image = ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
        let mut logic =
            load::load_program(project, &image).map_err(|e| ReplayError::Program(e.to_string()))?;
        let owned: Vec<bool> = seg
            .header
            .tags
            .iter()
            .map(|t| t.role.program_owned())
            .collect();
        for (i, t) in seg.header.tags.iter().enumerate() {
            if t.role == TagRole::Pushed {
                logic.release(TagId(i as u32));
            }
        }
        let k = &seg.keyframe;
        for (i, &(v, q)) in k.slots.iter().enumerate() {
            let id = TagId(i as u32);
            image.set(id, v, k.now);
            image.set_quality(id, q);
        }
        for &(tag, v) in &k.forces {
            image.force(TagId(tag), v);
        }
        if seg.header.segment > 0 && seg.gap.is_none() {
            report.notes.push(format!(
                "cycle {} (t={:.2}s): replay starts within a run whose earlier segments are gone \
                 (rotated out): the image is as recorded, the program's function blocks \
                 (timers, counters, edges) start fresh",
                k.next_cycle,
                k.now.since_origin().as_secs_f64()
            ));
        }
        Ok(Self {
            part,
            image,
            logic,
            recorded: k.slots.clone(),
            owned,
            period: seg.header.period,
        })
    }

    /// Replays every cycle of the part; false when the program faulted.
    fn go(
        &mut self,
        options: ReplayOptions,
        report: &mut ReplayReport,
        sink: &mut impl FnMut(CycleOutputs<'_>),
    ) -> bool {
        let compared: Vec<usize> = (0..self.owned.len()).filter(|&i| self.owned[i]).collect();
        let mut rec_values = vec![Value::Bool(false); compared.len()];
        let mut new_values = rec_values.clone();
        let mut previous: Option<ScanInstant> = None;
        let first_now = self.part[0].cycles.first().map(|c| c.now);
        let mut last_now = None;
        for r in self.part.iter().flat_map(|s| s.cycles.iter()) {
            if r.dropped_before > 0 {
                report.notes.push(format!(
                    "cycle {}: {} record(s) before it were dropped (the recorder fell behind); \
                     the program sees one long cycle",
                    r.cycle, r.dropped_before
                ));
            }
            for ev in &r.events {
                self.apply_event(ev, r.cycle, r.now, report);
            }
            self.apply_changes(&r.seen, r.now);
            self.image.apply_forces(r.now);
            let ctx = ScanContext {
                now: r.now,
                delta: previous.map_or(self.period, |p| r.now - p),
                cycle: r.cycle,
            };
            let result = self.logic.scan(&mut self.image, &ctx);
            if r.faulted {
                report.recorded_fault = Some(r.cycle);
            }
            match result {
                Err(fault) => {
                    report.fault = Some((r.cycle, fault.to_string()));
                    report.cycles += 1;
                    return false;
                }
                // The recorded cycle wrote nothing: there is nothing to compare.
                Ok(()) if r.faulted => {
                    report.cycles += 1;
                    continue;
                }
                Ok(()) => {}
            }
            self.image.apply_forces(r.now);
            for c in &r.wrote {
                self.recorded[c.tag as usize] = (c.value, c.quality);
            }
            let mut diff = Vec::new();
            for (k, &i) in compared.iter().enumerate() {
                rec_values[k] = self.recorded[i].0;
                new_values[k] = self.image.get(TagId(i as u32));
                if !same(rec_values[k], new_values[k]) {
                    diff.push(TagDifference {
                        tag: self.image.name(TagId(i as u32)).to_string(),
                        recorded: rec_values[k],
                        replayed: new_values[k],
                    });
                }
            }
            sink(CycleOutputs {
                cycle: r.cycle,
                now: r.now,
                recorded: &rec_values,
                replayed: &new_values,
            });
            if !diff.is_empty() {
                report.differing_cycles += 1;
                if report.differences.len() < options.differences {
                    report.differences.push(Difference {
                        cycle: r.cycle,
                        now: r.now,
                        tags: diff,
                    });
                }
            }
            // What the output phase then did to the image (quality marks, read-backs).
            self.apply_changes(&r.wrote, r.now);
            report.cycles += 1;
            previous = Some(r.now);
            last_now = Some(r.now);
        }
        if let (Some(a), Some(b)) = (first_now, last_now) {
            report.plant_time += b.saturating_duration_since(a) + self.period;
        }
        true
    }

    fn apply_event(&mut self, ev: &Event, cycle: u64, now: ScanInstant, report: &mut ReplayReport) {
        match ev {
            Event::Force { tag, value } => {
                self.image.force(TagId(*tag), *value);
                self.image.apply_forces(now);
            }
            Event::Unforce { tag } => {
                self.image.unforce(TagId(*tag));
            }
            Event::UnforceAll => {
                self.image.unforce_all();
            }
            Event::Write { values } => {
                for &(tag, v) in values {
                    self.image.set(TagId(tag), v, now);
                }
            }
            Event::Reload { program_hash } => report.notes.push(format!(
                "cycle {cycle}: the recorded run reloaded its program (sha256 {}…); the \
                 replay runs the project's program throughout",
                format::short_hex(program_hash)
            )),
        }
    }

    /// Recorded changes into the replayed image: values of the tags the program does not
    /// compute, qualities of all.
    fn apply_changes(&mut self, changes: &[format::Change], now: ScanInstant) {
        for c in changes {
            let i = c.tag as usize;
            self.recorded[i] = (c.value, c.quality);
            let id = TagId(c.tag);
            if !self.owned[i] {
                self.image.set(id, c.value, now);
            }
            self.image.set_quality(id, c.quality);
        }
    }
}
