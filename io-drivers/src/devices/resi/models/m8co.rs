//! RESI-8CO (manual chapter 13, L29036–L31787): 8 monostable changeover relays 250 Vac / 30 Vdc,
//! 8 A (L29043, L29100), with timed pulses. Modbus map 13.13 (L31259–L31787), ASCII commands
//! L31045–L31258.
//!
//! Errata: ROS at 4x00101 is printed with the index "I:0" (L31496, erratum 6); it is served at
//! protocol address 100, with the same value as 4x00001. The long form of `GPTx` is printed
//! `GET PPULSE TIMERx` (L31209, erratum 11); both spellings are accepted. `SROS` speaks of
//! "bistable" relays (L31146): they are monostable.

use crate::devices::resi::ascii::command::{Command, Field, Fmt};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{names, points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, RelayKind, Series};
use crate::devices::resi::value::{Enc, WordOrder};

const LEFT: &[&str] = names!("PULSETIME_RO" [1 2 3 4 5 6 7 8]);

static MAP: &[Block] = &[
    Block::bits(names!("RO" [1 2 3 4 5 6 7 8]), 1, Kind::Ro, Acc::ReadWrite).cite("L31282"),
    Block::bits(names!("DIP" [1 2 3 4 5 6 7 8]), 9, Kind::Dip, Acc::ReadOnly).cite("L31379"),
    Block::regs(&["ROS"], 1, Kind::Ros, Enc::U16, Acc::ReadWrite).cite("L31474"),
    Block::regs(&["ROS"], 101, Kind::Ros, Enc::U16, Acc::ReadWrite).cite("L31494"),
    Block::regs(&["DIP"], 103, Kind::DipWord, Enc::U16, Acc::ReadOnly).cite("L31514"),
    Block::regs(
        names!("PULSE_RO" [1 2 3 4 5 6 7 8]),
        201,
        Kind::RelayPulse,
        Enc::U16,
        Acc::ReadWrite,
    )
    .cite("L31532"),
    Block::regs(
        LEFT,
        301,
        Kind::RelayPulseLeft,
        Enc::S32(1, WordOrder::HighFirst),
        Acc::ReadOnly,
    )
    .cite("L31629"),
    Block::regs(
        LEFT,
        317,
        Kind::RelayPulseLeft,
        Enc::S32(1, WordOrder::LowFirst),
        Acc::ReadOnly,
    )
    .cite("L31709"),
];

static COMMANDS: &[Command] = &[
    Command::get("GROS", &["GET ROS"], &[Field::at(Kind::Ros, 0)], Fmt::Pairs),
    Command::set("SROS", &["SET ROS"], &[Field::at(Kind::Ros, 0)]),
    Command::get("GRO", &["GET RO"], &[Field::x(Kind::Ro)], Fmt::Pairs).xs(1, 8),
    Command::set("SRO", &["SET RO"], &[Field::x(Kind::Ro)]).xs(1, 8),
    Command::set("PRO", &["PULSE RO"], &[Field::x(Kind::RelayPulse)]).xs(1, 8),
    Command::get(
        "GPT",
        &["GET PULSE TIMER", "GET PPULSE TIMER"],
        &[Field::x(Kind::RelayPulseLeft)],
        Fmt::Pairs,
    )
    .xs(1, 8),
];

static POINTS: &[crate::point::PointSpec] = points![
    "RO" [1 2 3 4 5 6 7 8] "": Bool Output
        "monostable relay ROn (0x00001+n−1; ASCII SROx/GROx, L31282)";
    "ROS" [""] "": U16 Input "RO1..RO8 as bits (4x00001 = 4x00101; ASCII GROS, L31474)";
    "DIP" [""] "": U16 Input "DIP switches 1..8 as bits (4x00103; ASCII GDIP, L31514)";
    "DIP" [1 2 3 4 5 6 7 8] "": Bool Input "DIP switch n (0x00009+n−1, L31379)";
    "PULSE_RO" [1 2 3 4 5 6 7 8] "": U16 Output
        "pulse: a new value switches ROn on for value × 100 ms, 0 ends it; written on change \
         only (4x00201+n−1; ASCII PROx, L31532)";
    "PULSETIME_RO" [1 2 3 4 5 6 7 8] "": I32 Input
        "remaining pulse time of ROn, ms (4x00301+2(n−1) SINT32, 4x00317 SINT32I; ASCII GPTx, \
         L31629)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-8co",
    type_name: "RESI-8CO-ASCII",
    copyright: "2015-16 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Compact,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["RO*"],
    one_shot: &[
        "PULSE_RO1",
        "PULSE_RO2",
        "PULSE_RO3",
        "PULSE_RO4",
        "PULSE_RO5",
        "PULSE_RO6",
        "PULSE_RO7",
        "PULSE_RO8",
    ],
    hw: Hardware {
        relays: 8,
        relay: RelayKind::Monostable,
        relay_pulses: true,
        ..Hardware::NONE
    },
    system_registers: false,
};

crate::devices::resi::catalog_entry!(
    "RESI-8CO: 8 monostable changeover relays RO1..RO8 with timed pulses PULSE_RO1..8; Modbus \
     RTU and RESI ASCII"
);
