//! The SCADA map at run time: which tag a Modbus address reads or writes, and the encoding of
//! values into bits and registers. Pure (no I/O, no locks), so every request can be checked
//! against it, fuzzed and unit-tested.
//!
//! Addresses are protocol addresses (0-based; `mbpoll -0`). The map itself is built by the
//! project's validation (`project/scada.rs`, which documents how addresses are assigned).
//!
//! | space | tags | read with | write with |
//! |---|---|---|---|
//! | bits | bool | FC 1 (coils), FC 2 (discrete inputs) | FC 5, FC 15 (writable tags) |
//! | registers | u16 (1 register), i32 and f32 (2, high word first) | FC 3 (holding), FC 4 (input) | FC 6, FC 16 (writable tags) |
//!
//! A read must cover mapped addresses only, a write whole writable tags only.

use softplc_io::point::{Value, ValueType};

use crate::image::convert;
use crate::project::{ReadGaps, ScadaMap, Space};

/// Most bits one read returns (FC 1, 2: the spec's 2000).
pub(crate) const MAX_READ_BITS: u16 = 2000;
/// Most registers one read returns (FC 3, 4: 125).
pub(crate) const MAX_READ_REGISTERS: u16 = 125;
/// Most coils one write sets (FC 15: 1968).
pub(crate) const MAX_WRITE_BITS: usize = 1968;
/// Most registers one write sets (FC 16: 123).
pub(crate) const MAX_WRITE_REGISTERS: usize = 123;

/// A Modbus exception the server answers with (the protocol's codes; see docs/plant-services.md "SCADA and
/// metrics").
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum Exception {
    /// 01: a function this server does not implement, or a write while `writes: false`.
    #[error("illegal function (01)")]
    IllegalFunction,
    /// 02: an address no tag occupies, a read-only tag written, or part of a two-register tag
    /// written.
    #[error("illegal data address (02)")]
    IllegalDataAddress,
    /// 03: a quantity out of the protocol's range, or a float that is not finite.
    #[error("illegal data value (03)")]
    IllegalDataValue,
    /// 04: the scan refused the write (a forced tag) or did not apply it in time.
    #[error("server device failure (04)")]
    ServerDeviceFailure,
    /// 06: the scan has not published a snapshot yet.
    #[error("server device busy (06)")]
    ServerDeviceBusy,
    /// 0B: a unit identifier this server does not answer for.
    #[error("gateway target device failed to respond (0B)")]
    GatewayTargetFailed,
}

impl Exception {
    /// The exception code on the wire.
    pub(crate) fn code(self) -> u8 {
        match self {
            Exception::IllegalFunction => 0x01,
            Exception::IllegalDataAddress => 0x02,
            Exception::IllegalDataValue => 0x03,
            Exception::ServerDeviceFailure => 0x04,
            Exception::ServerDeviceBusy => 0x06,
            Exception::GatewayTargetFailed => 0x0B,
        }
    }
}

/// One exposed tag at run time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Slot {
    address: u16,
    width: u16,
    tag: usize,
    ty: ValueType,
    writable: bool,
}

impl Slot {
    fn last(&self) -> u32 {
        u32::from(self.address) + u32::from(self.width) - 1
    }
}

/// The map, indexed for lookups by address.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct ModbusMap {
    /// Bool tags, by address.
    bits: Vec<Slot>,
    /// Numeric tags, by address.
    registers: Vec<Slot>,
    /// Addresses no tag holds read 0 in a read that holds a tag (`read_gaps: zero`).
    zero_gaps: bool,
}

impl ModbusMap {
    /// Indexes `map`.
    pub(crate) fn new(map: &ScadaMap) -> Self {
        let mut m = Self::default();
        for e in &map.entries {
            let slot = Slot {
                address: e.address,
                width: e.width.max(1),
                tag: e.tag,
                ty: e.ty,
                writable: e.writable,
            };
            match e.space {
                Space::Bits => m.bits.push(slot),
                Space::Registers => m.registers.push(slot),
            }
        }
        m.bits.sort_by_key(|s| s.address);
        m.registers.sort_by_key(|s| s.address);
        m
    }

    /// With `read_gaps` `zero`: a read that holds a tag answers 0 for the addresses between.
    pub(crate) fn with_read_gaps(mut self, gaps: ReadGaps) -> Self {
        self.zero_gaps = gaps == ReadGaps::Zero;
        self
    }

    /// Whether a read of `range` answers 0 for an address no slot holds: gaps read as zero,
    /// and a tag somewhere in the range (a read of nothing at all is still refused).
    fn gap_reads_zero(&self, slots: &[Slot], range: &std::ops::Range<u32>) -> bool {
        self.zero_gaps
            && slots
                .iter()
                .any(|s| u32::from(s.address) < range.end && s.last() >= range.start)
    }

    /// The slot holding `address`.
    fn find(slots: &[Slot], address: u32) -> Option<&Slot> {
        let i = slots.partition_point(|s| u32::from(s.address) <= address);
        slots.get(i.checked_sub(1)?).filter(|s| address <= s.last())
    }

    /// The range `start .. start + qty`, or 02 when it leaves the address space.
    fn range(start: u16, qty: usize) -> Result<std::ops::Range<u32>, Exception> {
        let end = u32::from(start) + u32::try_from(qty).map_err(|_| Exception::IllegalDataValue)?;
        if end > 0x1_0000 {
            return Err(Exception::IllegalDataAddress);
        }
        Ok(u32::from(start)..end)
    }

    /// FC 1 and 2: the bits `start .. start + qty`, from `values` (tag values in tag order).
    pub(crate) fn read_bits(
        &self,
        start: u16,
        qty: u16,
        values: &[Value],
    ) -> Result<Vec<bool>, Exception> {
        if qty == 0 || qty > MAX_READ_BITS {
            return Err(Exception::IllegalDataValue);
        }
        let range = Self::range(start, usize::from(qty))?;
        let zero = self.gap_reads_zero(&self.bits, &range);
        range
            .map(|a| {
                let Some(slot) = Self::find(&self.bits, a) else {
                    return if zero {
                        Ok(false)
                    } else {
                        Err(Exception::IllegalDataAddress)
                    };
                };
                let v = values.get(slot.tag).ok_or(Exception::ServerDeviceFailure)?;
                Ok(v.as_bool())
            })
            .collect()
    }

    /// FC 3 and 4: the registers `start .. start + qty`, from `values`.
    pub(crate) fn read_registers(
        &self,
        start: u16,
        qty: u16,
        values: &[Value],
    ) -> Result<Vec<u16>, Exception> {
        if qty == 0 || qty > MAX_READ_REGISTERS {
            return Err(Exception::IllegalDataValue);
        }
        let range = Self::range(start, usize::from(qty))?;
        let zero = self.gap_reads_zero(&self.registers, &range);
        range
            .map(|a| {
                let Some(slot) = Self::find(&self.registers, a) else {
                    return if zero {
                        Ok(0)
                    } else {
                        Err(Exception::IllegalDataAddress)
                    };
                };
                let v = values.get(slot.tag).ok_or(Exception::ServerDeviceFailure)?;
                let words = encode(convert(*v, slot.ty));
                let k = (a - u32::from(slot.address)) as usize;
                words.get(k).copied().ok_or(Exception::ServerDeviceFailure)
            })
            .collect()
    }

    /// FC 5 and 15: the tag values that writing `bits` from `start` sets. Every bit must be a
    /// writable tag.
    pub(crate) fn write_bits(
        &self,
        start: u16,
        bits: &[bool],
    ) -> Result<Vec<(usize, Value)>, Exception> {
        if bits.is_empty() || bits.len() > MAX_WRITE_BITS {
            return Err(Exception::IllegalDataValue);
        }
        Self::range(start, bits.len())?
            .zip(bits)
            .map(|(a, &b)| match Self::find(&self.bits, a) {
                Some(s) if s.writable => Ok((s.tag, Value::Bool(b))),
                _ => Err(Exception::IllegalDataAddress),
            })
            .collect()
    }

    /// FC 6 and 16: the tag values that writing `words` from `start` sets. The words must
    /// cover whole writable tags.
    pub(crate) fn write_registers(
        &self,
        start: u16,
        words: &[u16],
    ) -> Result<Vec<(usize, Value)>, Exception> {
        if words.is_empty() || words.len() > MAX_WRITE_REGISTERS {
            return Err(Exception::IllegalDataValue);
        }
        let range = Self::range(start, words.len())?;
        let mut out = Vec::new();
        let mut a = range.start;
        while a < range.end {
            let slot = Self::find(&self.registers, a)
                .filter(|s| s.writable && u32::from(s.address) == a && s.last() < range.end)
                .ok_or(Exception::IllegalDataAddress)?;
            let k = (a - range.start) as usize;
            let w = words
                .get(k..k + usize::from(slot.width))
                .ok_or(Exception::IllegalDataAddress)?;
            out.push((slot.tag, decode(slot.ty, w)?));
            a += u32::from(slot.width);
        }
        Ok(out)
    }

    /// Every mapped tag with its space, first address and writability, in address order (for
    /// `softplc check` and the docs).
    pub(crate) fn describe(&self) -> Vec<(Space, u16, u16, usize, bool)> {
        let bits = self.bits.iter().map(|s| (Space::Bits, s));
        let regs = self.registers.iter().map(|s| (Space::Registers, s));
        bits.chain(regs)
            .map(|(sp, s)| (sp, s.address, s.width, s.tag, s.writable))
            .collect()
    }
}

/// A numeric value as registers: u16 as is; i32 and f32 as two registers, high word first.
/// A bool (never in the register space) reads as 0 or 1.
pub(crate) fn encode(v: Value) -> Vec<u16> {
    let split = |x: u32| vec![(x >> 16) as u16, x as u16];
    match v {
        Value::Bool(b) => vec![u16::from(b)],
        Value::U16(x) => vec![x],
        Value::I32(x) => split(x as u32),
        Value::F32(x) => split(x.to_bits()),
    }
}

/// Registers (high word first) as a value of type `ty`; a float that is not finite is refused
/// (03): NaN or infinity is never a sensible setpoint.
pub(crate) fn decode(ty: ValueType, words: &[u16]) -> Result<Value, Exception> {
    let joined = || match words {
        [hi, lo] => Ok((u32::from(*hi) << 16) | u32::from(*lo)),
        _ => Err(Exception::IllegalDataAddress),
    };
    match (ty, words) {
        (ValueType::U16, [w]) => Ok(Value::U16(*w)),
        (ValueType::Bool, [w]) => Ok(Value::Bool(*w != 0)),
        (ValueType::I32, _) => Ok(Value::I32(joined()? as i32)),
        (ValueType::F32, _) => {
            let f = f32::from_bits(joined()?);
            if f.is_finite() {
                Ok(Value::F32(f))
            } else {
                Err(Exception::IllegalDataValue)
            }
        }
        _ => Err(Exception::IllegalDataAddress),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::project::ScadaEntry;

    /// A map entry of `tag` at `address` in the space and width its type takes, not pinned
    /// (the Modbus TCP server's tests build their maps with it too).
    pub(crate) fn entry(tag: usize, ty: ValueType, address: u16, writable: bool) -> ScadaEntry {
        let (space, width) = Space::of(ty);
        ScadaEntry {
            tag,
            ty,
            space,
            address,
            width,
            writable,
            pinned: false,
        }
    }

    /// Tags: 0 run (bool, bit 0, ro), 1 enable (bool, bit 1, rw), 2 speed (u16, reg 0, rw),
    /// 3 count (i32, regs 1-2, ro), 4 level (f32, regs 3-4, rw), 5 gap... (u16 at reg 10, ro).
    fn map() -> (ModbusMap, Vec<Value>) {
        let m = ModbusMap::new(&ScadaMap {
            entries: vec![
                entry(0, ValueType::Bool, 0, false),
                entry(1, ValueType::Bool, 1, true),
                entry(2, ValueType::U16, 0, true),
                entry(3, ValueType::I32, 1, false),
                entry(4, ValueType::F32, 3, true),
                entry(5, ValueType::U16, 10, false),
            ],
        });
        let values = vec![
            Value::Bool(true),
            Value::Bool(false),
            Value::U16(1234),
            Value::I32(-2),
            Value::F32(1.5),
            Value::U16(7),
        ];
        (m, values)
    }

    #[test]
    fn reads_encode_values_high_word_first() {
        let (m, v) = map();
        assert_eq!(m.read_bits(0, 2, &v), Ok(vec![true, false]));
        assert_eq!(
            m.read_registers(0, 5, &v),
            Ok(vec![1234, 0xFFFF, 0xFFFE, 0x3FC0, 0x0000])
        );
        // Half of a two-register tag reads fine.
        assert_eq!(m.read_registers(2, 1, &v), Ok(vec![0xFFFE]));
        assert_eq!(m.read_registers(10, 1, &v), Ok(vec![7]));
    }

    #[test]
    fn reads_refuse_unmapped_addresses_and_bad_quantities() {
        let (m, v) = map();
        assert_eq!(m.read_bits(0, 3, &v), Err(Exception::IllegalDataAddress));
        assert_eq!(
            m.read_registers(4, 2, &v),
            Err(Exception::IllegalDataAddress)
        );
        assert_eq!(m.read_registers(0, 0, &v), Err(Exception::IllegalDataValue));
        assert_eq!(
            m.read_registers(0, 126, &v),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(m.read_bits(0, 2001, &v), Err(Exception::IllegalDataValue));
        assert_eq!(
            m.read_registers(u16::MAX, 2, &v),
            Err(Exception::IllegalDataAddress)
        );
        // A snapshot without the tag (not yet published) is a device failure, not a panic.
        assert_eq!(m.read_bits(0, 1, &[]), Err(Exception::ServerDeviceFailure));
    }

    #[test]
    fn writes_cover_whole_writable_tags() {
        let (m, _) = map();
        assert_eq!(m.write_bits(1, &[true]), Ok(vec![(1, Value::Bool(true))]));
        assert_eq!(m.write_bits(0, &[true]), Err(Exception::IllegalDataAddress));
        assert_eq!(
            m.write_bits(0, &[true, true]),
            Err(Exception::IllegalDataAddress)
        );
        assert_eq!(m.write_registers(0, &[42]), Ok(vec![(2, Value::U16(42))]));
        assert_eq!(
            m.write_registers(3, &[0x4120, 0x0000]),
            Ok(vec![(4, Value::F32(10.0))])
        );
        // Read-only i32 in between: the whole write is refused.
        assert_eq!(
            m.write_registers(0, &[1, 2, 3, 4, 5]),
            Err(Exception::IllegalDataAddress)
        );
        // Half of a float.
        assert_eq!(
            m.write_registers(3, &[0x4120]),
            Err(Exception::IllegalDataAddress)
        );
        assert_eq!(
            m.write_registers(4, &[0]),
            Err(Exception::IllegalDataAddress)
        );
        // NaN.
        assert_eq!(
            m.write_registers(3, &[0x7FC0, 0]),
            Err(Exception::IllegalDataValue)
        );
        assert_eq!(m.write_registers(0, &[]), Err(Exception::IllegalDataValue));
        assert_eq!(
            m.write_registers(u16::MAX, &[1, 2]),
            Err(Exception::IllegalDataAddress)
        );
    }

    #[test]
    fn encode_and_decode_are_inverse() {
        for v in [Value::U16(65535), Value::I32(i32::MIN), Value::F32(-3.25)] {
            assert_eq!(decode(v.value_type(), &encode(v)), Ok(v));
        }
    }

    #[test]
    fn arbitrary_requests_never_panic() {
        let (m, v) = map();
        // A small deterministic sweep over the edges of the address and quantity ranges.
        let edges = [
            0u16, 1, 2, 3, 4, 5, 9, 10, 11, 124, 125, 126, 2000, 2001, 65534, 65535,
        ];
        for &start in &edges {
            for &qty in &edges {
                // Any answer (data or exception) will do; the test is that none panics.
                drop(m.read_bits(start, qty, &v));
                drop(m.read_registers(start, qty, &v));
                let words = vec![0x7F80u16; usize::from(qty.min(200))];
                drop(m.write_registers(start, &words));
                let bits = vec![true; usize::from(qty.min(2000))];
                drop(m.write_bits(start, &bits));
            }
        }
    }
}
