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
//!
//! One such walk reads the whole text, so locating each of thousands of errors that way took
//! time in the square of the file's size. The locator therefore builds an [`Index`] of every
//! node's position at its first question, in as many readings as the document is deep (at
//! most [`super::nesting::MAX_DEPTH`]): an error the walker raises at a scalar leaves the
//! reader where it would be after that scalar, so a reading can collect every scalar and key
//! and go on; a collection's own position comes from the reader's complaint, raised only once
//! the collection has been read to its end, that its visitor left entries unread, so the
//! reading goes on after that too. Reading `n` levels down in turn gives the position of
//! every collection of level `n`. Only an empty collection (`[]`, `{}`) cannot be found that
//! way; it is found by the walk above, once per path asked.

use std::cell::{Cell, OnceCell, RefCell};
use std::collections::{HashMap, HashSet};
use std::fmt;

use serde::de::{self, DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};

/// Marks "this is the node": the error that carries the wanted position.
const HIT: &str = "\u{0}softplc-locate-hit";
/// Marks "the path is not in the text".
const MISS: &str = "\u{0}softplc-locate-miss";

/// One step of a path into the YAML document.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
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

/// A 1-based `(line, column)`.
type Position = (usize, usize);

/// Finds positions of paths in one YAML text.
#[derive(Debug)]
pub(crate) struct Locator<'a> {
    text: &'a str,
    /// Built at the first question; `None` when the text could not be indexed (then every
    /// question walks the text, as [`Locator::exact`] does).
    index: OnceCell<Option<Index>>,
    /// Answers of [`Locator::exact`] already given.
    walked: RefCell<HashMap<Vec<Seg>, Option<Position>>>,
    /// Readings of the whole text so far (the index's levels and each walk): what a question
    /// costs, counted rather than timed.
    readings: Cell<usize>,
}

impl<'a> Locator<'a> {
    /// A locator over `text` (which has already been parsed successfully once).
    pub(crate) fn new(text: &'a str) -> Self {
        Self {
            text,
            index: OnceCell::new(),
            walked: RefCell::new(HashMap::new()),
            readings: Cell::new(0),
        }
    }

    /// How many times the text has been read so far.
    #[cfg(test)]
    fn readings(&self) -> usize {
        self.readings.get()
    }

    /// 1-based `(line, column)` of the node at `path`, or of its nearest ancestor present in
    /// the text; `(1, 1)` when none is.
    pub(crate) fn position(&self, path: &YPath) -> (usize, usize) {
        let index = self.index.get_or_init(|| {
            let (index, levels) = Index::build(self.text);
            self.readings.set(self.readings.get() + levels);
            index
        });
        let mut segs: &[Seg] = &path.0;
        loop {
            let found = match index {
                Some(index) => match index.nodes.get(segs) {
                    Some(&pos) => Some(pos),
                    None if index.empty.contains(segs) => self.walked(segs),
                    None => None,
                },
                None => self.walked(segs),
            };
            if let Some(pos) = found {
                return pos;
            }
            match segs.split_last() {
                Some((_, parent)) => segs = parent,
                None => return (1, 1),
            }
        }
    }

    /// [`Locator::exact`], remembered.
    fn walked(&self, segs: &[Seg]) -> Option<(usize, usize)> {
        if let Some(&pos) = self.walked.borrow().get(segs) {
            return pos;
        }
        let pos = self.exact(segs);
        self.walked.borrow_mut().insert(segs.to_vec(), pos);
        pos
    }

    /// The 1-based line of the node at `path` (see [`Locator::position`]).
    pub(crate) fn line(&self, path: &YPath) -> usize {
        self.position(path).0
    }

    /// The position of exactly this path, if it is in the text.
    fn exact(&self, segs: &[Seg]) -> Option<(usize, usize)> {
        self.readings.set(self.readings.get() + 1);
        let de = yaml_serde::Deserializer::from_str(self.text);
        let err = PathSeed(segs).deserialize(de).err()?;
        if !err.to_string().contains(HIT) {
            return None;
        }
        err.location().map(|l| (l.line(), l.column()))
    }
}

/// The position of every node of a text (see the module docs).
#[derive(Debug, Default)]
struct Index {
    /// Node (or key, as [`Seg::KeyItself`]) → 1-based `(line, column)`.
    nodes: HashMap<Vec<Seg>, (usize, usize)>,
    /// Empty collections, whose position the index does not know.
    empty: HashSet<Vec<Seg>>,
}

/// What the node just read turned out to be, for the reading of its parent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Outcome {
    /// A scalar: its error carries its position.
    Scalar,
    /// A collection of the level this reading stops at: left unread, so the reader's error
    /// carries its position (none when it is empty).
    Stopped,
    /// A collection read through.
    Read,
}

/// One reading: down to collections of `level`, recording into `index`.
#[derive(Debug)]
struct Reading<'i> {
    level: usize,
    index: &'i RefCell<Index>,
    /// What the last node read was.
    outcome: Cell<Option<Outcome>>,
    /// The last key read, when it was a string.
    key: RefCell<Option<String>>,
    /// Collections of `level` met.
    stopped: Cell<usize>,
}

impl Index {
    /// Reads `text` level by level; `None` when a reading fails otherwise than by design.
    /// With it, how many readings it took.
    fn build(text: &str) -> (Option<Index>, usize) {
        let index = RefCell::new(Index::default());
        for level in 0..=super::nesting::MAX_DEPTH + 1 {
            let reading = Reading {
                level,
                index: &index,
                outcome: Cell::new(None),
                key: RefCell::new(None),
                stopped: Cell::new(0),
            };
            let de = yaml_serde::Deserializer::from_str(text);
            let result = Node {
                path: Vec::new(),
                depth: 0,
                reading: &reading,
            }
            .deserialize(de);
            match (result, reading.outcome.get()) {
                (Ok(()), Some(Outcome::Read)) => {}
                (Ok(()), Some(Outcome::Stopped)) => {
                    index.borrow_mut().empty.insert(Vec::new());
                }
                (Err(e), Some(Outcome::Scalar | Outcome::Stopped)) => {
                    let pos = e.location().map_or((1, 1), |l| (l.line(), l.column()));
                    index.borrow_mut().nodes.entry(Vec::new()).or_insert(pos);
                }
                _ => return (None, level + 1),
            }
            if reading.stopped.get() == 0 {
                return (Some(index.into_inner()), level + 1);
            }
        }
        (None, super::nesting::MAX_DEPTH + 2)
    }
}

/// The 1-based position at the end of a reader's error message (" at line L column C"), as
/// the reader writes it; none written means line 1, column 1.
fn position_in(message: &str) -> (usize, usize) {
    let parsed = message.rsplit_once(" at line ").and_then(|(_, rest)| {
        let (line, column) = rest.split_once(" column ")?;
        Some((line.parse().ok()?, column.trim().parse().ok()?))
    });
    parsed.unwrap_or((1, 1))
}

/// One node of a reading, at `path`, `depth` levels down.
struct Node<'r, 'i> {
    path: Vec<Seg>,
    depth: usize,
    reading: &'r Reading<'i>,
}

impl Node<'_, '_> {
    /// Records what reading the child at `path` gave.
    fn child<E: de::Error>(&self, path: Vec<Seg>, result: Result<(), E>) -> Result<(), E> {
        let r = self.reading;
        match (result, r.outcome.get()) {
            (Ok(()), Some(Outcome::Read)) => Ok(()),
            (Ok(()), Some(Outcome::Stopped)) => {
                r.index.borrow_mut().empty.insert(path);
                Ok(())
            }
            (Err(e), Some(Outcome::Scalar | Outcome::Stopped)) => {
                let pos = position_in(&e.to_string());
                r.index.borrow_mut().nodes.entry(path).or_insert(pos);
                Ok(())
            }
            (Err(e), _) => Err(e),
            (Ok(()), _) => Err(E::custom(MISS)),
        }
    }

    fn below(&self, seg: Seg) -> Node<'_, '_> {
        let mut path = self.path.clone();
        path.push(seg);
        Node {
            path,
            depth: self.depth + 1,
            reading: self.reading,
        }
    }

    fn scalar<E: de::Error>(&self) -> Result<(), E> {
        self.reading.outcome.set(Some(Outcome::Scalar));
        Err(E::custom(HIT))
    }

    /// Whether a collection here is left unread, for the reader to give its position.
    fn stop_here(&self) -> bool {
        if self.depth == self.reading.level {
            self.reading.stopped.set(self.reading.stopped.get() + 1);
            self.reading.outcome.set(Some(Outcome::Stopped));
            true
        } else {
            false
        }
    }
}

impl<'de> DeserializeSeed<'de> for Node<'_, '_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

/// What the path-walking visitors below share: `expecting`, `visit_some` (an optional node is
/// walked as itself) and the scalar `visit_*` methods, where a scalar ends the walk and
/// `self.scalar()` says whether the path ended there.
macro_rules! scalar_visits {
    () => {
        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("any YAML node")
        }
        fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
            d.deserialize_any(self)
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
    };
}

impl<'de> Visitor<'de> for Node<'_, '_> {
    type Value = ();

    scalar_visits!();

    fn visit_enum<A: de::EnumAccess<'de>>(self, data: A) -> Result<(), A::Error> {
        // A tagged node (`!tag value`): the node under the tag.
        let (IgnoredAny, node) = data.variant::<IgnoredAny>()?;
        de::VariantAccess::newtype_variant_seed(node, self)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        if self.stop_here() {
            return Ok(());
        }
        let r = self.reading;
        let mut seen = HashSet::new();
        loop {
            r.outcome.set(None);
            *r.key.borrow_mut() = None;
            let key = match map.next_key_seed(Key(r)) {
                Ok(None) => break,
                // Not a string: no path names it (as for `exact`).
                Ok(Some(())) => None,
                Err(e) => match r.key.borrow_mut().take() {
                    Some(k) => {
                        let pos = position_in(&e.to_string());
                        let mut at = self.path.clone();
                        at.push(Seg::KeyItself(k.clone()));
                        r.index.borrow_mut().nodes.entry(at).or_insert(pos);
                        Some(k)
                    }
                    None => return Err(e),
                },
            };
            match key {
                // The first of equal keys is the one a path names.
                Some(k) if seen.insert(k.clone()) => {
                    let child = self.below(Seg::Key(k));
                    let path = child.path.clone();
                    r.outcome.set(None);
                    let result = map.next_value_seed(child);
                    self.child(path, result)?;
                }
                _ => {
                    map.next_value::<IgnoredAny>()?;
                }
            }
        }
        r.outcome.set(Some(Outcome::Read));
        Ok(())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        if self.stop_here() {
            return Ok(());
        }
        let r = self.reading;
        for i in 0.. {
            let child = self.below(Seg::Index(i));
            let path = child.path.clone();
            r.outcome.set(None);
            match seq.next_element_seed(child) {
                Ok(None) => break,
                Ok(Some(())) => self.child(path, Ok(()))?,
                Err(e) => self.child(path, Err(e))?,
            }
        }
        r.outcome.set(Some(Outcome::Read));
        Ok(())
    }
}

/// Reads a mapping key: a string fails with [`HIT`] (its position) after noting it; anything
/// else is read through.
struct Key<'r, 'i>(&'r Reading<'i>);

impl<'de> DeserializeSeed<'de> for Key<'_, '_> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Key<'_, '_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a mapping key")
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<(), E> {
        *self.0.key.borrow_mut() = Some(v.to_owned());
        Err(E::custom(HIT))
    }

    fn visit_bool<E: de::Error>(self, _: bool) -> Result<(), E> {
        Ok(())
    }

    fn visit_i64<E: de::Error>(self, _: i64) -> Result<(), E> {
        Ok(())
    }

    fn visit_u64<E: de::Error>(self, _: u64) -> Result<(), E> {
        Ok(())
    }

    fn visit_i128<E: de::Error>(self, _: i128) -> Result<(), E> {
        Ok(())
    }

    fn visit_u128<E: de::Error>(self, _: u128) -> Result<(), E> {
        Ok(())
    }

    fn visit_f64<E: de::Error>(self, _: f64) -> Result<(), E> {
        Ok(())
    }

    fn visit_unit<E: de::Error>(self) -> Result<(), E> {
        Ok(())
    }

    fn visit_none<E: de::Error>(self) -> Result<(), E> {
        Ok(())
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        while map.next_entry::<IgnoredAny, IgnoredAny>()?.is_some() {}
        Ok(())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        while seq.next_element::<IgnoredAny>()?.is_some() {}
        Ok(())
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

    scalar_visits!();

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

    /// Every position the index holds is the one the walk along its path finds, and every
    /// empty collection it names is one the walk finds.
    fn index_agrees_with_the_walk(text: &str) -> usize {
        let loc = Locator::new(text);
        let index = Index::build(text).0.expect("the text is indexed");
        for (path, &pos) in &index.nodes {
            assert_eq!(loc.exact(path), Some(pos), "{path:?} in\n{text}");
        }
        for path in &index.empty {
            assert!(loc.exact(path).is_some(), "{path:?} in\n{text}");
            assert!(!index.nodes.contains_key(path));
        }
        index.nodes.len()
    }

    #[test]
    fn the_index_holds_what_the_walk_finds() {
        assert!(index_agrees_with_the_walk(TEXT) > 30);
        // Flow inside block, nested sequences, empty collections, a duplicate key (the first
        // counts), non-string keys, anchors and aliases, block scalars, comments,
        // quoted keys, an explicit document start.
        let odd = "\
---
# a comment
a: [1, [2, 3], {x: [], y: {}}, []]
b:
- - deep
  - {p: q}
- &anchor {k: v, 'quoted key': \"w\"}
- *anchor
d: |
  text [ { not a collection
e: >-
  folded
f: 1
f: {again: 2}
1: one
true: yes
? complex
: value
\"g\": ~
h:
";
        assert!(index_agrees_with_the_walk(odd) > 25);
        let quickstart = include_str!("../../../examples/quickstart/project.yaml");
        assert!(index_agrees_with_the_walk(quickstart) > 60);
        // Every example project.
        let examples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
        let mut seen = 0;
        for dir in std::fs::read_dir(examples).unwrap() {
            let file = dir.unwrap().path().join("project.yaml");
            if let Ok(text) = std::fs::read_to_string(&file) {
                index_agrees_with_the_walk(&text);
                seen += 1;
            }
        }
        assert!(seen >= 5, "{seen} example projects");
        // Documents that are one scalar, one empty collection, nothing.
        index_agrees_with_the_walk("just a scalar\n");
        index_agrees_with_the_walk("[]\n");
        index_agrees_with_the_walk("");
        // Under a tag, where the walk finds nothing, the index still finds the nodes.
        let tagged = "a: 1\nc: !custom {t: 1}\n";
        let loc = Locator::new(tagged);
        assert_eq!(
            loc.exact(&[Seg::Key("c".into()), Seg::Key("t".into())]),
            None
        );
        assert_eq!(loc.position(&YPath::root().key("c").key("t")), (2, 16));
    }

    #[test]
    fn duplicates_and_empties_resolve_as_the_walk_does() {
        let text = "f: {a: 1}\nf: {b: 2}\ng: []\nh: {}\n";
        let r = YPath::root();
        let loc = Locator::new(text);
        // The second `f` is not where paths go; its `b` is not in the text for them.
        assert_eq!(loc.position(&r.key("f").key("b")), (1, 4));
        assert_eq!(loc.position(&r.key("f").key("a")), (1, 8));
        assert_eq!(loc.position(&r.key_itself("f")), (1, 1));
        assert_eq!(loc.position(&r.key("g").index(0)), (3, 4));
        assert_eq!(loc.position(&r.key("h").key("x")), (4, 4));
    }

    #[test]
    fn thousands_of_questions_cost_a_few_readings() {
        let mut text = String::from("tags:\n");
        for i in 0..5000 {
            text.push_str(&format!(
                "  - {{ name: \"bad-{i}\", type: u16, scada: {{}} }}\n"
            ));
        }
        let loc = Locator::new(&text);
        let r = YPath::root().key("tags");
        for i in 0..5000 {
            assert_eq!(loc.position(&r.index(i).key("name")), (i + 2, 13));
            assert_eq!(loc.position(&r.index(i).key("missing")), (i + 2, 5));
        }
        // The empty `scada: {}` of a few tags, each found by a walk of its own.
        for i in 0..3 {
            let at = loc.position(&r.index(i).key("scada").key("access"));
            assert_eq!(at, (i + 2, 40));
        }
        // One walk per question took minutes here (10,003 readings of the text); the index
        // takes one reading per level, plus one walk per empty collection asked about.
        assert!(loc.readings() <= 8, "{} readings", loc.readings());
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
