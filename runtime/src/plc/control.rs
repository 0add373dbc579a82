//! What the control interface asks of a running PLC: force, write, reload. The PLC answers in
//! its own terms (values, counts, typed refusals); the service above turns them into its
//! protocol's replies, so nothing here knows how a request arrived.

use softplc_io::point::Value;

use crate::image::TagId;
use crate::logic::load;
use crate::offload::{self};
use crate::project::Project;
use crate::recorder::format::Event;

use super::error::{ReloadError, TagError};
use super::*;

impl Plc {
    /// Forces `tag` to the value `text` (parsed as the tag's type); returns the value.
    pub fn force(&mut self, tag: &str, text: &str) -> Result<Value, TagError> {
        let id = self.tag_id(tag)?;
        self.refuse_pushed(id, tag)?;
        let value = self.parse_value(id, tag, text)?;
        self.image.force(id, value);
        self.image.apply_forces(self.clock.now());
        self.note(|| Event::Force { tag: id.0, value });
        self.save_forces();
        tracing::warn!("tag {tag} forced to {value}");
        Ok(value)
    }

    /// Removes the force of `tag` (or of every tag); returns how many were removed.
    pub fn unforce(&mut self, tag: Option<&str>) -> Result<usize, TagError> {
        let n = match tag {
            Some(t) => {
                let id = self.tag_id(t)?;
                self.note(|| Event::Unforce { tag: id.0 });
                usize::from(self.image.unforce(id))
            }
            None => {
                self.note(|| Event::UnforceAll);
                self.image.unforce_all()
            }
        };
        if n > 0 {
            tracing::info!("{n} force(s) removed");
            self.save_forces();
        }
        Ok(n)
    }

    /// Sets tags to values (`(tag, text)`, the text parsed as each tag's type) all at once, as
    /// an assignment does: the program sees them in its next scan and may overwrite them.
    /// Nothing is set unless every tag exists, every value parses, no tag is forced (a force
    /// wins) and every tag is one the program may write (an input is its module's: the next
    /// input read would overwrite the value unseen). Every writer goes through here: the
    /// control socket's and the page's operator writes, OPC UA, Modbus TCP and MQTT. Returns
    /// how many tags were written.
    pub fn write_tags<'a>(
        &mut self,
        values: impl IntoIterator<Item = (&'a str, &'a str)>,
    ) -> Result<usize, TagError> {
        let mut parsed = Vec::new();
        for (tag, text) in values {
            let id = self.tag_id(tag)?;
            let value = self.parse_value(id, tag, text)?;
            if self.image.forced(id).is_some() {
                return Err(TagError::Forced { tag: tag.into() });
            }
            if !load::writable(&self.project, id.index()) {
                return Err(TagError::Input { tag: tag.into() });
            }
            self.refuse_pushed(id, tag)?;
            parsed.push((id, value));
        }
        let now = self.clock.now();
        for &(id, value) in &parsed {
            self.image.set(id, value, now);
            tracing::debug!("tag {} written: {value}", self.image.name(id));
        }
        self.note(|| Event::Write {
            values: parsed.iter().map(|&(id, v)| (id.0, v)).collect(),
        });
        Ok(parsed.len())
    }

    fn parse_value(&self, id: TagId, tag: &str, text: &str) -> Result<Value, TagError> {
        let ty = self.project.tags[id.index()].ty;
        Value::parse(ty, text).ok_or_else(|| TagError::BadValue {
            tag: tag.into(),
            ty,
            text: text.into(),
        })
    }

    /// A pushed-down output is its module's: the scan cannot set it.
    fn refuse_pushed(&self, id: TagId, tag: &str) -> Result<(), TagError> {
        if self.offload.refuses_force(id) {
            return Err(TagError::PushedOutput { tag: tag.into() });
        }
        if let Some(rung) = self.plan.pushed_reader(id) {
            return Err(TagError::PushedInput {
                tag: tag.into(),
                coil: rung.coil.clone(),
                pos: rung.rung.pos.clone(),
            });
        }
        Ok(())
    }

    fn tag_id(&self, tag: &str) -> Result<TagId, TagError> {
        self.image.id(tag).ok_or_else(|| TagError::Unknown {
            tag: tag.into(),
            project: self.project.name.clone(),
        })
    }

    /// Re-reads the project file and swaps in its program if it compiles against the same I/O
    /// map, all at once (tests and tools). A running scan does the same in two steps:
    /// [`Plc::reload_job`] compiles off the scan thread, [`Plc::apply_reload`] swaps at a
    /// cycle boundary.
    pub fn reload_program(&mut self) -> Result<(), ReloadError> {
        if let Prepared::Program(prepared) = self.reload_job().prepare()? {
            self.apply_reload(prepared);
        }
        Ok(())
    }

    /// What a reload needs, to be compiled on another thread (a large program would otherwise
    /// overrun the scan's next deadline).
    pub fn reload_job(&self) -> ReloadJob {
        ReloadJob {
            current: self.project.clone(),
            image: self.image.clone(),
            plan: self.plan.clone(),
            task: self.task.as_ref().map(|link| link.reload.clone()),
        }
    }

    /// Swaps in a program [`ReloadJob::prepare`] compiled. The running program is untouched
    /// until here; memory tags keep their values (the image is not rebuilt). The new program's
    /// files are [`Project::programs`].
    pub fn apply_reload(&mut self, prepared: PreparedReload) {
        self.logic = prepared.logic;
        self.project.programs = prepared.programs;
        if let (Some(link), Some(sources)) = (self.task.as_mut(), prepared.sources) {
            link.reload.swapped(sources);
        }
        self.note(|| Event::Reload {
            program_hash: prepared.program_hash,
        });
        tracing::info!("program {} reloaded", self.project.program_files());
    }
}

/// Whether two projects differ only in their program: a reload may change nothing else (the
/// scan, the lines, the retain file, push-down and services are set up at start).
fn same_io(a: &Project, b: &Project) -> bool {
    a.name == b.name
        && a.scan == b.scan
        && a.retain == b.retain
        && a.offload == b.offload
        && a.buses == b.buses
        && a.tags == b.tags
        && a.plant == b.plant
        && a.service == b.service
        && a.modules.len() == b.modules.len()
        && a.modules.iter().zip(&b.modules).all(|(x, y)| {
            x.name == y.name
                && x.bus == y.bus
                && x.model.name == y.model.name
                && x.device.address == y.device.address
                && x.device.protocol == y.device.protocol
                && x.device.settings == y.device.settings
        })
}

/// A reload to compile away from the scan: a copy of what the running PLC has.
#[derive(Debug)]
pub struct ReloadJob {
    current: Project,
    image: crate::image::ProcessImage,
    plan: offload::Plan,
    /// The task's checks, when the PLC is one task of several.
    task: Option<super::task_reload::TaskReload>,
}

/// A program compiled for the running PLC, ready to swap in at a cycle boundary.
#[derive(Debug)]
pub struct PreparedReload {
    logic: Box<dyn crate::logic::LogicEngine>,
    programs: Vec<crate::project::ProgramConfig>,
    /// The new program's identity, for the flight recorder (hashed here, off the scan).
    program_hash: crate::recorder::format::Digest,
    /// One task's of several: its program's sources, to tell the next reload whether they
    /// changed.
    sources: Option<crate::recorder::format::Digest>,
}

/// What a reload prepared.
#[derive(Debug)]
pub enum Prepared {
    /// A program to swap in.
    Program(PreparedReload),
    /// One task's of several whose program and block bodies are the ones running: nothing
    /// to swap.
    Unchanged,
}

impl ReloadJob {
    /// Reads the project file again and compiles its program; refused, with the reason, when
    /// it does not compile or when anything besides the program changed. One task of several
    /// reloads from its view of the project file, only when its program's files changed, and
    /// refuses a program writing a tag another task owns.
    pub fn prepare(self) -> Result<Prepared, ReloadError> {
        let loaded = crate::project::load(&self.current.source).map_err(ReloadError::Project)?;
        let fresh = match &self.task {
            Some(task) => task.view(&loaded)?,
            None => loaded,
        };
        if !same_io(&fresh, &self.current) {
            return Err(ReloadError::NotOnlyProgram);
        }
        if self
            .task
            .as_ref()
            .is_some_and(|t| t.unchanged(&fresh, &self.current))
        {
            return Ok(Prepared::Unchanged);
        }
        let mut logic = load::load_program(&fresh, &self.image).map_err(ReloadError::Program)?;
        if let Some(task) = &self.task {
            task.check_writes(logic.as_ref())?;
        }
        // The module tables were written at start-up: the new program must place its rungs
        // where the running one did.
        let plan = offload::plan_program(&fresh, logic.as_ref());
        if !offload::runtime::same_placement(&plan, &self.plan) {
            return Err(ReloadError::Placement);
        }
        for (r, _) in plan.pushed() {
            logic.release(r.rung.coil);
        }
        // The source as compiled was read just now; a read failing here (the file went away
        // since) leaves an identity of nothing rather than refusing a program that compiled.
        let source = fresh.program_source().unwrap_or_default();
        let sources = self
            .task
            .is_some()
            .then(|| super::task_reload::sources(&fresh));
        Ok(Prepared::Program(PreparedReload {
            logic,
            programs: fresh.programs,
            program_hash: crate::recorder::format::digest(&source),
            sources,
        }))
    }
}
