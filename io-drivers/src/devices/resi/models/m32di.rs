//! RESI-32DI (manual chapter 11, L23170–L26001): 32 digital inputs 12–48 Vdc, sampled every
//! 10 ms (L23241), with rising/falling edge counters. Modbus map 11.13 (L24063–L26001), ASCII
//! commands L23845–L24062.
//!
//! Erratum 10: the descriptions of RISE/FALL DI17..32 name DI13..16 (L25514 ff.); the name
//! column is followed.

use crate::devices::resi::ascii::command::{Command, Field, Fmt, Op};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{names, points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, Series};
use crate::devices::resi::value::Enc;

static MAP: &[Block] = &[
    Block::bits(
        names!("DI" [
            1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32
        ]),
        1,
        Kind::Di,
        Acc::ReadOnly,
    )
    .cite("L24086"),
    Block::bits(
        names!("DIP" [1 2 3 4 5 6 7 8]),
        33,
        Kind::Dip,
        Acc::ReadOnly,
    )
    .cite("L25012"),
    Block::bits(&["RESET_COUNTER"], 100, Kind::ResetCounter, Acc::WriteOnly).cite("L25084"),
    Block::regs(
        names!("RISE_DI" [
            1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32
        ]),
        1,
        Kind::Rise,
        Enc::U16,
        Acc::ReadOnly,
    )
    .stride(2)
    .cite("L25111"),
    Block::regs(
        names!("FALL_DI" [
            1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32
        ]),
        2,
        Kind::Fall,
        Enc::U16,
        Acc::ReadOnly,
    )
    .stride(2)
    .cite("L25124"),
    Block::regs(
        &["RESET_COUNTER"],
        100,
        Kind::ResetCounter,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L25927"),
    Block::regs(
        &["DIS1_16", "DIS17_32"],
        101,
        Kind::DisWord,
        Enc::U16,
        Acc::ReadOnly,
    )
    .cite("L25942"),
    Block::regs(&["DIP"], 103, Kind::DipWord, Enc::U16, Acc::ReadOnly).cite("L25986"),
];

static COMMANDS: &[Command] = &[
    Command::get("GDIS", &["GET DIS"], &[Field::at(Kind::Dis, 0)], Fmt::Pairs),
    Command::get("GDI", &["GET DI"], &[Field::x(Kind::Di)], Fmt::Pairs).xs(1, 32),
    Command::get("RDI", &["RISE DI"], &[Field::x(Kind::Rise)], Fmt::Pairs).xs(1, 32),
    Command::get("FDI", &["FALL DI"], &[Field::x(Kind::Fall)], Fmt::Pairs).xs(1, 32),
    Command::op("RC", &["RESET COUNTERS"], Op::ResetCounters),
];

static POINTS: &[crate::point::PointSpec] = points![
    "DI" [
        1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32
    ] "":
        Bool Input "input DIn, sampled every 10 ms (0x00001+n−1; ASCII GDIx, L24086)";
    "DIS1_16" [""] "": U16 Input "DI1..DI16 as bits (4x00101, L25942)";
    "DIS17_32" [""] "": U16 Input "DI17..DI32 as bits (4x00102, L25966)";
    "DIP" [""] "": U16 Input "DIP switches 1..8 as bits (4x00103; ASCII GDIP)";
    "DIP" [1 2 3 4 5 6 7 8] "": Bool Input "DIP switch n (0x00033+n−1, L25012)";
    "RISE_DI" [
        1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32
    ] "":
        U16 Input "rising edges of DIn since power-on (4x00001+2(n−1); ASCII RDIx)";
    "FALL_DI" [
        1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32
    ] "":
        U16 Input "falling edges of DIn since power-on (4x00002+2(n−1); ASCII FDIx)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-32di",
    type_name: "RESI-32DI-ASCII",
    copyright: "2015-16 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Compact,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["DI*"],
    one_shot: &[],
    hw: Hardware {
        inputs: 32,
        ..Hardware::NONE
    },
    system_registers: false,
};

crate::devices::resi::catalog_entry!(
    "RESI-32DI: 32 inputs DI1..DI32 with edge counters; Modbus RTU and RESI ASCII"
);
