//! The MiniMod Modbus register map, shared by the driver and the simulator.
//!
//! Source: MiniMod user manual, chapter "Modbus interface" (sections "Digital inputs,
//! latencies and counters", "Power outputs, blinkers, pulsers, and feedbacks", "Automatic
//! output management") and the two tables "Modbus register map (read-only registers)" and
//! "Modbus register map (read and write registers)".
//!
//! Every entry of [`MAP`] is written with the manual's **1-based reference** (`10001`,
//! `40020`); the constructors derive the table and the **0-based protocol address** from it
//! (reference 40020 → holding register 19), so the map reads like the manual's tables.
//!
//! Addresses the manual gives only in prose are included too: the 16 inputs as input
//! register 0 (30001), and the feedback bits at discrete inputs 48/49 (10049/10050), of which
//! discrete inputs 8/9 (X9/X10, 10009/10010) are mirrors.
//!
//! ## WDTTIME and WDTYMASK: two readings of the manual
//!
//! The bit tables are bit views of the word tables (coil *n* = bit *n* % 16 of holding
//! register *n* / 16): coils 0..3 (Y1..Y4) are the bits of YWORD (HR 0), coils 80..82 (EVX1..3)
//! those of XEVMASK (HR 5), coils 96..99 (EVY1..4) those of YEVMASK (HR 6). By that rule the
//! table's WDTTIME = 40129 and WDTYMASK = 40145 would really be holding registers 8 and 9
//! (the references look like the coil numbers 128/144 + 1), and WDTY1..4 (coils 144..147)
//! would be the bits of holding register 9. [`MAP`] follows the register table (holding
//! registers 128 and 144, [`WatchdogRegisters::Table`]); the simulator can serve the other
//! reading ([`WatchdogRegisters::Aliased`], [`lookup_in`]). The driver depends on neither: it
//! sets and reads back both by name through the text protocol (see `driver/watchdog.rs`).
//! Every other register the manual gives twice (prose and table) agrees between the two, and
//! the coil table (WDTY1..4 = 00145..00148, WDTFB1..2 = 00113..00114, WDTFIRED = 00161) is
//! the same under both readings.

use crate::point::{Access, PointSpec, ValueType};

/// One of the four Modbus tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Space {
    /// Coils (0xxxx), FC 1 / 5 / 15.
    Coil,
    /// Discrete inputs (1xxxx), FC 2.
    DiscreteInput,
    /// Input registers (3xxxx), FC 4.
    InputRegister,
    /// Holding registers (4xxxx), FC 3 / 6 / 16 / 22.
    HoldingRegister,
}

impl Space {
    /// The manual's reference of protocol address 0 minus one (`40001` − 1 for holding
    /// registers): reference = base + address + 1.
    pub(crate) const fn base(self) -> u32 {
        match self {
            Space::Coil => 0,
            Space::DiscreteInput => 10000,
            Space::InputRegister => 30000,
            Space::HoldingRegister => 40000,
        }
    }

    /// The highest protocol address the module implements in this table. Addresses up to it
    /// that are not in [`MAP`] are holes: they read 0 and ignore writes, as the manual says of
    /// discrete inputs 3..7 and 10..15. Addresses above it are refused with
    /// `IllegalDataAddress` (simulator's choice; the manual does not say).
    pub(crate) const fn extent(self) -> u16 {
        match self {
            Space::Coil => 160,            // WDTFIRED, 00161
            Space::DiscreteInput => 129,   // SW4, 10130
            Space::InputRegister => 9,     // ROTSW, 30010
            Space::HoldingRegister => 144, // WDTYMASK, 40145
        }
    }
}

/// Where the module keeps WDTTIME and WDTYMASK among its holding registers: the manual gives
/// them two ways (see the module docs above). The simulator serves either; the driver arms
/// the watchdog by name, so it works with both.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WatchdogRegisters {
    /// The register table ("Modbus register map (read and write registers)"): WDTTIME 40129,
    /// WDTYMASK 40145, holding registers 128 and 144.
    #[default]
    Table,
    /// The coil/register aliasing rule the other bit/word pairs follow: holding registers 8
    /// and 9 (the words of coils 128.. and 144..); nothing above YPULSE4 (40087).
    Aliased,
}

impl WatchdogRegisters {
    /// Both readings, the table's first.
    pub const ALL: [WatchdogRegisters; 2] = [WatchdogRegisters::Table, WatchdogRegisters::Aliased];

    /// The holding register (0-based) of WDTTIME.
    pub const fn wdttime(self) -> u16 {
        match self {
            WatchdogRegisters::Table => 128,
            WatchdogRegisters::Aliased => 8,
        }
    }

    /// The holding register (0-based) of WDTYMASK.
    pub const fn wdtymask(self) -> u16 {
        match self {
            WatchdogRegisters::Table => 144,
            WatchdogRegisters::Aliased => 9,
        }
    }

    /// The highest holding register the module implements under this reading.
    pub const fn holding_extent(self) -> u16 {
        match self {
            WatchdogRegisters::Table => Space::HoldingRegister.extent(),
            WatchdogRegisters::Aliased => 86, // YPULSE4, 40087
        }
    }

    /// The name the simulator's option takes (`table`, `aliased`).
    pub const fn name(self) -> &'static str {
        match self {
            WatchdogRegisters::Table => "table",
            WatchdogRegisters::Aliased => "aliased",
        }
    }

    /// The reading of option value `name`.
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|r| r.name() == name)
    }

    /// Where this reading puts the two registers, in words (for logs and errors).
    pub const fn describe(self) -> &'static str {
        match self {
            WatchdogRegisters::Table => {
                "the register table: WDTTIME holding register 128 (40129), WDTYMASK 144 (40145)"
            }
            WatchdogRegisters::Aliased => {
                "the coil/register aliasing rule: WDTTIME holding register 8 (40009), WDTYMASK 9 \
                 (40010)"
            }
        }
    }
}

/// What a register reaches inside the module. Indexes are 0-based (`Input(0)` is X1,
/// `Output(3)` is Y4, `AutoOn(0, 2)` is Y1AON3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Item {
    /// Cooked input X1..X3 (after latency).
    Input(u8),
    /// Output feedback FB1 (Y1 + Y2) or FB2 (Y3 + Y4); also X9/X10.
    Feedback(u8),
    /// Output Y1..Y4: the commanded (normal) state, a bit of YWORD.
    Output(u8),
    /// YWORD: the commanded outputs as a bitmap.
    Yword,
    /// The 16 discrete inputs 0..15 as one word (input register 0).
    InputWord,
    /// XCOUNT1..3: rising-edge counters.
    Xcount(u8),
    /// XLATUP1..3: rising-edge latency, ms.
    XlatUp(u8),
    /// XLATDN1..3: falling-edge latency, ms.
    XlatDn(u8),
    /// YnAONm: (output, condition) turn-on condition mask.
    AutoOn(u8, u8),
    /// YnAOFFm: (output, condition) turn-off condition mask.
    AutoOff(u8, u8),
    /// YLAMP1..4: blinker mask.
    Lamp(u8),
    /// YPULSE1..4: pulser, ms remaining.
    Pulse(u8),
    /// XEVMASK: event recording mask for X1..X3.
    XevMask,
    /// YEVMASK: event recording mask for Y1..Y4.
    YevMask,
    /// EVX1..3: bit of XEVMASK.
    EvX(u8),
    /// EVFB1..2: event recording enable for FB1/FB2.
    EvFb(u8),
    /// EVY1..4: bit of YEVMASK.
    EvY(u8),
    /// WDTFB1..2: feedback FB1/FB2 fires the watchdog (text protocol: FBENABLE bits).
    WdtFbEnable(u8),
    /// WDTY1..4: bit of WDTYMASK.
    WdtY(u8),
    /// WDTFIRED: the watchdog is firing.
    WdtFired,
    /// WDTTIME: communication watchdog timeout, 1/100 s.
    WdtTime,
    /// WDTYMASK: outputs while the watchdog fires.
    WdtYMask,
    /// EVENTSPRS: Collect events are queued.
    EventsPresent,
    /// GENERICFAIL.
    GenericFail,
    /// FLASHFAIL.
    FlashFail,
    /// WDTFB: the watchdog fired because of a feedback.
    WdtFb,
    /// WDTCOMM: the watchdog fired because of a communication loss.
    WdtComm,
    /// SW3: dip switch 3.
    Sw3,
    /// SW4: dip switch 4.
    Sw4,
    /// ROTSW: the rotary address selector.
    RotSw,
}

/// One address of the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Entry {
    /// The manual's name (mirrors carry their original's name).
    pub name: &'static str,
    /// The table.
    pub space: Space,
    /// Protocol address, 0-based.
    pub addr: u16,
    /// What it reaches.
    pub item: Item,
}

impl Entry {
    /// The manual's 1-based reference (`40020` for XLATUP1).
    #[cfg(test)]
    pub(crate) const fn reference(&self) -> u32 {
        self.space.base() + self.addr as u32 + 1
    }
}

const fn at(name: &'static str, space: Space, reference: u32, item: Item) -> Entry {
    // Only evaluated in the static below: a wrong reference is a compile error.
    let addr = reference - space.base() - 1;
    assert!(addr <= 0xFFFF);
    Entry {
        name,
        space,
        addr: addr as u16,
        item,
    }
}

const fn coil(name: &'static str, reference: u32, item: Item) -> Entry {
    at(name, Space::Coil, reference, item)
}

const fn di(name: &'static str, reference: u32, item: Item) -> Entry {
    at(name, Space::DiscreteInput, reference, item)
}

const fn ir(name: &'static str, reference: u32, item: Item) -> Entry {
    at(name, Space::InputRegister, reference, item)
}

const fn hr(name: &'static str, reference: u32, item: Item) -> Entry {
    at(name, Space::HoldingRegister, reference, item)
}

// Entries the driver addresses by themselves (its fixed reads and start-up steps), named once
// here so that the driver and the table cannot disagree.

/// EVENTSPRS (10018): the first discrete input of the driver's status read.
pub(crate) const EVENTSPRS: Entry = di("EVENTSPRS", 10018, Item::EventsPresent);
/// WDTFB (10025): the watchdog fired because of a feedback; WDTCOMM (10026) follows it.
pub(crate) const WDTFB: Entry = di("WDTFB", 10025, Item::WdtFb);
/// SW4 (10130): the last discrete input of the driver's status read.
pub(crate) const SW4: Entry = di("SW4", 10130, Item::Sw4);
/// EVFB1 (00089): event recording of FB1; EVFB2 (00090) follows it.
pub(crate) const EVFB1: Entry = coil("EVFB1", 89, Item::EvFb(0));
/// WDTFB1 (00113): FB1 fires the watchdog.
pub(crate) const WDTFB1: Entry = coil("WDTFB1", 113, Item::WdtFbEnable(0));
/// WDTFB2 (00114): FB2 fires the watchdog.
pub(crate) const WDTFB2: Entry = coil("WDTFB2", 114, Item::WdtFbEnable(1));
/// WDTFIRED (00161): the watchdog is firing (written 0 to reset it).
pub(crate) const WDTFIRED: Entry = coil("WDTFIRED", 161, Item::WdtFired);
/// XEVMASK (40006): event recording mask for X1..X3.
pub(crate) const XEVMASK: Entry = hr("XEVMASK", 40006, Item::XevMask);
/// XCOUNT1 (40012): the first of the three counters.
pub(crate) const XCOUNT1: Entry = hr("XCOUNT1", 40012, Item::Xcount(0));

/// Every address of both manual tables, plus the prose-only ones (input register 0,
/// discrete inputs 48/49). Written with the manual's 1-based references.
pub(crate) static MAP: &[Entry] = &[
    // --- Read-only registers (table "Modbus register map (read-only registers)") ---
    di("X1", 10001, Item::Input(0)),
    di("X2", 10002, Item::Input(1)),
    di("X3", 10003, Item::Input(2)),
    di("FB1", 10009, Item::Feedback(0)), // = X9
    di("FB2", 10010, Item::Feedback(1)), // = X10
    EVENTSPRS,
    di("GENERICFAIL", 10020, Item::GenericFail),
    di("FLASHFAIL", 10023, Item::FlashFail),
    WDTFB,
    di("WDTCOMM", 10026, Item::WdtComm),
    // Prose: "the outputs Y1 and Y2 set the Discrete Input at address 48; Y3 and Y4 set the
    // Discrete Input at address 49" (0-based).
    di("FB1", 10049, Item::Feedback(0)),
    di("FB2", 10050, Item::Feedback(1)),
    di("SW3", 10129, Item::Sw3),
    SW4,
    // Prose: "The 16 inputs can be read as a single Input Register at physical address 0."
    ir("XWORD", 30001, Item::InputWord),
    ir("ROTSW", 30010, Item::RotSw),
    // --- Read and write registers (table "Modbus register map (read and write registers)") ---
    coil("Y1", 1, Item::Output(0)),
    coil("Y2", 2, Item::Output(1)),
    coil("Y3", 3, Item::Output(2)),
    coil("Y4", 4, Item::Output(3)),
    coil("EVX1", 81, Item::EvX(0)),
    coil("EVX2", 82, Item::EvX(1)),
    coil("EVX3", 83, Item::EvX(2)),
    EVFB1,
    coil("EVFB2", 90, Item::EvFb(1)),
    coil("EVY1", 97, Item::EvY(0)),
    coil("EVY2", 98, Item::EvY(1)),
    coil("EVY3", 99, Item::EvY(2)),
    coil("EVY4", 100, Item::EvY(3)),
    WDTFB1,
    WDTFB2,
    coil("WDTY1", 145, Item::WdtY(0)),
    coil("WDTY2", 146, Item::WdtY(1)),
    coil("WDTY3", 147, Item::WdtY(2)),
    coil("WDTY4", 148, Item::WdtY(3)),
    WDTFIRED,
    hr("YWORD", 40001, Item::Yword),
    XEVMASK,
    hr("YEVMASK", 40007, Item::YevMask),
    XCOUNT1,
    hr("XCOUNT2", 40013, Item::Xcount(1)),
    hr("XCOUNT3", 40014, Item::Xcount(2)),
    hr("XLATUP1", 40020, Item::XlatUp(0)),
    hr("XLATUP2", 40021, Item::XlatUp(1)),
    hr("XLATUP3", 40022, Item::XlatUp(2)),
    hr("XLATDN1", 40036, Item::XlatDn(0)),
    hr("XLATDN2", 40037, Item::XlatDn(1)),
    hr("XLATDN3", 40038, Item::XlatDn(2)),
    hr("Y1AON1", 40052, Item::AutoOn(0, 0)),
    hr("Y1AON2", 40053, Item::AutoOn(0, 1)),
    hr("Y1AON3", 40054, Item::AutoOn(0, 2)),
    hr("Y2AON1", 40055, Item::AutoOn(1, 0)),
    hr("Y2AON2", 40056, Item::AutoOn(1, 1)),
    hr("Y2AON3", 40057, Item::AutoOn(1, 2)),
    hr("Y3AON1", 40058, Item::AutoOn(2, 0)),
    hr("Y3AON2", 40059, Item::AutoOn(2, 1)),
    hr("Y3AON3", 40060, Item::AutoOn(2, 2)),
    hr("Y4AON1", 40061, Item::AutoOn(3, 0)),
    hr("Y4AON2", 40062, Item::AutoOn(3, 1)),
    hr("Y4AON3", 40063, Item::AutoOn(3, 2)),
    hr("Y1AOFF1", 40064, Item::AutoOff(0, 0)),
    hr("Y1AOFF2", 40065, Item::AutoOff(0, 1)),
    hr("Y1AOFF3", 40066, Item::AutoOff(0, 2)),
    hr("Y2AOFF1", 40067, Item::AutoOff(1, 0)),
    hr("Y2AOFF2", 40068, Item::AutoOff(1, 1)),
    hr("Y2AOFF3", 40069, Item::AutoOff(1, 2)),
    hr("Y3AOFF1", 40070, Item::AutoOff(2, 0)),
    hr("Y3AOFF2", 40071, Item::AutoOff(2, 1)),
    hr("Y3AOFF3", 40072, Item::AutoOff(2, 2)),
    hr("Y4AOFF1", 40073, Item::AutoOff(3, 0)),
    hr("Y4AOFF2", 40074, Item::AutoOff(3, 1)),
    hr("Y4AOFF3", 40075, Item::AutoOff(3, 2)),
    hr("YLAMP1", 40076, Item::Lamp(0)),
    hr("YLAMP2", 40077, Item::Lamp(1)),
    hr("YLAMP3", 40078, Item::Lamp(2)),
    hr("YLAMP4", 40079, Item::Lamp(3)),
    hr("YPULSE1", 40084, Item::Pulse(0)),
    hr("YPULSE2", 40085, Item::Pulse(1)),
    hr("YPULSE3", 40086, Item::Pulse(2)),
    hr("YPULSE4", 40087, Item::Pulse(3)),
    hr("WDTTIME", 40129, Item::WdtTime),
    hr("WDTYMASK", 40145, Item::WdtYMask),
];

/// What a protocol address holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Slot {
    /// A mapped address.
    Mapped(Item),
    /// Inside the implemented range but not implemented: reads 0, writes are ignored.
    Hole,
    /// Beyond the implemented range: `IllegalDataAddress`.
    Outside,
}

/// The item at a protocol address (0-based) of a table.
pub(crate) fn lookup(space: Space, addr: u16) -> Slot {
    if addr > space.extent() {
        return Slot::Outside;
    }
    MAP.iter()
        .find(|e| e.space == space && e.addr == addr)
        .map_or(Slot::Hole, |e| Slot::Mapped(e.item))
}

/// The item at a protocol address (0-based) of a table, for a module that keeps WDTTIME and
/// WDTYMASK where `registers` says; [`lookup`] is the register table's reading.
pub(crate) fn lookup_in(space: Space, addr: u16, registers: WatchdogRegisters) -> Slot {
    if space != Space::HoldingRegister || registers == WatchdogRegisters::Table {
        return lookup(space, addr);
    }
    if addr == registers.wdttime() {
        Slot::Mapped(Item::WdtTime)
    } else if addr == registers.wdtymask() {
        Slot::Mapped(Item::WdtYMask)
    } else if addr > registers.holding_extent() {
        Slot::Outside
    } else {
        lookup(space, addr)
    }
}

/// The first map entry with this name (`FB1` gives discrete input 8, not its mirror at 48).
pub(crate) fn entry(name: &str) -> Option<&'static Entry> {
    MAP.iter().find(|e| e.name == name)
}

/// The item a point name reaches: the map's names plus X9/X10 (aliases of FB1/FB2, manual
/// "Outputs feedback") and Y1..Y4 (coils 0..3).
pub(crate) fn point_item(name: &str) -> Option<Item> {
    match name {
        "X9" => Some(Item::Feedback(0)),
        "X10" => Some(Item::Feedback(1)),
        _ => entry(name).map(|e| e.item),
    }
}

// --- Protocol addresses the driver uses (0-based) ---

/// Discrete input of X1 (10001): the driver's FC 2 read starts here.
pub(crate) const DI_X1: u16 = 0;
/// Discrete inputs read per cycle: 0..=9 covers X1..X3 and X9/X10 (10001..10010).
pub(crate) const DI_READ_COUNT: u16 = 10;
/// Coil of Y1 (00001).
pub(crate) const COIL_Y1: u16 = 0;
/// Holding register YWORD (40001).
pub(crate) const HR_YWORD: u16 = 0;

// --- Automatic output conditions ---

/// Whether condition mask `mask` holds for the inputs `inputs` (bit 0 = X1). Manual,
/// "Automatic output management": the low byte selects the inputs to check, the high byte the
/// inputs to invert before checking; all checked inputs must be 1 after inversion. A mask
/// with an empty low byte is no condition (never true).
pub(crate) fn condition_holds(mask: u16, inputs: u8) -> bool {
    let [check, invert] = mask.to_le_bytes();
    check != 0 && (inputs ^ invert) & check == check
}

/// Why a condition text was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ConditionError {
    /// Something other than `X1`..`X3`, optionally preceded by `-`, at byte `at`.
    #[error("expected X1, X2 or X3 (optionally preceded by -) at byte {at}")]
    Syntax {
        /// Byte offset in the text.
        at: usize,
    },
}

/// Parses a condition in the text protocol's form (`X1X2`, `X1-X3`, `-X1`; empty clears it)
/// into its mask. Manual, "Y1AON1..": "the names of the inputs to check, each perhaps
/// preceded by a minus sign to indicate a negation". Case and spaces are ignored.
pub fn parse_condition(text: &str) -> Result<u16, ConditionError> {
    let mut chars = text
        .bytes()
        .enumerate()
        .filter(|(_, b)| *b != b' ')
        .map(|(i, b)| (i, b.to_ascii_uppercase()));
    let mut mask = 0u16;
    while let Some((start, first)) = chars.next() {
        let negated = first == b'-';
        let x = if negated {
            chars.next().map(|(_, b)| b)
        } else {
            Some(first)
        };
        let bit = match (x, chars.next().map(|(_, b)| b)) {
            (Some(b'X'), Some(d @ b'1'..=b'3')) => d - b'1',
            _ => return Err(ConditionError::Syntax { at: start }),
        };
        mask |= 1 << bit;
        if negated {
            mask |= 1 << (bit + 8);
        }
    }
    Ok(mask)
}

// --- Points ---

const fn p(name: &'static str, ty: ValueType, access: Access, doc: &'static str) -> PointSpec {
    PointSpec {
        name,
        ty,
        access,
        doc,
    }
}

const B: ValueType = ValueType::Bool;
const W: ValueType = ValueType::U16;
const IN: Access = Access::Input;
const OUT: Access = Access::Output;
const RW: Access = Access::ReadWrite;

/// Every MiniMod point, by the manual's names. The first eleven (X1..X3, X9, X10, FB1, FB2,
/// Y1..Y4) are the ones the driver reads every cycle.
///
/// The register table calls the pulsers `YPULSE1..4`; the prose ("Pulse generation") and the
/// text protocol call them `Y1PULSE..Y4PULSE`. Points use the register table's names, as for
/// the blinkers (`YLAMP1..4`, text `Y1LAMP..`).
pub static POINTS: &[PointSpec] = &[
    p(
        "X1",
        B,
        IN,
        "input X1, cooked by XLATUP1/XLATDN1 (discrete input 0, 10001)",
    ),
    p("X2", B, IN, "input X2, cooked (discrete input 1, 10002)"),
    p("X3", B, IN, "input X3, cooked (discrete input 2, 10003)"),
    p(
        "X9",
        B,
        IN,
        "virtual input X9 = FB1 (discrete input 8, 10009)",
    ),
    p(
        "X10",
        B,
        IN,
        "virtual input X10 = FB2 (discrete input 9, 10010)",
    ),
    p(
        "FB1",
        B,
        IN,
        "feedback of Y1 + Y2: open load or overload (discrete input 8 and 48)",
    ),
    p(
        "FB2",
        B,
        IN,
        "feedback of Y3 + Y4 (discrete input 9 and 49)",
    ),
    p("Y1", B, OUT, "output Y1 (coil 0, 00001; bit 0 of YWORD)"),
    p("Y2", B, OUT, "output Y2 (coil 1, 00002; bit 1 of YWORD)"),
    p("Y3", B, OUT, "output Y3 (coil 2, 00003; bit 2 of YWORD)"),
    p("Y4", B, OUT, "output Y4 (coil 3, 00004; bit 3 of YWORD)"),
    p(
        "YWORD",
        W,
        RW,
        "outputs Y1..Y4 as a bitmap (holding register 0, 40001)",
    ),
    p(
        "XCOUNT1",
        W,
        RW,
        "rising edges of X1 (holding register 11, 40012)",
    ),
    p(
        "XCOUNT2",
        W,
        RW,
        "rising edges of X2 (holding register 12, 40013)",
    ),
    p(
        "XCOUNT3",
        W,
        RW,
        "rising edges of X3 (holding register 13, 40014)",
    ),
    p(
        "XLATUP1",
        W,
        RW,
        "rising-edge latency of X1, ms, power-on 20 (holding register 19, 40020)",
    ),
    p(
        "XLATUP2",
        W,
        RW,
        "rising-edge latency of X2, ms, power-on 20 (holding register 20, 40021)",
    ),
    p(
        "XLATUP3",
        W,
        RW,
        "rising-edge latency of X3, ms, power-on 20 (holding register 21, 40022)",
    ),
    p(
        "XLATDN1",
        W,
        RW,
        "falling-edge latency of X1, ms, power-on 20 (holding register 35, 40036)",
    ),
    p(
        "XLATDN2",
        W,
        RW,
        "falling-edge latency of X2, ms, power-on 20 (holding register 36, 40037)",
    ),
    p(
        "XLATDN3",
        W,
        RW,
        "falling-edge latency of X3, ms, power-on 20 (holding register 37, 40038)",
    ),
    p(
        "YPULSE1",
        W,
        RW,
        "pulser of Y1, ms left (holding register 83, 40084; text Y1PULSE)",
    ),
    p(
        "YPULSE2",
        W,
        RW,
        "pulser of Y2, ms left (holding register 84, 40085; text Y2PULSE)",
    ),
    p(
        "YPULSE3",
        W,
        RW,
        "pulser of Y3, ms left (holding register 85, 40086; text Y3PULSE)",
    ),
    p(
        "YPULSE4",
        W,
        RW,
        "pulser of Y4, ms left (holding register 86, 40087; text Y4PULSE)",
    ),
    p(
        "YLAMP1",
        W,
        RW,
        "blinker mask of Y1 (holding register 75, 40076; text Y1LAMP)",
    ),
    p(
        "YLAMP2",
        W,
        RW,
        "blinker mask of Y2 (holding register 76, 40077; text Y2LAMP)",
    ),
    p(
        "YLAMP3",
        W,
        RW,
        "blinker mask of Y3 (holding register 77, 40078; text Y3LAMP)",
    ),
    p(
        "YLAMP4",
        W,
        RW,
        "blinker mask of Y4 (holding register 78, 40079; text Y4LAMP)",
    ),
    p(
        "Y1AON1",
        W,
        RW,
        "turn-on condition 1 of Y1 (holding register 51, 40052)",
    ),
    p(
        "Y1AON2",
        W,
        RW,
        "turn-on condition 2 of Y1 (holding register 52, 40053)",
    ),
    p(
        "Y1AON3",
        W,
        RW,
        "turn-on condition 3 of Y1 (holding register 53, 40054)",
    ),
    p(
        "Y2AON1",
        W,
        RW,
        "turn-on condition 1 of Y2 (holding register 54, 40055)",
    ),
    p(
        "Y2AON2",
        W,
        RW,
        "turn-on condition 2 of Y2 (holding register 55, 40056)",
    ),
    p(
        "Y2AON3",
        W,
        RW,
        "turn-on condition 3 of Y2 (holding register 56, 40057)",
    ),
    p(
        "Y3AON1",
        W,
        RW,
        "turn-on condition 1 of Y3 (holding register 57, 40058)",
    ),
    p(
        "Y3AON2",
        W,
        RW,
        "turn-on condition 2 of Y3 (holding register 58, 40059)",
    ),
    p(
        "Y3AON3",
        W,
        RW,
        "turn-on condition 3 of Y3 (holding register 59, 40060)",
    ),
    p(
        "Y4AON1",
        W,
        RW,
        "turn-on condition 1 of Y4 (holding register 60, 40061)",
    ),
    p(
        "Y4AON2",
        W,
        RW,
        "turn-on condition 2 of Y4 (holding register 61, 40062)",
    ),
    p(
        "Y4AON3",
        W,
        RW,
        "turn-on condition 3 of Y4 (holding register 62, 40063)",
    ),
    p(
        "Y1AOFF1",
        W,
        RW,
        "turn-off condition 1 of Y1 (holding register 63, 40064)",
    ),
    p(
        "Y1AOFF2",
        W,
        RW,
        "turn-off condition 2 of Y1 (holding register 64, 40065)",
    ),
    p(
        "Y1AOFF3",
        W,
        RW,
        "turn-off condition 3 of Y1 (holding register 65, 40066)",
    ),
    p(
        "Y2AOFF1",
        W,
        RW,
        "turn-off condition 1 of Y2 (holding register 66, 40067)",
    ),
    p(
        "Y2AOFF2",
        W,
        RW,
        "turn-off condition 2 of Y2 (holding register 67, 40068)",
    ),
    p(
        "Y2AOFF3",
        W,
        RW,
        "turn-off condition 3 of Y2 (holding register 68, 40069)",
    ),
    p(
        "Y3AOFF1",
        W,
        RW,
        "turn-off condition 1 of Y3 (holding register 69, 40070)",
    ),
    p(
        "Y3AOFF2",
        W,
        RW,
        "turn-off condition 2 of Y3 (holding register 70, 40071)",
    ),
    p(
        "Y3AOFF3",
        W,
        RW,
        "turn-off condition 3 of Y3 (holding register 71, 40072)",
    ),
    p(
        "Y4AOFF1",
        W,
        RW,
        "turn-off condition 1 of Y4 (holding register 72, 40073)",
    ),
    p(
        "Y4AOFF2",
        W,
        RW,
        "turn-off condition 2 of Y4 (holding register 73, 40074)",
    ),
    p(
        "Y4AOFF3",
        W,
        RW,
        "turn-off condition 3 of Y4 (holding register 74, 40075)",
    ),
    p(
        "WDTTIME",
        W,
        RW,
        "watchdog timeout, 1/100 s, 0 = off (text WDTTIME; holding register 128, 40129, by \
         the register table, 8 by the coil/register aliasing)",
    ),
    p(
        "WDTYMASK",
        W,
        RW,
        "outputs while the watchdog fires (text WDTMASK; holding register 144, 40145, by the \
         register table, 9 by the coil/register aliasing)",
    ),
    p(
        "XEVMASK",
        W,
        RW,
        "event recording mask of X1..X3 (holding register 5, 40006)",
    ),
    p(
        "YEVMASK",
        W,
        RW,
        "event recording mask of Y1..Y4 (holding register 6, 40007)",
    ),
    p(
        "EVX1",
        B,
        RW,
        "event recording of X1 = XEVMASK bit 0 (coil 80, 00081)",
    ),
    p(
        "EVX2",
        B,
        RW,
        "event recording of X2 = XEVMASK bit 1 (coil 81, 00082)",
    ),
    p(
        "EVX3",
        B,
        RW,
        "event recording of X3 = XEVMASK bit 2 (coil 82, 00083)",
    ),
    p("EVFB1", B, RW, "event recording of FB1 (coil 88, 00089)"),
    p("EVFB2", B, RW, "event recording of FB2 (coil 89, 00090)"),
    p(
        "EVY1",
        B,
        RW,
        "event recording of Y1 = YEVMASK bit 0 (coil 96, 00097)",
    ),
    p(
        "EVY2",
        B,
        RW,
        "event recording of Y2 = YEVMASK bit 1 (coil 97, 00098)",
    ),
    p(
        "EVY3",
        B,
        RW,
        "event recording of Y3 = YEVMASK bit 2 (coil 98, 00099)",
    ),
    p(
        "EVY4",
        B,
        RW,
        "event recording of Y4 = YEVMASK bit 3 (coil 99, 00100)",
    ),
    p("WDTFB1", B, RW, "FB1 fires the watchdog (coil 112, 00113)"),
    p("WDTFB2", B, RW, "FB2 fires the watchdog (coil 113, 00114)"),
    p(
        "WDTY1",
        B,
        RW,
        "Y1 while the watchdog fires = WDTYMASK bit 0 (coil 144, 00145)",
    ),
    p(
        "WDTY2",
        B,
        RW,
        "Y2 while the watchdog fires = WDTYMASK bit 1 (coil 145, 00146)",
    ),
    p(
        "WDTY3",
        B,
        RW,
        "Y3 while the watchdog fires = WDTYMASK bit 2 (coil 146, 00147)",
    ),
    p(
        "WDTY4",
        B,
        RW,
        "Y4 while the watchdog fires = WDTYMASK bit 3 (coil 147, 00148)",
    ),
    p(
        "WDTFIRED",
        B,
        RW,
        "the watchdog is firing; reset by the master (coil 160, 00161)",
    ),
    p(
        "EVENTSPRS",
        B,
        IN,
        "events for Collect are present (discrete input 17, 10018)",
    ),
    p(
        "GENERICFAIL",
        B,
        IN,
        "generic hardware error (discrete input 19, 10020)",
    ),
    p(
        "FLASHFAIL",
        B,
        IN,
        "internal flash memory failure (discrete input 22, 10023)",
    ),
    p(
        "WDTFB",
        B,
        IN,
        "watchdog fired because of a feedback (discrete input 24, 10025)",
    ),
    p(
        "WDTCOMM",
        B,
        IN,
        "watchdog fired because of a comm loss (discrete input 25, 10026)",
    ),
    p("SW3", B, IN, "dip switch 3 (discrete input 128, 10129)"),
    p("SW4", B, IN, "dip switch 4 (discrete input 129, 10130)"),
    p(
        "XWORD",
        W,
        IN,
        "discrete inputs 0..15 as one word (input register 0, 30001)",
    ),
    p(
        "ROTSW",
        W,
        IN,
        "rotary address selector position 0..15 (input register 9, 30010)",
    ),
];

/// Index of a point in [`POINTS`].
pub fn point_index(name: &str) -> Option<usize> {
    POINTS.iter().position(|p| p.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn protocol_addresses_follow_the_manual_references() {
        let a = |name: &str| entry(name).map(|e| (e.space, e.addr));
        // Prose of "Digital inputs, latencies and counters" and "Power outputs, ...".
        assert_eq!(a("XLATUP1"), Some((Space::HoldingRegister, 19)));
        assert_eq!(a("XLATDN3"), Some((Space::HoldingRegister, 37)));
        assert_eq!(a("XCOUNT1"), Some((Space::HoldingRegister, 11)));
        assert_eq!(a("YLAMP1"), Some((Space::HoldingRegister, 75)));
        assert_eq!(a("YPULSE4"), Some((Space::HoldingRegister, 86)));
        assert_eq!(a("Y1AON1"), Some((Space::HoldingRegister, 51)));
        assert_eq!(a("Y4AOFF3"), Some((Space::HoldingRegister, 74)));
        assert_eq!(a("WDTFB1"), Some((Space::Coil, 112)));
        assert_eq!(a("FB1"), Some((Space::DiscreteInput, 8)));
        assert_eq!(a("ROTSW"), Some((Space::InputRegister, 9)));
        assert_eq!(entry("XLATUP1").map(Entry::reference), Some(40020));
        assert_eq!(
            lookup(Space::DiscreteInput, 48),
            Slot::Mapped(Item::Feedback(0))
        );
        assert_eq!(lookup(Space::DiscreteInput, 5), Slot::Hole);
        assert_eq!(lookup(Space::HoldingRegister, 145), Slot::Outside);
    }

    #[test]
    fn both_readings_of_wdttime_and_wdtymask() {
        let hr = Space::HoldingRegister;
        let table = WatchdogRegisters::Table;
        let aliased = WatchdogRegisters::Aliased;
        assert_eq!(lookup_in(hr, 128, table), Slot::Mapped(Item::WdtTime));
        assert_eq!(lookup_in(hr, 144, table), Slot::Mapped(Item::WdtYMask));
        assert_eq!(lookup_in(hr, 8, table), Slot::Hole);
        assert_eq!(lookup_in(hr, 8, aliased), Slot::Mapped(Item::WdtTime));
        assert_eq!(lookup_in(hr, 9, aliased), Slot::Mapped(Item::WdtYMask));
        assert_eq!(lookup_in(hr, 128, aliased), Slot::Outside);
        assert_eq!(lookup_in(hr, 144, aliased), Slot::Outside);
        // Everything else is where the table puts it, under both readings.
        for r in WatchdogRegisters::ALL {
            assert_eq!(lookup_in(hr, 86, r), Slot::Mapped(Item::Pulse(3)));
            assert_eq!(lookup_in(hr, 5, r), Slot::Mapped(Item::XevMask));
            assert_eq!(lookup_in(Space::Coil, 144, r), Slot::Mapped(Item::WdtY(0)));
            assert_eq!(lookup_in(Space::Coil, 160, r), Slot::Mapped(Item::WdtFired));
            assert_eq!(WatchdogRegisters::parse(r.name()), Some(r));
        }
        // The aliasing rule: coil n is bit n % 16 of holding register n / 16.
        assert_eq!(aliased.wdttime(), 128 / 16);
        assert_eq!(aliased.wdtymask(), map_coil("WDTY1") / 16);
        assert_eq!(WatchdogRegisters::parse("other"), None);
    }

    fn map_coil(name: &str) -> u16 {
        entry(name).map(|e| e.addr).unwrap()
    }

    #[test]
    fn map_has_no_duplicate_address_and_stays_in_extent() {
        for (i, e) in MAP.iter().enumerate() {
            assert!(e.addr <= e.space.extent(), "{} beyond extent", e.name);
            for f in &MAP[i + 1..] {
                assert!(
                    !(e.space == f.space && e.addr == f.addr),
                    "{} twice",
                    e.name
                );
            }
        }
    }

    #[test]
    fn every_point_reaches_an_item_and_every_name_is_a_point() {
        for p in POINTS {
            assert!(point_item(p.name).is_some(), "{}", p.name);
        }
        for e in MAP {
            assert!(point_index(e.name).is_some(), "{}", e.name);
        }
    }

    #[test]
    fn manual_condition_example() {
        // "X1=1, X2=0" is "0000.0010-0000.0011".
        assert_eq!(parse_condition("X1-X2"), Ok(0x0203));
        assert!(condition_holds(0x0203, 0b001));
        assert!(!condition_holds(0x0203, 0b011));
        assert!(!condition_holds(0x0203, 0b000));
        assert!(condition_holds(0x0203, 0b101), "X3 does not matter");
        // "0000.0000.0000.0111": X1 = X2 = X3 = 1.
        assert!(condition_holds(7, 0b111));
        assert!(!condition_holds(7, 0b011));
        // A zero mask is no condition, even with inversion bits.
        assert!(!condition_holds(0, 0));
        assert!(!condition_holds(0x0700, 0));
    }

    #[test]
    fn parses_text_conditions() {
        assert_eq!(parse_condition("x1x2"), Ok(0x0003));
        assert_eq!(parse_condition("-X1"), Ok(0x0101));
        assert_eq!(parse_condition("X2 -X3"), Ok(0x0406));
        assert_eq!(parse_condition(""), Ok(0));
        assert_eq!(parse_condition("X4"), Err(ConditionError::Syntax { at: 0 }));
        assert_eq!(
            parse_condition("X1-"),
            Err(ConditionError::Syntax { at: 2 })
        );
        assert_eq!(parse_condition("X"), Err(ConditionError::Syntax { at: 0 }));
    }
}
