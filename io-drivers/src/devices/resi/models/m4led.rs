//! RESI-4LED (manual chapter 9, L11900–L15750): twelve PWM outputs in four groups LED1..LED4
//! of three (A, B, C; output n = 3(g−1) + 1..3, L13432–L13456), each group with its own mode,
//! simulated at the register level (see [`crate::devices::resi::state::led`]). Modbus map 9.14
//! (L14200–L15118), ASCII commands L13677–L14199.
//!
//! Erratum 13: the RANDOM text cites "IS FADE ACTIVE 4x00014" (L12035); fading is 4x00029..32
//! or coils 1..4. `GTIMESx` and `GALLx` answer `GTIMES:` and `GALL:` without the group number
//! (L13957, L14030), as printed.

use crate::devices::resi::ascii::command::{Command, Field, Fmt};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{names, points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, Series};
use crate::devices::resi::value::Enc;

const RO: Acc = Acc::ReadOnly;
const RW: Acc = Acc::ReadWrite;
const GROUPS: &[&str] = names!("LED" [1 2 3 4] "_ISFADING");

static MAP: &[Block] = &[
    Block::bits(GROUPS, 1, Kind::IsFading, RO).cite("L14224"),
    Block::bits(names!("DIP" [1 2 3 4 5 6 7 8]), 2001, Kind::Dip, RO).cite("L14265"),
    Block::regs(
        names!("LO" [1 2 3 4 5 6 7 8 9 10 11 12]),
        1,
        Kind::Lo,
        Enc::U16,
        RW,
    )
    .cite("L14358"),
    Block::regs(names!("MODE" [1 2 3 4]), 13, Kind::Mode, Enc::U16, RW).cite("L14504"),
    Block::regs(
        names!("FADESPEED" [1 2 3 4]),
        17,
        Kind::FadeSpeed,
        Enc::U16,
        RW,
    )
    .cite("L14580"),
    Block::regs(names!("MINTIME" [1 2 3 4]), 21, Kind::MinTime, Enc::U16, RW).cite("L14644"),
    Block::regs(names!("MAXTIME" [1 2 3 4]), 25, Kind::MaxTime, Enc::U16, RW).cite("L14705"),
    Block::regs(
        names!("ISFADING" [1 2 3 4]),
        29,
        Kind::IsFading,
        Enc::Flag,
        RO,
    )
    .cite("L14765"),
    Block::regs(
        names!("CLO" [1 2 3 4 5 6 7 8 9 10 11 12]),
        33,
        Kind::Clo,
        Enc::U16,
        RO,
    )
    .cite("L14806"),
    Block::regs(
        names!("RLO" [1 2 3 4 5 6 7 8 9 10 11 12]),
        45,
        Kind::Rlo,
        Enc::U16,
        RO,
    )
    .cite("L14939"),
    Block::regs(&["DIP"], 2001, Kind::DipWord, Enc::U16, RO).cite("L15080"),
    Block::regs(
        &["RESET_SYSTEM"],
        6001,
        Kind::ResetSystem,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L15097"),
    Block::regs(
        &["MODBUS_UNIT_ADDRESS"],
        65222,
        Kind::UnitAddress,
        Enc::U16,
        RW,
    )
    .cite("L15106"),
];

const P: Fmt = Fmt::Pairs;
const D: Fmt = Fmt::DecsThenHexes;
const fn abc(kind: Kind, k: u8) -> Field {
    Field::group(kind, 3, k)
}
const LOS: [Field; 12] = Field::run(Kind::Lo);
const CLOS: [Field; 12] = Field::run(Kind::Clo);
const RLOS: [Field; 12] = Field::run(Kind::Rlo);
const TIMES: [Field; 2] = [Field::x(Kind::MinTime), Field::x(Kind::MaxTime)];
const ALL: [Field; 7] = [
    Field::x(Kind::Mode),
    abc(Kind::Lo, 0),
    abc(Kind::Lo, 1),
    abc(Kind::Lo, 2),
    Field::x(Kind::MinTime),
    Field::x(Kind::MaxTime),
    Field::x(Kind::FadeSpeed),
];
const GALL: [Field; 13] = [
    Field::x(Kind::Mode),
    abc(Kind::Lo, 0),
    abc(Kind::Lo, 1),
    abc(Kind::Lo, 2),
    Field::x(Kind::MinTime),
    Field::x(Kind::MaxTime),
    Field::x(Kind::FadeSpeed),
    abc(Kind::Clo, 0),
    abc(Kind::Clo, 1),
    abc(Kind::Clo, 2),
    abc(Kind::Rlo, 0),
    abc(Kind::Rlo, 1),
    abc(Kind::Rlo, 2),
];

static COMMANDS: &[Command] = &[
    Command::get("GLOS", &["GET LOS"], &LOS, D),
    Command::get("GLO", &["GET LO"], &[Field::x(Kind::Lo)], P).xs(1, 12),
    Command::set("SLO", &["SET LO"], &[Field::x(Kind::Lo)]).xs(1, 12),
    Command::set("SMODE", &["SET MODE"], &[Field::x(Kind::Mode)]).xs(1, 4),
    Command::get("GMODE", &["GET MODE"], &[Field::x(Kind::Mode)], P).xs(1, 4),
    Command::set("SFADE", &["SET FADE"], &[Field::x(Kind::FadeSpeed)]).xs(1, 4),
    Command::get("GFADE", &["GET FADE"], &[Field::x(Kind::FadeSpeed)], P).xs(1, 4),
    Command::set("SMINT", &["SET MIN TIME"], &[Field::x(Kind::MinTime)]).xs(1, 4),
    Command::get("GMINT", &["GET MIN TIME"], &[Field::x(Kind::MinTime)], P).xs(1, 4),
    Command::set("SMAXT", &["SET MAX TIME"], &[Field::x(Kind::MaxTime)]).xs(1, 4),
    Command::get("GMAXT", &["GET MAX TIME"], &[Field::x(Kind::MaxTime)], P).xs(1, 4),
    Command::set("STIMES", &["SET TIMES"], &TIMES).xs(1, 4),
    Command::get("GTIMES", &["GET TIMES"], &TIMES, D)
        .xs(1, 4)
        .reply("GTIMES"),
    Command::set("SALL", &["SET ALL"], &ALL).xs(1, 4),
    Command::get("GALL", &["GET ALL"], &GALL, D)
        .xs(1, 4)
        .reply("GALL"),
    Command::get("GCLOS", &["GET CURRENT LOS"], &CLOS, D),
    Command::get("GRLOS", &["GET RANDOM LOS"], &RLOS, D),
    Command::get("GCLO", &["GET CURRENT LO"], &[Field::x(Kind::Clo)], P).xs(1, 12),
    Command::get("GRLO", &["GET RANDOM LO"], &[Field::x(Kind::Rlo)], P).xs(1, 12),
];

static POINTS: &[crate::point::PointSpec] = points![
    "LO" [1 2 3 4 5 6 7 8 9 10 11 12] "": U16 Output
        "set point of output n = 3(g−1)+A/B/C, 0..4095 (4x00001+n−1; ASCII SLOx, L14358)";
    "MODE" [1 2 3 4] "": U16 Output
        "mode of group g: 0 OFF, 1 ON, 2 FLASH, 3 FADE, 4 RANDOM, 5 SEQUENCE (4x00013+g−1; \
         ASCII SMODEx, L14504)";
    "FADESPEED" [1 2 3 4] "": U16 ReadWrite "fade steps per 1/100 s of group g (4x00017+g−1)";
    "MINTIME" [1 2 3 4] "": U16 ReadWrite "FLASH on time of group g, 1/10 s (4x00021+g−1)";
    "MAXTIME" [1 2 3 4] "": U16 ReadWrite "FLASH off time of group g, 1/10 s (4x00025+g−1)";
    "ISFADING" [1 2 3 4] "": Bool Input "group g is fading (4x00029+g−1, L14765)";
    "CLO" [1 2 3 4 5 6 7 8 9 10 11 12] "": U16 Input
        "current value of output n (4x00033+n−1; ASCII GCLOx, L14806)";
    "RLO" [1 2 3 4 5 6 7 8 9 10 11 12] "": U16 Input
        "last random value of output n (4x00045+n−1, L14939)";
    "DIP" [""] "": U16 Input "DIP switches 1..8 as bits (4x02001; ASCII GDIP, L15080)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-4led",
    type_name: "RESI-4LED-ASCII",
    copyright: "2015-16 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Compact,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["CLO*"],
    one_shot: &[],
    hw: Hardware {
        led_groups: 4,
        ..Hardware::NONE
    },
    system_registers: true,
};

crate::devices::resi::catalog_entry!(
    "RESI-4LED: 12 PWM outputs LO1..LO12 in 4 groups with MODE1..4, outputs CLO1..CLO12 \
     (register-level simulation); Modbus RTU and RESI ASCII"
);
