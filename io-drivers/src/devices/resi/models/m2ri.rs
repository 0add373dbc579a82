//! RESI-2RI (manual chapter 5, L1626–L2746): 2 digital inputs 10–250 Vac/dc with their
//! negations, OR / XOR / AND of both, and edge counters. Modbus map 5.15 (L2413–L2731),
//! ASCII commands L2137–L2412.
//!
//! Erratum 5: the counters are printed with four digits, 4x0051..4x0054 (L2648–L2660); they
//! are 4x00051..4x00054, protocol addresses 50..53. The FALL DI texts say "rising edge"
//! (L2665).

use crate::devices::resi::ascii::command::{Command, Field, Fmt, Op};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, Series};
use crate::devices::resi::value::Enc;

const RO: Acc = Acc::ReadOnly;

static MAP: &[Block] = &[
    Block::bits(&["DI1", "DI2"], 1, Kind::Di, RO).cite("L2436"),
    Block::bits(&["NDI1", "NDI2"], 3, Kind::NegDi, RO).cite("L2454"),
    Block::bits(&["ORDIS"], 5, Kind::OrDis, RO).cite("L2472"),
    Block::bits(&["XORDIS"], 6, Kind::XorDis, RO),
    Block::bits(&["ANDDIS"], 7, Kind::AndDis, RO).cite("L2502"),
    Block::bits(&["RESET_COUNTER"], 100, Kind::ResetCounter, Acc::WriteOnly).cite("L2518"),
    Block::regs(&["DI1", "DI2"], 1, Kind::Di, Enc::Flag, RO).cite("L2548"),
    Block::regs(&["DIS"], 3, Kind::DisWord, Enc::U16, RO).cite("L2568"),
    Block::regs(&["NDI1", "NDI2"], 4, Kind::NegDi, Enc::Flag, RO),
    Block::regs(&["NDIS"], 6, Kind::NegDis, Enc::U16, RO).cite("L2598"),
    Block::regs(&["ORDIS"], 7, Kind::OrDis, Enc::Flag, RO),
    Block::regs(&["XORDIS"], 8, Kind::XorDis, Enc::Flag, RO),
    Block::regs(&["ANDDIS"], 9, Kind::AndDis, Enc::Flag, RO).cite("L2635"),
    Block::regs(&["RISE_DI1", "RISE_DI2"], 51, Kind::Rise, Enc::U16, RO)
        .stride(2)
        .cite("L2648"),
    Block::regs(&["FALL_DI1", "FALL_DI2"], 52, Kind::Fall, Enc::U16, RO)
        .stride(2)
        .cite("L2659"),
    Block::regs(
        &["RESET_COUNTER"],
        100,
        Kind::ResetCounter,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L2698"),
    Block::regs(
        &["RESET_SYSTEM"],
        6001,
        Kind::ResetSystem,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L2710"),
    Block::regs(
        &["MODBUS_UNIT_ADDRESS"],
        65222,
        Kind::UnitAddress,
        Enc::U16,
        Acc::ReadWrite,
    )
    .cite("L2719"),
];

const P: Fmt = Fmt::Pairs;

static COMMANDS: &[Command] = &[
    Command::get("GDIS", &["GET DIS"], &[Field::at(Kind::Dis, 0)], P),
    Command::get("GDI", &["GET DI"], &[Field::x(Kind::Di)], P).xs(1, 2),
    Command::get("GNDIS", &["GET NEG DIS"], &[Field::at(Kind::NegDis, 0)], P),
    Command::get("GNDI", &["GET NEG DI"], &[Field::x(Kind::NegDi)], P).xs(1, 2),
    Command::get("ORDIS", &["OR DIS"], &[Field::at(Kind::OrDis, 0)], P),
    Command::get("XORDIS", &["XOR DIS"], &[Field::at(Kind::XorDis, 0)], P),
    Command::get("ANDDIS", &["AND DIS"], &[Field::at(Kind::AndDis, 0)], P),
    Command::get("RDI", &["RISE DI"], &[Field::x(Kind::Rise)], P).xs(1, 2),
    Command::get("FDI", &["FALL DI"], &[Field::x(Kind::Fall)], P).xs(1, 2),
    Command::op("RC", &["RESET COUNTERS"], Op::ResetCounters),
];

static POINTS: &[crate::point::PointSpec] = points![
    "DI" [1 2] "": Bool Input "input DIn (0x00001+n−1; ASCII GDIx, L2436)";
    "NDI" [1 2] "": Bool Input "input DIn negated (0x00003+n−1, L2454)";
    "ORDIS" [""] "": Bool Input "DI1 OR DI2 (0x00005, L2472)";
    "XORDIS" [""] "": Bool Input "DI1 XOR DI2 (0x00006)";
    "ANDDIS" [""] "": Bool Input "DI1 AND DI2 (0x00007, L2502)";
    "DIS" [""] "": U16 Input "DI1, DI2 as bits (4x00003, L2568)";
    "NDIS" [""] "": U16 Input "DI1, DI2 negated as bits (4x00006, L2598)";
    "RISE_DI" [1 2] "": U16 Input "rising edges of DIn since power-on (4x00051+2(n−1), L2648)";
    "FALL_DI" [1 2] "": U16 Input "falling edges of DIn since power-on (4x00052+2(n−1), L2659)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-2ri",
    type_name: "RESI-2RI-ASCII",
    copyright: "2015 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Slim,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["DI*"],
    one_shot: &[],
    hw: Hardware {
        inputs: 2,
        ..Hardware::NONE
    },
    system_registers: true,
};

crate::devices::resi::catalog_entry!(
    "RESI-2RI: 2 inputs DI1, DI2 10..250 V with NDI, ORDIS/XORDIS/ANDDIS and edge counters; \
     Modbus RTU and RESI ASCII"
);
