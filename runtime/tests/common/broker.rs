//! A mosquitto of a test, and the Python code a Sparkplug host needs: what the end-to-end
//! tests against a real broker share.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A mosquitto of this test: loopback only, anonymous, no persistence.
pub(crate) struct Broker {
    child: Child,
    port: u16,
    conf: PathBuf,
}

impl Broker {
    pub(crate) fn start(dir: &Path, port: u16) -> Self {
        Self::start_with(dir, port, "")
    }

    /// With `extra` configuration lines for the listener (TLS, a password file: then no
    /// anonymous access).
    pub(crate) fn start_with(dir: &Path, port: u16, extra: &str) -> Self {
        let conf = dir.join("mosquitto.conf");
        let anonymous = !extra.contains("password_file");
        std::fs::write(
            &conf,
            format!(
                "listener {port} 127.0.0.1\n{extra}allow_anonymous {anonymous}\npersistence false\n"
            ),
        )
        .unwrap();
        let child = Command::new("mosquitto")
            .arg("-c")
            .arg(&conf)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| {
                panic!("cannot start mosquitto ({e}): scripts/test installs it (apt: mosquitto)")
            });
        let deadline = Instant::now() + Duration::from_secs(10);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                Instant::now() < deadline,
                "mosquitto did not listen on {port}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        Self { child, port, conf }
    }

    /// Stops the broker, runs `while_away`, and starts it again on the same port.
    pub(crate) fn restart_after(&mut self, while_away: impl FnOnce()) {
        // The child may have exited already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
        while_away();
        let dir = self.conf.parent().unwrap().to_path_buf();
        let extra = std::fs::read_to_string(&self.conf).unwrap_or_default();
        let extra: String = extra
            .lines()
            .filter(|l| {
                l.starts_with("cafile") || l.starts_with("certfile") || l.starts_with("keyfile")
            })
            .map(|l| format!("{l}\n"))
            .collect();
        *self = Broker::start_with(&dir, self.port, &extra);
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        // The child may have exited already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

/// Generates the Python protobuf module of `runtime/proto/sparkplug_b.proto` (Eclipse Tahu's)
/// into `dir/py` with `python`'s grpc_tools; that folder.
pub(crate) fn sparkplug_pb2(python: &Path, dir: &Path) -> PathBuf {
    let pb2 = dir.join("py");
    std::fs::create_dir_all(&pb2).unwrap();
    let proto = super::host::repo().join("runtime/proto");
    let gen = Command::new(python)
        .args(["-m", "grpc_tools.protoc", "-I"])
        .arg(&proto)
        .arg(format!("--python_out={}", pb2.display()))
        .arg(proto.join("sparkplug_b.proto"))
        .status()
        .unwrap();
    assert!(
        gen.success(),
        "grpc_tools.protoc failed on sparkplug_b.proto"
    );
    pb2
}
