//! Counting the changes a client missed, when every tag is a counter that steps by one each
//! time the PLC changes it: a client that saw 4 then 7 missed 5 and 6. Pure, so the count the
//! plant-load scenario reports is tested here.

/// What one client saw of counters that all started at the same value.
#[derive(Debug, Clone)]
pub(crate) struct SequenceCheck {
    /// The highest value received of each tag (the start value before any).
    last: Vec<i64>,
    /// Whether anything was received of each tag yet.
    seen: Vec<bool>,
    /// Changes received in order: each a step past the highest value before it.
    received: u64,
    /// Values equal to the highest one already received, after a tag's first: the same value
    /// again (a quality-only change, such as the first cycle's good after a birth).
    repeated: u64,
    /// Values below the highest one already received: a change that came out of order.
    out_of_order: u64,
    /// Values for a tag the check does not know.
    unknown: u64,
}

/// The count of one client against what the PLC made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Tally {
    /// Changes the PLC made (each tag's final value less the start value).
    pub made: u64,
    /// Changes received in order.
    pub received: u64,
    /// Changes never received: gaps in a tag's sequence, and steps after the last received.
    pub missed: u64,
    /// Values equal to the last received (the same value again).
    pub repeated: u64,
    /// Values below the last received (out of order).
    pub out_of_order: u64,
    /// Values for tags outside the check.
    pub unknown: u64,
}

impl SequenceCheck {
    /// A check of `tags` counters that all start at `start`.
    pub(crate) fn new(tags: usize, start: i64) -> Self {
        Self {
            last: vec![start; tags],
            seen: vec![false; tags],
            received: 0,
            repeated: 0,
            out_of_order: 0,
            unknown: 0,
        }
    }

    /// A value of tag `tag` as the client received it. A tag's first value equal to the start
    /// value is the subscription's initial value (OPC UA) or the birth's (Sparkplug), not a
    /// change.
    pub(crate) fn observe(&mut self, tag: usize, value: i64) {
        let (Some(last), Some(seen)) = (self.last.get_mut(tag), self.seen.get_mut(tag)) else {
            self.unknown += 1;
            return;
        };
        let first = !*seen;
        *seen = true;
        if value > *last {
            self.received += 1;
            *last = value;
        } else if value < *last {
            self.out_of_order += 1;
        } else if !first {
            self.repeated += 1;
        }
    }

    /// The tally against each tag's final value, as the PLC made it (`finals[tag]`), from the
    /// start value.
    pub(crate) fn tally(&self, start: i64, finals: &[i64]) -> Tally {
        let made: i64 = finals.iter().map(|f| (f - start).max(0)).sum();
        let made = u64::try_from(made).unwrap_or(0);
        Tally {
            made,
            received: self.received,
            missed: made.saturating_sub(self.received),
            repeated: self.repeated,
            out_of_order: self.out_of_order,
            unknown: self.unknown,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gap_in_a_tags_sequence_is_counted_as_missed() {
        let mut check = SequenceCheck::new(2, 0);
        // Tag 0: the initial value, then 1, 2, 5 (3 and 4 missed); tag 1: 1, 2, 3.
        for v in [0, 1, 2, 5] {
            check.observe(0, v);
        }
        for v in [1, 2, 3] {
            check.observe(1, v);
        }
        let t = check.tally(0, &[5, 3]);
        assert_eq!(
            t,
            Tally {
                made: 8,
                received: 6,
                missed: 2,
                repeated: 0,
                out_of_order: 0,
                unknown: 0
            }
        );
    }

    #[test]
    fn steps_after_the_last_received_value_are_missed_and_repeats_are_not_received() {
        let mut check = SequenceCheck::new(1, 10);
        // The initial value, 11, a duplicate 11, 12 then 11 late; the PLC went on to 14.
        for v in [10, 11, 11, 12, 11] {
            check.observe(0, v);
        }
        check.observe(3, 1);
        let t = check.tally(10, &[14]);
        assert_eq!((t.made, t.received, t.missed), (4, 2, 2));
        assert_eq!((t.repeated, t.out_of_order, t.unknown), (1, 1, 1));
    }
}
