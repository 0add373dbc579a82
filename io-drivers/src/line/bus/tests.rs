//! The bus owner's own discipline on the virtual line (virtual clock): a failed input flush.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::*;
use crate::devices::{self, Protocol};
use crate::line::settings::LineSettings;
use crate::sim::line::{SimWorld, VirtualPort};
use crate::time::{Clock, VirtualClock};

/// The master's end of the line, whose input flush can be made to fail; counts the frames sent.
#[derive(Debug)]
struct FlakyFlush {
    inner: VirtualPort,
    fail: Arc<AtomicBool>,
    sent: Arc<Mutex<usize>>,
}

impl Transport for FlakyFlush {
    fn settings(&self) -> LineSettings {
        self.inner.settings()
    }
    fn now(&self) -> LineInstant {
        self.inner.now()
    }
    fn sync(&mut self, t: LineInstant) {
        self.inner.sync(t);
    }
    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        *self.sent.lock().unwrap() += 1;
        self.inner.write_frame(frame)
    }
    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        self.inner.read_until(buf, deadline)
    }
    fn wait_until(&mut self, t: LineInstant) {
        self.inner.wait_until(t);
    }
    fn flush_input(&mut self) -> Result<usize, LineError> {
        if self.fail.load(Ordering::Relaxed) {
            return Err(LineError::Flush(std::io::ErrorKind::BrokenPipe.into()));
        }
        self.inner.flush_input()
    }
}

#[test]
fn a_failed_flush_is_a_line_failure_counted_and_nothing_is_sent() {
    let line = LineSettings::DEFAULT;
    let model = devices::model("minimod").unwrap();
    let mut world = SimWorld::new(vec![line]);
    world.add_device(0, "mm", (model.simulator)(5));
    let config = model.device_config("mm", 5, Protocol::Modbus, &[]).unwrap();
    let driver = (model.driver)(&config);
    let clock = Arc::new(VirtualClock::new());
    let fail = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(Mutex::new(0));
    let port = FlakyFlush {
        inner: VirtualPort::new(world.shared(), 0, line, clock.clone()),
        fail: fail.clone(),
        sent: sent.clone(),
    };
    let modules = vec![Module::new("mm", driver)];
    let mut owner = BusOwner::new("line", Box::new(port), Discipline::default(), modules);
    owner.sync(clock.line_now());
    owner.startup().unwrap();
    clock.advance_to(owner.now().on_scan_clock());

    let frame = owner.read_inputs();
    assert_eq!(frame.modules[0].quality, Quality::Good);
    assert_eq!(frame.modules[0].counters.flush_failures, 0);

    fail.store(true, Ordering::Relaxed);
    let before = *sent.lock().unwrap();
    let frame = owner.read_inputs();
    let module = &frame.modules[0];
    let failure = TxError::Line(LineFault::Flush(std::io::ErrorKind::BrokenPipe));
    assert_eq!(module.last_error, Some(failure));
    assert_eq!(module.counters.flush_failures, 1);
    assert_eq!(
        *sent.lock().unwrap(),
        before,
        "a request after a failed flush could be answered by the bytes left"
    );

    // The port is taken as failed: the next cycle does not use it until it is reopened.
    clock.advance_to(owner.now().on_scan_clock() + Duration::from_millis(100));
    owner.sync(clock.line_now());
    let frame = owner.read_inputs();
    assert_eq!(frame.modules[0].last_error, Some(TxError::PortDown));
    assert_eq!(
        TxError::PortDown.to_string(),
        "line failed: the port is down"
    );
    assert_eq!(*sent.lock().unwrap(), before);
}
