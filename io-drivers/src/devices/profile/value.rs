//! A point's raw encoding: its data type, the order of its words, and the conversion between
//! registers and the typed value a program sees (scale and offset included).

use super::ProfilePoint;
use crate::point::{Value, ValueType};

/// How a point's raw value is encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataType {
    /// A coil or a discrete input.
    Bool,
    /// One register, unsigned.
    U16,
    /// One register, two's complement.
    I16,
    /// Two registers, unsigned.
    U32,
    /// Two registers, two's complement.
    I32,
    /// Two registers, IEEE 754 single.
    F32,
}

impl DataType {
    /// The profile-file name.
    pub fn name(self) -> &'static str {
        match self {
            DataType::Bool => "bool",
            DataType::U16 => "u16",
            DataType::I16 => "i16",
            DataType::U32 => "u32",
            DataType::I32 => "i32",
            DataType::F32 => "f32",
        }
    }

    /// Every type, for errors.
    pub const ALL: [DataType; 6] = [
        DataType::Bool,
        DataType::U16,
        DataType::I16,
        DataType::U32,
        DataType::I32,
        DataType::F32,
    ];

    /// Registers (or bits) the value spans.
    pub fn words(self) -> u16 {
        match self {
            DataType::Bool | DataType::U16 | DataType::I16 => 1,
            DataType::U32 | DataType::I32 | DataType::F32 => 2,
        }
    }
}

/// The order of a 32-bit value's bytes over its two registers, named by where the value's
/// bytes A (most significant) to D go: `ABCD` is Modbus's own big-endian, high word first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WordOrder {
    /// High word first, each word big-endian (the Modbus convention).
    #[default]
    Abcd,
    /// Low word first ("word swap").
    Cdab,
    /// High word first, bytes swapped in each word.
    Badc,
    /// Low word first, bytes swapped.
    Dcba,
}

impl WordOrder {
    /// The profile-file name.
    pub fn name(self) -> &'static str {
        match self {
            WordOrder::Abcd => "ABCD",
            WordOrder::Cdab => "CDAB",
            WordOrder::Badc => "BADC",
            WordOrder::Dcba => "DCBA",
        }
    }

    /// Every order, for errors.
    pub const ALL: [WordOrder; 4] = [
        WordOrder::Abcd,
        WordOrder::Cdab,
        WordOrder::Badc,
        WordOrder::Dcba,
    ];

    /// The 32 bits from the two registers as they come on the wire.
    pub fn join(self, first: u16, second: u16) -> u32 {
        let (hi, lo) = match self {
            WordOrder::Abcd => (first, second),
            WordOrder::Cdab => (second, first),
            WordOrder::Badc => (first.swap_bytes(), second.swap_bytes()),
            WordOrder::Dcba => (second.swap_bytes(), first.swap_bytes()),
        };
        (u32::from(hi) << 16) | u32::from(lo)
    }

    /// The two registers, in wire order, of 32 bits.
    pub fn split(self, bits: u32) -> [u16; 2] {
        let (hi, lo) = ((bits >> 16) as u16, bits as u16);
        match self {
            WordOrder::Abcd => [hi, lo],
            WordOrder::Cdab => [lo, hi],
            WordOrder::Badc => [hi.swap_bytes(), lo.swap_bytes()],
            WordOrder::Dcba => [lo.swap_bytes(), hi.swap_bytes()],
        }
    }
}

/// The raw number of a point's registers (`words` in wire order, as many as its width), and
/// the bits they hold (for bit fields).
pub(crate) fn raw(point: &ProfilePoint, words: &[u16]) -> Option<(f64, u32)> {
    let first = *words.first()?;
    let (n, bits) = match point.data {
        DataType::Bool => (f64::from(u8::from(first != 0)), u32::from(first != 0)),
        DataType::U16 => (f64::from(first), u32::from(first)),
        DataType::I16 => (f64::from(first as i16), u32::from(first)),
        wide => {
            let bits = point.order.join(first, *words.get(1)?);
            let n = match wide {
                DataType::U32 => f64::from(bits),
                DataType::I32 => f64::from(bits as i32),
                _ => f64::from(f32::from_bits(bits)),
            };
            (n, bits)
        }
    };
    Some((n, bits))
}

/// The engineering value of a raw number.
pub(crate) fn engineering(point: &ProfilePoint, raw: f64) -> f64 {
    match point.scaling {
        Some(s) => raw * s.scale + s.offset,
        None => raw,
    }
}

/// The value programs see, of an engineering number.
pub(crate) fn to_value(point: &ProfilePoint, n: f64) -> Value {
    typed(point.value_type(), n)
}

/// `n` as a value of `ty` (integers saturate at the type's range).
pub(crate) fn typed(ty: ValueType, n: f64) -> Value {
    match ty {
        ValueType::Bool => Value::Bool(n != 0.0),
        ValueType::U16 => Value::U16(n.round().clamp(0.0, f64::from(u16::MAX)) as u16),
        ValueType::I32 => {
            Value::I32(n.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32)
        }
        ValueType::F32 => Value::F32(n as f32),
    }
}

/// A value as a number.
pub(crate) fn number(v: Value) -> f64 {
    match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(n) => f64::from(n),
        Value::I32(n) => f64::from(n),
        Value::F32(n) => f64::from(n),
    }
}

/// The registers (wire order) that hold engineering value `n`: unscaled, rounded for the
/// integer types and saturated at the raw type's range.
pub(crate) fn encode(point: &ProfilePoint, n: f64) -> Vec<u16> {
    let raw = match point.scaling {
        Some(s) => (n - s.offset) / s.scale,
        None => n,
    };
    let int = |min: f64, max: f64| raw.round().clamp(min, max);
    match point.data {
        DataType::Bool => vec![u16::from(raw != 0.0)],
        DataType::U16 => vec![int(0.0, f64::from(u16::MAX)) as u16],
        DataType::I16 => vec![int(f64::from(i16::MIN), f64::from(i16::MAX)) as i16 as u16],
        DataType::U32 => point
            .order
            .split(int(0.0, f64::from(u32::MAX)) as u32)
            .to_vec(),
        DataType::I32 => point
            .order
            .split(int(f64::from(i32::MIN), f64::from(i32::MAX)) as i32 as u32)
            .to_vec(),
        DataType::F32 => point.order.split((raw as f32).to_bits()).to_vec(),
    }
}
