//! Plant models: the machine around the simulated modules, so inputs answer outputs.
//!
//! A plant is wired to module points by terminal (`motor: mm1.Y1`). It runs on the simulated
//! world's 1 ms tick, reads the outputs it is wired to and drives the inputs, so a newcomer's
//! project behaves like a machine with no hardware at all. The models themselves are written
//! in Rhai and run by the runtime (its `plant` module); this crate knows only the interface.

use std::fmt::Debug;

use crate::time::LineInstant;

use crate::point::Value;

/// The plant's view of its wiring: values by terminal index (the order of the wires the world
/// was given with it, [`SimWorld::set_plant`](crate::sim::SimWorld::set_plant)).
pub trait PlantIo {
    /// Reads the point wired to role `role`.
    fn read(&self, role: usize) -> bool;
    /// Drives the point wired to role `role`.
    fn write(&mut self, role: usize, value: bool);
    /// Reads the point wired to role `role` as the module holds it (a word, a float), for
    /// plants that see more than levels.
    fn read_value(&self, role: usize) -> Value {
        Value::Bool(self.read(role))
    }
    /// Drives the point wired to role `role` with a value of the point's type.
    fn write_value(&mut self, role: usize, value: Value) {
        self.write(role, value.as_bool());
    }
}

/// A plant state's value, as a model holds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StateValue {
    /// A level.
    Bool(bool),
    /// A count.
    Int(i64),
    /// A continuous quantity.
    Float(f64),
}

impl std::fmt::Display for StateValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StateValue::Bool(b) => write!(f, "{b}"),
            StateValue::Int(i) => write!(f, "{i}"),
            StateValue::Float(x) => write!(f, "{x}"),
        }
    }
}

/// Whether a plant model still runs.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum PlantHealth {
    /// It steps.
    #[default]
    Running,
    /// It stopped on an error (what and where); the points it drives hold their last values.
    Stopped(String),
}

/// Why a fault could not be switched.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FaultSwitchError {
    /// The model declares no fault of that name.
    #[error(
        "plant {plant} has no fault \"{fault}\" (its faults: {})",
        known_or_none(known)
    )]
    Unknown {
        /// The plant model.
        plant: String,
        /// The name asked for.
        fault: String,
        /// The faults the model declares.
        known: Vec<String>,
    },
    /// A model written in Rust, which has no faults to switch.
    #[error("the plant has no faults to switch (asked for \"{fault}\")")]
    NoFaults {
        /// The name asked for.
        fault: String,
    },
}

fn known_or_none(known: &[String]) -> String {
    if known.is_empty() {
        "none".into()
    } else {
        known.join(", ")
    }
}

/// A running plant model.
pub trait Plant: Send + Debug {
    /// One 1 ms step ending at time `t` (the simulated world's, a line's time).
    fn step(&mut self, t: LineInstant, io: &mut dyn PlantIo);
    /// The model's states by name, for scenarios, the status and the web page (none for a
    /// model that keeps them private).
    fn states(&self) -> Vec<(String, StateValue)> {
        Vec::new()
    }
    /// Switches the fault `name` on or off (a scenario, an operator's test).
    fn set_fault(&mut self, name: &str, on: bool) -> Result<(), FaultSwitchError> {
        let _ = on;
        Err(FaultSwitchError::NoFaults {
            fault: name.to_owned(),
        })
    }
    /// Whether it runs or stopped on an error.
    fn health(&self) -> PlantHealth {
        PlantHealth::Running
    }
}
