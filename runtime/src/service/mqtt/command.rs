//! NCMD and DCMD (Sparkplug B 3.0, "Operational Behavior" › "Commands"): a rebirth request,
//! or writes, checked under the Modbus TCP server's rules (`writes: true`, only tags marked
//! `scada: write`) before they go to the scan, which refuses forced tags at its boundary.
//!
//! Sparkplug has no reply to a command: a refused one is logged with the tag and why, and a
//! host sees an accepted one in the DATA that follows, once the value has changed.

use prost::Message;
use softplc_io::point::Value;

use super::layout::REBIRTH;
use super::node::{EdgeNode, Topics};
use super::payload::{tag_value, ValueError};
use super::spb::payload::metric::Value as MetricValue;
use super::spb::Payload;

/// Why a command metric is not carried out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum Refusal {
    /// `service.mqtt.writes` is off.
    #[error("writes are off (service.mqtt.writes: false)")]
    WritesOff,
    /// The tag is not `scada: write`.
    #[error("the tag is not writable (scada: write)")]
    NotWritable,
    /// No such metric on that device.
    #[error("no such metric here")]
    Unknown,
    /// The value does not fit the tag.
    #[error("{0}")]
    Value(ValueError),
}

/// What one command message asks.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Command {
    /// `Node Control/Rebirth` = true.
    pub rebirth: bool,
    /// Writes to carry out: tag index and value.
    pub writes: Vec<(usize, Value)>,
    /// Metrics refused: what the command called it, and why.
    pub refused: Vec<(String, Refusal)>,
}

/// Why a message on a command topic is not a command at all.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(crate) enum BadCommand {
    /// Not this node's NCMD or one of its devices' DCMD.
    #[error("not a command topic of this node: {0}")]
    Topic(String),
    /// A DCMD for a device this node does not have.
    #[error("DCMD for unknown device {0}")]
    Device(String),
    /// Not a Sparkplug payload.
    #[error("{topic}: not a Sparkplug B payload: {why}")]
    Payload {
        /// The topic.
        topic: String,
        /// The decoder's message.
        why: String,
    },
}

/// Decodes and checks a command published on `topic`; `writes` is `service.mqtt.writes`,
/// `writable` each tag's `scada: write`.
pub(crate) fn decode(
    node: &EdgeNode,
    topic: &str,
    payload: &[u8],
    writes: bool,
    writable: &[bool],
) -> Result<Command, BadCommand> {
    let topics: &Topics = node.topics();
    let layout = node.layout();
    let target = topics
        .command_target(topic)
        .ok_or_else(|| BadCommand::Topic(topic.into()))?;
    let device = match target {
        None => None,
        Some(name) => Some(
            layout
                .devices
                .iter()
                .position(|d| d == name)
                .ok_or_else(|| BadCommand::Device(name.into()))?,
        ),
    };
    let p = Payload::decode(payload).map_err(|e| BadCommand::Payload {
        topic: topic.into(),
        why: e.to_string(),
    })?;
    let mut cmd = Command::default();
    for m in &p.metrics {
        let called = m
            .name
            .clone()
            .or_else(|| m.alias.map(|a| format!("alias {a}")))
            .unwrap_or_else(|| "a metric without name or alias".into());
        if device.is_none() && m.name.as_deref() == Some(REBIRTH) {
            if m.value == Some(MetricValue::BooleanValue(true)) {
                cmd.rebirth = true;
            }
            continue;
        }
        let Some(tag) = layout.find(device, m.alias, m.name.as_deref()) else {
            cmd.refused.push((called, Refusal::Unknown));
            continue;
        };
        let checked = if !writes {
            Err(Refusal::WritesOff)
        } else if !writable.get(tag.tag).copied().unwrap_or(false) {
            Err(Refusal::NotWritable)
        } else {
            tag_value(tag.ty, m.value.as_ref()).map_err(Refusal::Value)
        };
        match checked {
            Ok(v) => cmd.writes.push((tag.tag, v)),
            Err(r) => cmd.refused.push((tag.name.clone(), r)),
        }
    }
    Ok(cmd)
}
