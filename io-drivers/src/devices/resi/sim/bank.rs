//! The Modbus view of a simulated RESI module: the model's map over the module state, through
//! [`RegisterBank`].
//!
//! The manual documents no exception (resi-spec §7); the simulator answers:
//! - 01 ILLEGAL FUNCTION for a function the chapter does not list (FC 22, FC 70, others);
//! - 02 ILLEGAL DATA ADDRESS for an address the map does not document (or read 0 / ignore the
//!   write with the option `undocumented zero`), and for a write to an `R/O` address;
//! - 03 ILLEGAL DATA VALUE for a value the item cannot take (an LED set point above 4095);
//!   quantities and FC 5 values are checked by the codec ([`crate::modbus::server`]).
//!
//! Values wider than one register are written word by word: a write of one half of a 32-bit
//! value changes that half at once (resi-spec §3.4), so an FC 16 over both halves stores the
//! whole value. `W/O` addresses and command registers read 0 ("While reading always 0",
//! L20285).

use crate::devices::resi::item::{Item, Kind};
use crate::devices::resi::map::{Acc, Block, Map, Table};
use crate::devices::resi::state::{AccessError, Module};
use crate::devices::resi::value::{Enc, Num};
use crate::modbus::server::RegisterBank;
use crate::modbus::ExceptionCode;

/// RESET SYSTEM and MODBUS UNIT ADDRESS, as the slim modules and the 4LED document them
/// (L4305–L4323), served on the other models with the option `system-registers on`.
static SYSTEM: &[Block] = &[
    Block::regs(
        &["RESET_SYSTEM"],
        6001,
        Kind::ResetSystem,
        Enc::U16,
        Acc::WriteOnly,
    ),
    Block::regs(
        &["MODBUS_UNIT_ADDRESS"],
        65222,
        Kind::UnitAddress,
        Enc::U16,
        Acc::ReadWrite,
    ),
];

/// A module seen through its register map.
#[derive(Debug)]
pub(crate) struct Bank<'a> {
    m: &'a mut Module,
}

impl<'a> Bank<'a> {
    /// The bank of `m`.
    pub(crate) fn new(m: &'a mut Module) -> Self {
        Self { m }
    }

    fn find(&self, table: Table, addr: u16) -> Option<(Item, Enc, Acc, usize)> {
        let found = self.m.model().map.lookup(table, addr).or_else(|| {
            self.m
                .opts
                .system_registers
                .then(|| Map(SYSTEM).lookup(table, addr))
                .flatten()
        });
        found.map(|(e, w)| (e.item, e.enc, e.access, w))
    }

    fn read(&self, table: Table, addr: u16) -> Result<u16, ExceptionCode> {
        let Some((item, enc, access, word)) = self.find(table, addr) else {
            return if self.m.opts.strict_addresses {
                Err(ExceptionCode::IllegalDataAddress)
            } else {
                Ok(0)
            };
        };
        if access == Acc::WriteOnly {
            return Ok(0);
        }
        let value = self.m.read(item).map_err(exception)?;
        Ok(enc.word(value, word))
    }

    fn write(&mut self, table: Table, addr: u16, word: u16) -> Result<(), ExceptionCode> {
        let Some((item, enc, access, i)) = self.find(table, addr) else {
            return if self.m.opts.strict_addresses {
                Err(ExceptionCode::IllegalDataAddress)
            } else {
                Ok(())
            };
        };
        if access == Acc::ReadOnly {
            return Err(ExceptionCode::IllegalDataAddress);
        }
        let value = if enc.words() == 1 {
            enc.decode(&[word]).unwrap_or(Num::Int(0))
        } else {
            let current = self.m.read(item).map_err(exception)?;
            enc.with_word(current, i, word)
        };
        self.m.write(item, value).map_err(exception)
    }
}

fn exception(e: AccessError) -> ExceptionCode {
    match e {
        AccessError::Absent | AccessError::ReadOnly => ExceptionCode::IllegalDataAddress,
        AccessError::OutOfRange => ExceptionCode::IllegalDataValue,
    }
}

/// FC 1/2 read the same bit table, FC 3/4 the same register table (L19949, L20294).
impl RegisterBank for Bank<'_> {
    fn read_coil(&self, addr: u16) -> Result<bool, ExceptionCode> {
        self.read(Table::Bits, addr).map(|v| v != 0)
    }

    fn read_discrete_input(&self, addr: u16) -> Result<bool, ExceptionCode> {
        self.read(Table::Bits, addr).map(|v| v != 0)
    }

    fn read_holding_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        self.read(Table::Registers, addr)
    }

    fn read_input_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        self.read(Table::Registers, addr)
    }

    fn write_coil(&mut self, addr: u16, value: bool) -> Result<(), ExceptionCode> {
        self.write(Table::Bits, addr, u16::from(value))
    }

    fn write_holding_register(&mut self, addr: u16, value: u16) -> Result<(), ExceptionCode> {
        self.write(Table::Registers, addr, value)
    }
}
