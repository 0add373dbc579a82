//! What the control interface asks of a running PLC: force, write, reload, status.

use softplc_io::point::Value;

use crate::image::TagId;
use crate::logic::load;
use crate::offload::{self};
use crate::project::Project;

use super::*;

impl Plc {
    /// Forces `tag` to the value `text` (parsed as the tag's type); returns the value.
    pub fn force(&mut self, tag: &str, text: &str) -> Result<Value, String> {
        let id = self.tag_id(tag)?;
        self.refuse_pushed(id, tag)?;
        let ty = self.project.tags[id.index()].ty;
        let value = Value::parse(ty, text)
            .ok_or_else(|| format!("{tag} is {ty}: {text:?} is not a {ty}"))?;
        self.image.force(id, value);
        self.image.apply_forces(self.clock.now());
        self.save_forces();
        tracing::warn!("tag {tag} forced to {value}");
        Ok(value)
    }

    /// Removes the force of `tag` (or of every tag); returns how many were removed.
    pub fn unforce(&mut self, tag: Option<&str>) -> Result<usize, String> {
        let n = match tag {
            Some(t) => usize::from(self.image.unforce(self.tag_id(t)?)),
            None => self.image.unforce_all(),
        };
        if n > 0 {
            tracing::info!("{n} force(s) removed");
            self.save_forces();
        }
        Ok(n)
    }

    /// Sets tags to values (text, parsed as each tag's type) all at once, as an assignment
    /// does: the program sees them in its next scan and may overwrite them. Nothing is set
    /// unless every tag exists, every value parses and no tag is forced (a force wins).
    pub fn write_tags(
        &mut self,
        values: &[crate::service::control::TagValue],
    ) -> Result<String, String> {
        let mut parsed = Vec::with_capacity(values.len());
        for tv in values {
            let id = self.tag_id(&tv.tag)?;
            let ty = self.project.tags[id.index()].ty;
            let value = Value::parse(ty, &tv.value)
                .ok_or_else(|| format!("{} is {ty}: {:?} is not a {ty}", tv.tag, tv.value))?;
            if self.image.forced(id).is_some() {
                return Err(format!("{} is forced; unforce it to write it", tv.tag));
            }
            self.refuse_pushed(id, &tv.tag)?;
            parsed.push((id, value));
        }
        let now = self.clock.now();
        for &(id, value) in &parsed {
            self.image.set(id, value, now);
            tracing::debug!("tag {} written: {value}", self.image.name(id));
        }
        Ok(format!("{} tag(s) written", parsed.len()))
    }

    /// A pushed-down output is its module's: the scan cannot set it.
    fn refuse_pushed(&self, id: TagId, tag: &str) -> Result<(), String> {
        if self.offload.owns(id) {
            return Err(format!(
                "{tag} is driven by its module's own logic (push-down); set offload: never on \
                 the tag to drive it from the scan"
            ));
        }
        if let Some(rung) = self.plan.pushed_reader(id) {
            return Err(format!(
                "{tag} is read by the module's own logic for {} ({}), which sees the real \
                 terminal, not a force; set offload: never on {} to force it",
                rung.coil, rung.rung.pos, rung.coil
            ));
        }
        Ok(())
    }

    fn tag_id(&self, tag: &str) -> Result<TagId, String> {
        self.image
            .id(tag)
            .ok_or_else(|| format!("no tag {tag:?} in project {}", self.project.name))
    }

    /// Re-reads the project file and swaps in its program if it compiles against the same I/O
    /// map, all at once (tests and tools). A running scan does the same in two steps:
    /// [`Plc::reload_job`] compiles off the scan thread, [`Plc::apply_reload`] swaps at a
    /// cycle boundary.
    pub fn reload_program(&mut self) -> Result<String, String> {
        let prepared = self.reload_job().prepare()?;
        Ok(self.apply_reload(prepared))
    }

    /// What a reload needs, to be compiled on another thread (a large program would otherwise
    /// overrun the scan's next deadline).
    pub fn reload_job(&self) -> ReloadJob {
        ReloadJob {
            current: self.project.clone(),
            image: self.image.clone(),
            plan: self.plan.clone(),
        }
    }

    /// Swaps in a program [`ReloadJob::prepare`] compiled. The running program is untouched
    /// until here; memory tags keep their values (the image is not rebuilt).
    pub fn apply_reload(&mut self, prepared: PreparedReload) -> String {
        self.logic = prepared.logic;
        self.project.program = prepared.program;
        let msg = format!("program {} reloaded", self.project.program.path.display());
        tracing::info!("{msg}");
        msg
    }

    /// The status report for `softplc status`.
    pub fn status_report(
        &self,
        stats: &crate::scan::ScanStats,
    ) -> crate::service::status::StatusReport {
        use crate::service::status::{ModuleReport, StatusReport, TagReport};
        StatusReport {
            project: self.project.name.clone(),
            scans: stats.cycles,
            overruns: stats.overruns,
            period_us: self.project.scan.period.as_micros() as u64,
            cycle: stats.cycle.percentiles().into(),
            lateness: stats.lateness.percentiles().into(),
            modules: self
                .status
                .iter()
                .map(|m| ModuleReport {
                    name: m.name.clone(),
                    bus: m.bus.clone(),
                    quality: m.quality.to_string(),
                    requests: m.counters.requests,
                    timeouts: m.counters.timeouts,
                    crc_errors: m.counters.crc_errors,
                    bad_replies: m.counters.bad_replies,
                    exceptions: m.counters.exceptions,
                    last_round_trip_us: m.counters.last_round_trip.as_micros() as u64,
                    last_error: m.last_error.as_ref().map(ToString::to_string),
                })
                .collect(),
            tags: (0..self.image.len())
                .map(|i| {
                    let id = TagId(i as u32);
                    let slot = self.image.slot(id);
                    TagReport {
                        name: self.image.name(id).to_string(),
                        value: slot.value.to_string(),
                        quality: slot.quality.to_string(),
                        forced: self.image.forced(id).map(|v| v.to_string()),
                    }
                })
                .collect(),
        }
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
}

/// A program compiled for the running PLC, ready to swap in at a cycle boundary.
#[derive(Debug)]
pub struct PreparedReload {
    logic: Box<dyn crate::logic::LogicEngine>,
    program: crate::project::ProgramConfig,
}

impl ReloadJob {
    /// Reads the project file again and compiles its program; refused, with the reason, when
    /// it does not compile or when anything besides the program changed.
    pub fn prepare(self) -> Result<PreparedReload, String> {
        let fresh = crate::project::load(&self.current.source)
            .map_err(|e| format!("reload refused:\n{e}"))?;
        if !same_io(&fresh, &self.current) {
            return Err(
                "reload refused: something besides the program changed (scan, buses, modules, tags, retain, offload or service); restart to apply it"
                    .into(),
            );
        }
        let mut logic =
            load::load_program(&fresh, &self.image).map_err(|e| format!("reload refused:\n{e}"))?;
        // The module tables were written at start-up: the new program must place its rungs
        // where the running one did.
        let plan = offload::plan_program(&fresh, logic.as_ref());
        if !offload::runtime::same_placement(&plan, &self.plan) {
            return Err(
                "reload refused: the new program moves rungs into or out of modules; restart \
                 to write the module tables"
                    .into(),
            );
        }
        for (r, _) in plan.pushed() {
            logic.release(r.rung.coil);
        }
        Ok(PreparedReload {
            logic,
            program: fresh.program,
        })
    }
}
