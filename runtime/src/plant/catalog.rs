//! The built-in plant models, each a model file compiled into the binary: a project names one
//! with `plant: { model: conveyor }` as it names its own with `plant: { file: ... }`.

use std::path::Path;

use super::model::{compile, PlantModel};

/// A built-in model: its name, what it is, its source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Builtin {
    /// The name in project files.
    pub name: &'static str,
    /// One line about it.
    pub summary: &'static str,
    /// Its Rhai text (as `docs/plant.md` teaches).
    pub source: &'static str,
}

/// Every built-in model.
pub const CATALOG: [Builtin; 1] = [Builtin {
    name: "conveyor",
    summary: "a 1 m belt at 0.5 m/s, an entry and an exit sensor, and an operator who loads a \
              box, presses start, and takes the box away at the exit",
    source: include_str!("catalog/conveyor.plant.rhai"),
}];

/// The built-in model `name`, compiled.
pub fn builtin(name: &str) -> Option<PlantModel> {
    let b = CATALOG.iter().find(|b| b.name == name)?;
    let file = format!("{}.plant.rhai (built in)", b.name);
    // A built-in compiles: the catalog's test holds every entry to it.
    let mut model = compile(Path::new(&file), b.source).ok()?;
    model.name = b.name.to_owned();
    Some(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_compiles() {
        for b in CATALOG {
            let file = format!("{}.plant.rhai", b.name);
            if let Err(e) = compile(Path::new(&file), b.source) {
                panic!("built-in {} does not compile: {e:?}", b.name);
            }
        }
    }
}
