//! Blocks of one's own as Rhai functions: `station("s1", enable, start, stop)` calls the
//! declared instance `s1` of block STATION with its inputs in the block's order (inputs with a
//! `default:` may be left out at the end) and returns its main output. The checker holds each
//! call against the block ([`OwnSignature`]): the number of arguments, the instance's name, and
//! the type of every argument whose type shows without running the script.

use std::any::TypeId;
use std::sync::{Arc, Mutex, MutexGuard};

use rhai::{Dynamic, Engine, EvalAltResult, ImmutableString};
use softplc_io::point::{Value, ValueType};

use crate::image::ProcessImage;
use crate::logic::user_blocks::{OwnBlocks, UserInstance};
use crate::logic::ScanContext;

type Res<T> = Result<T, Box<EvalAltResult>>;

/// The instances a script calls, and the scan it is in.
#[derive(Debug)]
pub(crate) struct OwnCalls {
    instances: Vec<UserInstance>,
    ctx: Option<ScanContext>,
}

/// The handle the registered functions hold.
pub(crate) type SharedOwn = Arc<Mutex<OwnCalls>>;

fn lock(own: &Mutex<OwnCalls>) -> MutexGuard<'_, OwnCalls> {
    // The closures below do not panic while holding it; recover anyway.
    own.lock().unwrap_or_else(|p| p.into_inner())
}

/// What the checker holds a call of a block of one's own against.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OwnSignature {
    /// The Rhai function (`station`).
    pub function: String,
    /// The block (`STATION`).
    pub block: String,
    /// Its inputs, in order.
    pub inputs: Vec<(String, ValueType)>,
    /// How many inputs a call must give (those before the first optional one at the end).
    pub required: usize,
    /// The instances the project declares of it.
    pub instances: Vec<String>,
    /// Its variables: inputs, outputs, state, then its nested instances' (`la.on`).
    pub vars: Vec<String>,
}

/// The function reading any variable of an instance: `output("s1", "done")`.
pub(crate) const OUTPUT: &str = "output";

impl OwnSignature {
    /// `station(name, enable, start, stop[, fill_ms])`.
    pub(crate) fn usage(&self) -> String {
        let mut text = format!("{}(name", self.function);
        for (i, (name, _)) in self.inputs.iter().enumerate() {
            if i == self.required {
                text.push('[');
            }
            text.push_str(", ");
            text.push_str(name);
        }
        if self.required < self.inputs.len() {
            text.push(']');
        }
        text.push(')');
        text
    }
}

/// The signatures of `own`'s blocks.
pub(crate) fn signatures(own: &OwnBlocks) -> Vec<OwnSignature> {
    own.blocks
        .iter()
        .enumerate()
        .map(|(b, block)| {
            let optional = block.inputs.iter().rev().take_while(|v| v.optional).count();
            OwnSignature {
                function: block.function(),
                block: block.name.clone(),
                inputs: block
                    .inputs
                    .iter()
                    .map(|v| (v.name.clone(), v.ty))
                    .collect(),
                required: block.inputs.len() - optional,
                instances: own
                    .declared
                    .iter()
                    .filter(|(_, of)| *of == b)
                    .map(|(n, _)| n.clone())
                    .collect(),
                // Its nested instances' too (`la.on`), as the instance holds them.
                vars: block
                    .tree(&own.blocks)
                    .into_iter()
                    .map(|v| v.name)
                    .collect(),
            }
        })
        .collect()
}

/// Registers a function per block of `own` (an overload per number of inputs a call may
/// give) over its instances, which the returned handle keeps.
pub(crate) fn register(engine: &mut Engine, own: &mut OwnBlocks) -> SharedOwn {
    let sigs = signatures(own);
    let shared: SharedOwn = Arc::new(Mutex::new(OwnCalls {
        instances: own.take_instances(),
        ctx: None,
    }));
    {
        let shared = shared.clone();
        engine.register_fn(
            OUTPUT,
            move |instance: ImmutableString, var: ImmutableString| -> Res<Dynamic> {
                let own = lock(&shared);
                let Some(inst) = own.instances.iter().find(|i| i.name() == instance.as_str())
                else {
                    return Err(format!("output(): no instance \"{instance}\" is declared").into());
                };
                match inst.var(&var) {
                    Some(Value::Bool(b)) => Ok(Dynamic::from_bool(b)),
                    Some(Value::U16(x)) => Ok(Dynamic::from_int(x.into())),
                    Some(Value::I32(x)) => Ok(Dynamic::from_int(x.into())),
                    Some(Value::F32(x)) => Ok(Dynamic::from_float(x.into())),
                    None => {
                        Err(format!("output(): instance \"{instance}\" has no \"{var}\"").into())
                    }
                }
            },
        );
    }
    for (b, sig) in sigs.into_iter().enumerate() {
        let block = own.blocks.get(b).cloned();
        for given in sig.required..=sig.inputs.len() {
            let types = vec![TypeId::of::<Dynamic>(); given + 1];
            let shared = shared.clone();
            let sig = sig.clone();
            let block = block.clone();
            engine.register_raw_fn(
                sig.function.clone(),
                types,
                move |_ctx, values: &mut [&mut Dynamic]| -> Res<bool> {
                    let Some((name, values)) = values.split_first_mut() else {
                        return Err("a block call without an instance name".into());
                    };
                    let Some(name) = name.clone().try_cast::<ImmutableString>() else {
                        return Err(format!(
                            "{}(): the first argument is the instance's name, a string, not {}",
                            sig.function,
                            name.type_name()
                        )
                        .into());
                    };
                    let mut own = lock(&shared);
                    let Some(ctx) = own.ctx else {
                        return Err("a block called outside a scan".into());
                    };
                    let Some(inst) = own.instances.iter_mut().find(|i| i.name() == name.as_str())
                    else {
                        return Err(format!(
                            "{}(): no instance \"{name}\" of {} is declared (the project's instances: {})",
                            sig.function,
                            sig.block,
                            sig.instances.join(", ")
                        )
                        .into());
                    };
                    for (i, (input, ty)) in sig.inputs.iter().enumerate() {
                        let value = match values.get(i) {
                            Some(v) => number(v, *ty).ok_or_else(|| {
                                format!(
                                    "argument `{input}` of {}() is a {ty}, not {}",
                                    sig.function,
                                    v.type_name()
                                )
                            })?,
                            None => block
                                .as_ref()
                                .map_or(0.0, |b| crate::logic::user_blocks::default_of(b, i)),
                        };
                        inst.set_input(i, value, &ctx);
                    }
                    inst.run_body(&ctx).map_err(|f| f.to_string().into())
                },
            );
        }
    }
    shared
}

/// A script's value as an input of type `ty`: a bool for a bool, an integer or a float for a
/// number.
fn number(v: &Dynamic, ty: ValueType) -> Option<f64> {
    match ty {
        ValueType::Bool => v.as_bool().ok().map(|b| f64::from(u8::from(b))),
        _ => v.as_int().map(|i| i as f64).or_else(|_| v.as_float()).ok(),
    }
}

/// Before the script: the scan the calls run in; an instance not run yet takes its outputs and
/// state from its tags; every instance takes the forces on its tags (the calls run where the
/// image cannot be reached).
pub(crate) fn begin(own: &SharedOwn, image: &ProcessImage, ctx: &ScanContext) {
    let mut own = lock(own);
    own.ctx = Some(*ctx);
    for inst in &mut own.instances {
        inst.adopt(image, ctx);
        inst.follow_forces(image, ctx);
    }
}

/// After the script: every instance's variables into the project's tags.
pub(crate) fn publish(own: &SharedOwn, image: &mut ProcessImage, ctx: &ScanContext) {
    for inst in &lock(own).instances {
        inst.publish(image, ctx);
    }
}
