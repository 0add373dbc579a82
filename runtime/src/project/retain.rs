//! The `retain:` section: where and how often the values of `retain: true` tags are saved.
//!
//! ```yaml
//! retain:
//!   file: pump.retain.json   # relative to the project file's folder;
//!                            # default: <project file name>.retain.json beside it,
//!                            # or in $STATE_DIRECTORY/<project folder>/ under systemd
//!   period: 10s              # how often changed values are saved; default 10s, > 0
//! tags:
//!   - { name: run_seconds, type: i32, retain: true }   # memory tags only
//! ```

use std::path::{Path, PathBuf};
use std::time::Duration;

use schemars::JsonSchema;
use serde::Deserialize;

use super::error::ErrorKind;
use super::raw::DurationText;
use super::span::YPath;

/// Default save period.
pub(crate) const DEFAULT_RETAIN_PERIOD: Duration = Duration::from_secs(10);

/// `retain:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "retain settings: a mapping with file and period"
)]
pub(crate) struct RawRetain {
    /// The file, relative to the project file's folder.
    #[serde(default)]
    pub file: Option<String>,
    /// Save period.
    #[serde(default)]
    pub period: Option<DurationText>,
}

/// Where and how often retained values are saved.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RetainConfig {
    /// The file (resolved against the project file's folder).
    pub file: PathBuf,
    /// How often changed values are saved (they are also saved on stop).
    pub period: Duration,
}

/// The retain settings of a project read from `file`, with the errors found (and where).
pub(crate) fn validate(
    raw: Option<&RawRetain>,
    file: &Path,
) -> (Option<RetainConfig>, Vec<(YPath, ErrorKind)>) {
    let path = YPath::root().key("retain");
    let raw = raw.cloned().unwrap_or_default();
    let mut errors = Vec::new();
    let folder = file.parent().unwrap_or(Path::new(""));
    let retain_file = match raw.file.as_deref() {
        Some("") => {
            errors.push((path.key("file"), ErrorKind::EmptyRetainFile));
            None
        }
        Some(f) => Some(folder.join(f)),
        None => {
            let name = file.file_stem().map_or_else(
                || "project".to_string(),
                |s| s.to_string_lossy().into_owned(),
            );
            // Under systemd, in the unit's state directory (see `state`).
            Some(super::state::default_state_folder(file).join(format!("{name}.retain.json")))
        }
    };
    let period = match raw.period {
        None => Some(DEFAULT_RETAIN_PERIOD),
        Some(DurationText(d)) if d.is_zero() => {
            errors.push((
                path.key("period"),
                ErrorKind::ZeroDuration {
                    key: "retain.period",
                },
            ));
            None
        }
        Some(DurationText(d)) => Some(d),
    };
    let config = match (retain_file, period) {
        (Some(file), Some(period)) => Some(RetainConfig { file, period }),
        _ => None,
    };
    (config, errors)
}
