//! The project the plant services' alarm tests share: one simulated MiniMod, a memory tag
//! `jam` that is an alarm ("Door jammed", high), raised by a write, and `lamp` following it.

use std::path::{Path, PathBuf};

/// Writes the project `name` with `service` (the `service:` section's YAML, one line) in `dir`;
/// its path.
pub(crate) fn jam_project(dir: &Path, name: &str, service: &str) -> PathBuf {
    std::fs::write(dir.join("p.expr"), "lamp = jam\n").unwrap();
    let project = dir.join("project.yaml");
    std::fs::write(
        &project,
        format!(
            "project: {name}\n\
             scan: {{ period: 20ms }}\n\
             buses:\n  - {{ name: line1, port: sim, response_timeout: 50ms }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n\
             tags:\n\
             \x20 - {{ name: jam, type: bool, alarm: {{ text: Door jammed, priority: high }} }}\n\
             \x20 - {{ name: lamp, point: mm1.Y1, safe: false }}\n\
             program: {{ file: p.expr, kind: expr }}\n\
             service:\n  {service}\n"
        ),
    )
    .unwrap();
    project
}
