//! What the end-to-end tests that run servers and third-party clients share: the workspace's
//! folder, a free loopback port, a child's output as lines.
// Each test binary uses its own share of these.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver};

/// The workspace's root folder.
pub(crate) fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Runs the `softplc` binary with `args` from the workspace's folder (log level warn) and
/// returns whether it succeeded and what it printed (standard output, then standard error).
pub(crate) fn softplc(args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(args)
        .current_dir(repo())
        .env("SOFTPLC_LOG", "warn")
        .output()
        .expect("softplc runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// A port nobody listens on now (bound, then released).
pub(crate) fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The lines `r` gives, read on a thread of their own (so a test waits with a deadline).
pub(crate) fn lines_of(r: impl std::io::Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(r).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// A running `softplc run`, stopped (SIGTERM) when dropped.
pub(crate) struct Running(pub(crate) std::process::Child);

impl Drop for Running {
    fn drop(&mut self) {
        #[allow(unsafe_code)]
        // SAFETY: kill has no memory preconditions; the pid is our own child's.
        unsafe {
            libc::kill(self.0.id() as i32, libc::SIGTERM)
        };
        // Only reaps the child: its exit status is not what this test checks.
        drop(self.0.wait());
    }
}
