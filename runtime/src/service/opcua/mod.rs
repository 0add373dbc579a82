//! The PLC's OPC UA server (async-opcua; the project's `service.opcua:`, see
//! [`crate::project::opcua`]).
//!
//! - [`space`]: the address space (tags, modules' and the PLC's diagnostics) and what a
//!   snapshot changes in it.
//! - [`write`]: a client's write, under the Modbus TCP server's rules.
//! - [`alarms`]: the alarms as variables under `Alarms` (no Alarms & Conditions in
//!   async-opcua 0.19), refreshed by the updater whenever an alarm changes, and their
//!   `Acknowledge`.
//!
//! Three threads: the server's (a tokio runtime with two workers: each connection and request
//! is a task), and the updater's, which takes every cycle's tag changes from the scan's change
//! feed (`crate::service::changes`), one cycle at a time and in order, and hands them to the
//! server's address space with the cycle's scan time as their source timestamp, so each
//! monitored item queues every change; the diagnostics come from the snapshot the scan
//! publishes, read once per scan period (at most every 100 ms, at least every 5 ms). The scan
//! never waits on either: it offers its changes and publishes without waiting, and a write
//! reaches it through the control channel with `try_send`.
//!
//! One endpoint, at `opc.tcp://BIND:PORT/`: SecurityPolicy None with anonymous access (loopback
//! only, enforced when the project is loaded), or Basic256Sha256 Sign & Encrypt with the
//! project's user and password. The server's certificate and private key are made at first
//! start in the PLC's state folder (`opcua-pki/own/cert.der`, `opcua-pki/private/private.pem`);
//! a client certificate the server does not know yet is put in `opcua-pki/rejected/` and is
//! trusted once moved to `opcua-pki/trusted/`. A pair that does not read (a power cut at first
//! start) is moved aside and made again (see [`pki`]); the server's state (running, or stopped
//! and why) is in the service's [`Health`].

pub(crate) mod alarms;
pub(crate) mod pki;
pub(crate) mod space;
pub(crate) mod write;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::Sender;
use opcua::server::address_space::{AccessLevel, NodeType, ObjectBuilder, VariableBuilder};
use opcua::server::diagnostics::NamespaceMetadata;
use opcua::server::node_manager::memory::{simple_node_manager, SimpleNodeManager};
use opcua::server::{
    ServerBuilder, ServerEndpoint, ServerUserToken, SubscriptionCache, ANONYMOUS_USER_TOKEN_ID,
};
use opcua::types::{DateTime, NodeId, QualifiedName};

use super::changes::{ChangeFeed, ChangeStream, Delivery, QUEUE_CYCLES};
use super::control::Envelope;
use super::health::{Health, Service, ServiceState};
use super::snapshot::SnapshotCell;
use crate::log_limit::{limited, Site};
use crate::project::opcua::{OpcUaConfig, OpcUaSecurity};
use crate::project::Project;
use space::{Layout, Updates};

/// A log site the updater can repeat every cycle (see [`crate::log_limit`]).
const NOT_UPDATED: Site = Site::new("opcua.not_updated", "OPC UA: values not updated");

/// The user token id of the project's user.
const USER_TOKEN: &str = "project-user";

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub(crate) enum OpcUaStartError {
    /// The address could not be bound.
    #[error("OPC UA server: cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The OS error.
        source: std::io::Error,
    },
    /// The PKI folder cannot be made.
    #[error("OPC UA server: cannot make its certificate folder {}: {source}", path.display())]
    Pki {
        /// The folder.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// async-opcua refused the configuration.
    #[error("OPC UA server: {0}")]
    Config(String),
    /// A thread or the runtime could not be made.
    #[error("OPC UA server: cannot start its threads: {0}")]
    Thread(std::io::Error),
    /// No usable certificate and key, even after making a new pair.
    #[error("OPC UA server: no usable certificate in {}: {reason}", path.display())]
    NoCertificate {
        /// The PKI folder.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

impl OpcUaStartError {
    /// Whether the start-up must stop: the address is the plant's interface (a wrong one is a
    /// configuration to fix); anything else leaves the PLC running with OPC UA stopped.
    pub(crate) fn is_fatal(&self) -> bool {
        matches!(self, OpcUaStartError::Bind { .. })
    }
}

/// A running server; it lives as long as the process.
#[derive(Debug)]
pub(crate) struct OpcUaServer {
    url: String,
    security: OpcUaSecurity,
    login: String,
}

/// The folder of the server's certificates: in the PLC's state folder.
pub(crate) fn pki_folder(project: &Project) -> PathBuf {
    crate::project::state::default_state_folder(&project.source).join("opcua-pki")
}

fn builder(project: &Project, cfg: &OpcUaConfig, port: u16, pki: PathBuf) -> ServerBuilder {
    let url = cfg.endpoint_url(port);
    let mut b = ServerBuilder::new()
        .application_name(format!("softplc {}", project.name))
        .application_uri(format!("urn:softplc:server:{}", project.name))
        .product_uri("urn:softplc")
        .host(cfg.host().trim_matches(['[', ']']))
        .port(port)
        .discovery_urls(vec![url])
        .pki_dir(pki)
        .create_sample_keypair(true)
        .diagnostics_enabled(false);
    let token = match &cfg.user {
        Some((user, password)) => {
            b = b.add_user_token(
                USER_TOKEN,
                ServerUserToken::user_pass(user.as_str(), password.0.as_str()),
            );
            USER_TOKEN
        }
        None => ANONYMOUS_USER_TOKEN_ID,
    };
    let tokens = [token.to_string()];
    let endpoint = match cfg.security {
        OpcUaSecurity::None => ServerEndpoint::new_none("/", &tokens),
        OpcUaSecurity::Basic256Sha256 => {
            ServerEndpoint::new_basic256sha256_sign_encrypt("/", &tokens)
        }
    };
    b = b.add_endpoint("plc", endpoint).default_endpoint("plc");
    // Changes come at the scan's cycle boundaries: a client may sample and publish as fast as
    // the scan runs (async-opcua's floor is 100 ms), and the subscriptions are checked that
    // often.
    let tick = project
        .scan
        .period
        .clamp(Duration::from_millis(10), Duration::from_millis(100));
    let limits = &mut b.limits_mut().subscriptions;
    limits.min_sampling_interval_ms = 0.0;
    limits.min_publishing_interval_ms = tick.as_secs_f64() * 1e3;
    // Every cycle's change is queued to each monitored item (sampling interval 0): a client's
    // queue of 100 at a publishing interval of 10 cycles must be honoured, not cut to
    // async-opcua's 10.
    limits.max_monitored_item_queue_size = cfg.limits.queue_size;
    limits.max_subscriptions_per_session = cfg.limits.subscriptions;
    limits.max_monitored_items_per_sub = cfg.limits.monitored_items;
    b.limits_mut().max_sessions = cfg.limits.sessions;
    b.subscription_poll_interval_ms(tick.as_millis() as u64)
}

fn build_space(
    nm: &SimpleNodeManager,
    ns: u16,
    layout: &Layout,
    writer: &Arc<write::Writer>,
    scan: &Sender<Envelope>,
) {
    let id = |s: &str| NodeId::new(ns, s.to_string());
    let mut sp = nm.address_space().write();
    for f in &layout.folders {
        let parent = f
            .parent
            .as_deref()
            .map_or_else(NodeId::objects_folder_id, id);
        let folder = ObjectBuilder::new(
            &id(&f.id),
            QualifiedName::new(ns, f.name.as_str()),
            f.name.as_str(),
        )
        .is_folder()
        .organized_by(parent);
        // What the engineer wrote about the module: a client shows it beside the folder.
        match &f.description {
            Some(d) => folder.description(d.as_str()),
            None => folder,
        }
        .insert(&mut *sp);
    }
    let diagnostics = layout
        .modules
        .iter()
        .flatten()
        .chain(&layout.plc)
        .chain(layout.tasks.iter().flatten())
        .chain(layout.alarms.iter().flatten());
    let tags = layout.tags.iter().map(|t| &t.node);
    for n in tags.chain(diagnostics) {
        let access = if n.writable {
            AccessLevel::CURRENT_READ | AccessLevel::CURRENT_WRITE
        } else {
            AccessLevel::CURRENT_READ
        };
        let variable = VariableBuilder::new(
            &id(&n.id),
            QualifiedName::new(ns, n.name.as_str()),
            n.name.as_str(),
        )
        .data_type(n.data_type)
        .value(space::initial(n.data_type).value.unwrap_or_default())
        .access_level(access)
        .user_access_level(access)
        .organized_by(id(&n.folder));
        match &n.description {
            Some(d) => variable.description(d.as_str()),
            None => variable,
        }
        .insert(&mut *sp);
        // Waiting, not Good, until the first snapshot.
        if let Some(NodeType::Variable(v)) = sp.find_mut(&id(&n.id)) {
            v.set_data_value(space::initial(n.data_type));
        }
    }
    drop(sp);
    for t in layout.tags.iter().filter(|t| t.node.writable) {
        let w = writer.clone();
        let (tag, ty) = (t.tag, t.ty);
        nm.inner()
            .add_write_callback(id(&t.node.id), move |dv, _range| w.write(tag, ty, &dv));
    }
    for n in layout.alarms.iter().flatten().filter(|n| n.writable) {
        let Some(alarm) = alarms::alarm_of(n).map(str::to_owned) else {
            continue;
        };
        let scan = scan.clone();
        nm.inner().add_write_callback(id(&n.id), move |dv, _range| {
            alarms::acknowledge(&scan, &alarm, &dv)
        });
    }
}

impl OpcUaServer {
    /// Starts the server `project` configures (`None` when it configures none), reading
    /// `snapshot` and sending writes to `scan`.
    pub(crate) fn start(
        project: &Project,
        snapshot: &SnapshotCell,
        feed: &mut ChangeFeed,
        scan: &Sender<Envelope>,
        health: &Health,
        alarms: Option<&crate::service::alarms::Alarms>,
    ) -> Result<Option<Self>, OpcUaStartError> {
        let Some(cfg) = project.service.opcua.clone() else {
            return Ok(None);
        };
        let bind = SocketAddr::new(cfg.bind, cfg.port);
        let listener = std::net::TcpListener::bind(bind)
            .and_then(|l| l.set_nonblocking(true).map(|()| l))
            .map_err(|source| OpcUaStartError::Bind { addr: bind, source })?;
        let addr = listener
            .local_addr()
            .map_err(|source| OpcUaStartError::Bind { addr: bind, source })?;
        let pki = pki_folder(project);
        std::fs::create_dir_all(&pki).map_err(|source| OpcUaStartError::Pki {
            path: pki.clone(),
            source,
        })?;
        let checked = pki::check_own_pair(&pki).map_err(|source| OpcUaStartError::Pki {
            path: pki.clone(),
            source,
        })?;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("opcua")
            .enable_all()
            .build()
            .map_err(OpcUaStartError::Thread)?;
        // async-opcua starts tasks of its own while it is built.
        let _in_runtime = runtime.enter();
        let namespace = format!("{}{}", space::NAMESPACE_PREFIX, project.name);
        let (server, handle) = builder(project, &cfg, addr.port(), pki.clone())
            .with_node_manager(simple_node_manager(
                NamespaceMetadata {
                    namespace_uri: namespace.clone(),
                    ..Default::default()
                },
                "softplc",
            ))
            .build()
            .map_err(OpcUaStartError::Config)?;
        // async-opcua made the pair if there was none; whatever it has now must be sound.
        match pki::check_own_pair(&pki) {
            Ok(pki::OwnPair::Sound) => {}
            Ok(pki::OwnPair::MovedAside { reason, .. }) => {
                return Err(OpcUaStartError::NoCertificate { path: pki, reason })
            }
            Ok(pki::OwnPair::Absent) => {
                return Err(OpcUaStartError::NoCertificate {
                    path: pki,
                    reason: "no pair could be made".into(),
                })
            }
            Err(source) => return Err(OpcUaStartError::Pki { path: pki, source }),
        }
        if let pki::OwnPair::MovedAside { reason, kept } = &checked {
            let kept: Vec<String> = kept.iter().map(|p| p.display().to_string()).collect();
            tracing::warn!(
                "OPC UA server: its certificate or private key was damaged ({reason}); kept \
                 aside as {}; a new pair was made (certificate thumbprint {}): clients must \
                 trust the new certificate",
                kept.join(", "),
                pki::thumbprint(&pki).unwrap_or_default()
            );
        }
        let nm = handle
            .node_managers()
            .get_of_type::<SimpleNodeManager>()
            .ok_or_else(|| OpcUaStartError::Config("no node manager for the tags".into()))?;
        let ns = handle
            .get_namespace_index(&namespace)
            .ok_or_else(|| OpcUaStartError::Config("no namespace for the tags".into()))?;
        let names: Vec<String> = alarms
            .map(|a| a.all().0.into_iter().map(|v| v.name).collect())
            .unwrap_or_default();
        let layout = Layout::of(project, cfg.writes).with_alarms(&names, cfg.writes);
        let writer = Arc::new(write::Writer::new(
            project.tags.iter().map(|t| t.name.clone()).collect(),
            snapshot.clone(),
            scan.clone(),
        ));
        build_space(&nm, ns, &layout, &writer, scan);
        let server_health = health.clone();
        std::thread::Builder::new()
            .name("opcua".into())
            .spawn(move || {
                let stopped = runtime.block_on(async move {
                    match tokio::net::TcpListener::from_std(listener) {
                        Ok(l) => server.run_with(l).await.err().map(|e| e.to_string()),
                        Err(e) => Some(format!("cannot listen: {e}")),
                    }
                });
                if let Some(why) = stopped {
                    tracing::error!("OPC UA server stopped: {why}");
                    server_health.set(Service::Opcua, ServiceState::Stopped(why));
                }
            })
            .map_err(OpcUaStartError::Thread)?;
        health.set(Service::Opcua, ServiceState::Running);
        let updater = Updater {
            nm,
            subscriptions: handle.subscriptions().clone(),
            ns,
            layout,
            snapshot: snapshot.clone(),
            changes: feed.subscribe("opcua", QUEUE_CYCLES),
            written: writer.written(),
            alarms: alarms.cloned(),
            tick: project
                .scan
                .period
                .clamp(Duration::from_millis(5), Duration::from_millis(100)),
        };
        std::thread::Builder::new()
            .name("opcua-update".into())
            .spawn(move || updater.run())
            .map_err(OpcUaStartError::Thread)?;
        Ok(Some(Self {
            url: cfg.endpoint_url(addr.port()),
            security: cfg.security,
            login: cfg.login(),
        }))
    }

    /// What the log says of it: the endpoint, its security and who may log in.
    pub(crate) fn describe(&self) -> String {
        format!(
            "{} ({}, {})",
            self.url,
            self.security.describe(),
            self.login
        )
    }
}

/// The updater's thread (see the module docs).
struct Updater {
    nm: Arc<SimpleNodeManager>,
    subscriptions: Arc<SubscriptionCache>,
    ns: u16,
    layout: Layout,
    snapshot: SnapshotCell,
    changes: ChangeStream,
    /// Where the writes are noted (see [`write::WrittenAt`]).
    written: write::WrittenAt,
    /// The alarms, refreshed in the address space when their generation changes.
    alarms: Option<crate::service::alarms::Alarms>,
    tick: Duration,
}

impl Updater {
    fn run(self) {
        let mut updates = Updates::new(&self.layout);
        let ids: std::collections::HashMap<String, NodeId> = self
            .layout
            .tags
            .iter()
            .map(|t| &t.node)
            .chain(self.layout.modules.iter().flatten())
            .chain(&self.layout.plc)
            .chain(self.layout.tasks.iter().flatten())
            .chain(self.layout.alarms.iter().flatten())
            .map(|n| (n.id.clone(), NodeId::new(self.ns, n.id.clone())))
            .collect();
        let set = |values: Vec<(String, opcua::types::DataValue)>| {
            let values = values
                .into_iter()
                .filter_map(|(id, dv)| Some((ids.get(&id)?, None, dv)));
            if let Err(e) = self.nm.set_values(&self.subscriptions, values) {
                limited!(
                    WARN,
                    NOT_UPDATED,
                    e.to_string(),
                    "OPC UA: values not updated: {e}"
                );
            }
        };
        // A cycle's tag changes, but none older than a client's write of its tag: checked as
        // async-opcua takes the values, under the address space's lock, which a write holds
        // from its callback to its answer (see `write::WrittenAt`).
        let set_cycle = |d: &Delivery, values: Vec<(usize, String, opcua::types::DataValue)>| {
            let cycle = d.cycle.cycle;
            let values = values
                .into_iter()
                .filter(|(tag, _, _)| !self.written.hides(*tag, cycle))
                .filter_map(|(_, id, dv)| Some((ids.get(&id)?, None, dv)));
            if let Err(e) = self.nm.set_values(&self.subscriptions, values) {
                limited!(
                    WARN,
                    NOT_UPDATED,
                    e.to_string(),
                    "OPC UA: values not updated: {e}"
                );
            }
        };
        let mut last_stats = None;
        let mut last_alarms = None;
        // Each task's latest cycle whose changes are in the address space (the one task's
        // for a PLC of one).
        let mut task_scans = vec![0u64; self.layout.tasks.len().max(1)];
        // Cycles taken from the feed and not applied yet: until the first snapshot is in the
        // address space, so a client that sees a tag's first value sees the PLC's figures too.
        let mut held: Vec<Delivery> = Vec::new();
        loop {
            // Each cycle's changes as soon as they come, one cycle at a time and in order, so
            // every monitored item queues every change with its cycle's time.
            // The scan has ended when the feed is gone: one last pass, then stop.
            let mut ended = false;
            match self.changes.receiver().recv_timeout(self.tick) {
                Ok(d) => held.push(d),
                Err(crossbeam_channel::RecvTimeoutError::Timeout) => {}
                Err(crossbeam_channel::RecvTimeoutError::Disconnected) => ended = true,
            }
            // The snapshot before the rest of the queue: every cycle it shows is in the queue
            // already (the scan offers a cycle's changes before it publishes).
            let mut snap = self.snapshot.get();
            held.extend(self.changes.receiver().try_iter());
            at_least_delivered(&mut snap, &task_scans);
            // Every task's cycle counts in the key: a task faster than the first one moves its
            // `PLC.Tasks.NAME.Scans` with its tags, not at the first task's cycles.
            let key = (
                snap.cycles,
                snap.task_cycles.iter().sum::<u64>(),
                snap.stats_seq,
                snap.stopped,
            );
            if snap.published && last_stats != Some(key) {
                last_stats = Some(key);
                set(updates.diagnostics(&self.layout, &snap, DateTime::now()));
            }
            if last_stats.is_none() && !ended {
                continue;
            }
            let now = DateTime::now();
            let mut moved = false;
            for d in held.drain(..) {
                set_cycle(&d, updates.tag_changes(&self.layout, &d, now));
                if let Some(scans) = task_scans.get_mut(d.cycle.task) {
                    moved |= d.cycle.cycle > *scans;
                    *scans = (*scans).max(d.cycle.cycle);
                }
            }
            if moved && snap.published {
                // A task's Scans (and the first task's `PLC.Scans`) with the tags of its
                // cycle: the snapshot may lag a delivery (a task's publication skipped while a
                // reader held it).
                at_least_delivered(&mut snap, &task_scans);
                set(updates.diagnostics(&self.layout, &snap, now));
            }
            if let Some(a) = &self.alarms {
                if last_alarms != Some(a.generation()) {
                    let (views, generation) = a.all();
                    last_alarms = Some(generation);
                    set(alarms::values(&views, now));
                }
            }
            if snap.stopped || ended {
                // The last publication (outputs safe, state stopped) and the safe state's
                // changes are in the address space; clients read them until the process ends.
                return;
            }
        }
    }
}

/// `snap`'s task figures with each task's Scans at least the latest cycle of it delivered
/// (`delivered`, in task order), and `PLC.Scans` at least the first task's: a task's
/// `PLC.Tasks.NAME.Scans` never says a cycle before the one its tags in the address space
/// come from, and `PLC.Scans` never one before the first task's (it said 8 beside
/// `PLC.Tasks.main.Scans` 9 in one Read).
fn at_least_delivered(snap: &mut crate::service::ServiceSnapshot, delivered: &[u64]) {
    if let Some(&first) = delivered.first() {
        snap.cycles = snap.cycles.max(first);
    }
    for (t, &cycle) in snap.tasks.iter_mut().zip(delivered) {
        t.scans = t.scans.max(cycle);
    }
}

#[cfg(test)]
mod tests {
    use super::at_least_delivered;
    use crate::service::ServiceSnapshot;

    #[test]
    fn plc_scans_is_never_a_cycle_before_the_first_tasks_tags() {
        // The first task's cycle 9 is delivered; its publication of it was skipped.
        let mut snap = ServiceSnapshot {
            cycles: 8,
            ..ServiceSnapshot::default()
        };
        at_least_delivered(&mut snap, &[9, 65]);
        assert_eq!(snap.cycles, 9);
        // A snapshot ahead of the deliveries (a cycle that changed nothing) stays.
        at_least_delivered(&mut snap, &[7, 70]);
        assert_eq!(snap.cycles, 9);
    }
}
