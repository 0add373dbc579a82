//! RESI-1LED (manual chapter 8, L9514–L11899): a three-channel PWM LED dimmer (400 Hz,
//! 0..48 Vdc, common anode) with modes OFF, ON, FLASH, FADE, RANDOM, SEQUENCE, simulated at the
//! register level (see [`crate::devices::resi::state::led`]). Modbus map 8.15
//! (L11592–L11860), ASCII commands L11054–L11591.
//!
//! Errata 12: "steps per 17100s" (L11705) means 1/100 s; "RLO1 4x00001, RLO2 4x00002 and RLO3
//! 4x00003" (L9622) means 4x00011..13.

use crate::devices::resi::ascii::command::{Command, Field, Fmt};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, Series};
use crate::devices::resi::value::Enc;

const RO: Acc = Acc::ReadOnly;
const RW: Acc = Acc::ReadWrite;

static MAP: &[Block] = &[
    Block::bits(&["ISFADING"], 1, Kind::IsFading, RO).cite("L11615"),
    Block::regs(&["LO1", "LO2", "LO3"], 1, Kind::Lo, Enc::U16, RW).cite("L11644"),
    Block::regs(&["MODE"], 4, Kind::Mode, Enc::U16, RW).cite("L11686"),
    Block::regs(&["FADESPEED"], 5, Kind::FadeSpeed, Enc::U16, RW).cite("L11725"),
    Block::regs(&["MINTIME"], 6, Kind::MinTime, Enc::U16, RW).cite("L11741"),
    Block::regs(&["MAXTIME"], 7, Kind::MaxTime, Enc::U16, RW).cite("L11757"),
    Block::regs(&["CLO1", "CLO2", "CLO3"], 8, Kind::Clo, Enc::U16, RO).cite("L11773"),
    Block::regs(&["RLO1", "RLO2", "RLO3"], 11, Kind::Rlo, Enc::U16, RO).cite("L11800"),
    Block::regs(&["ISFADING"], 14, Kind::IsFading, Enc::Flag, RO).cite("L11827"),
    Block::regs(
        &["RESET_SYSTEM"],
        6001,
        Kind::ResetSystem,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L11837"),
    Block::regs(
        &["MODBUS_UNIT_ADDRESS"],
        65222,
        Kind::UnitAddress,
        Enc::U16,
        RW,
    )
    .cite("L11846"),
];

const P: Fmt = Fmt::Pairs;
const D: Fmt = Fmt::DecsThenHexes;
const fn at(kind: Kind, i: u8) -> Field {
    Field::at(kind, i)
}
const LOS: [Field; 3] = Field::run(Kind::Lo);
const CLOS: [Field; 3] = Field::run(Kind::Clo);
const RLOS: [Field; 3] = Field::run(Kind::Rlo);
const TIMES: [Field; 2] = [at(Kind::MinTime, 0), at(Kind::MaxTime, 0)];
const ALL: [Field; 7] = [
    at(Kind::Mode, 0),
    at(Kind::Lo, 0),
    at(Kind::Lo, 1),
    at(Kind::Lo, 2),
    at(Kind::MinTime, 0),
    at(Kind::MaxTime, 0),
    at(Kind::FadeSpeed, 0),
];
const GALL: [Field; 13] = [
    at(Kind::Mode, 0),
    at(Kind::Lo, 0),
    at(Kind::Lo, 1),
    at(Kind::Lo, 2),
    at(Kind::MinTime, 0),
    at(Kind::MaxTime, 0),
    at(Kind::FadeSpeed, 0),
    at(Kind::Clo, 0),
    at(Kind::Clo, 1),
    at(Kind::Clo, 2),
    at(Kind::Rlo, 0),
    at(Kind::Rlo, 1),
    at(Kind::Rlo, 2),
];

static COMMANDS: &[Command] = &[
    Command::get("GLOS", &["GET LOS"], &LOS, D),
    Command::get("GLO", &["GET LO"], &[Field::x(Kind::Lo)], P).xs(1, 3),
    Command::set("SLO", &["SET LO"], &[Field::x(Kind::Lo)]).xs(1, 3),
    Command::set("SMODE", &["SET MODE"], &[at(Kind::Mode, 0)]),
    Command::get("GMODE", &["GET MODE"], &[at(Kind::Mode, 0)], P),
    Command::set("SFADE", &["SET FADE"], &[at(Kind::FadeSpeed, 0)]),
    Command::get("GFADE", &["GET FADE"], &[at(Kind::FadeSpeed, 0)], P),
    Command::set("SMINT", &["SET MIN TIME"], &[at(Kind::MinTime, 0)]),
    Command::get("GMINT", &["GET MIN TIME"], &[at(Kind::MinTime, 0)], P),
    Command::set("SMAXT", &["SET MAX TIME"], &[at(Kind::MaxTime, 0)]),
    Command::get("GMAXT", &["GET MAX TIME"], &[at(Kind::MaxTime, 0)], P),
    Command::set("STIMES", &["SET TIMES"], &TIMES),
    Command::get("GTIMES", &["GET TIMES"], &TIMES, D),
    Command::set("SALL", &["SET ALL"], &ALL),
    Command::get("GALL", &["GET ALL"], &GALL, D),
    Command::get("GCLOS", &["GET CURRENT LOS"], &CLOS, D),
    Command::get("GRLOS", &["GET RANDOM LOS"], &RLOS, D),
    Command::get("GCLO", &["GET CURRENT LO"], &[Field::x(Kind::Clo)], P).xs(1, 3),
    Command::get("GRLO", &["GET RANDOM LO"], &[Field::x(Kind::Rlo)], P).xs(1, 3),
];

static POINTS: &[crate::point::PointSpec] = points![
    "LO" [1 2 3] "": U16 Output
        "set point of output n, 0..4095 (4x00001+n−1; ASCII SLOx, L11644)";
    "MODE" [""] "": U16 Output
        "0 OFF, 1 ON, 2 FLASH, 3 FADE, 4 RANDOM, 5 SEQUENCE (4x00004; ASCII SMODE, L11686)";
    "FADESPEED" [""] "": U16 ReadWrite "fade steps per 1/100 s, ≥ 1 (4x00005, L11725)";
    "MINTIME" [""] "": U16 ReadWrite "FLASH on time, 1/10 s (4x00006, L11741)";
    "MAXTIME" [""] "": U16 ReadWrite "FLASH off time, 1/10 s (4x00007, L11757)";
    "CLO" [1 2 3] "": U16 Input "current value of output n (4x00008+n−1; ASCII GCLOx, L11773)";
    "RLO" [1 2 3] "": U16 Input "last random value of output n (4x00011+n−1, L11800)";
    "ISFADING" [""] "": Bool Input "a fade is running (0x00001 / 4x00014, L11615)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-1led",
    type_name: "RESI-1LED-ASCII",
    copyright: "2015-16 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Slim,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["CLO*"],
    one_shot: &[],
    hw: Hardware {
        led_groups: 1,
        ..Hardware::NONE
    },
    system_registers: true,
};

crate::devices::resi::catalog_entry!(
    "RESI-1LED: RGB LED dimmer, set points LO1..LO3, MODE, outputs CLO1..CLO3 (register-level \
     simulation); Modbus RTU and RESI ASCII"
);
