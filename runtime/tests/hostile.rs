//! Hostile clients on every port a running PLC opens, on the real binary and the real clock
//! (the quick start): event streams that never read, slow clients on the metrics port, and
//! thousands of idle control-socket connections. While they hold on, the page, a scrape and
//! `softplc status` still answer, and the process's threads stay bounded. Out of file
//! descriptors, a server says it cannot accept and takes its clients once it can. The figures
//! are in docs/robustness.md.

use crate::common::host::repo as root;
use crate::common::host::{http_get, log_value};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::os::unix::net::UnixStream;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
/// What a page or a scrape may take while the hostile clients hold on; generous for a loaded
/// machine (they take milliseconds on a quiet one).
const ANSWER_WITHIN: Duration = Duration::from_secs(3);

/// The quick start with its page and metrics on free loopback ports, running for a minute.
struct Plc {
    child: Child,
    dir: PathBuf,
    web: String,
    metrics: String,
    socket: PathBuf,
}

impl Drop for Plc {
    fn drop(&mut self) {
        // The child may have exited already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
        // Best effort: the test's scratch folder (it may not exist).
        drop(std::fs::remove_dir_all(&self.dir));
    }
}

fn start(name: &str) -> Plc {
    let dir = std::env::temp_dir().join(format!("softplc-hostile-{name}-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    let yaml = std::fs::read_to_string(root().join("examples/quickstart/project.yaml")).unwrap();
    let yaml = crate::common::host::quickstart_plant_absolute(&yaml)
        .replace(
            "../../programs/conveyor.expr",
            root().join("programs/conveyor.expr").to_str().unwrap(),
        )
        .replace(
            "service:\n  web: { bind: 127.0.0.1:8080 }\n",
            "service:\n  web: { bind: 127.0.0.1:0 }\n  metrics: 127.0.0.1:0\n",
        );
    assert!(yaml.contains("metrics: 127.0.0.1:0"), "{yaml}");
    std::fs::write(dir.join("project.yaml"), yaml).unwrap();
    let log = dir.join("log");
    let socket = dir.join("ctl.sock");
    let child = Command::new(BIN)
        .args(["run", "--quiet", "--for", "120s", "--socket"])
        .arg(&socket)
        .arg(dir.join("project.yaml"))
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let web = log_value(&log, "web page: http://");
    let metrics = log_value(&log, "metrics at http://");
    Plc {
        child,
        dir,
        web,
        metrics,
        socket,
    }
}

impl Plc {
    /// Waits (30 s at most) for the control socket to be there.
    fn wait_for_the_control_socket(&self) {
        let begin = Instant::now();
        while !self.socket.exists() {
            assert!(
                begin.elapsed() < Duration::from_secs(30),
                "no control socket"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

fn threads(child: &Child) -> usize {
    let status = std::fs::read_to_string(format!("/proc/{}/status", child.id())).unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix("Threads:"))
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

#[test]
fn unread_event_streams_leave_the_page_answering_and_are_dropped() {
    let plc = start("sse");
    // 16 browsers that open the event stream and never read it.
    let streams: Vec<TcpStream> = (0..16)
        .map(|_| {
            let mut s = TcpStream::connect(&plc.web).unwrap();
            write!(s, "GET /api/events HTTP/1.1\r\nHost: {}\r\n\r\n", plc.web).unwrap();
            s
        })
        .collect();
    std::thread::sleep(Duration::from_millis(500));
    let mut slowest = Duration::ZERO;
    for _ in 0..10 {
        for path in ["/", "/api/state", "/api/info"] {
            let (status, took) = http_get(&plc.web, path);
            assert_eq!(status, 200, "{path} with 16 unread streams");
            slowest = slowest.max(took);
        }
    }
    assert!(slowest < ANSWER_WITHIN, "the page took {slowest:?}");
    eprintln!("page with 16 unread event streams: slowest answer {slowest:?}");
    // The streams' cap (8) is full of unread streams: a new one waits its turn, and gets it
    // once the write deadline has dropped them.
    let begin = Instant::now();
    loop {
        let mut s = TcpStream::connect(&plc.web).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        write!(s, "GET /api/events HTTP/1.1\r\nHost: {}\r\n\r\n", plc.web).unwrap();
        let mut head = [0u8; 12];
        if s.read_exact(&mut head).is_ok() && &head == b"HTTP/1.1 200" {
            break;
        }
        assert!(
            begin.elapsed() < Duration::from_secs(90),
            "unread streams were never dropped"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    eprintln!(
        "unread streams dropped, a new stream served after {:?}",
        begin.elapsed()
    );
    drop(streams);
}

#[test]
fn slow_clients_on_the_metrics_port_never_keep_a_scrape_out() {
    let plc = start("metrics");
    // 24 clients that send a few bytes of a request and then nothing.
    let slow: Vec<TcpStream> = (0..24)
        .map(|_| {
            let mut s = TcpStream::connect(&plc.metrics).unwrap();
            s.write_all(b"GET /met").unwrap();
            std::thread::sleep(Duration::from_millis(10));
            s
        })
        .collect();
    std::thread::sleep(Duration::from_millis(300));
    let mut slowest = Duration::ZERO;
    for _ in 0..18 {
        let (status, took) = http_get(&plc.metrics, "/metrics");
        assert_eq!(status, 200, "a scrape with 24 slow clients connected");
        slowest = slowest.max(took);
    }
    assert!(slowest < ANSWER_WITHIN, "a scrape took {slowest:?}");
    eprintln!("18 of 18 scrapes with 24 slow clients: slowest {slowest:?}");
    drop(slow);
}

#[test]
fn two_thousand_idle_control_connections_hold_few_threads_and_status_answers() {
    let plc = start("control");
    plc.wait_for_the_control_socket();
    let before = threads(&plc.child);
    let idle: Vec<UnixStream> = (0..2000)
        .filter_map(|_| UnixStream::connect(&plc.socket).ok())
        .collect();
    assert!(idle.len() >= 1900, "{} connected", idle.len());
    std::thread::sleep(Duration::from_millis(500));
    let during = threads(&plc.child);
    assert!(
        during <= before + 2 * 32 + 4,
        "{before} threads before, {during} with 2,000 idle connections"
    );
    let begin = Instant::now();
    let out = Command::new(BIN)
        .args(["status", "--json", "--socket"])
        .arg(&plc.socket)
        .output()
        .unwrap();
    let took = begin.elapsed();
    assert!(out.status.success(), "{out:?}");
    assert!(took < ANSWER_WITHIN, "status took {took:?}");
    eprintln!("status with 2,000 idle control connections: {took:?}, threads {before} → {during}");
    drop(idle);
}

/// Sets the soft limit of open files of process `pid` to `soft` (the hard limit unchanged);
/// the soft limit it had.
fn set_open_files(pid: u32, soft: u64) -> u64 {
    let mut old = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    #[allow(unsafe_code)]
    // SAFETY: prlimit only reads the null new limit (none) and writes `old`, valid for the call.
    let rc = unsafe {
        libc::prlimit(
            pid as libc::pid_t,
            libc::RLIMIT_NOFILE,
            std::ptr::null(),
            &mut old,
        )
    };
    assert_eq!(rc, 0, "{}", std::io::Error::last_os_error());
    let new = libc::rlimit {
        rlim_cur: soft,
        rlim_max: old.rlim_max,
    };
    #[allow(unsafe_code)]
    // SAFETY: prlimit reads `new`, valid for the call, and writes nothing (null old).
    let rc = unsafe {
        libc::prlimit(
            pid as libc::pid_t,
            libc::RLIMIT_NOFILE,
            &new,
            std::ptr::null_mut(),
        )
    };
    assert_eq!(rc, 0, "{}", std::io::Error::last_os_error());
    old.rlim_cur
}

/// The process out of file descriptors (its limit lowered to what it holds, then clients
/// connecting to the metrics port): the server cannot take them; the log says so once, with
/// the error, and the scan goes on; once there are descriptors again the waiting clients are
/// taken, the log says the server accepts again and `status` says `metrics: running`.
#[test]
fn out_of_file_descriptors_a_server_says_it_cannot_accept_and_takes_clients_again() {
    let plc = start("fds");
    plc.wait_for_the_control_socket();
    let log = plc.dir.join("log");
    let scans = || -> u64 {
        let out = Command::new(BIN)
            .args(["status", "--json", "--socket"])
            .arg(&plc.socket)
            .output()
            .unwrap();
        let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        status["scans"].as_u64().unwrap()
    };
    let before = scans();
    let pid = plc.child.id();
    let open = std::fs::read_dir(format!("/proc/{pid}/fd"))
        .unwrap()
        .count() as u64;
    let limit = set_open_files(pid, open + 2);
    let waiting: Vec<TcpStream> = (0..8)
        .filter_map(|_| TcpStream::connect(&plc.metrics).ok())
        .collect();
    let refused = crate::common::host::wait_in_log(
        &log,
        "metrics: cannot accept connections (Too many open files (os error 24)); retrying",
        Duration::from_secs(10),
    );
    // Descriptors again: the clients that waited in the backlog are taken, a scrape answers.
    set_open_files(pid, limit);
    drop(waiting);
    let (status, took) = http_get(&plc.metrics, "/metrics");
    assert_eq!(status, 200, "a scrape once descriptors are free");
    assert!(took < ANSWER_WITHIN, "a scrape took {took:?}");
    crate::common::host::wait_in_log(
        &log,
        "metrics: accepting connections again",
        Duration::from_secs(10),
    );
    let metrics = crate::common::host::service_state(&plc.socket, "metrics");
    assert_eq!(metrics["state"], "running", "{metrics}");
    assert!(scans() > before, "the scan went on");
    let text = std::fs::read_to_string(&log).unwrap();
    let lines = text
        .lines()
        .filter(|l| l.contains("metrics: cannot accept"))
        .count();
    // Once for the series, while the server retried every 10 ms (twice at most: a client
    // thread that ends frees a descriptor, and one accept goes through in between).
    assert!((1..=2).contains(&lines), "{text}");
    eprintln!("out of file descriptors: {refused}");
}
