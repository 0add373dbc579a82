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

    let stop = Arc::new(AtomicBool::new(false));
    let handle = {
        let (world, clock, stop) = (world.clone(), clock.clone(), stop.clone());
        std::thread::Builder::new()
            .name(format!("serve {path}"))
            .spawn(move || serve(master, world, LINE, clock, &stop))
            .expect("the server thread starts")
    };
    let server = Server {
        stop,
        handle: Some(handle),
    };

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
        w.advance_to(self.clock.now());
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
