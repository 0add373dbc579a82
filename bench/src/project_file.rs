//! Projects built in code: the YAML and the program are written to the scratch folder and
//! loaded through the runtime's own project reader, so a scenario runs what a user would run.

use std::fmt::Write;
use std::path::Path;

use anyhow::Context;
use softplc::project::{self, Project};

/// One bus of a generated project: its name, baud, and the unit addresses of its modules
/// (MiniMods unless [`SimBus::model`] says otherwise).
#[derive(Debug, Clone)]
pub(crate) struct SimBus {
    /// Bus name.
    pub name: String,
    /// Baud rate (8E1).
    pub baud: u32,
    /// Unit addresses on it; modules are named `<bus>_m<address>`.
    pub addresses: Vec<u8>,
    /// Catalog model of every module on it (`minimod`, `resi-16di8ro`).
    pub model: &'static str,
    /// Settings of every module on it, a YAML flow mapping (`{ Y1AON1: X1 }`), or empty.
    pub settings: String,
}

impl SimBus {
    /// A bus of MiniMods with their power-on settings.
    pub(crate) fn new(name: &str, baud: u32, addresses: impl IntoIterator<Item = u8>) -> Self {
        Self {
            name: name.into(),
            baud,
            addresses: addresses.into_iter().collect(),
            model: "minimod",
            settings: String::new(),
        }
    }
}

/// Writes `<name>.yaml` and `<name>.expr` into `scratch` and loads the project.
///
/// `buses` are simulated (`port: sim`) lines of modules; `tags` are YAML flow mappings
/// (`{ name: x, type: bool }`), `program` is `expr` source.
pub(crate) fn load(
    scratch: &Path,
    name: &str,
    period: &str,
    buses: &[SimBus],
    tags: &[String],
    program: &str,
) -> anyhow::Result<Project> {
    load_offload(scratch, name, period, buses, tags, program, "never")
}

/// [`load`] with the project's push-down mode (`offload: auto` lets the planner move rungs
/// into the modules).
pub(crate) fn load_offload(
    scratch: &Path,
    name: &str,
    period: &str,
    buses: &[SimBus],
    tags: &[String],
    program: &str,
    offload: &str,
) -> anyhow::Result<Project> {
    let mut yaml = String::new();
    let _ = writeln!(
        yaml,
        "project: {name}\nscan:\n  period: {period}\noffload: {offload}\nbuses:"
    );
    if buses.is_empty() {
        yaml.truncate(yaml.len() - "buses:\n".len());
        yaml.push_str("buses: []\n");
    }
    for b in buses {
        let _ = writeln!(
            yaml,
            "  - {{ name: {}, port: sim, baud: {}, format: 8E1, response_timeout: 100ms }}",
            b.name, b.baud
        );
    }
    let modules: Vec<String> = buses
        .iter()
        .flat_map(|b| {
            b.addresses.iter().map(move |a| {
                let settings = if b.settings.is_empty() {
                    String::new()
                } else {
                    format!(", settings: {}", b.settings)
                };
                format!(
                    "  - {{ name: {}_m{a}, bus: {}, model: {}, address: {a}{settings} }}",
                    b.name, b.name, b.model
                )
            })
        })
        .collect();
    if modules.is_empty() {
        yaml.push_str("modules: []\n");
    } else {
        let _ = writeln!(yaml, "modules:\n{}", modules.join("\n"));
    }
    let _ = writeln!(yaml, "tags:");
    for t in tags {
        let _ = writeln!(yaml, "  - {t}");
    }
    let _ = writeln!(yaml, "program: {{ file: {name}.expr, kind: expr }}");

    let yaml_path = scratch.join(format!("{name}.yaml"));
    std::fs::write(scratch.join(format!("{name}.expr")), program)
        .with_context(|| format!("cannot write {name}.expr in {}", scratch.display()))?;
    std::fs::write(&yaml_path, &yaml)
        .with_context(|| format!("cannot write {}", yaml_path.display()))?;
    project::load(&yaml_path).map_err(|e| anyhow::anyhow!("generated project {name}:\n{e}"))
}
