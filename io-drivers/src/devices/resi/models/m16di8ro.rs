//! RESI-16DI8RO (manual chapter 10, L15751–L23169): 16 digital inputs 12–48 Vdc, 8 bistable
//! relays 16 A with switching counters in FRAM, and the internal logic functions (10.1.1).
//! Modbus map 10.14 (L19940–L22536), ASCII commands 10.13.5 (L18660–L19939).

use crate::devices::resi::ascii::command::{Command, Field, Fmt, Op};
use crate::devices::resi::item::{Func, Kind};
use crate::devices::resi::map::{names, points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, RelayKind, Series};
use crate::devices::resi::value::{Enc, WordOrder};

const HI: WordOrder = WordOrder::HighFirst;
const LO: WordOrder = WordOrder::LowFirst;
const RO: Acc = Acc::ReadOnly;
const RW: Acc = Acc::ReadWrite;
const WO: Acc = Acc::WriteOnly;

const RELAYS: &[&str] = names!("RO" [1 2 3 4 5 6 7 8]);
const COUNTERS: &[&str] = names!("COUNTER_RO" [1 2 3 4 5 6 7 8]);
const PULSE_TIMES: &[&str] = names!("PULSE_TIME_RO" [1 2 3 4 5 6 7 8]);
const PULSE_TIMERS: &[&str] = names!("PULSE_TIMER_RO" [1 2 3 4 5 6 7 8]);

/// The Modbus map (10.14.1 coils, 10.14.2 registers).
static MAP: &[Block] = &[
    Block::bits(
        names!("DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16]),
        1,
        Kind::Di,
        RO,
    )
    .cite("L19963"),
    Block::bits(RELAYS, 17, Kind::Ro, RW).cite("L20109"),
    Block::bits(names!("DIP" [1 2 3 4 5 6 7 8]), 25, Kind::Dip, RO).cite("L20206"),
    Block::bits(&["RESET_COUNTER"], 100, Kind::ResetCounter, WO).cite("L20278"),
    Block::regs(
        names!("RISE_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16]),
        1,
        Kind::Rise,
        Enc::U16,
        RO,
    )
    .stride(2)
    .cite("L20305"),
    Block::regs(
        names!("FALL_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16]),
        2,
        Kind::Fall,
        Enc::U16,
        RO,
    )
    .stride(2)
    .cite("L20318"),
    Block::regs(&["RESET_COUNTER"], 100, Kind::ResetCounter, Enc::U16, WO).cite("L20709"),
    Block::regs(&["DIS"], 101, Kind::DisWord, Enc::U16, RO).cite("L20720"),
    Block::regs(&["ROS"], 102, Kind::Ros, Enc::U16, RW).cite("L20744"),
    Block::regs(&["DIP"], 103, Kind::DipWord, Enc::U16, RO).cite("L20764"),
    Block::regs(COUNTERS, 201, Kind::RoCounter, Enc::U32(HI), RO).cite("L20782"),
    Block::regs(COUNTERS, 221, Kind::RoCounter, Enc::U32(LO), RO).cite("L20877"),
    Block::regs(
        names!("SWITCH_RO" [1 2 3 4 5 6 7 8]),
        20001,
        Kind::Mask(Func::Switch),
        Enc::U16,
        RW,
    )
    .cite("L20971"),
    Block::regs(
        names!("TOGGLE_RO" [1 2 3 4 5 6 7 8]),
        20009,
        Kind::Mask(Func::Toggle),
        Enc::U16,
        RW,
    )
    .cite("L21071"),
    Block::regs(
        names!("SWITCH_ON_RO" [1 2 3 4 5 6 7 8]),
        20017,
        Kind::Mask(Func::SwitchOn),
        Enc::U16,
        RW,
    )
    .cite("L21168"),
    Block::regs(
        names!("SWITCH_OFF_RO" [1 2 3 4 5 6 7 8]),
        20025,
        Kind::Mask(Func::SwitchOff),
        Enc::U16,
        RW,
    )
    .cite("L21265"),
    Block::regs(
        names!("PULSE_RO" [1 2 3 4 5 6 7 8]),
        20033,
        Kind::Mask(Func::Pulse),
        Enc::U16,
        RW,
    )
    .cite("L21370"),
    Block::regs(PULSE_TIMES, 20065, Kind::PulseTime, Enc::U32(HI), RW).cite("L21469"),
    Block::regs(PULSE_TIMES, 20081, Kind::PulseTime, Enc::U32(LO), RW).cite("L21566"),
    Block::regs(PULSE_TIMERS, 20097, Kind::PulseTimer, Enc::U32(HI), RO).cite("L21663"),
    Block::regs(PULSE_TIMERS, 20113, Kind::PulseTimer, Enc::U32(LO), RO).cite("L22405"),
    Block::regs(
        &["ENABLE_LOGIC_FUNCTIONS"],
        21001,
        Kind::EnableLogic,
        Enc::U16,
        RW,
    )
    .cite("L22509"),
    Block::regs(
        &["CLEAR_ALL_LOGIC_FUNCTIONS"],
        21002,
        Kind::ClearLogic,
        Enc::U16,
        WO,
    )
    .cite("L22522"),
];

const P: Fmt = Fmt::Pairs;

/// The chapter's own ASCII commands (10.13.5, resi-spec §2.6).
static COMMANDS: &[Command] = &[
    Command::get("GDIS", &["GET DIS"], &[Field::at(Kind::Dis, 0)], P),
    Command::get("GDI", &["GET DI"], &[Field::x(Kind::Di)], P).xs(1, 16),
    Command::get("GROS", &["GET ROS"], &[Field::at(Kind::Ros, 0)], P),
    Command::set("SROS", &["SET ROS"], &[Field::at(Kind::Ros, 0)]),
    Command::get("GRO", &["GET RO"], &[Field::x(Kind::Ro)], P).xs(1, 8),
    Command::set("SRO", &["SET RO"], &[Field::x(Kind::Ro)]).xs(1, 8),
    Command::get("GCRO", &["GET CYCLES RO"], &[Field::x(Kind::RoCounter)], P).xs(1, 8),
    Command::get("RDI", &["RISE DI"], &[Field::x(Kind::Rise)], P).xs(1, 16),
    Command::get("FDI", &["FALL DI"], &[Field::x(Kind::Fall)], P).xs(1, 16),
    Command::op("RC", &["RESET COUNTERS"], Op::ResetCounters),
    Command::set(
        "SSMODE",
        &["SET SPECIAL MODE"],
        &[Field::at(Kind::EnableLogic, 0)],
    ),
    Command::get(
        "GSMODE",
        &["GET SPECIAL MODE"],
        &[Field::at(Kind::EnableLogic, 0)],
        P,
    ),
    Command::op("RSTSPCMODE", &["RESET SPECIAL MODE"], Op::ClearLogic),
    Command::set(
        "SSWITCH",
        &["SET SWITCH"],
        &[Field::x(Kind::Mask(Func::Switch))],
    )
    .xs(1, 8),
    Command::get(
        "GSWITCH",
        &["GET SWITCH"],
        &[Field::x(Kind::Mask(Func::Switch))],
        P,
    )
    .xs(1, 8),
    Command::set(
        "SSON",
        &["SET SWITCH ON"],
        &[Field::x(Kind::Mask(Func::SwitchOn))],
    )
    .xs(1, 8),
    Command::get(
        "GSON",
        &["GET SWITCH ON"],
        &[Field::x(Kind::Mask(Func::SwitchOn))],
        P,
    )
    .xs(1, 8),
    Command::set(
        "SSOFF",
        &["SET SWITCH OFF"],
        &[Field::x(Kind::Mask(Func::SwitchOff))],
    )
    .xs(1, 8),
    Command::get(
        "GSOFF",
        &["GET SWITCH OFF"],
        &[Field::x(Kind::Mask(Func::SwitchOff))],
        P,
    )
    .xs(1, 8),
    Command::set(
        "STOGGLE",
        &["SET TOGGLE"],
        &[Field::x(Kind::Mask(Func::Toggle))],
    )
    .xs(1, 8),
    Command::get(
        "GTOGGLE",
        &["GET TOGGLE"],
        &[Field::x(Kind::Mask(Func::Toggle))],
        P,
    )
    .xs(1, 8),
    Command::set(
        "SPULSE",
        &["SET PULSE"],
        &[Field::x(Kind::Mask(Func::Pulse))],
    )
    .xs(1, 8),
    Command::get(
        "GPULSE",
        &["GET PULSE"],
        &[Field::x(Kind::Mask(Func::Pulse))],
        P,
    )
    .xs(1, 8),
    Command::set("SPTIME", &["SET PULSE TIME"], &[Field::x(Kind::PulseTime)]).xs(1, 8),
    Command::get(
        "GPTIME",
        &["GET PULSE TIME"],
        &[Field::x(Kind::PulseTime)],
        P,
    )
    .xs(1, 8),
    Command::get(
        "GPTIMER",
        &["GET PULSE TIMER"],
        &[Field::x(Kind::PulseTimer)],
        P,
    )
    .xs(1, 8),
];

/// The points: the map's names.
static POINTS: &[crate::point::PointSpec] = points![
    "DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16] "": Bool Input
        "input DIn, sampled every 10 ms (coil/DI 0x00001+n−1; ASCII GDIx, L19963)";
    "RO" [1 2 3 4 5 6 7 8] "": Bool Output
        "bistable relay ROn (coil 0x00017+n−1; ASCII SROx/GROx, L20109)";
    "DIS" [""] "": U16 Input "DI1..DI16 as bits (4x00101; ASCII GDIS, L20720)";
    "ROS" [""] "": U16 Input "RO1..RO8 as bits (4x00102; ASCII GROS, L20744)";
    "DIP" [""] "": U16 Input "DIP switches 1..8 as bits (4x00103; ASCII GDIP, L20764)";
    "DIP" [1 2 3 4 5 6 7 8] "": Bool Input "DIP switch n (0x00025+n−1, L20206)";
    "RISE_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16] "": U16 Input
        "rising edges of DIn since power-on (4x00001+2(n−1); ASCII RDIx, L20305)";
    "FALL_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16] "": U16 Input
        "falling edges of DIn since power-on (4x00002+2(n−1); ASCII FDIx, L20318)";
    "COUNTER_RO" [1 2 3 4 5 6 7 8] "": I32 Input
        "switching cycles of ROn, FRAM, UINT32 (4x00201+2(n−1) high word first, 4x00221 low \
         word first; ASCII GCROx, L20782)";
    "SWITCH_RO" [1 2 3 4 5 6 7 8] "": U16 ReadWrite
        "SWITCH mask of ROn, bit n = DI(n+1) (4x20001+n−1; ASCII SSWITCHx, L20971)";
    "TOGGLE_RO" [1 2 3 4 5 6 7 8] "": U16 ReadWrite
        "TOGGLE mask of ROn (4x20009+n−1; ASCII STOGGLEx, L21071)";
    "SWITCH_ON_RO" [1 2 3 4 5 6 7 8] "": U16 ReadWrite
        "SWITCH ON mask of ROn (4x20017+n−1; ASCII SSONx, L21168)";
    "SWITCH_OFF_RO" [1 2 3 4 5 6 7 8] "": U16 ReadWrite
        "SWITCH OFF mask of ROn (4x20025+n−1; ASCII SSOFFx, L21265)";
    "PULSE_RO" [1 2 3 4 5 6 7 8] "": U16 ReadWrite
        "PULSE mask of ROn (4x20033+n−1; ASCII SPULSEx, L21370)";
    "PULSE_TIME_RO" [1 2 3 4 5 6 7 8] "": I32 ReadWrite
        "PULSE TIME of ROn, 1/10 s, UINT32 (4x20065+2(n−1) high word first, 4x20081 low word \
         first; ASCII SPTIMEx, L21469)";
    "PULSE_TIMER_RO" [1 2 3 4 5 6 7 8] "": I32 Input
        "remaining PULSE TIMER of ROn, 1/10 s (4x20097+2(n−1), 4x20113; ASCII GPTIMERx, \
         L21663)";
    "ENABLE_LOGIC_FUNCTIONS" [""] "": U16 ReadWrite
        "the logic runs only while this is 1 (4x21001; ASCII SSMODE, L22509)";
];

/// The model.
pub static MODEL: Model = Model {
    name: "resi-16di8ro",
    type_name: "RESI-16DI8RO-ASCII",
    copyright: "2015-16 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Compact,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["DI*", "RO*"],
    one_shot: &[],
    hw: Hardware {
        inputs: 16,
        relays: 8,
        relay: RelayKind::Bistable,
        relay_counters: true,
        logic: true,
        ..Hardware::NONE
    },
    system_registers: false,
};

crate::devices::resi::catalog_entry!(
    "RESI-16DI8RO: 16 inputs DI1..DI16, 8 bistable relays RO1..RO8 with switching counters, \
     internal logic (SWITCH, TOGGLE, SWITCH ON/OFF, PULSE); Modbus RTU and RESI ASCII"
);
