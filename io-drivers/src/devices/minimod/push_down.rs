//! What the push-down planner hands a MiniMod's driver, typed: automatic-output conditions
//! (AON/AOFF), the outputs' start values, the input latencies of `debounce` / `stretch`
//! tags, and the pulse width the scan writes to YPULSEn.
//!
//! The driver writes these at start-up, after its own settings, in the order of
//! [`super::driver`]'s "Start-up settings" (conditions armed last, after the start values;
//! see its `logic` part), and reads them back. Having them typed means the planner never
//! spells a register name or a mask as text for the driver to parse again.

use std::fmt;

use super::map::{self, condition_holds, Item, Space};
use super::settings::{Readback, Setting, Settings};
use super::text::format_condition;
use crate::devices::config::numbered_point;

/// Conditions per output and direction ("Automatic output management": YnAON1..3,
/// YnAOFF1..3).
pub const CONDITIONS: usize = 3;

/// Longest pulse, ms ("Pulse generation": 1 to 65000 ms).
pub const MAX_PULSE_MS: u16 = 65000;

numbered_point!(
    /// An output Y1..Y4.
    Output,
    "Y",
    1..=4
);

impl Output {
    /// Its bit in YWORD, YEVMASK and WDTYMASK.
    pub fn bit(self) -> u16 {
        1 << (self.0 - 1)
    }

    /// Its coil's map entry (Y1 = coil 0, 00001).
    fn coil(self) -> Option<&'static map::Entry> {
        let item = Item::Output(self.0 - 1);
        map::MAP
            .iter()
            .find(|e| e.space == Space::Coil && e.item == item)
    }
}

numbered_point!(
    /// An input X1..X3 (the ones the conditions and latencies work on).
    Input,
    "X",
    1..=3
);

/// One automatic-output condition: a product of X1..X3, each checked high or low. Manual,
/// "Automatic output management": the mask's low byte selects the inputs checked, its high
/// byte inverts them before the check (`X1=1, X2=0` is `0000.0010-0000.0011`). A mask with no
/// input checked never holds: it is an unused condition.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Condition(u16);

impl Condition {
    /// No input checked: never holds.
    pub const UNUSED: Condition = Condition(0);

    /// The condition that checks the inputs in `care` (bit 0 = X1) to be the levels in
    /// `levels`.
    pub fn product(care: u8, levels: u8) -> Self {
        let care = care & 0b111;
        Self(u16::from(care) | (u16::from(care & !levels) << 8))
    }

    /// The register value.
    pub fn mask(self) -> u16 {
        self.0
    }

    /// Whether it holds for inputs `inputs` (bit 0 = X1).
    pub fn holds(self, inputs: u8) -> bool {
        condition_holds(self.0, inputs)
    }

    /// Whether it checks no input.
    pub fn is_unused(self) -> bool {
        self.0 & 0xFF == 0
    }
}

impl fmt::Display for Condition {
    /// The manual's text form (`X1-X2`); `unused` for none.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match format_condition(self.0) {
            _ if self.is_unused() => f.write_str("unused"),
            Some(text) => f.write_str(&text),
            None => write!(f, "{:#06x}", self.0),
        }
    }
}

/// The automatic ON and OFF conditions of one output: every millisecond, if an OFF condition
/// holds the output turns off, else if an ON condition holds it turns on, else it keeps its
/// state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AutoOutput {
    /// The output.
    pub output: Output,
    /// YnAON1..3.
    pub on: [Condition; CONDITIONS],
    /// YnAOFF1..3.
    pub off: [Condition; CONDITIONS],
}

impl AutoOutput {
    /// Its registers by the register table's names, AON1..3 then AOFF1..3, with their
    /// conditions.
    pub fn registers(&self) -> impl Iterator<Item = (&'static str, Condition)> + '_ {
        let y = self.output.0 - 1;
        let on = (0u8..)
            .zip(self.on)
            .map(move |(c, v)| (Item::AutoOn(y, c), v));
        let off = (0u8..)
            .zip(self.off)
            .map(move |(c, v)| (Item::AutoOff(y, c), v));
        on.chain(off).filter_map(|(item, v)| {
            map::MAP
                .iter()
                .find(|e| e.space == Space::HoldingRegister && e.item == item)
                .map(|e| (e.name, v))
        })
    }
}

/// The conditioning of an input: XLATUPn (a rising edge counts once the input has been high
/// that long) and XLATDNn (falling), in ms ("Input conditioning").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Latency {
    /// The input.
    pub input: Input,
    /// XLATUPn, ms.
    pub rising: Option<u16>,
    /// XLATDNn, ms.
    pub falling: Option<u16>,
}

impl Latency {
    /// Its registers by the register table's names, with their values (ms).
    pub fn registers(&self) -> Vec<(&'static str, u16)> {
        let i = self.input.0 - 1;
        [
            (Item::XlatUp(i), self.rising),
            (Item::XlatDn(i), self.falling),
        ]
        .into_iter()
        .filter_map(|(item, v)| {
            let e = map::MAP
                .iter()
                .find(|e| e.space == Space::HoldingRegister && e.item == item)?;
            Some((e.name, v?))
        })
        .collect()
    }
}

/// XLATUPn and XLATDNn at power-on, ms ("Digital inputs, latencies and counters": "The
/// power-on setting for these values ... are 20 milliseconds").
pub(crate) const POWER_ON_LATENCY_MS: u16 = 20;

/// How long input `input` must hold before the module takes a change of it, either way: the
/// longer of XLATUPn and XLATDNn, as the plan's conditioning, else the project's settings,
/// else the power-on value set them. Every reaction to that input, the module's own or the
/// scan's, waits this long first.
pub(crate) fn input_latency(
    own: &Settings,
    push_down: &PushDown,
    input: Input,
) -> std::time::Duration {
    let planned = push_down.latencies.iter().find(|l| l.input == input);
    let edge = |planned: Option<u16>, name: String| {
        planned
            .or_else(|| own.register(&name))
            .unwrap_or(POWER_ON_LATENCY_MS)
    };
    let n = input.number();
    let rising = edge(planned.and_then(|l| l.rising), format!("XLATUP{n}"));
    let falling = edge(planned.and_then(|l| l.falling), format!("XLATDN{n}"));
    std::time::Duration::from_millis(u64::from(rising.max(falling)))
}

/// A pulse width for YPULSEn, 1..=65000 ms ("Pulse generation").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PulseWidth(u16);

impl PulseWidth {
    /// `ms` if the pulser takes it.
    pub fn from_ms(ms: u16) -> Option<Self> {
        (1..=MAX_PULSE_MS).contains(&ms).then_some(Self(ms))
    }

    /// The register value, ms.
    pub fn ms(self) -> u16 {
        self.0
    }
}

impl fmt::Display for PulseWidth {
    /// The register value (ms).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// Everything the planner pushes into one MiniMod.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct PushDown {
    /// Automatic outputs, one per output at most.
    pub auto: Vec<AutoOutput>,
    /// Start values of pushed-down outputs whose rung keeps a state (a latch, a pulse),
    /// written after the old tables are cleared and before these are armed.
    pub initial: Vec<(Output, bool)>,
    /// Input conditioning.
    pub latencies: Vec<Latency>,
}

impl PushDown {
    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.auto.is_empty() && self.initial.is_empty() && self.latencies.is_empty()
    }

    /// The start-up settings it adds to the module's own `settings`: the latencies, the start
    /// values, the conditions; then, with automatic outputs, the read-back of Y1..Y4 every
    /// cycle (so the image shows what the conditions did) unless the project chose its own,
    /// and in event mode YEVMASK for the outputs the conditions drive unless the project set
    /// it.
    pub fn settings(&self, own: &Settings) -> Vec<Setting> {
        let mut out = Vec::new();
        for l in &self.latencies {
            for (name, value) in l.registers() {
                out.extend(Setting::holding(name, value));
            }
        }
        for &(y, on) in &self.initial {
            out.extend(y.coil().map(|e| Setting::Coils {
                name: e.name,
                addr: e.addr,
                count: 1,
                bits: u8::from(on),
            }));
        }
        for a in &self.auto {
            for (name, c) in a.registers() {
                out.extend(Setting::holding(name, c.mask()));
            }
        }
        if self.auto.is_empty() {
            return out;
        }
        if own.readback().is_none() {
            out.push(Setting::Readback(Readback::Every(1)));
        }
        if own.events() && !own.sets("YEVMASK") {
            let ys = self.auto.iter().fold(0, |acc, a| acc | a.output.bit());
            out.extend(Setting::holding("YEVMASK", ys));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_are_the_manuals_masks() {
        // "X1=1, X2=0 ... can be expressed with the binary mask 0000.0010-0000.0011".
        let c = Condition::product(0b011, 0b001);
        assert_eq!(c.mask(), 0x0203);
        assert_eq!(c.to_string(), "X1-X2");
        assert_eq!(Condition::UNUSED.to_string(), "unused");
        assert!(c.holds(0b001) && !c.holds(0b011) && !Condition::UNUSED.holds(0));
    }

    #[test]
    fn tables_become_the_register_settings_the_driver_writes() {
        let y2 = Output::named("Y2").unwrap();
        let push = PushDown {
            auto: vec![AutoOutput {
                output: y2,
                on: [
                    Condition::product(1, 1),
                    Condition::UNUSED,
                    Condition::UNUSED,
                ],
                off: [
                    Condition::product(2, 2),
                    Condition::UNUSED,
                    Condition::UNUSED,
                ],
            }],
            initial: vec![(y2, false)],
            latencies: vec![Latency {
                input: Input::new(1).unwrap(),
                rising: Some(20),
                falling: None,
            }],
        };
        let s = push.settings(&Settings::default());
        let reg = |name: &str| {
            s.iter().find_map(|x| match *x {
                Setting::Register {
                    name: n,
                    addr,
                    value,
                } if n == name => Some((addr, value)),
                _ => None,
            })
        };
        assert_eq!(reg("XLATUP1"), Some((19, 20)));
        assert_eq!(reg("Y2AON1"), Some((54, 0x0001)));
        assert_eq!(reg("Y2AOFF1"), Some((66, 0x0002)), "40067");
        assert_eq!(reg("Y2AON2"), Some((55, 0)));
        assert!(s.contains(&Setting::Coils {
            name: "Y2",
            addr: 1,
            count: 1,
            bits: 0
        }));
        assert!(s.contains(&Setting::Readback(Readback::Every(1))));
        assert_eq!(reg("YEVMASK"), None, "not in event mode");
        let events = Settings::from_items(vec![
            Setting::Events(true),
            Setting::Readback(Readback::Off),
        ]);
        let s = push.settings(&events);
        assert!(
            !s.iter().any(|x| matches!(x, Setting::Readback(_))),
            "the project's own"
        );
        assert!(s.iter().any(|x| matches!(
            x,
            Setting::Register {
                name: "YEVMASK",
                value: 0b10,
                ..
            }
        )));
        assert_eq!(PulseWidth::from_ms(65001), None);
        assert_eq!(PulseWidth::from_ms(500).map(PulseWidth::ms), Some(500));
    }
}
