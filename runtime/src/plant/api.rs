//! The plant API a model's step calls: rates, lags, delays, edges, events, the seeded random
//! source and faults. Every helper reads the step's own context (its `dt`, its time), never a
//! clock, so a model is deterministic on the virtual clock.
//!
//! Helpers that remember (delays, edges) keep one memory per place in the file they are
//! called from, as a function block instance per call in a PLC language: the same line run
//! every step finds its own timer again.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};

use rand_chacha::rand_core::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rhai::{Dynamic, Engine, EvalAltResult, NativeCallContext, Position, FLOAT, INT};

use crate::logic::rhai::engine::{sandboxed, Deadline, Limits};

/// Operations one step may take: a model of a few dozen lines takes hundreds, so a runaway
/// loop is stopped long before it costs a scan's worth of time. Counted, not timed, so the
/// limit is the same on every machine.
pub(crate) const STEP_OPERATIONS: u64 = 200_000;

/// Variables a step may hold at once (declared names and its own `let`s).
const MAX_VARIABLES: usize = 1024;

/// A fault's switch and whether it is on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct FaultSwitch {
    pub(crate) name: String,
    pub(crate) on: bool,
}

/// What the helpers of one step see and remember.
#[derive(Debug)]
pub(crate) struct StepContext {
    /// The step, in whole milliseconds.
    pub(crate) step_ms: u64,
    /// Milliseconds since the model's start, at this step.
    pub(crate) time_ms: u64,
    /// Per call site (helper, line, column): a timer's elapsed seconds or an edge's last level.
    memory: HashMap<(&'static str, usize, usize), f64>,
    rng: ChaCha8Rng,
    /// The model's faults.
    pub(crate) faults: Vec<FaultSwitch>,
}

impl StepContext {
    pub(crate) fn new(step_ms: u64, seed: u64, faults: Vec<FaultSwitch>) -> Self {
        Self {
            step_ms,
            time_ms: 0,
            memory: HashMap::new(),
            rng: ChaCha8Rng::seed_from_u64(seed),
            faults,
        }
    }

    /// The step in seconds.
    pub(crate) fn dt(&self) -> FLOAT {
        self.step_ms as FLOAT / 1000.0
    }

    /// Seconds since the start.
    pub(crate) fn time(&self) -> FLOAT {
        self.time_ms as FLOAT / 1000.0
    }

    /// Switches fault `name`; false when the model has none of that name.
    pub(crate) fn switch(&mut self, name: &str, on: bool) -> bool {
        match self.faults.iter_mut().find(|f| f.name == name) {
            Some(f) => {
                f.on = on;
                true
            }
            None => false,
        }
    }

    /// The model's fault names, or `none`.
    pub(crate) fn fault_names(&self) -> String {
        if self.faults.is_empty() {
            return "none".into();
        }
        let names: Vec<&str> = self.faults.iter().map(|f| f.name.as_str()).collect();
        names.join(", ")
    }

    fn uniform(&mut self) -> FLOAT {
        // 53 random bits: every double in [0, 1) a multiple of 2^-53, equally likely.
        (self.rng.next_u64() >> 11) as FLOAT / (1u64 << 53) as FLOAT
    }

    fn memory(&mut self, helper: &'static str, at: Position, initial: f64) -> &mut f64 {
        let key = (helper, at.line().unwrap_or(0), at.position().unwrap_or(0));
        self.memory.entry(key).or_insert(initial)
    }
}

/// The context shared between a plant and its engine's helpers.
pub(crate) type Shared = Arc<Mutex<StepContext>>;

fn lock(ctx: &Shared) -> MutexGuard<'_, StepContext> {
    ctx.lock().unwrap_or_else(|p| p.into_inner())
}

type Res<T> = Result<T, Box<EvalAltResult>>;

/// A number argument (an integer or a float), or an error naming the helper and argument.
fn num(call: &NativeCallContext, v: &Dynamic, what: &str) -> Res<FLOAT> {
    if let Ok(x) = v.as_float() {
        return Ok(x);
    }
    if let Ok(i) = v.as_int() {
        return Ok(i as FLOAT);
    }
    Err(Box::new(EvalAltResult::ErrorRuntime(
        format!(
            "{}: {what} must be a number, not {}",
            call.fn_name(),
            v.type_name()
        )
        .into(),
        call.call_position(),
    )))
}

/// The sandboxed engine of a model: the program engine's packages and limits (no I/O, no
/// clock), no deadline (a step's cost is bounded by counting), and the plant API bound to
/// `ctx`.
pub(crate) fn engine(ctx: &Shared) -> Engine {
    let limits = Limits {
        operations: STEP_OPERATIONS,
        ..Limits::default()
    };
    // A deadline never armed never passes: the operation count alone bounds a step.
    let mut engine = sandboxed(limits, MAX_VARIABLES, &Deadline::new());
    register_math(&mut engine);
    register_memory(&mut engine, ctx);
    register_random(&mut engine, ctx);
    register_faults(&mut engine, ctx);
    engine
}

fn register_math(engine: &mut Engine) {
    engine.register_fn(
        "clamp",
        |call: NativeCallContext, x: Dynamic, lo: Dynamic, hi: Dynamic| -> Res<FLOAT> {
            Ok(num(&call, &x, "the value")?.clamp(
                num(&call, &lo, "min")?,
                num(&call, &hi, "max")?.max(num(&call, &lo, "min")?),
            ))
        },
    );
}

fn register_memory(engine: &mut Engine, ctx: &Shared) {
    let c = ctx.clone();
    engine.register_fn(
        "ramp",
        move |call: NativeCallContext, x: Dynamic, per_s: Dynamic| -> Res<FLOAT> {
            Ok(num(&call, &x, "the value")? + num(&call, &per_s, "the rate")? * lock(&c).dt())
        },
    );
    let c = ctx.clone();
    engine.register_fn(
        "ramp",
        move |call: NativeCallContext,
              x: Dynamic,
              per_s: Dynamic,
              lo: Dynamic,
              hi: Dynamic|
              -> Res<FLOAT> {
            let v = num(&call, &x, "the value")? + num(&call, &per_s, "the rate")? * lock(&c).dt();
            let (lo, hi) = (num(&call, &lo, "min")?, num(&call, &hi, "max")?);
            Ok(v.clamp(lo, hi.max(lo)))
        },
    );
    let c = ctx.clone();
    engine.register_fn(
        "lag",
        move |call: NativeCallContext, x: Dynamic, target: Dynamic, tau: Dynamic| -> Res<FLOAT> {
            let (x, target, tau) = (
                num(&call, &x, "the value")?,
                num(&call, &target, "the target")?,
                num(&call, &tau, "the time constant")?,
            );
            if tau <= 0.0 {
                return Ok(target);
            }
            // The exact response of a first-order lag over one step, stable for any dt.
            Ok(x + (target - x) * (1.0 - (-lock(&c).dt() / tau).exp()))
        },
    );
    let c = ctx.clone();
    engine.register_fn(
        "on_delay",
        move |call: NativeCallContext, cond: bool, secs: Dynamic| -> Res<bool> {
            let secs = num(&call, &secs, "the delay")?;
            let mut ctx = lock(&c);
            let dt = ctx.dt();
            let elapsed = ctx.memory("on_delay", call.call_position(), 0.0);
            if !cond {
                *elapsed = 0.0;
                return Ok(false);
            }
            // On `secs` after the first step that saw the condition; half a step of slack, so
            // a delay of whole steps is not lost to rounding.
            let on = *elapsed + dt / 2.0 >= secs;
            *elapsed += dt;
            Ok(on)
        },
    );
    let c = ctx.clone();
    engine.register_fn(
        "off_delay",
        move |call: NativeCallContext, cond: bool, secs: Dynamic| -> Res<bool> {
            let secs = num(&call, &secs, "the delay")?;
            let mut ctx = lock(&c);
            let dt = ctx.dt();
            // Starts expired: a condition false from the start gives false.
            let since = ctx.memory("off_delay", call.call_position(), f64::INFINITY);
            if cond {
                *since = 0.0;
                return Ok(true);
            }
            // Off `secs` after the first step that saw the condition gone.
            let on = *since + dt / 2.0 < secs;
            *since += dt;
            Ok(on)
        },
    );
    for (name, rising) in [("rising", true), ("falling", false)] {
        let c = ctx.clone();
        engine.register_fn(name, move |call: NativeCallContext, cond: bool| -> bool {
            let mut ctx = lock(&c);
            let last = ctx.memory(
                if rising { "rising" } else { "falling" },
                call.call_position(),
                0.0,
            );
            let was = *last != 0.0;
            *last = if cond { 1.0 } else { 0.0 };
            if rising {
                cond && !was
            } else {
                !cond && was
            }
        });
    }
    let c = ctx.clone();
    engine.register_fn(
        "every",
        move |call: NativeCallContext, secs: Dynamic| -> Res<bool> {
            let period_ms = (num(&call, &secs, "the period")? * 1000.0).round();
            if period_ms < 1.0 {
                return Err(Box::new(EvalAltResult::ErrorRuntime(
                    "every: the period must be 1 ms or more".into(),
                    call.call_position(),
                )));
            }
            let ctx = lock(&c);
            // Counted in whole milliseconds: a period is never lost to float rounding.
            let period = period_ms as u64;
            Ok(ctx.time_ms > 0 && ctx.time_ms % period < ctx.step_ms)
        },
    );
}

fn register_random(engine: &mut Engine, ctx: &Shared) {
    let c = ctx.clone();
    engine.register_fn("random", move || -> FLOAT { lock(&c).uniform() });
    let c = ctx.clone();
    engine.register_fn(
        "random",
        move |call: NativeCallContext, lo: Dynamic, hi: Dynamic| -> Res<FLOAT> {
            let (lo, hi) = (num(&call, &lo, "min")?, num(&call, &hi, "max")?);
            Ok(lo + (hi - lo) * lock(&c).uniform())
        },
    );
    let c = ctx.clone();
    engine.register_fn(
        "noise",
        move |call: NativeCallContext, amplitude: Dynamic| -> Res<FLOAT> {
            let a = num(&call, &amplitude, "the amplitude")?;
            Ok(a * (2.0 * lock(&c).uniform() - 1.0))
        },
    );
    let c = ctx.clone();
    engine.register_fn(
        "chance",
        move |call: NativeCallContext, per_second: Dynamic| -> Res<bool> {
            // A rate per second, so the same model gives the same odds at any step.
            let rate = num(&call, &per_second, "the rate")?;
            let mut ctx = lock(&c);
            let p = rate * ctx.dt();
            Ok(ctx.uniform() < p)
        },
    );
    engine.register_fn("random_int", {
        let c = ctx.clone();
        move |lo: INT, hi: INT| -> INT {
            let span = hi.saturating_sub(lo).max(0) as u64 + 1;
            lo.saturating_add((lock(&c).rng.next_u64() % span) as INT)
        }
    });
}

fn register_faults(engine: &mut Engine, ctx: &Shared) {
    let unknown = |call: &NativeCallContext, name: &str, ctx: &StepContext| {
        Box::new(EvalAltResult::ErrorRuntime(
            format!(
                "unknown fault \"{name}\" (its faults: {})",
                ctx.fault_names()
            )
            .into(),
            call.call_position(),
        ))
    };
    let c = ctx.clone();
    engine.register_fn(
        "fault",
        move |call: NativeCallContext, name: &str| -> Res<bool> {
            let ctx = lock(&c);
            match ctx.faults.iter().find(|f| f.name == name) {
                Some(f) => Ok(f.on),
                None => Err(unknown(&call, name, &ctx)),
            }
        },
    );
    for (fname, on) in [("inject", true), ("repair", false)] {
        let c = ctx.clone();
        engine.register_fn(
            fname,
            move |call: NativeCallContext, name: &str| -> Res<()> {
                let mut ctx = lock(&c);
                if ctx.switch(name, on) {
                    Ok(())
                } else {
                    Err(unknown(&call, name, &ctx))
                }
            },
        );
    }
}
