//! Starting the network services a project asks for (`service:`): the metrics endpoint, the
//! Modbus TCP server and the web page, all fed by the snapshot the scan publishes.

use crossbeam_channel::Sender;

use super::accepting::Accepting;
use super::control::Envelope;
use super::health::{Health, Service, ServiceState};
use super::metrics::{MetricsInfo, MetricsServer};
use super::modbus_map::ModbusMap;
use super::modbus_tcp::{ModbusTcpServer, StartError};
use super::snapshot::SnapshotCell;
use super::web::info::WebInfo;
use super::web::WebServer;
use crate::plc::Plc;
use crate::project::Project;

/// Why a service could not start.
#[derive(Debug, thiserror::Error)]
pub(crate) enum NetworkError {
    /// The metrics endpoint.
    #[error("metrics endpoint: cannot listen on {addr}: {source}")]
    Metrics {
        /// The configured address.
        addr: std::net::SocketAddr,
        /// The OS error.
        source: std::io::Error,
    },
    /// The Modbus TCP server.
    #[error("Modbus TCP server: {0}")]
    Modbus(#[from] StartError),
}

/// The running services; they live as long as the process.
#[derive(Debug, Default)]
pub(crate) struct NetworkServices {
    /// The metrics endpoint, when configured.
    pub metrics: Option<MetricsServer>,
    /// The Modbus TCP server, when configured.
    pub modbus: Option<ModbusTcpServer>,
    /// The web page, when configured and started (see [`start_web`]).
    pub web: Option<WebServer>,
}

impl NetworkServices {
    /// Whether any service runs (and so needs the scan to publish).
    pub(crate) fn any(&self) -> bool {
        self.metrics.is_some() || self.modbus.is_some() || self.web.is_some()
    }
}

/// What the web page shows of the PLC: one task's PLC, or every task's part of a PLC of
/// several tasks.
pub(crate) enum WebSource<'a> {
    /// A PLC of one task.
    One(&'a Plc),
    /// A PLC of several tasks: the whole project, each tag's owning task, each task's part.
    Tasks {
        /// The whole project.
        project: &'a Project,
        /// Each tag's owning task (its writer, or an input's line's task).
        owner: &'a dyn Fn(usize) -> Option<usize>,
        /// Each task's part, in task order.
        parts: Vec<super::web::TaskPart>,
    },
}

/// Starts the web page `source`'s project configures, reading `snapshot` and sending forces
/// to `scan`; logs its address. A page that cannot listen is logged and left out: it is for
/// people to look at, and the machine must not wait for it (the other services are part of
/// the plant's interface and stop the start-up instead).
pub(crate) fn start_web(
    source: WebSource<'_>,
    snapshot: &SnapshotCell,
    scan: &Sender<Envelope>,
    health: &Health,
    records: super::web::WebRecords,
) -> Option<WebServer> {
    let (config, info, period) = match source {
        WebSource::One(plc) => {
            let project = plc.project();
            let config = project.service.web.as_ref()?;
            (
                config,
                WebInfo::new(plc, project, config),
                project.scan.period,
            )
        }
        WebSource::Tasks {
            project,
            owner,
            parts,
        } => {
            let config = project.service.web.as_ref()?;
            // The trend samples as often as the fastest task may change a value.
            let fastest = project.tasks.iter().map(|t| t.scan.period).min();
            let period = fastest.unwrap_or(project.scan.period);
            (
                config,
                WebInfo::of_tasks(project, config, owner, parts),
                period,
            )
        }
    };
    match WebServer::start(
        config,
        &info,
        snapshot.clone(),
        scan.clone(),
        period,
        health,
        records,
    ) {
        Ok(server) => {
            health.set(Service::Web, ServiceState::Running);
            tracing::info!(
                "web page: {} ({})",
                server.url(),
                if server.writes() {
                    "forcing with the project's token"
                } else {
                    "read-only"
                }
            );
            Some(server)
        }
        Err(e) => {
            tracing::warn!(
                "web page: cannot listen on {}: {e}; running without it",
                config.bind
            );
            health.set(
                Service::Web,
                ServiceState::Stopped(format!("cannot listen on {}: {e}", config.bind)),
            );
            None
        }
    }
}

/// Starts what `project.service` configures, reading `snapshot` and sending Modbus writes to
/// `scan`. Each started service is logged with its address.
pub(crate) fn start(
    project: &Project,
    snapshot: &SnapshotCell,
    scan: &Sender<Envelope>,
    health: &Health,
    alarms: Option<&super::alarms::Alarms>,
) -> Result<NetworkServices, NetworkError> {
    let service = &project.service;
    let names: Vec<String> = project.tags.iter().map(|t| t.name.clone()).collect();
    let mut out = NetworkServices::default();
    if let Some(addr) = service.metrics {
        let info = MetricsInfo {
            project: project.name.clone(),
            period: project.scan.period,
            tags: names.clone(),
            modules: project
                .modules
                .iter()
                .map(|m| {
                    let bus = project.buses.get(m.bus).map(|b| b.name.clone());
                    (m.name.clone(), bus.unwrap_or_default())
                })
                .collect(),
            health: health.clone(),
            alarms: alarms.cloned(),
        };
        let server = MetricsServer::start(addr, info, snapshot.clone())
            .map_err(|source| NetworkError::Metrics { addr, source })?;
        tracing::info!("metrics at http://{}/metrics", server.local_addr());
        out.metrics = Some(server);
        health.set(Service::Metrics, ServiceState::Running);
    }
    if let Some(cfg) = service.modbus_tcp {
        let map = ModbusMap::new(&service.scada).with_read_gaps(cfg.read_gaps);
        let entries = &service.scada.entries;
        let writable = entries.iter().filter(|e| e.writable).count();
        let accepting = Accepting::new(health, Service::ModbusTcp);
        let server =
            ModbusTcpServer::start(cfg, map, names, snapshot.clone(), scan.clone(), accepting)?;
        tracing::info!(
            "Modbus TCP server on {}, unit {}: {} tags mapped, writes {}",
            server.local_addr(),
            cfg.unit,
            entries.len(),
            if cfg.writes {
                format!("on ({writable} writable tags)")
            } else {
                "off".to_string()
            }
        );
        out.modbus = Some(server);
        health.set(Service::ModbusTcp, ServiceState::Running);
    }
    Ok(out)
}

/// What `softplc check` prints about the services: their addresses and the SCADA map, in
/// address order (empty when the project configures none).
pub(crate) fn report(project: &Project) -> String {
    use std::fmt::Write;
    let service = &project.service;
    let mut out = String::new();
    if let Some(addr) = service.metrics {
        let _ = writeln!(out, "\nmetrics at http://{addr}/metrics");
    }
    if let Some(web) = &service.web {
        let trend: Vec<&str> = web
            .trend
            .iter()
            .filter_map(|&t| project.tags.get(t).map(|t| t.name.as_str()))
            .collect();
        let _ = writeln!(
            out,
            "\nweb page at http://{}/ ({}); trend: {}",
            web.bind,
            if web.writes {
                "forcing with the token"
            } else {
                "read-only"
            },
            if trend.is_empty() {
                "none".to_string()
            } else {
                trend.join(", ")
            }
        );
    }
    // Without the feature, loading refused a project with `service.opcua`.
    #[cfg(feature = "opcua")]
    if let Some(o) = &service.opcua {
        let writable = service.scada.entries.iter().filter(|e| e.writable).count();
        let _ = writeln!(
            out,
            "\nOPC UA server at {} ({}, {}): {} tags, writes {}; certificate in {}",
            o.endpoint_url(o.port),
            o.security.describe(),
            o.login(),
            service.scada.entries.len(),
            if o.writes {
                format!("on ({writable} writable tags)")
            } else {
                "off".to_string()
            },
            super::opcua::pki_folder(project).display()
        );
    }
    let Some(cfg) = service.modbus_tcp else {
        return out;
    };
    let _ = writeln!(
        out,
        "\nModbus TCP on {}, unit {}, writes {} (protocol addresses, 0-based):",
        cfg.bind,
        cfg.unit,
        if cfg.writes { "on" } else { "off" }
    );
    let map = ModbusMap::new(&service.scada);
    let mut space = None;
    for (sp, address, width, tag, writable) in map.describe() {
        if space != Some(sp) {
            space = Some(sp);
            let _ = writeln!(
                out,
                "  {}",
                match sp {
                    crate::project::Space::Bits => "coil = discrete input:",
                    crate::project::Space::Registers =>
                        "holding register = input register (i32/f32: high word first):",
                }
            );
        }
        let Some(t) = project.tags.get(tag) else {
            continue;
        };
        let at = if width > 1 {
            format!("{address}-{}", u32::from(address) + u32::from(width) - 1)
        } else {
            address.to_string()
        };
        let access = if writable && cfg.writes {
            "read/write"
        } else if writable {
            "read (write when writes: true)"
        } else {
            "read"
        };
        let _ = writeln!(
            out,
            "    {at:<11} {:<16} {:<4} {access}",
            t.name,
            t.ty.name()
        );
    }
    out
}
