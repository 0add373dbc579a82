//! Watching a simulated module's terminal: a point of a device in the simulated world, sampled
//! every millisecond on the world's clock, turned into pulse widths.

use std::time::Duration;

use softplc::scan::DurationHistogram;
use softplc_io::point::Value;
use softplc_io::sim::SharedWorld;
use softplc_io::time::{Clock, ScanInstant};

/// The sampling period.
pub(crate) const SAMPLE: Duration = Duration::from_millis(1);

/// Samples `point` of device `device` and records the width of each complete on-pulse.
#[derive(Debug)]
pub(crate) struct PulseWatch {
    world: SharedWorld,
    device: usize,
    point: &'static str,
    rose_at: Option<ScanInstant>,
    last: bool,
    /// Widths of the complete pulses seen so far.
    pub widths: DurationHistogram,
}

impl PulseWatch {
    /// Watches `point` of `device` in `world`.
    pub(crate) fn new(world: SharedWorld, device: usize, point: &'static str) -> Self {
        Self {
            world,
            device,
            point,
            rose_at: None,
            last: false,
            widths: DurationHistogram::new(),
        }
    }

    /// Brings the world to `clock`'s now and looks at the point once.
    pub(crate) fn sample(&mut self, clock: &dyn Clock) {
        let now = clock.now();
        let on = {
            let mut w = self.world.lock().unwrap_or_else(|e| e.into_inner());
            w.advance_to(now.on_line_clock());
            matches!(w.get(self.device, self.point), Ok(Value::Bool(true)))
        };
        match (self.last, on) {
            (false, true) => self.rose_at = Some(now),
            (true, false) => {
                if let Some(rose) = self.rose_at.take() {
                    self.widths.record(now - rose);
                }
            }
            _ => {}
        }
        self.last = on;
    }

    /// Samples every [`SAMPLE`] on absolute deadlines until `until` (clock time).
    pub(crate) fn run_until(&mut self, clock: &dyn Clock, until: ScanInstant) {
        let mut next = clock.now();
        while next < until {
            clock.sleep_until(next);
            self.sample(clock);
            next += SAMPLE;
        }
    }
}

/// How the output answers an input edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Follow {
    /// The output takes the input's level (`y = x`): every edge is timed.
    Level,
    /// The output flips on a rising edge (`y = y ^ rising(x)`, an impulse relay): rising edges
    /// are timed, falling edges only played.
    Toggle,
}

/// Drives an input terminal of a simulated device and times how long an output terminal takes
/// to follow it.
#[derive(Debug)]
pub(crate) struct ReactionProbe {
    world: SharedWorld,
    device: usize,
    input: &'static str,
    output: &'static str,
    follow: Follow,
    level: bool,
    /// Input edge → output edge, for every edge the output followed.
    pub latencies: DurationHistogram,
    /// Edges the output did not follow within the timeout.
    pub missed: u64,
}

impl ReactionProbe {
    /// Probes `input` → `output` of `device` in `world`; both start low.
    pub(crate) fn new(
        world: SharedWorld,
        device: usize,
        input: &'static str,
        output: &'static str,
        follow: Follow,
    ) -> Self {
        Self {
            world,
            device,
            input,
            output,
            follow,
            level: false,
            latencies: DurationHistogram::new(),
            missed: 0,
        }
    }

    fn output_is(&self, clock: &dyn Clock, level: bool) -> bool {
        let mut w = self.world.lock().unwrap_or_else(|e| e.into_inner());
        w.advance_to(clock.line_now());
        matches!(w.get(self.device, self.output), Ok(Value::Bool(on)) if on == level)
    }

    /// Flips the input at the terminal now, then samples the output every [`SAMPLE`] until it
    /// shows the expected level or `timeout` passes: the input's level ([`Follow::Level`]), or
    /// after a rising edge the opposite of the output's level at the edge ([`Follow::Toggle`]).
    pub(crate) fn edge(&mut self, clock: &dyn Clock, timeout: Duration) {
        self.level = !self.level;
        let at = clock.now();
        let expected = {
            let mut w = self.world.lock().unwrap_or_else(|e| e.into_inner());
            w.advance_to(at.on_line_clock());
            let before = matches!(w.get(self.device, self.output), Ok(Value::Bool(true)));
            // A stimulus that never reached the terminal would time every edge out.
            if let Err(e) = w.set(self.device, self.input, Value::Bool(self.level)) {
                panic!(
                    "setting {} of simulated device {}: {e}",
                    self.input, self.device
                );
            }
            match self.follow {
                Follow::Level => self.level,
                Follow::Toggle if self.level => !before,
                Follow::Toggle => return,
            }
        };
        let mut next = at;
        while next < at + timeout {
            next += SAMPLE;
            clock.sleep_until(next);
            if self.output_is(clock, expected) {
                self.latencies.record(clock.now() - at);
                return;
            }
        }
        self.missed += 1;
    }
}
