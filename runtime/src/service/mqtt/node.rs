//! The edge node's state, without I/O: which messages a snapshot turns into (Sparkplug B 3.0,
//! "Operational Behavior" › "Edge Node Session Establishment", "Data Publish" and "Commands").
//!
//! - A birth (a new MQTT session, or a rebirth command) is NBIRTH with seq 0 and every node
//!   metric, then a DBIRTH per live device, each with every metric's name, alias, datatype and
//!   current value, then what the buffer kept while the broker was away.
//! - Every cycle's changes come from the scan's change feed (`crate::service::changes`), in
//!   cycle order; what passes (by exception: a numeric tag beyond its deadband from the value
//!   last sent, any quality change) goes out in one NDATA and one DDATA per device per tick,
//!   where one metric may appear several times, each value with its cycle's timestamp (as
//!   Sparkplug B 3.0 allows, "Payloads" › "Metric"). A module that is lost gets a DDEATH;
//!   when it answers again, a DBIRTH with its current values. Changes the feed could not
//!   queue are counted in `MQTT/Lost changes`.
//! - While the broker is away the same changes go into a bounded buffer instead (the oldest is
//!   dropped and counted in `MQTT/Dropped changes`). Sparkplug forbids sending them before the
//!   new NBIRTH, and a host takes a birth's values as current, so the buffer is sent after the
//!   births, each metric marked `is_historical` with the time it was captured: the host keeps
//!   the history and the births' current values stand.

use std::collections::VecDeque;

use softplc_io::point::{Quality, Value};

use super::layout::{BirthProperties, Layout, PlcMetric, REBIRTH};
use super::payload::{self, bd_seq_metric, datatype, metric_value, MetricSpec};
use super::spb::payload::metric::Value as MetricValue;
use super::spb::DataType;
use crate::service::changes::Delivery;
use crate::service::snapshot::ServiceSnapshot;
use softplc_io::time::ScanInstant;

/// How often the PLC's own metrics (scans, cycle p99, ...) go out in NDATA at most, in ms: they
/// change every scan, and a host trends them, it does not react to them.
pub(crate) const PLC_METRICS_EVERY_MS: u64 = 1000;
/// The most metrics in one DATA message (a long backlog goes out in several).
pub(crate) const DATA_CHUNK: usize = 500;

/// One message to publish.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Outgoing {
    /// Its topic.
    pub topic: String,
    /// The Sparkplug payload.
    pub payload: Vec<u8>,
    /// QoS 1 (NDEATH) rather than 0 (everything else the edge node publishes).
    pub at_least_once: bool,
}

/// The topic namespace of one edge node ("Topics": `spBv1.0/GROUP/VERB/NODE[/DEVICE]`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Topics {
    group: String,
    node: String,
}

impl Topics {
    /// The topics of `node` in `group`.
    pub(crate) fn new(group: &str, node: &str) -> Self {
        Self {
            group: group.into(),
            node: node.into(),
        }
    }

    /// A node topic (`NBIRTH`, `NDEATH`, `NDATA`, `NCMD`).
    pub(crate) fn node(&self, verb: &str) -> String {
        format!("spBv1.0/{}/{verb}/{}", self.group, self.node)
    }

    /// A device topic (`DBIRTH`, `DDEATH`, `DDATA`, `DCMD`).
    pub(crate) fn device(&self, verb: &str, device: &str) -> String {
        format!("spBv1.0/{}/{verb}/{}/{device}", self.group, self.node)
    }

    /// Whom a command topic addresses: `Some(None)` the node (`NCMD`), `Some(Some(device))`
    /// a device (`DCMD`), `None` a topic that is neither.
    pub(crate) fn command_target<'a>(&self, topic: &'a str) -> Option<Option<&'a str>> {
        if topic == self.node("NCMD") {
            return Some(None);
        }
        let prefix = format!("{}/", self.node("DCMD"));
        topic.strip_prefix(&prefix).map(Some)
    }
}

/// A change kept while the broker was away.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Kept {
    tag: usize,
    value: Value,
    quality: Quality,
    timestamp: u64,
}

/// The edge node (see the module docs).
#[derive(Debug)]
pub(crate) struct EdgeNode {
    layout: Layout,
    topics: Topics,
    /// Per tag: the smallest change sent (0: any).
    deadband: Vec<f64>,
    seq: u8,
    /// Per tag: what the host was last told (sent, or kept in the buffer).
    last: Vec<Option<(Value, Quality)>>,
    /// Per device: whether it is born in this session.
    born: Vec<bool>,
    plc_last: Vec<Option<MetricValue>>,
    /// Each task metric as the host was last told (a PLC of several tasks).
    task_last: Vec<Option<MetricValue>>,
    /// Per task (the one task of a PLC of one), the latest cycle whose changes the host was
    /// given or kept for it: its number and its end (see [`Self::scans_of`]).
    delivered: Vec<(u64, ScanInstant)>,
    plc_sent_at: u64,
    buffer: VecDeque<Kept>,
    capacity: usize,
    dropped: u64,
    /// Changes the scan's feed could not queue for this node (see [`Self::set_lost`]).
    lost: u64,
    /// UTC ms minus scan ms, fixed at the first snapshot.
    epoch: Option<i128>,
    /// The alarms, their metrics' names and what the host was last told of each, and the
    /// alarms' generation then (see `super::alarms`).
    alarms: Option<crate::service::alarms::Alarms>,
    alarm_names: Vec<String>,
    alarm_last: Vec<Option<MetricValue>>,
    alarm_generation: Option<u64>,
}

fn changed(old: Value, new: Value, deadband: f64) -> bool {
    let num = |v: Value| match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(u) => f64::from(u),
        Value::I32(i) => f64::from(i),
        Value::F32(f) => f64::from(f),
    };
    if deadband <= 0.0 || matches!(new, Value::Bool(_)) {
        return old != new && !(num(old).is_nan() && num(new).is_nan());
    }
    let (a, b) = (num(old), num(new));
    (a - b).abs() >= deadband || a.is_nan() != b.is_nan()
}

impl EdgeNode {
    /// An edge node for `layout` publishing under `topics`, with a per-tag `deadband` and a
    /// buffer of `capacity` changes.
    pub(crate) fn new(
        layout: Layout,
        topics: Topics,
        deadband: &[(usize, f64)],
        capacity: usize,
    ) -> Self {
        let mut db = vec![0.0; layout.tags.len()];
        for &(tag, d) in deadband {
            if let Some(slot) = db.get_mut(tag) {
                *slot = d;
            }
        }
        Self {
            last: vec![None; layout.tags.len()],
            born: vec![false; layout.devices.len()],
            plc_last: vec![None; PlcMetric::ALL.len()],
            task_last: vec![None; layout.tasks.len()],
            delivered: Vec::new(),
            plc_sent_at: 0,
            deadband: db,
            layout,
            topics,
            seq: 0,
            buffer: VecDeque::new(),
            capacity: capacity.max(1),
            dropped: 0,
            lost: 0,
            epoch: None,
            alarms: None,
            alarm_names: Vec::new(),
            alarm_last: Vec::new(),
            alarm_generation: None,
        }
    }

    /// Publishes `alarms` as node metrics under `Alarms/` (see `super::alarms`).
    pub(crate) fn with_alarms(mut self, alarms: crate::service::alarms::Alarms) -> Self {
        let names: Vec<String> = alarms.all().0.into_iter().map(|v| v.name).collect();
        self.alarm_names = super::alarms::metric_names(&names);
        self.alarm_last = vec![None; self.alarm_names.len()];
        self.alarms = Some(alarms);
        self
    }

    /// The alias of alarm metric `k` (after the PLC's own).
    fn alarm_alias(&self, k: usize) -> u64 {
        self.layout.task_alias(self.layout.tasks.len()) + k as u64
    }

    /// Every task metric's value now and the scan time it is of, in [`Layout::tasks`] order
    /// (0 until a task's figures are published): a task's Scans is [`Self::scans_of`] it,
    /// its other figures are of its last publication.
    fn task_values(&self, snap: &ServiceSnapshot) -> Vec<(MetricValue, ScanInstant)> {
        let fields = super::layout::TASK_FIELDS.len();
        (0..self.layout.tasks.len())
            .map(|j| {
                let (task, field) = (j / fields, j % fields);
                let (v, at) = match field {
                    0 => self.scans_of(snap, task),
                    _ => (
                        snap.tasks
                            .get(task)
                            .map_or(0, |t| super::layout::task_field(t, field)),
                        snap.now_of(task),
                    ),
                };
                (MetricValue::LongValue(v), at)
            })
            .collect()
    }

    /// Task `task`'s scan count as the host sees its tags: the cycle the latest of them come
    /// from, and that cycle's end (the timestamp of the tags it changed). That is the later of
    /// the task's last publication in `snap` and the latest cycle of it delivered: the node
    /// reads the snapshot before it takes the feed, and a publication is skipped while a
    /// reader holds the snapshot, so a count from the snapshot alone may say a cycle before
    /// the tags sent with it, stamped at another task's time.
    fn scans_of(&self, snap: &ServiceSnapshot, task: usize) -> (u64, ScanInstant) {
        let published = (snap.cycles_of(task), snap.now_of(task));
        self.delivered
            .get(task)
            .map_or(published, |&d| d.max(published))
    }

    /// Notes the latest cycle of each task in `changes` (see [`Self::scans_of`]).
    fn note_delivered(&mut self, changes: &[Delivery]) {
        for d in changes {
            let task = d.cycle.task;
            if self.delivered.len() <= task {
                self.delivered.resize(task + 1, (0, ScanInstant::ZERO));
            }
            let latest = &mut self.delivered[task];
            *latest = (*latest).max((d.cycle.cycle, d.cycle.at));
        }
    }

    /// The alarm metrics that changed since the host was told (all of them for a birth), with
    /// their index; what it is told is noted.
    fn alarm_changes(&mut self, birth: bool) -> Vec<(usize, MetricValue)> {
        let Some(a) = &self.alarms else {
            return Vec::new();
        };
        if !birth && self.alarm_generation == Some(a.generation()) {
            return Vec::new();
        }
        let (views, generation) = a.all();
        self.alarm_generation = Some(generation);
        let mut out = Vec::new();
        for (k, v) in super::alarms::values(&views).into_iter().enumerate() {
            if k >= self.alarm_last.len() {
                break;
            }
            if birth || self.alarm_last[k].as_ref() != Some(&v) {
                self.alarm_last[k] = Some(v.clone());
                out.push((k, v));
            }
        }
        out
    }

    /// The topics.
    pub(crate) fn topics(&self) -> &Topics {
        &self.topics
    }

    /// The metric set.
    pub(crate) fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Changes dropped from the buffer so far.
    #[cfg(test)]
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Sets what `MQTT/Lost changes` says: the changes the scan's feed could not queue.
    pub(crate) fn set_lost(&mut self, lost: u64) {
        self.lost = lost;
    }

    /// Changes in the buffer.
    pub(crate) fn buffered(&self) -> usize {
        self.buffer.len()
    }

    fn next_seq(&mut self) -> u8 {
        let s = self.seq;
        self.seq = self.seq.wrapping_add(1);
        s
    }

    fn utc(&mut self, snap: &ServiceSnapshot, wall_ms: u64, scan: ScanInstant) -> u64 {
        let epoch = *self
            .epoch
            .get_or_insert(i128::from(wall_ms) - snap.now.since_origin().as_millis() as i128);
        (epoch + scan.since_origin().as_millis() as i128).clamp(0, u64::MAX as i128) as u64
    }

    fn alive(snap: &ServiceSnapshot, device: usize) -> bool {
        // Module qualities come with the statistics; before their first refresh, alive.
        snap.modules
            .get(device)
            .is_none_or(|m| m.quality != Quality::Bad)
    }

    fn tag_now(snap: &ServiceSnapshot, tag: usize) -> Option<(Value, Quality)> {
        Some((*snap.values.get(tag)?, *snap.qualities.get(tag)?))
    }

    fn tag_spec(
        &mut self,
        snap: &ServiceSnapshot,
        wall_ms: u64,
        tag: usize,
        birth: bool,
    ) -> Option<MetricSpec<'static>> {
        let (value, quality) = Self::tag_now(snap, tag)?;
        let at = snap.timestamps.get(tag).copied().unwrap_or(snap.now);
        let timestamp = self.utc(snap, wall_ms, at);
        self.last[tag] = Some((value, quality));
        let t = &self.layout.tags[tag];
        Some(MetricSpec {
            name: None,
            alias: Some(t.alias),
            datatype: birth.then(|| datatype(t.ty)),
            timestamp,
            value: metric_value(value),
            quality: Some(quality),
            historical: false,
            birth: None,
        })
    }

    /// The PLC's metrics now, each with the scan time it is of: `PLC/Scans` is the first
    /// task's count as [`Self::scans_of`] says it, the others are of the last publication.
    fn plc_values(
        &self,
        snap: &ServiceSnapshot,
    ) -> Vec<(PlcMetric, DataType, MetricValue, ScanInstant)> {
        let (scans, scans_at) = self.scans_of(snap, 0);
        PlcMetric::ALL
            .iter()
            .map(|&m| match m {
                PlcMetric::Scans => (m, DataType::UInt64, MetricValue::LongValue(scans)),
                PlcMetric::Overruns => (m, DataType::UInt64, MetricValue::LongValue(snap.overruns)),
                PlcMetric::CycleP99 => (
                    m,
                    DataType::UInt64,
                    MetricValue::LongValue(snap.phases[0].p99.as_micros() as u64),
                ),
                PlcMetric::State => (
                    m,
                    DataType::String,
                    MetricValue::StringValue(
                        if snap.stopped { "stopped" } else { "running" }.into(),
                    ),
                ),
                PlcMetric::Dropped => (m, DataType::UInt64, MetricValue::LongValue(self.dropped)),
                PlcMetric::Lost => (m, DataType::UInt64, MetricValue::LongValue(self.lost)),
            })
            .map(|(m, dt, v)| {
                let at = if m == PlcMetric::Scans {
                    scans_at
                } else {
                    snap.now
                };
                (m, dt, v, at)
            })
            .collect()
    }

    /// Births for a new session or a rebirth: NBIRTH (seq 0, carrying `bd_seq`), a DBIRTH per
    /// live device, then the buffer as historical DATA.
    pub(crate) fn birth(
        &mut self,
        snap: &ServiceSnapshot,
        wall_ms: u64,
        bd_seq: u8,
    ) -> Vec<Outgoing> {
        self.seq = 0;
        let now = self.utc(snap, wall_ms, snap.now);
        let mut out = Vec::new();
        let mut metrics = vec![
            bd_seq_metric(bd_seq, now),
            MetricSpec {
                name: Some(REBIRTH),
                alias: None,
                datatype: Some(DataType::Boolean),
                timestamp: now,
                value: MetricValue::BooleanValue(false),
                quality: None,
                historical: false,
                birth: None,
            },
        ];
        // The PLC's and the tasks' figures, each stamped with the scan time it is of: a
        // task's Scans with its cycle's end, as the tags that cycle changed.
        let plc = self.plc_values(snap);
        for (m, dt, v, at) in &plc {
            let timestamp = self.utc(snap, wall_ms, *at);
            metrics.push(MetricSpec {
                name: Some(m.name()),
                datatype: Some(*dt),
                ..node_data(self.layout.plc_alias(*m), v.clone(), timestamp)
            });
        }
        self.plc_last = plc.into_iter().map(|(_, _, v, _)| Some(v)).collect();
        self.plc_sent_at = wall_ms;
        let tasks = self.task_values(snap);
        let task_names = self.layout.tasks.clone();
        for (j, (v, at)) in tasks.iter().enumerate() {
            let timestamp = self.utc(snap, wall_ms, *at);
            metrics.push(MetricSpec {
                name: task_names.get(j).map(String::as_str),
                datatype: Some(DataType::UInt64),
                ..node_data(self.layout.task_alias(j), v.clone(), timestamp)
            });
        }
        self.task_last = tasks.into_iter().map(|(v, _)| Some(v)).collect();
        let alarm_values: Vec<(usize, u64, MetricValue)> = self
            .alarm_changes(true)
            .into_iter()
            .map(|(k, v)| (k, self.alarm_alias(k), v))
            .collect();
        let alarm_names = self.alarm_names.clone();
        for (k, alias, v) in alarm_values {
            metrics.push(super::alarms::spec(
                alarm_names.get(k).map(String::as_str),
                alias,
                k,
                v,
                now,
            ));
        }
        let node_tags: Vec<usize> = self.layout.tags_of(None).map(|t| t.tag).collect();
        let names: Vec<String> = self.layout.tags.iter().map(|t| t.name.clone()).collect();
        let births: Vec<BirthProperties> =
            self.layout.tags.iter().map(|t| t.birth.clone()).collect();
        let tag_specs: Vec<(usize, MetricSpec<'static>)> = node_tags
            .iter()
            .filter_map(|&t| Some((t, self.tag_spec(snap, wall_ms, t, true)?)))
            .collect();
        let mut all: Vec<MetricSpec<'_>> = metrics;
        for (t, spec) in &tag_specs {
            all.push(MetricSpec {
                name: Some(names[*t].as_str()),
                birth: Some(&births[*t]),
                ..spec.clone()
            });
        }
        let seq = self.next_seq();
        out.push(Outgoing {
            topic: self.topics.node("NBIRTH"),
            payload: payload::encode(now, Some(seq), &all),
            at_least_once: false,
        });
        for d in 0..self.layout.devices.len() {
            self.born[d] = false;
            if Self::alive(snap, d) {
                out.push(self.device_birth(snap, wall_ms, d));
            }
        }
        out.extend(self.flush_buffer(wall_ms));
        out
    }

    fn device_birth(&mut self, snap: &ServiceSnapshot, wall_ms: u64, device: usize) -> Outgoing {
        let tags: Vec<usize> = self.layout.tags_of(Some(device)).map(|t| t.tag).collect();
        let specs: Vec<(usize, MetricSpec<'static>)> = tags
            .iter()
            .filter_map(|&t| Some((t, self.tag_spec(snap, wall_ms, t, true)?)))
            .collect();
        let now = self.utc(snap, wall_ms, snap.now);
        let metrics: Vec<MetricSpec<'_>> = specs
            .iter()
            .map(|(t, s)| MetricSpec {
                name: Some(self.layout.tags[*t].name.as_str()),
                birth: Some(&self.layout.tags[*t].birth),
                ..s.clone()
            })
            .collect();
        let payload = payload::encode(now, Some(self.seq), &metrics);
        self.next_seq();
        self.born[device] = true;
        Outgoing {
            topic: self.topics.device("DBIRTH", &self.layout.devices[device]),
            payload,
            at_least_once: false,
        }
    }

    fn flush_buffer(&mut self, wall_ms: u64) -> Vec<Outgoing> {
        let kept: Vec<Kept> = self.buffer.drain(..).collect();
        let mut out = Vec::new();
        for device in std::iter::once(None).chain((0..self.layout.devices.len()).map(Some)) {
            if device.is_some_and(|d| !self.born[d]) {
                continue;
            }
            let mine: Vec<&Kept> = kept
                .iter()
                .filter(|k| self.layout.tags[k.tag].device == device)
                .collect();
            for chunk in mine.chunks(DATA_CHUNK) {
                let metrics: Vec<MetricSpec<'_>> = chunk
                    .iter()
                    .map(|k| MetricSpec {
                        name: None,
                        alias: Some(self.layout.tags[k.tag].alias),
                        datatype: None,
                        timestamp: k.timestamp,
                        value: metric_value(k.value),
                        quality: Some(k.quality),
                        historical: true,
                        birth: None,
                    })
                    .collect();
                out.push(self.data_message(device, wall_ms, &metrics));
            }
        }
        out
    }

    fn data_message(
        &mut self,
        device: Option<usize>,
        wall_ms: u64,
        metrics: &[MetricSpec<'_>],
    ) -> Outgoing {
        let seq = self.next_seq();
        Outgoing {
            topic: match device {
                None => self.topics.node("NDATA"),
                Some(d) => self.topics.device("DDATA", &self.layout.devices[d]),
            },
            payload: payload::encode(wall_ms, Some(seq), metrics),
            at_least_once: false,
        }
    }

    /// Keeps `changes` in the buffer, as history for after the next births.
    pub(crate) fn keep(&mut self, snap: &ServiceSnapshot, changes: &[Delivery], wall_ms: u64) {
        self.take_changes(snap, changes, wall_ms, false);
    }

    /// The tag changes of `changes` that pass the deadband: per slot (0 the node, d + 1
    /// device d), the metrics to send (`online`), or kept in the buffer (not `online`).
    fn take_changes(
        &mut self,
        snap: &ServiceSnapshot,
        changes: &[Delivery],
        wall_ms: u64,
        online: bool,
    ) -> Vec<Vec<MetricSpec<'static>>> {
        self.note_delivered(changes);
        let mut out: Vec<Vec<MetricSpec<'static>>> =
            vec![Vec::new(); self.layout.devices.len() + 1];
        for d in changes {
            let timestamp = self.utc(snap, wall_ms, d.cycle.at);
            for (c, _) in d.all() {
                let Some(t) = self.layout.tags.get(c.tag) else {
                    continue;
                };
                let (device, alias) = (t.device, t.alias);
                // A device not born in this session gets its values in its DBIRTH.
                if online && device.is_some_and(|d| !self.born[d]) {
                    continue;
                }
                let due = match self.last[c.tag] {
                    None => true,
                    Some((v, q)) => q != c.quality || changed(v, c.value, self.deadband[c.tag]),
                };
                if !due {
                    continue;
                }
                self.last[c.tag] = Some((c.value, c.quality));
                if online {
                    out[device.map_or(0, |d| d + 1)].push(MetricSpec {
                        name: None,
                        alias: Some(alias),
                        datatype: None,
                        timestamp,
                        value: metric_value(c.value),
                        quality: Some(c.quality),
                        historical: false,
                        birth: None,
                    });
                } else {
                    if self.buffer.len() >= self.capacity {
                        self.buffer.pop_front();
                        self.dropped += 1;
                    }
                    self.buffer.push_back(Kept {
                        tag: c.tag,
                        value: c.value,
                        quality: c.quality,
                        timestamp,
                    });
                }
            }
        }
        out
    }

    /// The cycles' `changes` as NDATA/DDATA, with DDEATH/DBIRTH for modules lost or back
    /// (`online`), or kept in the buffer (not `online`: nothing is returned).
    pub(crate) fn update(
        &mut self,
        snap: &ServiceSnapshot,
        changes: &[Delivery],
        wall_ms: u64,
        online: bool,
    ) -> Vec<Outgoing> {
        let mut out = Vec::new();
        if online {
            for d in 0..self.layout.devices.len() {
                let alive = Self::alive(snap, d);
                if self.born[d] && !alive {
                    let now = self.utc(snap, wall_ms, snap.now);
                    let seq = self.next_seq();
                    out.push(Outgoing {
                        topic: self.topics.device("DDEATH", &self.layout.devices[d]),
                        payload: payload::encode(now, Some(seq), &[]),
                        at_least_once: false,
                    });
                    self.born[d] = false;
                } else if !self.born[d] && alive {
                    out.push(self.device_birth(snap, wall_ms, d));
                }
            }
        }
        let mut changes = self.take_changes(snap, changes, wall_ms, online);
        if !online {
            return out;
        }
        let plc_due =
            snap.stopped || wall_ms.saturating_sub(self.plc_sent_at) >= PLC_METRICS_EVERY_MS;
        if plc_due {
            // After the tags: each count is the cycle the latest tags sent come from, with
            // that cycle's end as its timestamp.
            for (i, (m, _, v, at)) in self.plc_values(snap).into_iter().enumerate() {
                if self.plc_last[i].as_ref() != Some(&v) {
                    let at = self.utc(snap, wall_ms, at);
                    changes[0].push(node_data(self.layout.plc_alias(m), v.clone(), at));
                    self.plc_last[i] = Some(v);
                }
            }
            for (j, (v, at)) in self.task_values(snap).into_iter().enumerate() {
                if self
                    .task_last
                    .get(j)
                    .is_some_and(|last| last.as_ref() != Some(&v))
                {
                    let at = self.utc(snap, wall_ms, at);
                    changes[0].push(node_data(self.layout.task_alias(j), v.clone(), at));
                    self.task_last[j] = Some(v);
                }
            }
            self.plc_sent_at = wall_ms;
        }
        let now = self.utc(snap, wall_ms, snap.now);
        for (k, v) in self.alarm_changes(false) {
            let alias = self.alarm_alias(k);
            changes[0].push(super::alarms::spec(None, alias, k, v, now));
        }
        for (slot, metrics) in changes.iter().enumerate() {
            let device = slot.checked_sub(1);
            for chunk in metrics.chunks(DATA_CHUNK) {
                out.push(self.data_message(device, wall_ms, chunk));
            }
        }
        out
    }
}

#[cfg(test)]
#[path = "node_tests.rs"]
mod tests;

/// A node metric in DATA: by alias alone, no quality (the PLC's and the tasks' figures).
fn node_data(alias: u64, value: MetricValue, timestamp: u64) -> MetricSpec<'static> {
    MetricSpec {
        name: None,
        alias: Some(alias),
        datatype: None,
        timestamp,
        value,
        quality: None,
        historical: false,
        birth: None,
    }
}
