//! `softplc sim --pty` serving simulated modules, driven through its standard input as a
//! person would drive it: shared by the end-to-end tests that need a real serial line.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

/// A running `softplc sim --pty`.
pub(crate) struct Sim {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<String>,
}

impl Sim {
    /// Starts `bin sim --pty DEVICES…`; returns it and the pty path it printed.
    pub(crate) fn start(bin: &str, devices: &[&str]) -> (Self, String) {
        let mut child = Command::new(bin)
            .arg("sim")
            .arg("--pty")
            .args(devices)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take().unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let banner = lines
            .recv_timeout(Duration::from_secs(20))
            .expect("softplc sim prints its pty");
        let pty = banner
            .split_whitespace()
            .find(|w| w.starts_with("/dev/"))
            .unwrap_or_else(|| panic!("no pty path in {banner:?}"))
            .to_string();
        (
            Self {
                child,
                stdin,
                lines,
            },
            pty,
        )
    }

    /// Sends one command line.
    pub(crate) fn send(&mut self, command: &str) {
        writeln!(self.stdin, "{command}").unwrap();
        self.stdin.flush().unwrap();
    }

    /// `get TARGET`, and its answer line.
    pub(crate) fn get(&mut self, target: &str) -> String {
        self.send(&format!("get {target}"));
        loop {
            let line = self
                .lines
                .recv_timeout(Duration::from_secs(10))
                .expect("sim answers");
            if line.starts_with(target) || line.starts_with("error") {
                return line;
            }
        }
    }

    /// The next line of its output that starts with `prefix`, waiting at most `within`.
    pub(crate) fn wait_line(&mut self, prefix: &str, within: Duration) -> Option<String> {
        let start = Instant::now();
        while let Some(left) = within.checked_sub(start.elapsed()) {
            match self.lines.recv_timeout(left) {
                Ok(line) if line.starts_with(prefix) => return Some(line),
                Ok(_) => {}
                Err(_) => return None,
            }
        }
        None
    }

    /// Polls `target` until it reads `want`; how long that took, or `None` after `within`.
    pub(crate) fn wait_for(
        &mut self,
        target: &str,
        want: &str,
        within: Duration,
    ) -> Option<Duration> {
        let start = Instant::now();
        while start.elapsed() < within {
            if self.get(target) == format!("{target}={want}") {
                return Some(start.elapsed());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        // The child may have exited already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}
