//! The OPC UA address space of a project, and what a snapshot changes in it.
//!
//! ```text
//! Objects/
//!   Tags/            one variable per exposed tag (not `scada: none`): Tags.NAME
//!   Modules/NAME/    Quality, Requests, Errors, RoundTrip: Modules.NAME.FIELD
//!   PLC/             State, Scans, Overruns, CycleP50, CycleP99, CycleMax: PLC.FIELD
//!     Tasks/NAME/    with `tasks:`, each task's Period, Scans, Overruns, CycleP50, CycleP99,
//!                    CycleMax, LatenessP99, LatenessMax: PLC.Tasks.NAME.FIELD
//! ```
//!
//! Node ids are strings in the project's namespace ([`NAMESPACE_PREFIX`] + the project's
//! name). A tag's DataType is its type's (bool → Boolean, u16 → UInt16, i32 → Int32, f32 →
//! Float); its StatusCode is its quality's ([`status_of`]); its SourceTimestamp is the scan
//! time of the value, its ServerTimestamp when the server took it from the snapshot. Durations
//! are OPC UA `Duration`s (a Double of milliseconds).

use opcua::types::{DataTypeId, DataValue, DateTime, StatusCode, Variant};
use softplc_io::point::{Quality, Value, ValueType};

use crate::project::Project;
use crate::service::changes::Delivery;
use crate::service::snapshot::ServiceSnapshot;
use softplc_io::time::ScanInstant;

/// The namespace URI of a project's nodes: this + the project's name.
pub(crate) const NAMESPACE_PREFIX: &str = "urn:softplc:";

/// The StatusCode of a value of quality `q`.
pub(crate) fn status_of(q: Quality) -> StatusCode {
    match q {
        Quality::Good => StatusCode::Good,
        Quality::Stale => StatusCode::UncertainLastUsableValue,
        Quality::Bad => StatusCode::BadCommunicationError,
    }
}

/// A tag's value as an OPC UA Variant of its exact type.
pub(crate) fn variant(v: Value) -> Variant {
    match v {
        Value::Bool(b) => Variant::Boolean(b),
        Value::U16(u) => Variant::UInt16(u),
        Value::I32(i) => Variant::Int32(i),
        Value::F32(f) => Variant::Float(f),
    }
}

/// The value a Variant written by a client gives a tag of type `ty`, when it is of that exact
/// type (the server has checked it against the node's DataType already).
pub(crate) fn value_of(ty: ValueType, v: &Variant) -> Option<Value> {
    match (ty, v) {
        (ValueType::Bool, Variant::Boolean(b)) => Some(Value::Bool(*b)),
        (ValueType::U16, Variant::UInt16(u)) => Some(Value::U16(*u)),
        (ValueType::I32, Variant::Int32(i)) => Some(Value::I32(*i)),
        (ValueType::F32, Variant::Float(f)) => Some(Value::F32(*f)),
        _ => None,
    }
}

/// A tag type's DataType.
pub(crate) fn data_type(ty: ValueType) -> DataTypeId {
    match ty {
        ValueType::Bool => DataTypeId::Boolean,
        ValueType::U16 => DataTypeId::UInt16,
        ValueType::I32 => DataTypeId::Int32,
        ValueType::F32 => DataTypeId::Float,
    }
}

/// A module's diagnostic variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ModuleField {
    /// Its last read's quality: "good", "stale" or "bad" (String).
    Quality,
    /// Requests sent (UInt64).
    Requests,
    /// Failed requests (UInt64).
    Errors,
    /// Round trip of its last good transaction (Duration).
    RoundTrip,
}

impl ModuleField {
    /// Every field, in browse order.
    pub(crate) const ALL: [ModuleField; 4] = [
        ModuleField::Quality,
        ModuleField::Requests,
        ModuleField::Errors,
        ModuleField::RoundTrip,
    ];

    /// Its browse name.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Quality => "Quality",
            Self::Requests => "Requests",
            Self::Errors => "Errors",
            Self::RoundTrip => "RoundTrip",
        }
    }

    fn data_type(self) -> DataTypeId {
        match self {
            Self::Quality => DataTypeId::String,
            Self::Requests | Self::Errors => DataTypeId::UInt64,
            Self::RoundTrip => DataTypeId::Duration,
        }
    }
}

/// The PLC's diagnostic variables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PlcField {
    /// "running" or "stopped" (String).
    State,
    /// Completed scans (UInt64).
    Scans,
    /// Overruns (UInt64).
    Overruns,
    /// Cycle time median (Duration).
    CycleP50,
    /// Cycle time 99th percentile (Duration).
    CycleP99,
    /// Longest cycle (Duration).
    CycleMax,
}

impl PlcField {
    /// Every field, in browse order.
    pub(crate) const ALL: [PlcField; 6] = [
        PlcField::State,
        PlcField::Scans,
        PlcField::Overruns,
        PlcField::CycleP50,
        PlcField::CycleP99,
        PlcField::CycleMax,
    ];

    /// Its browse name.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::State => "State",
            Self::Scans => "Scans",
            Self::Overruns => "Overruns",
            Self::CycleP50 => "CycleP50",
            Self::CycleP99 => "CycleP99",
            Self::CycleMax => "CycleMax",
        }
    }

    fn data_type(self) -> DataTypeId {
        match self {
            Self::State => DataTypeId::String,
            Self::Scans | Self::Overruns => DataTypeId::UInt64,
            _ => DataTypeId::Duration,
        }
    }
}

/// A task's diagnostic variables (a PLC of several tasks).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TaskField {
    /// Its period (Duration).
    Period,
    /// Completed cycles (UInt64).
    Scans,
    /// Overruns (UInt64).
    Overruns,
    /// Cycle time median (Duration).
    CycleP50,
    /// Cycle time 99th percentile (Duration).
    CycleP99,
    /// Longest cycle (Duration).
    CycleMax,
    /// Wake-up lateness 99th percentile (Duration).
    LatenessP99,
    /// Largest wake-up lateness (Duration).
    LatenessMax,
}

impl TaskField {
    /// Every field, in browse order.
    pub(crate) const ALL: [TaskField; 8] = [
        TaskField::Period,
        TaskField::Scans,
        TaskField::Overruns,
        TaskField::CycleP50,
        TaskField::CycleP99,
        TaskField::CycleMax,
        TaskField::LatenessP99,
        TaskField::LatenessMax,
    ];

    /// Its browse name.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::Period => "Period",
            Self::Scans => "Scans",
            Self::Overruns => "Overruns",
            Self::CycleP50 => "CycleP50",
            Self::CycleP99 => "CycleP99",
            Self::CycleMax => "CycleMax",
            Self::LatenessP99 => "LatenessP99",
            Self::LatenessMax => "LatenessMax",
        }
    }

    fn data_type(self) -> DataTypeId {
        match self {
            Self::Scans | Self::Overruns => DataTypeId::UInt64,
            _ => DataTypeId::Duration,
        }
    }

    /// Its value in task report `t`.
    fn value(self, t: &crate::service::status::TaskReport) -> Variant {
        let ms = |us: u64| Variant::Double(us as f64 / 1e3);
        match self {
            Self::Period => ms(t.period_us),
            Self::Scans => Variant::UInt64(t.scans),
            Self::Overruns => Variant::UInt64(t.overruns),
            Self::CycleP50 => ms(t.cycle.p50_us),
            Self::CycleP99 => ms(t.cycle.p99_us),
            Self::CycleMax => ms(t.cycle.max_us),
            Self::LatenessP99 => ms(t.lateness.p99_us),
            Self::LatenessMax => ms(t.lateness.max_us),
        }
    }
}

/// A variable of the address space.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Node {
    /// Its node id (string part).
    pub id: String,
    /// Its browse and display name.
    pub name: String,
    /// The folder it is in (string part of the folder's node id).
    pub folder: String,
    /// Its DataType.
    pub data_type: DataTypeId,
    /// Whether clients may write it (a `scada: write` tag with writes on).
    pub writable: bool,
    /// Its Description attribute: the tag's `description:` (none for diagnostics, whose
    /// names say what they are).
    pub description: Option<String>,
}

/// A folder of the address space.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Folder {
    /// Its node id (string part).
    pub id: String,
    /// Its browse and display name.
    pub name: String,
    /// Its parent folder's id; `None`: the Objects folder.
    pub parent: Option<String>,
    /// Its Description attribute: a module's `description:`.
    pub description: Option<String>,
}

impl Folder {
    fn top(name: &str) -> Self {
        Self {
            id: name.into(),
            name: name.into(),
            parent: None,
            description: None,
        }
    }
}

/// An exposed tag.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TagNode {
    /// Index into the project's tags.
    pub tag: usize,
    /// Its type.
    pub ty: ValueType,
    /// Its node.
    pub node: Node,
}

/// The whole address space of a project.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Layout {
    /// Folders, in creation order (a parent before its children).
    pub folders: Vec<Folder>,
    /// Tags, in project order.
    pub tags: Vec<TagNode>,
    /// Each module's diagnostics, in project order, in [`ModuleField::ALL`] order.
    pub modules: Vec<Vec<Node>>,
    /// The PLC's, in [`PlcField::ALL`] order.
    pub plc: Vec<Node>,
    /// Each task's (a PLC of several tasks), in project order, in [`TaskField::ALL`] order.
    pub tasks: Vec<Vec<Node>>,
    /// Each alarm's variables, in the alarms' order (see `super::alarms`).
    pub alarms: Vec<Vec<Node>>,
}

pub(crate) fn node(folder: &str, name: &str, data_type: DataTypeId) -> Node {
    Node {
        id: format!("{folder}.{name}"),
        name: name.into(),
        folder: folder.into(),
        data_type,
        writable: false,
        description: None,
    }
}

impl Layout {
    /// The address space of `project`; `writes` is the server's switch.
    pub(crate) fn of(project: &Project, writes: bool) -> Self {
        let mut folders = vec![
            Folder::top("Tags"),
            Folder::top("Modules"),
            Folder::top("PLC"),
        ];
        let tags = project
            .service
            .scada
            .entries
            .iter()
            .filter_map(|e| {
                let t = project.tags.get(e.tag)?;
                Some(TagNode {
                    tag: e.tag,
                    ty: t.ty,
                    node: Node {
                        writable: writes && e.writable,
                        description: t.description.as_ref().map(|d| d.to_string()),
                        ..node("Tags", &t.name, data_type(t.ty))
                    },
                })
            })
            .collect::<Vec<_>>();
        let mut tags = tags;
        tags.sort_by_key(|t| t.tag);
        let mut modules = Vec::new();
        for m in &project.modules {
            let folder = format!("Modules.{}", m.name);
            folders.push(Folder {
                id: folder.clone(),
                name: m.name.clone(),
                parent: Some("Modules".into()),
                description: m.description.as_ref().map(|d| d.to_string()),
            });
            modules.push(
                ModuleField::ALL
                    .iter()
                    .map(|f| node(&folder, f.name(), f.data_type()))
                    .collect(),
            );
        }
        let plc = PlcField::ALL
            .iter()
            .map(|f| node("PLC", f.name(), f.data_type()))
            .collect();
        let mut tasks = Vec::new();
        if project.multitask() {
            folders.push(Folder {
                id: "PLC.Tasks".into(),
                name: "Tasks".into(),
                parent: Some("PLC".into()),
                description: None,
            });
            for t in &project.tasks {
                let folder = format!("PLC.Tasks.{}", t.name);
                folders.push(Folder {
                    id: folder.clone(),
                    name: t.name.clone(),
                    parent: Some("PLC.Tasks".into()),
                    description: None,
                });
                tasks.push(
                    TaskField::ALL
                        .iter()
                        .map(|f| node(&folder, f.name(), f.data_type()))
                        .collect(),
                );
            }
        }
        Self {
            folders,
            tags,
            modules,
            plc,
            tasks,
            alarms: Vec::new(),
        }
    }

    /// With the alarms `names` (in the alarms' order) under `Alarms`.
    pub(crate) fn with_alarms(mut self, names: &[String], writes: bool) -> Self {
        let (folders, nodes) = super::alarms::layout(names, writes);
        self.folders.extend(folders);
        self.alarms = nodes;
        self
    }
}

fn ms(d: std::time::Duration) -> Variant {
    Variant::Double(d.as_secs_f64() * 1e3)
}

/// Turns the scan's changes and snapshots into the values of the address space's variables.
#[derive(Debug)]
pub(crate) struct Updates {
    /// Per project tag: its place in [`Layout::tags`], when exposed.
    exposed: Vec<Option<usize>>,
    /// What the diagnostics were last given, per variable id.
    diagnostics: std::collections::HashMap<String, Variant>,
    /// OPC UA ticks (100 ns since 1601) minus scan ticks, fixed at the first call.
    epoch: Option<i64>,
}

impl Updates {
    /// Nothing sent yet.
    pub(crate) fn new(layout: &Layout) -> Self {
        let mut exposed = Vec::new();
        for (i, t) in layout.tags.iter().enumerate() {
            if exposed.len() <= t.tag {
                exposed.resize(t.tag + 1, None);
            }
            exposed[t.tag] = Some(i);
        }
        Self {
            exposed,
            diagnostics: Default::default(),
            epoch: None,
        }
    }

    /// The OPC UA time of scan time `scan`; the first call fixes the relation: `now` is
    /// scan time `reference`.
    fn at(&mut self, now: DateTime, reference: ScanInstant, scan: ScanInstant) -> DateTime {
        let scan_ticks =
            |t: ScanInstant| (t.since_origin().as_nanos() / 100).min(i64::MAX as u128) as i64;
        let epoch = *self
            .epoch
            .get_or_insert_with(|| now.ticks().saturating_sub(scan_ticks(reference)));
        DateTime::from(epoch.saturating_add(scan_ticks(scan)))
    }

    /// The exposed tags one cycle changed (tag, node id string, value), in the order to apply
    /// them, with the cycle's scan time as the source timestamp and `now` as the server's; a
    /// value after changes the server lost carries the Overflow InfoBit (OPC 10000-4 §7.39.1,
    /// as a monitored item's queue does).
    pub(crate) fn tag_changes(
        &mut self,
        layout: &Layout,
        delivery: &Delivery,
        now: DateTime,
    ) -> Vec<(usize, String, DataValue)> {
        let at = delivery.cycle.at;
        let source = self.at(now, at, at);
        delivery
            .all()
            .filter_map(|(c, overflow)| {
                let node = &layout.tags[(*self.exposed.get(c.tag)?)?].node;
                let status = status_of(c.quality);
                Some((
                    c.tag,
                    node.id.clone(),
                    DataValue {
                        value: Some(variant(c.value)),
                        status: Some(if overflow {
                            status.set_overflow(true)
                        } else {
                            status
                        }),
                        source_timestamp: Some(source),
                        server_timestamp: Some(now),
                        ..Default::default()
                    },
                ))
            })
            .collect()
    }

    /// The diagnostic variables (modules, PLC) `snap` changes, with `now` as the server
    /// timestamp.
    pub(crate) fn diagnostics(
        &mut self,
        layout: &Layout,
        snap: &ServiceSnapshot,
        now: DateTime,
    ) -> Vec<(String, DataValue)> {
        let mut out = Vec::new();
        let source = self.at(now, snap.now, snap.now);
        let mut diag = |node: &Node, v: Variant, out: &mut Vec<(String, DataValue)>| {
            if self.diagnostics.get(&node.id) == Some(&v) {
                return;
            }
            self.diagnostics.insert(node.id.clone(), v.clone());
            out.push((
                node.id.clone(),
                DataValue {
                    value: Some(v),
                    status: Some(StatusCode::Good),
                    source_timestamp: Some(source),
                    server_timestamp: Some(now),
                    ..Default::default()
                },
            ));
        };
        for (nodes, m) in layout.modules.iter().zip(&snap.modules) {
            for (n, f) in nodes.iter().zip(ModuleField::ALL) {
                let v = match f {
                    ModuleField::Quality => Variant::from(m.quality.to_string()),
                    ModuleField::Requests => Variant::UInt64(m.counters.requests),
                    ModuleField::Errors => Variant::UInt64(m.counters.errors()),
                    ModuleField::RoundTrip => ms(m.counters.last_round_trip),
                };
                diag(n, v, &mut out);
            }
        }
        let cycle = snap.phases[0];
        for (n, f) in layout.plc.iter().zip(PlcField::ALL) {
            let v = match f {
                PlcField::State => Variant::from(if snap.stopped { "stopped" } else { "running" }),
                PlcField::Scans => Variant::UInt64(snap.cycles),
                PlcField::Overruns => Variant::UInt64(snap.overruns),
                PlcField::CycleP50 => ms(cycle.p50),
                PlcField::CycleP99 => ms(cycle.p99),
                PlcField::CycleMax => ms(cycle.max),
            };
            diag(n, v, &mut out);
        }
        for (nodes, t) in layout.tasks.iter().zip(&snap.tasks) {
            for (n, f) in nodes.iter().zip(TaskField::ALL) {
                diag(n, f.value(t), &mut out);
            }
        }
        out
    }
}

/// The value a variable holds before the first snapshot: zero of its type, waiting.
pub(crate) fn initial(data_type: DataTypeId) -> DataValue {
    let value = match data_type {
        DataTypeId::Boolean => Variant::Boolean(false),
        DataTypeId::UInt16 => Variant::UInt16(0),
        DataTypeId::Int32 => Variant::Int32(0),
        DataTypeId::Float => Variant::Float(0.0),
        DataTypeId::UInt64 => Variant::UInt64(0),
        DataTypeId::String => Variant::from(""),
        DataTypeId::DateTime => Variant::DateTime(Box::new(DateTime::null())),
        _ => Variant::Double(0.0),
    };
    DataValue {
        value: Some(value),
        status: Some(StatusCode::BadWaitingForInitialData),
        server_timestamp: Some(DateTime::now()),
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::changes::{CycleChanges, TagChange};
    use crate::service::snapshot::ModuleSnapshot;
    use std::time::Duration;

    fn layout() -> Layout {
        let tag = |tag: usize, name: &str, ty: ValueType| TagNode {
            tag,
            ty,
            node: node("Tags", name, data_type(ty)),
        };
        Layout {
            folders: vec![],
            tags: vec![
                tag(0, "run", ValueType::Bool),
                tag(2, "speed", ValueType::U16),
            ],
            modules: vec![ModuleField::ALL
                .iter()
                .map(|f| node("Modules.mm1", f.name(), f.data_type()))
                .collect()],
            plc: PlcField::ALL
                .iter()
                .map(|f| node("PLC", f.name(), f.data_type()))
                .collect(),
            tasks: vec![TaskField::ALL
                .iter()
                .map(|f| node("PLC.Tasks.press", f.name(), f.data_type()))
                .collect()],
            alarms: Vec::new(),
        }
    }

    fn snap(cycle: u64) -> ServiceSnapshot {
        ServiceSnapshot {
            published: true,
            cycles: cycle,
            now: ScanInstant::after_origin(Duration::from_millis(10 * cycle)),
            modules: vec![ModuleSnapshot::default()],
            ..ServiceSnapshot::default()
        }
    }

    fn delivery(cycle: u64, changes: &[(usize, Value, Quality)], lost: &[usize]) -> Delivery {
        Delivery {
            cycle: std::sync::Arc::new(CycleChanges {
                task: 0,
                cycle,
                at: ScanInstant::after_origin(Duration::from_millis(10 * cycle)),
                changes: changes
                    .iter()
                    .map(|&(tag, value, quality)| TagChange {
                        tag,
                        value,
                        quality,
                    })
                    .collect(),
                modules: Vec::new(),
            }),
            catch_up: Vec::new(),
            overflowed: lost.to_vec(),
            modules_catch_up: Vec::new(),
        }
    }

    #[test]
    fn each_cycles_changes_go_out_with_their_status_and_scan_time() {
        let l = layout();
        let mut u = Updates::new(&l);
        let t0 = DateTime::from(1_000_000_000_000_000i64);
        let all = [
            (0, Value::Bool(true), Quality::Good),
            (1, Value::I32(3), Quality::Good),
            (2, Value::U16(5), Quality::Good),
        ];
        let first = u.tag_changes(&l, &delivery(1, &all, &[]), t0);
        let ids: Vec<&str> = first.iter().map(|(_, i, _)| i.as_str()).collect();
        assert_eq!(ids, ["Tags.run", "Tags.speed"], "tag 1 is not exposed");
        assert_eq!(first[1].0, 2);
        assert_eq!(first[1].2.value, Some(Variant::UInt16(5)));
        assert_eq!(first[1].2.source_timestamp, Some(t0));
        // The next cycle: speed went stale, 10 ms of scan time later.
        let next = u.tag_changes(
            &l,
            &delivery(2, &[(2, Value::U16(5), Quality::Stale)], &[]),
            t0,
        );
        assert_eq!(next.len(), 1);
        assert_eq!(next[0].2.status, Some(StatusCode::UncertainLastUsableValue));
        assert_eq!(
            next[0].2.source_timestamp.map(|t| t.ticks() - t0.ticks()),
            Some(100_000),
            "10 ms in 100 ns ticks"
        );
        // After lost changes: the Overflow InfoBit on the tag's next value.
        let after = u.tag_changes(
            &l,
            &delivery(5, &[(2, Value::U16(9), Quality::Good)], &[2]),
            t0,
        );
        let status = after[0].2.status.unwrap();
        assert!(status.is_good() && status.overflow(), "{status}");
        assert_eq!(status_of(Quality::Bad), StatusCode::BadCommunicationError);
    }

    #[test]
    fn a_wall_clock_step_moves_no_source_timestamp_off_its_cycles_scan_time() {
        let l = layout();
        let mut u = Updates::new(&l);
        let t0 = DateTime::from(1_000_000_000_000_000i64);
        let hour = 36_000_000_000i64;
        let first = u.tag_changes(
            &l,
            &delivery(1, &[(0, Value::Bool(true), Quality::Good)], &[]),
            t0,
        );
        assert_eq!(first[0].2.source_timestamp, Some(t0));
        // The server's clock steps back an hour (NTP at boot), then a day forward: the
        // server timestamp says so, the source timestamp stays the cycle's scan time.
        for (cycle, now) in [(2, t0.ticks() - hour), (3, t0.ticks() + 24 * hour)] {
            let now = DateTime::from(now);
            let next = u.tag_changes(
                &l,
                &delivery(cycle, &[(0, Value::Bool(cycle == 3), Quality::Good)], &[]),
                now,
            );
            assert_eq!(next[0].2.server_timestamp, Some(now));
            assert_eq!(
                next[0].2.source_timestamp.map(|t| t.ticks() - t0.ticks()),
                Some((cycle as i64 - 1) * 100_000),
                "10 ms a cycle in 100 ns ticks, whatever the wall clock did"
            );
        }
    }

    #[test]
    fn only_changed_diagnostics_go_out() {
        let l = layout();
        let mut u = Updates::new(&l);
        let t0 = DateTime::from(1_000_000_000_000_000i64);
        let first = u.diagnostics(&l, &snap(1), t0);
        let ids: Vec<&str> = first.iter().map(|(i, _)| i.as_str()).collect();
        assert!(ids.contains(&"Modules.mm1.Quality") && ids.contains(&"PLC.Scans"));
        let next = u.diagnostics(&l, &snap(2), t0);
        let ids: Vec<&str> = next.iter().map(|(i, _)| i.as_str()).collect();
        assert_eq!(ids, ["PLC.Scans"]);
    }

    #[test]
    fn each_tasks_figures_go_out_under_its_folder_as_they_change() {
        use crate::service::status::{MicrosPercentiles, TaskReport};
        let l = layout();
        let mut u = Updates::new(&l);
        let t0 = DateTime::from(1_000_000_000_000_000i64);
        let task = |scans: u64| TaskReport {
            name: "press".into(),
            scans,
            overruns: 2,
            period_us: 30_000,
            cycle: MicrosPercentiles {
                p99_us: 1_500,
                ..MicrosPercentiles::default()
            },
            lateness: MicrosPercentiles::default(),
            programs: Vec::new(),
        };
        let at = |out: &[(String, DataValue)], id: &str| {
            out.iter()
                .find(|(i, _)| i == id)
                .and_then(|(_, v)| v.value.clone())
        };
        let first = u.diagnostics(
            &l,
            &ServiceSnapshot {
                tasks: vec![task(10)],
                ..snap(1)
            },
            t0,
        );
        assert_eq!(
            at(&first, "PLC.Tasks.press.Scans"),
            Some(Variant::UInt64(10))
        );
        assert_eq!(
            at(&first, "PLC.Tasks.press.Overruns"),
            Some(Variant::UInt64(2))
        );
        assert_eq!(
            at(&first, "PLC.Tasks.press.Period"),
            Some(Variant::Double(30.0))
        );
        assert_eq!(
            at(&first, "PLC.Tasks.press.CycleP99"),
            Some(Variant::Double(1.5))
        );
        let next = u.diagnostics(
            &l,
            &ServiceSnapshot {
                tasks: vec![task(11)],
                ..snap(1)
            },
            t0,
        );
        let ids: Vec<&str> = next.iter().map(|(i, _)| i.as_str()).collect();
        assert_eq!(ids, ["PLC.Tasks.press.Scans"]);
    }

    #[test]
    fn written_values_must_have_the_tags_exact_type() {
        assert_eq!(
            value_of(ValueType::U16, &Variant::UInt16(7)),
            Some(Value::U16(7))
        );
        assert_eq!(value_of(ValueType::U16, &Variant::Int64(7)), None);
        assert_eq!(value_of(ValueType::F32, &Variant::Double(1.0)), None);
        assert_eq!(variant(Value::I32(-4)), Variant::Int32(-4));
    }
}
