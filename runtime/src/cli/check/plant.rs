//! The plant's part of `check`: the model, its step, every terminal with the point it is
//! wired to, its states with their limits, its faults.

use crate::project::Project;
use crate::scan::fmt_duration;

/// The lines `check` prints for the project's plant (none without one).
pub(super) fn lines(project: &Project) -> Vec<String> {
    let Some(plant) = &project.plant else {
        return Vec::new();
    };
    let m = &plant.model;
    let mut out = vec![format!(
        "plant {} ({}): a step every {}, random seed {}",
        m.name,
        m.file.display(),
        fmt_duration(m.decl.step),
        plant.seed
    )];
    for ((name, drives), (_, module, point)) in m.terminals().zip(&plant.wiring) {
        let module = &project.modules[*module].name;
        let (verb, arrow) = if drives {
            ("drives", "→")
        } else {
            ("reads ", "←")
        };
        out.push(format!("  {verb} {name} {arrow} {module}.{point}"));
    }
    for s in &m.decl.states {
        let limits = match (s.min, s.max) {
            (None, None) => String::new(),
            (lo, hi) => format!(
                " ({}..{})",
                lo.map_or_else(String::new, |x| x.to_string()),
                hi.map_or_else(String::new, |x| x.to_string())
            ),
        };
        out.push(format!("  state  {} = {}{limits}", s.name, s.initial));
    }
    if !m.decl.faults.is_empty() {
        let faults: Vec<String> = m
            .decl
            .faults
            .iter()
            .map(|f| match f.at {
                Some(at) => format!("{} (at {})", f.name, fmt_duration(at)),
                None => f.name.clone(),
            })
            .collect();
        out.push(format!("  faults {}", faults.join(", ")));
    }
    out
}
