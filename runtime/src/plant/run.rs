//! A model running in the simulated world: its step every `step` of the world's time, the
//! terminals in and out by value, and the error path (the model stops, its terminals hold,
//! the PLC runs on).

use std::sync::{Arc, Mutex};
use std::time::Duration;

use rhai::{Dynamic, Engine, Scope, AST, FLOAT, INT};
use softplc_io::point::{Value, ValueType};
use softplc_io::sim::plant::{FaultSwitchError, Plant, PlantHealth, PlantIo, StateValue};
use softplc_io::time::LineInstant;

use super::api::{self, FaultSwitch, Shared, StepContext};
use super::decl::{FaultDecl, StateDecl, RESERVED};
use super::error::RunError;
use super::model::{initial, PlantModel};

/// A driven terminal: its name, the point's type and the value the model last gave it.
#[derive(Debug)]
struct Driven {
    name: String,
    ty: ValueType,
    value: Dynamic,
}

/// A model running in the simulated world.
#[derive(Debug)]
pub struct RhaiPlant {
    name: String,
    file: String,
    engine: Engine,
    ast: Arc<AST>,
    ctx: Shared,
    reads: Vec<String>,
    driven: Vec<Driven>,
    states: Vec<(StateDecl, Dynamic)>,
    timed_faults: Vec<FaultDecl>,
    step: Duration,
    steps: u64,
    next: Option<LineInstant>,
    health: PlantHealth,
}

impl RhaiPlant {
    pub(crate) fn new(
        model: &PlantModel,
        ast: Arc<AST>,
        drive_types: Vec<ValueType>,
        seed: u64,
    ) -> Self {
        let d = &model.decl;
        let faults = d
            .faults
            .iter()
            .map(|f| FaultSwitch {
                name: f.name.clone(),
                on: false,
            })
            .collect();
        let step_ms = d.step.as_millis() as u64;
        let ctx = Arc::new(Mutex::new(StepContext::new(step_ms, seed, faults)));
        let driven = d
            .drives
            .iter()
            .zip(
                drive_types
                    .into_iter()
                    .chain(std::iter::repeat(ValueType::Bool)),
            )
            .map(|(name, ty)| Driven {
                name: name.clone(),
                ty,
                value: zero(ty),
            })
            .collect();
        Self {
            name: model.name.clone(),
            file: model.file.display().to_string(),
            engine: api::engine(&ctx),
            ast,
            ctx,
            reads: d.reads.clone(),
            driven,
            states: d
                .states
                .iter()
                .map(|s| (s.clone(), initial(s.initial)))
                .collect(),
            timed_faults: d
                .faults
                .iter()
                .filter(|f| f.at.is_some())
                .cloned()
                .collect(),
            step: d.step,
            steps: 0,
            next: None,
            health: PlantHealth::Running,
        }
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Steps run so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Runs one step; an error stops the model.
    fn run_step(&mut self, io: &mut dyn PlantIo) -> Result<(), (Option<(usize, usize)>, RunError)> {
        let elapsed = Duration::from_millis(self.steps * self.step.as_millis() as u64);
        let (dt, time) = {
            let mut ctx = self.ctx.lock().unwrap_or_else(|p| p.into_inner());
            ctx.time_ms = elapsed.as_millis() as u64;
            for f in &self.timed_faults {
                // Injected once, on the step its time comes: a scenario may repair it after.
                if f.at
                    .is_some_and(|at| at <= elapsed && at + self.step > elapsed)
                {
                    ctx.switch(&f.name, true);
                }
            }
            (ctx.dt(), ctx.time())
        };
        let mut scope = Scope::new();
        for (i, name) in self.reads.iter().enumerate() {
            scope.push_constant_dynamic(name.as_str(), to_dynamic(io.read_value(i)));
        }
        let [dt_name, time_name] = RESERVED;
        scope.push_constant(dt_name, dt);
        scope.push_constant(time_name, time);
        for d in &self.driven {
            scope.push_dynamic(d.name.as_str(), d.value.clone());
        }
        for (s, v) in &self.states {
            scope.push_dynamic(s.name.as_str(), v.clone());
        }
        if let Err(mut e) = self.engine.run_ast_with_scope(&mut scope, &self.ast) {
            let at = e
                .position()
                .line()
                .map(|l| (l, e.position().position().unwrap_or(1)));
            e.clear_position();
            // A helper's own refusal (an unknown fault) reads as itself, without Rhai's
            // "Runtime error: " before it.
            let message = match &*e {
                rhai::EvalAltResult::ErrorRuntime(what, _) => what.to_string(),
                other => other.to_string(),
            };
            return Err((at, RunError::Script { message }));
        }
        // The declared names are the scope's first entries, in this order; a step's own
        // `let`s come after them.
        let values: Vec<Dynamic> = scope
            .iter()
            .skip(self.reads.len() + RESERVED.len())
            .map(|(_, _, v)| v)
            .collect();
        let (drives, states) = values.split_at(self.driven.len().min(values.len()));
        for (d, v) in self.driven.iter_mut().zip(drives) {
            d.value = v.clone();
        }
        for ((s, held), v) in self.states.iter_mut().zip(states) {
            *held = checked_state(s, v.clone()).map_err(|e| (None, e))?;
        }
        let first = self.reads.len();
        for (k, d) in self.driven.iter().enumerate() {
            let value = to_value(d).map_err(|e| (None, e))?;
            io.write_value(first + k, value);
        }
        Ok(())
    }
}

/// A terminal's value before the model first drives it.
fn zero(ty: ValueType) -> Dynamic {
    match ty {
        ValueType::Bool => Dynamic::FALSE,
        ValueType::U16 | ValueType::I32 => Dynamic::from_int(0),
        ValueType::F32 => Dynamic::from_float(0.0),
    }
}

/// A read terminal as the step sees it: a bool, an integer or a float.
fn to_dynamic(v: Value) -> Dynamic {
    match v {
        Value::Bool(b) => Dynamic::from_bool(b),
        Value::U16(w) => Dynamic::from_int(INT::from(w)),
        Value::I32(i) => Dynamic::from_int(INT::from(i)),
        Value::F32(x) => Dynamic::from_float(FLOAT::from(x)),
    }
}

fn number(v: &Dynamic) -> Option<FLOAT> {
    v.as_float()
        .ok()
        .or_else(|| v.as_int().ok().map(|i| i as FLOAT))
}

fn wrong(what: &'static str, name: &str, expected: &'static str, v: &Dynamic) -> RunError {
    RunError::WrongType {
        what,
        name: name.to_owned(),
        expected,
        given: format!("{v} ({})", v.type_name()),
    }
}

/// A driven terminal's value in its point's type; a number beyond the point's range is
/// clamped to it, as a transmitter's output saturates.
fn to_value(d: &Driven) -> Result<Value, RunError> {
    let v = &d.value;
    match d.ty {
        ValueType::Bool => v
            .as_bool()
            .map(Value::Bool)
            .map_err(|_| wrong("terminal", &d.name, "bool", v)),
        ValueType::U16 => number(v)
            .map(|x| Value::U16(x.round().clamp(0.0, f64::from(u16::MAX)) as u16))
            .ok_or_else(|| wrong("terminal", &d.name, "number (u16)", v)),
        ValueType::I32 => number(v)
            .map(|x| Value::I32(x.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32))
            .ok_or_else(|| wrong("terminal", &d.name, "number (i32)", v)),
        ValueType::F32 => number(v)
            .map(|x| Value::F32(x as f32))
            .ok_or_else(|| wrong("terminal", &d.name, "number (f32)", v)),
    }
}

/// A state's new value: of its type, not NaN, within its limits.
fn checked_state(s: &StateDecl, v: Dynamic) -> Result<Dynamic, RunError> {
    let clamp = |x: f64| {
        x.clamp(
            s.min.unwrap_or(f64::NEG_INFINITY),
            s.max.unwrap_or(f64::INFINITY),
        )
    };
    match s.initial {
        StateValue::Bool(_) if v.is_bool() => Ok(v),
        StateValue::Bool(_) => Err(wrong("state", &s.name, "bool", &v)),
        StateValue::Int(_) => match v.as_int() {
            Ok(i) => Ok(Dynamic::from_int(clamp(i as f64) as INT)),
            Err(_) => Err(wrong("state", &s.name, "integer", &v)),
        },
        StateValue::Float(_) => match number(&v) {
            Some(x) if x.is_finite() => Ok(Dynamic::from_float(clamp(x))),
            Some(x) => Err(RunError::NotANumber {
                name: s.name.clone(),
                value: x,
            }),
            None => Err(wrong("state", &s.name, "float", &v)),
        },
    }
}

/// A step's value of a state, as scenarios and the page show it.
fn state_value(v: &Dynamic) -> StateValue {
    if let Ok(b) = v.as_bool() {
        StateValue::Bool(b)
    } else if let Ok(i) = v.as_int() {
        StateValue::Int(i)
    } else {
        StateValue::Float(v.as_float().unwrap_or(0.0))
    }
}

impl Plant for RhaiPlant {
    fn step(&mut self, t: LineInstant, io: &mut dyn PlantIo) {
        if self.health != PlantHealth::Running {
            return;
        }
        let next = *self.next.get_or_insert(t);
        if t < next {
            return;
        }
        // Absolute: the steps keep their grid however the world's ticks fall.
        self.next = Some(next + self.step);
        match self.run_step(io) {
            Ok(()) => self.steps += 1,
            Err((at, e)) => {
                let place = at.map_or_else(
                    || self.file.clone(),
                    |(line, col)| format!("{}:{line}:{col}", self.file),
                );
                let why = format!("{place}: {e}");
                tracing::error!(
                    "plant {} stopped at step {}: {why}; its terminals hold their last values, \
                     the PLC runs on",
                    self.name,
                    self.steps
                );
                self.health = PlantHealth::Stopped(why);
            }
        }
    }

    fn states(&self) -> Vec<(String, StateValue)> {
        self.states
            .iter()
            .map(|(s, v)| (s.name.clone(), state_value(v)))
            .collect()
    }

    fn set_fault(&mut self, name: &str, on: bool) -> Result<(), FaultSwitchError> {
        let mut ctx = self.ctx.lock().unwrap_or_else(|p| p.into_inner());
        if ctx.switch(name, on) {
            Ok(())
        } else {
            Err(FaultSwitchError::Unknown {
                plant: self.name.clone(),
                fault: name.to_owned(),
                known: ctx.faults.iter().map(|f| f.name.clone()).collect(),
            })
        }
    }

    fn health(&self) -> PlantHealth {
        self.health.clone()
    }
}
