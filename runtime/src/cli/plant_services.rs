//! The plant services of `softplc run` (alarms, OPC UA, metrics, Modbus TCP, MQTT, the web
//! page), started in one order and stopped in one order for a PLC of one task and for one of
//! several tasks (hosted on the first task's cycle boundary, whose image holds every tag).

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

#[cfg(feature = "mqtt")]
use anyhow::Context;
use crossbeam_channel::Sender;

use crate::clock::Clock;
use crate::plc::Plc;
use crate::project::Project;
use crate::service::alarms::AlarmService;
use crate::service::audit::AuditLog;
use crate::service::boundary::ServiceBoundary;
use crate::service::changes::ChangeFeed;
use crate::service::control::Envelope;
#[cfg(feature = "opcua")]
use crate::service::opcua::OpcUaServer;
use crate::service::task_share::TaskShare;
use crate::service::{network, snapshot, Health, TaskStatus};
#[cfg(feature = "opcua")]
use crate::service::{Service, ServiceState};

/// The services one PLC runs, and what the scan hands them (the published snapshot, the
/// change feed).
pub(super) struct PlantServices {
    /// The alarm thread, when it started.
    pub(super) alarms: Option<AlarmService>,
    #[cfg(feature = "opcua")]
    opcua: Option<OpcUaServer>,
    network: network::NetworkServices,
    #[cfg(feature = "mqtt")]
    mqtt: Option<crate::service::mqtt::MqttNode>,
    published: snapshot::SnapshotCell,
    feed: ChangeFeed,
}

impl PlantServices {
    /// The alarms, then the OPC UA server: before the modules' start-up, since making the
    /// server's key pair takes seconds on a small machine and the start-up arms the modules'
    /// watchdogs, which would fire in that time before the first scan commands them. Clients
    /// see Bad_WaitingForInitialData until the first scan. An OPC UA server that cannot start
    /// (a port taken) is logged and the PLC runs without it; a fatal error ends the run.
    pub(super) fn start_early(
        project: &Project,
        clock: &Arc<dyn Clock>,
        project_file: &Path,
        audit: Option<AuditLog>,
        health: &Health,
        requests: &Sender<Envelope>,
    ) -> anyhow::Result<Self> {
        let published = snapshot::SnapshotCell::new();
        // Every cycle's changes, for the services that must see each one (OPC UA, Sparkplug).
        let mut feed = ChangeFeed::new();
        // Before OPC UA, which publishes them under `Alarms`.
        let alarms =
            super::run::start_alarms(project, clock, project_file, &mut feed, audit, health);
        #[cfg(feature = "opcua")]
        let opcua = match OpcUaServer::start(
            project,
            &published,
            &mut feed,
            requests,
            health,
            alarms.as_ref().map(AlarmService::alarms),
        ) {
            Ok(server) => server,
            Err(e) if e.is_fatal() => return Err(e.into()),
            Err(e) => {
                // The PLC runs without it, and says why.
                tracing::error!("{e}; the PLC runs without it");
                health.set(Service::Opcua, ServiceState::Stopped(e.to_string()));
                None
            }
        };
        #[cfg(not(feature = "opcua"))]
        let _ = requests;
        Ok(Self {
            alarms,
            #[cfg(feature = "opcua")]
            opcua,
            network: network::NetworkServices::default(),
            #[cfg(feature = "mqtt")]
            mqtt: None,
            published,
            feed,
        })
    }

    /// Metrics, Modbus TCP and the MQTT edge node, once the PLC is built.
    pub(super) fn start_network(
        &mut self,
        project: &Project,
        requests: &Sender<Envelope>,
        health: &Health,
    ) -> anyhow::Result<()> {
        let alarms = self.alarms.as_ref().map(AlarmService::alarms);
        self.network = network::start(project, &self.published, requests, health, alarms)?;
        #[cfg(feature = "mqtt")]
        {
            self.mqtt = crate::service::mqtt::MqttNode::start(
                project,
                &self.published,
                &mut self.feed,
                requests,
                health,
                alarms,
            )
            .context("cannot start the MQTT edge node")?;
        }
        #[cfg(feature = "opcua")]
        if let Some(server) = &self.opcua {
            tracing::info!("OPC UA server at {}", server.describe());
        }
        Ok(())
    }

    /// The web page's starter, for `plc` (off on the virtual clock: nobody could watch it).
    pub(super) fn web_starter(
        &self,
        requests: &Sender<Envelope>,
        health: &Health,
        audit: Option<AuditLog>,
    ) -> WebStarter {
        WebStarter {
            published: self.published.clone(),
            requests: requests.clone(),
            health: health.clone(),
            records: crate::service::web::WebRecords {
                audit,
                alarms: self.alarms.as_ref().map(|a| a.alarms().clone()),
            },
        }
    }

    /// Hands the web page (when it started) to these services, which keep it until the end.
    pub(super) fn keep_web(&mut self, web: Option<crate::service::web::WebServer>) {
        self.network.web = web;
    }

    /// `boundary` publishing to the services and feeding them every cycle's changes;
    /// `web_later`: the page starts later (on a task's thread) and wants the details too.
    pub(super) fn attach(&mut self, boundary: ServiceBoundary, web_later: bool) -> ServiceBoundary {
        let boundary = self.attach_share(boundary, web_later, None, &[]);
        let feed = std::mem::take(&mut self.feed);
        match feed.is_empty() {
            true => boundary,
            false => boundary.with_feed(feed),
        }
    }

    /// Every task's boundary of a PLC of several tasks (`boundaries[i]` is task `i`'s),
    /// each publishing its share (the tags it owns, its modules, its forces) to the services
    /// and feeding them its share's changes at its own cycle end; the first task's also
    /// answers for the whole PLC (`tasks`: every task's figures, which it publishes).
    pub(super) fn attach_tasks(
        &mut self,
        boundaries: Vec<ServiceBoundary>,
        shares: Vec<TaskShare>,
        web_later: bool,
        tasks: &[TaskStatus],
    ) -> Vec<ServiceBoundary> {
        let boundaries = boundaries
            .into_iter()
            .zip(shares)
            .map(|(b, share)| {
                let feed = self.feed.share(share.clone());
                let b = self.attach_share(b, web_later, Some(share), tasks);
                match feed.is_empty() {
                    true => b,
                    false => b.with_feed(feed),
                }
            })
            .collect();
        // Each boundary holds its own end of every consumer's queue now: once the tasks have
        // ended, the consumers see the feed close.
        drop(std::mem::take(&mut self.feed));
        boundaries
    }

    /// `boundary` with the alarms' requests and the publisher (of `share` only, with several
    /// tasks; the first task's also of `tasks`' figures).
    fn attach_share(
        &self,
        mut boundary: ServiceBoundary,
        web_later: bool,
        share: Option<TaskShare>,
        tasks: &[TaskStatus],
    ) -> ServiceBoundary {
        let web = web_later || self.network.web.is_some();
        let host = share.as_ref().is_none_or(|s| s.task() == 0);
        if let (Some(a), true) = (&self.alarms, host) {
            boundary = boundary.with_alarms(a);
        }
        if web || self.network.any() || self.networked() {
            let mut publisher = snapshot::Publisher::new(self.published.clone());
            if web {
                publisher = publisher.with_details();
            }
            if host {
                publisher = publisher
                    .with_feeds(self.feed.counts())
                    .with_tasks(tasks.to_vec());
            }
            if let Some(share) = share {
                publisher = publisher.with_share(share, host);
            }
            boundary = boundary.with_publisher(publisher);
        }
        boundary
    }

    /// Whether OPC UA or MQTT runs.
    fn networked(&self) -> bool {
        #[cfg(feature = "opcua")]
        if self.opcua.is_some() {
            return true;
        }
        #[cfg(feature = "mqtt")]
        if self.mqtt.is_some() {
            return true;
        }
        false
    }

    /// After the scan: MQTT's last DATA (the safe state) and its NDEATH leave, the alarms'
    /// last changes reach their history file.
    pub(super) fn finish_services(&mut self) {
        #[cfg(feature = "mqtt")]
        if let Some(node) = self.mqtt.take() {
            node.finish(Duration::from_secs(3));
        }
        if let Some(a) = self.alarms.take() {
            a.finish(Duration::from_secs(2));
        }
    }

    /// Before the summary, once the trace is out: the page's event streams carry the last
    /// state (stopped, outputs safe) before the process goes away, so an open page says
    /// "stopped" rather than "no connection".
    pub(super) fn let_web_see_the_end(&self) {
        if self.network.web.is_some() {
            std::thread::sleep(crate::service::web::sse::TICK * 3);
        }
    }
}

/// What starting the web page needs besides the PLC: it may start on a task's own thread,
/// once that task's PLC (with several tasks: the first one built) is built.
pub(super) struct WebStarter {
    published: snapshot::SnapshotCell,
    requests: Sender<Envelope>,
    health: Health,
    records: crate::service::web::WebRecords,
}

impl WebStarter {
    /// Starts the page `plc`'s project configures; `None` when none is or it cannot listen
    /// (said in the log and the status).
    pub(super) fn start(self, plc: &Plc) -> Option<crate::service::web::WebServer> {
        self.start_from(network::WebSource::One(plc))
    }

    /// Starts the page of a PLC of several tasks (`project`, the whole project; `owner`:
    /// each tag's owning task; `parts`: each task's, in task order).
    pub(super) fn start_tasks(
        self,
        project: &Project,
        owner: &dyn Fn(usize) -> Option<usize>,
        parts: Vec<crate::service::web::TaskPart>,
    ) -> Option<crate::service::web::WebServer> {
        self.start_from(network::WebSource::Tasks {
            project,
            owner,
            parts,
        })
    }

    fn start_from(self, source: network::WebSource<'_>) -> Option<crate::service::web::WebServer> {
        network::start_web(
            source,
            &self.published,
            &self.requests,
            &self.health,
            self.records,
        )
    }
}
