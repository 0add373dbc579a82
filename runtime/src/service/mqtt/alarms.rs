//! The alarms as node metrics under `Alarms/` (see docs/alarms.md): per alarm
//! `Alarms/NAME/Active`, `Acknowledged` (Boolean), `Severity` (UInt16, 1..=1000), `Text`
//! (String), `RaisedAt`, `ClearedAt`, `AckedAt` (DateTime, UTC ms; 0 when none). They are in
//! NBIRTH with their names and aliases (after the PLC's own), and in NDATA, by alias, each
//! time one changes.

use super::payload::MetricSpec;
use super::spb::payload::metric::Value as MetricValue;
use super::spb::DataType;
use crate::service::alarms::{AlarmView, Stamp};

/// Each alarm's metrics, in alias order.
pub(crate) const FIELDS: [(&str, DataType); 7] = [
    ("Active", DataType::Boolean),
    ("Acknowledged", DataType::Boolean),
    ("Severity", DataType::UInt16),
    ("Text", DataType::String),
    ("RaisedAt", DataType::DateTime),
    ("ClearedAt", DataType::DateTime),
    ("AckedAt", DataType::DateTime),
];

/// The metric names of the alarms `names`, in alias order.
pub(crate) fn metric_names(names: &[String]) -> Vec<String> {
    names
        .iter()
        .flat_map(|n| FIELDS.iter().map(move |(f, _)| format!("Alarms/{n}/{f}")))
        .collect()
}

fn ms(stamp: Option<&Stamp>) -> MetricValue {
    let at = stamp
        .and_then(|s| chrono::DateTime::parse_from_rfc3339(&s.utc).ok())
        .map_or(0, |t| u64::try_from(t.timestamp_millis()).unwrap_or(0));
    MetricValue::LongValue(at)
}

/// Every alarm metric's value, in alias order (the alarms in `views`' order).
pub(crate) fn values(views: &[AlarmView]) -> Vec<MetricValue> {
    views
        .iter()
        .flat_map(|a| {
            [
                MetricValue::BooleanValue(a.active),
                MetricValue::BooleanValue(a.acknowledged),
                MetricValue::IntValue(u32::from(a.priority)),
                MetricValue::StringValue(a.text.clone()),
                ms(a.raised.as_ref()),
                ms(a.cleared.as_ref()),
                ms(a.acked.as_ref()),
            ]
        })
        .collect()
}

/// The metric at `k` (in alias order) with `value`: named and typed for a birth, by alias
/// alone for DATA.
pub(crate) fn spec(
    name: Option<&str>,
    alias: u64,
    k: usize,
    value: MetricValue,
    timestamp: u64,
) -> MetricSpec<'_> {
    MetricSpec {
        name,
        alias: Some(alias),
        datatype: name.map(|_| FIELDS[k % FIELDS.len()].1),
        timestamp,
        value,
        quality: None,
        historical: false,
        birth: None,
    }
}
