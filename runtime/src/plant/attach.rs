//! Putting a project's plant into a simulated world: its terminals wired, in the model's
//! order, to the world's devices, each driven terminal told its point's type.

use softplc_io::point::ValueType;
use softplc_io::sim::SimWorld;

use crate::project::Project;

/// A plant terminal wired to a module the world does not hold.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "plant {plant}: terminal {terminal} is wired to module {module}, which is not simulated here"
)]
pub struct NotInWorld {
    /// The model.
    pub plant: String,
    /// The terminal.
    pub terminal: String,
    /// The module it is wired to.
    pub module: String,
}

/// Attaches `project`'s plant (if it has one) to `world`, whose devices are named as the
/// project names its modules; its first step is the world's next tick.
pub fn attach(project: &Project, world: &mut SimWorld) -> Result<(), NotInWorld> {
    let Some(cfg) = &project.plant else {
        return Ok(());
    };
    let mut wires = Vec::with_capacity(cfg.wiring.len());
    for (terminal, m, point) in &cfg.wiring {
        let module = &project.modules[*m].name;
        match world.find(module) {
            Some(d) => wires.push((d, point.clone())),
            None => {
                return Err(NotInWorld {
                    plant: cfg.model.name.clone(),
                    terminal: terminal.clone(),
                    module: module.clone(),
                })
            }
        }
    }
    let point_type = |m: usize, p: &str| {
        let points = project.modules[m].model.points;
        points
            .iter()
            .find(|s| s.name == p)
            .map_or(ValueType::Bool, |s| s.ty)
    };
    let drive_types = cfg
        .wiring
        .iter()
        .skip(cfg.model.decl.reads.len())
        .map(|(_, m, p)| point_type(*m, p))
        .collect();
    let plant = cfg.model.instantiate(drive_types, cfg.seed);
    world.set_plant(Box::new(plant), wires);
    Ok(())
}
