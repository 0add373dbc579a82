//! Values inside a RESI module and their encodings on the wire: 16-bit registers, 32-bit values
//! in both word orders (e.g. 4x00201 "0x12345678 -> register 0:0x1234 register 1:0x5678" and
//! 4x00221 "register 0:0x5678 register 1:0x1234", L20788, L20877), scaled integers (2RTD
//! "temperature*10", "temperature*100000", L6790, L7140) and floats (FLOAT32, DOUBLE64; note
//! erratum 8: DOUBLE64 is lowest word first, DOUBLE64I highest word first).

use crate::point::{Value, ValueType};

/// A value inside a module: an integer (states, counters, masks, times) or a real number
/// (2RTD temperatures and offsets).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Num {
    /// An integer.
    Int(i64),
    /// A real number.
    Real(f64),
}

impl Num {
    /// The value as an integer (reals rounded, saturating).
    pub fn int(self) -> i64 {
        match self {
            Num::Int(v) => v,
            // `as` saturates for floats (NaN gives 0): never panics on odd input.
            Num::Real(f) => f.round() as i64,
        }
    }

    /// The value as a real number.
    pub fn real(self) -> f64 {
        match self {
            Num::Int(v) => v as f64,
            Num::Real(f) => f,
        }
    }

    /// The value as a point of type `ty` sees it; integers beyond the type saturate.
    pub fn to_value(self, ty: ValueType) -> Value {
        match ty {
            ValueType::Bool => Value::Bool(self.int() != 0),
            ValueType::U16 => Value::U16(self.int().clamp(0, i64::from(u16::MAX)) as u16),
            ValueType::I32 => {
                Value::I32(self.int().clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32)
            }
            ValueType::F32 => Value::F32(self.real() as f32),
        }
    }

    /// A point's value as a module value.
    pub fn from_value(value: Value) -> Self {
        match value {
            Value::Bool(b) => Num::Int(i64::from(b)),
            Value::U16(v) => Num::Int(i64::from(v)),
            Value::I32(v) => Num::Int(i64::from(v)),
            Value::F32(v) => Num::Real(f64::from(v)),
        }
    }
}

/// The order of the 16-bit words of a value wider than one register.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WordOrder {
    /// The most significant word at the lower address (`0x1234, 0x5678`).
    HighFirst,
    /// The least significant word at the lower address (`0x5678, 0x1234`).
    LowFirst,
}

/// How a value sits in the bit table or in registers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Enc {
    /// One coil / discrete input.
    Bit,
    /// One register, unsigned.
    U16,
    /// One register holding 0 or 1 ("=0:DO is OFF, =1:DO is ON", L4243): a boolean.
    Flag,
    /// One register, signed, value × scale (2RTD SINT16 "temperature*10"; scale 1 for plain
    /// signed numbers).
    S16(u32),
    /// Two registers, unsigned.
    U32(WordOrder),
    /// Two registers, signed, value × scale (2RTD SINT32 "temperature*100000").
    S32(u32, WordOrder),
    /// Two registers, IEEE 754 single.
    F32(WordOrder),
    /// Four registers, IEEE 754 double.
    F64(WordOrder),
}

/// Words of one value, least significant first.
type Words = [u16; 4];

impl Enc {
    /// How many addresses the value takes.
    pub const fn words(self) -> u16 {
        match self {
            Enc::Bit | Enc::U16 | Enc::Flag | Enc::S16(_) => 1,
            Enc::U32(_) | Enc::S32(..) | Enc::F32(_) => 2,
            Enc::F64(_) => 4,
        }
    }

    /// The type a point with this encoding has.
    pub const fn value_type(self) -> ValueType {
        match self {
            Enc::Bit | Enc::Flag => ValueType::Bool,
            Enc::U16 => ValueType::U16,
            Enc::S16(1) | Enc::U32(_) | Enc::S32(1, _) => ValueType::I32,
            Enc::S16(_) | Enc::S32(..) | Enc::F32(_) | Enc::F64(_) => ValueType::F32,
        }
    }

    const fn order(self) -> WordOrder {
        match self {
            Enc::U32(o) | Enc::S32(_, o) | Enc::F32(o) | Enc::F64(o) => o,
            _ => WordOrder::HighFirst,
        }
    }

    /// Whether `n` can be stored with this encoding without saturating.
    pub fn fits(self, n: Num) -> bool {
        let scaled = |scale: u32| (n.real() * f64::from(scale)).round();
        match self {
            Enc::Bit | Enc::Flag => matches!(n, Num::Int(0 | 1)),
            Enc::U16 => matches!(n, Num::Int(v) if (0..=0xFFFF).contains(&v)),
            Enc::U32(_) => matches!(n, Num::Int(v) if (0..=0xFFFF_FFFF).contains(&v)),
            Enc::S16(s) => (-32768.0..=32767.0).contains(&scaled(s)),
            Enc::S32(s, _) => (-2_147_483_648.0..=2_147_483_647.0).contains(&scaled(s)),
            Enc::F32(_) | Enc::F64(_) => n.real().is_finite(),
        }
    }

    /// The value as words, least significant first (saturating).
    fn raw(self, n: Num) -> Words {
        let scaled = |scale: u32| (n.real() * f64::from(scale)).round();
        let bits: u64 = match self {
            Enc::Bit => u64::from(n.int() != 0),
            Enc::U16 | Enc::Flag => n.int().clamp(0, 0xFFFF) as u64,
            Enc::U32(_) => n.int().clamp(0, 0xFFFF_FFFF) as u64,
            Enc::S16(s) => u64::from(scaled(s) as i16 as u16),
            Enc::S32(s, _) => u64::from(scaled(s) as i32 as u32),
            Enc::F32(_) => u64::from((n.real() as f32).to_bits()),
            Enc::F64(_) => n.real().to_bits(),
        };
        [0, 16, 32, 48].map(|shift| (bits >> shift) as u16)
    }

    fn unraw(self, w: Words) -> Num {
        let bits = w
            .iter()
            .rev()
            .fold(0u64, |acc, &word| (acc << 16) | u64::from(word));
        match self {
            Enc::Bit => Num::Int(i64::from(w[0] != 0)),
            Enc::U16 | Enc::Flag | Enc::U32(_) => Num::Int(bits as i64),
            Enc::S16(1) => Num::Int(i64::from(bits as u16 as i16)),
            Enc::S16(s) => Num::Real(f64::from(bits as u16 as i16) / f64::from(s)),
            Enc::S32(1, _) => Num::Int(i64::from(bits as u32 as i32)),
            Enc::S32(s, _) => Num::Real(f64::from(bits as u32 as i32) / f64::from(s)),
            Enc::F32(_) => Num::Real(f64::from(f32::from_bits(bits as u32))),
            Enc::F64(_) => Num::Real(f64::from_bits(bits)),
        }
    }

    /// Position of address word `i` (0 = the value's first address) in least-significant-first
    /// order.
    fn slot(self, i: usize) -> usize {
        let n = usize::from(self.words());
        match self.order() {
            WordOrder::LowFirst => i,
            WordOrder::HighFirst => n.saturating_sub(1).saturating_sub(i),
        }
    }

    /// The word at address offset `i` of the value (`0` beyond its width).
    pub fn word(self, n: Num, i: usize) -> u16 {
        if i >= usize::from(self.words()) {
            return 0;
        }
        self.raw(n).get(self.slot(i)).copied().unwrap_or(0)
    }

    /// The words of the value in address order.
    pub fn encode(self, n: Num) -> Vec<u16> {
        (0..usize::from(self.words()))
            .map(|i| self.word(n, i))
            .collect()
    }

    /// The value of words in address order; `None` unless exactly [`Enc::words`] are given.
    pub fn decode(self, words: &[u16]) -> Option<Num> {
        if words.len() != usize::from(self.words()) {
            return None;
        }
        let mut raw: Words = [0; 4];
        for (i, w) in words.iter().enumerate() {
            if let Some(slot) = raw.get_mut(self.slot(i)) {
                *slot = *w;
            }
        }
        Some(self.unraw(raw))
    }

    /// `current` with the word at address offset `i` replaced: a write of one half of a 32-bit
    /// value (the manual documents only writes of both halves, see resi-spec §3.4).
    pub fn with_word(self, current: Num, i: usize, word: u16) -> Num {
        let mut raw = self.raw(current);
        if i < usize::from(self.words()) {
            if let Some(slot) = raw.get_mut(self.slot(i)) {
                *slot = word;
            }
        }
        self.unraw(raw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn word_orders_follow_the_manual_example() {
        let n = Num::Int(0x1234_5678);
        assert_eq!(
            Enc::U32(WordOrder::HighFirst).encode(n),
            [0x1234, 0x5678],
            "L20790"
        );
        assert_eq!(
            Enc::U32(WordOrder::LowFirst).encode(n),
            [0x5678, 0x1234],
            "L20880"
        );
        // PULSE TIME 300 = 0x0000012C (L16730).
        assert_eq!(
            Enc::U32(WordOrder::HighFirst).encode(Num::Int(300)),
            [0, 0x012C]
        );
        assert_eq!(
            Enc::U32(WordOrder::LowFirst).decode(&[0x012C, 0]),
            Some(Num::Int(300))
        );
        // DOUBLE64: "0x1122334455667788 -> 0x7788 0x5566 0x3344 0x1122" (L7608).
        let d = Num::Real(f64::from_bits(0x1122_3344_5566_7788));
        assert_eq!(
            Enc::F64(WordOrder::LowFirst).encode(d),
            [0x7788, 0x5566, 0x3344, 0x1122]
        );
        assert_eq!(
            Enc::F64(WordOrder::HighFirst).encode(d),
            [0x1122, 0x3344, 0x5566, 0x7788]
        );
    }

    #[test]
    fn scaled_and_signed() {
        assert_eq!(Enc::S16(10).encode(Num::Real(-999.0)), [(-9990i16) as u16]);
        assert_eq!(
            Enc::S16(10).decode(&[(-9990i16) as u16]),
            Some(Num::Real(-999.0))
        );
        let s32 = Enc::S32(100_000, WordOrder::HighFirst);
        assert_eq!(
            s32.decode(&s32.encode(Num::Real(-999.0))),
            Some(Num::Real(-999.0))
        );
        assert_eq!(
            Enc::F32(WordOrder::LowFirst)
                .decode(&Enc::F32(WordOrder::LowFirst).encode(Num::Real(21.5))),
            Some(Num::Real(21.5))
        );
        assert!(Enc::U16.fits(Num::Int(65535)));
        assert!(!Enc::U16.fits(Num::Int(65536)));
        assert!(!Enc::U16.fits(Num::Int(-1)));
        assert!(!Enc::S16(10).fits(Num::Real(4000.0)));
        assert!(!Enc::F32(WordOrder::LowFirst).fits(Num::Real(f64::NAN)));
        assert_eq!(Enc::U16.decode(&[1, 2]), None);
    }

    #[test]
    fn half_writes_replace_one_word() {
        let e = Enc::U32(WordOrder::HighFirst);
        let v = e.with_word(Num::Int(0), 1, 0x012C);
        assert_eq!(v, Num::Int(300));
        assert_eq!(e.with_word(v, 0, 1), Num::Int(0x1_012C));
        assert_eq!(e.with_word(v, 5, 1), v, "beyond the width: unchanged");
        assert_eq!(e.word(v, 7), 0);
    }

    #[test]
    fn points_saturate() {
        assert_eq!(Num::Int(70_000).to_value(ValueType::U16), Value::U16(65535));
        assert_eq!(
            Num::Int(0xFFFF_FFFF).to_value(ValueType::I32),
            Value::I32(i32::MAX)
        );
        assert_eq!(Num::Real(f64::NAN).int(), 0);
        assert_eq!(Num::from_value(Value::Bool(true)), Num::Int(1));
    }
}
