//! The process image: every tag's value, its quality and the time of its last good read.
//!
//! Logic reads and writes the image only (DESIGN.md principle 2). Tags are addressed by
//! [`TagId`], an index resolved once at load time, so access never searches by name.

use softplc_io::point::{Quality, Value, ValueType};
use softplc_io::time::ScanInstant;

/// Index of a tag in the image (its position in the project's tag list); the push-down
/// seam's type, so a rung's shape names tags the same way in both crates.
pub use softplc_io::rung::TagId;

/// One tag's slot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Slot {
    /// The value logic sees.
    pub value: Value,
    /// How much to trust it.
    pub quality: Quality,
    /// Time of the last good read (inputs) or write (memory, outputs).
    pub timestamp: ScanInstant,
}

/// The process image.
#[derive(Debug, Clone, Default)]
pub struct ProcessImage {
    names: Vec<String>,
    slots: Vec<Slot>,
    /// Forced values by tag: applied after the input read and again before the output write,
    /// so neither a module nor the program can change a forced tag.
    forces: Vec<Option<Value>>,
}

impl ProcessImage {
    /// An image with one slot per `(name, initial value)`, all of quality `Bad` until read,
    /// except memory tags which the caller marks good.
    pub fn new(tags: impl IntoIterator<Item = (String, Value)>) -> Self {
        let (names, slots): (Vec<String>, Vec<Slot>) = tags
            .into_iter()
            .map(|(n, v)| {
                (
                    n,
                    Slot {
                        value: v,
                        quality: Quality::Bad,
                        timestamp: ScanInstant::ZERO,
                    },
                )
            })
            .unzip();
        let forces = vec![None; names.len()];
        Self {
            names,
            slots,
            forces,
        }
    }

    /// Number of tags.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// True when there are no tags.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// A tag's id by name (load-time use only: it searches).
    pub fn id(&self, name: &str) -> Option<TagId> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| TagId(i as u32))
    }

    /// A tag's name.
    pub fn name(&self, id: TagId) -> &str {
        &self.names[id.index()]
    }

    /// A tag's type.
    pub fn value_type(&self, id: TagId) -> ValueType {
        self.slots[id.index()].value.value_type()
    }

    /// A tag's value.
    pub fn get(&self, id: TagId) -> Value {
        self.slots[id.index()].value
    }

    /// A tag's slot.
    pub fn slot(&self, id: TagId) -> &Slot {
        &self.slots[id.index()]
    }

    /// Sets a value of the tag's own type, as logic does. A value of another type is converted
    /// the way an assignment would (bool ↔ numbers by non-zero).
    pub fn set(&mut self, id: TagId, value: Value, now: ScanInstant) {
        let slot = &mut self.slots[id.index()];
        slot.value = convert(value, slot.value.value_type());
        slot.quality = Quality::Good;
        slot.timestamp = now;
    }

    /// Puts a slot back as it was (a program that wrote a tag the value it held leaves the
    /// slot as it found it).
    pub(crate) fn restore(&mut self, id: TagId, slot: Slot) {
        self.slots[id.index()] = slot;
    }

    /// Records a read from a module: value and quality as the bus reported them.
    pub fn update(&mut self, id: TagId, value: Option<Value>, quality: Quality, now: ScanInstant) {
        let slot = &mut self.slots[id.index()];
        if let (Some(v), Quality::Good) = (value, quality) {
            slot.value = convert(v, slot.value.value_type());
            slot.timestamp = now;
        }
        slot.quality = quality;
    }

    /// Marks a tag's quality without touching its value.
    pub fn set_quality(&mut self, id: TagId, quality: Quality) {
        self.slots[id.index()].quality = quality;
    }

    /// All slots, in tag order.
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }

    /// All names, in tag order.
    pub fn names(&self) -> &[String] {
        &self.names
    }
}

impl ProcessImage {
    /// Forces a tag to `value` (converted to the tag's type) until [`ProcessImage::unforce`].
    pub fn force(&mut self, id: TagId, value: Value) {
        let ty = self.slots[id.index()].value.value_type();
        self.forces[id.index()] = Some(convert(value, ty));
    }

    /// Removes a tag's force; returns whether it was forced.
    pub fn unforce(&mut self, id: TagId) -> bool {
        self.forces[id.index()].take().is_some()
    }

    /// Removes every force; returns how many there were.
    pub fn unforce_all(&mut self) -> usize {
        let n = self.forces.iter().filter(|f| f.is_some()).count();
        self.forces.iter_mut().for_each(|f| *f = None);
        n
    }

    /// A tag's forced value, if forced.
    pub fn forced(&self, id: TagId) -> Option<Value> {
        self.forces[id.index()]
    }

    /// Every forced tag with its forced value, in tag order.
    pub fn forces(&self) -> impl Iterator<Item = (TagId, Value)> + '_ {
        (0u32..)
            .zip(&self.forces)
            .filter_map(|(i, f)| Some((TagId(i), (*f)?)))
    }

    /// Writes every forced value into its slot (the scan calls this after the input read and
    /// after the logic).
    pub fn apply_forces(&mut self, now: ScanInstant) {
        for (slot, force) in self.slots.iter_mut().zip(&self.forces) {
            if let Some(v) = force {
                slot.value = *v;
                slot.quality = Quality::Good;
                slot.timestamp = now;
            }
        }
    }
}

/// Converts `v` to type `ty` as an assignment does.
pub fn convert(v: Value, ty: ValueType) -> Value {
    if v.value_type() == ty {
        return v;
    }
    match ty {
        ValueType::Bool => Value::Bool(v.as_bool()),
        ValueType::U16 => Value::U16(match v {
            Value::Bool(b) => u16::from(b),
            Value::U16(x) => x,
            Value::I32(x) => x.clamp(0, i32::from(u16::MAX)) as u16,
            Value::F32(x) => x.clamp(0.0, f32::from(u16::MAX)) as u16,
        }),
        ValueType::I32 => Value::I32(match v {
            Value::Bool(b) => i32::from(b),
            Value::U16(x) => i32::from(x),
            Value::I32(x) => x,
            Value::F32(x) => x as i32,
        }),
        ValueType::F32 => Value::F32(match v {
            Value::Bool(b) => f32::from(u8::from(b)),
            Value::U16(x) => f32::from(x),
            Value::I32(x) => x as f32,
            Value::F32(x) => x,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn reads_keep_the_last_good_value_when_stale() {
        let mut img = ProcessImage::new([("x".to_string(), Value::Bool(false))]);
        let id = img.id("x").unwrap();
        img.update(
            id,
            Some(Value::Bool(true)),
            Quality::Good,
            ScanInstant::after_origin(Duration::from_millis(10)),
        );
        img.update(
            id,
            None,
            Quality::Stale,
            ScanInstant::after_origin(Duration::from_millis(20)),
        );
        assert_eq!(img.get(id), Value::Bool(true));
        assert_eq!(img.slot(id).quality, Quality::Stale);
        assert_eq!(
            img.slot(id).timestamp,
            ScanInstant::after_origin(Duration::from_millis(10))
        );
    }

    #[test]
    fn forces_win_over_reads_and_logic_until_removed() {
        let mut img = ProcessImage::new([("x".to_string(), Value::U16(0))]);
        let id = img.id("x").unwrap();
        img.force(id, Value::Bool(true));
        img.update(id, Some(Value::U16(7)), Quality::Good, ScanInstant::ZERO);
        img.apply_forces(ScanInstant::ZERO);
        assert_eq!(img.get(id), Value::U16(1));
        img.set(id, Value::U16(9), ScanInstant::ZERO);
        img.apply_forces(ScanInstant::ZERO);
        assert_eq!(img.get(id), Value::U16(1));
        assert!(img.unforce(id));
        img.set(id, Value::U16(9), ScanInstant::ZERO);
        img.apply_forces(ScanInstant::ZERO);
        assert_eq!(img.get(id), Value::U16(9));
    }

    #[test]
    fn assignment_converts_to_the_tag_type() {
        assert_eq!(
            convert(Value::I32(70000), ValueType::U16),
            Value::U16(65535)
        );
        assert_eq!(convert(Value::U16(2), ValueType::Bool), Value::Bool(true));
    }
}
