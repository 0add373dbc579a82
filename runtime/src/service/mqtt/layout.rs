//! The edge node's metric set: what NBIRTH and each DBIRTH declare, with the aliases DATA and
//! CMD messages use (Sparkplug B 3.0, "Payloads" › "Metric": an alias is unique across the
//! edge node's whole metric set, devices included).
//!
//! Each module is a Sparkplug device whose metrics are the tags bound to its points; memory
//! tags are node metrics, beside the PLC's own (scans, overruns, cycle p99, state).

use softplc_io::point::ValueType;

use crate::project::{Binding, Project};

/// The name of the rebirth command metric (Sparkplug B 3.0, "Operational Behavior" ›
/// "Commands"); it has no alias, as the specification requires.
pub(crate) const REBIRTH: &str = "Node Control/Rebirth";
/// The birth/death sequence metric.
pub(crate) const BD_SEQ: &str = "bdSeq";

/// The PLC's own node metrics, in alias order after the tags.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PlcMetric {
    /// Completed scans (UInt64).
    Scans,
    /// Overruns (UInt64).
    Overruns,
    /// Cycle time's 99th percentile in µs (UInt64).
    CycleP99,
    /// `running` or `stopped` (String).
    State,
    /// Changes dropped from the buffer while the broker was away (UInt64).
    Dropped,
    /// Changes the node could not take from the scan in time (UInt64).
    Lost,
}

impl PlcMetric {
    /// Every PLC metric.
    pub(crate) const ALL: [PlcMetric; 6] = [
        PlcMetric::Scans,
        PlcMetric::Overruns,
        PlcMetric::CycleP99,
        PlcMetric::State,
        PlcMetric::Dropped,
        PlcMetric::Lost,
    ];

    /// Its metric name.
    pub(crate) fn name(self) -> &'static str {
        match self {
            PlcMetric::Scans => "PLC/Scans",
            PlcMetric::Overruns => "PLC/Overruns",
            PlcMetric::CycleP99 => "PLC/Cycle p99 us",
            PlcMetric::State => "PLC/State",
            PlcMetric::Dropped => "MQTT/Dropped changes",
            PlcMetric::Lost => "MQTT/Lost changes",
        }
    }
}

/// A task's node metrics (a PLC of several tasks): `Tasks/NAME/FIELD`, UInt64, durations in µs
/// (as `PLC/Cycle p99 us`).
pub(crate) const TASK_FIELDS: [&str; 6] = [
    "Scans",
    "Overruns",
    "Cycle p50 us",
    "Cycle p99 us",
    "Cycle max us",
    "Lateness p99 us",
];

/// Field `k` of [`TASK_FIELDS`] in task report `t`.
pub(crate) fn task_field(t: &crate::service::status::TaskReport, k: usize) -> u64 {
    match k {
        0 => t.scans,
        1 => t.overruns,
        2 => t.cycle.p50_us,
        3 => t.cycle.p99_us,
        4 => t.cycle.max_us,
        _ => t.lateness.p99_us,
    }
}

/// One tag as a metric.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TagMetric {
    /// Index into the project's tags (and the snapshot's values).
    pub tag: usize,
    /// The metric name (the tag's name).
    pub name: String,
    /// Its type.
    pub ty: ValueType,
    /// Its alias.
    pub alias: u64,
    /// Its device (module index), `None` for a node metric (a memory tag).
    pub device: Option<usize>,
    /// What its births say of it besides its value.
    pub birth: BirthProperties,
}

/// What a tag's births say of it besides its value: the tag's `description:` (the
/// `description` property), and the engineering unit and range from its device profile
/// point's `unit:` and `range:` (Sparkplug's `engUnit`, `engLow`, `engHigh` properties, as
/// Ignition reads them).
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct BirthProperties {
    /// The tag's description.
    pub description: Option<String>,
    /// The unit (`V`, `Hz`).
    pub unit: Option<String>,
    /// Low and high end of the measuring range.
    pub range: Option<(f64, f64)>,
}

impl BirthProperties {
    /// What `tag` of `project` says: its description, and what the profile point behind it
    /// says (nothing for a memory tag, a built-in model or a bit field).
    fn of(project: &Project, tag: &crate::project::TagConfig) -> Self {
        let description = tag.description.as_ref().map(|d| d.to_string());
        let Binding::Point { module, point } = tag.binding else {
            return Self {
                description,
                ..Self::default()
            };
        };
        let model = project.modules[module].model;
        let found = model
            .profile
            .zip(model.points.get(point))
            .and_then(|(profile, spec)| profile.points.iter().find(|p| p.name == spec.name));
        Self {
            description,
            unit: found.and_then(|p| p.unit.clone()),
            range: found.and_then(|p| p.range),
        }
    }
}

/// The whole metric set.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Layout {
    /// Every tag, in tag order (alias = tag index + 1).
    pub tags: Vec<TagMetric>,
    /// Device ids (module names), in module order.
    pub devices: Vec<String>,
    /// With several tasks, each task's metric names, task after task in [`TASK_FIELDS`]
    /// order (aliases after the PLC's own).
    pub tasks: Vec<String>,
}

impl Layout {
    /// The layout of `project`.
    pub(crate) fn of(project: &Project) -> Self {
        let tags = project
            .tags
            .iter()
            .enumerate()
            .map(|(i, t)| TagMetric {
                tag: i,
                name: t.name.clone(),
                ty: t.ty,
                alias: i as u64 + 1,
                device: match t.binding {
                    Binding::Point { module, .. } => Some(module),
                    Binding::Memory => None,
                },
                birth: BirthProperties::of(project, t),
            })
            .collect();
        let devices = project.modules.iter().map(|m| m.name.clone()).collect();
        let tasks = match project.multitask() {
            true => project
                .tasks
                .iter()
                .flat_map(|t| {
                    TASK_FIELDS
                        .iter()
                        .map(move |f| format!("Tasks/{}/{f}", t.name))
                })
                .collect(),
            false => Vec::new(),
        };
        Self {
            tags,
            devices,
            tasks,
        }
    }

    /// The alias of task metric `j` (in [`Layout::tasks`]; after the PLC's own).
    pub(crate) fn task_alias(&self, j: usize) -> u64 {
        self.tags.len() as u64 + 1 + PlcMetric::ALL.len() as u64 + j as u64
    }

    /// The alias of a PLC metric (after every tag's).
    pub(crate) fn plc_alias(&self, m: PlcMetric) -> u64 {
        let at = PlcMetric::ALL.iter().position(|&x| x == m).unwrap_or(0);
        self.tags.len() as u64 + 1 + at as u64
    }

    /// The tags of device `device` (`None`: the node's own).
    pub(crate) fn tags_of(&self, device: Option<usize>) -> impl Iterator<Item = &TagMetric> {
        self.tags.iter().filter(move |t| t.device == device)
    }

    /// The tag a CMD names, by alias or by name, on `device`.
    pub(crate) fn find(
        &self,
        device: Option<usize>,
        alias: Option<u64>,
        name: Option<&str>,
    ) -> Option<&TagMetric> {
        self.tags_of(device)
            .find(|t| alias.is_some_and(|a| a == t.alias) || name.is_some_and(|n| n == t.name))
    }
}
