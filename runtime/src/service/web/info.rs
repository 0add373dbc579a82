//! What the page knows of the instance that does not change while it runs (the project's
//! lines, modules and tags, the program with its push-down placements), sent once as
//! `GET /api/info`.

use serde::Serialize;

use softplc_io::point::Access;

use super::program::{self, ProgramView};
use crate::image::TagId;
use crate::plc::{Plc, TaskPlan};
use crate::project::{Binding, PortConfig, WebConfig};

/// One RS-485 line.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct BusInfo {
    /// Its name.
    pub name: String,
    /// `sim` or the device path.
    pub port: String,
    /// Baud and format, `19200 8E1`.
    pub settings: String,
    /// With several tasks, the task polling it (its index in `tasks`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub task: Option<usize>,
}

/// One module.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ModuleInfo {
    /// Its name.
    pub name: String,
    /// Index into the buses.
    pub bus: usize,
    /// Its model.
    pub model: &'static str,
    /// Its unit address.
    pub address: u8,
    /// Its protocol.
    pub protocol: &'static str,
    /// Its `description:`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

/// One tag.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct TagInfo {
    /// Its name.
    pub name: String,
    /// `bool`, `u16`, `i32` or `f32`.
    #[serde(rename = "type")]
    pub ty: &'static str,
    /// `input`, `output`, `setting` (a module's read-write point) or `memory`.
    pub kind: &'static str,
    /// Its module (index), for a point.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub module: Option<usize>,
    /// Its point, the manual's name.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point: Option<&'static str>,
    /// The point's description.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub doc: Option<&'static str>,
    /// Whether a module's own logic drives it (push-down): the scan cannot force it.
    pub pushed: bool,
    /// Whether it is retained.
    pub retain: bool,
    /// Its `description:`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// With several tasks, the task owning it (its index in `tasks`): the one writing it,
    /// or for an input the one polling its line; none for a memory tag no program writes
    /// (the first task publishes it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub task: Option<usize>,
}

/// One task of a PLC of several tasks, as the page names it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct TaskInfo {
    /// Its name.
    pub name: String,
    /// Its period, µs.
    pub period_us: u64,
}

/// What one task gives the page in a PLC of several tasks: its programs with its own plan's
/// push-down marks and its own block numbering.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TaskPart {
    info: TaskInfo,
    programs: Vec<ProgramView>,
    /// The tags its plan pushes down into its modules.
    pushed: Vec<usize>,
}

impl TaskPart {
    /// Task `task`'s part, from its programs as its PLC runs them (`planned`), every
    /// `period`.
    pub fn of(planned: &TaskPlan, task: &str, period: std::time::Duration) -> Self {
        let plan = &planned.plan;
        let pushed = (0..planned.view.tags.len())
            .filter(|&t| plan.is_pushed(TagId(t as u32)))
            .collect();
        Self {
            info: TaskInfo {
                name: task.to_owned(),
                period_us: period.as_micros() as u64,
            },
            programs: program::views(&planned.view, plan, &planned.instance_counts),
            pushed,
        }
    }
}

/// Everything `GET /api/info` sends.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct WebInfo {
    /// The project's name.
    pub project: String,
    /// softplc's version.
    pub version: &'static str,
    /// Scan period, µs.
    pub period_us: u64,
    /// Whether the page may write (the project allows writes and has a token).
    pub writes: bool,
    /// Lines.
    pub buses: Vec<BusInfo>,
    /// Modules, in project order.
    pub modules: Vec<ModuleInfo>,
    /// Tags, in project order.
    pub tags: Vec<TagInfo>,
    /// Tags of the trend.
    pub trend: Vec<usize>,
    /// Tags on the operator's page (`operator: true`), in project order.
    pub operator: Vec<usize>,
    /// The programs of the task, in running order (one for most projects); with several
    /// tasks every task's, task after task, each naming its task.
    pub programs: Vec<ProgramView>,
    /// With several tasks, each task's name and period, in project order (empty for one).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub tasks: Vec<TaskInfo>,
}

impl WebInfo {
    /// The information of the one-task `plc` under the page settings `web`, listing
    /// `project`'s lines, modules and tags.
    pub fn new(plc: &Plc, project: &crate::project::Project, web: &WebConfig) -> Self {
        let programs = program::views(plc.project(), plc.plan(), &plc.instance_counts());
        Self::listing(
            project,
            web,
            |t| plc.plan().is_pushed(TagId(t as u32)),
            |_| None,
        )
        .with_programs(programs, Vec::new())
    }

    /// The information of a PLC of several tasks under the page settings `web`: the whole
    /// `project`'s lines, modules and tags (`owner`: each tag's owning task), and every
    /// task's programs from its `parts` (in task order).
    pub fn of_tasks(
        project: &crate::project::Project,
        web: &WebConfig,
        owner: impl Fn(usize) -> Option<usize>,
        parts: Vec<TaskPart>,
    ) -> Self {
        let listed = Self::listing(
            project,
            web,
            |t| parts.iter().any(|p| p.pushed.contains(&t)),
            owner,
        );
        let mut listed = listed;
        for (i, bus) in listed.buses.iter_mut().enumerate() {
            bus.task = Some(project.task_of_bus(i));
        }
        let mut programs = Vec::new();
        let mut tasks = Vec::with_capacity(parts.len());
        for (i, part) in parts.into_iter().enumerate() {
            programs.extend(
                part.programs
                    .into_iter()
                    .map(|p| ProgramView { task: Some(i), ..p }),
            );
            tasks.push(part.info);
        }
        listed.with_programs(programs, tasks)
    }

    fn with_programs(mut self, programs: Vec<ProgramView>, tasks: Vec<TaskInfo>) -> Self {
        self.programs = programs;
        self.tasks = tasks;
        self
    }

    /// `project`'s lines, modules and tags (`pushed`: whether a module's logic drives a tag;
    /// `owner`: its owning task), no program yet.
    fn listing(
        project: &crate::project::Project,
        web: &WebConfig,
        pushed: impl Fn(usize) -> bool,
        owner: impl Fn(usize) -> Option<usize>,
    ) -> Self {
        let buses = project
            .buses
            .iter()
            .map(|b| BusInfo {
                name: b.name.clone(),
                port: match &b.port {
                    PortConfig::Sim => "sim".to_owned(),
                    PortConfig::Serial(p) => p.display().to_string(),
                    PortConfig::Tcp(e) => e.to_string(),
                },
                settings: b.settings.to_string(),
                task: None,
            })
            .collect();
        let modules = project
            .modules
            .iter()
            .map(|m| ModuleInfo {
                name: m.name.clone(),
                bus: m.bus,
                model: m.model.name,
                address: m.device.address.get(),
                protocol: m.device.protocol.name(),
                description: m.description.as_ref().map(ToString::to_string),
            })
            .collect();
        let tags = project
            .tags
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let (kind, module, point) = match t.binding {
                    Binding::Memory => ("memory", None, None),
                    Binding::Point { module, point } => {
                        let spec = project
                            .modules
                            .get(module)
                            .and_then(|m| m.model.points.get(point));
                        let kind = match spec.map(|s| s.access) {
                            Some(Access::Input) => "input",
                            Some(Access::Output) => "output",
                            _ => "setting",
                        };
                        (kind, Some(module), spec)
                    }
                };
                TagInfo {
                    name: t.name.clone(),
                    ty: t.ty.name(),
                    kind,
                    module,
                    point: point.map(|p| p.name),
                    doc: point.map(|p| p.doc),
                    pushed: pushed(i),
                    retain: t.retain,
                    description: t.description.as_ref().map(ToString::to_string),
                    task: owner(i),
                }
            })
            .collect();
        Self {
            project: project.name.clone(),
            version: env!("CARGO_PKG_VERSION"),
            period_us: project.scan.period.as_micros() as u64,
            writes: web.writes && (web.token.is_some() || web.operator_token.is_some()),
            buses,
            modules,
            tags,
            trend: web.trend.clone(),
            operator: project.alarms.operator.clone(),
            programs: Vec::new(),
            tasks: Vec::new(),
        }
    }
}
