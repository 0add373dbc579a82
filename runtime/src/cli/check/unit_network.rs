//! What the shipped systemd unit lets through: it allows loopback traffic only
//! (`IPAddressDeny=any`, `IPAddressAllow=localhost`), so a service that listens beyond this
//! machine or a peer on another one (an MQTT broker, a Modbus TCP gateway) needs the
//! addresses allowed in the drop-in the package installs, commented. `check` says so for each.

use std::net::IpAddr;

use crate::project::{PortConfig, Project};

/// The drop-in the package installs (every line commented) for the plant network's addresses.
pub(crate) const DROP_IN: &str = "/etc/systemd/system/softplc@.service.d/plant-network.conf";

/// Whether `host` (an IP literal or a name) is this machine's loopback.
fn loopback(host: &str) -> bool {
    host.eq_ignore_ascii_case("localhost")
        || host
            .trim_matches(|c| c == '[' || c == ']')
            .parse::<IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// One note per listener or peer beyond loopback, naming the project key.
pub(super) fn notes(project: &Project) -> Vec<String> {
    let service = &project.service;
    // (what, where, who must be allowed)
    let mut beyond: Vec<(String, String, &str)> = Vec::new();
    let clients = "the clients' addresses";
    if let Some(addr) = service.metrics.filter(|a| !a.ip().is_loopback()) {
        beyond.push((
            "service.metrics listens on".into(),
            addr.to_string(),
            clients,
        ));
    }
    if let Some(m) = service.modbus_tcp.filter(|m| !m.bind.ip().is_loopback()) {
        beyond.push((
            "service.modbus_tcp listens on".into(),
            m.bind.to_string(),
            clients,
        ));
    }
    if let Some(w) = service.web.as_ref().filter(|w| !w.bind.ip().is_loopback()) {
        beyond.push(("service.web listens on".into(), w.bind.to_string(), clients));
    }
    if let Some(o) = service.opcua.as_ref().filter(|o| !o.bind.is_loopback()) {
        beyond.push((
            "service.opcua listens on".into(),
            format!("{}:{}", o.bind, o.port),
            clients,
        ));
    }
    if let Some(m) = service.mqtt.as_ref().filter(|m| !loopback(&m.host)) {
        beyond.push((
            "service.mqtt's broker is".into(),
            format!("{}:{}", m.host, m.port),
            "the broker's address",
        ));
    }
    for bus in &project.buses {
        if let PortConfig::Tcp(e) = &bus.port {
            if !loopback(&e.host) {
                beyond.push((
                    format!("bus {}'s endpoint is", bus.name),
                    e.to_string(),
                    "the endpoint's address",
                ));
            }
        }
    }
    beyond
        .into_iter()
        .map(|(what, place, allow)| {
            format!(
                "note: {what} {place}, beyond this machine: the shipped systemd unit allows \
                 loopback traffic only (IPAddressDeny=any); allow {allow} with IPAddressAllow= \
                 in {DROP_IN} (installed commented), then systemctl daemon-reload"
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_is_the_names_and_addresses_of_this_machine() {
        for host in [
            "localhost",
            "127.0.0.1",
            "127.0.0.53",
            "::1",
            "[::1]",
            "LOCALHOST",
        ] {
            assert!(loopback(host), "{host}");
        }
        for host in ["10.0.0.5", "broker.plant", "0.0.0.0", "::"] {
            assert!(!loopback(host), "{host}");
        }
    }
}
