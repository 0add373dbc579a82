//! async-opcua's own client (the crate the server is built on, same version), subscribed to
//! every counter tag with sampling interval 0, counting each data change against the
//! sequence: a client compiled into the harness, so it is not the bottleneck.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::{anyhow, bail, Context};
use opcua::client::{ClientBuilder, IdentityToken, Session, SubscriptionCallbacks};
use opcua::types::{
    DataValue, EndpointDescription, ExtensionObject, MessageSecurityMode,
    MonitoredItemCreateRequest, MonitoringMode, MonitoringParameters, NodeId, ReadValueId,
    TimestampsToReturn, UserTokenPolicy, Variant,
};

use crate::sequence::{SequenceCheck, Tally};

/// The most array elements the client decodes in one message: every tag's queue in full.
const MAX_ARRAY: usize = 1_000_000;

/// The largest message the client takes (a publish of every tag's queue in full, 100,000
/// values of about 30 bytes, fits), and the chunks it may come in.
const MAX_MESSAGE: usize = 16 << 20;
const MIN_CHUNK: usize = 8192;

/// Monitored items per CreateMonitoredItems call (the server's per-call limit is larger).
const ITEMS_PER_CALL: usize = 250;

/// What the client counted.
#[derive(Debug)]
struct Counts {
    check: SequenceCheck,
    /// Data values with the Overflow InfoBit (OPC 10000-4 §7.8.2.2: a value was discarded
    /// before this one).
    overflow: u64,
    /// Data values without an Int32 value (a bad status with no value).
    without_value: u64,
    /// Data values received, initial ones included.
    values: u64,
    /// Subscription status changes (a timeout, a transfer): none in a good run.
    status_changes: u64,
}

/// What the client saw, once stopped.
#[derive(Debug, Clone, Copy)]
pub(super) struct UaFigures {
    /// Against the PLC's counters.
    pub tally: Tally,
    /// Values with the Overflow InfoBit.
    pub overflow: u64,
    /// Values without a value.
    pub without_value: u64,
    /// Data values received, the subscription's initial ones included.
    pub values: u64,
    /// Subscription status changes the server sent.
    pub status_changes: u64,
    /// The queue size the server granted (the smallest of the items').
    pub queue: u32,
}

/// The client, subscribed; stopped by [`UaCounter::finish`] (or when dropped).
#[derive(Debug)]
pub(super) struct UaCounter {
    stop: Arc<AtomicBool>,
    counts: Arc<Mutex<Counts>>,
    thread: Option<JoinHandle<()>>,
    queue: u32,
}

/// The subscription asked for.
#[derive(Debug, Clone, Copy)]
pub(super) struct UaRequest {
    /// Publishing interval.
    pub publishing: Duration,
    /// Each monitored item's queue.
    pub queue: u32,
    /// Tags `c0..c{tags-1}`.
    pub tags: usize,
}

impl UaCounter {
    /// Connects to `opc.tcp://127.0.0.1:PORT/`, finds namespace `urn:softplc:PROJECT` and
    /// subscribes; returns once every monitored item is created. `pki` is the client's
    /// certificate folder (SecurityPolicy None: nothing is made in it).
    pub(super) fn start(
        port: u16,
        project: &str,
        pki: &Path,
        request: UaRequest,
    ) -> anyhow::Result<Self> {
        let stop = Arc::new(AtomicBool::new(false));
        let counts = Arc::new(Mutex::new(Counts {
            check: SequenceCheck::new(request.tags, 0),
            overflow: 0,
            without_value: 0,
            values: 0,
            status_changes: 0,
        }));
        let (ready_tx, ready_rx) = mpsc::channel();
        let url = format!("opc.tcp://127.0.0.1:{port}/");
        let namespace = format!("urn:softplc:{project}");
        let pki = pki.to_path_buf();
        let thread = {
            let (stop, counts) = (stop.clone(), counts.clone());
            std::thread::Builder::new()
                .name("bench-ua-client".into())
                .spawn(move || {
                    let runtime = match tokio::runtime::Builder::new_current_thread()
                        .enable_all()
                        .build()
                    {
                        Ok(r) => r,
                        Err(e) => {
                            // The harness may have given up waiting; nobody to tell then.
                            ready_tx.send(Err(anyhow!("no tokio runtime: {e}"))).ok();
                            return;
                        }
                    };
                    runtime.block_on(async move {
                        let session = match subscribe(&url, &namespace, &pki, request, counts).await
                        {
                            Ok((session, queue)) => {
                                ready_tx.send(Ok(queue)).ok();
                                session
                            }
                            Err(e) => {
                                ready_tx.send(Err(e)).ok();
                                return;
                            }
                        };
                        while !stop.load(Ordering::Relaxed) {
                            tokio::time::sleep(Duration::from_millis(20)).await;
                        }
                        // A server already gone cannot be told; the counts stand.
                        drop(session.disconnect().await);
                    });
                })
                .context("cannot start the OPC UA client's thread")?
        };
        let queue = ready_rx
            .recv_timeout(Duration::from_secs(60))
            .context("the async-opcua client did not subscribe within 60 s")??;
        Ok(Self {
            stop,
            counts,
            thread: Some(thread),
            queue,
        })
    }

    /// Stops the client; what it counted against the PLC's final values.
    pub(super) fn finish(mut self, finals: &[i64]) -> UaFigures {
        self.halt();
        let c = self.counts.lock().unwrap_or_else(|p| p.into_inner());
        UaFigures {
            tally: c.check.tally(0, finals),
            overflow: c.overflow,
            without_value: c.without_value,
            values: c.values,
            status_changes: c.status_changes,
            queue: self.queue,
        }
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            // A client thread that panicked counted what it counted.
            drop(t.join());
        }
    }
}

impl Drop for UaCounter {
    fn drop(&mut self) {
        self.halt();
    }
}

/// Connects, subscribes every tag; the session (its event loop runs on this runtime) and the
/// smallest queue size the server granted.
async fn subscribe(
    url: &str,
    namespace: &str,
    pki: &Path,
    request: UaRequest,
    counts: Arc<Mutex<Counts>>,
) -> anyhow::Result<(Arc<Session>, u32)> {
    let mut client = ClientBuilder::new()
        .application_name("softplc-bench")
        .application_uri("urn:softplc-bench")
        .pki_dir(pki)
        .create_sample_keypair(false)
        .trust_server_certs(true)
        .session_retry_limit(3)
        // One publish carries every tag's initial value and the changes of a publishing
        // interval, over the client's default limit of 1000 array elements, which would
        // close the connection (the client then stops publishing after it reconnects).
        .max_array_length(MAX_ARRAY)
        .max_message_size(MAX_MESSAGE)
        .max_chunk_count(MAX_MESSAGE / MIN_CHUNK)
        .client()
        .map_err(|e| anyhow!("the OPC UA client's configuration: {}", e.join("; ")))?;
    let endpoint: EndpointDescription = (
        url,
        "None",
        MessageSecurityMode::None,
        UserTokenPolicy::anonymous(),
    )
        .into();
    let (session, event_loop) = client
        .connect_to_matching_endpoint(endpoint, IdentityToken::Anonymous)
        .await
        .with_context(|| format!("cannot connect to {url}"))?;
    // The event loop ends with the session; its result says nothing the counts do not.
    drop(event_loop.spawn());
    if !session.wait_for_connection().await {
        bail!("no session with {url}");
    }
    let ns = session
        .get_namespace_index(namespace)
        .await
        .with_context(|| format!("no namespace {namespace}"))?;
    let on_status = counts.clone();
    let callback = SubscriptionCallbacks::new(
        move |_| {
            let mut c = on_status.lock().unwrap_or_else(|p| p.into_inner());
            c.status_changes += 1;
        },
        move |value: DataValue, item| {
            let tag = item.client_handle().wrapping_sub(1) as usize;
            let mut c = counts.lock().unwrap_or_else(|p| p.into_inner());
            c.values += 1;
            if value.status.is_some_and(|s| s.overflow()) {
                c.overflow += 1;
            }
            match value.value {
                Some(Variant::Int32(v)) => c.check.observe(tag, i64::from(v)),
                _ => c.without_value += 1,
            }
        },
        // No event is monitored.
        |_, _| {},
    );
    let subscription = session
        .create_subscription(request.publishing, 600, 30, 0, 0, true, callback)
        .await
        .context("CreateSubscription failed")?;
    let mut granted = u32::MAX;
    let items: Vec<MonitoredItemCreateRequest> = (0..request.tags)
        .map(|i| {
            let node = NodeId::new(ns, format!("Tags.c{i}"));
            MonitoredItemCreateRequest::new(
                ReadValueId::from(node),
                MonitoringMode::Reporting,
                MonitoringParameters {
                    // The tag's index + 1: the client library numbers a 0 itself.
                    client_handle: u32::try_from(i + 1).unwrap_or(u32::MAX),
                    sampling_interval: 0.0,
                    filter: ExtensionObject::null(),
                    queue_size: request.queue,
                    discard_oldest: true,
                },
            )
        })
        .collect();
    for chunk in items.chunks(ITEMS_PER_CALL) {
        let created = session
            .create_monitored_items(subscription, TimestampsToReturn::Both, chunk.to_vec())
            .await
            .context("CreateMonitoredItems failed")?;
        for (item, asked) in created.iter().zip(chunk) {
            let status = item.result.status_code;
            if !status.is_good() {
                bail!(
                    "monitored item {} refused: {status}",
                    asked.item_to_monitor.node_id
                );
            }
            granted = granted.min(item.result.revised_queue_size);
        }
    }
    Ok((session, granted))
}
