//! A client's write to a tag, under the Modbus TCP server's rules, and the StatusCode it gets:
//!
//! | the write                                         | StatusCode            |
//! |---------------------------------------------------|-----------------------|
//! | applied by the scan at its next cycle boundary    | `Good`                |
//! | `writes: false`, or the tag is not `scada: write` | `BadUserAccessDenied` (the tag's AccessLevel is CurrentRead only; async-opcua answers) |
//! | not the tag's exact type (UInt16 for u16, ...)    | `BadTypeMismatch`     |
//! | the tag is forced                                 | `BadLocked`           |
//! | refused by the scan otherwise (pushed-down output)| `BadNotWritable`      |
//! | the scan did not take or answer it in time        | `BadTimeout`          |
//!
//! The write goes through the same request as the control socket's and the Modbus TCP
//! server's (`Request::Write`), applied by the scan thread between two cycles. On `Good` the
//! server keeps the written value as the variable's (the vendored async-opcua-server's second
//! change), so a Read that follows the answer returns it; the scan's change feed then brings
//! the value that boundary left, with its time. async-opcua
//! calls this holding its address space's lock, so the wait for the scan's answer (one cycle,
//! [`WRITE_WAIT`] at most) holds up the updates and other clients' requests meanwhile, never
//! the scan.

use crate::log_limit::{limited, Site};
use std::time::{Duration, Instant};

use crossbeam_channel::Sender;
use opcua::types::{DataValue, StatusCode};
use softplc_io::point::ValueType;

use super::space::value_of;
use crate::service::control::{Envelope, Request, TagValue};
use crate::service::snapshot::SnapshotCell;

/// How long a write waits for the scan to take and answer it.
pub(crate) const WRITE_WAIT: Duration = Duration::from_secs(2);

/// What a write needs (shared by every writable tag's callback).
#[derive(Debug)]
pub(crate) struct Writer {
    names: Vec<String>,
    snapshot: SnapshotCell,
    scan: Sender<Envelope>,
    written: WrittenAt,
}

/// Per tag: the cycle boundary its last OPC UA write was applied at. The updater takes no
/// older change of the tag after it: the server already holds the written value, and a change
/// from before it, late from the feed, would hide it from a Read that follows the answer.
#[derive(Debug, Clone, Default)]
pub(crate) struct WrittenAt(std::sync::Arc<std::sync::Mutex<Vec<u64>>>);

impl WrittenAt {
    fn set(&self, tag: usize, cycle: u64) {
        // A writer that panicked left the list whole: keep using it.
        let mut w = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if w.len() <= tag {
            w.resize(tag + 1, 0);
        }
        w[tag] = w[tag].max(cycle);
    }

    /// Whether a change of `tag` at boundary `cycle` is older than its last write.
    pub(crate) fn hides(&self, tag: usize, cycle: u64) -> bool {
        let w = self.0.lock().unwrap_or_else(|e| e.into_inner());
        w.get(tag).is_some_and(|&at| cycle < at)
    }
}

impl Writer {
    /// Writes name their tags from `names` (in tag order), check forces in `snapshot`, and go
    /// to `scan`.
    pub(crate) fn new(names: Vec<String>, snapshot: SnapshotCell, scan: Sender<Envelope>) -> Self {
        Self {
            names,
            snapshot,
            scan,
            written: WrittenAt::default(),
        }
    }

    /// Where the writes are noted, for the updater.
    pub(crate) fn written(&self) -> WrittenAt {
        self.written.clone()
    }

    /// Writes `dv` to tag `tag` of type `ty` (see the module docs).
    pub(crate) fn write(&self, tag: usize, ty: ValueType, dv: &DataValue) -> StatusCode {
        let Some(name) = self.names.get(tag) else {
            return StatusCode::BadNodeIdUnknown;
        };
        let Some(value) = dv.value.as_ref().and_then(|v| value_of(ty, v)) else {
            return StatusCode::BadTypeMismatch;
        };
        if self
            .snapshot
            .with(|s| s.forced.get(tag).copied().unwrap_or(false))
        {
            limited!(
                INFO,
                REFUSED,
                name,
                "OPC UA: write to {name} refused: {name} is forced"
            );
            return StatusCode::BadLocked;
        }
        let deadline = Instant::now() + WRITE_WAIT;
        let (reply, answer) = crossbeam_channel::bounded(1);
        let values = vec![TagValue {
            tag: name.clone(),
            value: value.to_string(),
        }];
        let env = Envelope::new(
            Request::Write { values },
            reply,
            WRITE_WAIT,
            crate::service::audit::Origin::Opcua,
        );
        if self.scan.send_deadline(env, deadline).is_err() {
            limited!(
                WARN,
                REFUSED,
                name,
                "OPC UA: write to {name} refused: the scan did not take it in time"
            );
            return StatusCode::BadTimeout;
        }
        match answer.recv_deadline(deadline) {
            Ok(r) if r.ok => {
                if let Some(cycle) = r.applied_at {
                    self.written.set(tag, cycle);
                }
                limited!(INFO, WRITTEN, name, "OPC UA: {name} written: {value}");
                StatusCode::Good
            }
            Ok(r) => {
                let why = r.error.unwrap_or_default();
                limited!(
                    INFO,
                    REFUSED,
                    name,
                    "OPC UA: write to {name} refused: {why}"
                );
                // Forced after the snapshot checked above: the scan knows.
                if r.locked {
                    StatusCode::BadLocked
                } else {
                    StatusCode::BadNotWritable
                }
            }
            Err(_) => {
                limited!(
                    WARN,
                    REFUSED,
                    name,
                    "OPC UA: write to {name}: the scan did not answer in time"
                );
                StatusCode::BadTimeout
            }
        }
    }
}

/// Log sites a client's writes repeat (see [`crate::log_limit`]).
const REFUSED: Site = Site::new("opcua.write_refused", "OPC UA: refused writes");
const WRITTEN: Site = Site::new("opcua.written", "OPC UA: writes applied");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::control::Response;
    use crate::service::snapshot::ServiceSnapshot;
    use opcua::types::Variant;

    fn dv(v: Variant) -> DataValue {
        DataValue {
            value: Some(v),
            ..Default::default()
        }
    }

    #[test]
    fn a_write_goes_to_the_scan_unless_forced_or_of_another_type() {
        let cell = SnapshotCell::new();
        cell.set(ServiceSnapshot {
            forced: vec![false, true],
            ..Default::default()
        });
        let (tx, rx) = crossbeam_channel::bounded::<Envelope>(4);
        let w = Writer::new(vec!["speed".into(), "held".into()], cell, tx);
        // A stand-in scan: applies "speed", refuses anything else.
        let scan = std::thread::spawn(move || {
            let mut seen = Vec::new();
            while let Ok(env) = rx.recv() {
                let Request::Write { values } = &env.request else {
                    continue;
                };
                seen.push(format!("{}={}", values[0].tag, values[0].value));
                let r = if values[0].tag == "speed" && values[0].value == "7" {
                    Response::done("1 tag(s) written")
                } else if values[0].value == "9" {
                    // Forced at the boundary after the snapshot the writer looked at.
                    Response {
                        locked: true,
                        ..Response::refused("speed is forced; unforce it to write it")
                    }
                } else {
                    Response::refused("pushed down")
                };
                drop(env.reply.send(r));
            }
            seen
        });
        assert_eq!(
            w.write(0, ValueType::U16, &dv(Variant::UInt16(7))),
            StatusCode::Good
        );
        assert_eq!(
            w.write(0, ValueType::U16, &dv(Variant::Int64(7))),
            StatusCode::BadTypeMismatch
        );
        assert_eq!(
            w.write(1, ValueType::U16, &dv(Variant::UInt16(3))),
            StatusCode::BadLocked
        );
        assert_eq!(
            w.write(0, ValueType::U16, &dv(Variant::UInt16(8))),
            StatusCode::BadNotWritable
        );
        assert_eq!(
            w.write(0, ValueType::U16, &dv(Variant::UInt16(9))),
            StatusCode::BadLocked,
            "a force the snapshot did not show yet is still a lock"
        );
        drop(w);
        assert_eq!(scan.join().unwrap(), ["speed=7", "speed=8", "speed=9"]);
    }

    #[test]
    fn a_change_older_than_a_write_of_its_tag_is_hidden() {
        let w = WrittenAt::default();
        assert!(!w.hides(3, 1));
        w.set(3, 10);
        assert!(w.hides(3, 9), "from before the write");
        assert!(!w.hides(3, 10), "the boundary that applied it");
        assert!(!w.hides(2, 1), "another tag");
        w.set(3, 5);
        assert!(w.hides(3, 9), "an older answer does not move it back");
    }
}
