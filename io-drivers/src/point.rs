//! Points: the named values a module exposes (`X1`, `Y2`, `XCOUNT1`), their types and access.

use std::fmt;

/// The type of a point or tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ValueType {
    /// A bit.
    Bool,
    /// An unsigned 16-bit word (a Modbus register).
    U16,
    /// A signed 32-bit integer.
    I32,
    /// A 32-bit float.
    F32,
}

impl ValueType {
    /// The name used in project files: `bool`, `u16`, `i32`, `f32`.
    pub fn name(self) -> &'static str {
        match self {
            ValueType::Bool => "bool",
            ValueType::U16 => "u16",
            ValueType::I32 => "i32",
            ValueType::F32 => "f32",
        }
    }

    /// Parses a project-file type name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "bool" => Some(ValueType::Bool),
            "u16" => Some(ValueType::U16),
            "i32" => Some(ValueType::I32),
            "f32" => Some(ValueType::F32),
            _ => None,
        }
    }

    /// The zero of this type.
    pub fn zero(self) -> Value {
        match self {
            ValueType::Bool => Value::Bool(false),
            ValueType::U16 => Value::U16(0),
            ValueType::I32 => Value::I32(0),
            ValueType::F32 => Value::F32(0.0),
        }
    }
}

impl fmt::Display for ValueType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A typed value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// A bit.
    Bool(bool),
    /// An unsigned 16-bit word.
    U16(u16),
    /// A signed 32-bit integer.
    I32(i32),
    /// A 32-bit float.
    F32(f32),
}

impl Value {
    /// The type of this value.
    pub fn value_type(self) -> ValueType {
        match self {
            Value::Bool(_) => ValueType::Bool,
            Value::U16(_) => ValueType::U16,
            Value::I32(_) => ValueType::I32,
            Value::F32(_) => ValueType::F32,
        }
    }

    /// Truthiness as a contact sees it: non-zero is true.
    pub fn as_bool(self) -> bool {
        match self {
            Value::Bool(b) => b,
            Value::U16(v) => v != 0,
            Value::I32(v) => v != 0,
            Value::F32(v) => v != 0.0,
        }
    }

    /// Parses `text` as a value of type `ty` (`1`/`0`/`true`/`false` for bools).
    pub fn parse(ty: ValueType, text: &str) -> Option<Value> {
        let t = text.trim();
        match ty {
            ValueType::Bool => match t.to_ascii_lowercase().as_str() {
                "1" | "true" | "on" => Some(Value::Bool(true)),
                "0" | "false" | "off" => Some(Value::Bool(false)),
                _ => None,
            },
            ValueType::U16 => parse_int(t)
                .and_then(|v| u16::try_from(v).ok())
                .map(Value::U16),
            ValueType::I32 => parse_int(t)
                .and_then(|v| i32::try_from(v).ok())
                .map(Value::I32),
            ValueType::F32 => t.parse::<f32>().ok().map(Value::F32),
        }
    }
}

fn parse_int(t: &str) -> Option<i64> {
    if let Some(hex) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        i64::from_str_radix(hex, 16).ok()
    } else {
        t.parse::<i64>().ok()
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Bool(b) => write!(f, "{}", u8::from(*b)),
            Value::U16(v) => write!(f, "{v}"),
            Value::I32(v) => write!(f, "{v}"),
            Value::F32(v) => write!(f, "{v}"),
        }
    }
}

/// Who may write a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Read from the module; the program may not write it.
    Input,
    /// Written by the program (and read back from the module).
    Output,
    /// A module setting that is read and may be written (counters, latencies, masks).
    ReadWrite,
}

/// One named point of a module model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PointSpec {
    /// The manual's name: `X1`, `Y2`, `XCOUNT1`.
    pub name: &'static str,
    /// Its type.
    pub ty: ValueType,
    /// Who writes it.
    pub access: Access,
    /// One line for `softplc check` and docs, with the manual's address.
    pub doc: &'static str,
}

/// Quality of a value in the process image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Quality {
    /// Read in the last cycle.
    Good,
    /// The last read failed; the value is the last good one.
    Stale,
    /// Never read, or lost (consecutive failures past the limit).
    #[default]
    Bad,
}

impl fmt::Display for Quality {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Quality::Good => "good",
            Quality::Stale => "stale",
            Quality::Bad => "bad",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_values_by_type() {
        assert_eq!(Value::parse(ValueType::Bool, "1"), Some(Value::Bool(true)));
        assert_eq!(Value::parse(ValueType::U16, "0x10"), Some(Value::U16(16)));
        assert_eq!(Value::parse(ValueType::U16, "70000"), None);
        assert_eq!(Value::parse(ValueType::I32, "-5"), Some(Value::I32(-5)));
    }
}
