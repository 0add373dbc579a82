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
    ReadCoils { addr: u16, count: u16 },
    /// FC 2: `count` discrete inputs from `addr`.
    ReadDiscreteInputs { addr: u16, count: u16 },
    /// FC 3: `count` holding registers from `addr`.
    ReadHoldingRegisters { addr: u16, count: u16 },
    /// FC 4: `count` input registers from `addr`.
    ReadInputRegisters { addr: u16, count: u16 },
    /// FC 5.
    WriteSingleCoil { addr: u16, value: bool },
    /// FC 6.
    WriteSingleRegister { addr: u16, value: u16 },
    /// FC 15.
    WriteMultipleCoils { addr: u16, values: Vec<bool> },
    /// FC 16.
    WriteMultipleRegisters { addr: u16, values: Vec<u16> },
    /// FC 22: register := (register AND and_mask) OR (or_mask AND NOT and_mask).
    MaskWriteRegister {
        addr: u16,
        and_mask: u16,
        or_mask: u16,
    },
    /// FC 70 (MiniMod): `FIRST LAST SLVACK SLVSEQ`.
    Collect {
        first: u8,
        last: u8,
        slave_ack: u8,
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
    WriteSingleCoil { addr: u16, value: bool },
    /// FC 6 echo.
    WriteSingleRegister { addr: u16, value: u16 },
    /// FC 15: address and quantity written.
    WriteMultipleCoils { addr: u16, count: u16 },
    /// FC 16: address and quantity written.
    WriteMultipleRegisters { addr: u16, count: u16 },
    /// FC 22 echo.
    MaskWriteRegister {
        addr: u16,
        and_mask: u16,
        or_mask: u16,
    },
    /// FC 70 reply: `SLAVE 70 SLVSEQ TYPE DATH DATL 0`. `slave` is the frame's address (the
    /// device that answered inside the Collect window); `kind` is TYPE (2 = inputs,
    /// 1 = outputs); `data` is `DATH DATL`.
    Collect {
        slave: u8,
        seq: u8,
        kind: u8,
        data: u16,
    },
    /// The device said no.
    Exception { function: u8, code: ExceptionCode },
}
