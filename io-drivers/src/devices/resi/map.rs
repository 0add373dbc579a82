//! The register-map mechanism shared by every RESI model: a model's map is a table of
//! [`Block`]s, each a run of like values written as in the manual's tables (`RISE DI1..16` at
//! 4x00001 every 2 registers, `COUNTER RO1..8` as UINT32 from 4x00201), and the simulator and
//! the driver both read it.
//!
//! Conventions of every RESI chapter (e.g. 10.14, L19944–L19957, L20289–L20302):
//! - one **bit table**, written `0x00001` (coil) and `1x00001` (the same bit as a discrete
//!   input): FC 1 and FC 2 read it, FC 5 and FC 15 write it;
//! - one **register table**, written `4x00001` (holding) and `3x00001` (the same register as
//!   an input register): FC 3 and FC 4 read it, FC 6 and FC 16 write it;
//! - the manual's references are **1-based** (`4x20001`); the protocol address is one less
//!   (`I:20000` in the manual). A [`Block`] is written with the reference; [`Entry::addr`]
//!   gives the protocol address.
//!
//! Names are the manual's register names with spaces written `_` (`RISE DI1` → `RISE_DI1`,
//! `ENABLE LOGIC FUNCTIONS` → `ENABLE_LOGIC_FUNCTIONS`), so they work as point names in
//! project files and on `softplc sim`'s standard input. A value with two word orders has two
//! blocks with the same names; the first one listed is the one a point reads.

use super::item::{Item, Kind};
use super::value::Enc;

/// One of the two tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Table {
    /// Coils / discrete inputs (`0x` / `1x`), FC 1, 2, 5, 15.
    Bits,
    /// Holding / input registers (`4x` / `3x`), FC 3, 4, 6, 16.
    Registers,
}

impl Table {
    /// The manual's prefix: `0x` or `4x`.
    pub const fn prefix(self) -> &'static str {
        match self {
            Table::Bits => "0x",
            Table::Registers => "4x",
        }
    }
}

/// Who may access an address, as the manual's R/W column says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Acc {
    /// `R/O`.
    ReadOnly,
    /// `R/W`.
    ReadWrite,
    /// `W/O` or a command register that "while reading always" gives 0 (RESET COUNTER,
    /// CLEAR ALL LOGIC FUNCTIONS, RESET SYSTEM).
    WriteOnly,
}

/// A run of like values in one table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Block {
    /// The names, one per value (see the module docs).
    pub names: &'static [&'static str],
    /// The table.
    pub table: Table,
    /// The manual's 1-based reference of the first value.
    pub first: u32,
    /// References from one value to the next (2 for interleaved `RISE`/`FALL` counters).
    pub stride: u16,
    /// What the values are.
    pub kind: Kind,
    /// The item index of the first value (`DIS17..32` is [`Kind::DisWord`] index 1).
    pub base: u8,
    /// How each value is encoded.
    pub enc: Enc,
    /// Access.
    pub access: Acc,
    /// Where the manual documents it (`L20311`).
    pub cite: &'static str,
}

impl Block {
    /// Values in the bit table, one reference apart.
    pub const fn bits(names: &'static [&'static str], first: u32, kind: Kind, access: Acc) -> Self {
        Self {
            names,
            table: Table::Bits,
            first,
            stride: 1,
            kind,
            base: 0,
            enc: Enc::Bit,
            access,
            cite: "",
        }
    }

    /// Values in the register table, back to back.
    pub const fn regs(
        names: &'static [&'static str],
        first: u32,
        kind: Kind,
        enc: Enc,
        access: Acc,
    ) -> Self {
        Self {
            names,
            table: Table::Registers,
            first,
            stride: enc.words(),
            kind,
            base: 0,
            enc,
            access,
            cite: "",
        }
    }

    /// The same with another distance between values.
    pub const fn stride(mut self, stride: u16) -> Self {
        self.stride = stride;
        self
    }

    /// The same with another first index.
    pub const fn base(mut self, base: u8) -> Self {
        self.base = base;
        self
    }

    /// The same with its source in the manual.
    pub const fn cite(mut self, cite: &'static str) -> Self {
        self.cite = cite;
        self
    }

    /// The `i`th value of the block.
    fn entry(&self, i: usize) -> Option<Entry> {
        let name = *self.names.get(i)?;
        let offset = u32::try_from(i).ok()? * u32::from(self.stride);
        Some(Entry {
            name,
            table: self.table,
            reference: self.first + offset,
            item: Item::new(self.kind, self.base.wrapping_add(i as u8)),
            enc: self.enc,
            access: self.access,
            cite: self.cite,
        })
    }
}

/// One value of a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// The name.
    pub name: &'static str,
    /// The table.
    pub table: Table,
    /// The manual's 1-based reference of its first address.
    pub reference: u32,
    /// What it reaches.
    pub item: Item,
    /// How it is encoded.
    pub enc: Enc,
    /// Access.
    pub access: Acc,
    /// Where the manual documents it.
    pub cite: &'static str,
}

impl Entry {
    /// The 0-based protocol address of its first word (reference − 1).
    pub fn addr(&self) -> u16 {
        u16::try_from(self.reference.saturating_sub(1)).unwrap_or(u16::MAX)
    }

    /// Addresses it takes.
    pub fn words(&self) -> u16 {
        self.enc.words()
    }

    /// Whether the protocol address `addr` is one of its words; which one.
    fn word_at(&self, addr: u16) -> Option<usize> {
        let start = u32::from(self.addr());
        let a = u32::from(addr);
        (a >= start && a < start + u32::from(self.words())).then(|| (a - start) as usize)
    }

    /// The manual's notation: `4x20001`, `0x00017`.
    pub fn notation(&self) -> String {
        format!("{}{:05}", self.table.prefix(), self.reference)
    }
}

/// A model's register map.
#[derive(Debug, Clone, Copy)]
pub struct Map(pub &'static [Block]);

impl Map {
    /// Every value, block by block.
    pub fn entries(self) -> impl Iterator<Item = Entry> {
        self.0
            .iter()
            .flat_map(|b| (0..b.names.len()).filter_map(move |i| b.entry(i)))
    }

    /// The value a protocol address belongs to, and the word of it; `None` for an address the
    /// manual does not document.
    pub fn lookup(self, table: Table, addr: u16) -> Option<(Entry, usize)> {
        self.0.iter().filter(|b| b.table == table).find_map(|b| {
            let offset = u32::from(addr).checked_sub(b.first.checked_sub(1)?)?;
            let i = usize::try_from(offset / u32::from(b.stride.max(1))).ok()?;
            let e = b.entry(i)?;
            e.word_at(addr).map(|w| (e, w))
        })
    }

    /// The first value named `name`.
    pub fn by_name(self, name: &str) -> Option<Entry> {
        self.entries().find(|e| e.name == name)
    }

    /// The first value that reaches `item`.
    pub fn by_item(self, item: Item) -> Option<Entry> {
        self.entries().find(|e| e.item == item)
    }
}

/// Names of a numbered run: `names!("RISE_DI" [1 2 3])` is `&["RISE_DI1", "RISE_DI2",
/// "RISE_DI3"]`; an optional suffix follows the numbers.
macro_rules! names {
    ($prefix:literal [$($n:literal)*] $suffix:literal) => {
        &[$(concat!($prefix, $n, $suffix)),*]
    };
    ($prefix:literal [$($n:literal)*]) => {
        &[$(concat!($prefix, $n)),*]
    };
}
pub(crate) use names;

/// A point table: each line is `"PREFIX" [numbers] "SUFFIX": Type Access "doc";` and gives
/// one point per number (write `[""]` for a single point).
macro_rules! points {
    ($($prefix:literal [$($n:literal)*] $suffix:literal : $ty:ident $acc:ident $doc:literal;)*) => {
        &[$($($crate::point::PointSpec {
            name: concat!($prefix, $n, $suffix),
            ty: $crate::point::ValueType::$ty,
            access: $crate::point::Access::$acc,
            doc: $doc,
        },)*)*]
    };
}
pub(crate) use points;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::resi::value::WordOrder;

    static MAP: &[Block] = &[
        Block::bits(names!("DI" [1 2 3]), 1, Kind::Di, Acc::ReadOnly),
        Block::regs(
            names!("RISE_DI" [1 2 3]),
            1,
            Kind::Rise,
            Enc::U16,
            Acc::ReadOnly,
        )
        .stride(2),
        Block::regs(
            names!("FALL_DI" [1 2 3]),
            2,
            Kind::Fall,
            Enc::U16,
            Acc::ReadOnly,
        )
        .stride(2),
        Block::regs(
            names!("COUNTER_RO" [1 2]),
            201,
            Kind::RoCounter,
            Enc::U32(WordOrder::HighFirst),
            Acc::ReadOnly,
        ),
    ];

    #[test]
    fn references_are_one_based() {
        let m = Map(MAP);
        let (e, w) = m.lookup(Table::Registers, 3).unwrap();
        assert_eq!(
            (e.name, w, e.item),
            ("FALL_DI2", 0, Item::new(Kind::Fall, 1))
        );
        let (e, w) = m.lookup(Table::Registers, 201).unwrap();
        assert_eq!((e.name, w, e.reference), ("COUNTER_RO1", 1, 201));
        assert_eq!(e.notation(), "4x00201");
        assert_eq!(m.lookup(Table::Registers, 6), None, "RISE/FALL stop at DI3");
        assert_eq!(m.lookup(Table::Registers, 204), None);
        assert_eq!(m.lookup(Table::Bits, 2).map(|(e, _)| e.name), Some("DI3"));
        assert_eq!(m.lookup(Table::Bits, 3), None);
        assert_eq!(m.by_name("COUNTER_RO2").map(|e| e.addr()), Some(202));
        assert_eq!(m.entries().count(), 11);
    }
}
