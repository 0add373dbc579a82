//! The alarms in the address space, as plain variables: async-opcua 0.19 has no Alarms &
//! Conditions (no ConditionType, no events), so a client reads or subscribes to these.
//!
//! ```text
//! Objects/
//!   Alarms/
//!     NAME/          one folder per alarm (a tag's name, or lost.MODULE): Alarms.NAME
//!       Active        Boolean   its condition holds
//!       Acknowledged  Boolean   its last raise was acknowledged (true if never raised)
//!       Severity      UInt16    its priority, 1..=1000
//!       Text          String    what the operator reads
//!       RaisedAt      DateTime  its last raise (null: never)
//!       ClearedAt     DateTime  its last clear after that raise (null: none)
//!       AckedAt       DateTime  its last acknowledgement (null: none)
//!       Acknowledge   Boolean   writable when the server's writes are on: write true to
//!                               acknowledge (as the operator's page does); reads as
//!                               Acknowledged
//! ```
//!
//! An acknowledgement goes through the scan's requests like every write (audited as `opcua`):
//! `Good` once done, `BadInvalidState` when the alarm is not waiting for one, `BadOutOfRange`
//! for `false`, `BadTypeMismatch` for anything but a Boolean, `BadTimeout` when the scan does
//! not answer in time.

use crossbeam_channel::Sender;
use opcua::types::{DataTypeId, DataValue, DateTime, StatusCode, Variant};

use super::space::{node, Folder, Node};
use super::write::WRITE_WAIT;
use crate::service::alarms::{AlarmRequest, AlarmView, Stamp};
use crate::service::control::{Envelope, Request};

/// Each alarm's variables, in this order.
const FIELDS: [(&str, DataTypeId); 8] = [
    ("Active", DataTypeId::Boolean),
    ("Acknowledged", DataTypeId::Boolean),
    ("Severity", DataTypeId::UInt16),
    ("Text", DataTypeId::String),
    ("RaisedAt", DataTypeId::DateTime),
    ("ClearedAt", DataTypeId::DateTime),
    ("AckedAt", DataTypeId::DateTime),
    ("Acknowledge", DataTypeId::Boolean),
];

/// The `Alarms` folder, a folder per alarm (`names`, in the alarms' order) and its variables;
/// `Acknowledge` is writable when `writes` is.
pub(crate) fn layout(names: &[String], writes: bool) -> (Vec<Folder>, Vec<Vec<Node>>) {
    let mut folders = vec![Folder {
        id: "Alarms".into(),
        name: "Alarms".into(),
        parent: None,
        description: None,
    }];
    let mut nodes = Vec::new();
    for name in names {
        let folder = format!("Alarms.{name}");
        folders.push(Folder {
            id: folder.clone(),
            name: name.clone(),
            parent: Some("Alarms".into()),
            description: None,
        });
        nodes.push(
            FIELDS
                .iter()
                .map(|(f, ty)| Node {
                    writable: writes && *f == "Acknowledge",
                    ..node(&folder, f, *ty)
                })
                .collect(),
        );
    }
    (folders, nodes)
}

/// The alarm a writable node acknowledges: its folder's name.
pub(crate) fn alarm_of(node: &Node) -> Option<&str> {
    node.folder.strip_prefix("Alarms.")
}

fn time(stamp: Option<&Stamp>) -> Variant {
    let t = stamp
        .and_then(|s| chrono::DateTime::parse_from_rfc3339(&s.utc).ok())
        .map_or_else(DateTime::null, |t| {
            DateTime::from(t.with_timezone(&chrono::Utc))
        });
    Variant::DateTime(Box::new(t))
}

/// Every alarm variable's value now (ids as [`layout`] makes them), stamped `now`.
pub(crate) fn values(views: &[AlarmView], now: DateTime) -> Vec<(String, DataValue)> {
    let mut out = Vec::with_capacity(views.len() * FIELDS.len());
    for a in views {
        let v = [
            Variant::Boolean(a.active),
            Variant::Boolean(a.acknowledged),
            Variant::UInt16(a.priority),
            Variant::from(a.text.as_str()),
            time(a.raised.as_ref()),
            time(a.cleared.as_ref()),
            time(a.acked.as_ref()),
            Variant::Boolean(a.acknowledged),
        ];
        for ((field, _), value) in FIELDS.iter().zip(v) {
            out.push((
                format!("Alarms.{}.{field}", a.name),
                DataValue {
                    value: Some(value),
                    status: Some(StatusCode::Good),
                    source_timestamp: Some(now),
                    server_timestamp: Some(now),
                    ..Default::default()
                },
            ));
        }
    }
    out
}

/// A client's write to `alarm`'s `Acknowledge` (see the module docs).
pub(crate) fn acknowledge(scan: &Sender<Envelope>, alarm: &str, dv: &DataValue) -> StatusCode {
    match dv.value {
        Some(Variant::Boolean(true)) => {}
        Some(Variant::Boolean(false)) => return StatusCode::BadOutOfRange,
        _ => return StatusCode::BadTypeMismatch,
    }
    let deadline = std::time::Instant::now() + WRITE_WAIT;
    let (reply, answer) = crossbeam_channel::bounded(1);
    let env = Envelope::new(
        Request::Alarms(AlarmRequest::Ack {
            alarm: alarm.to_owned(),
        }),
        reply,
        WRITE_WAIT,
        crate::service::audit::Origin::Opcua,
    );
    if scan.send_deadline(env, deadline).is_err() {
        return StatusCode::BadTimeout;
    }
    match answer.recv_deadline(deadline) {
        Ok(r) if r.ok => StatusCode::Good,
        Ok(_) => StatusCode::BadInvalidState,
        Err(_) => StatusCode::BadTimeout,
    }
}
