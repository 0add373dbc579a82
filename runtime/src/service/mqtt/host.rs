//! The Sparkplug B 3.0 primary host application's STATE ("Operational Behavior" › "Primary
//! Host Application" and "Edge Node Session Establishment"): with `primary_host:` set, the
//! node subscribes to `spBv1.0/STATE/<host_id>` (a retained JSON payload
//! `{"online": bool, "timestamp": ms}` the host publishes), births only while the host is
//! online, births again when it comes back, and on its offline STATE publishes NDEATH and
//! disconnects. Timestamps decide which STATE counts: an online STATE no older than the last
//! STATE seen, an offline STATE no older than the last online one; an older one is ignored.

use serde::Deserialize;

/// The STATE payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
struct State {
    online: bool,
    timestamp: u64,
}

/// What a STATE message asks of the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum HostEvent {
    /// The host is online now (it was not, or nothing was known): birth.
    Online,
    /// The host went offline: NDEATH, disconnect, wait for it.
    Offline,
    /// Nothing changes (the same state again, an older timestamp, another host's topic).
    Nothing,
}

/// Why a STATE message was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum StateError {
    /// Not the JSON object Sparkplug specifies.
    #[error("not a Sparkplug STATE payload ({{\"online\": bool, \"timestamp\": ms}})")]
    Payload,
}

/// The node's view of its primary host.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct PrimaryHost {
    topic: String,
    online: Option<bool>,
    last: u64,
    last_online: u64,
}

impl PrimaryHost {
    /// Watching host `id`.
    pub(crate) fn new(id: &str) -> Self {
        Self {
            topic: format!("spBv1.0/STATE/{id}"),
            online: None,
            last: 0,
            last_online: 0,
        }
    }

    /// Its STATE topic.
    pub(crate) fn topic(&self) -> &str {
        &self.topic
    }

    /// Whether births may go out: the host said it is online.
    pub(crate) fn online(&self) -> bool {
        self.online == Some(true)
    }

    /// A message on `topic` with `payload`.
    pub(crate) fn on_message(
        &mut self,
        topic: &str,
        payload: &[u8],
    ) -> Result<HostEvent, StateError> {
        if topic != self.topic {
            return Ok(HostEvent::Nothing);
        }
        let state: State = serde_json::from_slice(payload).map_err(|_| StateError::Payload)?;
        if state.online {
            if state.timestamp < self.last {
                return Ok(HostEvent::Nothing);
            }
            self.last = state.timestamp;
            self.last_online = state.timestamp;
            let was = self.online.replace(true);
            return Ok(if was == Some(true) {
                HostEvent::Nothing
            } else {
                HostEvent::Online
            });
        }
        if state.timestamp < self.last_online {
            return Ok(HostEvent::Nothing);
        }
        self.last = self.last.max(state.timestamp);
        let was = self.online.replace(false);
        Ok(if was == Some(true) {
            HostEvent::Offline
        } else {
            HostEvent::Nothing
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(online: bool, ts: u64) -> Vec<u8> {
        format!("{{\"online\": {online}, \"timestamp\": {ts}}}").into_bytes()
    }

    #[test]
    fn states_count_by_their_timestamps() {
        let mut h = PrimaryHost::new("scada1");
        let t = "spBv1.0/STATE/scada1";
        assert!(!h.online());
        assert_eq!(h.on_message(t, &state(false, 10)), Ok(HostEvent::Nothing));
        assert!(!h.online(), "offline: no births");
        assert_eq!(h.on_message(t, &state(true, 20)), Ok(HostEvent::Online));
        assert!(h.online());
        assert_eq!(h.on_message(t, &state(true, 20)), Ok(HostEvent::Nothing));
        // An offline STATE older than the last online one is ignored.
        assert_eq!(h.on_message(t, &state(false, 15)), Ok(HostEvent::Nothing));
        assert!(h.online());
        assert_eq!(h.on_message(t, &state(false, 30)), Ok(HostEvent::Offline));
        assert!(!h.online());
        // An online STATE older than the last seen is ignored too.
        assert_eq!(h.on_message(t, &state(true, 25)), Ok(HostEvent::Nothing));
        assert_eq!(h.on_message(t, &state(true, 40)), Ok(HostEvent::Online));
        // Another host's STATE, and a payload that is not one.
        assert_eq!(
            h.on_message("spBv1.0/STATE/other", &state(false, 99)),
            Ok(HostEvent::Nothing)
        );
        assert_eq!(h.on_message(t, b"online"), Err(StateError::Payload));
        assert!(h.online());
    }
}
