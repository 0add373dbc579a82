//! Positions of nodes in the project text, for semantic errors.
//!
//! yaml_serde reports a location only for its own deserialization errors and has no `Spanned`
//! type. So to find where `modules[2].address` is, the text is deserialized once more with a
//! [`DeserializeSeed`] that walks the path (at a mapping it deserializes the wanted key's value
//! with the rest of the path and skips other values with [`IgnoredAny`]; at a sequence it skips
//! to the wanted index) and fails at the target node with a marker error. yaml_serde attaches
//! the position of the node being deserialized to an error that has none, so the marker comes
//! back with the node's line and column.
//!
//! What the position points at (verified by the tests below):
//! - a scalar: its first character (the opening quote of a quoted scalar);
//! - a block mapping or sequence: its first key or first `-`; a flow one: its `{` or `[`;
//! - [`Seg::KeyItself`]: the key's first character.
//!
//! A path that is not in the text (a key left to its default) resolves to its nearest ancestor
//! that is; the document itself is line 1, column 1.

use std::fmt;

use serde::de::{self, DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};

/// Marks "this is the node": the error that carries the wanted position.
const HIT: &str = "\u{0}softplc-locate-hit";
/// Marks "the path is not in the text".
const MISS: &str = "\u{0}softplc-locate-miss";

/// One step of a path into the YAML document.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Seg {
    /// The value of a mapping key.
    Key(String),
    /// The key itself (not its value). Only meaningful as the last step.
    KeyItself(String),
    /// An element of a sequence (0-based).
    Index(usize),
}

/// A path into the YAML document, like `modules[2].address`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct YPath(Vec<Seg>);

impl YPath {
    /// The document root.
    pub(crate) fn root() -> Self {
        Self(Vec::new())
    }

    /// This path followed by the value of `key`.
    pub(crate) fn key(&self, key: &str) -> Self {
        let mut p = self.clone();
        p.0.push(Seg::Key(key.to_owned()));
        p
    }

    /// This path followed by the key `key` itself.
    pub(crate) fn key_itself(&self, key: &str) -> Self {
        let mut p = self.clone();
        p.0.push(Seg::KeyItself(key.to_owned()));
        p
    }

    /// This path followed by element `i` of a sequence.
    pub(crate) fn index(&self, i: usize) -> Self {
        let mut p = self.clone();
        p.0.push(Seg::Index(i));
        p
    }
}

/// Finds positions of paths in one YAML text.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Locator<'a> {
    text: &'a str,
}

impl<'a> Locator<'a> {
    /// A locator over `text` (which has already been parsed successfully once).
    pub(crate) fn new(text: &'a str) -> Self {
        Self { text }
    }

    /// 1-based `(line, column)` of the node at `path`, or of its nearest ancestor present in
    /// the text; `(1, 1)` when none is.
    pub(crate) fn position(&self, path: &YPath) -> (usize, usize) {
        let mut segs: &[Seg] = &path.0;
        loop {
            if let Some(pos) = self.exact(segs) {
                return pos;
            }
            match segs.split_last() {
                Some((_, parent)) => segs = parent,
                None => return (1, 1),
            }
        }
    }

    /// The 1-based line of the node at `path` (see [`Locator::position`]).
    pub(crate) fn line(&self, path: &YPath) -> usize {
        self.position(path).0
    }

    /// The position of exactly this path, if it is in the text.
    fn exact(&self, segs: &[Seg]) -> Option<(usize, usize)> {
        let de = yaml_serde::Deserializer::from_str(self.text);
        let err = PathSeed(segs).deserialize(de).err()?;
        if !err.to_string().contains(HIT) {
            return None;
        }
        err.location().map(|l| (l.line(), l.column()))
    }
}

/// Walks `0` and fails at its end with [`HIT`].
struct PathSeed<'p>(&'p [Seg]);

impl<'de> DeserializeSeed<'de> for PathSeed<'_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(PathVisitor(self.0))
    }
}

struct PathVisitor<'p>(&'p [Seg]);

impl PathVisitor<'_> {
    /// A scalar is the target when the path ends here; otherwise the path goes nowhere.
    fn scalar<E: de::Error>(self) -> Result<(), E> {
        Err(E::custom(if self.0.is_empty() { HIT } else { MISS }))
    }
}

impl<'de> Visitor<'de> for PathVisitor<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("any YAML node")
    }

    fn visit_bool<E: de::Error>(self, _: bool) -> Result<(), E> {
        self.scalar()
    }

    fn visit_i64<E: de::Error>(self, _: i64) -> Result<(), E> {
        self.scalar()
    }

    fn visit_u64<E: de::Error>(self, _: u64) -> Result<(), E> {
        self.scalar()
    }

    fn visit_i128<E: de::Error>(self, _: i128) -> Result<(), E> {
        self.scalar()
    }

    fn visit_u128<E: de::Error>(self, _: u128) -> Result<(), E> {
        self.scalar()
    }

    fn visit_f64<E: de::Error>(self, _: f64) -> Result<(), E> {
        self.scalar()
    }

    fn visit_str<E: de::Error>(self, _: &str) -> Result<(), E> {
        self.scalar()
    }

    fn visit_unit<E: de::Error>(self) -> Result<(), E> {
        self.scalar()
    }

    fn visit_none<E: de::Error>(self) -> Result<(), E> {
        self.scalar()
    }

    fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let Some((first, rest)) = self.0.split_first() else {
            return Err(de::Error::custom(HIT));
        };
        let (want, itself) = match first {
            Seg::Key(k) => (k.as_str(), false),
            Seg::KeyItself(k) => (k.as_str(), true),
            Seg::Index(_) => return Err(de::Error::custom(MISS)),
        };
        while let Some(found) = map.next_key_seed(KeySeed { want, itself })? {
            if found {
                return map.next_value_seed(PathSeed(rest));
            }
            map.next_value::<IgnoredAny>()?;
        }
        Err(de::Error::custom(MISS))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let Some((first, rest)) = self.0.split_first() else {
            return Err(de::Error::custom(HIT));
        };
        let Seg::Index(i) = first else {
            return Err(de::Error::custom(MISS));
        };
        for _ in 0..*i {
            if seq.next_element::<IgnoredAny>()?.is_none() {
                return Err(de::Error::custom(MISS));
            }
        }
        seq.next_element_seed(PathSeed(rest))?;
        Err(de::Error::custom(MISS))
    }
}

/// Reads one mapping key: `Ok(true)` when it is the wanted one, `Ok(false)` otherwise; fails
/// with [`HIT`] when the key itself is the target.
struct KeySeed<'p> {
    want: &'p str,
    itself: bool,
}

impl<'de> DeserializeSeed<'de> for KeySeed<'_> {
    type Value = bool;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<bool, D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for KeySeed<'_> {
    type Value = bool;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a mapping key")
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<bool, E> {
        match (v == self.want, self.itself) {
            (true, true) => Err(E::custom(HIT)),
            (found, _) => Ok(found),
        }
    }

    fn visit_bool<E: de::Error>(self, _: bool) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_i64<E: de::Error>(self, _: i64) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_u64<E: de::Error>(self, _: u64) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_i128<E: de::Error>(self, _: i128) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_u128<E: de::Error>(self, _: u128) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_f64<E: de::Error>(self, _: f64) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_unit<E: de::Error>(self) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_none<E: de::Error>(self) -> Result<bool, E> {
        Ok(false)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<bool, A::Error> {
        while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        Ok(false)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<bool, A::Error> {
        while seq.next_element::<IgnoredAny>()?.is_some() {}
        Ok(false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
project: q
scan:
  period: 20ms
modules:
  - name: mm1
    address: 1
  - name: mm2
    address:   2
    settings: {a: 1, b: x}
tags:
  - { name: start,  point: mm1.X2 }
  - name: x
    safe: \"5\"
plant:
  wiring:
    motor: mm1.Y1
";

    fn pos(path: YPath) -> (usize, usize) {
        Locator::new(TEXT).position(&path)
    }

    #[test]
    fn scalars_point_at_their_first_character() {
        let r = YPath::root();
        assert_eq!(pos(r.key("project")), (1, 10));
        assert_eq!(pos(r.key("scan").key("period")), (3, 11));
        assert_eq!(pos(r.key("modules").index(1).key("address")), (8, 16));
        assert_eq!(
            pos(r.key("modules").index(1).key("settings").key("b")),
            (9, 25)
        );
        assert_eq!(pos(r.key("tags").index(0).key("point")), (11, 28));
        // A quoted scalar: its opening quote.
        assert_eq!(pos(r.key("tags").index(1).key("safe")), (13, 11));
    }

    #[test]
    fn collections_point_at_their_first_entry_or_brace() {
        let r = YPath::root();
        assert_eq!(pos(r.key("scan")), (3, 3));
        assert_eq!(pos(r.key("modules").index(1)), (7, 5));
        assert_eq!(pos(r.key("modules").index(1).key("settings")), (9, 15));
        assert_eq!(pos(r.key("tags").index(0)), (11, 5));
    }

    #[test]
    fn keys_themselves() {
        let r = YPath::root();
        assert_eq!(
            pos(r.key("plant").key("wiring").key_itself("motor")),
            (16, 5)
        );
        assert_eq!(
            pos(r.key("modules").index(1).key("settings").key_itself("b")),
            (9, 22)
        );
        assert_eq!(pos(r.key_itself("plant")), (14, 1));
    }

    #[test]
    fn missing_paths_fall_back_to_the_nearest_ancestor() {
        let r = YPath::root();
        assert_eq!(pos(r.key("modules").index(0).key("protocol")), (5, 5));
        assert_eq!(pos(r.key("modules").index(7).key("address")), (5, 3));
        assert_eq!(pos(r.key("nope").key("deeper")), (1, 1));
        assert_eq!(pos(r.key("project").key("below_a_scalar")), (1, 10));
        assert_eq!(pos(r), (1, 1));
    }
}
