//! Typed Modbus PDUs: what a master asks and what a device answers.

use std::fmt;

/// A Modbus slave address for unicast, 1..=247 (validated newtype).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct UnitId(u8);

impl UnitId {
    /// The broadcast address: every device acts, none replies.
    pub const BROADCAST: u8 = 0;

    /// A unit address, if it is in 1..=247.
    pub fn new(addr: u8) -> Option<Self> {
        (1..=247).contains(&addr).then_some(Self(addr))
    }

    /// The address byte.
    pub fn get(self) -> u8 {
        self.0
    }
}

impl fmt::Display for UnitId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// The function codes softplc speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum FunctionCode {
    /// FC 1.
    ReadCoils = 1,
    /// FC 2.
    ReadDiscreteInputs = 2,
    /// FC 3.
    ReadHoldingRegisters = 3,
    /// FC 4.
    ReadInputRegisters = 4,
    /// FC 5.
    WriteSingleCoil = 5,
    /// FC 6.
    WriteSingleRegister = 6,
    /// FC 15.
    WriteMultipleCoils = 15,
    /// FC 16.
    WriteMultipleRegisters = 16,
    /// FC 22.
    MaskWriteRegister = 22,
    /// FC 70, MiniMod's "Collect" (event management).
    Collect = 70,
}

impl FunctionCode {
    /// The code for a byte, if softplc knows it.
    pub fn from_u8(b: u8) -> Option<Self> {
        Some(match b {
            1 => Self::ReadCoils,
            2 => Self::ReadDiscreteInputs,
            3 => Self::ReadHoldingRegisters,
            4 => Self::ReadInputRegisters,
            5 => Self::WriteSingleCoil,
            6 => Self::WriteSingleRegister,
            15 => Self::WriteMultipleCoils,
            16 => Self::WriteMultipleRegisters,
            22 => Self::MaskWriteRegister,
            70 => Self::Collect,
            _ => return None,
        })
    }

    /// The byte on the wire.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// The largest quantity one request of this function may carry (Modbus Application
    /// Protocol v1.1b3, §6: 2000 bits read, 125 registers read, 1968 coils written, 123
    /// registers written), for the functions that carry a quantity; `None` otherwise.
    pub fn max_quantity(self) -> Option<u16> {
        match self {
            Self::ReadCoils | Self::ReadDiscreteInputs => Some(2000),
            Self::ReadHoldingRegisters | Self::ReadInputRegisters => Some(125),
            Self::WriteMultipleCoils => Some(1968),
            Self::WriteMultipleRegisters => Some(123),
            Self::WriteSingleCoil
            | Self::WriteSingleRegister
            | Self::MaskWriteRegister
            | Self::Collect => None,
        }
    }
}

/// A Modbus exception code, as a device returns it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ExceptionCode {
    /// 01: the function is not supported.
    IllegalFunction,
    /// 02: the address (or address + count) is outside the map.
    IllegalDataAddress,
    /// 03: a value (or a count) is not acceptable.
    IllegalDataValue,
    /// 04: the device failed while acting.
    ServerDeviceFailure,
    /// Any other code, kept as it came.
    Other(u8),
}

impl ExceptionCode {
    /// The code byte.
    pub fn code(self) -> u8 {
        match self {
            Self::IllegalFunction => 1,
            Self::IllegalDataAddress => 2,
            Self::IllegalDataValue => 3,
            Self::ServerDeviceFailure => 4,
            Self::Other(c) => c,
        }
    }

    /// The exception for a code byte.
    pub fn from_u8(c: u8) -> Self {
        match c {
            1 => Self::IllegalFunction,
            2 => Self::IllegalDataAddress,
            3 => Self::IllegalDataValue,
            4 => Self::ServerDeviceFailure,
            c => Self::Other(c),
        }
    }
}

impl fmt::Display for ExceptionCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Self::IllegalFunction => "illegal function",
            Self::IllegalDataAddress => "illegal data address",
            Self::IllegalDataValue => "illegal data value",
            Self::ServerDeviceFailure => "server device failure",
            Self::Other(_) => "exception",
        };
        write!(f, "{name} ({:02})", self.code())
    }
}

/// A request PDU (function code and data; no address, no CRC). Addresses are 0-based.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// FC 1: `count` coils from `addr`.
    ReadCoils {
        /// First coil, 0-based.
        addr: u16,
        /// How many coils (1..=2000 on the wire).
        count: u16,
    },
    /// FC 2: `count` discrete inputs from `addr`.
    ReadDiscreteInputs {
        /// First discrete input, 0-based.
        addr: u16,
        /// How many inputs (1..=2000 on the wire).
        count: u16,
    },
    /// FC 3: `count` holding registers from `addr`.
    ReadHoldingRegisters {
        /// First holding register, 0-based.
        addr: u16,
        /// How many registers (1..=125 on the wire).
        count: u16,
    },
    /// FC 4: `count` input registers from `addr`.
    ReadInputRegisters {
        /// First input register, 0-based.
        addr: u16,
        /// How many registers (1..=125 on the wire).
        count: u16,
    },
    /// FC 5.
    WriteSingleCoil {
        /// The coil, 0-based.
        addr: u16,
        /// On is sent as `FF 00`, off as `00 00`.
        value: bool,
    },
    /// FC 6.
    WriteSingleRegister {
        /// The holding register, 0-based.
        addr: u16,
        /// The value written.
        value: u16,
    },
    /// FC 15.
    WriteMultipleCoils {
        /// First coil, 0-based.
        addr: u16,
        /// One value per coil from `addr` on; the count sent is its length.
        values: Vec<bool>,
    },
    /// FC 16.
    WriteMultipleRegisters {
        /// First holding register, 0-based.
        addr: u16,
        /// One value per register from `addr` on; the count sent is its length.
        values: Vec<u16>,
    },
    /// FC 22: register := (register AND and_mask) OR (or_mask AND NOT and_mask).
    MaskWriteRegister {
        /// The holding register, 0-based.
        addr: u16,
        /// Bits set here keep the register's current value.
        and_mask: u16,
        /// Bits taken where `and_mask` is clear.
        or_mask: u16,
    },
    /// FC 70 (MiniMod): `FIRST LAST SLVACK SLVSEQ` (MiniMod manual, "The Modbus function
    /// Collect").
    Collect {
        /// FIRST: lowest slave address allowed to reply in this window.
        first: u8,
        /// LAST: highest slave address allowed to reply; each slave gets 3 ms in turn.
        last: u8,
        /// SLVACK: the slave whose last reply this Collect acknowledges (0: none).
        slave_ack: u8,
        /// SLVSEQ: the sequence number of the reply acknowledged (0: none).
        slave_seq: u8,
    },
}

impl Request {
    /// The function code of this request.
    pub fn function(&self) -> FunctionCode {
        match self {
            Request::ReadCoils { .. } => FunctionCode::ReadCoils,
            Request::ReadDiscreteInputs { .. } => FunctionCode::ReadDiscreteInputs,
            Request::ReadHoldingRegisters { .. } => FunctionCode::ReadHoldingRegisters,
            Request::ReadInputRegisters { .. } => FunctionCode::ReadInputRegisters,
            Request::WriteSingleCoil { .. } => FunctionCode::WriteSingleCoil,
            Request::WriteSingleRegister { .. } => FunctionCode::WriteSingleRegister,
            Request::WriteMultipleCoils { .. } => FunctionCode::WriteMultipleCoils,
            Request::WriteMultipleRegisters { .. } => FunctionCode::WriteMultipleRegisters,
            Request::MaskWriteRegister { .. } => FunctionCode::MaskWriteRegister,
            Request::Collect { .. } => FunctionCode::Collect,
        }
    }
}

/// A response PDU, decoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Response {
    /// FC 1: exactly the requested number of coils (padding bits dropped).
    ReadCoils(Vec<bool>),
    /// FC 2.
    ReadDiscreteInputs(Vec<bool>),
    /// FC 3.
    ReadHoldingRegisters(Vec<u16>),
    /// FC 4.
    ReadInputRegisters(Vec<u16>),
    /// FC 5 echo.
    WriteSingleCoil {
        /// The coil written, 0-based.
        addr: u16,
        /// The state the device echoed.
        value: bool,
    },
    /// FC 6 echo.
    WriteSingleRegister {
        /// The holding register written, 0-based.
        addr: u16,
        /// The value the device echoed.
        value: u16,
    },
    /// FC 15: address and quantity written.
    WriteMultipleCoils {
        /// First coil written, 0-based.
        addr: u16,
        /// How many coils the device says it wrote.
        count: u16,
    },
    /// FC 16: address and quantity written.
    WriteMultipleRegisters {
        /// First holding register written, 0-based.
        addr: u16,
        /// How many registers the device says it wrote.
        count: u16,
    },
    /// FC 22 echo.
    MaskWriteRegister {
        /// The holding register masked, 0-based.
        addr: u16,
        /// The AND mask the device echoed.
        and_mask: u16,
        /// The OR mask the device echoed.
        or_mask: u16,
    },
    /// FC 70 reply: `SLAVE 70 SLVSEQ TYPE DATH DATL 0` (MiniMod manual, "The Modbus function
    /// Collect").
    Collect {
        /// SLAVE: the frame's address, the device that answered inside the Collect window.
        slave: u8,
        /// SLVSEQ: the event's sequence number, echoed back in the acknowledging Collect.
        seq: u8,
        /// TYPE: 2 = inputs, 1 = outputs.
        kind: u8,
        /// `DATH DATL`: the 16-bit mask of the inputs or outputs stored as the event.
        data: u16,
    },
    /// The device said no.
    Exception {
        /// The request's function code, without the 0x80 exception bit.
        function: u8,
        /// Why the device refused.
        code: ExceptionCode,
    },
}
