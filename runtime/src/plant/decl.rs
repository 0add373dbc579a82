//! A model's declarations: the map its `fn plant()` returns, read into typed lists.
//!
//! ```rhai
//! fn plant() {
//!     #{
//!         step: "10ms",                               // optional, default 10ms
//!         reads:  ["motor_up", "motor_down"],         // module outputs the model reads
//!         drives: ["limit_open", "limit_closed"],     // module inputs the model drives
//!         states: #{ position: #{ initial: 0.0, min: 0.0, max: 100.0 }, count: 0 },
//!         faults: #{ jammed: #{}, eye_broken: #{ at: "30s" } },   // or ["jammed", ...]
//!     }
//! }
//! ```

use std::time::Duration;

use rhai::{Dynamic, Map};
use softplc_io::sim::plant::StateValue;

use super::error::ModelError;
use crate::project::raw::parse_duration;

/// The step when a model does not say: 100 steps a second, fine enough for motions of
/// seconds, coarse enough to cost little (docs/plant.md has the measured cost).
pub const DEFAULT_STEP: Duration = Duration::from_millis(10);

/// Names every step is given by the plant API.
pub(crate) const RESERVED: [&str; 2] = ["dt", "time"];

/// A state: its name, initial value (which sets its type) and limits.
#[derive(Debug, Clone, PartialEq)]
pub struct StateDecl {
    /// The name, a variable of the step.
    pub name: String,
    /// The value at the start; its type is the state's.
    pub initial: StateValue,
    /// The least value, for a number (the step's result is clamped to it).
    pub min: Option<f64>,
    /// The greatest value, for a number.
    pub max: Option<f64>,
}

/// A fault the model can suffer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultDecl {
    /// Its name, for `fault("name")` and scenarios.
    pub name: String,
    /// Injected at this time after the start, if given.
    pub at: Option<Duration>,
}

/// Everything `fn plant()` declares.
#[derive(Debug, Clone, PartialEq)]
pub struct Declarations {
    /// The step's length in virtual time.
    pub step: Duration,
    /// Terminals the model reads (module outputs).
    pub reads: Vec<String>,
    /// Terminals the model drives (module inputs).
    pub drives: Vec<String>,
    /// The model's states.
    pub states: Vec<StateDecl>,
    /// The model's faults.
    pub faults: Vec<FaultDecl>,
}

/// An error and the text to place it at (a name the file spells), when there is one.
pub(crate) type Placed = (ModelError, Option<String>);

/// Reads the declaration map; every error found.
pub(crate) fn read(map: &Map) -> Result<Declarations, Vec<Placed>> {
    let mut errors = Vec::new();
    for key in map.keys() {
        if !["step", "reads", "drives", "states", "faults"].contains(&key.as_str()) {
            errors.push((
                ModelError::UnknownKey {
                    key: key.to_string(),
                },
                Some(key.to_string()),
            ));
        }
    }
    let step = match map.get("step") {
        None => DEFAULT_STEP,
        Some(v) => step(v).unwrap_or_else(|e| {
            errors.push((e, Some("step".into())));
            DEFAULT_STEP
        }),
    };
    let reads = names(map.get("reads"), "reads", &mut errors);
    let drives = names(map.get("drives"), "drives", &mut errors);
    let states = states(map.get("states"), &mut errors);
    let faults = faults(map.get("faults"), &mut errors);
    let mut seen: Vec<(&str, &'static str)> = Vec::new();
    let lists = [
        ("reads", reads.iter().collect::<Vec<_>>()),
        ("drives", drives.iter().collect()),
        ("states", states.iter().map(|s| &s.name).collect()),
    ];
    for (list, list_names) in &lists {
        for name in list_names {
            if RESERVED.contains(&name.as_str()) {
                errors.push((
                    ModelError::Reserved {
                        name: name.to_string(),
                    },
                    Some((*name).clone()),
                ));
            } else if let Some((_, first)) = seen.iter().find(|(n, _)| n == name) {
                errors.push((
                    ModelError::Duplicate {
                        name: name.to_string(),
                        first,
                        second: list,
                    },
                    Some((*name).clone()),
                ));
            } else {
                seen.push((name.as_str(), list));
            }
        }
    }
    if errors.is_empty() {
        Ok(Declarations {
            step,
            reads,
            drives,
            states,
            faults,
        })
    } else {
        Err(errors)
    }
}

fn step(v: &Dynamic) -> Result<Duration, ModelError> {
    let given = v.to_string();
    let bad = |why: String| ModelError::BadStep {
        given: given.clone(),
        why,
    };
    let Some(text) = v.clone().try_cast::<rhai::ImmutableString>() else {
        return Err(bad(format!(
            "a string like \"10ms\", not a {}",
            v.type_name()
        )));
    };
    let d = parse_duration(&text).map_err(|e| bad(e.to_string()))?;
    if d < Duration::from_millis(1)
        || d > Duration::from_secs(1)
        || d.subsec_nanos() % 1_000_000 != 0
    {
        return Err(bad("the world moves in 1 ms ticks".into()));
    }
    Ok(d)
}

fn shape(key: &str, expected: &'static str, given: &Dynamic) -> Placed {
    (
        ModelError::BadShape {
            key: key.to_owned(),
            expected,
            given: given
                .type_name()
                .rsplit("::")
                .next()
                .unwrap_or("?")
                .to_owned(),
        },
        Some(key.split('.').next_back().unwrap_or(key).to_owned()),
    )
}

fn is_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

fn checked_name(name: &str, errors: &mut Vec<Placed>) -> bool {
    let ok = is_name(name);
    if !ok {
        errors.push((
            ModelError::BadName {
                name: name.to_owned(),
            },
            Some(name.to_owned()),
        ));
    }
    ok
}

/// A list of terminal names.
fn names(v: Option<&Dynamic>, key: &str, errors: &mut Vec<Placed>) -> Vec<String> {
    let Some(v) = v else { return Vec::new() };
    let Some(items) = v.read_lock::<rhai::Array>() else {
        errors.push(shape(key, "an array of names", v));
        return Vec::new();
    };
    let mut out = Vec::new();
    for item in items.iter() {
        match item.clone().try_cast::<rhai::ImmutableString>() {
            Some(name) if checked_name(&name, errors) => out.push(name.to_string()),
            Some(_) => {}
            None => errors.push(shape(key, "an array of names (strings)", item)),
        }
    }
    out
}

fn number(v: &Dynamic) -> Option<f64> {
    v.as_float()
        .ok()
        .or_else(|| v.as_int().ok().map(|i| i as f64))
}

fn states(v: Option<&Dynamic>, errors: &mut Vec<Placed>) -> Vec<StateDecl> {
    let Some(v) = v else { return Vec::new() };
    let Some(map) = v.read_lock::<Map>() else {
        errors.push(shape("states", "a map of name: initial value", v));
        return Vec::new();
    };
    let mut out = Vec::new();
    for (name, spec) in map.iter() {
        if !checked_name(name, errors) {
            continue;
        }
        if let Some(state) = state(name, spec, errors) {
            out.push(state);
        }
    }
    out
}

fn state(name: &str, spec: &Dynamic, errors: &mut Vec<Placed>) -> Option<StateDecl> {
    let key = |k: &str| format!("states.{name}.{k}");
    let (initial, min, max) = match spec.read_lock::<Map>() {
        Some(m) => {
            for k in m.keys() {
                if !["initial", "min", "max"].contains(&k.as_str()) {
                    errors.push((ModelError::UnknownKey { key: key(k) }, Some(k.to_string())));
                }
            }
            let Some(initial) = m.get("initial") else {
                errors.push(shape(
                    &key("initial"),
                    "a bool, an integer or a float",
                    &Dynamic::UNIT,
                ));
                return None;
            };
            let limit = |k: &str, errors: &mut Vec<Placed>| match m.get(k) {
                None => None,
                Some(v) => number(v).or_else(|| {
                    errors.push(shape(&key(k), "a number", v));
                    None
                }),
            };
            (initial.clone(), limit("min", errors), limit("max", errors))
        }
        None => (spec.clone(), None, None),
    };
    let initial = if let Ok(b) = initial.as_bool() {
        StateValue::Bool(b)
    } else if let Ok(i) = initial.as_int() {
        StateValue::Int(i)
    } else if let Ok(x) = initial.as_float() {
        StateValue::Float(x)
    } else {
        errors.push(shape(
            &key("initial"),
            "a bool, an integer or a float",
            &initial,
        ));
        return None;
    };
    let value = match initial {
        StateValue::Bool(_) => {
            if min.is_some() || max.is_some() {
                errors.push((
                    ModelError::LimitsOnBool {
                        name: name.to_owned(),
                    },
                    Some(name.to_owned()),
                ));
            }
            None
        }
        StateValue::Int(i) => Some(i as f64),
        StateValue::Float(x) => Some(x),
    };
    let (lo, hi) = (
        min.unwrap_or(f64::NEG_INFINITY),
        max.unwrap_or(f64::INFINITY),
    );
    if lo > hi {
        errors.push((
            ModelError::LimitsReversed {
                name: name.to_owned(),
                min: lo,
                max: hi,
            },
            Some(name.to_owned()),
        ));
    } else if let Some(x) = value.filter(|x| *x < lo || *x > hi) {
        errors.push((
            ModelError::InitialOutsideLimits {
                name: name.to_owned(),
                initial: x,
                min: lo,
                max: hi,
            },
            Some(name.to_owned()),
        ));
    }
    Some(StateDecl {
        name: name.to_owned(),
        initial,
        min,
        max,
    })
}

fn faults(v: Option<&Dynamic>, errors: &mut Vec<Placed>) -> Vec<FaultDecl> {
    let Some(v) = v else { return Vec::new() };
    if v.is_array() {
        return names(Some(v), "faults", errors)
            .into_iter()
            .map(|name| FaultDecl { name, at: None })
            .collect();
    }
    let Some(map) = v.read_lock::<Map>() else {
        errors.push(shape(
            "faults",
            "an array of names or a map of name: #{ at: \"20s\" }",
            v,
        ));
        return Vec::new();
    };
    let mut out = Vec::new();
    for (name, spec) in map.iter() {
        if !checked_name(name, errors) {
            continue;
        }
        let at = spec
            .read_lock::<Map>()
            .and_then(|m| m.get("at").cloned())
            .and_then(|at| {
                let given = at.to_string();
                let parsed = at
                    .clone()
                    .try_cast::<rhai::ImmutableString>()
                    .ok_or_else(|| format!("a string like \"20s\", not a {}", at.type_name()))
                    .and_then(|t| parse_duration(&t).map_err(|e| e.to_string()));
                parsed
                    .map_err(|why| {
                        errors.push((
                            ModelError::BadFaultTime {
                                name: name.to_string(),
                                given,
                                why,
                            },
                            Some(name.to_string()),
                        ));
                    })
                    .ok()
            });
        out.push(FaultDecl {
            name: name.to_string(),
            at,
        });
    }
    out
}
