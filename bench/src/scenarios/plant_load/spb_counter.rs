//! A compiled Sparkplug B host of the harness (rumqttc, the payload decoded with the runtime's
//! code generated from Eclipse Tahu's `sparkplug_b.proto`), counting every metric change of
//! the counter tags against the sequence.
//!
//! Sparkplug DATA is QoS 0, so a subscriber that falls behind loses messages without anyone
//! being told. The harness shows it did not: rumqttc's event loop hands each PUBLISH at once
//! to a bounded queue (`try_send`, never waiting) that a second thread decodes and counts; the
//! queue's high-water mark and any message it refused are reported, and so is mosquitto's own
//! count of messages it dropped (`$SYS/broker/publish/messages/dropped`, every second).

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::Context;
use prost::Message;
use softplc::service::mqtt::spb;

use crate::sequence::{SequenceCheck, Tally};

/// The decoder's queue, in PUBLISH messages: about a second of the node's DATA at a 10 ms tick.
pub(super) const QUEUE: usize = 128;

/// mosquitto's count of dropped messages (QoS 0 beyond a client's queue, among others).
const DROPPED_TOPIC: &str = "$SYS/broker/publish/messages/dropped";

/// What the host saw, once stopped.
#[derive(Debug, Clone, Copy)]
pub(super) struct SpbFigures {
    /// Against the PLC's counters.
    pub tally: Tally,
    /// DATA and BIRTH messages decoded.
    pub messages: u64,
    /// The most messages that ever waited in the decoder's queue.
    pub high_water: usize,
    /// Messages the queue refused (full).
    pub refused: u64,
    /// mosquitto's dropped-message count at the end; `None` if it never said.
    pub broker_dropped: Option<u64>,
}

/// The host, subscribed; stopped by [`SpbCounter::finish`].
pub(super) struct SpbCounter {
    client: rumqttc::Client,
    reader: Option<JoinHandle<()>>,
    decoder: Option<JoinHandle<(SequenceCheck, u64)>>,
    shared: Arc<Shared>,
}

/// What the reader and the harness share.
#[derive(Debug, Default)]
struct Shared {
    pending: AtomicUsize,
    high_water: AtomicUsize,
    refused: AtomicU64,
    /// mosquitto's dropped count + 1 (0: not heard).
    broker_dropped: AtomicU64,
}

impl SpbCounter {
    /// Subscribes to every message of `group`/`node` and to mosquitto's dropped count on the
    /// broker at `port`; returns once the broker acknowledged the subscriptions.
    pub(super) fn start(port: u16, group: &str, node: &str, tags: usize) -> anyhow::Result<Self> {
        let mut opts = rumqttc::MqttOptions::new("softplc-bench-host", "127.0.0.1", port);
        opts.set_keep_alive(Duration::from_secs(30));
        opts.set_max_packet_size(1 << 20, 1 << 20);
        let (client, mut connection) = rumqttc::Client::new(opts, 16);
        let topics = [
            format!("spBv1.0/{group}/+/{node}"),
            format!("spBv1.0/{group}/+/{node}/+"),
            DROPPED_TOPIC.to_string(),
        ];
        for t in &topics {
            client.subscribe(t, rumqttc::QoS::AtMostOnce)?;
        }
        let shared = Arc::new(Shared::default());
        let (tx, rx) = mpsc::sync_channel::<rumqttc::Publish>(QUEUE);
        let (ready_tx, ready_rx) = mpsc::channel();
        let reader = {
            let shared = shared.clone();
            let wanted = topics.len();
            std::thread::Builder::new()
                .name("bench-spb-reader".into())
                .spawn(move || {
                    let mut acked = 0;
                    for event in connection.iter() {
                        match event {
                            Ok(rumqttc::Event::Incoming(rumqttc::Packet::SubAck(_))) => {
                                acked += 1;
                                if acked == wanted {
                                    // The harness may have given up waiting.
                                    ready_tx.send(()).ok();
                                }
                            }
                            Ok(rumqttc::Event::Incoming(rumqttc::Packet::Publish(p))) => {
                                shared.take(p, &tx);
                            }
                            Ok(_) => {}
                            Err(_) => break,
                        }
                    }
                })
                .context("cannot start the MQTT reader")?
        };
        let decoder = std::thread::Builder::new()
            .name("bench-spb-decoder".into())
            .spawn({
                let shared = shared.clone();
                move || decode(&rx, &shared, tags)
            })
            .context("cannot start the Sparkplug decoder")?;
        ready_rx
            .recv_timeout(Duration::from_secs(10))
            .context("the harness's Sparkplug host got no SUBACK within 10 s")?;
        Ok(Self {
            client,
            reader: Some(reader),
            decoder: Some(decoder),
            shared,
        })
    }

    /// Disconnects; what it counted against the PLC's final values.
    pub(super) fn finish(mut self, finals: &[i64]) -> anyhow::Result<SpbFigures> {
        // Already gone if the broker went first; the reader ends either way.
        drop(self.client.disconnect());
        if let Some(r) = self.reader.take() {
            drop(r.join());
        }
        let (check, messages) = self
            .decoder
            .take()
            .context("the decoder was already taken")?
            .join()
            .map_err(|_| anyhow::anyhow!("the Sparkplug decoder panicked"))?;
        let dropped = self.shared.broker_dropped.load(Ordering::Relaxed);
        Ok(SpbFigures {
            tally: check.tally(0, finals),
            messages,
            high_water: self.shared.high_water.load(Ordering::Relaxed),
            refused: self.shared.refused.load(Ordering::Relaxed),
            broker_dropped: dropped.checked_sub(1),
        })
    }
}

impl Shared {
    /// A PUBLISH from the event loop: mosquitto's count read here, the rest queued.
    fn take(&self, p: rumqttc::Publish, tx: &mpsc::SyncSender<rumqttc::Publish>) {
        if p.topic == DROPPED_TOPIC {
            if let Some(n) = std::str::from_utf8(&p.payload)
                .ok()
                .and_then(|t| t.trim().parse::<u64>().ok())
            {
                self.broker_dropped.store(n + 1, Ordering::Relaxed);
            }
            return;
        }
        // Counted before it is sent, so the decoder's decrement never comes first.
        let now = self.pending.fetch_add(1, Ordering::Relaxed) + 1;
        self.high_water.fetch_max(now, Ordering::Relaxed);
        if tx.try_send(p).is_err() {
            self.pending.fetch_sub(1, Ordering::Relaxed);
            self.refused.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Decodes and counts until the reader ends: the check and the messages decoded.
fn decode(
    rx: &mpsc::Receiver<rumqttc::Publish>,
    shared: &Shared,
    tags: usize,
) -> (SequenceCheck, u64) {
    let mut check = SequenceCheck::new(tags, 0);
    // Alias → tag index, from the births (aliases are unique within an edge node).
    let mut by_alias: HashMap<u64, usize> = HashMap::new();
    let mut messages = 0;
    for p in rx {
        shared.pending.fetch_sub(1, Ordering::Relaxed);
        let Ok(payload) = spb::Payload::decode(p.payload.as_ref()) else {
            continue;
        };
        messages += 1;
        for m in &payload.metrics {
            let named = m.name.as_deref().and_then(counter_index);
            if let (Some(tag), Some(alias)) = (named, m.alias) {
                by_alias.insert(alias, tag);
            }
            let tag = named.or_else(|| m.alias.and_then(|a| by_alias.get(&a).copied()));
            if let (Some(tag), Some(spb::payload::metric::Value::IntValue(v))) = (tag, &m.value) {
                // Int32 travels in the proto's uint32 field, two's complement.
                check.observe(tag, i64::from(*v as i32));
            }
        }
    }
    (check, messages)
}

/// `c123` → 123.
fn counter_index(name: &str) -> Option<usize> {
    name.strip_prefix('c')?.parse().ok()
}

impl Drop for SpbCounter {
    fn drop(&mut self) {
        // A host dropped without `finish` (a run that failed) leaves the broker too.
        drop(self.client.disconnect());
    }
}
