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

use std::any::TypeId;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rhai::{Dynamic, Engine, EvalAltResult, ImmutableString, NativeCallContext, Position, INT};

use crate::logic::blocks::{
    from_millis, Arg, Args, BlockDef, Form, Instance, Kind, Member, Pattern, PinType,
};

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

/// The block function `name` (`ton`, `blink_pattern`): its block and form.
pub(crate) fn block_function(name: &str) -> Option<(&'static BlockDef, &'static Form)> {
    Kind::ALL.iter().find_map(|k| {
        let def = k.def();
        def.forms.iter().find(|f| f.rhai == name).map(|f| (def, f))
    })
}

/// The output readers.
pub(crate) const READERS: [&str; 5] = ["q", "et", "cv", "qu", "qd"];

/// The type Rhai passes for a pin of type `ty` (a time is any value: a number or a string).
fn type_of(ty: PinType) -> TypeId {
    match ty {
        PinType::Bool => TypeId::of::<bool>(),
        PinType::Time => TypeId::of::<Dynamic>(),
        PinType::Count | PinType::Mask => TypeId::of::<INT>(),
        PinType::Pattern => TypeId::of::<ImmutableString>(),
    }
}

/// One call's arguments (after the instance's name) as the block's pins: times first, then
/// patterns, so a call with both wrong reports its time.
fn pin_args(def: &BlockDef, pins: &[usize], values: &[&mut Dynamic]) -> Res<Args> {
    let mut args = Args::default();
    let given = || {
        pins.iter()
            .zip(values)
            .filter_map(|(&i, v)| Some((i, def.pins.get(i)?, v)))
    };
    for (i, pin, v) in given() {
        let arg = match pin.ty {
            PinType::Bool => Arg::Bool(v.as_bool().unwrap_or(false)),
            PinType::Count | PinType::Mask => Arg::Count(preset(v.as_int().unwrap_or(0))),
            PinType::Time => Arg::Time(time(v)?),
            PinType::Pattern => continue,
        };
        args.0[i] = arg;
    }
    for (i, pin, v) in given() {
        if pin.ty == PinType::Pattern {
            let bits = (**v).clone().into_immutable_string().unwrap_or_default();
            match Pattern::parse(&bits) {
                Ok(p) => args.0[i] = Arg::Pattern(p),
                Err(e) => return error(format!("bad pattern \"{bits}\": {e}")),
            }
        }
    }
    Ok(args)
}

/// Registers every block function on `engine`, over `blocks`: each form of each block, and
/// each shorter overload where the form's last pins are optional.
pub(crate) fn register(engine: &mut Engine, blocks: &SharedBlocks) {
    for kind in Kind::ALL {
        let def = kind.def();
        for form in def.forms {
            for pins in form.overloads() {
                let mut types = vec![TypeId::of::<ImmutableString>()];
                types.extend(
                    pins.iter()
                        .filter_map(|&i| def.pins.get(i))
                        .map(|p| type_of(p.ty)),
                );
                let b = blocks.clone();
                engine.register_raw_fn(
                    form.rhai,
                    types,
                    move |ctx: NativeCallContext, values: &mut [&mut Dynamic]| -> Res<bool> {
                        let Some((name, values)) = values.split_first_mut() else {
                            return error("a block call without an instance name".into());
                        };
                        let name = name.clone().into_immutable_string().unwrap_or_default();
                        let args = pin_args(def, pins, values)?;
                        with(&b, ctx.call_position(), &name, kind, |i, now| {
                            i.call(&args, now)
                        })
                    },
                );
            }
        }
    }

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
