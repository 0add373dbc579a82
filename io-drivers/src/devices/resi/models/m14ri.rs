//! RESI-14RI (manual chapter 12, L26002–L29035): 14 isolated digital inputs 24–250 Vac/dc,
//! sampled every 10 ms (L26072), with edge counters. Modbus map 12.14 (L28375–L29035), ASCII
//! commands L28179–L28374. The DIP coils sit at 0x00033, as on the 32DI; 4x00102 is FREE.
//! Erratum 10: `GDIS` is said to return "all 32 digital inputs" (L28259); it has 14.

use crate::devices::resi::ascii::command::{Command, Field, Fmt, Op};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{names, points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, Series};
use crate::devices::resi::value::Enc;

static MAP: &[Block] = &[
    Block::bits(
        names!("DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14]),
        1,
        Kind::Di,
        Acc::ReadOnly,
    )
    .cite("L28398"),
    Block::bits(
        names!("DIP" [1 2 3 4 5 6 7 8]),
        33,
        Kind::Dip,
        Acc::ReadOnly,
    )
    .cite("L28526"),
    Block::bits(&["RESET_COUNTER"], 100, Kind::ResetCounter, Acc::WriteOnly).cite("L28598"),
    Block::regs(
        names!("RISE_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14]),
        1,
        Kind::Rise,
        Enc::U16,
        Acc::ReadOnly,
    )
    .stride(2),
    Block::regs(
        names!("FALL_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14]),
        2,
        Kind::Fall,
        Enc::U16,
        Acc::ReadOnly,
    )
    .stride(2),
    Block::regs(
        &["RESET_COUNTER"],
        100,
        Kind::ResetCounter,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L28977"),
    Block::regs(&["DIS"], 101, Kind::DisWord, Enc::U16, Acc::ReadOnly).cite("L28988"),
    Block::regs(&["FREE"], 102, Kind::Free, Enc::U16, Acc::ReadOnly).cite("L29012"),
    Block::regs(&["DIP"], 103, Kind::DipWord, Enc::U16, Acc::ReadOnly).cite("L29020"),
];

static COMMANDS: &[Command] = &[
    Command::get("GDIS", &["GET DIS"], &[Field::at(Kind::Dis, 0)], Fmt::Pairs),
    Command::get("GDI", &["GET DI"], &[Field::x(Kind::Di)], Fmt::Pairs).xs(1, 14),
    Command::get("RDI", &["RISE DI"], &[Field::x(Kind::Rise)], Fmt::Pairs).xs(1, 14),
    Command::get("FDI", &["FALL DI"], &[Field::x(Kind::Fall)], Fmt::Pairs).xs(1, 14),
    Command::op("RC", &["RESET COUNTERS"], Op::ResetCounters),
];

static POINTS: &[crate::point::PointSpec] = points![
    "DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14] "": Bool Input
        "isolated input DIn, sampled every 10 ms (0x00001+n−1; ASCII GDIx)";
    "DIS" [""] "": U16 Input "DI1..DI14 as bits (4x00101)";
    "DIP" [""] "": U16 Input "DIP switches 1..8 as bits (4x00103; ASCII GDIP)";
    "DIP" [1 2 3 4 5 6 7 8] "": Bool Input "DIP switch n (0x00033+n−1)";
    "RISE_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14] "": U16 Input
        "rising edges of DIn since power-on (4x00001+2(n−1); ASCII RDIx)";
    "FALL_DI" [1 2 3 4 5 6 7 8 9 10 11 12 13 14] "": U16 Input
        "falling edges of DIn since power-on (4x00002+2(n−1); ASCII FDIx)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-14ri",
    type_name: "RESI-14RI-ASCII",
    copyright: "2015-16 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Compact,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["DI*"],
    one_shot: &[],
    hw: Hardware {
        inputs: 14,
        ..Hardware::NONE
    },
    system_registers: false,
};

crate::devices::resi::catalog_entry!(
    "RESI-14RI: 14 isolated 24..250 V inputs DI1..DI14 with edge counters; Modbus RTU and RESI \
     ASCII"
);
