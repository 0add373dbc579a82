//! The definition of every block: its name, pins and their types, outputs, the forms each
//! language calls it in, and its documentation. Every language's checker, the VM, the ladder
//! drawing and the docs take what they need from here, so a new block is one [`BlockDef`] (a
//! line of the `blocks!` list in `mod.rs`) plus its behaviour (a [`Block`](super::Block)).

use super::{Kind, Member};

/// What a pin carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PinType {
    /// A power flow: a condition (ladder), a bool (Rhai). Left out, it is `false`.
    Bool,
    /// A time: a duration literal, or a number of milliseconds (a tag, a block's output).
    Time,
    /// A counter's preset: an `i32` (saturated into it).
    Count,
    /// A blink pattern: a string of `0` and `1` (see [`Pattern`](super::Pattern)).
    Pattern,
    /// A 16-bit mask (LAMP's): an integer, 0..=65535; a literal outside is refused, a tag's
    /// value is held to the range.
    Mask,
}

/// One input of a block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pin {
    /// The pin's name as the ladder drawing and the docs show it (`IN`, `PT`, `R`); lower
    /// case, it is the ladder's argument keyword (`r=reset`).
    pub name: &'static str,
    /// Its type.
    pub ty: PinType,
    /// Whether ladder takes it by position (`TON t(5s)`) as well as by keyword.
    pub positional: bool,
    /// The argument's name in Rhai's signatures and messages (`reset`, `load`).
    pub rhai: &'static str,
}

/// One way of calling a block: which pins a call gives (a BLINK blinks by times or plays a
/// pattern). Ladder tells the forms apart by the pins an instance's call names; Rhai has a
/// function per form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Form {
    /// The Rhai function.
    pub rhai: &'static str,
    /// The pins the form takes, by index into [`BlockDef::pins`], in the order of Rhai's
    /// arguments (after the instance's name). The first is always the power flow.
    pub pins: &'static [usize],
    /// How many of the last `pins` Rhai may leave out (bools: `false` then), each shorter
    /// call an overload of its own.
    pub optional: usize,
    /// A ladder call of this form, for the docs (`TON t(5s)`).
    pub example: &'static str,
    /// What it does, in one line of the docs.
    pub doc: &'static str,
}

impl Form {
    /// The pins of each Rhai overload of the form, shortest first (`stair(name, in, pt)`, then
    /// `stair(name, in, pt, reset)`).
    pub fn overloads(&self) -> impl Iterator<Item = &'static [usize]> {
        let pins = self.pins;
        (0..=self.optional)
            .rev()
            .map(move |left_out| &pins[..pins.len() - left_out])
    }
}

/// A block type: everything the languages, the VM and the docs know of it but its
/// behaviour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlockDef {
    /// Its kind.
    pub kind: Kind,
    /// The name programs use: `TON`, `R_TRIG`, ...; lower case, it is the Rhai function (and
    /// the `expr` function, where [`BlockDef::expr`] offers it).
    pub name: &'static str,
    /// Its inputs, in ladder order: the power flow (the IEC first input: `IN`, `CU`, `CLK`,
    /// `S1`, `S`, `EN`) first, then the arguments as a ladder call gives them.
    pub pins: &'static [Pin],
    /// The outputs an instance exposes; the first is the main output, the one a rung passes
    /// on to its coils and a Rhai call returns.
    pub outputs: &'static [Member],
    /// The forms it is called in (at least one).
    pub forms: &'static [Form],
    /// Whether `expr` offers it, as `name(E, PT)`: only blocks of a power flow and one time
    /// (each call site is an instance of its own there; `expr` names no instances).
    pub expr: bool,
}

impl BlockDef {
    /// The power flow: the first pin.
    pub fn main_input(&self) -> &'static Pin {
        &self.pins[0]
    }

    /// The output a rung passes on.
    pub fn main_output(&self) -> Member {
        self.outputs[0]
    }

    /// The pin named `name` (as [`Pin::name`], any case) and its index.
    pub fn pin(&self, name: &str) -> Option<(usize, &'static Pin)> {
        self.pins
            .iter()
            .enumerate()
            .find(|(_, p)| p.name.eq_ignore_ascii_case(name))
    }

    /// The lower-case name Rhai and `expr` call it by (`ton`; BLINK's first form).
    pub fn function(&self) -> &'static str {
        self.forms[0].rhai
    }

    /// The arguments a ladder call takes (every pin but the power flow).
    pub fn arguments(&self) -> &'static [Pin] {
        &self.pins[1..]
    }

    /// The arguments a ladder call of `form` takes, in ladder order.
    pub fn form_arguments<'a>(&'a self, form: &'a Form) -> impl Iterator<Item = &'static Pin> + 'a {
        let pins: &'static [Pin] = self.pins;
        pins.iter()
            .enumerate()
            .skip(1)
            .filter(move |(i, _)| form.pins.contains(i))
            .map(|(_, p)| p)
    }

    /// Whether a call is a power flow and one time, nothing else: a timer the VM runs as one
    /// instruction with its preset inline (`Instr::Timer`).
    pub fn is_plain_timer(&self) -> bool {
        matches!(
            self.pins,
            [
                Pin {
                    ty: PinType::Bool,
                    ..
                },
                Pin {
                    ty: PinType::Time,
                    ..
                }
            ]
        )
    }
}

const fn pin(name: &'static str, ty: PinType, positional: bool, rhai: &'static str) -> Pin {
    Pin {
        name,
        ty,
        positional,
        rhai,
    }
}

const fn form(
    rhai: &'static str,
    pins: &'static [usize],
    optional: usize,
    example: &'static str,
    doc: &'static str,
) -> Form {
    Form {
        rhai,
        pins,
        optional,
        example,
        doc,
    }
}

use PinType::{Bool, Count, Mask, Pattern, Time};

const IN: Pin = pin("IN", Bool, false, "in");
const PT: Pin = pin("PT", Time, true, "pt");
const R: Pin = pin("R", Bool, false, "reset");
const PV: Pin = pin("PV", Count, true, "pv");
const TIMER_OUT: &[Member] = &[Member::Q, Member::Et];
const COUNTER_OUT: &[Member] = &[Member::Q, Member::Cv];
const Q: &[Member] = &[Member::Q];

/// On-delay timer.
pub(crate) static TON: BlockDef = BlockDef {
    kind: Kind::Ton,
    name: "TON",
    pins: &[IN, PT],
    outputs: TIMER_OUT,
    forms: &[form(
        "ton",
        &[0, 1],
        0,
        "TON t(5s)",
        "Q true once IN has been true for PT",
    )],
    expr: true,
};

/// Off-delay timer.
pub(crate) static TOF: BlockDef = BlockDef {
    kind: Kind::Tof,
    name: "TOF",
    pins: &[IN, PT],
    outputs: TIMER_OUT,
    forms: &[form(
        "tof",
        &[0, 1],
        0,
        "TOF t(5s)",
        "Q true while IN, and PT after it falls",
    )],
    expr: true,
};

/// Pulse timer.
pub(crate) static TP: BlockDef = BlockDef {
    kind: Kind::Tp,
    name: "TP",
    pins: &[IN, PT],
    outputs: TIMER_OUT,
    forms: &[form(
        "tp",
        &[0, 1],
        0,
        "TP t(5s)",
        "a pulse of PT on a rising edge of IN",
    )],
    expr: true,
};

/// Staircase timer.
pub(crate) static STAIR: BlockDef = BlockDef {
    kind: Kind::Stair,
    name: "STAIR",
    pins: &[IN, PT, R],
    outputs: TIMER_OUT,
    forms: &[form(
        "stair",
        &[0, 1, 2],
        1,
        "STAIR s(30s, r=off)",
        "staircase: every rising edge (re)starts a pulse of PT; R ends it",
    )],
    expr: false,
};

/// Up counter.
pub(crate) static CTU: BlockDef = BlockDef {
    kind: Kind::Ctu,
    name: "CTU",
    pins: &[pin("CU", Bool, false, "cu"), PV, R],
    outputs: COUNTER_OUT,
    forms: &[form(
        "ctu",
        &[0, 2, 1],
        0,
        "CTU c(10, r=rst)",
        "rising edges of CU counted in CV; Q = CV ≥ PV",
    )],
    expr: false,
};

/// Down counter.
pub(crate) static CTD: BlockDef = BlockDef {
    kind: Kind::Ctd,
    name: "CTD",
    pins: &[
        pin("CD", Bool, false, "cd"),
        PV,
        pin("LD", Bool, false, "load"),
    ],
    outputs: COUNTER_OUT,
    forms: &[form(
        "ctd",
        &[0, 2, 1],
        0,
        "CTD c(10, ld=load)",
        "LD loads PV, edges of CD count down; Q = CV ≤ 0",
    )],
    expr: false,
};

/// Up-down counter.
pub(crate) static CTUD: BlockDef = BlockDef {
    kind: Kind::Ctud,
    name: "CTUD",
    pins: &[
        pin("CU", Bool, false, "cu"),
        PV,
        pin("CD", Bool, false, "cd"),
        R,
        pin("LD", Bool, false, "load"),
    ],
    outputs: &[Member::Qu, Member::Qd, Member::Cv],
    forms: &[form(
        "ctud",
        &[0, 2, 3, 4, 1],
        0,
        "CTUD c(10, cd=down, r=rst, ld=load)",
        "QU = CV ≥ PV, QD = CV ≤ 0",
    )],
    expr: false,
};

const CLK: Pin = pin("CLK", Bool, false, "x");

/// Rising-edge detector.
pub(crate) static R_TRIG: BlockDef = BlockDef {
    kind: Kind::RTrig,
    name: "R_TRIG",
    pins: &[CLK],
    outputs: Q,
    forms: &[form(
        "r_trig",
        &[0],
        0,
        "R_TRIG e",
        "Q for one scan on a rising edge",
    )],
    expr: false,
};

/// Falling-edge detector.
pub(crate) static F_TRIG: BlockDef = BlockDef {
    kind: Kind::FTrig,
    name: "F_TRIG",
    pins: &[CLK],
    outputs: Q,
    forms: &[form(
        "f_trig",
        &[0],
        0,
        "F_TRIG e",
        "Q for one scan on a falling edge",
    )],
    expr: false,
};

/// Set-dominant bistable.
pub(crate) static SR: BlockDef = BlockDef {
    kind: Kind::Sr,
    name: "SR",
    pins: &[pin("S1", Bool, false, "s1"), pin("R", Bool, false, "r")],
    outputs: Q,
    forms: &[form("sr", &[0, 1], 0, "SR l(r=reset)", "latch, set wins")],
    expr: false,
};

/// Reset-dominant bistable.
pub(crate) static RS: BlockDef = BlockDef {
    kind: Kind::Rs,
    name: "RS",
    pins: &[pin("S", Bool, false, "s"), pin("R", Bool, false, "r1")],
    outputs: Q,
    forms: &[form("rs", &[0, 1], 0, "RS l(r=reset)", "latch, reset wins")],
    expr: false,
};

/// Impulse relay.
pub(crate) static TOGGLE: BlockDef = BlockDef {
    kind: Kind::Toggle,
    name: "TOGGLE",
    pins: &[pin("IN", Bool, false, "x"), R],
    outputs: Q,
    forms: &[form(
        "toggle",
        &[0, 1],
        1,
        "TOGGLE t(r=off)",
        "impulse relay: each rising edge flips Q",
    )],
    expr: false,
};

/// Blinker.
pub(crate) static BLINK: BlockDef = BlockDef {
    kind: Kind::Blink,
    name: "BLINK",
    pins: &[
        pin("EN", Bool, false, "en"),
        pin("ON", Time, true, "on"),
        pin("OFF", Time, true, "off"),
        pin("PATTERN", Pattern, false, "pattern"),
        pin("STEP", Time, false, "step"),
    ],
    outputs: Q,
    forms: &[
        form(
            "blink",
            &[0, 1, 2],
            0,
            "BLINK b(500ms, 250ms)",
            "blinks while enabled, starting on",
        ),
        form(
            "blink_pattern",
            &[0, 3, 4],
            0,
            "BLINK b(pattern=1101, step=200ms)",
            "plays the bits, one per step",
        ),
    ],
    expr: false,
};

/// The MiniMod's blinker.
pub(crate) static LAMP: BlockDef = BlockDef {
    kind: Kind::Lamp,
    name: "LAMP",
    pins: &[
        pin("EN", Bool, false, "en"),
        pin("MASK", Mask, true, "mask"),
    ],
    outputs: Q,
    forms: &[form(
        "lamp",
        &[0, 1],
        0,
        "LAMP l(3855)",
        "the MiniMod's blinker: while enabled, bit k of the 16-bit MASK in step k of 100 ms, steps free-running from the PLC's start (3855 = 0x0F0F: 400 ms on, 400 ms off)",
    )],
    expr: false,
};
