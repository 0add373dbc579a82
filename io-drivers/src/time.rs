//! Time as the whole system sees it.
//!
//! A point in time has the type of its clock, so that one clock's instant cannot meet the
//! other's (rtic's `Monotonic` is the model: an instant belongs to its clock); a span of time
//! (a period, a timeout, the time between two instants) is a [`Duration`]. Logic, lines and
//! simulators ask a [`Clock`] instead of the OS, so a project can run on a [`VirtualClock`]
//! faster than real time and give the same trace twice (DESIGN.md principle 2).
//!
//! Two clocks run in a PLC:
//! - [`ScanInstant`]: time since the PLC started, on the scan's [`Clock`] (the OS monotonic
//!   clock, or a virtual one). Cycle starts and deadlines, what logic sees as `now`, the
//!   process image's timestamps, the trace, the recorder, the watchdogs and the services'
//!   timestamps count on it.
//! - [`LineInstant`]: time on one line's own clock: what a [`Transport`](crate::line::Transport)
//!   and its [`BusOwner`](crate::line::BusOwner) answer to `now()`, when a frame left and its
//!   reply ended ([`InputFrame`](crate::line::InputFrame),
//!   [`WriteReport`](crate::line::WriteReport)),
//!   a module's health and refresh times, the wire trace, the simulated world's time and what
//!   its modules and plant are told ([`SimDevice`](crate::sim::SimDevice),
//!   [`Plant`](crate::sim::plant::Plant)). On the
//!   real clock a line reads the PLC's clock; on a virtual clock each line keeps its own
//!   cursor, which the scan moves forward (`BusOwner::sync`), so lines stay parallel in virtual
//!   time and may run ahead of the scan.
//!
//! The two meet only where the code really maps one onto the other, and there by name:
//! [`ScanInstant::on_line_clock`] (the scan tells a line what time it is; the simulated world
//! is brought to the scan's time) and [`LineInstant::on_scan_clock`] (the scan takes a line's
//! answer at the time it ended). A line that keeps the PLC's time (a serial port, a network
//! bus, a simulator serving a pty) reads it through [`Clock::line_now`] and
//! [`Clock::sleep_until_on_line`].
//!
//! Arithmetic never panics: `instant + duration` saturates at the far end of time
//! ([`Duration::MAX`] after the origin, centuries beyond any run), `instant - duration` at the
//! origin, and `later - earlier` at zero when `earlier` is in fact later (as
//! [`std::time::Instant`] does). Where going past an end means something, ask with
//! [`checked_add`](ScanInstant::checked_add), [`checked_sub`](ScanInstant::checked_sub) or
//! [`checked_duration_since`](ScanInstant::checked_duration_since). `Display` prints an
//! instant as [`fmt_duration`] does (`12.35ms` after the origin); `Debug` prints the exact
//! duration since the origin, as a `Duration` field printed before.
//!
//! Stable API: [`ScanInstant`], [`LineInstant`], their arithmetic and the two mappings, the
//! [`Clock`] trait, [`MonotonicClock`], [`VirtualClock`] and [`fmt_duration`].
//!
//! ```compile_fail,E0308
//! use softplc_io::time::{LineInstant, ScanInstant};
//! // A scan instant and a line instant do not compare: map one onto the other's clock first.
//! let _ = ScanInstant::ZERO < LineInstant::ZERO;
//! ```
//!
//! ```compile_fail,E0277
//! use softplc_io::time::{LineInstant, ScanInstant};
//! // Nor does one clock's instant subtract from, or add to, the other's.
//! let _ = ScanInstant::ZERO - LineInstant::ZERO;
//! ```
//!
//! ```compile_fail,E0308
//! use softplc_io::time::{LineInstant, ScanInstant};
//! // Nor is one passed where the other is asked for (the scan telling a line its time).
//! fn sync(t: LineInstant) {}
//! sync(ScanInstant::ZERO);
//! ```
//!
//! ```compile_fail,E0308
//! use softplc_io::time::ScanInstant;
//! // Two instants do not add up to a third (only an instant and a duration do).
//! let _ = ScanInstant::ZERO + ScanInstant::ZERO;
//! ```
//!
//! ```
//! use std::time::Duration;
//! use softplc_io::time::{LineInstant, ScanInstant};
//! let cycle_start = ScanInstant::after_origin(Duration::from_millis(20));
//! let deadline = cycle_start + Duration::from_millis(10);
//! assert_eq!(deadline - cycle_start, Duration::from_millis(10));
//! // The mapping is explicit and keeps the time.
//! let on_line: LineInstant = deadline.on_line_clock();
//! assert_eq!(on_line.on_scan_clock(), deadline);
//! assert_eq!(deadline.to_string(), "30.00ms");
//! ```

use std::fmt::Debug;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

mod instant;

pub use instant::{LineInstant, ScanInstant};

/// A duration as a person reads it: `850µs`, `12.35ms`, `1.20s` (what every report, log line
/// and error message of softplc prints).
pub fn fmt_duration(d: Duration) -> String {
    let us = d.as_micros();
    if us < 1000 {
        format!("{us}µs")
    } else if us < 1_000_000 {
        format!("{:.2}ms", d.as_secs_f64() * 1e3)
    } else {
        format!("{:.2}s", d.as_secs_f64())
    }
}

/// The PLC's clock: a source of time that can also wait. Its origin is the PLC's start, so its
/// instants are [`ScanInstant`]s (a line that keeps the PLC's time reads it too, through
/// [`Clock::line_now`]).
pub trait Clock: Send + Sync + Debug {
    /// Time since this clock's origin.
    fn now(&self) -> ScanInstant;
    /// Blocks until `deadline` (absolute, on this clock). A virtual clock jumps there instead.
    fn sleep_until(&self, deadline: ScanInstant);
    /// True for a clock that does not follow the wall: waits are jumps, not sleeps.
    fn is_virtual(&self) -> bool;

    /// The time now on a line that keeps this clock's time (a real port, a network bus, a
    /// simulator serving a pty): the one place such a line maps the scan's clock onto its own.
    fn line_now(&self) -> LineInstant {
        self.now().on_line_clock()
    }

    /// Blocks until `deadline` on a line that keeps this clock's time ([`Clock::line_now`]).
    fn sleep_until_on_line(&self, deadline: LineInstant) {
        self.sleep_until(deadline.on_scan_clock());
    }
}

/// The OS monotonic clock; waits with `clock_nanosleep(TIMER_ABSTIME)` so a deadline does not
/// drift by the time spent computing it.
#[derive(Debug)]
pub struct MonotonicClock {
    origin: Duration,
}

impl MonotonicClock {
    /// A clock whose origin is now.
    pub fn new() -> Self {
        Self {
            origin: monotonic_raw(),
        }
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

#[allow(unsafe_code)] // one clock_gettime; see SAFETY below
fn monotonic_raw() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC is always supported on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

impl Clock for MonotonicClock {
    fn now(&self) -> ScanInstant {
        ScanInstant::after_origin(monotonic_raw().saturating_sub(self.origin))
    }

    #[allow(unsafe_code)] // one clock_nanosleep; see SAFETY below
    fn sleep_until(&self, deadline: ScanInstant) {
        let abs = self.origin.saturating_add(deadline.since_origin());
        let ts = libc::timespec {
            tv_sec: abs.as_secs() as libc::time_t,
            tv_nsec: abs.subsec_nanos() as libc::c_long,
        };
        loop {
            // SAFETY: `ts` is a valid timespec; a null remainder is allowed with TIMER_ABSTIME.
            let rc = unsafe {
                libc::clock_nanosleep(
                    libc::CLOCK_MONOTONIC,
                    libc::TIMER_ABSTIME,
                    &ts,
                    std::ptr::null_mut(),
                )
            };
            match rc {
                0 => break,
                // A signal woke us early; the deadline is absolute, so just wait again.
                libc::EINTR => continue,
                // Refused (a wrapper library in the process, a kernel without the call):
                // returning now would let the scan run flat out, cycles back to back with
                // no error shown anywhere. Relative sleeps on the same clock keep the grid.
                refused => {
                    static SAID: std::sync::Once = std::sync::Once::new();
                    SAID.call_once(|| {
                        tracing::warn!(
                            "the absolute wait on CLOCK_MONOTONIC is refused ({}): deadlines \
                             are waited for in relative sleeps on the same clock",
                            std::io::Error::from_raw_os_error(refused)
                        );
                    });
                    sleep_relative_until(deadline, || self.now());
                    break;
                }
            }
        }
    }

    fn is_virtual(&self) -> bool {
        false
    }
}

/// Sleeps in relative steps until `now()` reaches `deadline`: where the absolute
/// `clock_nanosleep` is refused. `std::thread::sleep` sleeps at least as long as asked, so
/// the loop ends at the deadline or just after it, like the absolute wait.
fn sleep_relative_until(deadline: ScanInstant, now: impl Fn() -> ScanInstant) {
    loop {
        let left = deadline.saturating_duration_since(now());
        if left.is_zero() {
            return;
        }
        std::thread::sleep(left);
    }
}

/// A clock that moves only when told to: `sleep_until` jumps to the deadline.
#[derive(Debug, Default)]
pub struct VirtualClock {
    nanos: AtomicU64,
}

impl VirtualClock {
    /// A virtual clock at time zero.
    pub fn new() -> Self {
        Self::default()
    }

    /// Moves the clock forward to `t`; never backwards.
    pub fn advance_to(&self, t: ScanInstant) {
        self.nanos
            .fetch_max(t.since_origin().as_nanos() as u64, Ordering::SeqCst);
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> ScanInstant {
        ScanInstant::after_origin(Duration::from_nanos(self.nanos.load(Ordering::SeqCst)))
    }

    fn sleep_until(&self, deadline: ScanInstant) {
        self.advance_to(deadline);
    }

    fn is_virtual(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn virtual_clock_only_moves_forward() {
        let c = VirtualClock::new();
        c.sleep_until(ScanInstant::after_origin(Duration::from_millis(10)));
        c.sleep_until(ScanInstant::after_origin(Duration::from_millis(5)));
        assert_eq!(
            c.now(),
            ScanInstant::after_origin(Duration::from_millis(10))
        );
    }

    #[test]
    fn monotonic_sleep_until_reaches_deadline() {
        let c = MonotonicClock::new();
        let d = c.now() + Duration::from_millis(2);
        c.sleep_until(d);
        assert!(c.now() >= d);
    }

    #[test]
    fn the_relative_fallback_reaches_the_deadline_and_not_before() {
        let c = MonotonicClock::new();
        let d = c.now() + Duration::from_millis(30);
        sleep_relative_until(d, || c.now());
        assert!(c.now() >= d);
        // A deadline already past returns at once.
        let begin = c.now();
        sleep_relative_until(ScanInstant::ZERO, || c.now());
        assert!(c.now().saturating_duration_since(begin) < Duration::from_secs(1));
    }
}
