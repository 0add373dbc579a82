//! Where a request ends, for a module that frames by silence on the line.
//!
//! A Modbus RTU slave knows a request has ended only when the line has been silent long enough
//! (MiniMod manual, "Setting the Modbus communication timeout": "the end of a message is
//! signaled by a silence on the line, lasting 28 bits or more, and Minimod respects this
//! value", enlarged by RDELAYM tenths of a millisecond). A master that pauses inside a request
//! for less than that silence still sends one request; a longer pause makes two, and neither
//! half passes the CRC. [`Assembly`] is one module's request in the making: the bytes heard so
//! far and when the last of them ended. The world keeps one per module that declares its
//! silence ([`crate::sim::SimDevice::frame_silence`]) and hands the module the request once
//! the silence has passed ([`crate::sim::line::SimWorld::settle`]) or once a burst comes after
//! a longer pause.

use std::time::Duration;

use crate::time::LineInstant;

/// One module's request in the making.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Assembly {
    bytes: Vec<u8>,
    /// When the last byte ended on the wire.
    end: LineInstant,
}

/// What a burst of bytes does to a module's assembly.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Heard {
    /// The burst continues the request (or starts one): nothing to hand over yet.
    Continues,
    /// The burst came after the silence: the request before it is complete (bytes, end).
    Ended(Vec<u8>, LineInstant),
}

impl Assembly {
    /// A burst `bytes` that started on the wire at `start` and ended at `end`, heard by a
    /// module whose requests end after `silence`; `pending` is its assembly so far.
    pub(crate) fn hear(
        pending: &mut Option<Assembly>,
        bytes: &[u8],
        start: LineInstant,
        end: LineInstant,
        silence: Duration,
    ) -> Heard {
        match pending {
            Some(a) if start - a.end < silence => {
                a.bytes.extend_from_slice(bytes);
                a.end = end;
                Heard::Continues
            }
            _ => {
                let before = pending.replace(Assembly {
                    bytes: bytes.to_vec(),
                    end,
                });
                match before {
                    Some(a) => Heard::Ended(a.bytes, a.end),
                    None => Heard::Continues,
                }
            }
        }
    }

    /// The request, once the line has been silent until `now` for at least `silence` after
    /// it (bytes, end); `None` while it may still go on.
    pub(crate) fn complete(
        pending: &mut Option<Assembly>,
        now: LineInstant,
        silence: Duration,
    ) -> Option<(Vec<u8>, LineInstant)> {
        let ended = pending.as_ref().is_some_and(|a| a.end + silence <= now);
        ended
            .then(|| pending.take())
            .flatten()
            .map(|a| (a.bytes, a.end))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> LineInstant {
        LineInstant::after_origin(Duration::from_millis(n))
    }

    #[test]
    fn a_pause_shorter_than_the_silence_joins_and_a_longer_one_splits() {
        let silence = Duration::from_micros(1460);
        let mut p = None;
        assert_eq!(
            Assembly::hear(&mut p, b"ab", ms(0), ms(1), silence),
            Heard::Continues
        );
        // 1 ms of pause: the same request.
        assert_eq!(
            Assembly::hear(&mut p, b"cd", ms(2), ms(3), silence),
            Heard::Continues
        );
        assert_eq!(
            Assembly::complete(&mut p, ms(4), silence),
            None,
            "not silent long enough"
        );
        // 3 ms of pause: the first request ended.
        assert_eq!(
            Assembly::hear(&mut p, b"ef", ms(6), ms(7), silence),
            Heard::Ended(b"abcd".to_vec(), ms(3))
        );
        assert_eq!(
            Assembly::complete(
                &mut p,
                LineInstant::after_origin(Duration::from_micros(8460)),
                silence
            ),
            Some((b"ef".to_vec(), ms(7)))
        );
        assert_eq!(p, None);
    }
}
