//! Modbus TCP and RTU-over-TCP buses end to end: the seed modules' own drivers behind
//! `softplc sim`'s TCP serving ([`serve_tcp`]), one connection shared by every unit id;
//! connection refused at start-up, the server killed mid-run and back, and hostile servers
//! (silence, garbage, another transaction id, a trickle) that cost timeouts and bad replies,
//! never a panic or a stuck bus. Everything on 127.0.0.1, on free ports, bounded in time.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use softplc_io::devices::{self, Protocol};
use softplc_io::driver::Driver;
use softplc_io::line::{
    BusOwner, Discipline, InputFrame, LineFault, LineSettings, ModbusTcpTransport, Module,
    NetFraming, OutputFrame, RtuOverTcpTransport, TcpEndpoint, Transport, TxError,
};
use softplc_io::point::{Quality, Value};
use softplc_io::sim::{serve_tcp, SharedWorld, SimWorld, SERVED_LINE};
use softplc_io::time::{Clock, MonotonicClock};

const LINE: LineSettings = LineSettings::DEFAULT;
const ON: Option<Value> = Some(Value::Bool(true));
const OFF: Option<Value> = Some(Value::Bool(false));

fn clock() -> Arc<dyn Clock> {
    Arc::new(MonotonicClock::new())
}

fn driver(model: &str, address: u8) -> Box<dyn Driver> {
    let m = devices::model(model).unwrap();
    let config = m
        .device_config(
            &format!("{model}@{address}"),
            address,
            Protocol::Modbus,
            &[],
        )
        .unwrap();
    (m.driver)(&config)
}

fn point(model: &str, name: &str) -> usize {
    devices::model(model).unwrap().point_index(name).unwrap()
}

/// A MiniMod at 1 and a RESI-16DI8RO at 2 on one simulated line, and the clock every server
/// of it keeps time with (a line's time never goes back when its server is restarted).
fn world() -> (SharedWorld, Arc<dyn Clock>) {
    let mut w = SimWorld::new(vec![LINE]);
    for (model, addr) in [("minimod", 1), ("resi-16di8ro", 2)] {
        let m = devices::model(model).unwrap();
        let i = w.add_device(SERVED_LINE, &format!("{model}@{addr}"), (m.simulator)(addr));
        w.install_device_uart(i, LINE);
    }
    (w.shared(), clock())
}

fn set(world: &SharedWorld, device: usize, point: &str, on: bool) {
    world
        .lock()
        .unwrap()
        .set(device, point, Value::Bool(on))
        .unwrap();
}

fn get(world: &SharedWorld, device: usize, point: &str) -> Value {
    world.lock().unwrap().get(device, point).unwrap()
}

/// `softplc sim --tcp` / `--rtu-tcp` in a thread: stopped and joined on drop.
struct Server {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    fn start(
        listener: TcpListener,
        (world, clock): &(SharedWorld, Arc<dyn Clock>),
        framing: NetFraming,
    ) -> Self {
        let (world, clock) = (world.clone(), clock.clone());
        let addr = listener.local_addr().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            serve_tcp(listener, world, framing, LINE, clock, &flag).unwrap();
        });
        Self {
            addr,
            stop,
            thread: Some(thread),
        }
    }

    fn on_free_port(world: &(SharedWorld, Arc<dyn Clock>), framing: NetFraming) -> Self {
        Self::start(TcpListener::bind("127.0.0.1:0").unwrap(), world, framing)
    }

    fn kill(mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.join().unwrap();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            drop(t.join());
        }
    }
}

fn endpoint(framing: NetFraming, addr: SocketAddr) -> TcpEndpoint {
    TcpEndpoint {
        framing,
        host: addr.ip().to_string(),
        port: addr.port(),
    }
}

fn discipline() -> Discipline {
    Discipline {
        response_timeout: Duration::from_millis(300),
        retries: 0,
        fail_limit: 3,
        // Short, so recovery shows within a test's time; bounded and doubling as in a project.
        reconnect_min: Duration::from_millis(50),
        reconnect_max: Duration::from_millis(400),
        ..Discipline::default()
    }
}

fn transport(framing: NetFraming, addr: SocketAddr) -> Box<dyn Transport> {
    let e = endpoint(framing, addr);
    match framing {
        NetFraming::ModbusTcp => {
            Box::new(ModbusTcpTransport::new(e, Duration::from_secs(1), clock()).unwrap())
        }
        NetFraming::RtuOverTcp => Box::new(RtuOverTcpTransport::new(
            e,
            LINE,
            Duration::from_secs(1),
            clock(),
        )),
    }
}

fn owner(framing: NetFraming, addr: SocketAddr) -> BusOwner {
    let modules = vec![
        Module::new("mm1", driver("minimod", 1)),
        Module::new("r2", driver("resi-16di8ro", 2)),
    ];
    BusOwner::new("gw", transport(framing, addr), discipline(), modules)
}

/// Outputs: MiniMod Y1 and RESI RO1.
fn outputs(y1: bool, ro1: bool) -> OutputFrame {
    let mut mm = vec![None; devices::model("minimod").unwrap().points.len()];
    mm[point("minimod", "Y1")] = Some(Value::Bool(y1));
    let mut resi = vec![None; devices::model("resi-16di8ro").unwrap().points.len()];
    resi[point("resi-16di8ro", "RO1")] = Some(Value::Bool(ro1));
    OutputFrame {
        modules: vec![mm, resi],
    }
}

fn x1(f: &InputFrame) -> Option<Value> {
    f.modules[0].values[point("minimod", "X1")]
}

fn di1(f: &InputFrame) -> Option<Value> {
    f.modules[1].values[point("resi-16di8ro", "DI1")]
}

/// Reads until every module is `quality`, at most `within`; the last frame.
fn read_until(owner: &mut BusOwner, quality: Quality, within: Duration) -> InputFrame {
    let deadline = Instant::now() + within;
    loop {
        let f = owner.read_inputs();
        if f.modules.iter().all(|m| m.quality == quality) {
            return f;
        }
        assert!(
            Instant::now() < deadline,
            "not {quality:?} within {within:?}: {:?}",
            f.modules
                .iter()
                .map(|m| (m.quality, m.last_error))
                .collect::<Vec<_>>()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn reads_and_writes_through(framing: NetFraming) {
    let sim = world();
    let world = &sim.0;
    let server = Server::on_free_port(&sim, framing);
    let mut owner = owner(framing, server.addr);
    owner.startup().unwrap();
    let f = read_until(&mut owner, Quality::Good, Duration::from_secs(3));
    assert_eq!((x1(&f), di1(&f)), (OFF, OFF));

    set(world, 0, "X1", true);
    set(world, 1, "DI1", true);
    std::thread::sleep(Duration::from_millis(30)); // the modules' own input filters
    let f = owner.read_inputs();
    assert_eq!((x1(&f), di1(&f)), (ON, ON), "{:?}", f.modules[0].last_error);

    let report = owner.write_outputs(&outputs(true, true));
    assert_eq!(report.failures, 0, "{report:?}");
    assert_eq!(get(world, 0, "Y1"), Value::Bool(true));
    assert_eq!(get(world, 1, "RO1"), Value::Bool(true));
    let report = owner.write_outputs(&outputs(false, true));
    assert_eq!(report.failures, 0, "{report:?}");
    assert_eq!(get(world, 0, "Y1"), Value::Bool(false));
    let f = owner.read_inputs();
    for m in &f.modules {
        assert_eq!(m.counters.errors(), 0, "{framing:?}: {:?}", m.counters);
        assert!(m.counters.requests > 0);
    }
}

#[test]
fn seed_modules_read_and_write_behind_a_modbus_tcp_gateway() {
    reads_and_writes_through(NetFraming::ModbusTcp);
}

#[test]
fn seed_modules_read_and_write_through_a_transparent_serial_server() {
    reads_and_writes_through(NetFraming::RtuOverTcp);
}

/// A port nobody listens on now: bound, then released.
fn free_addr() -> SocketAddr {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
}

#[test]
fn a_refused_connection_leaves_the_modules_bad_until_the_server_appears() {
    for framing in [NetFraming::ModbusTcp, NetFraming::RtuOverTcp] {
        let addr = free_addr();
        let mut owner = owner(framing, addr);
        // Nobody listens: the start goes on, every module lost.
        owner.startup().unwrap();
        let f = owner.read_inputs();
        for m in &f.modules {
            assert_eq!(m.quality, Quality::Bad, "{framing:?}");
        }
        let f = read_until(&mut owner, Quality::Bad, Duration::from_secs(1));
        let refused = f.modules.iter().any(|m| {
            m.last_error
                == Some(TxError::Line(LineFault::Connect(
                    std::io::ErrorKind::ConnectionRefused,
                )))
        });
        assert!(
            refused,
            "{framing:?}: {:?}",
            f.modules.iter().map(|m| m.last_error).collect::<Vec<_>>()
        );
        // The server appears on that port: the modules run their start-up and come back.
        let sim = world();
        let world = &sim.0;
        set(world, 0, "X1", true);
        std::thread::sleep(Duration::from_millis(30)); // the MiniMod's input filter
        let _server = Server::start(TcpListener::bind(addr).unwrap(), &sim, framing);
        let f = read_until(&mut owner, Quality::Good, Duration::from_secs(5));
        assert_eq!(x1(&f), ON, "{framing:?}");
        let report = owner.write_outputs(&outputs(true, false));
        assert_eq!(report.failures, 0, "{framing:?}: {report:?}");
        assert_eq!(get(world, 0, "Y1"), Value::Bool(true), "{framing:?}");
    }
}

#[test]
fn a_server_killed_mid_run_turns_the_modules_bad_and_they_recover_when_it_is_back() {
    for framing in [NetFraming::ModbusTcp, NetFraming::RtuOverTcp] {
        let sim = world();
        let world = &sim.0;
        let server = Server::on_free_port(&sim, framing);
        let addr = server.addr;
        let mut owner = owner(framing, addr);
        owner.startup().unwrap();
        read_until(&mut owner, Quality::Good, Duration::from_secs(3));

        server.kill();
        // Stale first (last values kept), then bad once lost; never a panic, each read bounded.
        let started = Instant::now();
        let f = owner.read_inputs();
        assert!(
            f.modules.iter().all(|m| m.quality != Quality::Good),
            "{framing:?}"
        );
        let f = read_until(&mut owner, Quality::Bad, Duration::from_secs(3));
        assert_eq!(
            x1(&f),
            OFF,
            "{framing:?}: the last value is kept, marked bad"
        );
        assert!(started.elapsed() < Duration::from_secs(3));

        // Back on the same port, with X1 now on: reconnect (backoff ≤ 400 ms), restart, read.
        set(world, 0, "X1", true);
        std::thread::sleep(Duration::from_millis(30)); // the MiniMod's input filter
        let _server = Server::start(TcpListener::bind(addr).unwrap(), &sim, framing);
        read_until(&mut owner, Quality::Good, Duration::from_secs(5));
        // The simulated line's time stood still while nobody asked: the MiniMod's 20 ms input
        // filter runs from the first request after the restart.
        std::thread::sleep(Duration::from_millis(40));
        let f = owner.read_inputs();
        assert_eq!(x1(&f), ON, "{framing:?}");
        assert_eq!(f.modules[0].quality, Quality::Good);
    }
}

/// How a hostile server answers each request.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Hostile {
    /// Reads the request, answers nothing.
    Silent,
    /// Answers bytes that are not Modbus TCP.
    Garbage,
    /// Answers a well-formed reply with another transaction id.
    WrongTransaction,
    /// Answers the right reply one byte every 60 ms (past the response timeout).
    Trickle,
    /// Closes the connection at once.
    Hangup,
}

/// A Modbus TCP server on a free port that answers `mode`; counts connections.
fn hostile(mode: Hostile) -> (SocketAddr, Arc<AtomicUsize>, Arc<AtomicBool>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    listener.set_nonblocking(true).unwrap();
    let connections = Arc::new(AtomicUsize::new(0));
    let stop = Arc::new(AtomicBool::new(false));
    let (count, flag) = (connections.clone(), stop.clone());
    std::thread::spawn(move || {
        while !flag.load(Ordering::Relaxed) {
            let Ok((stream, _)) = listener.accept() else {
                std::thread::sleep(Duration::from_millis(5));
                continue;
            };
            count.fetch_add(1, Ordering::Relaxed);
            let flag = flag.clone();
            std::thread::spawn(move || serve_hostile(stream, mode, &flag));
        }
    });
    (addr, connections, stop)
}

fn serve_hostile(mut stream: TcpStream, mode: Hostile, stop: &AtomicBool) {
    stream.set_nonblocking(false).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    if mode == Hostile::Hangup {
        return;
    }
    let mut req = [0u8; 260];
    while !stop.load(Ordering::Relaxed) {
        let n = match stream.read(&mut req) {
            Ok(0) => return,
            Ok(n) => n,
            Err(_) => continue,
        };
        if n < 8 {
            continue;
        }
        // A reply the request's function accepts: FC 1/2 one byte, FC 3/4 the words asked.
        let function = req[7];
        let count = u16::from_be_bytes([req[10], req[11]]);
        let mut pdu = vec![function];
        match function {
            1 | 2 => {
                let bytes = count.div_ceil(8) as u8;
                pdu.push(bytes);
                pdu.extend(std::iter::repeat_n(0, usize::from(bytes)));
            }
            3 | 4 => {
                pdu.push((count * 2) as u8);
                pdu.extend(std::iter::repeat_n(0, usize::from(count) * 2));
            }
            _ => pdu.extend_from_slice(&req[8..12]),
        }
        let mut tid = [req[0], req[1]];
        if mode == Hostile::WrongTransaction {
            tid[1] = tid[1].wrapping_add(7);
        }
        let mut reply = vec![tid[0], tid[1], 0, 0];
        reply.extend_from_slice(&(pdu.len() as u16 + 1).to_be_bytes());
        reply.push(req[6]);
        reply.extend_from_slice(&pdu);
        let sent = match mode {
            Hostile::Silent | Hostile::Hangup => Ok(()),
            // A whole frame by its length, with a protocol id that is not Modbus's.
            Hostile::Garbage => stream.write_all(&[0xDE, 0xAD, 0xBE, 0xEF, 0x00, 0x02, 0x01, 0x83]),
            Hostile::WrongTransaction => stream.write_all(&reply),
            Hostile::Trickle => reply.iter().try_for_each(|b| {
                std::thread::sleep(Duration::from_millis(60));
                stream.write_all(&[*b])
            }),
        };
        if sent.is_err() {
            return;
        }
    }
}

#[test]
fn a_unit_the_gateway_cannot_reach_is_lost_and_keeps_the_connection() {
    let sim = world();
    let server = Server::on_free_port(&sim, NetFraming::ModbusTcp);
    // Unit 9 is not behind the gateway: it answers exception 0x0B for it.
    let modules = vec![
        Module::new("mm1", driver("minimod", 1)),
        Module::new("ghost", driver("minimod", 9)),
    ];
    let mut owner = BusOwner::new(
        "gw",
        transport(NetFraming::ModbusTcp, server.addr),
        discipline(),
        modules,
    );
    owner.startup().unwrap();
    let end = Instant::now() + Duration::from_secs(3);
    let f = loop {
        let f = owner.read_inputs();
        if f.modules[1].quality == Quality::Bad || Instant::now() > end {
            break f;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(f.modules[0].quality, Quality::Good);
    assert_eq!(f.modules[1].quality, Quality::Bad);
    // The gateway's "target device failed to respond" is the unit's silence, not a refusal.
    assert!(
        f.modules[1].counters.timeouts >= 1,
        "{:?}",
        f.modules[1].counters
    );
    assert_eq!(f.modules[1].counters.exceptions, 0);
    assert_eq!(f.modules[0].counters.errors(), 0);
}

#[test]
fn hostile_servers_cost_timeouts_and_bad_replies_never_a_stuck_bus() {
    for mode in [
        Hostile::Silent,
        Hostile::Garbage,
        Hostile::WrongTransaction,
        Hostile::Trickle,
        Hostile::Hangup,
    ] {
        let (addr, connections, stop) = hostile(mode);
        let mut owner = owner(NetFraming::ModbusTcp, addr);
        let started = Instant::now();
        // A module that answers wrongly or not at all is lost at start-up, not an error.
        owner.startup().unwrap();
        for _ in 0..4 {
            let f = owner.read_inputs();
            assert!(
                f.modules.iter().all(|m| m.quality != Quality::Good),
                "{mode:?}"
            );
            std::thread::sleep(Duration::from_millis(60));
        }
        // Every exchange is bounded by the response timeout (300 ms) or the connect timeout.
        assert!(
            started.elapsed() < Duration::from_secs(8),
            "{mode:?}: {:?}",
            started.elapsed()
        );
        let f = owner.read_inputs();
        let c = f.modules[0].counters;
        let e = f.modules[0].last_error;
        match mode {
            Hostile::Silent | Hostile::Trickle => {
                assert!(c.timeouts >= 1, "{mode:?}: {c:?}");
            }
            Hostile::Garbage | Hostile::WrongTransaction => {
                assert!(c.bad_replies >= 1, "{mode:?}: {c:?} {e:?}");
            }
            Hostile::Hangup => {
                assert!(
                    matches!(e, Some(TxError::Line(_)) | Some(TxError::PortDown)),
                    "{mode:?}: {e:?}"
                );
            }
        }
        // A miss drops the connection: a late answer never meets a later request.
        if mode != Hostile::Hangup {
            assert!(
                connections.load(Ordering::Relaxed) >= 2,
                "{mode:?}: one connection for several misses"
            );
        }
        stop.store(true, Ordering::Relaxed);
    }
}
