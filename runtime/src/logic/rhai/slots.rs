//! Read-only tags (module inputs) as indexed slots, read through Rhai's variable resolver.
//!
//! A read-only tag is declared in the script's scope (so strict variables accept it and every
//! later variable keeps its compile-time offset), but its value lives here, in one slot per
//! tag, copied in from the image at the start of the scan. Rhai hands the resolver each
//! variable's offset from the end of the scope, fixed at compile time: the scope's length minus
//! that offset is the variable's place in the declarations, and a table indexed by that place
//! gives the slot. So reading an input is an index and an atomic load, with no name compared
//! and no lock, whatever the number of tags; variables that are not inputs (outputs, memory
//! tags, `let`s) answer `None` and are read from the scope as usual.
//!
//! The atomics make the slots shareable with the engine's callback (`Send + Sync`); they are
//! written by the scan between two runs of the script and read during one, on one thread.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

use rhai::{Dynamic, INT};
use softplc_io::point::{Value, ValueType};

/// How a slot's 64 bits read back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Bool,
    Int,
    Float,
}

/// The input slots of one script.
#[derive(Debug, Default)]
pub(crate) struct InputSlots {
    /// Per place in the declarations: the slot of a read-only tag, `None` for a writable one.
    by_position: Vec<Option<u32>>,
    /// Slot by name, for the one case Rhai passes no offset (it searches the scope by name).
    by_name: HashMap<String, u32>,
    values: Vec<AtomicU64>,
    kinds: Vec<Kind>,
}

impl InputSlots {
    /// Slots for `declared` (name, type, writable) in the order of the declarations line.
    pub(crate) fn new<'a>(declared: impl Iterator<Item = (&'a str, ValueType, bool)>) -> Self {
        let mut slots = Self::default();
        for (name, ty, writable) in declared {
            if writable {
                slots.by_position.push(None);
                continue;
            }
            let slot = slots.values.len() as u32;
            slots.by_position.push(Some(slot));
            slots.by_name.insert(name.to_string(), slot);
            slots.kinds.push(match ty {
                ValueType::Bool => Kind::Bool,
                ValueType::U16 | ValueType::I32 => Kind::Int,
                ValueType::F32 => Kind::Float,
            });
            slots.values.push(AtomicU64::new(0));
        }
        slots
    }

    /// The slot of the read-only tag at `position` in the declarations.
    pub(crate) fn slot_at(&self, position: usize) -> Option<u32> {
        self.by_position.get(position).copied().flatten()
    }

    /// Stores `v` in `slot`.
    pub(crate) fn store(&self, slot: u32, v: Value) {
        let bits = match v {
            Value::Bool(b) => u64::from(b),
            Value::U16(x) => INT::from(x) as u64,
            Value::I32(x) => INT::from(x) as u64,
            Value::F32(x) => f64::from(x).to_bits(),
        };
        if let Some(s) = self.values.get(slot as usize) {
            s.store(bits, Ordering::Relaxed);
        }
    }

    /// The resolver's answer for variable `name` at `offset` from the end of a scope of
    /// `scope_len` entries (offset 0: Rhai did not resolve it, search by name).
    pub(crate) fn resolve(&self, name: &str, offset: usize, scope_len: usize) -> Option<Dynamic> {
        let slot = if offset == 0 {
            *self.by_name.get(name)?
        } else {
            self.slot_at(scope_len.checked_sub(offset)?)?
        };
        let bits = self.values.get(slot as usize)?.load(Ordering::Relaxed);
        Some(match self.kinds.get(slot as usize)? {
            Kind::Bool => Dynamic::from_bool(bits != 0),
            Kind::Int => Dynamic::from_int(bits as INT),
            Kind::Float => Dynamic::from_float(f64::from_bits(bits)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_resolve_by_offset_and_by_name_and_others_do_not() {
        let slots = InputSlots::new(
            [
                ("start", ValueType::Bool, false),
                ("motor", ValueType::Bool, true),
                ("level", ValueType::U16, false),
                ("temp", ValueType::F32, false),
            ]
            .into_iter(),
        );
        slots.store(0, Value::Bool(true));
        slots.store(1, Value::U16(65535));
        slots.store(2, Value::F32(-2.5));
        // A scope of the 4 declarations and one `let`: offsets count from its end.
        let len = 5;
        assert_eq!(
            slots
                .resolve("start", 5, len)
                .and_then(|d| d.as_bool().ok()),
            Some(true)
        );
        assert!(
            slots.resolve("motor", 4, len).is_none(),
            "writable: read from the scope"
        );
        assert_eq!(
            slots.resolve("level", 3, len).and_then(|d| d.as_int().ok()),
            Some(65535)
        );
        assert_eq!(
            slots
                .resolve("temp", 2, len)
                .and_then(|d| d.as_float().ok()),
            Some(-2.5)
        );
        assert!(slots.resolve("x", 1, len).is_none(), "a let");
        assert_eq!(
            slots.resolve("level", 0, len).and_then(|d| d.as_int().ok()),
            Some(65535)
        );
        assert!(slots.resolve("nope", 0, len).is_none());
        assert!(
            slots.resolve("start", 9, len).is_none(),
            "an offset past the scope"
        );
    }
}
