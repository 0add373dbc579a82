//! Who turns a line's transceiver round after a request, and so how soon a module may answer.
//!
//! MiniMod manual, "Setting the reply delay": "Because the RS-485 line is half-duplex,
//! transmissions from two devices must not overlap. Minimod waits 1/100 of a second, before
//! replying, in order to allow the master to deactivate its transmitter". A reply delay of
//! 0 (`RDELAYT=0`, the range is 0 to 200 hundredths) is safe only when the master's
//! transmitter is off within a character of its request's end: then the module's first
//! character, which its UART starts no sooner than the request's last one has been received,
//! cannot meet the master's driver still on. That holds for
//! - the kernel's RS-485 mode (`rs485:`), which drops RTS when the UART's shift register is
//!   empty, plus its `delay_after_send` (so only with that delay within one character);
//! - an adapter that switches by itself (`direction: auto`: most USB RS-485 adapters, which
//!   turn round on the TX line's idle, within a bit or a character);
//! - the simulated line, which has no transceiver.
//!
//! A host that switches RTS itself, or an adapter nobody declared, may hold the line for
//! milliseconds (a user-space RTS toggle waits for the port to drain, then the scheduler):
//! the factory 10 ms stays.

use std::time::Duration;

use super::super::model::{BusConfig, PortConfig};

/// `direction:` of a bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Direction {
    /// The host (or something undeclared) turns the transceiver round: `host`, the default.
    #[default]
    Host,
    /// The adapter turns round by itself within a character: `auto`.
    Auto,
}

impl std::str::FromStr for Direction {
    type Err = ();

    fn from_str(s: &str) -> Result<Self, ()> {
        match s {
            "host" => Ok(Direction::Host),
            "auto" => Ok(Direction::Auto),
            _ => Err(()),
        }
    }
}

/// Why a line turns round within a character, so that a module may answer at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FastTurn {
    /// The simulated line.
    Simulated,
    /// The kernel's RS-485 mode, with its delay after send.
    Kernel(Duration),
    /// An adapter declared `direction: auto`.
    AutoAdapter,
}

impl FastTurn {
    /// The words `check` prints.
    pub fn describe(self) -> String {
        match self {
            FastTurn::Simulated => "the simulated line has no transceiver to turn round".into(),
            FastTurn::Kernel(d) if d.is_zero() => {
                "the kernel's RS-485 mode (rs485:) drops RTS at the request's last bit".into()
            }
            FastTurn::Kernel(d) => format!(
                "the kernel's RS-485 mode (rs485:) drops RTS {} after the request's last bit, \
                 within a character",
                crate::scan::fmt_duration(d)
            ),
            FastTurn::AutoAdapter => {
                "the adapter turns round by itself (direction: auto), within a character".into()
            }
        }
    }
}

/// Why a line may not: the words of the refusal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlowTurn {
    /// The host switches, or nobody said.
    Host,
    /// `rs485:` holds RTS longer than a character after the request.
    KernelDelay {
        /// `delay_after_send`.
        after: Duration,
        /// One character at the line's settings.
        char_time: Duration,
    },
    /// A network bus: the gateway or serial server turns its own line round.
    Network,
}

impl std::fmt::Display for SlowTurn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SlowTurn::Host => write!(
                f,
                "the line's direction control is the host's (direction: host, no rs485:), \
                 which may keep its transmitter on for milliseconds after a request; configure \
                 the kernel's RS-485 mode (rs485:) or declare an auto-direction adapter \
                 (direction: auto)"
            ),
            SlowTurn::KernelDelay { after, char_time } => write!(
                f,
                "rs485.delay_after_send {} keeps the transmitter on longer than a character \
                 ({}); lower it to 0ms",
                crate::scan::fmt_duration(*after),
                crate::scan::fmt_duration(*char_time)
            ),
            SlowTurn::Network => write!(
                f,
                "a network bus's line is turned round by its gateway or serial server, which \
                 softplc cannot see"
            ),
        }
    }
}

/// Whether bus `bus` turns round within a character.
pub(crate) fn turnaround(bus: &BusConfig) -> Result<FastTurn, SlowTurn> {
    match &bus.port {
        PortConfig::Sim => Ok(FastTurn::Simulated),
        PortConfig::Tcp(_) => Err(SlowTurn::Network),
        PortConfig::Serial(_) => {
            if bus.direction == Direction::Auto {
                return Ok(FastTurn::AutoAdapter);
            }
            match &bus.rs485 {
                None => Err(SlowTurn::Host),
                Some(mode) => {
                    let char_time = bus.settings.char_time();
                    if mode.delay_after_send <= char_time {
                        Ok(FastTurn::Kernel(mode.delay_after_send))
                    } else {
                        Err(SlowTurn::KernelDelay {
                            after: mode.delay_after_send,
                            char_time,
                        })
                    }
                }
            }
        }
    }
}
