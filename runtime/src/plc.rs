//! A project wired into a runnable PLC: one bus owner per line, one driver per module, the
//! simulated world behind `port: sim` lines, the process image and the program.
//!
//! The scan ([`crate::scan`]) calls the three phases in order. On a real clock every line has
//! its own thread and the phases wait for all lines in parallel; on a virtual clock the scan
//! runs each line itself, each from the cycle's start, so the whole project replays
//! deterministically and still models the lines as parallel.

use std::sync::Arc;
use std::time::Duration;

use softplc_io::line::bus::{
    BusCommand, BusEvent, BusOwner, BusThread, Counters, Discipline, InputFrame, Module,
    OutputFrame, StartupError, TxError,
};
use softplc_io::line::transport::{LineError, SerialTransport, Transport};
use softplc_io::point::{Access, Quality, Value};
use softplc_io::sim::line::{SharedWorld, SimWorld, VirtualPort};
use softplc_io::sim::plant;

use crate::clock::Clock;
use crate::image::{convert, ProcessImage, TagId};
use crate::logic::{load, LogicEngine, LogicFault, ScanContext};
use crate::offload::{self, runtime::Offloaded, Plan, RequireFailure};
use crate::project::{Binding, PortConfig, Project};

/// Why a PLC could not be built or started.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// The program did not compile.
    #[error("{0}")]
    Program(#[from] load::ProgramError),
    /// Rungs with `offload: require` cannot be pushed down (one line each).
    #[error("{}", offload::runtime::lines(.0))]
    Offload(Vec<RequireFailure>),
    /// A port could not be opened.
    #[error("bus {bus}: {source}")]
    Port {
        /// The bus.
        bus: String,
        /// The failure.
        source: LineError,
    },
    /// A bus thread could not be started.
    #[error("bus {bus}: cannot start its thread: {source}")]
    Thread {
        /// The bus.
        bus: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A module refused its start-up configuration.
    #[error("bus {bus}: {source}")]
    Startup {
        /// The bus.
        bus: String,
        /// The failure.
        source: StartupError,
    },
}

/// A tag fed from a module point.
#[derive(Debug, Clone, Copy)]
struct InputBinding {
    tag: TagId,
    bus: usize,
    module: usize,
    point: usize,
}

/// A tag that drives a module output.
#[derive(Debug, Clone, Copy)]
struct OutputBinding {
    tag: TagId,
    bus: usize,
    module: usize,
    point: usize,
    safe: Value,
}

/// How a line is driven.
#[derive(Debug)]
enum Line {
    /// Run by the scan itself (virtual clock).
    Inline(Box<BusOwner>),
    /// On its own thread (real time).
    Thread(BusThread),
    /// Shut down.
    Stopped,
}

/// A module's state as the scan last saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModuleStatus {
    /// Project name of the module.
    pub name: String,
    /// Its bus.
    pub bus: String,
    /// Quality of the last read.
    pub quality: Quality,
    /// Its counters.
    pub counters: Counters,
    /// Last failure, if the last read failed.
    pub last_error: Option<TxError>,
}

/// A PLC ready to scan.
#[derive(Debug)]
pub struct Plc {
    project: Project,
    clock: Arc<dyn Clock>,
    image: ProcessImage,
    logic: Box<dyn LogicEngine>,
    lines: Vec<Line>,
    /// Per bus: project module indexes, in the bus owner's order.
    bus_modules: Vec<Vec<usize>>,
    inputs: Vec<InputBinding>,
    outputs: Vec<OutputBinding>,
    frames: Vec<OutputFrame>,
    status: Vec<ModuleStatus>,
    world: Option<SharedWorld>,
    /// The longest time the scan waits for a line's answer.
    line_wait: Duration,
    /// Retained tags and their writer, when the project retains any.
    retain: Option<crate::retain::Retainer>,
    /// Where every rung runs (see [`crate::offload`]).
    plan: Plan,
    /// The outputs the modules drive.
    offload: Offloaded,
}

impl Plc {
    /// Builds the PLC for `project` on `clock`: compiles the program, opens every line (and the
    /// simulated world for `port: sim`), and runs every module's start-up configuration.
    pub fn build(project: Project, clock: Arc<dyn Clock>) -> Result<Self, BuildError> {
        let image = ProcessImage::new(project.tags.iter().map(|t| (t.name.clone(), t.initial)));
        let mut logic = load::load_program(&project, &image)?;
        // Push-down: the modules run the rungs the plan places there; their drivers get the
        // tables as start-up settings (written and verified before the first scan).
        let plan = offload::plan_program(&project, logic.as_ref());
        let failures = plan.require_failures();
        if !failures.is_empty() {
            return Err(BuildError::Offload(failures));
        }
        for (r, _) in plan.pushed() {
            logic.release(r.rung.coil);
        }
        let devices = plan.device_configs(&project);
        let mut image = image;
        for (i, t) in project.tags.iter().enumerate() {
            if t.binding == Binding::Memory {
                image.set(TagId(i as u32), t.initial, Duration::ZERO);
            }
        }
        let (retain, notes) = crate::retain::Retainer::open(&project, &mut image);
        for note in notes {
            match note {
                n if n.is_warning() => tracing::warn!("{n}"),
                n @ crate::retain::LoadNote::Missing(_) => tracing::debug!("{n}"),
                n => tracing::info!("{n}"),
            }
        }

        let mut world = build_world(&project);
        let mut bus_modules: Vec<Vec<usize>> = vec![Vec::new(); project.buses.len()];
        for (m, module) in project.modules.iter().enumerate() {
            bus_modules[module.bus].push(m);
        }
        let mut lines = Vec::with_capacity(project.buses.len());
        for (b, bus) in project.buses.iter().enumerate() {
            let transport: Box<dyn Transport> = match &bus.port {
                PortConfig::Sim => {
                    // build_world makes a world whenever a bus is `port: sim`.
                    let world = world.get_or_insert_with(|| SimWorld::new(Vec::new()).shared());
                    Box::new(VirtualPort::new(
                        world.clone(),
                        b,
                        bus.settings,
                        clock.clone(),
                    ))
                }
                PortConfig::Serial(path) => Box::new(
                    SerialTransport::open(path, bus.settings, clock.clone()).map_err(|source| {
                        BuildError::Port {
                            bus: bus.name.clone(),
                            source,
                        }
                    })?,
                ),
            };
            let modules = bus_modules[b]
                .iter()
                .map(|&m| {
                    let cfg = &project.modules[m];
                    Module::new(cfg.name.clone(), (cfg.model.driver)(&devices[m]))
                })
                .collect();
            let discipline = Discipline {
                response_timeout: bus.response_timeout,
                retries: bus.retries,
                output_refresh: bus.output_refresh,
                ..Discipline::default()
            };
            let mut owner = BusOwner::new(bus.name.clone(), transport, discipline, modules);
            owner.sync(clock.now());
            owner.startup().map_err(|source| BuildError::Startup {
                bus: bus.name.clone(),
                source,
            })?;
            if clock.is_virtual() {
                // The first cycle starts after the start-up traffic (tables, settings), as it
                // does on a real clock.
                clock.sleep_until(owner.now());
            }
            lines.push(if clock.is_virtual() {
                Line::Inline(Box::new(owner))
            } else {
                Line::Thread(
                    BusThread::spawn(owner).map_err(|source| BuildError::Thread {
                        bus: bus.name.clone(),
                        source,
                    })?,
                )
            });
        }

        let mut inputs = Vec::new();
        let mut outputs = Vec::new();
        for (i, tag) in project.tags.iter().enumerate() {
            let Binding::Point { module, point } = tag.binding else {
                continue;
            };
            let cfg = &project.modules[module];
            let bus = cfg.bus;
            let in_bus = bus_modules[bus]
                .iter()
                .position(|&m| m == module)
                .unwrap_or(0);
            let id = TagId(i as u32);
            match cfg.model.points[point].access {
                // The module drives it (see `offload`).
                Access::Output if plan.is_pushed(id) => {}
                Access::Output => outputs.push(OutputBinding {
                    tag: id,
                    bus,
                    module: in_bus,
                    point,
                    safe: tag.safe.unwrap_or(tag.ty.zero()),
                }),
                Access::Input | Access::ReadWrite => inputs.push(InputBinding {
                    tag: id,
                    bus,
                    module: in_bus,
                    point,
                }),
            }
        }
        let frames = bus_modules
            .iter()
            .map(|mods| OutputFrame {
                modules: mods
                    .iter()
                    .map(|&m| vec![None; project.modules[m].model.points.len()])
                    .collect::<Vec<_>>(),
            })
            .collect();
        let status = project
            .modules
            .iter()
            .map(|m| ModuleStatus {
                name: m.name.clone(),
                bus: project.buses[m.bus].name.clone(),
                quality: Quality::Bad,
                counters: Counters::default(),
                last_error: None,
            })
            .collect();
        let line_wait = project.scan.watchdog.time * project.scan.watchdog.sensitivity.max(1)
            + project.scan.period;
        let offload = Offloaded::new(&plan, &project, &bus_modules);
        Ok(Self {
            project,
            clock,
            image,
            logic,
            lines,
            bus_modules,
            inputs,
            outputs,
            frames,
            status,
            world,
            line_wait,
            retain,
            plan,
            offload,
        })
    }

    /// Where every rung runs: in a module or in the scan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The project.
    pub fn project(&self) -> &Project {
        &self.project
    }

    /// The clock.
    pub fn clock(&self) -> &Arc<dyn Clock> {
        &self.clock
    }

    /// The retained tags' store, when the project retains any.
    pub fn retainer(&self) -> Option<&crate::retain::Retainer> {
        self.retain.as_ref()
    }

    /// The process image.
    pub fn image(&self) -> &ProcessImage {
        &self.image
    }

    /// Per-module status, in project order.
    pub fn module_status(&self) -> &[ModuleStatus] {
        &self.status
    }

    /// The simulated world, when the project has `port: sim` lines.
    pub fn world(&self) -> Option<&SharedWorld> {
        self.world.as_ref()
    }

    /// Input phase: every line reads its modules (in parallel), then the image is updated.
    pub fn read_inputs(&mut self) {
        let start = self.clock.now();
        let mut frames: Vec<Option<InputFrame>> = Vec::with_capacity(self.lines.len());
        for line in &self.lines {
            if let Line::Thread(t) = line {
                t.send(BusCommand::Read);
            }
        }
        let mut latest = start;
        for line in &mut self.lines {
            let frame = match line {
                Line::Inline(owner) => {
                    owner.sync(start);
                    let f = owner.read_inputs();
                    latest = latest.max(f.finished);
                    Some(f)
                }
                Line::Thread(t) => match t.recv(self.line_wait) {
                    Some(BusEvent::Inputs(f)) => Some(f),
                    _ => None,
                },
                Line::Stopped => None,
            };
            frames.push(frame);
        }
        if self.clock.is_virtual() {
            self.clock.sleep_until(latest);
        }
        let now = self.clock.now();
        for (b, frame) in frames.iter().enumerate() {
            for (k, &m) in self.bus_modules[b].iter().enumerate() {
                let st = &mut self.status[m];
                match frame.as_ref().and_then(|f| f.modules.get(k)) {
                    Some(snap) => {
                        st.quality = snap.quality;
                        st.counters = snap.counters;
                        st.last_error = snap.last_error.clone();
                    }
                    None => {
                        // The line did not answer in time: its points keep their values.
                        st.quality = if st.quality == Quality::Good {
                            Quality::Stale
                        } else {
                            st.quality
                        };
                    }
                }
            }
        }
        for bind in &self.inputs {
            let Some(frame) = frames.get(bind.bus).and_then(Option::as_ref) else {
                let q = self.image.slot(bind.tag).quality;
                if q == Quality::Good {
                    self.image.set_quality(bind.tag, Quality::Stale);
                }
                continue;
            };
            if let Some(snap) = frame.modules.get(bind.module) {
                let value = snap.values.get(bind.point).copied().flatten();
                let quality = if value.is_none() {
                    Quality::Bad
                } else {
                    snap.quality
                };
                self.image.update(bind.tag, value, quality, now);
            }
        }
        self.offload.read_back(&mut self.image, &frames, now);
        self.image.apply_forces(now);
    }

    /// Logic phase.
    pub fn run_logic(&mut self, ctx: &ScanContext) -> Result<(), LogicFault> {
        let result = self.logic.scan(&mut self.image, ctx);
        self.offload.after_logic(&mut self.image, ctx.now);
        result
    }

    /// Output phase: every line writes what changed (in parallel).
    pub fn write_outputs(&mut self) {
        self.image.apply_forces(self.clock.now());
        for bind in &self.outputs {
            let v = convert(
                self.image.get(bind.tag),
                self.project.tags[bind.tag.index()].ty,
            );
            self.frames[bind.bus].modules[bind.module][bind.point] = Some(v);
        }
        self.offload.commands(&mut self.frames);
        self.dispatch_writes();
        self.offload.clear_commands(&mut self.frames);
        // Between cycles: hand changed retained values to their writer (never waits).
        if let Some(r) = self.retain.as_mut() {
            r.tick(&self.image, self.clock.now());
        }
    }

    /// Drives every output to its safe value (stop, fault, watchdog).
    pub fn write_safe_state(&mut self) {
        // Pushed-down outputs: their tables are cleared first, in a write of their own, so no
        // module logic drives them once they are set to their safe values.
        if self.offload.clear_tables(&mut self.frames) {
            self.dispatch_writes();
            self.offload.clear_commands(&mut self.frames);
        }
        for bind in &self.outputs {
            self.frames[bind.bus].modules[bind.module][bind.point] = Some(bind.safe);
            self.image.set(bind.tag, bind.safe, self.clock.now());
        }
        self.offload
            .safe_outputs(&mut self.frames, &mut self.image, self.clock.now());
        self.dispatch_writes();
        self.offload.clear_commands(&mut self.frames);
    }

    fn dispatch_writes(&mut self) {
        let start = self.clock.now();
        for (b, line) in self.lines.iter().enumerate() {
            if let Line::Thread(t) = line {
                t.send(BusCommand::Write(self.frames[b].clone()));
            }
        }
        let mut latest = start;
        for (b, line) in self.lines.iter_mut().enumerate() {
            match line {
                Line::Inline(owner) => {
                    owner.sync(start);
                    latest = latest.max(owner.write_outputs(&self.frames[b]).finished);
                }
                Line::Thread(t) => {
                    let _ = t.recv(self.line_wait);
                }
                Line::Stopped => {}
            }
        }
        if self.clock.is_virtual() {
            self.clock.sleep_until(latest);
        }
    }

    /// Writes the safe state and stops every line thread.
    pub fn shutdown(&mut self) {
        self.write_safe_state();
        if let Some(r) = self.retain.as_mut() {
            r.finish(&self.image);
        }
        for line in &mut self.lines {
            if let Line::Thread(t) = std::mem::replace(line, Line::Stopped) {
                let _ = t.stop(None, self.line_wait);
            }
        }
    }

    /// Forces `tag` to the value `text` (parsed as the tag's type); returns the value.
    pub fn force(&mut self, tag: &str, text: &str) -> Result<Value, String> {
        let id = self.tag_id(tag)?;
        self.refuse_pushed(id, tag)?;
        let ty = self.project.tags[id.index()].ty;
        let value = Value::parse(ty, text)
            .ok_or_else(|| format!("{tag} is {ty}: {text:?} is not a {ty}"))?;
        self.image.force(id, value);
        self.image.apply_forces(self.clock.now());
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
        Ok(())
    }

    fn tag_id(&self, tag: &str) -> Result<TagId, String> {
        self.image
            .id(tag)
            .ok_or_else(|| format!("no tag {tag:?} in project {}", self.project.name))
    }

    /// Re-reads the project file and swaps in its program if it compiles against the same I/O
    /// map. The running program is untouched when anything is refused. Memory tags keep their
    /// values (the image is not rebuilt).
    pub fn reload_program(&mut self) -> Result<String, String> {
        let fresh = crate::project::load(&self.project.source)
            .map_err(|e| format!("reload refused:\n{e}"))?;
        if !same_io(&fresh, &self.project) {
            return Err(
                "reload refused: buses, modules, tags or service changed; restart to apply them"
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
        self.logic = logic;
        self.project.program = fresh.program;
        let msg = format!("program {} reloaded", self.project.program.path.display());
        tracing::info!("{msg}");
        Ok(msg)
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

    /// Total bus errors over all modules.
    pub fn bus_errors(&self) -> u64 {
        self.status.iter().map(|s| s.counters.errors()).sum()
    }
}

impl Drop for Plc {
    fn drop(&mut self) {
        for line in &mut self.lines {
            if let Line::Thread(t) = std::mem::replace(line, Line::Stopped) {
                let _ = t.stop(None, Duration::from_millis(100));
            }
        }
    }
}

/// Whether two projects have the same I/O: a reload may only change the program.
fn same_io(a: &Project, b: &Project) -> bool {
    a.buses == b.buses
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

/// The simulated world for the project's `port: sim` lines, with its plant.
fn build_world(project: &Project) -> Option<SharedWorld> {
    if !project.buses.iter().any(|b| b.port == PortConfig::Sim) {
        return None;
    }
    let mut world = SimWorld::new(project.buses.iter().map(|b| b.settings).collect());
    let mut index = vec![None; project.modules.len()];
    for (m, module) in project.modules.iter().enumerate() {
        if project.buses[module.bus].port == PortConfig::Sim {
            let mut sim = (module.model.simulator)(module.device.address);
            if module.device.protocol != module.model.protocols[0] {
                // Validation checked the model speaks it, so this cannot be refused.
                let _ = sim.set_protocol(module.device.protocol);
            }
            index[m] = Some(world.add_device(module.bus, &module.name, sim));
        }
    }
    if let Some(cfg) = &project.plant {
        if let Some(spec) = plant::spec(&cfg.model) {
            let wires = spec
                .roles
                .iter()
                .filter_map(|role| {
                    cfg.wiring
                        .iter()
                        .find(|(r, _, _)| r == role.name)
                        .and_then(|(_, m, p)| index[*m].map(|d| (d, p.clone())))
                })
                .collect::<Vec<_>>();
            if wires.len() == spec.roles.len() {
                world.set_plant((spec.build)(), wires);
            }
        }
    }
    Some(world.shared())
}
