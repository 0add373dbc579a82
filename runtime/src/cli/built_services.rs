//! The optional services this binary was built with (the `softplc` crate's cargo features
//! `opcua` and `mqtt`, on by default), and the refusal of a project that asks for one it
//! lacks. `check` and `run` load projects through [`load`], so both name the same key: a PLC
//! that started without the OPC UA server its SCADA expects would fail where nobody looks.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::project::span::{Locator, YPath};
use crate::project::{self, Project};

/// Which optional services a binary has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct BuiltServices {
    /// The OPC UA server (feature `opcua`).
    pub(crate) opcua: bool,
    /// The MQTT Sparkplug B edge node (feature `mqtt`).
    pub(crate) mqtt: bool,
}

impl BuiltServices {
    /// This binary's.
    pub(crate) const THIS_BINARY: Self = Self {
        opcua: cfg!(feature = "opcua"),
        mqtt: cfg!(feature = "mqtt"),
    };
}

/// An optional service a project asks for and a binary lacks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum OptionalService {
    /// `service.opcua`.
    OpcUa,
    /// `service.mqtt`.
    Mqtt,
}

impl OptionalService {
    /// Its key under `service:` (also the cargo feature's name).
    fn key(self) -> &'static str {
        match self {
            Self::OpcUa => "opcua",
            Self::Mqtt => "mqtt",
        }
    }

    /// What it is, for people.
    fn what(self) -> &'static str {
        match self {
            Self::OpcUa => "the OPC UA server",
            Self::Mqtt => "the MQTT Sparkplug B edge node",
        }
    }
}

/// The refusal: `file:line:col: error: ...` at the service's key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct MissingService {
    /// The project file.
    pub(crate) file: PathBuf,
    /// 1-based line of the key `service.<key>`.
    pub(crate) line: usize,
    /// 1-based column of the key.
    pub(crate) column: usize,
    /// The service.
    pub(crate) service: OptionalService,
}

impl fmt::Display for MissingService {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let key = self.service.key();
        write!(
            f,
            "{}:{}:{}: error: service.{key} asks for {}, but this softplc was built without it \
             (cargo feature `{key}` off); remove service.{key}, or install a build that has \
             it (the Debian package does; from source: cargo build --release -p softplc, \
             default features)",
            self.file.display(),
            self.line,
            self.column,
            self.service.what()
        )
    }
}

/// The services `project` (read from `text`, the file `file`) asks for that `built` lacks,
/// each at its key in the text.
pub(crate) fn missing(
    project: &Project,
    text: &str,
    file: &Path,
    built: BuiltServices,
) -> Vec<MissingService> {
    let asked = [
        (
            OptionalService::OpcUa,
            project.service.opcua.is_some(),
            built.opcua,
        ),
        (
            OptionalService::Mqtt,
            project.service.mqtt.is_some(),
            built.mqtt,
        ),
    ];
    let loc = Locator::new(text);
    asked
        .into_iter()
        .filter(|&(_, asked, built)| asked && !built)
        .map(|(service, _, _)| {
            let (line, column) =
                loc.position(&YPath::root().key("service").key_itself(service.key()));
            MissingService {
                file: file.to_path_buf(),
                line,
                column,
                service,
            }
        })
        .collect()
}

/// Loads the project at `path` as this binary can run it: its errors, or the services it asks
/// for that this binary lacks, are the text to print.
pub(crate) fn load(path: &Path) -> Result<Project, String> {
    let text = project::error::read_text(path).map_err(|e| e.to_string())?;
    let project = project::parse_str(&text, path).map_err(|e| e.to_string())?;
    let refused = missing(&project, &text, path, BuiltServices::THIS_BINARY);
    if refused.is_empty() {
        Ok(project)
    } else {
        Err(refused
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join("\n"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick start (its program exists) with both optional services added.
    fn quickstart_with_services() -> (String, PathBuf, usize) {
        let file =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/quickstart/project.yaml");
        let base = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{e}"));
        let lines = base.lines().count();
        // Under the quick start's `service:` (its last section).
        let text = format!(
            "{base}  mqtt:\n    host: 127.0.0.1\n    group: plant\n    node: line1\n  \
             opcua:\n    port: 0\n"
        );
        (text, file, lines)
    }

    fn none() -> BuiltServices {
        BuiltServices {
            opcua: false,
            mqtt: false,
        }
    }

    #[test]
    fn a_binary_without_a_service_refuses_it_at_its_key() {
        let (text, file, lines) = quickstart_with_services();
        let p = project::parse_str(&text, &file).unwrap_or_else(|e| panic!("{e}"));
        let refused = missing(&p, &text, &file, none());
        let text: Vec<String> = refused.iter().map(ToString::to_string).collect();
        assert_eq!(text.len(), 2, "{text:?}");
        // mqtt is the line after the quick start's last, opcua 4 lines on.
        let mqtt_at = format!("{}:{}:3: error: ", file.display(), lines + 1);
        let opcua_at = format!("{}:{}:3: error: ", file.display(), lines + 5);
        assert_eq!(
            text[0],
            format!(
                "{opcua_at}service.opcua asks for the OPC UA server, but this softplc was \
                 built without it (cargo feature `opcua` off); remove service.opcua, or install \
                 a build that has it (the Debian package does; from source: cargo build \
                 --release -p softplc, default features)"
            )
        );
        assert!(
            text[1].starts_with(&format!(
                "{mqtt_at}service.mqtt asks for the MQTT Sparkplug B edge node, but this \
                 softplc was built without it (cargo feature `mqtt` off); remove service.mqtt"
            )),
            "{}",
            text[1]
        );
    }

    #[test]
    fn only_the_missing_service_is_refused() {
        let (text, file, _) = quickstart_with_services();
        let p = project::parse_str(&text, &file).unwrap_or_else(|e| panic!("{e}"));
        let opcua_only = BuiltServices {
            opcua: true,
            mqtt: false,
        };
        let refused = missing(&p, &text, &file, opcua_only);
        assert_eq!(
            refused.iter().map(|m| m.service).collect::<Vec<_>>(),
            [OptionalService::Mqtt]
        );
        let all = BuiltServices {
            opcua: true,
            mqtt: true,
        };
        assert!(missing(&p, &text, &file, all).is_empty());
    }

    #[test]
    fn a_project_without_the_services_needs_neither() {
        let (text, file, _) = quickstart_with_services();
        let text = text.split("\n  mqtt:").next().unwrap_or_default();
        let p = project::parse_str(text, &file).unwrap_or_else(|e| panic!("{e}"));
        assert!(missing(&p, text, &file, none()).is_empty());
    }
}
