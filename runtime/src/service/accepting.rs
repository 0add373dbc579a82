//! A server's taking of connections, as its service's state says it.
//!
//! Why: an accept that fails (the process out of file descriptors, the kernel out of memory)
//! is retried by every server, so no client is refused for good; but until it is taken again
//! nobody reaches the service, and the log and the state must say so rather than show it up.
//! The first failure of a series sets the service degraded with the error and logs it once;
//! the next connection taken sets it running again and says so. Only the transitions write,
//! so a server retrying every few milliseconds cannot flood the log.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use super::health::{Health, Service, ServiceState};

/// One server's report of its accepting; cloned handles share it.
#[derive(Debug, Clone)]
pub(crate) struct Accepting {
    health: Health,
    service: Service,
    failing: Arc<AtomicBool>,
}

impl Accepting {
    /// The accepting of `service`, reported in `health`.
    pub(crate) fn new(health: &Health, service: Service) -> Self {
        Self {
            health: health.clone(),
            service,
            failing: Arc::default(),
        }
    }

    /// A connection was taken: running again if accepting had failed.
    pub(crate) fn taken(&self) {
        if self.failing.swap(false, Ordering::AcqRel) {
            self.health.set(self.service, ServiceState::Running);
            tracing::warn!("{}: accepting connections again", self.service.name());
        }
    }

    /// Taking a connection failed with `error`; the server retries.
    pub(crate) fn failed(&self, error: &std::io::Error) {
        if !self.failing.swap(true, Ordering::AcqRel) {
            let why = format!("cannot accept connections ({error}); retrying");
            tracing::error!("{}: {why}", self.service.name());
            self.health.set(self.service, ServiceState::Degraded(why));
        }
    }

    /// The server ended for good: stopped, with why.
    pub(crate) fn stopped(&self, why: String) {
        tracing::error!("{}: stopped: {why}", self.service.name());
        self.health.set(self.service, ServiceState::Stopped(why));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failing_accept_degrades_the_service_until_a_connection_is_taken() {
        let health = Health::new();
        health.set(Service::Metrics, ServiceState::Running);
        let accepting = Accepting::new(&health, Service::Metrics);
        let emfile = std::io::Error::from_raw_os_error(libc::EMFILE);
        accepting.failed(&emfile);
        // A series of failures is one state (and one log line).
        accepting.clone().failed(&emfile);
        assert_eq!(
            health.state(Service::Metrics),
            ServiceState::Degraded(
                "cannot accept connections (Too many open files (os error 24)); retrying".into()
            )
        );
        accepting.taken();
        assert_eq!(health.state(Service::Metrics), ServiceState::Running);
        accepting.stopped("no listener".into());
        assert_eq!(
            health.state(Service::Metrics),
            ServiceState::Stopped("no listener".into())
        );
    }
}
