//! Communication health of a module (or a whole line): when to call it lost, when to try it
//! again, and what to log, once per change of state rather than once per scan.
//!
//! A module that fails `fail_limit` cycles in a row is *lost*: its points turn bad, and it is
//! polled again only after a backoff (doubling from `reconnect_min` to `reconnect_max`), so a
//! dead module does not cost the rest of the line a response timeout every cycle.

use std::time::Duration;

use crate::time::LineInstant;

use crate::point::Quality;

/// Limits of the health state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct HealthLimits {
    /// Consecutive failed cycles after which the module is lost.
    pub fail_limit: u32,
    /// First retry interval once lost.
    pub reconnect_min: Duration,
    /// Longest retry interval.
    pub reconnect_max: Duration,
}

/// A change worth one log line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum HealthEvent {
    /// The module just became lost.
    Lost,
    /// A lost module answered again after being lost for this long.
    Back(Duration),
}

/// One module's health.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct Health {
    failed_cycles: u32,
    lost_since: Option<LineInstant>,
    backoff: Duration,
    next_attempt: LineInstant,
}

impl Health {
    /// Whether the module should be polled at `now` (always, unless lost and backing off).
    pub(crate) fn due(&self, now: LineInstant) -> bool {
        self.lost_since.is_none() || now >= self.next_attempt
    }

    /// Makes a lost module due now (its line came back: no reason to wait out its backoff).
    pub(crate) fn retry_now(&mut self) {
        self.next_attempt = LineInstant::ZERO;
    }

    /// Whether the module is lost.
    pub(crate) fn is_lost(&self) -> bool {
        self.lost_since.is_some()
    }

    /// Whether its last polled cycle failed (it is stale or lost).
    pub(crate) fn is_failing(&self) -> bool {
        self.failed_cycles > 0 || self.is_lost()
    }

    /// Its quality as its last polled cycle left it.
    pub(crate) fn quality(&self) -> Quality {
        if self.is_lost() {
            Quality::Bad
        } else if self.failed_cycles > 0 {
            Quality::Stale
        } else {
            Quality::Good
        }
    }

    /// The quality of a module that was not polled this cycle.
    pub(crate) fn skipped_quality(&self) -> Quality {
        if self.is_lost() {
            Quality::Bad
        } else {
            Quality::Stale
        }
    }

    /// Makes the module lost at once (it did not answer its start-up), retried after the
    /// first backoff.
    pub(crate) fn mark_lost(&mut self, now: LineInstant, limits: &HealthLimits) {
        self.failed_cycles = limits.fail_limit;
        self.lost_since.get_or_insert(now);
        self.backoff = limits.reconnect_min;
        self.next_attempt = now + self.backoff;
    }

    /// Records a polled cycle's outcome at `now`; returns the quality to report and an event
    /// when the state changed.
    pub(crate) fn record(
        &mut self,
        ok: bool,
        now: LineInstant,
        limits: &HealthLimits,
    ) -> (Quality, Option<HealthEvent>) {
        if ok {
            self.failed_cycles = 0;
            self.backoff = Duration::ZERO;
            let event = self
                .lost_since
                .take()
                .map(|since| HealthEvent::Back(now - since));
            return (Quality::Good, event);
        }
        self.failed_cycles = self.failed_cycles.saturating_add(1);
        if self.failed_cycles < limits.fail_limit {
            return (Quality::Stale, None);
        }
        let event = if self.lost_since.is_none() {
            self.lost_since = Some(now);
            self.backoff = limits.reconnect_min;
            Some(HealthEvent::Lost)
        } else {
            self.backoff = (self.backoff * 2).clamp(limits.reconnect_min, limits.reconnect_max);
            None
        };
        self.next_attempt = now + self.backoff;
        (Quality::Bad, event)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: HealthLimits = HealthLimits {
        fail_limit: 3,
        reconnect_min: Duration::from_secs(1),
        reconnect_max: Duration::from_secs(4),
    };

    fn s(secs: u64) -> Duration {
        Duration::from_secs(secs)
    }

    fn at(secs: u64) -> LineInstant {
        LineInstant::after_origin(s(secs))
    }

    #[test]
    fn lost_after_the_limit_then_backs_off_and_comes_back_once() {
        let mut h = Health::default();
        assert_eq!(h.record(false, at(0), &LIMITS), (Quality::Stale, None));
        assert_eq!(h.record(false, at(0), &LIMITS), (Quality::Stale, None));
        assert_eq!(
            h.record(false, at(10), &LIMITS),
            (Quality::Bad, Some(HealthEvent::Lost))
        );
        assert!(!h.due(at(10)) && h.due(at(11)), "1 s backoff");
        assert_eq!(
            h.record(false, at(11), &LIMITS),
            (Quality::Bad, None),
            "logged once"
        );
        assert!(!h.due(at(12)) && h.due(at(13)), "doubled to 2 s");
        h.record(false, at(13), &LIMITS);
        h.record(false, at(17), &LIMITS);
        assert!(!h.due(at(20)) && h.due(at(21)), "capped at 4 s");
        assert_eq!(
            h.record(true, at(21), &LIMITS),
            (Quality::Good, Some(HealthEvent::Back(s(11))))
        );
        assert!(h.due(at(21)));
        assert_eq!(h.record(true, at(22), &LIMITS), (Quality::Good, None));
    }
}
