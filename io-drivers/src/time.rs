//! Time as the whole system sees it.
//!
//! Every timestamp is a [`Duration`] since the clock's origin. Logic, lines and simulators ask a
//! [`Clock`] instead of the OS, so a project can run on a [`VirtualClock`] faster than real time
//! and give the same trace twice (DESIGN.md principle 2).

use std::fmt::Debug;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

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

/// A source of time that can also wait.
pub trait Clock: Send + Sync + Debug {
    /// Time since this clock's origin.
    fn now(&self) -> Duration;
    /// Blocks until `deadline` (absolute, on this clock). A virtual clock jumps there instead.
    fn sleep_until(&self, deadline: Duration);
    /// True for a clock that does not follow the wall: waits are jumps, not sleeps.
    fn is_virtual(&self) -> bool;
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
    fn now(&self) -> Duration {
        monotonic_raw().saturating_sub(self.origin)
    }

    #[allow(unsafe_code)] // one clock_nanosleep; see SAFETY below
    fn sleep_until(&self, deadline: Duration) {
        let abs = self.origin + deadline;
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
            // EINTR: a signal woke us early; the deadline is absolute, so just wait again.
            if rc != libc::EINTR {
                break;
            }
        }
    }

    fn is_virtual(&self) -> bool {
        false
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
    pub fn advance_to(&self, t: Duration) {
        self.nanos.fetch_max(t.as_nanos() as u64, Ordering::SeqCst);
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> Duration {
        Duration::from_nanos(self.nanos.load(Ordering::SeqCst))
    }

    fn sleep_until(&self, deadline: Duration) {
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
        c.sleep_until(Duration::from_millis(10));
        c.sleep_until(Duration::from_millis(5));
        assert_eq!(c.now(), Duration::from_millis(10));
    }

    #[test]
    fn monotonic_sleep_until_reaches_deadline() {
        let c = MonotonicClock::new();
        let d = c.now() + Duration::from_millis(2);
        c.sleep_until(d);
        assert!(c.now() >= d);
    }
}
