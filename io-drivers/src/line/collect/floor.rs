//! The wire-time floor of a Collect round, with the timing model `check` uses (DESIGN.md
//! "Timing model", `line/settings.rs`): no master can run the round faster on this line.
//!
//! From the MiniMod manual, "The Modbus function Collect":
//! - every Collect is `DST FCN FIRST LAST SLVACK SLVSEQ` and its CRC: 8 characters;
//! - a reply is `SLAVE FCN SLVSEQ TYPE DATH DATL 0` and its CRC: 9 characters;
//! - the slaves of the window have 3 ms each, in ascending address order, and a Collect
//!   nobody answers ends after its slots "plus 1 for safety".
//!
//! So a round over a window of N addresses in which nobody has events costs one request,
//! N slots, the 1 ms and t3.5. A slave with an event ends that Collect with its reply: the
//! request, the slots before its own, its 9 characters and t3.5; the round goes on with a
//! Collect whose window starts after it (carrying the acknowledgement), unless it was the
//! window's last address. The walk is [`CollectRound`]'s own, so the floor follows the round
//! the bus owner runs.
//!
//! Choices where the manual is silent:
//! - A reply is counted from the start of its slave's slot, the earliest the manual allows
//!   (a slave that turns round later in its slot takes that much more: the simulator starts
//!   1 ms in). Then an event costs the same wherever its slave sits in the window (one more
//!   request, its reply and t3.5, less the slot it answered in), except one from the window's
//!   last address, which needs no silent Collect after it.
//! - Reply delays (RDELAYT) do not apply: a Collect reply has its slot instead. RDELAYM does
//!   ([`CollectFloor::with_frame_timeout`]): a slave that waits longer for the end of the
//!   request ("Setting the Modbus communication timeout") starts its slot that much later,
//!   so every Collect lasts the members' largest RDELAYM more.
//! - An adapter's latency timer (`line/latency.rs`) counts once per Collect: a reply may be
//!   held back by that much, so a master cannot know a window silent before it has passed.

use std::time::Duration;

use super::{CollectRound, SLOT};
use crate::line::budget::AdapterTiming;
use crate::line::settings::LineSettings;
use crate::modbus::master::encode_request;
use crate::modbus::Request;

/// The floor of the Collect rounds of one line: its window and its timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CollectFloor {
    settings: LineSettings,
    adapter: AdapterTiming,
    first: u8,
    last: u8,
    /// The members' largest [`crate::driver::Membership::frame_timeout`]: every slot starts
    /// that much later.
    frame_timeout: Duration,
}

impl CollectFloor {
    /// The floor of rounds over the window the bus owner uses for `members` (the lowest to
    /// the highest member address); `None` when there is no member.
    pub fn over(settings: LineSettings, adapter: AdapterTiming, members: &[u8]) -> Option<Self> {
        let round = CollectRound::over(members, None)?;
        Some(Self {
            settings,
            adapter,
            first: round.next,
            last: round.last,
            frame_timeout: Duration::ZERO,
        })
    }

    /// The same floor where a member waits `frame_timeout` longer for the end of a request
    /// (a MiniMod's RDELAYM): each Collect's slots start that much later, whether a slave
    /// answers or the window passes in silence.
    pub fn with_frame_timeout(self, frame_timeout: Duration) -> Self {
        Self {
            frame_timeout,
            ..self
        }
    }

    /// The window: first and last address.
    pub fn window(&self) -> (u8, u8) {
        (self.first, self.last)
    }

    /// How much later than the request's end each Collect's slots start: the members'
    /// largest RDELAYM ([`Self::with_frame_timeout`]).
    pub fn frame_timeout(&self) -> Duration {
        self.frame_timeout
    }

    /// Slots in the window.
    pub fn slots(&self) -> u32 {
        u32::from(self.last - self.first) + 1
    }

    /// A round in which no slave has events: one Collect that passes in silence.
    pub fn idle(&self) -> Duration {
        self.round(&[])
    }

    /// A round in which each slave of `replying` (addresses in the window; any order) sends
    /// one event.
    pub fn round(&self, replying: &[u8]) -> Duration {
        let s = self.settings;
        let Some(mut round) = CollectRound::new(self.first, self.last, None) else {
            return Duration::ZERO;
        };
        let mut total = Duration::ZERO;
        while let Some(request) = round.request() {
            total += s.chars(request_len(&request))
                + self.adapter.latency
                + s.t3_5()
                + self.frame_timeout;
            let answer = replying
                .iter()
                .copied()
                .filter(|a| (round.next..=round.last).contains(a))
                .min();
            match answer {
                Some(slave) => {
                    // From the end of the request to the start of the slave's slot, then
                    // its reply.
                    total += round.slot_end(slave) - SLOT + s.chars(REPLY_LEN);
                    round.on_reply(slave, 1);
                }
                None => {
                    total += round.reply_window();
                    round.on_silence();
                }
            }
        }
        total
    }

    /// What one event adds to a round when its slave is not the window's last address.
    pub fn per_event(&self) -> Duration {
        let s = self.settings;
        s.chars(REQUEST_LEN) + s.chars(REPLY_LEN) + self.adapter.latency + s.t3_5() - SLOT
            + self.frame_timeout
    }
}

/// Characters of a Collect request on the wire.
pub const REQUEST_LEN: usize = 8;

/// Characters of a Collect reply on the wire.
pub const REPLY_LEN: usize = 9;

fn request_len(request: &Request) -> usize {
    let mut frame = Vec::with_capacity(REQUEST_LEN);
    match encode_request(0, request, &mut frame) {
        Ok(()) => frame.len(),
        Err(_) => REQUEST_LEN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::line::budget::modbus_reply_len;
    use crate::line::settings::SerialFormat;

    const US: fn(u64) -> Duration = Duration::from_micros;
    const NS: fn(u64) -> Duration = Duration::from_nanos;

    fn at(baud: u32, format: &str) -> LineSettings {
        LineSettings {
            baud,
            format: format.parse::<SerialFormat>().unwrap(),
        }
    }

    fn floor(settings: LineSettings, members: &[u8]) -> CollectFloor {
        CollectFloor::over(settings, AdapterTiming::default(), members).unwrap()
    }

    #[test]
    fn frame_lengths_are_the_manuals() {
        let request = Request::Collect {
            first: 1,
            last: 16,
            slave_ack: 4,
            slave_seq: 0x21,
        };
        assert_eq!(request_len(&request), REQUEST_LEN);
        assert_eq!(modbus_reply_len(&request), REPLY_LEN);
    }

    #[test]
    fn idle_round_of_4_minimods_at_19200_8e1() {
        // 11 bits a character: 8 × 572.916 µs = 4.583 ms, 4 slots × 3 ms, 1 ms, t3.5 =
        // 3.5 characters = 2.005 ms: 19.588 ms.
        let f = floor(LineSettings::DEFAULT, &[1, 2, 3, 4]);
        assert_eq!(f.window(), (1, 4));
        assert_eq!(f.slots(), 4);
        assert_eq!(f.idle(), NS(4_583_333) + US(13_000) + NS(2_005_208));
        assert_eq!(f.idle().as_micros(), 19_588);
    }

    #[test]
    fn the_window_spans_the_lowest_to_the_highest_member() {
        // Members 3, 7, 12: ten slots, whichever addresses between are members.
        let f = floor(LineSettings::DEFAULT, &[12, 3, 7]);
        assert_eq!(f.window(), (3, 12));
        assert_eq!(f.idle().as_micros(), 4_583 + 31_000 + 2_005);
        assert_eq!(
            CollectFloor::over(LineSettings::DEFAULT, AdapterTiming::default(), &[]),
            None
        );
    }

    #[test]
    fn above_19200_t3_5_is_1_75_ms_and_8n1_has_10_bits() {
        // 57600 8N1: 10 bits = 173.611 µs a character; 8 of them 1.388 ms.
        let f = floor(at(57600, "8N1"), &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10]);
        assert_eq!(f.idle(), NS(1_388_888) + US(31_000) + US(1_750));
        // 9600 8E1: 1.145833 ms a character; t3.5 = 4.010 ms.
        let f = floor(at(9600, "8E1"), &[1]);
        assert_eq!(f.idle(), NS(9_166_666) + US(4_000) + NS(4_010_416));
    }

    #[test]
    fn an_event_ends_its_collect_and_the_round_goes_on_after_its_slave() {
        let s = LineSettings::DEFAULT;
        let f = floor(s, &[1, 2, 3, 4]);
        // Slave 2 answers window 1–4 at the start of its slot (3 ms in) with 9 characters,
        // then window 3–4 passes in silence.
        let first = s.chars(8) + US(3_000) + s.chars(9) + s.t3_5();
        let second = s.chars(8) + US(2 * 3_000 + 1_000) + s.t3_5();
        assert_eq!(f.round(&[2]), first + second);
        // 8 + 9 characters (9.740 ms) + t3.5 − the 3 ms slot it answered in: 8.745 ms more.
        assert_eq!(f.per_event(), NS(9_739_583) + NS(2_005_208) - US(3_000));
        assert_eq!(f.round(&[2]), f.idle() + f.per_event());
        // Wherever the slave sits, but for the last address.
        assert_eq!(f.round(&[1]), f.idle() + f.per_event());
        assert_eq!(f.round(&[3, 1]), f.idle() + f.per_event() * 2);
    }

    #[test]
    fn an_event_from_the_last_address_ends_the_round() {
        let s = LineSettings::DEFAULT;
        let f = floor(s, &[1, 2, 3, 4]);
        // Slots 1–3 pass, slave 4 answers: no Collect after it (the next round acknowledges).
        assert_eq!(
            f.round(&[4]),
            s.chars(8) + US(9_000) + s.chars(9) + s.t3_5()
        );
        assert_eq!(f.round(&[2, 4]), f.round(&[4]) + f.per_event());
        // Addresses outside the window and repeats change nothing.
        assert_eq!(f.round(&[9, 2, 2]), f.round(&[2]));
    }

    #[test]
    fn an_adapter_latency_counts_once_per_collect() {
        let adapter = AdapterTiming {
            latency: US(1_000),
            ..AdapterTiming::default()
        };
        let plain = floor(LineSettings::DEFAULT, &[1, 2, 3, 4]);
        let usb = CollectFloor::over(LineSettings::DEFAULT, adapter, &[1, 2, 3, 4]).unwrap();
        assert_eq!(usb.idle(), plain.idle() + US(1_000));
        assert_eq!(usb.round(&[2]), plain.round(&[2]) + US(2_000));
        assert_eq!(usb.per_event(), plain.per_event() + US(1_000));
    }

    #[test]
    fn a_members_rdelaym_counts_once_per_collect() {
        // RDELAYM = 50: 5 ms more before any slot, in each Collect of the round.
        let plain = floor(LineSettings::DEFAULT, &[1, 2, 3, 4]);
        let late = plain.with_frame_timeout(US(5_000));
        assert_eq!(late.idle(), plain.idle() + US(5_000));
        assert_eq!(late.round(&[2]), plain.round(&[2]) + US(10_000));
        assert_eq!(late.per_event(), plain.per_event() + US(5_000));
    }
}
