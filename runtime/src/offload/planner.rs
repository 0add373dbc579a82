//! The planner: every rung the engine describes, with the project's bindings and switches,
//! becomes a [`Placement`]: in a module (with the tables to write) or central (with the
//! reason). Pure: no I/O, the same project and program give the same plan.

use std::collections::BTreeSet;

use softplc_io::devices::{DeviceConfig, ModelSpec, ModuleSettings, Protocol, PushDown};
use softplc_io::point::{Access, PointSpec};
pub use softplc_io::push_down::{Command, Feature, ModulePlacement, Pushed, Reason, TableEntry};

use crate::image::TagId;
use crate::logic::Rung;
use crate::logic::SourcePos;
use crate::project::{Binding, ModuleConfig, OffloadMode, Project};
use softplc_io::rung::RungShape;

/// Where a rung runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Placement {
    /// In a module.
    Module(ModulePlacement),
    /// In the scan.
    Central(Reason),
}

/// The plan of one rung.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RungPlan {
    /// The rung as the engine described it.
    pub rung: Rung,
    /// The coil's tag name.
    pub coil: String,
    /// The mode that applied (the tag's, else the project's).
    pub mode: OffloadMode,
    /// Where it runs.
    pub placement: Placement,
}

/// Input conditioning declared on a tag (`debounce`, `stretch`): registers written at start-up
/// whatever the mode, since no rung computes them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Conditioning {
    /// The tag.
    pub tag: String,
    /// Index into [`Project::modules`].
    pub module: usize,
    /// The module's registers that hold it, with their values (ms).
    pub registers: Vec<(&'static str, u16)>,
}

/// A rung that must be pushed down and cannot.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "{pos}: error: offload: require: the rung writing {coil}{} stays central: {reason}",
    titled(.title)
)]
pub struct RequireFailure {
    /// The rung.
    pub pos: SourcePos,
    /// Its coil.
    pub coil: String,
    /// The rung's title, when the program gives it one.
    pub title: Option<String>,
    /// Why.
    pub reason: Reason,
}

/// ` ("Belt latch")` after a coil's name when its rung has a title, else nothing.
fn titled(title: &Option<String>) -> String {
    title
        .as_ref()
        .map_or(String::new(), |t| format!(" (\"{t}\")"))
}

/// The push-down plan of a project.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Plan {
    /// Every rung, in program order.
    pub rungs: Vec<RungPlan>,
    /// Set when the engine does not describe its rungs: its name.
    pub silent_engine: Option<&'static str>,
    /// Input conditioning from tags.
    pub conditioning: Vec<Conditioning>,
    /// Per module (project order): what the plan hands its driver (tables, start values,
    /// input conditioning).
    pub push_down: Vec<PushDown>,
}

impl Plan {
    /// The rungs placed in modules.
    pub fn pushed(&self) -> impl Iterator<Item = (&RungPlan, &ModulePlacement)> + '_ {
        self.rungs.iter().filter_map(|r| match &r.placement {
            Placement::Module(p) => Some((r, p)),
            Placement::Central(_) => None,
        })
    }

    /// A pushed-down rung whose module reads `tag` itself (a force on `tag` cannot reach it).
    pub fn pushed_reader(&self, tag: TagId) -> Option<&RungPlan> {
        self.pushed()
            .map(|(r, _)| r)
            .find(|r| r.rung.shape.module_inputs().contains(&tag))
    }

    /// Whether the coil `tag` is owned by a module.
    pub fn is_pushed(&self, tag: TagId) -> bool {
        self.pushed().any(|(r, _)| r.rung.coil == tag)
    }

    /// Rungs with `offload: require` that stay central. Rungs writing memory tags are no
    /// candidates (a project-wide `require` is about the outputs).
    pub fn require_failures(&self) -> Vec<RequireFailure> {
        self.rungs
            .iter()
            .filter_map(|r| match (&r.placement, r.mode) {
                (Placement::Central(Reason::NotAnOutput { .. }), _) => None,
                (Placement::Central(reason), OffloadMode::Require) => Some(RequireFailure {
                    pos: r.rung.pos.clone(),
                    coil: r.coil.clone(),
                    title: r.rung.title.clone(),
                    reason: reason.clone(),
                }),
                _ => None,
            })
            .collect()
    }

    /// The modules' driver configurations with the plan's push-down.
    pub fn device_configs(&self, project: &Project) -> Vec<DeviceConfig> {
        project
            .modules
            .iter()
            .enumerate()
            .map(|(m, cfg)| {
                let mut device = cfg.device_with_watchdog();
                if let Some(push) = self.push_down.get(m) {
                    device.push_down = push.clone();
                }
                device
            })
            .collect()
    }
}

/// The project around one rung, as a family's push-down target asks it.
struct RungSite<'a> {
    /// The project.
    project: &'a Project,
    /// The coil's module.
    module: usize,
    /// The coil's point index.
    point: usize,
    /// The coil.
    coil: TagId,
    /// Coils of this rung and the rungs after it.
    later: &'a BTreeSet<TagId>,
}

impl RungSite<'_> {
    /// The coil's module.
    fn config(&self) -> &ModuleConfig {
        &self.project.modules[self.module]
    }
}

impl softplc_io::push_down::Site for RungSite<'_> {
    fn module(&self) -> usize {
        self.module
    }

    fn module_name(&self) -> &str {
        &self.config().name
    }

    fn model(&self) -> &'static ModelSpec {
        self.config().model
    }

    fn settings(&self) -> &ModuleSettings {
        &self.config().device.settings
    }

    fn protocol(&self) -> Protocol {
        self.config().device.protocol
    }

    fn setting_taken(&self, register: &str) -> bool {
        let config = self.config();
        config
            .model
            .family
            .sets_register(&config.device.settings, register)
    }

    fn point(&self) -> usize {
        self.point
    }

    fn coil_point(&self) -> &'static PointSpec {
        &self.config().model.points[self.point]
    }

    fn name(&self, tag: TagId) -> String {
        self.project
            .tags
            .get(tag.index())
            .map_or_else(|| format!("#{}", tag.0), |t| t.name.clone())
    }

    fn input(&self, tag: TagId, checks: &'static str) -> Result<&'static PointSpec, Reason> {
        let name = self.name(tag);
        let Some(t) = self.project.tags.get(tag.index()) else {
            return Err(Reason::Memory { tag: name });
        };
        let copied = self
            .project
            .tasks
            .first()
            .and_then(|task| task.copied_io.iter().find(|c| c.tag == tag.index()));
        match t.binding {
            Binding::Memory => Err(match copied {
                // Another task's I/O, a memory tag in this task's view.
                Some(c) => Reason::OtherTask {
                    tag: name,
                    task: c.task.clone(),
                    bus: c.bus.clone(),
                },
                None => Reason::Memory { tag: name },
            }),
            Binding::Point { module, point } => {
                let cfg = &self.project.modules[module];
                if module != self.module {
                    return Err(Reason::OtherModule {
                        tag: name,
                        module: cfg.name.clone(),
                    });
                }
                let spec = &cfg.model.points[point];
                if spec.access != Access::Input {
                    return Err(Reason::NotCheckable {
                        tag: name,
                        point: spec.name,
                        checks,
                    });
                }
                Ok(spec)
            }
        }
    }

    fn blink_phase_free(&self) -> bool {
        self.project
            .offload
            .tags
            .get(self.coil.index())
            .is_some_and(|t| t.blink_phase_free)
    }

    fn later(&self) -> &BTreeSet<TagId> {
        self.later
    }
}

/// Plans every rung. `rungs` is `None` when the engine does not describe its rungs; `engine`
/// is its name (for the report).
pub fn plan(project: &Project, rungs: Option<Vec<Rung>>, engine: &'static str) -> Plan {
    let mut plan = Plan {
        push_down: vec![PushDown::None; project.modules.len()],
        ..Plan::default()
    };
    plan.conditioning = conditioning(project, &mut plan.push_down);
    let Some(rungs) = rungs else {
        plan.silent_engine = Some(engine);
        return plan;
    };
    // Coils written by several rungs (an engine may describe a coil twice).
    let mut seen = BTreeSet::new();
    let twice: BTreeSet<TagId> = rungs
        .iter()
        .filter(|r| !seen.insert(r.coil))
        .map(|r| r.coil)
        .collect();
    for (i, rung) in rungs.iter().enumerate() {
        let later: BTreeSet<TagId> = rungs.iter().skip(i).map(|r| r.coil).collect();
        let coil = project
            .tags
            .get(rung.coil.index())
            .map_or_else(|| format!("#{}", rung.coil.0), |t| t.name.clone());
        let mode = project.offload.mode_of(rung.coil.index());
        let mapped = if twice.contains(&rung.coil) {
            // The other rung by its place: with a task's several programs it may be in
            // another file.
            let other = rungs
                .iter()
                .enumerate()
                .find(|(j, r)| *j != i && r.coil == rung.coil)
                .map_or_else(String::new, |(_, r)| format!(" at {}", r.pos));
            Err(Reason::WrittenElsewhere {
                by: format!("another rung of the program{other}"),
            })
        } else {
            place(project, rung, &later)
        };
        let placement = match (mode, mapped) {
            (_, Err(reason)) => Placement::Central(reason),
            (OffloadMode::Never, Ok(p)) => Placement::Central(Reason::Never {
                by_tag: project
                    .offload
                    .tags
                    .get(rung.coil.index())
                    .is_some_and(|t| t.mode.is_some()),
                would: Some(Box::new(p)),
            }),
            (_, Ok(p)) => Placement::Module(p),
        };
        plan.rungs.push(RungPlan {
            rung: rung.clone(),
            coil,
            mode,
            placement,
        });
    }
    let pushed: Vec<ModulePlacement> = plan.pushed().map(|(_, p)| p.clone()).collect();
    for p in &pushed {
        let point = project.modules[p.module].model.points.get(p.point);
        if let Some(push) = plan.push_down.get_mut(p.module) {
            let family = project.modules[p.module].model.family;
            family.add_pushed(push, p.pushed);
        }
        let Some((on, point)) = p.initial.zip(point) else {
            continue;
        };
        if let Some(push) = plan.push_down.get_mut(p.module) {
            let family = project.modules[p.module].model.family;
            family.push_initial(push, point.name, on);
        }
    }
    plan
}

fn initial(shape: &RungShape, tag_initial: bool) -> Option<bool> {
    match shape {
        RungShape::Latch { .. } | RungShape::Toggle { .. } | RungShape::EdgeSetReset { .. } => {
            Some(tag_initial)
        }
        // No pulse runs before the first trigger; a blinker's output is off until its mask
        // is written (and off again whenever its mask is 0).
        RungShape::Pulse { .. }
        | RungShape::StairPulse { .. }
        | RungShape::Blink { .. }
        | RungShape::BlinkPattern { .. }
        | RungShape::Lamp { .. } => Some(false),
        RungShape::Combinational { .. } | RungShape::Opaque { .. } => None,
    }
}

/// One rung's module placement, or why it stays central.
fn place(
    project: &Project,
    rung: &Rung,
    later: &BTreeSet<TagId>,
) -> Result<ModulePlacement, Reason> {
    let Some(tag) = project.tags.get(rung.coil.index()) else {
        return Err(Reason::NotAnOutput {
            what: "not a tag of the project".into(),
        });
    };
    let (module, point) = match tag.binding {
        Binding::Memory => {
            return Err(Reason::NotAnOutput {
                what: "a memory tag".into(),
            })
        }
        Binding::Point { module, point } => (module, point),
    };
    let cfg = &project.modules[module];
    if cfg.model.points[point].access != Access::Output {
        return Err(Reason::NotAnOutput {
            what: format!("bound to {}.{}", cfg.name, cfg.model.points[point].name),
        });
    }
    // After the coil: a rung writing a memory tag is no candidate whatever its shape, so a
    // project-wide `offload: require` (which is about the outputs) does not fail on it.
    if let RungShape::Opaque { reason } = &rung.shape {
        return Err(Reason::Opaque(reason.clone()));
    }
    if project
        .service
        .scada
        .entries
        .iter()
        .any(|e| e.tag == rung.coil.index() && e.writable)
    {
        return Err(Reason::WrittenElsewhere {
            by: "SCADA (scada: write)".into(),
        });
    }
    let site = RungSite {
        project,
        module,
        point,
        coil: rung.coil,
        later,
    };
    let mut placement = cfg.model.family.push_down(&rung.shape, &site)?;
    placement.initial = initial(&rung.shape, tag.initial.as_bool());
    Ok(placement)
}

/// The input conditioning the tags declare, added to their modules' push-down.
fn conditioning(project: &Project, push_down: &mut [PushDown]) -> Vec<Conditioning> {
    let mut out = Vec::new();
    for (i, tag) in project.tags.iter().enumerate() {
        let Some(opts) = project.offload.tags.get(i) else {
            continue;
        };
        if opts.debounce.is_none() && opts.stretch.is_none() {
            continue;
        }
        let Binding::Point { module, point } = tag.binding else {
            continue;
        };
        let cfg = &project.modules[module];
        let Some(push) = push_down.get_mut(module) else {
            continue;
        };
        // debounce: both edges (stretch, when also given, sets the falling one).
        let falling = opts.stretch.or(opts.debounce);
        let registers = cfg.model.family.condition_input(
            push,
            cfg.model.points[point].name,
            opts.debounce,
            falling,
        );
        if let Some(registers) = registers {
            out.push(Conditioning {
                tag: tag.name.clone(),
                module,
                registers,
            });
        }
    }
    out
}
