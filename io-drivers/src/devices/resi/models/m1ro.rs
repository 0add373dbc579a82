//! RESI-1RO (manual chapter 6, L2747–L4340): one changeover relay 250 Vac / 30 Vdc 8 A, driven
//! by DO1 and by the off-delay OFFDLY, the catalogue's only communication watchdog: "If no
//! command is received within 5 seconds, the module switches off the relay" (L4102–L4110).
//! Modbus map 6.15 (L4149–L4323), ASCII commands L3924–L4148.
//!
//! The register block is listed before the coils, so the points read from registers: one
//! FC 3 of 4x00001..4x00005 gives DO1, NDO1, TDO1, NTDO1 and the remaining off-delay in ms.
//! Erratum 14: `GNDOS` bit 1 is printed "(=0:OFF, =1:ON)"; the simulator negates it, as its
//! name says.

use crate::devices::resi::ascii::command::{Command, Field, Fmt};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, RelayKind, Series};
use crate::devices::resi::value::Enc;

static MAP: &[Block] = &[
    Block::regs(&["DO1"], 1, Kind::Do, Enc::Flag, Acc::ReadWrite).cite("L4243"),
    Block::regs(&["NDO1"], 2, Kind::NegDo, Enc::Flag, Acc::ReadOnly),
    Block::regs(&["TDO1"], 3, Kind::TrueDo, Enc::Flag, Acc::ReadOnly),
    Block::regs(&["NTDO1"], 4, Kind::NegTrueDo, Enc::Flag, Acc::ReadOnly),
    Block::regs(&["OFFDLY"], 5, Kind::OffDelay, Enc::U16, Acc::ReadWrite).cite("L4285"),
    Block::regs(
        &["RESET_SYSTEM"],
        6001,
        Kind::ResetSystem,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L4302"),
    Block::regs(
        &["MODBUS_UNIT_ADDRESS"],
        65222,
        Kind::UnitAddress,
        Enc::U16,
        Acc::ReadWrite,
    )
    .cite("L4311"),
    Block::bits(&["DO1"], 1, Kind::Do, Acc::ReadWrite).cite("L4172"),
    Block::bits(&["NDO1"], 2, Kind::NegDo, Acc::ReadOnly).cite("L4187"),
    Block::bits(&["TDO1"], 3, Kind::TrueDo, Acc::ReadOnly).cite("L4196"),
    Block::bits(&["NTDO1"], 4, Kind::NegTrueDo, Acc::ReadOnly),
    Block::bits(&["OFFDLY"], 5, Kind::OffDelayOn, Acc::ReadOnly).cite("L4214"),
];

static COMMANDS: &[Command] = &[
    Command::get("GDOS", &["GET DOS"], &[Field::at(Kind::Dos, 0)], Fmt::Pairs),
    Command::get("GDO", &["GET DO"], &[Field::x(Kind::Do)], Fmt::Pairs).xs(1, 1),
    Command::get(
        "GNDOS",
        &["GET NEG DOS"],
        &[Field::at(Kind::NegDos, 0)],
        Fmt::Pairs,
    ),
    Command::get(
        "GNDO",
        &["GET NEG DO"],
        &[Field::x(Kind::NegDo)],
        Fmt::Pairs,
    )
    .xs(1, 1),
    Command::get(
        "GTDO",
        &["GET TRUE DO"],
        &[Field::x(Kind::TrueDo)],
        Fmt::Pairs,
    )
    .xs(1, 1),
    Command::get(
        "GOFFDLY",
        &["GET OFFDELAY"],
        &[Field::at(Kind::OffDelay, 0)],
        Fmt::Pairs,
    ),
    Command::set("SDO", &["SET DO"], &[Field::x(Kind::Do)]).xs(1, 1),
    Command::set(
        "SOFFDLY",
        &["SET OFFDELAY"],
        &[Field::at(Kind::OffDelay, 0)],
    ),
];

static POINTS: &[crate::point::PointSpec] = points![
    "DO1" [""] "": Bool Output "the commanded output DO1 (4x00001 / 0x00001; ASCII SDO1, L4243)";
    "NDO1" [""] "": Bool Input "DO1 negated (4x00002)";
    "TDO1" [""] "": Bool Input
        "the true relay state, off-delay included (4x00003; ASCII GTDO1, L4196)";
    "NTDO1" [""] "": Bool Input "the true relay state negated (4x00004)";
    "OFFDLY" [""] "": U16 Input
        "remaining off-delay, ms (4x00005; ASCII GOFFDLY, L4285)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-1ro",
    type_name: "RESI-1RO-ASCII",
    copyright: "2015 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Slim,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &["DO1", "TDO1", "OFFDLY"],
    one_shot: &[],
    hw: Hardware {
        relay: RelayKind::Monostable,
        one_relay: true,
        ..Hardware::NONE
    },
    system_registers: true,
};

crate::devices::resi::catalog_entry!(
    "RESI-1RO: one changeover relay DO1 (true state TDO1) with the off-delay OFFDLY that works \
     as a communication watchdog (setting SOFFDLY); Modbus RTU and RESI ASCII"
);
