//! The task watchdog: a cycle longer than `time` is an overrun; `sensitivity` consecutive
//! overruns fire it, and so does a single cycle longer than `time × sensitivity` (CODESYS
//! semantics).

use std::time::Duration;

use crate::project::WatchdogConfig;

/// Watchdog state across cycles.
#[derive(Debug, Clone)]
pub(crate) struct TaskWatchdog {
    cfg: WatchdogConfig,
    consecutive: u32,
}

/// Why the watchdog fired.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum WatchdogTrip {
    /// Too many consecutive cycles above the watchdog time.
    #[error("{count} consecutive cycles over the watchdog time {limit:?} (last {last:?})")]
    Consecutive {
        /// Consecutive long cycles.
        count: u32,
        /// The watchdog time.
        limit: Duration,
        /// The last cycle's time.
        last: Duration,
    },
    /// One cycle above time × sensitivity.
    #[error("a cycle took {took:?}, over the watchdog time × sensitivity {limit:?}")]
    Single {
        /// The cycle's time.
        took: Duration,
        /// time × sensitivity.
        limit: Duration,
    },
}

impl TaskWatchdog {
    /// A watchdog with no history.
    pub(crate) fn new(cfg: WatchdogConfig) -> Self {
        Self {
            cfg,
            consecutive: 0,
        }
    }

    /// Checks one completed cycle's duration.
    pub(crate) fn check(&mut self, cycle: Duration) -> Result<(), WatchdogTrip> {
        let sensitivity = self.cfg.sensitivity.max(1);
        let hard = self.cfg.time.saturating_mul(sensitivity);
        if cycle > hard {
            return Err(WatchdogTrip::Single {
                took: cycle,
                limit: hard,
            });
        }
        if cycle > self.cfg.time {
            self.consecutive += 1;
            if self.consecutive >= sensitivity {
                return Err(WatchdogTrip::Consecutive {
                    count: self.consecutive,
                    limit: self.cfg.time,
                    last: cycle,
                });
            }
        } else {
            self.consecutive = 0;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wd() -> TaskWatchdog {
        TaskWatchdog::new(WatchdogConfig {
            time: Duration::from_millis(10),
            sensitivity: 3,
        })
    }

    #[test]
    fn fires_after_sensitivity_consecutive_overruns() {
        let mut w = wd();
        let long = Duration::from_millis(12);
        assert!(w.check(long).is_ok());
        assert!(w.check(long).is_ok());
        assert!(matches!(
            w.check(long),
            Err(WatchdogTrip::Consecutive { count: 3, .. })
        ));
    }

    #[test]
    fn a_good_cycle_resets_the_count() {
        let mut w = wd();
        let long = Duration::from_millis(12);
        for _ in 0..10 {
            assert!(w.check(long).is_ok());
            assert!(w.check(long).is_ok());
            assert!(w.check(Duration::from_millis(5)).is_ok());
        }
    }

    #[test]
    fn one_cycle_over_time_times_sensitivity_fires_at_once() {
        let mut w = wd();
        assert_eq!(
            w.check(Duration::from_millis(31)),
            Err(WatchdogTrip::Single {
                took: Duration::from_millis(31),
                limit: Duration::from_millis(30)
            })
        );
    }
}
