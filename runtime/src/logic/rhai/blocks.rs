//! The function-block library as Rhai functions, instance state keyed by name.
//!
//! `ton("jam", motor && !box_out, "10s")` calls the TON instance `jam` (created on its first
//! call) and returns its Q; `q("jam")`, `et("jam")` (ms), `cv(..)`, `qu(..)`, `qd(..)` read the
//! outputs anywhere. Times are milliseconds (integer or float) or duration strings ("1.5s").
//!
//! Instances live in slots. A call whose instance name is a literal (`ton("jam", ..)`, the
//! usual form) is resolved when the script is compiled: its position in the script gives the
//! slot (a binary search over integers, checked against the name the call passes), so no name
//! is hashed during the scan. Any other call (a name in a variable) finds its slot by name.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rhai::{Dynamic, Engine, EvalAltResult, ImmutableString, NativeCallContext, Position, INT};

use crate::logic::blocks::{from_millis, Instance, Kind, Member, Pattern};

/// Most instances a script may create (names made in a loop must not eat the memory).
pub const MAX_INSTANCES: usize = 10_000;

/// Every block instance of a script, and the scan's time.
#[derive(Debug, Default)]
pub(crate) struct Blocks {
    pub now: Duration,
    /// Instances by slot, each created on its first call.
    slots: Vec<Option<Instance>>,
    /// The instance name of each slot.
    names: Vec<ImmutableString>,
    /// Slot by instance name.
    by_name: HashMap<String, usize>,
    /// Call sites resolved at compile time: `(line, column)` of the call → slot, sorted.
    sites: Vec<((usize, usize), usize)>,
    /// Instances created.
    created: usize,
}

/// The shared handle the registered functions hold.
pub(crate) type SharedBlocks = Arc<Mutex<Blocks>>;

type Res<T> = Result<T, Box<EvalAltResult>>;

fn error<T>(text: String) -> Res<T> {
    Err(text.into())
}

fn lock(blocks: &Mutex<Blocks>) -> MutexGuard<'_, Blocks> {
    // A panic cannot happen while the lock is held (the closures below do not panic); recover
    // anyway rather than propagate a poison.
    blocks.lock().unwrap_or_else(|p| p.into_inner())
}

/// A position as a sortable key.
fn key(pos: Position) -> (usize, usize) {
    (pos.line().unwrap_or(0), pos.position().unwrap_or(0))
}

impl Blocks {
    /// Resolves the calls with a literal instance name: `(call position, instance name)`.
    pub(crate) fn resolve(&mut self, calls: &[(Position, String)]) {
        for (pos, name) in calls {
            let slot = self.slot_named(name);
            self.sites.push((key(*pos), slot));
        }
        self.sites.sort_unstable();
        self.sites.dedup_by_key(|s| s.0);
    }

    /// The slot of instance `name`, a new (empty) one if the name is new.
    fn slot_named(&mut self, name: &str) -> usize {
        if let Some(&slot) = self.by_name.get(name) {
            return slot;
        }
        let slot = self.slots.len();
        self.slots.push(None);
        self.names.push(name.into());
        self.by_name.insert(name.to_string(), slot);
        slot
    }

    /// The slot of instance `name` called or read at `at`: the resolved one, or by name.
    fn slot(&self, at: Position, name: &str) -> Option<usize> {
        if let Ok(i) = self.sites.binary_search_by_key(&key(at), |s| s.0) {
            let slot = self.sites[i].1;
            if self.names.get(slot).is_some_and(|n| n.as_str() == name) {
                return Some(slot);
            }
        }
        self.by_name.get(name).copied()
    }

    /// The instance called `name`, if it was ever called.
    #[cfg(test)]
    pub(crate) fn named(&self, name: &str) -> Option<&Instance> {
        self.slots.get(*self.by_name.get(name)?)?.as_ref()
    }

    /// The instance `name` read at `at`, if it was ever called.
    fn find(&self, at: Position, name: &str) -> Option<&Instance> {
        self.slots.get(self.slot(at, name)?)?.as_ref()
    }
}

/// Runs `f` on instance `name` of `kind`, called at `at`, creating it on first use.
fn with<T>(
    blocks: &Mutex<Blocks>,
    at: Position,
    name: &str,
    kind: Kind,
    f: impl FnOnce(&mut Instance, Duration) -> T,
) -> Res<T> {
    let mut b = lock(blocks);
    let now = b.now;
    let slot = match b.slot(at, name) {
        Some(slot) => slot,
        None if b.created >= MAX_INSTANCES => {
            return error(format!("more than {MAX_INSTANCES} block instances"));
        }
        None => b.slot_named(name),
    };
    if b.slots.get(slot).is_some_and(Option::is_none) {
        if b.created >= MAX_INSTANCES {
            return error(format!("more than {MAX_INSTANCES} block instances"));
        }
        b.slots[slot] = Some(Instance::new(kind));
        b.created += 1;
    }
    match b.slots.get_mut(slot).and_then(Option::as_mut) {
        Some(inst) if inst.kind() == kind => Ok(f(inst, now)),
        Some(inst) => error(format!(
            "instance \"{name}\" is a {}; it cannot be called as {kind}",
            inst.kind()
        )),
        None => error(format!("instance \"{name}\" vanished")),
    }
}

/// A time argument: milliseconds (INT or FLOAT) or a duration string.
fn time(v: &Dynamic) -> Res<Duration> {
    if let Ok(ms) = v.as_int() {
        return Ok(from_millis(ms as f64));
    }
    if let Ok(ms) = v.as_float() {
        return Ok(from_millis(ms));
    }
    if let Some(s) = v.clone().try_cast::<ImmutableString>() {
        return crate::project::parse_duration(&s).or_else(|e| {
            error(format!(
                "bad duration \"{s}\": {e}; write e.g. \"500ms\", \"2s\" or a number of ms"
            ))
        });
    }
    error(format!(
        "a time is a number of milliseconds or a string like \"2s\", not {}",
        v.type_name()
    ))
}

/// A preset value, saturated into `i32`.
fn preset(pv: INT) -> i32 {
    pv.clamp(INT::from(i32::MIN), INT::from(i32::MAX)) as i32
}

/// The kinds as Rhai names them, and the output readers.
pub(crate) const FUNCTIONS: [(&str, Kind); 14] = [
    ("ton", Kind::Ton),
    ("tof", Kind::Tof),
    ("tp", Kind::Tp),
    ("stair", Kind::Stair),
    ("ctu", Kind::Ctu),
    ("ctd", Kind::Ctd),
    ("ctud", Kind::Ctud),
    ("r_trig", Kind::RTrig),
    ("f_trig", Kind::FTrig),
    ("sr", Kind::Sr),
    ("rs", Kind::Rs),
    ("toggle", Kind::Toggle),
    ("blink", Kind::Blink),
    ("blink_pattern", Kind::Blink),
];

/// The output readers.
pub(crate) const READERS: [&str; 5] = ["q", "et", "cv", "qu", "qd"];

/// Registers every block function on `engine`, over `blocks`.
pub(crate) fn register(engine: &mut Engine, blocks: &SharedBlocks) {
    macro_rules! timer {
        ($name:literal, $variant:ident) => {{
            let b = blocks.clone();
            engine.register_fn(
                $name,
                move |ctx: NativeCallContext, n: ImmutableString, x: bool, pt: Dynamic| {
                    let pt = time(&pt)?;
                    with(
                        &b,
                        ctx.call_position(),
                        &n,
                        Kind::$variant,
                        |i, now| match i {
                            Instance::$variant(t) => t.call(x, pt, now),
                            _ => false,
                        },
                    )
                },
            );
        }};
    }
    timer!("ton", Ton);
    timer!("tof", Tof);
    timer!("tp", Tp);

    let b = blocks.clone();
    engine.register_fn(
        "stair",
        move |ctx: NativeCallContext, n: ImmutableString, x: bool, pt: Dynamic, reset: bool| {
            let pt = time(&pt)?;
            with(&b, ctx.call_position(), &n, Kind::Stair, |i, now| match i {
                Instance::Stair(t) => t.call(x, reset, pt, now),
                _ => false,
            })
        },
    );
    let b = blocks.clone();
    engine.register_fn(
        "stair",
        move |ctx: NativeCallContext, n: ImmutableString, x: bool, pt: Dynamic| {
            let pt = time(&pt)?;
            with(&b, ctx.call_position(), &n, Kind::Stair, |i, now| match i {
                Instance::Stair(t) => t.call(x, false, pt, now),
                _ => false,
            })
        },
    );

    let b = blocks.clone();
    engine.register_fn(
        "ctu",
        move |ctx: NativeCallContext, n: ImmutableString, cu: bool, reset: bool, pv: INT| {
            with(&b, ctx.call_position(), &n, Kind::Ctu, |i, _| match i {
                Instance::Ctu(c) => c.call(cu, reset, preset(pv)),
                _ => false,
            })
        },
    );
    let b = blocks.clone();
    engine.register_fn(
        "ctd",
        move |ctx: NativeCallContext, n: ImmutableString, cd: bool, load: bool, pv: INT| {
            with(&b, ctx.call_position(), &n, Kind::Ctd, |i, _| match i {
                Instance::Ctd(c) => c.call(cd, load, preset(pv)),
                _ => false,
            })
        },
    );
    let b = blocks.clone();
    engine.register_fn(
        "ctud",
        move |ctx: NativeCallContext,
              n: ImmutableString,
              cu: bool,
              cd: bool,
              reset: bool,
              load: bool,
              pv: INT| {
            with(&b, ctx.call_position(), &n, Kind::Ctud, |i, _| match i {
                Instance::Ctud(c) => c.call(cu, cd, reset, load, preset(pv)),
                _ => false,
            })
        },
    );

    let b = blocks.clone();
    engine.register_fn(
        "r_trig",
        move |ctx: NativeCallContext, n: ImmutableString, x: bool| {
            with(&b, ctx.call_position(), &n, Kind::RTrig, |i, _| match i {
                Instance::RTrig(e) => e.rising(x),
                _ => false,
            })
        },
    );
    let b = blocks.clone();
    engine.register_fn(
        "f_trig",
        move |ctx: NativeCallContext, n: ImmutableString, x: bool| {
            with(&b, ctx.call_position(), &n, Kind::FTrig, |i, _| match i {
                Instance::FTrig(e) => e.falling(x),
                _ => false,
            })
        },
    );

    macro_rules! latch {
        ($name:literal, $variant:ident) => {{
            let b = blocks.clone();
            engine.register_fn(
                $name,
                move |ctx: NativeCallContext, n: ImmutableString, s: bool, r: bool| {
                    with(
                        &b,
                        ctx.call_position(),
                        &n,
                        Kind::$variant,
                        |i, _| match i {
                            Instance::$variant(l) => l.call(s, r),
                            _ => false,
                        },
                    )
                },
            );
        }};
    }
    latch!("sr", Sr);
    latch!("rs", Rs);
    latch!("toggle", Toggle);
    let b = blocks.clone();
    engine.register_fn(
        "toggle",
        move |ctx: NativeCallContext, n: ImmutableString, x: bool| {
            with(&b, ctx.call_position(), &n, Kind::Toggle, |i, _| match i {
                Instance::Toggle(l) => l.call(x, false),
                _ => false,
            })
        },
    );

    let b = blocks.clone();
    engine.register_fn(
        "blink",
        move |ctx: NativeCallContext, n: ImmutableString, en: bool, on: Dynamic, off: Dynamic| {
            let (on, off) = (time(&on)?, time(&off)?);
            with(&b, ctx.call_position(), &n, Kind::Blink, |i, now| match i {
                Instance::Blink(bl) => bl.call(en, on, off, now),
                _ => false,
            })
        },
    );
    let b = blocks.clone();
    engine.register_fn(
        "blink_pattern",
        move |ctx: NativeCallContext,
              n: ImmutableString,
              en: bool,
              bits: ImmutableString,
              step: Dynamic| {
            let step = time(&step)?;
            let pattern = match Pattern::parse(&bits) {
                Ok(p) => p,
                Err(e) => return error(format!("bad pattern \"{bits}\": {e}")),
            };
            with(&b, ctx.call_position(), &n, Kind::Blink, |i, now| match i {
                Instance::Blink(bl) => bl.call_pattern(en, pattern, step, now),
                _ => false,
            })
        },
    );

    // Outputs: a fresh (never called) instance reads false / 0.
    let b = blocks.clone();
    engine.register_fn(
        "q",
        move |ctx: NativeCallContext, n: ImmutableString| -> bool {
            let b = lock(&b);
            b.find(ctx.call_position(), &n).is_some_and(|i| {
                let m = i.kind().main_output();
                i.bool_output(if m == Member::Qu {
                    Member::Qu
                } else {
                    Member::Q
                })
            })
        },
    );
    for (name, member) in [("qu", Member::Qu), ("qd", Member::Qd)] {
        let b = blocks.clone();
        engine.register_fn(
            name,
            move |ctx: NativeCallContext, n: ImmutableString| -> bool {
                lock(&b)
                    .find(ctx.call_position(), &n)
                    .is_some_and(|i| i.bool_output(member))
            },
        );
    }
    for (name, member) in [("et", Member::Et), ("cv", Member::Cv)] {
        let b = blocks.clone();
        engine.register_fn(
            name,
            move |ctx: NativeCallContext, n: ImmutableString| -> INT {
                lock(&b)
                    .find(ctx.call_position(), &n)
                    .map_or(0, |i| i.number_output(member) as INT)
            },
        );
    }

    engine.register_fn("limit", |mn: INT, x: INT, mx: INT| x.max(mn).min(mx));
    engine.register_fn("limit", |mn: f64, x: f64, mx: f64| x.max(mn).min(mx));
}
