//! SCADA access and metrics of a running instance: a third-party Modbus TCP master (Debian's
//! `mbpoll`) reads the documented addresses of the quick-start project, writes the tags the
//! project allows and is refused the others with the documented exceptions; `GET /metrics`
//! answers the Prometheus text format. Everything listens on loopback, on free ports.

use crate::common::host::{free_port, repo};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

/// The quick start with four memory tags for SCADA and `service` (the YAML after
/// `service:`), in a scratch folder; returns the folder.
fn project(name: &str, service: &str) -> PathBuf {
    project_with(name, service, "")
}

/// [`project`] with `extra` (tag lines) after the four SCADA tags.
fn project_with(name: &str, service: &str, extra: &str) -> PathBuf {
    let dir = crate::common::host::conveyor_scratch("scada", name);
    let quickstart =
        std::fs::read_to_string(repo().join("examples/quickstart/project.yaml")).unwrap();
    // The quick start's own `service:` (its web page) makes way for the one under test.
    let quickstart = quickstart.split("\nservice:\n").next().unwrap_or_default();
    let lamp = "  - { name: lamp,         point: mm2.Y1, safe: false }\n";
    assert!(
        quickstart.contains(lamp),
        "the quick start changed:\n{quickstart}"
    );
    let text = quickstart
        .replace("../../programs/conveyor.expr", "conveyor.expr")
        .replace(
            lamp,
            &[
                lamp,
                "  - { name: speed,  type: u16, initial: 120, scada: write }\n",
                "  - { name: level,  type: f32, initial: 2.5 }\n",
                "  - { name: total,  type: i32, initial: -7, scada: { access: write, address: 10 } }\n",
                "  - { name: enable, type: bool, scada: write }\n",
                extra,
            ]
            .concat(),
        )
        + "\nservice:\n"
        + service;
    std::fs::write(dir.join("project.yaml"), text).unwrap();
    dir
}

/// `softplc run --for 10s` on the project in `dir`, with its control socket in `dir`.
fn start(dir: &Path) -> Child {
    Command::new(BIN)
        .args(["run", "--quiet", "--for", "10s", "--socket"])
        .arg(dir.join("ctl.sock"))
        .arg(dir.join("project.yaml"))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits for the run to end by itself (`--for`), killing it past a margin.
fn finish(mut child: Child) -> Output {
    let end = Instant::now() + Duration::from_secs(20);
    while Instant::now() < end {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    // The child may have exited already; then there is nothing to stop.
    drop(child.kill());
    child.wait_with_output().unwrap()
}

/// Runs `mbpoll -m tcp -p PORT -0 -1 ARGS 127.0.0.1 VALUES`: (success, stdout + stderr).
fn mbpoll(port: u16, args: &[&str], values: &[&str]) -> (bool, String) {
    let out = Command::new("mbpoll")
        .args(["-m", "tcp", "-p", &port.to_string(), "-0", "-1", "-o", "2"])
        .args(args)
        .arg("127.0.0.1")
        .args(values)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "mbpoll, the third-party Modbus master of these tests, cannot run ({e}); \
                 run scripts/test, which installs it (Debian package mbpoll)"
            )
        });
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &*String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

/// The `[address]: value` lines of mbpoll's output.
fn values(text: &str) -> Vec<(u32, String)> {
    text.lines()
        .filter_map(|l| {
            let (addr, value) = l.strip_prefix('[')?.split_once("]:")?;
            Some((addr.parse().ok()?, value.trim().to_string()))
        })
        .collect()
}

/// Reads until the instance answers (it answers 06 until its first scan is published).
fn wait_until_serving(child: &mut Child, port: u16) {
    let end = Instant::now() + Duration::from_secs(15);
    loop {
        let (ok, text) = mbpoll(port, &["-t", "1", "-r", "0", "-c", "1"], &[]);
        if ok {
            return;
        }
        if child.try_wait().unwrap().is_some() {
            let mut log = String::new();
            // Best effort: the log only adds to the panic message.
            drop(child.stderr.take().unwrap().read_to_string(&mut log));
            panic!("softplc run stopped before serving:\n{log}");
        }
        assert!(
            Instant::now() < end,
            "the Modbus TCP server never answered:\n{text}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// A tag's value as `softplc status --json` reports it.
fn status_value(dir: &Path, tag: &str) -> String {
    let out = Command::new(BIN)
        .args(["status", "--json", "--socket"])
        .arg(dir.join("ctl.sock"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let tags = status["tags"].as_array().unwrap();
    let t = tags.iter().find(|t| t["name"] == tag).unwrap();
    t["value"].as_str().unwrap().to_string()
}

fn http_get(port: u16, path: &str) -> String {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(s, "GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n").unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    out
}

#[test]
fn with_read_gaps_zero_a_block_read_across_unmapped_addresses_answers_0_there() {
    let modbus = free_port();
    let dir = project(
        "gaps",
        &format!("  modbus_tcp: {{ bind: 127.0.0.1:{modbus}, read_gaps: zero }}\n"),
    );
    let mut child = start(&dir);
    wait_until_serving(&mut child, modbus);
    // speed at 0, level at 1-2, nothing at 3..=9, total at 10-11: one block of 12.
    let (ok, text) = mbpoll(modbus, &["-t", "3", "-r", "0", "-c", "12"], &[]);
    assert!(ok, "{text}");
    let regs = values(&text);
    assert_eq!(regs.len(), 12, "{text}");
    assert_eq!(regs[0], (0, "120".to_string()), "{text}");
    assert!(regs[3..10].iter().all(|(_, v)| v == "0"), "{text}");
    // total = -7 as i32, high word first: 0xFFFF, 0xFFF9.
    assert_eq!(regs[10].1, "65535 (-1)", "{text}");
    assert_eq!(regs[11].1, "65529 (-7)", "{text}");
    // Bits past the last bool tag, in a read that holds tags: 0.
    let (ok, text) = mbpoll(modbus, &["-t", "1", "-r", "0", "-c", "9"], &[]);
    assert!(ok && values(&text).len() == 9, "{text}");
    assert_eq!(values(&text)[8], (8, "0".to_string()), "{text}");
    // A read that holds no tag at all is still refused.
    let (ok, text) = mbpoll(modbus, &["-t", "3", "-r", "3", "-c", "2"], &[]);
    assert!(!ok && text.contains("Illegal data address"), "{text}");
    drop(finish(child));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn a_third_party_master_reads_the_map_and_writes_only_writable_tags() {
    let (modbus, metrics) = (free_port(), free_port());
    let dir = project(
        "rw",
        &format!(
            "  metrics: 127.0.0.1:{metrics}\n  modbus_tcp: {{ bind: 127.0.0.1:{modbus}, writes: true }}\n"
        ),
    );
    let mut child = start(&dir);
    wait_until_serving(&mut child, modbus);

    // The map: bools in file order at bits 0..=6 (the quick start's six, then enable);
    // speed (u16) at register 0, level (f32) at 1-2, total (i32, pinned) at 10-11.
    let (ok, text) = mbpoll(modbus, &["-t", "1", "-r", "0", "-c", "7"], &[]);
    assert!(ok, "{text}");
    let bits = values(&text);
    assert_eq!(bits.len(), 7, "{text}");
    assert!(bits.iter().all(|(_, v)| v == "0" || v == "1"), "{text}");
    assert_eq!(bits[6], (6, "0".to_string()), "enable starts false: {text}");
    let (ok, text) = mbpoll(modbus, &["-t", "3", "-r", "0", "-c", "1"], &[]);
    assert!(ok && values(&text) == [(0, "120".into())], "{text}");
    let (ok, text) = mbpoll(modbus, &["-t", "3:float", "-B", "-r", "1", "-c", "1"], &[]);
    assert!(ok && values(&text) == [(1, "2.5".into())], "{text}");
    let (ok, text) = mbpoll(modbus, &["-t", "4:int", "-B", "-r", "10", "-c", "1"], &[]);
    assert!(ok && values(&text) == [(10, "-7".into())], "{text}");
    // Past the last bool, and the gap before the pinned register: no tag there.
    let (ok, text) = mbpoll(modbus, &["-t", "1", "-r", "0", "-c", "8"], &[]);
    assert!(!ok && text.contains("Illegal data address"), "{text}");
    let (ok, text) = mbpoll(modbus, &["-t", "3", "-r", "3", "-c", "1"], &[]);
    assert!(!ok && text.contains("Illegal data address"), "{text}");
    // Another unit: exception 0B.
    let (ok, text) = mbpoll(modbus, &["-a", "7", "-t", "1", "-r", "0", "-c", "1"], &[]);
    assert!(
        !ok && text.contains("Target device failed to respond"),
        "{text}"
    );

    // Writes to writable tags take effect, read back and in `softplc status`.
    let (ok, text) = mbpoll(modbus, &["-t", "4", "-r", "0"], &["555"]);
    assert!(ok, "{text}");
    let (ok, text) = mbpoll(modbus, &["-t", "3", "-r", "0", "-c", "1"], &[]);
    assert!(ok && values(&text) == [(0, "555".into())], "{text}");
    let (ok, text) = mbpoll(
        modbus,
        &["-t", "4:int", "-B", "-r", "10"],
        &["--", "-123456"],
    );
    assert!(ok, "{text}");
    let (ok, text) = mbpoll(modbus, &["-t", "0", "-r", "6"], &["1"]);
    assert!(ok, "{text}");
    let (ok, text) = mbpoll(modbus, &["-t", "1", "-r", "6", "-c", "1"], &[]);
    assert!(ok && values(&text) == [(6, "1".into())], "{text}");
    assert_eq!(status_value(&dir, "speed"), "555");
    assert_eq!(status_value(&dir, "total"), "-123456");
    assert_eq!(status_value(&dir, "enable"), "1");

    // Read-only tags, half of a two-register tag and unmapped addresses: exception 02.
    for (args, vals) in [
        (&["-t", "4:float", "-B", "-r", "1"][..], &["9.5"][..]),
        (&["-t", "0", "-r", "0"], &["1"]),
        (&["-t", "4", "-r", "11"], &["1"]),
        (&["-t", "4", "-r", "3"], &["1"]),
    ] {
        let (ok, text) = mbpoll(modbus, args, vals);
        assert!(
            !ok && text.contains("Illegal data address"),
            "{args:?}: {text}"
        );
    }
    assert_eq!(status_value(&dir, "level"), "2.5");

    // The metrics endpoint.
    let m = http_get(metrics, "/metrics");
    assert!(m.starts_with("HTTP/1.1 200 OK\r\n"), "{m}");
    assert!(m.contains("Content-Type: text/plain; version=0.0.4"), "{m}");
    for needle in [
        "\nsoftplc_scans_total ",
        "\nsoftplc_overruns_total ",
        "\nsoftplc_cycle_seconds{quantile=\"0.99\"} ",
        "\nsoftplc_read_seconds_count ",
        "\nsoftplc_lateness_seconds_sum ",
        "\nsoftplc_module_requests_total{module=\"mm1\",bus=\"line1\"} ",
        "\nsoftplc_module_timeouts_total{module=\"mm2\",bus=\"line1\"} ",
        "\nsoftplc_module_quality{module=\"mm1\",bus=\"line1\"} 0\n",
        "\nsoftplc_tag_value{tag=\"speed\"} 555\n",
        "\nsoftplc_tag_forced{tag=\"motor\"} 0\n",
    ] {
        assert!(m.contains(needle), "no {needle:?} in\n{m}");
    }
    assert!(http_get(metrics, "/nothing").starts_with("HTTP/1.1 404"));

    let out = finish(child);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(
        log.contains(&format!("Modbus TCP server on 127.0.0.1:{modbus}"))
            && log.contains(&format!("metrics at http://127.0.0.1:{metrics}/metrics")),
        "{log}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

#[test]
fn writes_are_refused_unless_the_project_allows_them() {
    let modbus = free_port();
    let dir = project(
        "ro",
        &format!("  modbus_tcp: {{ bind: 127.0.0.1:{modbus} }}\n"),
    );
    let mut child = start(&dir);
    wait_until_serving(&mut child, modbus);
    // `speed` is `scada: write`, but the project-wide switch is off: exception 01.
    let (ok, text) = mbpoll(modbus, &["-t", "4", "-r", "0"], &["555"]);
    assert!(!ok && text.contains("Illegal function"), "{text}");
    let (ok, text) = mbpoll(modbus, &["-t", "0", "-r", "6"], &["1"]);
    assert!(!ok && text.contains("Illegal function"), "{text}");
    assert_eq!(status_value(&dir, "speed"), "120");
    let (ok, text) = mbpoll(modbus, &["-t", "4", "-r", "0", "-c", "1"], &[]);
    assert!(ok && values(&text) == [(0, "120".into())], "{text}");
    let out = finish(child);
    assert!(out.status.success(), "{out:?}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// A Modbus TCP request for the most registers one reply carries, 125 from 0, transaction
/// `t`: 12 bytes that ask for 259 (see [`wide`]).
fn read_registers(t: u16) -> [u8; 12] {
    let [hi, lo] = t.to_be_bytes();
    [hi, lo, 0, 0, 0, 6, 1, 0x03, 0, 0, 0, 125]
}

/// Length of the reply to [`read_registers`].
const REPLY: usize = 7 + 2 + 2 * 125;

/// 125 more u16 tags, so registers 0..125 are all mapped (with `speed`, `level`, `total`).
fn wide() -> String {
    (0..125)
        .map(|i| format!("  - {{ name: r{i}, type: u16, initial: {i} }}\n"))
        .collect()
}

/// Connects, sends one read and waits up to `wait` for its whole reply: whether it came.
fn served(port: u16, wait: Duration) -> bool {
    let Ok(mut c) = TcpStream::connect(("127.0.0.1", port)) else {
        return false;
    };
    // Only a zero `wait` is refused, and that would block this probe forever.
    c.set_read_timeout(Some(wait))
        .expect("a nonzero probe timeout");
    if c.write_all(&read_registers(7)).is_err() {
        return false;
    }
    let mut reply = [0u8; REPLY];
    c.read_exact(&mut reply).is_ok() && reply[..2] == [0, 7] && reply[7] == 0x03
}

/// Shrinks the kernel buffers of `c` (the kernel doubles the value), so a client that does
/// not read fills them, and the server's, within a few thousand requests.
fn small_buffers(c: &TcpStream) {
    use std::os::fd::AsRawFd;
    for option in [libc::SO_SNDBUF, libc::SO_RCVBUF] {
        let size: libc::c_int = 4096;
        #[allow(unsafe_code)]
        // SAFETY: the fd is `c`'s open socket; the value is a c_int of the length given.
        let rc = unsafe {
            libc::setsockopt(
                c.as_raw_fd(),
                libc::SOL_SOCKET,
                option,
                std::ptr::from_ref(&size).cast(),
                std::mem::size_of::<libc::c_int>() as libc::socklen_t,
            )
        };
        assert_eq!(rc, 0, "{}", std::io::Error::last_os_error());
    }
}

/// Writes requests on `c` without ever reading, until the server stops taking them (its
/// receive side is full because it is stuck sending replies nobody reads) or closes the
/// connection. Returns the bytes written; fails past `cap` bytes.
fn flood(c: &mut TcpStream, cap: usize) -> usize {
    c.set_nonblocking(true).unwrap();
    let frames: Vec<u8> = (0..256u16).flat_map(read_registers).collect();
    let (mut sent, mut at) = (0usize, 0usize);
    let mut stuck_since: Option<Instant> = None;
    loop {
        match c.write(&frames[at..]) {
            Ok(n) => {
                sent += n;
                at = (at + n) % frames.len();
                stuck_since = None;
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                let since = *stuck_since.get_or_insert_with(Instant::now);
                if since.elapsed() > Duration::from_millis(300) {
                    return sent;
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            // Reset or closed by the server: it is done with this client already.
            Err(_) => return sent,
        }
        assert!(
            sent < cap,
            "the server took {sent} bytes and never pushed back"
        );
    }
}

#[test]
fn clients_that_never_read_their_replies_lose_their_slots() {
    let modbus = free_port();
    let dir = project_with(
        "flood",
        &format!(
            "  modbus_tcp: {{ bind: 127.0.0.1:{modbus}, idle_timeout: 1s, send_timeout: 1s }}\n"
        ),
        &wide(),
    );
    let mut child = start(&dir);
    wait_until_serving(&mut child, modbus);

    // Sixteen clients, the most the server takes, each sending requests and never reading
    // the replies until the server stops reading them, then silent (kept open).
    let floods: Vec<_> = (0..16)
        .map(|_| {
            std::thread::spawn(move || {
                let mut c = TcpStream::connect(("127.0.0.1", modbus)).unwrap();
                small_buffers(&c);
                let sent = flood(&mut c, 64 << 20);
                (c, sent)
            })
        })
        .collect();
    let clients: Vec<(TcpStream, usize)> = floods.into_iter().map(|t| t.join().unwrap()).collect();
    assert!(clients.iter().all(|(_, sent)| *sent > 0));

    // A seventeenth client is served once the server has given up on them: within the send
    // timeout (1 s) and the idle timeout (1 s) of their last request, with a generous margin.
    let silent = Instant::now();
    let bound = Duration::from_secs(15);
    while !served(modbus, Duration::from_secs(1)) {
        assert!(
            silent.elapsed() < bound,
            "no client served {bound:?} after 16 clients fell silent"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    drop(clients);

    // A client that sends its request byte by byte, slower than the idle timeout allows for
    // a whole one, is disconnected without an answer; bytes that do not complete a request do
    // not restart the clock.
    let mut slow = TcpStream::connect(("127.0.0.1", modbus)).unwrap();
    slow.set_read_timeout(Some(Duration::from_millis(10)))
        .unwrap();
    let started = Instant::now();
    let mut closed = false;
    for b in read_registers(9) {
        if slow.write_all(&[b]).is_err() {
            closed = true;
            break;
        }
        std::thread::sleep(Duration::from_millis(250));
        let mut one = [0u8; 1];
        match slow.read(&mut one) {
            Ok(0) => {
                closed = true;
                break;
            }
            Ok(_) => panic!("a reply to a request dribbled over 3 s"),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
            Err(_) => {
                closed = true;
                break;
            }
        }
    }
    if !closed {
        // All twelve bytes went out (over at least 3 s): the server must not answer them.
        slow.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut rest = Vec::new();
        // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
        drop(slow.read_to_end(&mut rest));
        assert!(rest.is_empty(), "answered a dribbled request: {rest:?}");
    }
    assert!(started.elapsed() < Duration::from_secs(10));
    // And the server still serves.
    assert!(served(modbus, Duration::from_secs(5)));

    let out = finish(child);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

#[test]
fn slow_clients_do_not_hold_up_a_scrape() {
    let metrics = free_port();
    let dir = project("slowscrape", &format!("  metrics: 127.0.0.1:{metrics}\n"));
    let mut child = start(&dir);
    let end = Instant::now() + Duration::from_secs(15);
    loop {
        if TcpStream::connect(("127.0.0.1", metrics)).is_ok() {
            break;
        }
        assert!(child.try_wait().unwrap().is_none(), "softplc run stopped");
        assert!(Instant::now() < end, "the metrics endpoint never listened");
        std::thread::sleep(Duration::from_millis(100));
    }
    // Eight clients that start a request and never finish it, and stay connected.
    let mut slow: Vec<TcpStream> = (0..8)
        .map(|_| {
            let mut c = TcpStream::connect(("127.0.0.1", metrics)).unwrap();
            c.write_all(b"GET /metr").unwrap();
            c
        })
        .collect();
    // A scrape still answers, well before their request deadline (5 s) frees anything.
    let t = Instant::now();
    let m = http_get(metrics, "/metrics");
    let took = t.elapsed();
    assert!(m.starts_with("HTTP/1.1 200 OK\r\n"), "{m}");
    assert!(m.contains("\nsoftplc_scans_total "), "{m}");
    assert!(took < Duration::from_secs(3), "a scrape took {took:?}");
    // They were being served all along: each gets its 408 at its own deadline.
    for c in &mut slow {
        c.set_read_timeout(Some(Duration::from_secs(15))).unwrap();
        let mut out = String::new();
        // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
        drop(c.read_to_string(&mut out));
        assert!(out.starts_with("HTTP/1.1 408"), "{out}");
    }
    let out = finish(child);
    assert!(out.status.success(), "{out:?}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// A remote I/O as another softplc's Modbus TCP bus sees this one: `speed` (input register 0,
/// written at holding register 0) and `enable` (discrete input 6, written at coil 6), read
/// and written through the bus owner and the transport a `port: tcp://` bus runs on.
#[derive(Debug)]
struct RemoteTags {
    values: Vec<Option<softplc_io::point::Value>>,
}

impl softplc_io::driver::Driver for RemoteTags {
    fn address(&self) -> u8 {
        1
    }

    fn plan_read(&mut self, out: &mut Vec<softplc_io::driver::Transaction>) {
        use softplc_io::modbus::Request;
        for (tag, request) in [
            Request::ReadInputRegisters { addr: 0, count: 1 },
            Request::ReadDiscreteInputs { addr: 6, count: 1 },
        ]
        .into_iter()
        .enumerate()
        {
            out.push(tx(tag as u32, request));
        }
    }

    fn plan_write(
        &mut self,
        desired: &[Option<softplc_io::point::Value>],
        _refresh: bool,
        out: &mut Vec<softplc_io::driver::Transaction>,
    ) {
        use softplc_io::modbus::Request;
        use softplc_io::point::Value;
        if let Some(Some(Value::U16(v))) = desired.first() {
            out.push(tx(10, Request::WriteSingleRegister { addr: 0, value: *v }));
        }
        if let Some(Some(Value::Bool(b))) = desired.get(1) {
            out.push(tx(11, Request::WriteSingleCoil { addr: 6, value: *b }));
        }
    }

    fn on_reply(
        &mut self,
        tag: u32,
        reply: &softplc_io::driver::Reply,
    ) -> Result<(), softplc_io::driver::DecodeError> {
        use softplc_io::driver::Reply;
        use softplc_io::modbus::Response;
        use softplc_io::point::Value;
        match (tag, reply) {
            (0, Reply::Modbus(Response::ReadInputRegisters(w))) => {
                self.values[0] = Some(Value::U16(w[0]))
            }
            (1, Reply::Modbus(Response::ReadDiscreteInputs(b))) => {
                self.values[1] = Some(Value::Bool(b[0]))
            }
            (10 | 11, Reply::Modbus(_)) => {}
            _ => return Err(softplc_io::driver::DecodeError::Unexpected { tag }),
        }
        Ok(())
    }

    fn values(&self) -> &[Option<softplc_io::point::Value>] {
        &self.values
    }

    fn reply_delay(&self) -> Duration {
        Duration::ZERO
    }
}

fn tx(tag: u32, request: softplc_io::modbus::Request) -> softplc_io::driver::Transaction {
    softplc_io::driver::Transaction {
        frame: softplc_io::driver::Outgoing::Modbus {
            unit: softplc_io::modbus::UnitId::new(1).unwrap(),
            request,
        },
        tag,
    }
}

#[test]
fn another_softplc_reads_and_writes_these_tags_as_remote_io_over_modbus_tcp() {
    use softplc_io::line::{
        BusOwner, Discipline, ModbusTcpTransport, Module, NetFraming, OutputFrame, TcpEndpoint,
    };
    use softplc_io::point::{Quality, Value};
    use softplc_io::time::MonotonicClock;

    let modbus = free_port();
    let dir = project(
        "remote-io",
        &format!("  modbus_tcp: {{ bind: 127.0.0.1:{modbus}, writes: true }}\n"),
    );
    let mut child = start(&dir);
    wait_until_serving(&mut child, modbus);

    let endpoint = TcpEndpoint {
        framing: NetFraming::ModbusTcp,
        host: "127.0.0.1".into(),
        port: modbus,
    };
    let transport = ModbusTcpTransport::new(
        endpoint,
        Duration::from_secs(1),
        std::sync::Arc::new(MonotonicClock::new()),
    )
    .unwrap();
    let remote = Module::new(
        "plc_a",
        Box::new(RemoteTags {
            values: vec![None; 2],
        }),
    );
    let discipline = Discipline {
        response_timeout: Duration::from_millis(500),
        ..Discipline::default()
    };
    let mut owner = BusOwner::new("to_a", Box::new(transport), discipline, vec![remote]);
    owner.startup().unwrap();
    let f = owner.read_inputs();
    let m = &f.modules[0];
    assert_eq!(m.quality, Quality::Good, "{:?}", m.last_error);
    assert_eq!(
        m.values,
        vec![Some(Value::U16(120)), Some(Value::Bool(false))]
    );

    let report = owner.write_outputs(&OutputFrame {
        modules: vec![vec![Some(Value::U16(777)), Some(Value::Bool(true))]],
    });
    assert_eq!((report.transactions, report.failures), (2, 0));
    // The instance publishes a write at its next cycle boundary (100 ms period).
    let end = Instant::now() + Duration::from_secs(5);
    let f = loop {
        let f = owner.read_inputs();
        if f.modules[0].values[1] == Some(Value::Bool(true)) || Instant::now() > end {
            break f;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert_eq!(
        f.modules[0].values,
        vec![Some(Value::U16(777)), Some(Value::Bool(true))]
    );
    assert_eq!(status_value(&dir, "speed"), "777");
    assert_eq!(status_value(&dir, "enable"), "1");
    // One connection served every request.
    assert_eq!(
        f.modules[0].counters.errors(),
        0,
        "{:?}",
        f.modules[0].counters
    );
    drop(child.kill());
    drop(child.wait());
}
