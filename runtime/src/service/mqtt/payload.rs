//! Sparkplug B payloads (Sparkplug B 3.0, "Payloads"): typed PLC values to protobuf metrics and
//! back, the quality property, and the NDEATH payload.

use prost::Message;
use softplc_io::point::{Quality, Value, ValueType};

use super::layout::BirthProperties;
use super::spb::payload::metric::Value as MetricValue;
use super::spb::payload::property_value::Value as PropValue;
use super::spb::payload::{Metric, PropertySet, PropertyValue};
use super::spb::{DataType, Payload};

/// The Sparkplug datatype of a PLC type ("Datatype Details": Boolean, UInt16, Int32, Float).
pub(crate) fn datatype(ty: ValueType) -> DataType {
    match ty {
        ValueType::Bool => DataType::Boolean,
        ValueType::U16 => DataType::UInt16,
        ValueType::I32 => DataType::Int32,
        ValueType::F32 => DataType::Float,
    }
}

/// A PLC value as a metric value. Int32 travels as its two's complement in `int_value`, as
/// Eclipse Tahu's encoder writes it.
pub(crate) fn metric_value(v: Value) -> MetricValue {
    match v {
        Value::Bool(b) => MetricValue::BooleanValue(b),
        Value::U16(u) => MetricValue::IntValue(u32::from(u)),
        Value::I32(i) => MetricValue::IntValue(i as u32),
        Value::F32(f) => MetricValue::FloatValue(f),
    }
}

/// Why a command's value cannot be a tag's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum ValueError {
    /// No value in the metric.
    #[error("the metric carries no value")]
    Missing,
    /// A value of another kind.
    #[error("a {ty} tag cannot take that kind of value")]
    WrongKind {
        /// The tag's type.
        ty: ValueType,
    },
    /// Outside the tag's range.
    #[error("the value is outside the range of a {ty} tag")]
    OutOfRange {
        /// The tag's type.
        ty: ValueType,
    },
}

/// A command's metric value as a value of type `ty`. Integers are accepted from any integer
/// field that holds them exactly (hosts differ in which one they fill); floats from float or
/// double.
pub(crate) fn tag_value(ty: ValueType, v: Option<&MetricValue>) -> Result<Value, ValueError> {
    let v = v.ok_or(ValueError::Missing)?;
    let wrong = ValueError::WrongKind { ty };
    let range = ValueError::OutOfRange { ty };
    Ok(match (ty, v) {
        (ValueType::Bool, MetricValue::BooleanValue(b)) => Value::Bool(*b),
        (ValueType::U16, MetricValue::IntValue(u)) => {
            Value::U16(u16::try_from(*u).map_err(|_| range)?)
        }
        (ValueType::U16, MetricValue::LongValue(u)) => {
            Value::U16(u16::try_from(*u).map_err(|_| range)?)
        }
        (ValueType::I32, MetricValue::IntValue(u)) => Value::I32(*u as i32),
        (ValueType::I32, MetricValue::LongValue(u)) => {
            Value::I32(i32::try_from(*u as i64).map_err(|_| range)?)
        }
        (ValueType::F32, MetricValue::FloatValue(f)) => Value::F32(*f),
        (ValueType::F32, MetricValue::DoubleValue(d)) => {
            let f = *d as f32;
            if d.is_finite() && !f.is_finite() {
                return Err(range);
            }
            Value::F32(f)
        }
        _ => return Err(wrong),
    })
}

/// The Sparkplug quality code of a PLC quality ("Quality Codes": 0 bad, 192 good, 500 stale).
pub(crate) fn quality_code(q: Quality) -> i32 {
    match q {
        Quality::Good => 192,
        Quality::Stale => 500,
        Quality::Bad => 0,
    }
}

/// The key of a tag's `description:` in its births' property set. Sparkplug B 3.0 lets a
/// PropertySet carry any key ("Payloads" › "PropertySet") and names none for a description,
/// so the key is ours, written as the specification writes its own (`engUnit`), and
/// documented for integrators in docs/plant-services.md. In births only, as the engineering
/// properties are: a host keeps a metric's properties from its birth.
pub(crate) const DESCRIPTION: &str = "description";

/// The `Quality` property set (type Int32). Sent on every tag metric, good included: whether a
/// host resets a metric to good when the property is left out is not specified.
pub(crate) fn quality_property(q: Quality) -> PropertySet {
    PropertySet {
        keys: vec!["Quality".into()],
        values: vec![PropertyValue {
            r#type: Some(DataType::Int32 as u32),
            is_null: None,
            value: Some(PropValue::IntValue(quality_code(q) as u32)),
        }],
    }
}

/// What one metric of a message says.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MetricSpec<'a> {
    /// Its name, in BIRTH messages only (DATA carries the alias alone).
    pub name: Option<&'a str>,
    /// Its alias.
    pub alias: Option<u64>,
    /// Its datatype, in BIRTH messages only.
    pub datatype: Option<DataType>,
    /// Capture time, UTC ms.
    pub timestamp: u64,
    /// The value.
    pub value: MetricValue,
    /// The tag's quality, for tag metrics.
    pub quality: Option<Quality>,
    /// A value kept while the broker was away, sent after the rebirth.
    pub historical: bool,
    /// Its engineering unit and range, in BIRTH messages only.
    pub birth: Option<&'a BirthProperties>,
}

impl MetricSpec<'_> {
    /// The protobuf metric.
    pub(crate) fn encode(&self) -> Metric {
        Metric {
            name: self.name.map(str::to_owned),
            alias: self.alias,
            timestamp: Some(self.timestamp),
            datatype: self.datatype.map(|d| d as u32),
            is_historical: self.historical.then_some(true),
            properties: self.properties(),
            value: Some(self.value.clone()),
            ..Metric::default()
        }
    }
}

impl MetricSpec<'_> {
    /// Its property set: `Quality` for a tag, then in births `description` (String) where the
    /// tag has one, `engUnit` (String), `engLow` and `engHigh` (Double) where its profile
    /// gives them (Sparkplug B 3.0, "Payloads" › "PropertySet"; the unit and range names are
    /// the specification's and Ignition's).
    fn properties(&self) -> Option<PropertySet> {
        let mut set = self.quality.map(quality_property)?;
        let Some(birth) = self.birth else {
            return Some(set);
        };
        let mut add = |key: &str, ty: DataType, value: PropValue| {
            set.keys.push(key.into());
            set.values.push(PropertyValue {
                r#type: Some(ty as u32),
                is_null: None,
                value: Some(value),
            });
        };
        if let Some(text) = &birth.description {
            add(
                DESCRIPTION,
                DataType::String,
                PropValue::StringValue(text.clone()),
            );
        }
        if let Some(unit) = &birth.unit {
            add(
                "engUnit",
                DataType::String,
                PropValue::StringValue(unit.clone()),
            );
        }
        if let Some((low, high)) = birth.range {
            add("engLow", DataType::Double, PropValue::DoubleValue(low));
            add("engHigh", DataType::Double, PropValue::DoubleValue(high));
        }
        Some(set)
    }
}

/// A payload of `metrics`, at `timestamp` (UTC ms), with `seq`.
pub(crate) fn encode(timestamp: u64, seq: Option<u8>, metrics: &[MetricSpec<'_>]) -> Vec<u8> {
    Payload {
        timestamp: Some(timestamp),
        metrics: metrics.iter().map(MetricSpec::encode).collect(),
        seq: seq.map(u64::from),
        ..Payload::default()
    }
    .encode_to_vec()
}

/// The bdSeq metric (Int64; "Payloads" › "NBIRTH" and "NDEATH").
pub(crate) fn bd_seq_metric(bd_seq: u8, timestamp: u64) -> MetricSpec<'static> {
    MetricSpec {
        name: Some(super::layout::BD_SEQ),
        alias: None,
        datatype: Some(DataType::Int64),
        timestamp,
        value: MetricValue::LongValue(u64::from(bd_seq)),
        quality: None,
        historical: false,
        birth: None,
    }
}

/// The NDEATH payload: the bdSeq metric only, no seq ("Payloads" › "NDEATH"); the same bytes
/// serve as the MQTT Will and as the death published at a clean stop.
pub(crate) fn ndeath(bd_seq: u8, timestamp: u64) -> Vec<u8> {
    encode(timestamp, None, &[bd_seq_metric(bd_seq, timestamp)])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An NBIRTH as the edge node encodes it, byte for byte: timestamp 1000, bdSeq 3
    /// (Int64), the rebirth metric (Boolean false, no alias), a u16 tag (alias 1, 1500, good)
    /// and an i32 tag (alias 2, -2 as two's complement, stale), seq 0. The same message built
    /// with Google's Python protobuf from the Tahu proto serializes to exactly these bytes.
    const GOLDEN_NBIRTH: &str = concat!(
        "08e807",                                                         // timestamp
        "120e0a05626453657118e80720045803",                               // bdSeq
        "121d0a144e6f646520436f6e74726f6c2f5265626972746818e807200b7000", // rebirth
        "12230a057370656564100118de0720064a100a075175616c6974791205080318c00150dc0b",
        "12270a066f6666736574100218de0720034a100a075175616c6974791205080318f40350feffffff0f",
        "1800", // seq
    );

    fn nbirth() -> Vec<u8> {
        encode(
            1000,
            Some(0),
            &[
                bd_seq_metric(3, 1000),
                MetricSpec {
                    name: Some("Node Control/Rebirth"),
                    alias: None,
                    datatype: Some(DataType::Boolean),
                    timestamp: 1000,
                    value: MetricValue::BooleanValue(false),
                    quality: None,
                    historical: false,
                    birth: None,
                },
                MetricSpec {
                    name: Some("speed"),
                    alias: Some(1),
                    datatype: Some(datatype(ValueType::U16)),
                    timestamp: 990,
                    value: metric_value(Value::U16(1500)),
                    quality: Some(Quality::Good),
                    historical: false,
                    birth: None,
                },
                MetricSpec {
                    name: Some("offset"),
                    alias: Some(2),
                    datatype: Some(datatype(ValueType::I32)),
                    timestamp: 990,
                    value: metric_value(Value::I32(-2)),
                    quality: Some(Quality::Stale),
                    historical: false,
                    birth: None,
                },
            ],
        )
    }

    #[test]
    fn an_nbirth_encodes_to_its_golden_bytes_and_decodes_back() {
        let bytes = nbirth();
        let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
        assert_eq!(hex, GOLDEN_NBIRTH);
        let p = Payload::decode(bytes.as_slice()).unwrap();
        assert_eq!(p.timestamp, Some(1000));
        assert_eq!(p.seq, Some(0));
        assert_eq!(p.metrics.len(), 4);
        let bd = &p.metrics[0];
        assert_eq!(bd.name.as_deref(), Some("bdSeq"));
        assert_eq!(bd.datatype, Some(DataType::Int64 as u32));
        assert_eq!(bd.value, Some(MetricValue::LongValue(3)));
        let rebirth = &p.metrics[1];
        assert_eq!(rebirth.alias, None);
        assert_eq!(rebirth.datatype, Some(11));
        assert_eq!(rebirth.value, Some(MetricValue::BooleanValue(false)));
        let speed = &p.metrics[2];
        assert_eq!(speed.datatype, Some(6));
        assert_eq!(speed.value, Some(MetricValue::IntValue(1500)));
        let q = speed.properties.as_ref().unwrap();
        assert_eq!(q.keys, ["Quality"]);
        assert_eq!(q.values[0].value, Some(PropValue::IntValue(192)));
        let offset = &p.metrics[3];
        assert_eq!(offset.datatype, Some(3));
        assert_eq!(
            tag_value(ValueType::I32, offset.value.as_ref()),
            Ok(Value::I32(-2))
        );
        let q = offset.properties.as_ref().unwrap();
        assert_eq!(q.values[0].value, Some(PropValue::IntValue(500)));
    }

    #[test]
    fn the_death_payload_is_bd_seq_alone_without_seq() {
        let bytes = ndeath(7, 5);
        // timestamp 5; one metric: name "bdSeq", timestamp 5, Int64, long_value 7.
        assert_eq!(
            bytes,
            [
                0x08, 0x05, 0x12, 0x0d, 0x0a, 0x05, b'b', b'd', b'S', b'e', b'q', 0x18, 0x05, 0x20,
                0x04, 0x58, 0x07
            ]
        );
        let p = Payload::decode(bytes.as_slice()).unwrap();
        assert_eq!(p.seq, None);
    }

    #[test]
    fn command_values_are_checked_against_the_tag_type() {
        use MetricValue::*;
        assert_eq!(
            tag_value(ValueType::U16, Some(&IntValue(7))),
            Ok(Value::U16(7))
        );
        assert_eq!(
            tag_value(ValueType::U16, Some(&IntValue(70_000))),
            Err(ValueError::OutOfRange { ty: ValueType::U16 })
        );
        assert_eq!(
            tag_value(ValueType::Bool, Some(&FloatValue(1.0))),
            Err(ValueError::WrongKind {
                ty: ValueType::Bool
            })
        );
        assert_eq!(tag_value(ValueType::F32, None), Err(ValueError::Missing));
        assert_eq!(
            tag_value(ValueType::I32, Some(&LongValue((-5i64) as u64))),
            Ok(Value::I32(-5))
        );
    }
}
