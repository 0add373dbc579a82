//! The planner: every rung the engine describes, with the project's bindings and switches,
//! becomes a [`Placement`]: in a module (with the tables to write) or central (with the
//! reason). Pure: no I/O, the same project and program give the same plan.

use std::collections::BTreeSet;
use std::fmt;
use std::time::Duration;

use softplc_io::devices::minimod::{self as mm, PulseWidth};
use softplc_io::devices::resi::{self as r};
use softplc_io::devices::{DeviceConfig, PushDown};
use softplc_io::point::{Access, PointSpec};

use super::{minimod, resi};
use crate::image::TagId;
use crate::logic::Rung;
use crate::logic::SourcePos;
use crate::project::{Binding, ModuleConfig, OffloadMode, Project};
use softplc_io::rung::{BoolExpr, RungShape};

/// One register the planner writes into a module at start-up (read back and verified by the
/// driver; cleared at stop unless the project keeps the tables).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TableEntry {
    /// The register's name in the model's map (`Y1AON1`, `SWITCH_RO3`).
    pub register: &'static str,
    /// Its value.
    pub value: u32,
    /// A bit mask (shown in hex) rather than a number.
    pub mask: bool,
    /// What it means, for the report (`X1-X2`).
    pub meaning: String,
}

/// A write the scan sends to a module at run time instead of the output itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Command {
    /// MiniMod pulser: on an edge of `trigger` (evaluated centrally, after the logic) while no
    /// pulse runs, write `width_ms` to the pulser register `point` (`YPULSEn`); the module
    /// holds the output on for exactly that many ms.
    Pulse {
        /// Index of the pulser register among the model's points.
        point: usize,
        /// Starts the pulse.
        trigger: Vec<BoolExpr>,
        /// Length.
        width: Duration,
        /// The register value.
        width_ms: PulseWidth,
    },
}

/// Which module feature runs the rung.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// MiniMod YnAON1..3 / YnAOFF1..3.
    AutoOnOff,
    /// MiniMod YPULSEn, triggered by the scan.
    Pulser,
    /// RESI-16DI8RO SWITCH.
    Switch,
    /// RESI-16DI8RO SWITCH ON + SWITCH OFF.
    SwitchOnOff,
    /// RESI-16DI8RO TOGGLE.
    Toggle,
    /// RESI-16DI8RO PULSE + PULSE TIME.
    Pulse,
}

impl Feature {
    /// The manual's name.
    pub fn name(self) -> &'static str {
        match self {
            Feature::AutoOnOff => "automatic outputs AON/AOFF (an OFF condition wins)",
            Feature::Pulser => "pulser YPULSE",
            Feature::Switch => "SWITCH",
            Feature::SwitchOnOff => "SWITCH ON / SWITCH OFF",
            Feature::Toggle => "TOGGLE",
            Feature::Pulse => "PULSE",
        }
    }
}

/// A rung placed in a module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModulePlacement {
    /// Index into [`Project::modules`].
    pub module: usize,
    /// The coil's output point, among the model's points.
    pub point: usize,
    /// The module feature.
    pub feature: Feature,
    /// Registers written at start-up, for the report and the clear at stop.
    pub tables: Vec<TableEntry>,
    /// The same tables as the driver takes them.
    pub pushed: Pushed,
    /// What the scan writes at run time, if anything.
    pub command: Option<Command>,
    /// The module's own reaction: its tick (input conditioning comes on top, for the module
    /// and for the scan alike).
    pub tick: Duration,
    /// The output's value written at start-up, after the module's old tables are cleared and
    /// before these are armed, when the rung keeps a state (a latch, a toggle, an edge set /
    /// reset, a pulse): the module never resets an output when its tables are written, so
    /// without it a pushed-down output would start from whatever the module held (a latch left
    /// on by a crashed run would stay on). It is the central rung's start: the tag's initial
    /// value, no pulse running. `None` for a combinational rung or a SWITCH: the module sets
    /// those from its inputs at once, as the first scan would.
    pub initial: Option<bool>,
}

/// A placement's tables as the module's driver takes them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pushed {
    /// No table (a pulser is driven by the scan).
    Nothing,
    /// A MiniMod output's AON/AOFF conditions.
    MiniMod(mm::AutoOutput),
    /// A RESI-16DI8RO relay's logic row.
    Resi(r::LogicRow),
}

/// Where a rung runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Placement {
    /// In a module.
    Module(ModulePlacement),
    /// In the scan.
    Central(Reason),
}

/// Why a rung stays central.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reason {
    /// `offload: never`; `pushable` tells whether `auto` would push it down.
    Never {
        /// Set on the coil's tag (else the project's mode).
        by_tag: bool,
        /// What `auto` would do: the module placement it would get.
        would: Option<Box<ModulePlacement>>,
    },
    /// The engine says the rung is none of the module's forms.
    Opaque(String),
    /// The coil is not a module output.
    NotAnOutput {
        /// What it is (`a memory tag`).
        what: String,
    },
    /// The coil's module has no logic tables.
    NoTables {
        /// The module.
        module: String,
        /// Its model.
        model: &'static str,
    },
    /// A condition reads a memory tag.
    Memory {
        /// The tag.
        tag: String,
    },
    /// A condition reads a point of another module.
    OtherModule {
        /// The tag.
        tag: String,
        /// Its module.
        module: String,
    },
    /// A condition reads a point of the module its logic cannot check.
    NotCheckable {
        /// The tag.
        tag: String,
        /// Its point.
        point: &'static str,
        /// What the module checks.
        checks: &'static str,
    },
    /// The sum of products does not fit.
    TooManyTerms {
        /// ON conditions needed.
        on: usize,
        /// OFF conditions needed.
        off: usize,
    },
    /// A time the module cannot represent.
    Time {
        /// The time.
        time: Duration,
        /// What the module takes.
        takes: &'static str,
    },
    /// The coil is written by more than this rung.
    WrittenElsewhere {
        /// By what.
        by: String,
    },
    /// The module has no such function.
    Unsupported {
        /// Why, in words.
        why: &'static str,
    },
    /// The module's tables cannot be read back to verify them on this protocol.
    NotVerifiable {
        /// Why.
        why: &'static str,
    },
    /// The pulse trigger reads a coil written later in the scan (or the rung's own coil).
    TriggerReadsLater {
        /// The tag.
        tag: String,
    },
    /// The module's settings already set a register the rung needs.
    SettingTaken {
        /// The register.
        register: String,
    },
}

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reason::Never { by_tag, would } => {
                let whose = if *by_tag {
                    "the tag's"
                } else {
                    "the project's"
                };
                write!(f, "offload: never ({whose} choice)")?;
                if let Some(p) = would {
                    write!(f, "; auto would push it into {}", p.feature.name())?;
                }
                Ok(())
            }
            Reason::Opaque(why) => f.write_str(why),
            Reason::NotAnOutput { what } => write!(f, "the coil is {what}, not a module output"),
            Reason::NoTables { module, model } => {
                write!(f, "module {module} ({model}) has no logic tables")
            }
            Reason::Memory { tag } => write!(
                f,
                "memory or a timer in the condition: {tag} is a memory tag, which the module \
                 cannot see"
            ),
            Reason::OtherModule { tag, module } => {
                write!(f, "an input from another module: {tag} is on {module}")
            }
            Reason::NotCheckable { tag, point, checks } => write!(
                f,
                "{tag} ({point}) cannot be checked by the module's logic, which checks {checks}"
            ),
            Reason::TooManyTerms { on, off } => write!(
                f,
                "too many terms: the condition needs {on} ON and {off} OFF conditions, the \
                 module has 3 of each"
            ),
            Reason::Time { time, takes } => write!(
                f,
                "a time the module cannot represent: {} (it takes {takes})",
                crate::scan::fmt_duration(*time)
            ),
            Reason::WrittenElsewhere { by } => {
                write!(f, "an output also written elsewhere: {by}")
            }
            Reason::Unsupported { why } => f.write_str(why),
            Reason::NotVerifiable { why } => f.write_str(why),
            Reason::TriggerReadsLater { tag } => write!(
                f,
                "the trigger reads {tag}, which is written by this rung or a later one (the \
                 scan evaluates the trigger after the logic)"
            ),
            Reason::SettingTaken { register } => write!(
                f,
                "the module's settings already set {register}; remove it there to let the \
                 planner write it"
            ),
        }
    }
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
    /// The latencies it sets.
    pub latency: mm::Latency,
}

/// A rung that must be pushed down and cannot.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{pos}: error: offload: require: the rung writing {coil} stays central: {reason}")]
pub struct RequireFailure {
    /// The rung.
    pub pos: SourcePos,
    /// Its coil.
    pub coil: String,
    /// Why.
    pub reason: Reason,
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

/// What the mappings see of the project around one rung.
pub(crate) struct Site<'a> {
    /// The project.
    pub project: &'a Project,
    /// The coil's module.
    pub module: usize,
    /// The coil's point index.
    pub point: usize,
    /// Coils of this rung and the rungs after it.
    pub later: &'a BTreeSet<TagId>,
}

impl Site<'_> {
    /// The coil's module.
    pub(crate) fn config(&self) -> &ModuleConfig {
        &self.project.modules[self.module]
    }

    /// The coil's point.
    pub(crate) fn coil_point(&self) -> &'static PointSpec {
        &self.config().model.points[self.point]
    }

    /// A tag's name.
    pub(crate) fn name(&self, tag: TagId) -> String {
        self.project
            .tags
            .get(tag.index())
            .map_or_else(|| format!("#{}", tag.0), |t| t.name.clone())
    }

    /// The point of the coil's module a condition tag reads, or why it cannot be read there.
    /// `checks` says what the module's logic checks, for the error.
    pub(crate) fn input(
        &self,
        tag: TagId,
        checks: &'static str,
    ) -> Result<&'static PointSpec, Reason> {
        let name = self.name(tag);
        let Some(t) = self.project.tags.get(tag.index()) else {
            return Err(Reason::Memory { tag: name });
        };
        match t.binding {
            Binding::Memory => Err(Reason::Memory { tag: name }),
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

    /// Whether the module's own settings already set `register` (the map's name).
    pub(crate) fn setting_taken(&self, register: &str) -> bool {
        let config = self.config();
        config
            .model
            .family
            .sets_register(&config.device.settings, register)
    }
}

/// Plans every rung. `rungs` is `None` when the engine does not describe its rungs; `engine`
/// is its name (for the report).
pub fn plan(project: &Project, rungs: Option<Vec<Rung>>, engine: &'static str) -> Plan {
    let mut plan = Plan {
        push_down: vec![PushDown::None; project.modules.len()],
        ..Plan::default()
    };
    plan.conditioning = conditioning(project);
    for c in &plan.conditioning {
        if let Some(PushDown::MiniMod(push)) = minimod_push(&mut plan.push_down, c.module) {
            push.latencies.push(c.latency);
        }
    }
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
            Err(Reason::WrittenElsewhere {
                by: "another rung of the program".into(),
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
        match p.pushed {
            Pushed::MiniMod(auto) => {
                if let Some(PushDown::MiniMod(push)) = minimod_push(&mut plan.push_down, p.module) {
                    push.auto.push(auto);
                }
            }
            Pushed::Resi(row) => {
                if let Some(PushDown::Resi(table)) = resi_push(&mut plan.push_down, p.module) {
                    table.rows.push(row);
                }
            }
            Pushed::Nothing => {}
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

/// The MiniMod push-down of module `m`, made when it is the first.
fn minimod_push(push: &mut [PushDown], m: usize) -> Option<&mut PushDown> {
    let slot = push.get_mut(m)?;
    if *slot == PushDown::None {
        *slot = PushDown::MiniMod(mm::PushDown::default());
    }
    Some(slot)
}

/// The RESI logic table of module `m`, made when it is the first.
fn resi_push(push: &mut [PushDown], m: usize) -> Option<&mut PushDown> {
    let slot = push.get_mut(m)?;
    if *slot == PushDown::None {
        *slot = PushDown::Resi(r::LogicTable::default());
    }
    Some(slot)
}

/// The start value of a pushed-down output whose rung keeps a state (see
/// [`ModulePlacement::initial`]).
fn initial(shape: &RungShape, tag_initial: bool) -> Option<bool> {
    match shape {
        RungShape::Latch { .. } | RungShape::Toggle { .. } | RungShape::EdgeSetReset { .. } => {
            Some(tag_initial)
        }
        // No pulse runs before the first trigger.
        RungShape::Pulse { .. } | RungShape::StairPulse { .. } => Some(false),
        RungShape::Combinational { .. } | RungShape::Blink { .. } | RungShape::Opaque { .. } => {
            None
        }
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
    let site = Site {
        project,
        module,
        point,
        later,
    };
    let mut placement = match cfg.model.name {
        minimod::MODEL => minimod::map(&rung.shape, &site),
        resi::MODEL => resi::map(&rung.shape, &site),
        model => Err(Reason::NoTables {
            module: cfg.name.clone(),
            model,
        }),
    }?;
    placement.initial = initial(&rung.shape, tag.initial.as_bool());
    Ok(placement)
}

/// The input conditioning the tags declare.
fn conditioning(project: &Project) -> Vec<Conditioning> {
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
        let spec = &cfg.model.points[point];
        let Some(input) = mm::Input::named(spec.name).filter(|_| cfg.model.name == minimod::MODEL)
        else {
            continue;
        };
        // debounce: both edges (stretch, when also given, sets the falling one).
        let latency = mm::Latency {
            input,
            rising: opts.debounce,
            falling: opts.stretch.or(opts.debounce),
        };
        out.push(Conditioning {
            tag: tag.name.clone(),
            module,
            latency,
        });
    }
    out
}
