//! When a line's periodic refreshes run: a Collect member's full read (`line/collect.rs`) and
//! a module's rewrite of every output (`BusOwner::write_outputs`).
//!
//! Each is a whole exchange with the module's reply delay, and a cycle that carries one is
//! longer by that exchange (20 ms for a factory-default MiniMod at 19200 against a 41 ms
//! cycle). Run for every module at the same instant, as a plain period would after a start,
//! they made one cycle a second several times longer than the others (190 ms against 42 ms
//! for four MiniMods), which is what a line's p99 then shows. So a refresh may run from
//! three quarters of its period on, at most one such a cycle per kind, the most overdue first:
//! that spreads the modules' refreshes over consecutive cycles, and they stay spread, each on
//! its own period. A refresh that reaches its whole period runs in any case, so no module
//! ever goes longer than its period (what the watchdog times and `check` derive from it
//! rely on); on a line whose refreshes do not fit one a cycle, the late ones run together.

use std::time::Duration;

use crate::time::LineInstant;

/// How urgent one periodic refresh is now.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Urgency {
    /// Not yet three quarters of its period.
    Idle,
    /// Past three quarters: may run in a cycle that carries no other refresh of its kind.
    /// The value orders candidates: the share of its period that has passed, in 1/1024.
    Eligible(u64),
    /// Never done, or a whole period: runs this cycle.
    Due,
}

impl Urgency {
    /// The urgency of a refresh last done at `last` (`None`: never), with `period`, at `now`.
    pub(crate) fn of(last: Option<LineInstant>, period: Duration, now: LineInstant) -> Self {
        let Some(last) = last else {
            return Urgency::Due;
        };
        let since = now - last;
        if since >= period {
            return Urgency::Due;
        }
        if since < period - period / 4 {
            return Urgency::Idle;
        }
        let share = since.as_nanos() * 1024 / period.as_nanos().max(1);
        Urgency::Eligible(u64::try_from(share).unwrap_or(u64::MAX))
    }
}

/// One cycle's choice among modules: every one [`Urgency::Due`] runs; of the
/// [`Urgency::Eligible`] ones, the most overdue runs only when nothing else does.
#[derive(Debug, Default)]
pub(crate) struct Pick {
    due: Vec<usize>,
    best: Option<(u64, usize)>,
    /// The cycle carries a refresh for another reason.
    busy: bool,
}

impl Pick {
    /// Module `m` at `urgency`.
    pub(crate) fn offer(&mut self, m: usize, urgency: Urgency) {
        match urgency {
            Urgency::Idle => {}
            Urgency::Due => self.due.push(m),
            Urgency::Eligible(share) => {
                if self.best.is_none_or(|(b, _)| share > b) {
                    self.best = Some((share, m));
                }
            }
        }
    }

    /// A refresh that runs this cycle for another reason (a module back after a loss, a lost
    /// event): the cycle already carries one, so no eligible one is added.
    pub(crate) fn taken(&mut self) {
        self.busy = true;
    }

    /// The modules whose refresh runs this cycle.
    pub(crate) fn chosen(&self) -> impl Iterator<Item = usize> + '_ {
        let extra = if self.due.is_empty() && !self.busy {
            self.best.map(|(_, m)| m)
        } else {
            None
        };
        self.due.iter().copied().chain(extra)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: Duration = Duration::from_secs(1);

    fn ms(n: u64) -> LineInstant {
        LineInstant::after_origin(Duration::from_millis(n))
    }

    #[test]
    fn a_refresh_is_idle_then_eligible_from_three_quarters_then_due() {
        assert_eq!(Urgency::of(None, S, ms(5)), Urgency::Due);
        assert_eq!(Urgency::of(Some(ms(0)), S, ms(749)), Urgency::Idle);
        assert_eq!(Urgency::of(Some(ms(0)), S, ms(750)), Urgency::Eligible(768));
        assert_eq!(
            Urgency::of(Some(ms(0)), S, ms(999)),
            Urgency::Eligible(1022)
        );
        assert_eq!(Urgency::of(Some(ms(0)), S, ms(1000)), Urgency::Due);
    }

    #[test]
    fn one_eligible_refresh_a_cycle_the_most_overdue_and_none_beside_a_due_one() {
        let mut pick = Pick::default();
        pick.offer(0, Urgency::Eligible(800));
        pick.offer(1, Urgency::Eligible(900));
        pick.offer(2, Urgency::Idle);
        assert_eq!(pick.chosen().collect::<Vec<_>>(), [1]);

        let mut pick = Pick::default();
        pick.offer(0, Urgency::Eligible(900));
        pick.offer(1, Urgency::Due);
        pick.offer(2, Urgency::Due);
        assert_eq!(pick.chosen().collect::<Vec<_>>(), [1, 2]);

        let mut pick = Pick::default();
        pick.offer(0, Urgency::Eligible(900));
        pick.taken();
        assert_eq!(pick.chosen().count(), 0);
    }
}
