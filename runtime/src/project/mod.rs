//! The project file: YAML → `raw` serde structs → validated [`Project`].
//!
//! Everything is checked before the first scan, and every error found is reported with its
//! `file:line:col`, like rustc:
//!
//! ```text
//! plant.yaml:12:14: error: unknown model "minimodd" (known: minimod)
//! plant.yaml:19:14: error: address 1 is already used by module mm1 on bus line1 (line 13)
//! ```
//!
//! The schema is documented in `raw`. Errors of the YAML reader (syntax, a value of the
//! wrong type) stop the reading, so they come alone; unknown keys are all collected, with the
//! semantic errors of the rest (see `unknown_keys.rs`), and so are semantic errors (names,
//! references, ranges, owners). Positions of semantic errors come from
//! re-reading the text along the error's path (see `span.rs`): they point at the offending
//! value (or key, for an unknown plant role; or at the enclosing entry when the value is
//! missing).

mod adapter;
pub(crate) mod alarm;
mod cycle_mix;
mod dcon_neighbours;
mod doc_text;
pub(crate) mod error;
pub(crate) mod line_plan;
pub(crate) mod model;
pub(crate) mod mqtt;
pub(crate) mod nesting;
pub(crate) mod offload;
pub(crate) mod opcua;
pub mod profile;
mod programs;
pub(crate) mod raw;
mod raw_schema;
pub(crate) mod recorder;
pub(crate) mod retain;
mod scada;
pub(crate) mod secret;
pub(crate) mod service;
pub(crate) mod span;
pub(crate) mod state;
pub(crate) mod task_view;
pub(crate) mod trace;
pub(crate) mod trace_budget;
pub(crate) mod unknown_keys;
pub(crate) mod user_blocks;
pub(crate) mod validate;
pub(crate) mod watchdog;
pub(crate) mod web;

use std::path::Path;

pub use alarm::{AlarmConfig, AlarmError, AlarmWhen, AlarmsConfig, Priority};
pub use doc_text::{DocKind, DocText, DocTextError};
pub use error::{ErrorKind, Item, ProjectError, ProjectErrors};
pub use line_plan::{Choice, Direction, FastTurn, InputPlan, LinePlan, SlowTurn, Tuned};
pub use model::*;
pub use mqtt::{MqttConfig, MqttError};
pub use nesting::MAX_DEPTH;
pub use offload::{OffloadConfig, OffloadError, OffloadMode, OnStop, TagOffload};
pub use opcua::{OpcUaConfig, OpcUaError, OpcUaLimits, OpcUaSecurity};
pub use raw::{parse_duration, DurationError};
pub use recorder::{RecorderConfig, RecorderError};
pub use retain::RetainConfig;
pub use scada::ServiceError;
pub use secret::Password;
pub use service::{
    ModbusTcpConfig, ReadGaps, ScadaAccess, ScadaEntry, ScadaMap, ServiceConfig, Space,
    DEFAULT_MODBUS_BIND,
};
pub use trace::{
    CompareOp, Condition, Counter, Phase, Probe, RawTrace, TraceConfig, TraceError, TraceMode,
    Trigger,
};
pub use trace_budget::{Bytes, TraceBudget, TraceBudgetError};
pub use user_blocks::{
    BlockInstance, BlockVar, NestedInstance, TreeVar, UserBlock, UserBlockError, VarRole,
};
pub use watchdog::{Armed, Derivation, ModuleWatchdog, Origin, WatchdogPolicy};
pub use web::{TokenSource, WebConfig, WebError, WebRole, WebToken, DEFAULT_WEB_BIND};

/// Reads and validates the project file at `path`. The program file is resolved against the
/// file's folder and must exist.
pub fn load(path: &Path) -> Result<Project, ProjectErrors> {
    parse_str(&error::read_text(path)?, path)
}

/// Validates project text as if read from `file`: errors name `file`, and the program file is
/// resolved against `file`'s folder and must exist (as for [`load`]).
pub fn parse_str(text: &str, file: &Path) -> Result<Project, ProjectErrors> {
    unknown_keys::read_checked::<raw::RawProject, _>(text, file, validate::validate)
}

/// Converts an error of the YAML reader, keeping its position and classifying its message.
fn yaml_error(err: &yaml_serde::Error, file: &Path) -> ProjectError {
    let (line, column) = err.location().map_or((1, 1), |l| (l.line(), l.column()));
    let mut message = err.to_string();
    let suffix = format!(" at line {line} column {column}");
    if let Some(at) = message.find(&suffix) {
        message.replace_range(at..at + suffix.len(), "");
    }
    ProjectError {
        file: file.to_path_buf(),
        line,
        column,
        kind: classify(message),
    }
}

/// Splits `path: message` as yaml_serde writes it and recognises serde's standard messages.
fn classify(message: String) -> ErrorKind {
    let split = |at: usize| -> String {
        message
            .get(..at)
            .unwrap_or("")
            .trim_end()
            .trim_end_matches(':')
            .to_owned()
    };
    let quoted = |rest: &str| -> Option<(String, String)> {
        let (name, after) = rest.split_once('`')?;
        Some((name.to_owned(), after.to_owned()))
    };
    for (phrase, which) in [
        ("unknown field `", 0),
        ("missing field `", 1),
        ("duplicate field `", 2),
        ("invalid type: ", 3),
        ("invalid value: ", 3),
        ("invalid length ", 3),
    ] {
        let Some(at) = message.find(phrase) else {
            continue;
        };
        let section = split(at);
        let rest = message.get(at + phrase.len()..).unwrap_or("");
        let kind = match which {
            0 => quoted(rest).map(|(key, after)| ErrorKind::UnknownKey {
                section,
                key,
                expected: after.trim_start_matches(", expected ").to_owned(),
            }),
            1 => quoted(rest).map(|(key, _)| ErrorKind::MissingKey { section, key }),
            2 => quoted(rest).map(|(key, _)| ErrorKind::DuplicateKey { section, key }),
            _ => Some(ErrorKind::WrongType {
                key: section,
                message: message.get(at..).unwrap_or("").to_owned(),
            }),
        };
        if let Some(kind) = kind {
            return kind;
        }
    }
    ErrorKind::Yaml { message }
}
