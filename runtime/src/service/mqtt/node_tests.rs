//! The edge node without a broker: which messages snapshots turn into.

use std::time::Duration;

use prost::Message;
use softplc_io::point::{Quality, Value, ValueType};

use super::*;
use crate::service::changes::{CycleChanges, TagChange};
use crate::service::mqtt::layout::{BirthProperties, TagMetric};
use crate::service::mqtt::spb::Payload;
use crate::service::snapshot::ModuleSnapshot;

fn layout() -> Layout {
    let tag = |tag: usize, name: &str, ty, device| TagMetric {
        tag,
        name: name.into(),
        ty,
        alias: tag as u64 + 1,
        device,
        birth: BirthProperties::default(),
    };
    let level = TagMetric {
        birth: BirthProperties {
            description: None,
            unit: Some("m".into()),
            range: Some((0.0, 4.5)),
        },
        ..tag(0, "level", ValueType::F32, Some(0))
    };
    Layout {
        tags: vec![
            level,
            tag(1, "pump", ValueType::Bool, Some(0)),
            tag(2, "setpoint", ValueType::U16, None),
        ],
        devices: vec!["mm1".into()],
        tasks: Vec::new(),
    }
}

fn snap(level: f32, pump: bool, setpoint: u16, module: Quality) -> ServiceSnapshot {
    ServiceSnapshot {
        published: true,
        cycles: 10,
        now: ScanInstant::after_origin(Duration::from_millis(500)),
        values: vec![Value::F32(level), Value::Bool(pump), Value::U16(setpoint)],
        qualities: vec![Quality::Good; 3],
        timestamps: vec![ScanInstant::after_origin(Duration::from_millis(400)); 3],
        forced: vec![false; 3],
        modules: vec![ModuleSnapshot {
            quality: module,
            ..ModuleSnapshot::default()
        }],
        ..ServiceSnapshot::default()
    }
}

/// What a cycle changed against `before`, as the scan's feed hands it over (at scan 450 ms).
fn changed_from(before: &ServiceSnapshot, after: &ServiceSnapshot) -> Vec<Delivery> {
    let changes: Vec<TagChange> = (0..after.values.len())
        .filter(|&t| {
            (before.values[t], before.qualities[t]) != (after.values[t], after.qualities[t])
        })
        .map(|tag| TagChange {
            tag,
            value: after.values[tag],
            quality: after.qualities[tag],
        })
        .collect();
    vec![Delivery {
        cycle: std::sync::Arc::new(CycleChanges {
            task: 0,
            cycle: after.cycles,
            at: ScanInstant::after_origin(Duration::from_millis(450)),
            changes,
            modules: Vec::new(),
        }),
        catch_up: Vec::new(),
        overflowed: Vec::new(),
        modules_catch_up: Vec::new(),
    }]
}

/// The node's update from `before` to `after`.
fn step(
    n: &mut EdgeNode,
    before: &ServiceSnapshot,
    after: &ServiceSnapshot,
    wall_ms: u64,
    online: bool,
) -> Vec<Outgoing> {
    n.update(after, &changed_from(before, after), wall_ms, online)
}

fn node(capacity: usize) -> EdgeNode {
    EdgeNode::new(layout(), Topics::new("g", "n"), &[(0, 0.5)], capacity)
}

fn decoded(m: &Outgoing) -> Payload {
    Payload::decode(m.payload.as_slice()).unwrap()
}

/// One metric: alias, value (debug-printed), historical.
type Seen = (Option<u64>, String, bool);

/// (topic, seq, metrics) of each message.
fn summary(out: &[Outgoing]) -> Vec<(String, Option<u64>, Vec<Seen>)> {
    out.iter()
        .map(|m| {
            let p = decoded(m);
            let metrics = p
                .metrics
                .iter()
                .map(|x| {
                    (
                        x.alias,
                        format!("{:?}", x.value.as_ref().unwrap()),
                        x.is_historical == Some(true),
                    )
                })
                .collect();
            (m.topic.clone(), p.seq, metrics)
        })
        .collect()
}

#[test]
fn a_birth_declares_everything_then_data_carries_only_changes_beyond_the_deadband() {
    let mut n = node(10);
    let birth = n.birth(&snap(1.0, false, 5, Quality::Good), 1_000_000, 4);
    let s = summary(&birth);
    assert_eq!(s.len(), 2);
    assert_eq!((s[0].0.as_str(), s[0].1), ("spBv1.0/g/NBIRTH/n", Some(0)));
    assert_eq!(
        (s[1].0.as_str(), s[1].1),
        ("spBv1.0/g/DBIRTH/n/mm1", Some(1))
    );
    let nb = decoded(&birth[0]);
    assert_eq!(nb.metrics[0].name.as_deref(), Some("bdSeq"));
    assert_eq!(
        nb.metrics[0].value,
        Some(crate::service::mqtt::spb::payload::metric::Value::LongValue(4))
    );
    let db = decoded(&birth[1]);
    let names: Vec<_> = db.metrics.iter().map(|m| m.name.clone().unwrap()).collect();
    assert_eq!(names, ["level", "pump"]);
    // The tag's timestamp: its capture time, scan 400 ms = 100 ms before the snapshot's.
    assert_eq!(db.metrics[0].timestamp, Some(1_000_000 - 100));

    // 0.3 is within level's deadband of 0.5: nothing; the pump changes: one DDATA, by alias.
    let s0 = snap(1.0, false, 5, Quality::Good);
    let s1 = snap(1.3, true, 5, Quality::Good);
    let out = step(&mut n, &s0, &s1, 1_000_050, true);
    let s = summary(&out);
    assert_eq!(s.len(), 1);
    assert_eq!(s[0].0, "spBv1.0/g/DDATA/n/mm1");
    assert_eq!(s[0].1, Some(2));
    assert_eq!(s[0].2, [(Some(2), "BooleanValue(true)".into(), false)]);
    assert_eq!(decoded(&out[0]).metrics[0].name, None);
    // 1.6 is 0.6 from the 1.0 last sent: out; the setpoint goes in NDATA.
    let s2 = snap(1.6, true, 6, Quality::Good);
    let s = summary(&step(&mut n, &s1, &s2, 1_000_100, true));
    assert_eq!(s.len(), 2);
    assert_eq!(s[0].0, "spBv1.0/g/NDATA/n");
    assert_eq!(s[0].2, [(Some(3), "IntValue(6)".into(), false)]);
    assert_eq!(s[1].2, [(Some(1), "FloatValue(1.6)".into(), false)]);
    assert_eq!((s[0].1, s[1].1), (Some(3), Some(4)));
    // Nothing changed: nothing sent.
    assert!(step(&mut n, &s2, &s2, 1_000_150, true).is_empty());
}

#[test]
fn a_lost_module_dies_and_is_born_again_when_it_answers() {
    let mut n = node(10);
    let s0 = snap(1.0, false, 5, Quality::Good);
    n.birth(&s0, 0, 0);
    let s1 = snap(1.0, false, 5, Quality::Bad);
    let s = summary(&step(&mut n, &s0, &s1, 50, true));
    assert_eq!(s.len(), 1);
    assert_eq!(s[0].0, "spBv1.0/g/DDEATH/n/mm1");
    // Its tags are not sent while it is dead.
    let s2 = snap(9.0, true, 5, Quality::Bad);
    assert!(step(&mut n, &s1, &s2, 100, true).is_empty());
    let s3 = snap(9.0, true, 5, Quality::Good);
    let s = summary(&step(&mut n, &s2, &s3, 150, true));
    assert_eq!(s.len(), 1);
    assert_eq!(s[0].0, "spBv1.0/g/DBIRTH/n/mm1");
    assert_eq!(
        s[0].2,
        [
            (Some(1), "FloatValue(9.0)".into(), false),
            (Some(2), "BooleanValue(true)".into(), false)
        ]
    );
}

#[test]
fn changes_while_offline_are_buffered_oldest_dropped_and_sent_as_history_after_the_births() {
    let mut n = node(2);
    let s0 = snap(1.0, false, 5, Quality::Good);
    n.birth(&s0, 0, 0);
    // Broker away: three changes, room for two.
    let s1 = snap(1.0, true, 5, Quality::Good);
    let s2 = snap(1.0, false, 5, Quality::Good);
    let s3 = snap(1.0, false, 7, Quality::Good);
    assert!(step(&mut n, &s0, &s1, 50, false).is_empty());
    assert!(step(&mut n, &s1, &s2, 100, false).is_empty());
    assert!(step(&mut n, &s2, &s3, 150, false).is_empty());
    assert_eq!((n.buffered(), n.dropped()), (2, 1));
    // Back: births with the current values, then the history (node first, then the device).
    let out = n.birth(&snap(1.0, false, 7, Quality::Good), 200, 1);
    let s = summary(&out);
    let topics: Vec<&str> = s.iter().map(|m| m.0.as_str()).collect();
    assert_eq!(
        topics,
        [
            "spBv1.0/g/NBIRTH/n",
            "spBv1.0/g/DBIRTH/n/mm1",
            "spBv1.0/g/NDATA/n",
            "spBv1.0/g/DDATA/n/mm1"
        ]
    );
    let seqs: Vec<_> = s.iter().map(|m| m.1).collect();
    assert_eq!(seqs, [Some(0), Some(1), Some(2), Some(3)]);
    assert_eq!(s[2].2, [(Some(3), "IntValue(7)".into(), true)]);
    assert_eq!(s[3].2, [(Some(2), "BooleanValue(false)".into(), true)]);
    // The NBIRTH counts the dropped change.
    let nb = decoded(&out[0]);
    let dropped = nb
        .metrics
        .iter()
        .find(|m| m.name.as_deref() == Some("MQTT/Dropped changes"))
        .unwrap();
    assert_eq!(
        dropped.value,
        Some(crate::service::mqtt::spb::payload::metric::Value::LongValue(1))
    );
    assert_eq!(n.buffered(), 0);
}

/// Tick `k` after the snapshot's cycle 10: cycle 11 + k at scan 510 + 10 k ms, where the
/// setpoint (tag 2) became 6 + k.
fn setpoint_tick(k: u16) -> Delivery {
    Delivery {
        cycle: std::sync::Arc::new(CycleChanges {
            task: 0,
            cycle: 11 + u64::from(k),
            at: ScanInstant::after_origin(Duration::from_millis(510 + 10 * u64::from(k))),
            changes: vec![TagChange {
                tag: 2,
                value: Value::U16(6 + k),
                quality: Quality::Good,
            }],
            modules: Vec::new(),
        }),
        catch_up: Vec::new(),
        overflowed: Vec::new(),
        modules_catch_up: Vec::new(),
    }
}

#[test]
fn every_value_of_a_metric_goes_out_in_order_each_with_its_cycles_time_and_losses_are_counted() {
    let mut n = node(10);
    let s0 = snap(1.0, false, 5, Quality::Good);
    n.birth(&s0, 1_000_000, 0);
    // Three cycles of one tick: the setpoint 6, 7, 8, at 10 ms apart.
    let cycles: Vec<Delivery> = (0..3u16).map(setpoint_tick).collect();
    let out = n.update(&s0, &cycles, 1_000_050, true);
    let s = summary(&out);
    assert_eq!(s.len(), 1, "one NDATA: {s:?}");
    assert_eq!(
        s[0].2,
        [
            (Some(3), "IntValue(6)".into(), false),
            (Some(3), "IntValue(7)".into(), false),
            (Some(3), "IntValue(8)".into(), false)
        ]
    );
    let stamps: Vec<_> = decoded(&out[0])
        .metrics
        .iter()
        .map(|m| m.timestamp)
        .collect();
    // Scan 500 ms was wall 1_000_000 at the birth.
    assert_eq!(stamps, [Some(1_000_010), Some(1_000_020), Some(1_000_030)]);
    // The feed lost changes: the next PLC figures say so.
    n.set_lost(4);
    let out = n.update(&s0, &[], 1_002_000, true);
    let lost = decoded(&out[0])
        .metrics
        .iter()
        .find(|m| m.alias == Some(n.layout().plc_alias(PlcMetric::Lost)))
        .and_then(|m| m.value.clone());
    assert_eq!(
        lost,
        Some(crate::service::mqtt::spb::payload::metric::Value::LongValue(4))
    );
}

#[test]
fn births_carry_a_profile_points_engineering_unit_and_range_and_data_does_not() {
    let mut n = node(10);
    let s0 = snap(1.0, false, 5, Quality::Good);
    let birth = n.birth(&s0, 1_000_000, 0);
    let db = decoded(&birth[1]);
    let props = |m: &crate::service::mqtt::spb::payload::Metric| {
        let p = m.properties.clone().unwrap_or_default();
        p.keys
            .iter()
            .zip(&p.values)
            .map(|(k, v)| format!("{k}={:?}", v.value.as_ref().unwrap()))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        props(&db.metrics[0]),
        [
            "Quality=IntValue(192)",
            "engUnit=StringValue(\"m\")",
            "engLow=DoubleValue(0.0)",
            "engHigh=DoubleValue(4.5)"
        ]
    );
    assert_eq!(props(&db.metrics[1]), ["Quality=IntValue(192)"], "no unit");
    let s1 = snap(2.0, false, 5, Quality::Good);
    let data = step(&mut n, &s0, &s1, 1_000_050, true);
    assert_eq!(
        props(&decoded(&data[0]).metrics[0]),
        ["Quality=IntValue(192)"]
    );
}

#[test]
fn command_topics_name_the_node_or_a_device() {
    let t = Topics::new("g", "n");
    assert_eq!(t.command_target("spBv1.0/g/NCMD/n"), Some(None));
    assert_eq!(t.command_target("spBv1.0/g/DCMD/n/mm1"), Some(Some("mm1")));
    assert_eq!(t.command_target("spBv1.0/g/DCMD/other/mm1"), None);
    assert_eq!(t.command_target("spBv1.0/g/NDATA/n"), None);
}

#[test]
fn a_wall_clock_step_moves_no_value_off_its_cycles_time() {
    let mut n = node(10);
    let s0 = snap(1.0, false, 5, Quality::Good);
    // Scan 500 ms is wall `wall` at the birth; then the wall clock steps back an hour (NTP
    // at boot) and a day forward: each value keeps its cycle's scan time on that one origin.
    let wall = 1_800_000_000_000;
    n.birth(&s0, wall, 0);
    for (k, stepped) in [(0u16, wall - 3_600_000), (1, wall + 86_400_000)] {
        let at = 510 + 10 * u64::from(k);
        let out = n.update(&s0, &[setpoint_tick(k)], stepped, true);
        let stamps: Vec<_> = decoded(&out[0])
            .metrics
            .iter()
            .map(|m| m.timestamp)
            .collect();
        // A day forward makes the PLC's figures due: `PLC/Scans` goes with the setpoint, the
        // count of the same cycle, at the same time.
        let expected = vec![Some(wall + at - 500); 1 + usize::from(k)];
        assert_eq!(stamps, expected, "wall stepped to {stepped}");
    }
}

#[test]
fn plc_scans_is_the_cycle_the_tags_sent_come_from_stamped_at_its_end() {
    let mut n = node(10);
    // The snapshot says cycle 10 (at 500 ms) for the birth, and still does a second later:
    // the cycles 11 to 13 came through the feed after it was read.
    let s0 = snap(1.0, false, 5, Quality::Good);
    n.birth(&s0, 1_000_000, 0);
    let cycles: Vec<Delivery> = (0..3u16).map(setpoint_tick).collect();
    let out = n.update(&s0, &cycles, 1_001_000, true);
    let metrics = decoded(&out[0]).metrics;
    let setpoint = metrics.iter().rfind(|m| m.alias == Some(3)).unwrap();
    let scans = metrics
        .iter()
        .find(|m| m.alias == Some(n.layout().plc_alias(PlcMetric::Scans)))
        .unwrap();
    assert_eq!(scans.value, Some(MetricValue::LongValue(13)), "{metrics:?}");
    assert_eq!(
        setpoint.value,
        Some(MetricValue::IntValue(8)),
        "{metrics:?}"
    );
    // Cycle 13 ended at scan 530 ms: wall 1_000_030, for the count and the setpoint alike.
    assert_eq!(scans.timestamp, Some(1_000_030));
    assert_eq!(setpoint.timestamp, scans.timestamp);
    // A snapshot that caught up says the same: nothing new to send.
    let s1 = ServiceSnapshot {
        cycles: 13,
        now: ScanInstant::after_origin(Duration::from_millis(530)),
        ..s0
    };
    assert!(n.update(&s1, &[], 1_002_000, true).is_empty());
}
