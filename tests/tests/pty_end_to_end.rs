//! End to end through a real pseudo-terminal created in-process: the simulated MiniMod served
//! on the master end (as `softplc sim` serves it), the runtime's serial transport, bus owner
//! and MiniMod driver on the slave end. Real time: the waits are generous and nothing asserts
//! a duration.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use softplc_io::line::{
    pty_pair, BusOwner, Discipline, InputFrame, LineError, LineSettings, Module, OutputFrame,
    SerialTransport,
};
use softplc_io::point::{Quality, Value};
use softplc_io::sim::{serve, ServeStats, SharedWorld, SimWorld, SERVED_LINE};
use softplc_io::time::{Clock, MonotonicClock};
use softplc_tests::minimod::{desired, driver, model, point};

const LINE: LineSettings = LineSettings::DEFAULT;
/// Longer than the MiniMod's power-on input latency (XLATUP/XLATDN = 20 ms), with room for a
/// loaded machine.
const SETTLE: Duration = Duration::from_millis(150);

/// The simulator served on the master end until dropped.
struct Server {
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<Result<ServeStats, LineError>>>,
}

impl Server {
    /// Serves `world` on the pty's master end on a thread of its own.
    fn start(
        master: serialport::TTYPort,
        path: &str,
        world: SharedWorld,
        clock: Arc<dyn Clock>,
    ) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let handle = {
            let stop = stop.clone();
            std::thread::Builder::new()
                .name(format!("serve {path}"))
                .spawn(move || serve(master, world, LINE, clock, &stop))
                .expect("the server thread starts")
        };
        Server {
            stop,
            handle: Some(handle),
        }
    }

    fn finish(mut self) -> ServeStats {
        self.stop.store(true, Ordering::Relaxed);
        let handle = self.handle.take().expect("server running");
        handle
            .join()
            .expect("the server thread panicked")
            .expect("the server's line failed")
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            // Tests that care about the server's outcome call `finish`; here the test has
            // already failed or does not look, and a second panic in drop would abort.
            drop(h.join());
        }
    }
}

struct Rig {
    world: SharedWorld,
    device: usize,
    clock: Arc<dyn Clock>,
    owner: BusOwner,
    server: Server,
}

fn rig() -> Rig {
    let (master, slave, path) = pty_pair().expect("a pty pair");
    let mut world = SimWorld::new(vec![LINE]);
    let device = world.add_device(SERVED_LINE, "minimod@5", (model().simulator)(5));
    let world = world.shared();
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());

    let server = Server::start(master, &path, world.clone(), clock.clone());

    let transport = SerialTransport::from_port(slave, LINE, clock.clone());
    let discipline = Discipline {
        // A pty on a loaded 2-core machine can be slow to schedule the server.
        response_timeout: Duration::from_millis(500),
        retries: 2,
        ..Discipline::default()
    };
    let module = Module::new("mm5", driver("mm5", 5));
    let owner = BusOwner::new("pty", Box::new(transport), discipline, vec![module]);
    Rig {
        world,
        device,
        clock,
        owner,
        server,
    }
}

impl Rig {
    /// Sets a simulated terminal as `softplc sim`'s `set` does: at the world's current time.
    fn set(&self, name: &str, on: bool) {
        let mut w = self.world.lock().unwrap_or_else(|e| e.into_inner());
        w.advance_to(self.clock.line_now());
        w.set(self.device, name, Value::Bool(on))
            .expect("a MiniMod point");
    }

    fn get(&self, name: &str) -> Value {
        let w = self.world.lock().unwrap_or_else(|e| e.into_inner());
        w.get(self.device, name).expect("a MiniMod point")
    }

    fn read(&mut self) -> InputFrame {
        let frame = self.owner.read_inputs();
        let m = &frame.modules[0];
        assert_eq!(
            m.quality,
            Quality::Good,
            "the read over the pty failed: {:?}, counters {:?}",
            m.last_error,
            m.counters
        );
        frame
    }
}

fn value(frame: &InputFrame, name: &str) -> Option<Value> {
    frame.modules[0].values[point(name)]
}

#[test]
fn inputs_and_outputs_cross_a_real_pty() {
    let mut rig = rig();

    let frame = rig.read();
    for name in ["X1", "X2", "X3", "X9", "X10"] {
        assert_eq!(value(&frame, name), Some(Value::Bool(false)), "{name}");
    }

    // A level at terminal X1 shows after the module's input latency.
    rig.set("X1", true);
    std::thread::sleep(SETTLE);
    let frame = rig.read();
    assert_eq!(value(&frame, "X1"), Some(Value::Bool(true)));
    assert_eq!(value(&frame, "X2"), Some(Value::Bool(false)));

    // Y1 written by the bus owner is on at the module's terminal.
    assert_eq!(rig.get("Y1"), Value::Bool(false));
    let report = rig.owner.write_outputs(&OutputFrame {
        modules: vec![desired(&[("Y1", true)])],
    });
    assert_eq!(report.failures, 0, "the write over the pty failed");
    assert_eq!(rig.get("Y1"), Value::Bool(true));
    assert_eq!(rig.get("YWORD"), Value::U16(0b0001));
    assert_eq!(
        rig.owner.modules()[0].driver.values()[point("Y1")],
        Some(Value::Bool(true)),
        "the echo came back"
    );

    // And back: X1 released, Y1 off.
    rig.set("X1", false);
    std::thread::sleep(SETTLE);
    let frame = rig.read();
    assert_eq!(value(&frame, "X1"), Some(Value::Bool(false)));
    let report = rig.owner.write_outputs(&OutputFrame {
        modules: vec![desired(&[("Y1", false)])],
    });
    assert_eq!(report.failures, 0);
    assert_eq!(rig.get("Y1"), Value::Bool(false));

    let stats = rig.server.finish();
    assert_eq!(stats.noise_bytes, 0, "every byte was part of a frame");
    assert_eq!(stats.replies, stats.frames, "every request was answered");
    assert!(stats.frames >= 5, "{stats:?}");
}

/// A MiniMod at 5 served on a pty's master end, with RDELAYM set through its own text
/// command; the slave end, as a third-party master would hold it.
fn served_minimod(rdelaym: u8) -> (serialport::TTYPort, Server) {
    use std::io::Write;
    let (master, mut slave, path) = pty_pair().expect("a pty pair");
    let mut world = SimWorld::new(vec![LINE]);
    world.add_device(SERVED_LINE, "minimod@5", (model().simulator)(5));
    let world = world.shared();
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let server = Server::start(master, &path, world, clock);
    slave
        .write_all(format!("@5>RDELAYM={rdelaym}\r").as_bytes())
        .expect("the pty takes the command");
    assert_eq!(read_for(&mut slave, Duration::from_millis(500)), b"OK\r");
    (slave, server)
}

/// Whatever the slave end reads in `wait`.
fn read_for(port: &mut serialport::TTYPort, wait: Duration) -> Vec<u8> {
    use std::io::Read;
    let end = std::time::Instant::now() + wait;
    let mut got = Vec::new();
    let mut chunk = [0u8; 64];
    while let Some(left) = end.checked_duration_since(std::time::Instant::now()) {
        if serialport::SerialPort::set_timeout(port, left.max(Duration::from_millis(1))).is_err() {
            break;
        }
        match port.read(&mut chunk) {
            Ok(n) => got.extend_from_slice(&chunk[..n]),
            Err(_) => break,
        }
    }
    got
}

/// The driver's FC 2 input read of unit 5 sent in two halves `gap` apart; what comes back.
fn split_request(port: &mut serialport::TTYPort, gap: Duration) -> Vec<u8> {
    use std::io::Write;
    let request = [5u8, 0x02, 0x00, 0x00, 0x00, 0x0A, 0xF9, 0x89];
    port.write_all(&request[..4]).expect("first half");
    std::thread::sleep(gap);
    port.write_all(&request[4..]).expect("second half");
    read_for(port, Duration::from_millis(400))
}

/// MiniMod manual, "Setting the Modbus communication timeout": a request ends after a silence
/// of 28 bit times + RDELAYM. A pty gives no byte timing, so only the wide margins are
/// asserted (sim/serve.rs): a pause under half the silence is one request, one over twice it
/// two (which the module does not answer: neither half passes the CRC).
#[test]
fn a_served_minimod_frames_requests_by_its_own_silence() {
    // RDELAYM=200: 1.46 ms + 20 ms. Halves 5 ms apart are one request...
    let (mut port, server) = served_minimod(200);
    let reply = split_request(&mut port, Duration::from_millis(5));
    assert_eq!(reply.get(..3), Some(&[5u8, 0x02, 0x02][..]), "{reply:02X?}");
    // ... halves 100 ms apart are two (more than twice the silence, and long enough that a
    // loaded machine's server has read the first half before the second comes).
    let reply = split_request(&mut port, Duration::from_millis(100));
    assert!(reply.is_empty(), "{reply:02X?}");
    drop(server);
    // RDELAYM=0 at 19200: 1.46 ms; halves 50 ms apart are two requests.
    let (mut port, server) = served_minimod(0);
    let reply = split_request(&mut port, Duration::from_millis(50));
    assert!(reply.is_empty(), "{reply:02X?}");
    // The whole request is answered.
    let reply = split_request(&mut port, Duration::ZERO);
    assert_eq!(reply.len(), 7, "{reply:02X?}");
    drop(server);
}
