//! The MiniMod's event queue for FC 70 Collect.
//!
//! Manual, "Modbus function “Collect” (event management)", "The Modbus function Collect" and
//! the register tables (EVX1..3 / XEVMASK, EVFB1..2, EVY1..4 / YEVMASK, EVENTSPRS):
//! - the module stores input and output variations in a queue, cleared when the transmission
//!   is acknowledged;
//! - a Collect `DST 70 FIRST LAST SLVACK SLVSEQ` authorises the slaves FIRST..=LAST to reply,
//!   in ascending address order, 3 ms each; only a slave with events replies, and only the
//!   first of them: the others are blocked until the next Collect;
//! - the reply is `SLAVE 70 SLVSEQ TYPE DATH DATL 0`, TYPE 2 for inputs and 1 for outputs,
//!   DATH:DATL the 16-bit mask after the variation;
//! - the next Collect acknowledges it with SLVACK = SLAVE and SLVSEQ = the received SLVSEQ.
//!
//! Choices where the manual is silent:
//! - An input event carries the input word of input register 0 / XWORD (X1..X3 in bits 0..2,
//!   FB1/FB2 = X9/X10 in bits 8/9); XEVMASK enables X1..X3, EVFB1..2 the feedbacks. An output
//!   event carries the levels at the output terminals Y1..Y4 (pulsers, blinkers and the
//!   watchdog included), enabled per output by YEVMASK.
//! - Variations are looked for at every 1 ms sample, between two samples at most one input
//!   and one output event is queued (input first).
//! - Every event gets its own SLVSEQ, counting 1..=255 and wrapping to 1; 0 is never used, so
//!   `SLVACK = me, SLVSEQ = 0` acknowledges nothing.
//! - An acknowledgement whose SLVSEQ is not the head event's is ignored; an unacknowledged
//!   event is sent again (with its SLVSEQ) at the next Collect.
//! - The queue holds [`QUEUE_CAPACITY`] events; when it is full the oldest is dropped, so the
//!   latest state is never lost and the master sees the loss as a gap in SLVSEQ.
//! - The reply starts [`COLLECT_TURNAROUND_MS`] into the slave's slot (the master needs its
//!   turnaround as for ordinary replies, where RDELAYT serves; RDELAYT itself would not fit a
//!   3 ms slot and does not apply).

use std::collections::VecDeque;

/// Events the queue holds.
pub(crate) const QUEUE_CAPACITY: usize = 16;
/// Length of one reply slot of a Collect, in ms.
pub(crate) const SLOT_MS: u64 = 3;
/// Where in its slot a slave starts its Collect reply, in ms.
pub(crate) const COLLECT_TURNAROUND_MS: u64 = 1;
/// TYPE of an output event.
pub(crate) const KIND_OUTPUTS: u8 = 1;
/// TYPE of an input event.
pub(crate) const KIND_INPUTS: u8 = 2;

/// Bits of the input word that can make events: X1..X3 and FB1/FB2.
const INPUT_EVENT_BITS: u16 = 0x0307;

/// One queued variation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Event {
    /// SLVSEQ, 1..=255.
    pub seq: u8,
    /// TYPE: `KIND_INPUTS` or `KIND_OUTPUTS`.
    pub kind: u8,
    /// DATH:DATL.
    pub data: u16,
}

/// The event enables and the queue.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Events {
    /// XEVMASK (EVX1..3 are its bits).
    xevmask: u16,
    /// YEVMASK (EVY1..4 are its bits).
    yevmask: u16,
    /// EVFB1..2, bits 0..1.
    evfb: u8,
    queue: VecDeque<Event>,
    next_seq: u8,
    /// Input word and output levels at the last sample.
    last_inputs: u16,
    last_outputs: u16,
    /// Events dropped because the queue was full.
    dropped: u64,
}

impl Events {
    /// Power-up: nothing enabled, queue empty, `inputs` and `outputs` as the first sample.
    pub fn new(inputs: u16, outputs: u16) -> Self {
        Self {
            xevmask: 0,
            yevmask: 0,
            evfb: 0,
            queue: VecDeque::with_capacity(QUEUE_CAPACITY),
            next_seq: 1,
            last_inputs: inputs,
            last_outputs: outputs,
            dropped: 0,
        }
    }

    /// XEVMASK.
    pub fn xevmask(&self) -> u16 {
        self.xevmask
    }

    /// Sets XEVMASK.
    pub fn set_xevmask(&mut self, mask: u16) {
        self.xevmask = mask;
    }

    /// YEVMASK.
    pub fn yevmask(&self) -> u16 {
        self.yevmask
    }

    /// Sets YEVMASK.
    pub fn set_yevmask(&mut self, mask: u16) {
        self.yevmask = mask;
    }

    /// EVFB1..2 as bits 0..1.
    pub fn evfb(&self) -> u8 {
        self.evfb
    }

    /// Sets EVFB1..2 (bits above 1 are dropped).
    pub fn set_evfb(&mut self, bits: u8) {
        self.evfb = bits & 0x03;
    }

    /// EVENTSPRS.
    pub fn present(&self) -> bool {
        !self.queue.is_empty()
    }

    /// Queued events, oldest first.
    pub fn queued(&self) -> impl Iterator<Item = &Event> {
        self.queue.iter()
    }

    /// Events dropped on a full queue since power-up.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// One sample: queues the enabled variations since the last one.
    pub fn observe(&mut self, inputs: u16, outputs: u16) {
        let input_enable = (self.xevmask & 0x0007) | (u16::from(self.evfb) << 8);
        if (inputs ^ self.last_inputs) & input_enable & INPUT_EVENT_BITS != 0 {
            self.push(KIND_INPUTS, inputs);
        }
        if (outputs ^ self.last_outputs) & self.yevmask & 0x000F != 0 {
            self.push(KIND_OUTPUTS, outputs);
        }
        self.last_inputs = inputs;
        self.last_outputs = outputs;
    }

    fn push(&mut self, kind: u8, data: u16) {
        if self.queue.len() >= QUEUE_CAPACITY {
            self.queue.pop_front();
            self.dropped += 1;
        }
        let seq = self.next_seq;
        self.next_seq = if seq == u8::MAX { 1 } else { seq + 1 };
        self.queue.push_back(Event { seq, kind, data });
    }

    /// A Collect for this module (broadcast or its address) from slave `me`'s point of view:
    /// applies the acknowledgement, then returns the event to send and its delay after the end
    /// of the request, if `me` is in the window and has one.
    pub fn collect(
        &mut self,
        me: u8,
        first: u8,
        last: u8,
        ack: u8,
        seq: u8,
    ) -> Option<(Event, u64)> {
        if ack == me && self.queue.front().is_some_and(|e| e.seq == seq) {
            self.queue.pop_front();
        }
        if !(first..=last).contains(&me) {
            return None;
        }
        let event = *self.queue.front()?;
        let slot = u64::from(me - first);
        Some((event, slot * SLOT_MS + COLLECT_TURNAROUND_MS))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_enabled_variations_are_queued() {
        let mut e = Events::new(0, 0);
        e.observe(0b001, 0);
        assert!(!e.present(), "nothing enabled");
        e.set_xevmask(0b010);
        e.observe(0b000, 0);
        assert!(!e.present(), "X1 is not enabled");
        e.observe(0b010, 0);
        assert_eq!(
            e.queued().copied().collect::<Vec<_>>(),
            [Event {
                seq: 1,
                kind: KIND_INPUTS,
                data: 0b010
            }]
        );
        e.set_evfb(0b01);
        e.observe(0x0102, 0);
        e.set_yevmask(0b1000);
        e.observe(0x0102, 0b0100);
        e.observe(0x0102, 0b1100);
        let kinds: Vec<_> = e.queued().map(|ev| (ev.seq, ev.kind, ev.data)).collect();
        assert_eq!(kinds, [(1, 2, 0x0002), (2, 2, 0x0102), (3, 1, 0b1100)]);
    }

    #[test]
    fn collect_window_slots_and_acknowledgement() {
        let mut e = Events::new(0, 0);
        e.set_xevmask(7);
        e.observe(1, 0);
        e.observe(0, 0);
        // Slave 4 in window 1..=16: its slot is the fourth.
        let (ev, delay) = e.collect(4, 1, 16, 0, 0).unwrap();
        assert_eq!(
            (ev.seq, ev.data, delay),
            (1, 1, 3 * SLOT_MS + COLLECT_TURNAROUND_MS)
        );
        // A wrong SLVSEQ acknowledges nothing; the event is sent again.
        assert_eq!(e.collect(4, 1, 16, 4, 9).map(|(ev, _)| ev.seq), Some(1));
        // Window 5..=16 acknowledging 4: no reply from 4, but its head is gone.
        assert_eq!(e.collect(4, 5, 16, 4, 1), None);
        assert_eq!(e.queued().next().map(|ev| ev.seq), Some(2));
        assert_eq!(e.collect(4, 4, 4, 4, 2), None);
        assert!(!e.present());
    }

    #[test]
    fn a_full_queue_drops_the_oldest_and_seq_skips_zero() {
        let mut e = Events::new(0, 0);
        e.set_xevmask(1);
        for i in 1..=300u16 {
            e.observe(i & 1, 0);
        }
        assert_eq!(e.queued().count(), QUEUE_CAPACITY);
        assert_eq!(e.dropped(), 300 - QUEUE_CAPACITY as u64);
        assert!(e.queued().all(|ev| ev.seq != 0));
        let last = e.queued().last().unwrap();
        assert_eq!(
            (last.seq, last.data),
            (45, 0),
            "300th event: 255 wrapped to 1"
        );
    }
}
