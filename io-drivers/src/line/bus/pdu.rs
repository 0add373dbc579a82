//! The exchange path of a transport that carries Modbus requests whole (Modbus TCP,
//! [`crate::line::transport::PduChannel`]): no RTU framing, no silences, no guard and flush
//! (the channel drops its connection after a miss instead); the outcome is the same
//! [`Exchanged`] the byte path gives, so counters, retries, quality, loss and recovery are
//! the serial line's.

use std::time::Duration;

use super::{BusOwner, Exchanged, Miss};
use crate::driver::Reply;
use crate::line::transport::CallMiss;
use crate::modbus::master::validate_request;
use crate::modbus::Request;
use crate::wire::trace::WireEvent;

impl BusOwner {
    /// Whether this bus's transport carries Modbus requests whole.
    pub(crate) fn carries_pdus(&mut self) -> bool {
        self.transport.pdu_channel().is_some()
    }

    /// One request to `unit` on the PDU channel, waiting at most `wait` for its answer.
    pub(super) fn exchange_pdu(
        &mut self,
        unit: u8,
        request: &Request,
        wait: Duration,
    ) -> Exchanged {
        let mut done = Exchanged::nothing_yet();
        // A broadcast gets no answer on TCP to tell it was heard: drivers on a TCP bus address
        // their unit, and anything else is refused before it is sent.
        if unit == 0 || validate_request(unit, request).is_err() {
            done.outcome = Err(Miss::Encode);
            return done;
        }
        let started = self.transport.now();
        let Some(channel) = self.transport.pdu_channel() else {
            done.outcome = Err(Miss::Encode);
            return done;
        };
        let answer = channel.call(unit, request, wait);
        let now = self.transport.now();
        // A connection that could not be made sent nothing.
        if !matches!(answer, Err(CallMiss::Line(_))) {
            done.sent = Some(started);
        }
        self.line_free_at = now;
        done.outcome = match answer {
            Ok(response) => {
                done.round_trip = Some(now - started);
                Ok(Some(Reply::Modbus(response)))
            }
            Err(CallMiss::Silence) => {
                self.trace(now, WireEvent::Timeout { waited: wait });
                Err(Miss::Silence)
            }
            Err(CallMiss::Bad(e)) => Err(Miss::Bad(e)),
            Err(CallMiss::Line(e)) => Err(Miss::Line(e)),
        };
        done
    }
}
