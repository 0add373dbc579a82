//! What the page knows of the instance that does not change while it runs (the project's
//! lines, modules and tags, the program with its push-down placements), sent once as
//! `GET /api/info`.

use serde::Serialize;

use softplc_io::point::Access;

use super::program::{self, ProgramView};
use crate::image::TagId;
use crate::plc::Plc;
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
    /// The programs of the task, in running order (one for most projects).
    pub programs: Vec<ProgramView>,
}

impl WebInfo {
    /// The information of `plc` under the page settings `web`, listing `project`'s lines,
    /// modules and tags (`plc.project()`, or with several tasks the whole project: `plc` is
    /// the first task's, whose program the page draws).
    pub fn new(plc: &Plc, project: &crate::project::Project, web: &WebConfig) -> Self {
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
                    pushed: plc.plan().is_pushed(TagId(i as u32)),
                    retain: t.retain,
                    description: t.description.as_ref().map(ToString::to_string),
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
            programs: program::views(plc.project(), plc.plan(), &plc.instance_counts()),
        }
    }
}
