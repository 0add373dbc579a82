//! Whether a read-back that differs from what was written is the module's word or a garbled
//! reply.
//!
//! Behind an integrity check (Modbus RTU's CRC-16, a DCON checksum) a reply that passed is
//! what the module holds: a read-back that differs is believed at once, and no retry changes
//! it. A frame without one (MiniMod text protocol, RESI ASCII, DCON without checksum) can
//! carry a character with one bit flipped that still reads as a plausible value
//! (`WDTTIME=00131` for `00133`), on a line the manuals allow without parity. So the bus owner
//! asks again: only the same differing answer twice in a row is the module's word (a timeout
//! or a garbled frame between the two is no answer and does not break the row); an answer
//! equal to what was written is a success; and once the line's retries are spent, a differing
//! answer that follows another is believed, so a module that really holds something else
//! stops its start within the line's retries plus one. A first differing answer on the last
//! attempt always gets one confirming ask, even with `retries: 0`. Each answer not believed is
//! counted as noise (a decode error) and followed by the guard time and a flush.

use crate::driver::{DecodeError, Integrity};

/// The attempts of one transaction and the differing read-back they have heard.
#[derive(Debug)]
pub(crate) struct ReadBackVote {
    integrity: Integrity,
    /// Attempts allowed: the first and the line's retries, plus a confirming ask when the
    /// first differing answer came on the last of them.
    allowed: u32,
    /// Attempts made.
    made: u32,
    /// A differing answer not believed yet.
    unconfirmed: Option<DecodeError>,
}

impl ReadBackVote {
    /// A transaction whose replies have `integrity`, with `retries` attempts after the first.
    pub(crate) fn new(integrity: Integrity, retries: u8) -> Self {
        Self {
            integrity,
            allowed: u32::from(retries) + 1,
            made: 0,
            unconfirmed: None,
        }
    }

    /// Whether another attempt may be made (it is then counted as made).
    pub(crate) fn next_attempt(&mut self) -> bool {
        let more = self.made < self.allowed;
        self.made += u32::from(more);
        more
    }

    /// Whether the read-back `mismatch` heard on the attempt just made is believed; if not,
    /// it is noise and the next attempt asks again.
    pub(crate) fn believes(&mut self, mismatch: DecodeError) -> bool {
        if self.integrity == Integrity::Checked {
            return true;
        }
        let retries_spent = self.made >= self.allowed;
        match self.unconfirmed {
            Some(heard) if heard == mismatch => true,
            Some(_) if retries_spent => true,
            _ => {
                self.unconfirmed = Some(mismatch);
                if retries_spent {
                    self.allowed += 1;
                }
                false
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reads(found: u32) -> DecodeError {
        DecodeError::Mismatch {
            register: "WDTTIME",
            expected: 133,
            found,
        }
    }

    /// Feeds differing answers (`None`: no answer this attempt) until the vote believes one
    /// or the attempts run out: the answer believed and the attempts made.
    fn run(integrity: Integrity, retries: u8, answers: &[Option<u32>]) -> (Option<u32>, u32) {
        let mut vote = ReadBackVote::new(integrity, retries);
        let mut answers = answers.iter();
        while vote.next_attempt() {
            let Some(answer) = answers.next().expect("an answer for every attempt") else {
                continue;
            };
            if vote.believes(reads(*answer)) {
                return (Some(*answer), vote.made);
            }
        }
        (None, vote.made)
    }

    #[test]
    fn a_checked_read_back_is_believed_at_once() {
        assert_eq!(run(Integrity::Checked, 3, &[Some(131)]), (Some(131), 1));
    }

    #[test]
    fn an_unchecked_read_back_is_believed_when_it_says_the_same_twice_in_a_row() {
        assert_eq!(
            run(Integrity::Unchecked, 3, &[Some(131), Some(131)]),
            (Some(131), 2)
        );
        // A timeout between the two is no answer.
        assert_eq!(
            run(Integrity::Unchecked, 3, &[Some(131), None, Some(131)]),
            (Some(131), 3)
        );
        // Two garbled answers that differ: the third decides.
        assert_eq!(
            run(Integrity::Unchecked, 3, &[Some(131), Some(137), Some(137)]),
            (Some(137), 3)
        );
    }

    #[test]
    fn with_no_retries_a_differing_answer_still_gets_one_confirming_ask() {
        assert_eq!(
            run(Integrity::Unchecked, 0, &[Some(131), Some(131)]),
            (Some(131), 2)
        );
        // The confirming ask timed out: nothing is believed (the transaction failed).
        assert_eq!(run(Integrity::Unchecked, 0, &[Some(131), None]), (None, 2));
        assert_eq!(run(Integrity::Checked, 0, &[None]), (None, 1));
    }

    #[test]
    fn once_the_retries_are_spent_a_differing_answer_after_another_is_believed() {
        assert_eq!(
            run(Integrity::Unchecked, 1, &[Some(131), Some(137)]),
            (Some(137), 2)
        );
        // A first differing answer on the last retry gets its confirming ask.
        assert_eq!(
            run(Integrity::Unchecked, 1, &[None, Some(131), Some(137)]),
            (Some(137), 3)
        );
    }
}
