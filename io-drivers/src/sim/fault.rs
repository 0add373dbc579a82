//! Fault injection on the virtual line: what a real RS-485 bus does to frames.
//!
//! A [`FaultRule`] attaches a [`Fault`] to one device (or to every device) for a number of
//! replies or at a rate. The world applies the rules to each reply as it goes on the wire, and
//! [`LineFaults::dead`] silences the whole line. The random choices come from a seeded
//! generator, so a faulty run replays exactly on a virtual clock.

use std::fmt;
use std::time::Duration;

use crate::modbus::crc::append_crc;

/// One kind of fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Noise bytes on the line just before the reply.
    Garbage {
        /// How many bytes.
        bytes: u8,
    },
    /// One bit of the reply flipped (a CRC error at the master).
    FlipBit,
    /// Bit `bit` (0: the least significant) of byte `byte` of the reply flipped, where the
    /// reply has that byte: a chosen character garbled, as on a line without parity (a text
    /// reply has no check, so the master reads another character).
    FlipBitAt {
        /// The byte's offset in the reply.
        byte: u8,
        /// The bit, 0..=7.
        bit: u8,
    },
    /// The reply cut after `keep` bytes.
    Truncate {
        /// Bytes that make it.
        keep: u8,
    },
    /// The reply starts `by` later than the device's reply delay.
    Late {
        /// Extra delay.
        by: Duration,
    },
    /// The reply sent twice, back to back.
    Duplicate,
    /// The reply carries another unit address (with a valid CRC).
    WrongAddress {
        /// The address it claims.
        unit: u8,
    },
    /// The device babbles: noise bytes overlapping its reply.
    Babble {
        /// How many bytes.
        bytes: u8,
    },
    /// The device does not answer.
    Silent,
}

impl Fault {
    /// Parses the `softplc sim` form: `garbage 5`, `crc`, `truncate 3`, `late 80ms`,
    /// `duplicate`, `wrong-address 9`, `babble 20`, `silent`, `flip-bit 12 1` (byte 12, bit 1).
    pub fn parse(words: &[&str]) -> Result<Fault, String> {
        let num = |w: Option<&&str>, what: &str| -> Result<u8, String> {
            w.and_then(|s| s.parse::<u8>().ok())
                .ok_or_else(|| format!("{what} needs a number 0..=255"))
        };
        Ok(match words {
            ["garbage", rest @ ..] => Fault::Garbage {
                bytes: num(rest.first(), "garbage")?,
            },
            ["crc"] | ["flip-bit"] => Fault::FlipBit,
            ["flip-bit", byte, bit] => Fault::FlipBitAt {
                byte: num(Some(byte), "flip-bit's byte")?,
                bit: bit
                    .parse::<u8>()
                    .ok()
                    .filter(|b| *b < 8)
                    .ok_or_else(|| "flip-bit's bit must be 0..=7".to_string())?,
            },
            ["truncate", rest @ ..] => Fault::Truncate {
                keep: num(rest.first(), "truncate")?,
            },
            ["late", d] => Fault::Late { by: parse_ms(d)? },
            ["duplicate"] => Fault::Duplicate,
            ["wrong-address", rest @ ..] => Fault::WrongAddress {
                unit: num(rest.first(), "wrong-address")?,
            },
            ["babble", rest @ ..] => Fault::Babble {
                bytes: num(rest.first(), "babble")?,
            },
            ["silent"] => Fault::Silent,
            _ => {
                return Err(format!(
                    "unknown fault {:?}; one of: {}",
                    words.join(" "),
                    FAULT_HELP
                ))
            }
        })
    }
}

/// The fault kinds as `softplc sim` takes them.
pub(crate) const FAULT_HELP: &str =
    "garbage N | crc | flip-bit BYTE BIT | truncate N | late 80ms | duplicate | wrong-address N \
     | babble N | silent";

fn parse_ms(text: &str) -> Result<Duration, String> {
    let ms = text.strip_suffix("ms").unwrap_or(text);
    ms.parse::<u64>()
        .map(Duration::from_millis)
        .map_err(|_| format!("{text:?}: expected milliseconds like 80ms"))
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fault::Garbage { bytes } => write!(f, "garbage {bytes}"),
            Fault::FlipBit => write!(f, "crc"),
            Fault::FlipBitAt { byte, bit } => write!(f, "flip-bit {byte} {bit}"),
            Fault::Truncate { keep } => write!(f, "truncate {keep}"),
            Fault::Late { by } => write!(f, "late {}ms", by.as_millis()),
            Fault::Duplicate => write!(f, "duplicate"),
            Fault::WrongAddress { unit } => write!(f, "wrong-address {unit}"),
            Fault::Babble { bytes } => write!(f, "babble {bytes}"),
            Fault::Silent => write!(f, "silent"),
        }
    }
}

/// How often a rule applies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Frequency {
    /// To the next `n` replies, then the rule is spent.
    Next(u32),
    /// To the `n`-th next reply only (1: the next one), then the rule is spent: a fault on
    /// one chosen exchange of a sequence (a start-up's read-back).
    Nth(u32),
    /// To each reply with this probability (0..=1).
    Rate(f64),
    /// To every reply until cleared.
    Always,
}

/// A fault attached to a device.
#[derive(Debug, Clone, PartialEq)]
pub struct FaultRule {
    /// The device index in the world, or every device.
    pub device: Option<usize>,
    /// The fault.
    pub fault: Fault,
    /// How often.
    pub frequency: Frequency,
}

/// A reply after the faults: the bytes that reach the wire and when they start.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Wire {
    /// Bursts of bytes, each with its start offset from the end of the request.
    pub bursts: Vec<(Duration, Vec<u8>)>,
}

/// The faults of one world.
#[derive(Debug, Clone, Default)]
pub struct LineFaults {
    rules: Vec<FaultRule>,
    /// Lines that are dead (nothing reaches the devices, nothing comes back).
    dead: Vec<usize>,
    rng: u64,
    /// Faults applied so far, per kind name.
    pub applied: u64,
}

impl LineFaults {
    /// No faults; `seed` makes rate-based rules repeatable.
    pub fn new(seed: u64) -> Self {
        Self {
            rng: seed | 1,
            ..Self::default()
        }
    }

    /// Adds a rule.
    pub fn add(&mut self, rule: FaultRule) {
        self.rules.push(rule);
    }

    /// Removes every rule of `device` (or all rules).
    pub fn clear(&mut self, device: Option<usize>) {
        match device {
            Some(d) => self.rules.retain(|r| r.device != Some(d)),
            None => self.rules.clear(),
        }
    }

    /// The active rules.
    pub fn rules(&self) -> &[FaultRule] {
        &self.rules
    }

    /// Marks `line` dead or alive.
    pub fn set_dead(&mut self, line: usize, dead: bool) {
        self.dead.retain(|l| *l != line);
        if dead {
            self.dead.push(line);
        }
    }

    /// Whether `line` is dead.
    pub fn is_dead(&self, line: usize) -> bool {
        self.dead.contains(&line)
    }

    fn next_random(&mut self) -> u64 {
        // xorshift64: tiny, deterministic, good enough to pick bits and bytes.
        let mut x = self.rng;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.rng = x;
        x
    }

    /// Applies the rules for `device` to a reply that would start at `delay`, with `char_time`
    /// per byte on the wire.
    pub fn apply(
        &mut self,
        device: usize,
        reply: Vec<u8>,
        delay: Duration,
        char_time: Duration,
    ) -> Wire {
        let mut wire = Wire {
            bursts: vec![(delay, reply)],
        };
        let mut i = 0;
        while i < self.rules.len() {
            let rule = self.rules[i].clone();
            if rule.device.is_some_and(|d| d != device) {
                i += 1;
                continue;
            }
            let fires = match rule.frequency {
                Frequency::Always => true,
                Frequency::Next(_) => true,
                Frequency::Nth(n) => n <= 1,
                Frequency::Rate(p) => (self.next_random() % 1_000_000) as f64 / 1e6 < p,
            };
            if let Frequency::Next(n) | Frequency::Nth(n) = rule.frequency {
                if n <= 1 {
                    self.rules.remove(i);
                } else {
                    self.rules[i].frequency = match rule.frequency {
                        Frequency::Nth(_) => Frequency::Nth(n - 1),
                        _ => Frequency::Next(n - 1),
                    };
                    i += 1;
                }
            } else {
                i += 1;
            }
            if fires {
                self.applied += 1;
                wire = self.inject(rule.fault, wire, char_time);
            }
        }
        wire
    }

    fn inject(&mut self, fault: Fault, mut wire: Wire, char_time: Duration) -> Wire {
        let Some((delay, reply)) = wire.bursts.first().cloned() else {
            return wire;
        };
        match fault {
            Fault::Silent => wire.bursts.clear(),
            Fault::FlipBit => {
                if !reply.is_empty() {
                    let r = self.next_random();
                    let byte = (r as usize) % reply.len();
                    let bit = (r >> 32) % 8;
                    wire.bursts[0].1[byte] ^= 1 << bit;
                }
            }
            Fault::FlipBitAt { byte, bit } => {
                if let Some(b) = wire.bursts[0].1.get_mut(usize::from(byte)) {
                    *b ^= 1u8.checked_shl(u32::from(bit)).unwrap_or(0);
                }
            }
            Fault::Truncate { keep } => wire.bursts[0].1.truncate(usize::from(keep)),
            Fault::Late { by } => wire.bursts[0].0 = delay + by,
            Fault::Duplicate => {
                let len = u32::try_from(reply.len()).unwrap_or(u32::MAX);
                wire.bursts
                    .push((delay + char_time * len.saturating_add(4), reply));
            }
            Fault::WrongAddress { unit } => {
                if reply.len() >= 3 {
                    let mut r = reply[..reply.len() - 2].to_vec();
                    r[0] = unit;
                    append_crc(&mut r);
                    wire.bursts[0].1 = r;
                }
            }
            Fault::Garbage { bytes } => {
                let noise: Vec<u8> = (0..bytes).map(|_| self.next_random() as u8).collect();
                let lead = char_time * (u32::from(bytes) + 4);
                // Kept after the reply in the list (the line orders bursts by time), so that rules
                // applied after this one still act on the reply itself.
                wire.bursts.push((delay.saturating_sub(lead), noise));
            }
            Fault::Babble { bytes } => {
                let noise: Vec<u8> = (0..bytes).map(|_| self.next_random() as u8).collect();
                wire.bursts.push((delay + char_time * 2, noise));
            }
        }
        wire
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CT: Duration = Duration::from_micros(573);
    const REPLY: [u8; 7] = [0x05, 0x02, 0x02, 0x01, 0x00, 0x49, 0xE8];

    fn one(fault: Fault) -> Wire {
        let mut f = LineFaults::new(7);
        f.add(FaultRule {
            device: None,
            fault,
            frequency: Frequency::Next(1),
        });
        f.apply(0, REPLY.to_vec(), Duration::from_millis(10), CT)
    }

    #[test]
    fn each_fault_changes_the_wire_as_named() {
        assert!(one(Fault::Silent).bursts.is_empty());
        let flipped = one(Fault::FlipBit);
        let diff: u32 = flipped.bursts[0]
            .1
            .iter()
            .zip(REPLY)
            .map(|(a, b)| (a ^ b).count_ones())
            .sum();
        assert_eq!(diff, 1);
        assert_eq!(one(Fault::Truncate { keep: 3 }).bursts[0].1, &REPLY[..3]);
        assert_eq!(
            one(Fault::Late {
                by: Duration::from_millis(80)
            })
            .bursts[0]
                .0,
            Duration::from_millis(90)
        );
        assert_eq!(one(Fault::Duplicate).bursts.len(), 2);
        let wrong = one(Fault::WrongAddress { unit: 9 });
        assert_eq!(wrong.bursts[0].1[0], 9);
        assert!(crate::modbus::crc::check_crc(&wrong.bursts[0].1));
        let garbage = one(Fault::Garbage { bytes: 4 });
        assert_eq!(
            garbage.bursts[0].1, REPLY,
            "the reply stays first for later rules"
        );
        assert_eq!(garbage.bursts[1].1.len(), 4);
        assert!(
            garbage.bursts[1].0 < garbage.bursts[0].0,
            "the noise comes before it"
        );
    }

    #[test]
    fn counted_rules_are_spent_and_rates_repeat_with_the_seed() {
        let mut f = LineFaults::new(1);
        f.add(FaultRule {
            device: Some(0),
            fault: Fault::Silent,
            frequency: Frequency::Next(2),
        });
        assert!(
            f.apply(1, REPLY.to_vec(), Duration::ZERO, CT).bursts.len() == 1,
            "other device"
        );
        assert!(f
            .apply(0, REPLY.to_vec(), Duration::ZERO, CT)
            .bursts
            .is_empty());
        assert!(f
            .apply(0, REPLY.to_vec(), Duration::ZERO, CT)
            .bursts
            .is_empty());
        assert_eq!(
            f.apply(0, REPLY.to_vec(), Duration::ZERO, CT).bursts.len(),
            1
        );

        // The third reply only, one chosen bit: '3' (0x33) reads as '1' (0x31).
        let mut f = LineFaults::new(1);
        f.add(FaultRule {
            device: None,
            fault: Fault::FlipBitAt { byte: 1, bit: 1 },
            frequency: Frequency::Nth(3),
        });
        let replies: Vec<Vec<u8>> = (0..4)
            .map(|_| {
                f.apply(0, b"=3".to_vec(), Duration::ZERO, CT).bursts[0]
                    .1
                    .clone()
            })
            .collect();
        assert_eq!(replies, [b"=3", b"=3", b"=1", b"=3"]);
        assert!(f.rules().is_empty(), "spent");

        let run = |seed| {
            let mut f = LineFaults::new(seed);
            f.add(FaultRule {
                device: None,
                fault: Fault::Silent,
                frequency: Frequency::Rate(0.3),
            });
            (0..100)
                .map(|_| {
                    f.apply(0, REPLY.to_vec(), Duration::ZERO, CT)
                        .bursts
                        .is_empty()
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(42), run(42));
        let silent = run(42).iter().filter(|s| **s).count();
        assert!((15..=45).contains(&silent), "{silent} of 100 at rate 0.3");
    }

    #[test]
    fn parses_the_sim_command_forms() {
        assert_eq!(
            Fault::parse(&["late", "80ms"]),
            Ok(Fault::Late {
                by: Duration::from_millis(80)
            })
        );
        assert_eq!(Fault::parse(&["crc"]), Ok(Fault::FlipBit));
        assert_eq!(
            Fault::parse(&["flip-bit", "12", "1"]),
            Ok(Fault::FlipBitAt { byte: 12, bit: 1 })
        );
        assert_eq!(
            Fault::parse(&["flip-bit", "12", "8"]),
            Err("flip-bit's bit must be 0..=7".to_string())
        );
        assert_eq!(
            Fault::parse(&["wrong-address", "9"]),
            Ok(Fault::WrongAddress { unit: 9 })
        );
        assert!(Fault::parse(&["garbage"]).is_err());
        assert!(Fault::parse(&["melt"]).is_err());
    }
}
