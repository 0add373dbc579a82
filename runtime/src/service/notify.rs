//! `sd_notify` without libsystemd: a datagram to `$NOTIFY_SOCKET`. Outside systemd the
//! variable is unset and every call is a no-op.

use std::os::unix::net::UnixDatagram;

/// A connection to systemd's notification socket, if the service manager gave one.
#[derive(Debug)]
pub struct Notifier {
    socket: Option<(UnixDatagram, String)>,
    /// How often WATCHDOG=1 is worth sending: a quarter of systemd's `WatchdogSec`.
    watchdog_every: std::time::Duration,
    last_watchdog: Option<std::time::Instant>,
}

impl Notifier {
    /// Reads `$NOTIFY_SOCKET` (a path, or `@name` for the abstract namespace).
    pub fn from_env() -> Self {
        let socket = std::env::var("NOTIFY_SOCKET").ok().and_then(|addr| {
            let sock = UnixDatagram::unbound().ok()?;
            // The scan thread sends these: never let a stalled service manager block it.
            sock.set_nonblocking(true).ok()?;
            Some((sock, addr))
        });
        let watchdog_every = std::env::var("WATCHDOG_USEC")
            .ok()
            .and_then(|u| u.parse::<u64>().ok())
            .map_or(std::time::Duration::from_millis(250), |us| {
                std::time::Duration::from_micros(us / 4)
            });
        Self {
            socket,
            watchdog_every,
            last_watchdog: None,
        }
    }

    /// Feeds systemd's watchdog after a completed scan, at most every quarter of its period.
    pub fn watchdog(&mut self) {
        let now = std::time::Instant::now();
        if self
            .last_watchdog
            .is_some_and(|t| now.duration_since(t) < self.watchdog_every)
        {
            return;
        }
        self.last_watchdog = Some(now);
        self.notify("WATCHDOG=1");
    }

    /// Whether systemd is listening.
    pub fn enabled(&self) -> bool {
        self.socket.is_some()
    }

    /// Sends `state` (e.g. `READY=1`); errors are ignored, as sd_notify does.
    pub fn notify(&self, state: &str) {
        let Some((sock, addr)) = &self.socket else {
            return;
        };
        if let Some(name) = addr.strip_prefix('@') {
            use std::os::linux::net::SocketAddrExt;
            if let Ok(a) = std::os::unix::net::SocketAddr::from_abstract_name(name.as_bytes()) {
                // Best effort, as sd_notify(3) is: a supervisor that is gone has nobody to tell.
                drop(sock.send_to_addr(state.as_bytes(), &a));
            }
        } else {
            // Best effort, as sd_notify(3) is: a supervisor that is gone has nobody to tell.
            drop(sock.send_to(state.as_bytes(), addr));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sends_states_to_the_notify_socket() {
        let path = std::env::temp_dir().join(format!("softplc-notify-{}", std::process::id()));
        // Best effort: the test's scratch socket, possibly absent.
        drop(std::fs::remove_file(&path));
        let listener = UnixDatagram::bind(&path).unwrap();
        let mut n = Notifier {
            socket: Some((UnixDatagram::unbound().unwrap(), path.display().to_string())),
            watchdog_every: std::time::Duration::from_secs(3600),
            last_watchdog: None,
        };
        n.notify("READY=1");
        let mut buf = [0u8; 64];
        let len = listener.recv(&mut buf).unwrap();
        assert_eq!(&buf[..len], b"READY=1");
        // WATCHDOG=1 is rate-limited: the second one within the period is not sent.
        n.watchdog();
        n.watchdog();
        n.notify("STOPPING=1");
        let len = listener.recv(&mut buf).unwrap();
        assert_eq!(&buf[..len], b"WATCHDOG=1");
        let len = listener.recv(&mut buf).unwrap();
        assert_eq!(&buf[..len], b"STOPPING=1");
        // Best effort: the test's scratch socket, possibly absent.
        drop(std::fs::remove_file(&path));
    }
}
