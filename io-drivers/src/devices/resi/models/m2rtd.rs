//! RESI-2RTD (manual chapter 7, L4341–L9513): two RTD inputs (PT10…PT1000, NI120), simulated
//! at the register level (see [`crate::devices::resi::state::rtd`]). Modbus map 7.16
//! (L6751–L8862), every temperature in seven encodings; ASCII commands L5351–L6750.
//!
//! Errata: DOUBLE64 is lowest word first and DOUBLE64I highest word first, the reverse of the
//! 32-bit "I" convention (erratum 8, L7607, L7749). 4x00909-912 is listed twice, for CH1 and
//! CH2 AVG_SUM (erratum 7, L7929, L7944): it serves CH1's. The TYPE row prints
//! `RESI-1RO-ASCII` (L5370); the simulator answers `RESI-2RTD-ASCII`. The sensor
//! configuration commands `GSCS`, `GSC1`, `GSC2`, `SSCS`, `SSC1`, `SSC2` (L6416–L6530) read
//! and write 4x06021 / 4x06041 (SENSOR_TYPE) by name (see
//! [`crate::devices::resi::ascii::sensor_config`] for the names and where the chapters
//! differ); like the register, a new configuration is stored at once and measured with after
//! a reboot, and `GSCx` shows what is stored.

use crate::devices::resi::ascii::command::{Command, Field, Fmt};
use crate::devices::resi::item::{Kind, Temp};
use crate::devices::resi::map::{points, Acc, Block, Map};
use crate::devices::resi::model::{Hardware, Model, Series};
use crate::devices::resi::value::{Enc, WordOrder};

const HI: WordOrder = WordOrder::HighFirst;
const LO: WordOrder = WordOrder::LowFirst;
const RO: Acc = Acc::ReadOnly;
const RW: Acc = Acc::ReadWrite;

static MAP: &[Block] = &[
    // STATUS as a plain number first, so the STATUS points are integers (L6914).
    Block::regs(
        &["CH1_STATUS", "CH2_STATUS"],
        7,
        Kind::Status,
        Enc::S16(1),
        RO,
    ),
    // FLOAT32, high word first (L7336).
    Block::regs(
        &["CH1_VALID_TEMP", "CH2_VALID_TEMP"],
        301,
        Kind::Temp(Temp::Valid),
        Enc::F32(HI),
        RO,
    )
    .cite("L7336"),
    Block::regs(
        &["CH1_REAL_TEMP", "CH2_REAL_TEMP"],
        305,
        Kind::Temp(Temp::Real),
        Enc::F32(HI),
        RO,
    ),
    Block::regs(
        &["CH1_AVG_TEMP", "CH2_AVG_TEMP"],
        309,
        Kind::Temp(Temp::Avg),
        Enc::F32(HI),
        RO,
    ),
    Block::regs(
        &["CH1_STATUS", "CH2_STATUS"],
        313,
        Kind::Status,
        Enc::F32(HI),
        RO,
    ),
    // SINT16 × 10 (L6804).
    Block::regs(
        &["CH1_VALID_TEMP", "CH2_VALID_TEMP"],
        1,
        Kind::Temp(Temp::Valid),
        Enc::S16(10),
        RO,
    )
    .cite("L6804"),
    Block::regs(
        &["CH1_REAL_TEMP", "CH2_REAL_TEMP"],
        3,
        Kind::Temp(Temp::Real),
        Enc::S16(10),
        RO,
    ),
    Block::regs(
        &["CH1_AVG_TEMP", "CH2_AVG_TEMP"],
        5,
        Kind::Temp(Temp::Avg),
        Enc::S16(10),
        RO,
    ),
    // SINT32 × 100000, high word first (L7051).
    Block::regs(
        &["CH1_VALID_TEMP", "CH2_VALID_TEMP"],
        101,
        Kind::Temp(Temp::Valid),
        Enc::S32(100_000, HI),
        RO,
    )
    .cite("L7051"),
    Block::regs(
        &["CH1_REAL_TEMP", "CH2_REAL_TEMP"],
        105,
        Kind::Temp(Temp::Real),
        Enc::S32(100_000, HI),
        RO,
    ),
    Block::regs(
        &["CH1_AVG_TEMP", "CH2_AVG_TEMP"],
        109,
        Kind::Temp(Temp::Avg),
        Enc::S32(100_000, HI),
        RO,
    ),
    Block::regs(
        &["CH1_STATUS", "CH2_STATUS"],
        113,
        Kind::Status,
        Enc::S32(1, HI),
        RO,
    ),
    // SINT32I × 100000, low word first (L7194).
    Block::regs(
        &["CH1_VALID_TEMP", "CH2_VALID_TEMP"],
        201,
        Kind::Temp(Temp::Valid),
        Enc::S32(100_000, LO),
        RO,
    )
    .cite("L7194"),
    Block::regs(
        &["CH1_REAL_TEMP", "CH2_REAL_TEMP"],
        205,
        Kind::Temp(Temp::Real),
        Enc::S32(100_000, LO),
        RO,
    ),
    Block::regs(
        &["CH1_AVG_TEMP", "CH2_AVG_TEMP"],
        209,
        Kind::Temp(Temp::Avg),
        Enc::S32(100_000, LO),
        RO,
    ),
    Block::regs(
        &["CH1_STATUS", "CH2_STATUS"],
        213,
        Kind::Status,
        Enc::S32(1, LO),
        RO,
    ),
    // FLOAT32I, low word first (L7476).
    Block::regs(
        &["CH1_VALID_TEMP", "CH2_VALID_TEMP"],
        321,
        Kind::Temp(Temp::Valid),
        Enc::F32(LO),
        RO,
    )
    .cite("L7476"),
    Block::regs(
        &["CH1_REAL_TEMP", "CH2_REAL_TEMP"],
        325,
        Kind::Temp(Temp::Real),
        Enc::F32(LO),
        RO,
    ),
    Block::regs(
        &["CH1_AVG_TEMP", "CH2_AVG_TEMP"],
        329,
        Kind::Temp(Temp::Avg),
        Enc::F32(LO),
        RO,
    ),
    Block::regs(
        &["CH1_STATUS", "CH2_STATUS"],
        333,
        Kind::Status,
        Enc::F32(LO),
        RO,
    ),
    // DOUBLE64, lowest word first (erratum 8) (L7618).
    Block::regs(
        &["CH1_VALID_TEMP", "CH2_VALID_TEMP"],
        501,
        Kind::Temp(Temp::Valid),
        Enc::F64(LO),
        RO,
    )
    .cite("L7618"),
    Block::regs(
        &["CH1_REAL_TEMP", "CH2_REAL_TEMP"],
        509,
        Kind::Temp(Temp::Real),
        Enc::F64(LO),
        RO,
    ),
    Block::regs(
        &["CH1_AVG_TEMP", "CH2_AVG_TEMP"],
        517,
        Kind::Temp(Temp::Avg),
        Enc::F64(LO),
        RO,
    ),
    Block::regs(
        &["CH1_STATUS", "CH2_STATUS"],
        525,
        Kind::Status,
        Enc::F64(LO),
        RO,
    ),
    // DOUBLE64I, highest word first (erratum 8) (L7760).
    Block::regs(
        &["CH1_VALID_TEMP", "CH2_VALID_TEMP"],
        701,
        Kind::Temp(Temp::Valid),
        Enc::F64(HI),
        RO,
    )
    .cite("L7760"),
    Block::regs(
        &["CH1_REAL_TEMP", "CH2_REAL_TEMP"],
        709,
        Kind::Temp(Temp::Real),
        Enc::F64(HI),
        RO,
    ),
    Block::regs(
        &["CH1_AVG_TEMP", "CH2_AVG_TEMP"],
        717,
        Kind::Temp(Temp::Avg),
        Enc::F64(HI),
        RO,
    ),
    Block::regs(
        &["CH1_STATUS", "CH2_STATUS"],
        725,
        Kind::Status,
        Enc::F64(HI),
        RO,
    ),
    // AVG_SUM (°C) and AVG_COUNT (L7899–L8020).
    Block::regs(
        &["CH1_AVG_SUM", "CH2_AVG_SUM"],
        901,
        Kind::AvgSum,
        Enc::F64(LO),
        RO,
    )
    .cite("L7899"),
    Block::regs(&["CH1_AVG_SUM"], 909, Kind::AvgSum, Enc::F64(HI), RO).cite("L7929"),
    Block::regs(
        &["CH1_AVG_COUNT", "CH2_AVG_COUNT"],
        913,
        Kind::AvgCount,
        Enc::U32(LO),
        RO,
    )
    .cite("L7966"),
    Block::regs(
        &["CH1_AVG_COUNT", "CH2_AVG_COUNT"],
        917,
        Kind::AvgCount,
        Enc::U32(HI),
        RO,
    )
    .cite("L8004"),
    Block::regs(
        &["RESET_SYSTEM"],
        6001,
        Kind::ResetSystem,
        Enc::U16,
        Acc::WriteOnly,
    )
    .cite("L8681"),
    Block::regs(
        &["MODBUS_UNIT_ADDRESS"],
        65222,
        Kind::UnitAddress,
        Enc::U16,
        RW,
    )
    .cite("L8690"),
    // Configuration in FLASH, valid after a reboot (L8707–L8862).
    Block::regs(
        &["CH1_SENSOR_TYPE", "CH2_SENSOR_TYPE"],
        6021,
        Kind::SensorType,
        Enc::U16,
        RW,
    )
    .stride(20)
    .cite("L8707"),
    Block::regs(
        &["CH1_ZERO_OFFSET", "CH2_ZERO_OFFSET"],
        6022,
        Kind::ZeroOffset,
        Enc::S32(100_000, LO),
        RW,
    )
    .stride(20)
    .cite("L8750"),
    Block::regs(
        &["CH1_AVG_INTERVAL", "CH2_AVG_INTERVAL"],
        6024,
        Kind::AvgInterval,
        Enc::U32(LO),
        RW,
    )
    .stride(20)
    .cite("L8768"),
];

const P: Fmt = Fmt::Pairs;
const R: Fmt = Fmt::Reals;
const VALID: [Field; 2] = [
    Field::at(Kind::Temp(Temp::Valid), 0),
    Field::at(Kind::Temp(Temp::Valid), 1),
];
const REAL: [Field; 2] = [
    Field::at(Kind::Temp(Temp::Real), 0),
    Field::at(Kind::Temp(Temp::Real), 1),
];
const AVG: [Field; 2] = [
    Field::at(Kind::Temp(Temp::Avg), 0),
    Field::at(Kind::Temp(Temp::Avg), 1),
];
const INTERVALS: [Field; 2] = [
    Field::at(Kind::AvgInterval, 0),
    Field::at(Kind::AvgInterval, 1),
];
const OFFSETS: [Field; 2] = [
    Field::at(Kind::ZeroOffset, 0),
    Field::at(Kind::ZeroOffset, 1),
];
const STATUS: [Field; 2] = [Field::at(Kind::Status, 0), Field::at(Kind::Status, 1)];
const SENSORS: [Field; 2] = [
    Field::at(Kind::SensorType, 0),
    Field::at(Kind::SensorType, 1),
];
const SENSOR1: [Field; 1] = [Field::at(Kind::SensorType, 0)];
const SENSOR2: [Field; 1] = [Field::at(Kind::SensorType, 1)];
const SC: Fmt = Fmt::SensorConfig;

static COMMANDS: &[Command] = &[
    Command::get("GTS", &["GET TEMPS", "GETTEMPS"], &VALID, R),
    Command::get("GT", &["GET TEMP"], &[Field::x(Kind::Temp(Temp::Valid))], R).xs(1, 2),
    Command::get("GRTS", &["GET REAL TEMPS"], &REAL, R),
    Command::get(
        "GRT",
        &["GET REAL TEMP"],
        &[Field::x(Kind::Temp(Temp::Real))],
        R,
    )
    .xs(1, 2),
    Command::get("GATS", &["GET AVG TEMPS"], &AVG, R),
    Command::get(
        "GAT",
        &["GET AVG TEMP"],
        &[Field::x(Kind::Temp(Temp::Avg))],
        R,
    )
    .xs(1, 2),
    Command::get("GAIS", &["GET AVG INTERVALS"], &INTERVALS, P),
    Command::get(
        "GAI",
        &["GET AVG INTERVAL"],
        &[Field::x(Kind::AvgInterval)],
        P,
    )
    .xs(1, 2),
    Command::set("SAIS", &["SET AVG INTERVALS"], &INTERVALS),
    Command::set("SAI", &["SET AVG INTERVAL"], &[Field::x(Kind::AvgInterval)]).xs(1, 2),
    Command::get("GOTS", &["GET OFFSET TEMPS"], &OFFSETS, R),
    Command::get(
        "GOT",
        &["GET OFFSET TEMP"],
        &[Field::x(Kind::ZeroOffset)],
        R,
    )
    .xs(1, 2),
    Command::set("SOTS", &["SET OFFSET TEMPS"], &OFFSETS),
    Command::set("SOT", &["SET OFFSET TEMP"], &[Field::x(Kind::ZeroOffset)]).xs(1, 2),
    Command::get(
        "GSCS",
        &["GET SENSOR CONFIGS", "GETSENSORCONFIGS"],
        &SENSORS,
        SC,
    )
    .reply("CSCS"),
    Command::get(
        "GSC1",
        &["GET SENSOR CONFIG1", "GETSENSORCONFIG1"],
        &SENSOR1,
        SC,
    )
    .reply("CSC1"),
    Command::get(
        "GSC2",
        &["GET SENSOR CONFIG2", "GETSENSORCONFIG2"],
        &SENSOR2,
        SC,
    )
    .reply("CSC2"),
    Command::set_sensor_config(
        "SSCS",
        &["SET SENSOR CONFIGS", "SETSENSORCONFIGS"],
        &SENSORS,
    ),
    Command::set_sensor_config(
        "SSC1",
        &["SET SENSOR CONFIG1", "SETSENSORCONFIG1"],
        &SENSOR1,
    ),
    Command::set_sensor_config(
        "SSC2",
        &["SET SENSOR CONFIG2", "SETSENSORCONFIG2"],
        &SENSOR2,
    ),
    Command::get("GSS", &["GET SENSOR STATUS"], &STATUS, P),
    Command::get("GSS", &["GET SENSOR STATUS"], &[Field::x(Kind::Status)], P).xs(1, 2),
];

static POINTS: &[crate::point::PointSpec] = points![
    "CH" [1 2] "_VALID_TEMP": F32 Input
        "last valid temperature in the channel's unit (4x00301 FLOAT32; SINT16 4x00001; ASCII \
         GTx, L7336)";
    "CH" [1 2] "_REAL_TEMP": F32 Input
        "last measured temperature, -999.0 when invalid (4x00305; ASCII GRTx; set on the \
         simulator)";
    "CH" [1 2] "_AVG_TEMP": F32 Input "last average temperature (4x00309; ASCII GATx)";
    "CH" [1 2] "_STATUS": I32 Input
        "measurement status: bit 0 valid, 1 ADC out of range, 2 under range, 3 over range, 7 \
         hard fault (4x00007; ASCII GSSx, L6914)";
    "CH" [1 2] "_AVG_SUM": F32 Input "running sum of the average, °C (4x00901 DOUBLE64)";
    "CH" [1 2] "_AVG_COUNT": I32 Input "values in the running average (4x00913 UINT32)";
    "CH" [1 2] "_SENSOR_TYPE": U16 ReadWrite
        "TYPE bits 0..3, CURRENT 4..7, LINEARISATION 8..11, UNIT 12..15; valid after a reboot \
         (4x06021 / 4x06041, L8707)";
    "CH" [1 2] "_ZERO_OFFSET": F32 ReadWrite
        "zero offset, °C; valid after a reboot (4x06022 / 4x06042 SINT32I × 100000; ASCII \
         SOTx, L8750)";
    "CH" [1 2] "_AVG_INTERVAL": I32 ReadWrite
        "averaging time span, s; valid after a reboot (4x06024 / 4x06044; ASCII SAIx, L8768)";
];

/// The model.
pub(crate) static MODEL: Model = Model {
    name: "resi-2rtd",
    type_name: "RESI-2RTD-ASCII",
    copyright: "2016 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC",
    version: "3.0.0",
    series: Series::Slim,
    map: Map(MAP),
    commands: COMMANDS,
    points: POINTS,
    poll: &[
        "CH1_VALID_TEMP",
        "CH2_VALID_TEMP",
        "CH1_STATUS",
        "CH2_STATUS",
    ],
    one_shot: &[],
    hw: Hardware {
        rtd: 2,
        ..Hardware::NONE
    },
    system_registers: true,
};

crate::devices::resi::catalog_entry!(
    "RESI-2RTD: two RTD channels CH1/CH2 (VALID/REAL/AVG temperatures, STATUS, configuration), \
     register-level simulation; Modbus RTU and RESI ASCII"
);
