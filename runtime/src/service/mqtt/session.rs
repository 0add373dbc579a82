//! The edge node's thread: one MQTT 3.1.1 connection (rumqttc's sync client), driven from
//! this thread alone, and the snapshot read once per scan period. The scan never waits on
//! it: the snapshot is published with `try_lock`, writes reach the scan through the control
//! channel with `try_send`, and publishes are queued with `try_publish`.
//!
//! Sessions ("Edge Node Session Establishment"): every CONNECT carries the Will (NDEATH with
//! the session's bdSeq, QoS 1, not retained); on CONNACK the node subscribes to its NCMD and
//! DCMD topics, then births. A lost connection bumps bdSeq (the next CONNECT is a new
//! session), puts the new Will in place, and retries with a backoff doubling from
//! [`BACKOFF_MIN`] to [`BACKOFF_MAX`] (rumqttc itself would retry at once, in a loop), each
//! wait spread over its upper half by the node's name ([`spread`]) so that the nodes of a plant
//! do not all reconnect and birth in the same instant after a broker restart.
//! A clean stop publishes NDEATH, then DISCONNECT (which makes the broker drop the Will).

use crate::log_limit::{limited, Site};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use crossbeam_channel::{Receiver, Sender};
use rumqttc::{
    Client, Connection, Event, LastWill, MqttOptions, Outgoing as Out, Packet, QoS, Transport,
};

use super::command;
use super::host::{HostEvent, PrimaryHost};
use super::node::{EdgeNode, Outgoing};
use super::payload;
use crate::project::mqtt::MqttConfig;
use crate::service::changes::{ChangeStream, Delivery};
use crate::service::control::{Envelope, Request, Response, TagValue};
use crate::service::health::{Health, Service, ServiceState};
use crate::service::snapshot::SnapshotCell;

/// The first wait before reconnecting.
pub(crate) const BACKOFF_MIN: Duration = Duration::from_millis(250);
/// The longest wait before reconnecting.
pub(crate) const BACKOFF_MAX: Duration = Duration::from_secs(10);
/// `backoff` shortened by up to a half, by a hash of the node's identity and the session:
/// different nodes wait different times ("equal jitter"), the same node the same time for the
/// same session, so a test can reason about it. Never longer than `backoff`.
pub(crate) fn spread(backoff: Duration, group: &str, node: &str, bd_seq: u64) -> Duration {
    use std::hash::{Hash, Hasher};
    // DefaultHasher::new() has fixed keys: the same inputs give the same wait in every run.
    let mut h = std::hash::DefaultHasher::new();
    (group, node, bd_seq).hash(&mut h);
    let half = backoff / 2;
    let nanos = u64::try_from(half.as_nanos()).unwrap_or(u64::MAX).max(1);
    half + Duration::from_nanos(h.finish() % nanos)
}

/// How long a write may wait for the scan's answer before it is logged as lost.
pub(crate) const WRITE_WAIT: Duration = Duration::from_secs(2);
/// The MQTT keep-alive: a broker that vanished without closing is noticed within 1.5 × this.
pub(crate) const KEEP_ALIVE: Duration = Duration::from_secs(5);
/// Queued requests to the connection (births of many devices fit at once).
const REQUEST_CAPACITY: usize = 4096;
/// How long a connection attempt may take (TCP, TLS, CONNECT to CONNACK). The session's
/// thread waits for it whole, so changes wait in the scan's feed meanwhile (up to
/// `QUEUE_CYCLES` cycles: 5 s at a scan of 5 ms or longer).
const CONNECT_TIMEOUT: Duration = Duration::from_secs(5);
/// Largest MQTT packet either way (a birth of thousands of tags).
const MAX_PACKET: usize = 4 << 20;

fn wall_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// The options of a CONNECT (without the Will).
fn options(cfg: &MqttConfig) -> MqttOptions {
    let mut o = MqttOptions::new(cfg.client_id.clone(), cfg.host.clone(), cfg.port);
    o.set_keep_alive(KEEP_ALIVE)
        .set_clean_session(true)
        .set_max_packet_size(MAX_PACKET, MAX_PACKET);
    if let Some((user, password)) = &cfg.credentials {
        o.set_credentials(user.clone(), password.0.clone());
    }
    if let Some((_, ca)) = &cfg.tls_ca {
        // rustls without a compiled-in default: ring is the provider (already installed
        // when another part of the process did it first).
        drop(rustls::crypto::ring::default_provider().install_default());
        o.set_transport(Transport::tls(ca.clone(), None, None));
    }
    o
}

/// Log sites a flood of commands repeats (see [`crate::log_limit`]).
const COMMAND_IGNORED: Site = Site::new("mqtt.command_ignored", "MQTT: ignored commands");
const WRITE_REFUSED: Site = Site::new("mqtt.write_refused", "MQTT: refused writes");
const WRITE_APPLIED: Site = Site::new("mqtt.write_applied", "MQTT: applied writes");
/// What any client of the broker can repeat too: a primary host's STATE it cannot read, a
/// rebirth asked for; and a queue that stays full while the broker is slow.
const HOST_STATE_UNREAD: Site = Site::new("mqtt.host_state", "MQTT: unreadable host states");
const REBIRTH_ASKED: Site = Site::new("mqtt.rebirth", "MQTT: rebirths requested");
const NOT_QUEUED: Site = Site::new("mqtt.not_queued", "MQTT: messages not queued");

/// The running session (see the module docs).
pub(super) struct Session {
    pub(super) cfg: MqttConfig,
    pub(super) node: EdgeNode,
    pub(super) writable: Vec<bool>,
    pub(super) names: Vec<String>,
    pub(super) snapshot: SnapshotCell,
    /// Every cycle's changes, from the scan.
    pub(super) changes: ChangeStream,
    /// Changes taken from the feed and not yet handed to the node.
    pub(super) waiting: Vec<Delivery>,
    /// The primary host application, when the project names one.
    pub(super) host: Option<PrimaryHost>,
    /// Its offline STATE came: NDEATH and disconnect at once.
    pub(super) host_left: bool,
    pub(super) scan: Sender<Envelope>,
    pub(super) period: Duration,
    /// Where the service's state goes (connected, or why not).
    pub(super) health: Health,
}

struct Pending {
    tags: Vec<String>,
    answer: Receiver<Response>,
    deadline: Instant,
}

impl Session {
    fn will(&self, bd_seq: u8) -> LastWill {
        LastWill::new(
            self.node.topics().node("NDEATH"),
            payload::ndeath(bd_seq, wall_ms()),
            QoS::AtLeastOnce,
            false,
        )
    }

    /// Runs until the PLC's last publication (the scan stopped), then dies cleanly.
    pub(super) fn run(mut self) {
        let mut bd_seq: u8 = 0;
        let mut opts = options(&self.cfg);
        opts.set_last_will(self.will(bd_seq));
        let (client, mut conn) = Client::new(opts, REQUEST_CAPACITY);
        conn.eventloop
            .network_options
            .set_connection_timeout(CONNECT_TIMEOUT.as_secs());
        let mut online = false;
        let mut want_birth = false;
        let mut retry_at: Option<Instant> = None;
        let mut backoff = BACKOFF_MIN;
        let mut pending: Vec<Pending> = Vec::new();
        let mut last_cycle = u64::MAX;
        let tick = self
            .period
            .clamp(Duration::from_millis(5), Duration::from_millis(100));
        let mut next_tick = Instant::now();
        tracing::info!(
            "MQTT Sparkplug B: edge node {}/{} on {}:{}{}",
            self.cfg.group,
            self.cfg.node,
            self.cfg.host,
            self.cfg.port,
            if self.cfg.tls_ca.is_some() {
                " (TLS)"
            } else {
                ""
            }
        );
        loop {
            // The connection: events until the next tick, unless waiting to reconnect.
            let now = Instant::now();
            match retry_at {
                Some(at) if now < at => std::thread::sleep(at.min(next_tick) - now),
                _ => {
                    retry_at = None;
                    // While not connected, each wait is a connection attempt: it gets the whole
                    // connect timeout. Cut short, rumqttc drops the half-open connection after
                    // its CONNECT (and Will) reached the broker, which then publishes the Will:
                    // an NDEATH before the session's NBIRTH.
                    let wait = if online {
                        next_tick
                            .saturating_duration_since(now)
                            .max(Duration::from_millis(1))
                    } else {
                        CONNECT_TIMEOUT + Duration::from_secs(1)
                    };
                    match conn.recv_timeout(wait) {
                        Ok(Ok(event)) => {
                            if let Some(rebirth) =
                                self.on_event(&client, event, &mut online, &mut pending)
                            {
                                want_birth |= rebirth;
                                backoff = BACKOFF_MIN;
                            }
                            if std::mem::take(&mut self.host_left) && online {
                                // Sparkplug 3.0: the primary host went offline: NDEATH,
                                // disconnect, and births again only once it is back.
                                if !want_birth {
                                    self.die(&client, &mut conn, bd_seq, online);
                                } else {
                                    drop(client.try_disconnect());
                                }
                                online = false;
                                want_birth = true;
                            }
                        }
                        Ok(Err(e)) => {
                            self.health.set(
                                Service::Mqtt,
                                ServiceState::Degraded(format!(
                                    "no connection to the broker {}:{}: {e}; buffering changes",
                                    self.cfg.host, self.cfg.port
                                )),
                            );
                            if online {
                                tracing::warn!(
                                    "MQTT: connection to {}:{} lost: {e}; buffering changes",
                                    self.cfg.host,
                                    self.cfg.port
                                );
                            } else if backoff == BACKOFF_MIN {
                                // The first failure of a series says why (a refused
                                // certificate, a wrong password); the retries stay quiet.
                                tracing::warn!(
                                    "MQTT: cannot connect to {}:{}: {e}; retrying up to every {}s",
                                    self.cfg.host,
                                    self.cfg.port,
                                    BACKOFF_MAX.as_secs()
                                );
                            } else {
                                tracing::debug!(
                                    "MQTT: cannot connect to {}:{}: {e}",
                                    self.cfg.host,
                                    self.cfg.port
                                );
                            }
                            online = false;
                            // The next CONNECT is a new session: a new bdSeq, in its Will.
                            bd_seq = bd_seq.wrapping_add(1);
                            let will = self.will(bd_seq);
                            conn.eventloop.mqtt_options.set_last_will(will);
                            retry_at = Some(
                                Instant::now()
                                    + spread(
                                        backoff,
                                        &self.cfg.group,
                                        &self.cfg.node,
                                        u64::from(bd_seq),
                                    ),
                            );
                            backoff = (backoff * 2).min(BACKOFF_MAX);
                        }
                        Err(rumqttc::RecvTimeoutError::Timeout) => {}
                        Err(rumqttc::RecvTimeoutError::Disconnected) => return,
                    }
                }
            }
            if Instant::now() < next_tick {
                continue;
            }
            next_tick = Instant::now() + tick;
            self.answers(&mut pending);
            // The snapshot first: every cycle it shows is in the feed already (the scan
            // offers a cycle's changes before it publishes).
            let snap = self.snapshot.get();
            self.waiting.extend(self.changes.receiver().try_iter());
            self.node.set_lost(self.changes.lost());
            if !snap.published
                || (snap.cycles == last_cycle
                    && !want_birth
                    && !snap.stopped
                    && self.waiting.is_empty())
            {
                continue;
            }
            last_cycle = snap.cycles;
            let changes = std::mem::take(&mut self.waiting);
            let host_ready = self.host.as_ref().is_none_or(PrimaryHost::online);
            let out = if online && want_birth && host_ready {
                want_birth = false;
                // What changed up to the births' snapshot is history by the time they go
                // out: kept, and sent after them; what came after it is current.
                let (before, after): (Vec<Delivery>, Vec<Delivery>) = changes
                    .into_iter()
                    .partition(|d| d.cycle.cycle <= snap.cycles_of(d.cycle.task));
                self.node.keep(&snap, &before, wall_ms());
                tracing::info!(
                    "MQTT: NBIRTH (bdSeq {bd_seq}) and DBIRTHs, {} buffered change(s) after them",
                    self.node.buffered()
                );
                let mut out = self.node.birth(&snap, wall_ms(), bd_seq);
                out.extend(self.node.update(&snap, &after, wall_ms(), true));
                out
            } else {
                // Until the births are out (the primary host not online yet), changes are
                // kept as they are while the broker is away.
                self.node
                    .update(&snap, &changes, wall_ms(), online && !want_birth)
            };
            if !self.send(&client, out) {
                want_birth = true;
            }
            if snap.stopped {
                self.die(&client, &mut conn, bd_seq, online);
                return;
            }
        }
    }

    /// Queues `out`; false when the queue was full (a rebirth then resends everything).
    fn send(&self, client: &Client, out: Vec<Outgoing>) -> bool {
        for m in out {
            let qos = if m.at_least_once {
                QoS::AtLeastOnce
            } else {
                QoS::AtMostOnce
            };
            if let Err(e) = client.try_publish(m.topic.clone(), qos, false, m.payload) {
                limited!(
                    WARN,
                    NOT_QUEUED,
                    "",
                    "MQTT: {} not queued ({e}); a rebirth follows",
                    m.topic
                );
                return false;
            }
        }
        true
    }

    /// One connection event; `Some(true)` when a session just started (birth due).
    fn on_event(
        &mut self,
        client: &Client,
        event: Event,
        online: &mut bool,
        pending: &mut Vec<Pending>,
    ) -> Option<bool> {
        match event {
            Event::Incoming(Packet::ConnAck(_)) => {
                *online = true;
                let topics = self.node.topics();
                let mut subs = vec![topics.node("NCMD")];
                subs.extend(self.host.as_ref().map(|h| h.topic().to_string()));
                subs.extend(
                    self.node
                        .layout()
                        .devices
                        .iter()
                        .map(|d| topics.device("DCMD", d)),
                );
                for s in subs {
                    if let Err(e) = client.try_subscribe(s.clone(), QoS::AtLeastOnce) {
                        tracing::warn!("MQTT: cannot subscribe to {s}: {e}");
                    }
                }
                tracing::info!("MQTT: connected to {}:{}", self.cfg.host, self.cfg.port);
                self.health.set(Service::Mqtt, ServiceState::Running);
                Some(true)
            }
            Event::Incoming(Packet::Publish(p)) => {
                if let Some(host) = self.host.as_mut().filter(|h| h.topic() == p.topic) {
                    match host.on_message(&p.topic, &p.payload) {
                        Ok(HostEvent::Online) => {
                            tracing::info!("MQTT: primary host online ({}): births", p.topic);
                            return Some(true);
                        }
                        Ok(HostEvent::Offline) => {
                            tracing::info!(
                                "MQTT: primary host offline ({}): NDEATH and disconnect; \
                                 births again once it is online",
                                p.topic
                            );
                            self.host_left = true;
                        }
                        Ok(HostEvent::Nothing) => {}
                        Err(e) => limited!(
                            WARN,
                            HOST_STATE_UNREAD,
                            format!("on {}", p.topic),
                            "MQTT: {}: {e}",
                            p.topic
                        ),
                    }
                    return Some(false);
                }
                match command::decode(
                    &self.node,
                    &p.topic,
                    &p.payload,
                    self.cfg.writes,
                    &self.writable,
                ) {
                    Err(e) => limited!(
                        WARN,
                        COMMAND_IGNORED,
                        format!("on {}", p.topic),
                        "MQTT: command ignored: {e}"
                    ),
                    Ok(cmd) => {
                        for (tag, why) in &cmd.refused {
                            limited!(
                                WARN,
                                WRITE_REFUSED,
                                format!("on {}", p.topic),
                                "MQTT: {}: write to {tag} refused: {why}",
                                p.topic
                            );
                        }
                        if !cmd.writes.is_empty() {
                            self.write(&p.topic, &cmd.writes, pending);
                        }
                        if cmd.rebirth {
                            limited!(
                                INFO,
                                REBIRTH_ASKED,
                                format!("on {}", p.topic),
                                "MQTT: rebirth requested on {}",
                                p.topic
                            );
                            return Some(true);
                        }
                    }
                }
                Some(false)
            }
            _ => None,
        }
    }

    /// Hands writes to the scan, through the control socket's request path; the answer is
    /// read at a later tick (never waited for here).
    fn write(
        &self,
        topic: &str,
        writes: &[(usize, softplc_io::point::Value)],
        pending: &mut Vec<Pending>,
    ) {
        let values: Vec<TagValue> = writes
            .iter()
            .map(|&(t, v)| TagValue {
                tag: self.names[t].clone(),
                value: v.to_string(),
            })
            .collect();
        let tags: Vec<String> = values.iter().map(|v| v.tag.clone()).collect();
        let (reply, answer) = crossbeam_channel::bounded(1);
        let env = Envelope::new(
            Request::Write { values },
            reply,
            WRITE_WAIT,
            crate::service::audit::Origin::Mqtt(topic.to_string()),
        );
        match self.scan.try_send(env) {
            Ok(()) => pending.push(Pending {
                tags,
                answer,
                deadline: Instant::now() + WRITE_WAIT,
            }),
            Err(_) => limited!(
                WARN,
                WRITE_REFUSED,
                format!("on {topic}"),
                "MQTT: {topic}: write to {} refused: the scan's request queue is full",
                tags.join(", ")
            ),
        }
    }

    fn answers(&self, pending: &mut Vec<Pending>) {
        pending.retain(|p| match p.answer.try_recv() {
            Ok(r) if r.ok => {
                limited!(
                    INFO,
                    WRITE_APPLIED,
                    "",
                    "MQTT: write to {} applied",
                    p.tags.join(", ")
                );
                false
            }
            Ok(r) => {
                limited!(
                    WARN,
                    WRITE_REFUSED,
                    "",
                    "MQTT: write to {} refused: {}",
                    p.tags.join(", "),
                    r.error.unwrap_or_default()
                );
                false
            }
            Err(_) if Instant::now() >= p.deadline => {
                limited!(
                    WARN,
                    WRITE_REFUSED,
                    "",
                    "MQTT: write to {} refused: the scan did not answer within {WRITE_WAIT:?}",
                    p.tags.join(", ")
                );
                false
            }
            Err(_) => true,
        });
    }

    /// The clean stop: the last DATA went out; NDEATH, DISCONNECT, and the connection driven
    /// until both left (at most two seconds: a dead broker must not hold up the stop).
    fn die(&self, client: &Client, conn: &mut Connection, bd_seq: u8, online: bool) {
        if !online {
            return;
        }
        let death = payload::ndeath(bd_seq, wall_ms());
        // A full queue or a lost link: the broker then publishes the will, the same NDEATH.
        drop(client.try_publish(
            self.node.topics().node("NDEATH"),
            QoS::AtLeastOnce,
            false,
            death,
        ));
        // Already disconnected is the goal; the wait below is bounded either way.
        drop(client.try_disconnect());
        let deadline = Instant::now() + Duration::from_secs(2);
        while Instant::now() < deadline {
            match conn.recv_timeout(deadline - Instant::now()) {
                Ok(Ok(Event::Outgoing(Out::Disconnect))) | Ok(Err(_)) | Err(_) => break,
                Ok(Ok(_)) => {}
            }
        }
        tracing::info!("MQTT: NDEATH (bdSeq {bd_seq}) published, disconnected");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reconnect_waits_are_spread_over_the_upper_half_and_differ_between_nodes() {
        let waits: Vec<Duration> = (0..50)
            .map(|i| spread(Duration::from_secs(4), "plant1", &format!("press{i}"), 1))
            .collect();
        for w in &waits {
            assert!(
                *w >= Duration::from_secs(2) && *w <= Duration::from_secs(4),
                "{w:?}"
            );
        }
        let mut distinct = waits.clone();
        distinct.sort();
        distinct.dedup();
        assert!(
            distinct.len() > 45,
            "{} distinct waits of 50",
            distinct.len()
        );
        // The same node, the same session: the same wait.
        assert_eq!(
            spread(Duration::from_secs(4), "plant1", "press7", 1),
            waits[7]
        );
    }
}
