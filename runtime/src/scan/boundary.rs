//! The cycle boundary: the one place where anything outside the scan touches the PLC.
//!
//! The scan knows nothing of who asks for what (a control socket, systemd, a web page): it
//! calls a [`CycleBoundary`] between two cycles, after the outputs are written and before it
//! sleeps to the next deadline, and hands it the PLC and the statistics. Whatever the boundary
//! does there never races a scan; whatever it takes is time the next cycle does not have, so
//! it must not block (long work, such as compiling a reload, belongs on a thread of its own
//! and comes back at a later boundary).

use crate::plc::Plc;
use crate::scan::{ScanInstant, ScanStats, StopReason};

/// What runs at the scan's cycle boundaries. Every method is called on the scan thread.
pub trait CycleBoundary: Send {
    /// Before the first cycle, with the PLC as built.
    fn started(&mut self, _plc: &mut Plc) {}

    /// After each completed cycle (its watchdog check passed), before the sleep to the next
    /// deadline. `now` is the end of the cycle on the PLC's clock.
    fn between_cycles(&mut self, plc: &mut Plc, stats: &ScanStats, now: ScanInstant);

    /// The run ends for `reason`; the outputs have not been driven to their safe values yet
    /// (and will not be if the run is abandoned).
    fn stopping(&mut self, _reason: &StopReason) {}

    /// The run has ended and the outputs hold their safe values; `now` is the PLC's clock.
    /// Not called when the run is abandoned (as `kill -9` would leave it).
    fn stopped(&mut self, _plc: &Plc, _stats: &ScanStats, _reason: &StopReason, _now: ScanInstant) {
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use super::*;
    use crate::clock::VirtualClock;
    use crate::scan::ScanEngine;
    use std::time::Duration;

    /// Writes down what the scan called, and when.
    struct Recorder(Arc<Mutex<Vec<String>>>);

    impl CycleBoundary for Recorder {
        fn started(&mut self, plc: &mut Plc) {
            self.0
                .lock()
                .unwrap()
                .push(format!("started {}", plc.project().name));
        }
        fn between_cycles(&mut self, plc: &mut Plc, stats: &ScanStats, now: ScanInstant) {
            self.0.lock().unwrap().push(format!(
                "between {} at {}ms",
                stats.cycles,
                now.since_origin().as_millis()
            ));
            // The boundary may change the PLC: the next cycle sees it.
            if stats.cycles == 1 {
                // The tag exists in this test's project; what matters is the next cycle seeing it.
                drop(plc.write_tags([("flag", "1")]));
            }
        }
        fn stopping(&mut self, reason: &StopReason) {
            self.0.lock().unwrap().push(format!("stopping {reason:?}"));
        }
        fn stopped(&mut self, plc: &Plc, stats: &ScanStats, _: &StopReason, _: ScanInstant) {
            let seen = plc.image().get(plc.image().id("seen").unwrap());
            self.0
                .lock()
                .unwrap()
                .push(format!("stopped after {} with seen={seen}", stats.cycles));
        }
    }

    fn plc() -> Plc {
        plc_with("b", "")
    }

    /// The test's PLC at a 10 ms period, with `scan_extra` in its `scan:` map, in a folder of
    /// its own named after `name`.
    fn plc_with(name: &str, scan_extra: &str) -> Plc {
        let dir =
            std::env::temp_dir().join(format!("softplc-boundary-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // seen follows what the boundary wrote into flag.
        std::fs::write(dir.join("b.expr"), "seen = flag\n").unwrap();
        let yaml = format!(
            "project: b\nscan:\n  period: 10ms\n{scan_extra}buses: []\nmodules: []\ntags:\n  - {{ name: flag, type: bool }}\n  - {{ name: seen, type: bool }}\nprogram: {{ file: b.expr, kind: expr }}\n"
        );
        std::fs::write(dir.join("b.yaml"), yaml).unwrap();
        let project = crate::project::load(&dir.join("b.yaml")).unwrap();
        Plc::build(project, Arc::new(VirtualClock::new())).unwrap()
    }

    #[test]
    fn the_boundary_runs_between_cycles_and_around_the_run() {
        let log = Arc::new(Mutex::new(Vec::new()));
        let outcome = ScanEngine::new(plc())
            .max_cycles(3)
            .with_boundary(Recorder(log.clone()))
            .run();
        assert_eq!(outcome.reason, StopReason::TimeUp);
        assert_eq!(
            *log.lock().unwrap(),
            [
                "started b",
                "between 1 at 0ms",
                "between 2 at 10ms",
                "between 3 at 20ms",
                "stopping TimeUp",
                "stopped after 3 with seen=1",
            ]
        );
    }

    /// A boundary that takes `0` of the PLC's clock every time (a slow trace export, a control
    /// client's large answer).
    struct Slow(Duration);

    impl CycleBoundary for Slow {
        fn between_cycles(&mut self, plc: &mut Plc, _: &ScanStats, now: ScanInstant) {
            plc.clock().sleep_until(now + self.0);
        }
    }

    #[test]
    fn the_boundary_is_a_phase_of_the_cycle() {
        // 4 ms of boundary in a 10 ms period: in time, and in the cycle's time.
        let outcome = ScanEngine::new(plc_with("timed", ""))
            .max_cycles(10)
            .with_boundary(Slow(Duration::from_millis(4)))
            .run();
        let s = &outcome.stats;
        assert_eq!((s.cycles, s.overruns), (10, 0));
        let boundary = s.boundary.percentiles();
        assert_eq!(boundary.count, 10);
        assert!(boundary.max.as_micros().abs_diff(4000) <= 4, "{boundary:?}");
        let cycle = s.cycle.percentiles();
        assert!(cycle.p50 >= Duration::from_millis(4), "{cycle:?}");
    }

    #[test]
    fn a_boundary_past_the_period_is_an_overrun() {
        // 12 ms of boundary in a 10 ms period: each cycle passes its next deadline, which is
        // skipped; the next cycle starts on the grid.
        let outcome = ScanEngine::new(plc_with("overrun", ""))
            .max_cycles(5)
            .with_boundary(Slow(Duration::from_millis(12)))
            .run();
        assert_eq!((outcome.stats.cycles, outcome.stats.overruns), (5, 5));
        assert_eq!(
            outcome.stats.last.start,
            ScanInstant::after_origin(Duration::from_millis(80))
        );
    }

    #[test]
    fn a_boundary_that_hangs_trips_the_task_watchdog() {
        let outcome = ScanEngine::new(plc_with(
            "watchdog",
            "  watchdog: { time: 30ms, sensitivity: 1 }\n",
        ))
        .max_cycles(10)
        .with_boundary(Slow(Duration::from_millis(50)))
        .run();
        assert!(
            matches!(outcome.reason, StopReason::Watchdog(_)),
            "{:?}",
            outcome.reason
        );
        assert_eq!(outcome.stats.cycles, 1);
    }
}
