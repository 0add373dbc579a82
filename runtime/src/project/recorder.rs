//! The `recorder:` section: the flight recorder (see [`crate::recorder`]).
//!
//! ```yaml
//! recorder:
//!   keep: 10m          # scan time kept at least (the oldest segments go beyond it); > 0
//!   size: 256MiB       # the most disk the record may take; default 256MiB, at least 1MiB
//!   folder: records    # relative to the project file's folder; default
//!                      # <project file name>.record beside it, or in
//!                      # $STATE_DIRECTORY/<project folder>/ under systemd
//! ```
//!
//! Without the section the recorder is off unless `softplc run --record KEEP` turns it on
//! (the service unit does), with these defaults.

use std::path::{Path, PathBuf};
use std::time::Duration;

use schemars::JsonSchema;
use serde::Deserialize;

use super::error::ErrorKind;
use super::raw::DurationText;
use super::span::YPath;

/// The default size bound.
pub(crate) const DEFAULT_SIZE: u64 = 256 << 20;
/// The smallest size bound: a few segments of the smallest size.
pub(crate) const MIN_SIZE: u64 = 1 << 20;

/// `recorder:` as written.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "recorder settings: a mapping with keep, size and folder"
)]
pub(crate) struct RawRecorder {
    /// Scan time kept.
    pub keep: DurationText,
    /// Size bound (`256MiB`).
    #[serde(default)]
    pub size: Option<String>,
    /// The record's folder, relative to the project file's folder.
    #[serde(default)]
    pub folder: Option<String>,
}

/// The flight recorder's settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecorderConfig {
    /// Scan time kept at least.
    pub keep: Duration,
    /// The most bytes the record takes.
    pub size: u64,
    /// The record's folder.
    pub folder: PathBuf,
}

impl RecorderConfig {
    /// The settings `softplc run --record KEEP` uses when the project has no `recorder:`.
    pub fn defaults(project_file: &Path, keep: Duration) -> Self {
        Self {
            keep,
            size: DEFAULT_SIZE,
            folder: default_folder(project_file),
        }
    }
}

/// Where a project's record goes by default: `<project file name>.record`, beside the project
/// file or in its state folder under systemd (see [`super::state`]).
pub(crate) fn default_folder(project_file: &Path) -> PathBuf {
    let mut name = project_file.file_name().unwrap_or_default().to_os_string();
    name.push(".record");
    super::state::default_state_folder(project_file).join(name)
}

/// What is wrong with a `recorder:` section.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RecorderError {
    /// `size` does not read as a size.
    #[error(
        "recorder.size {text:?} is not a size: write it with a unit, like 64MiB, 1GiB or 500MB"
    )]
    BadSize {
        /// What was written.
        text: String,
    },
    /// `size` is below `MIN_SIZE`.
    #[error("recorder.size {bytes} bytes is too small: at least 1MiB")]
    SmallSize {
        /// The size given.
        bytes: u64,
    },
    /// `folder` is empty.
    #[error(
        "recorder.folder is empty; give a folder (relative to the project file) or leave it out"
    )]
    EmptyFolder,
}

/// Reads a size with its unit: `64MiB`, `1GiB`, `500MB`, `512KiB`, `4096B`.
pub(crate) fn parse_size(text: &str) -> Option<u64> {
    let t = text.trim();
    let split = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let n: u64 = num.parse().ok()?;
    let scale: u64 = match unit.trim() {
        "B" => 1,
        "kB" | "KB" => 1_000,
        "MB" => 1_000_000,
        "GB" => 1_000_000_000,
        "KiB" => 1 << 10,
        "MiB" => 1 << 20,
        "GiB" => 1 << 30,
        _ => return None,
    };
    n.checked_mul(scale)
}

/// The recorder settings of a project read from `file`, with the errors found (and where).
pub(crate) fn validate(
    raw: Option<&RawRecorder>,
    file: &Path,
) -> (Option<RecorderConfig>, Vec<(YPath, ErrorKind)>) {
    let Some(raw) = raw else {
        return (None, Vec::new());
    };
    let path = YPath::root().key("recorder");
    let mut errors = Vec::new();
    let keep = raw.keep.0;
    if keep.is_zero() {
        errors.push((
            path.key("keep"),
            ErrorKind::ZeroDuration {
                key: "recorder.keep",
            },
        ));
    }
    let size = match raw.size.as_deref().map(|t| (t, parse_size(t))) {
        None => DEFAULT_SIZE,
        Some((text, None)) => {
            errors.push((
                path.key("size"),
                RecorderError::BadSize { text: text.into() }.into(),
            ));
            DEFAULT_SIZE
        }
        Some((_, Some(bytes))) if bytes < MIN_SIZE => {
            errors.push((path.key("size"), RecorderError::SmallSize { bytes }.into()));
            DEFAULT_SIZE
        }
        Some((_, Some(bytes))) => bytes,
    };
    let folder = match raw.folder.as_deref() {
        Some("") => {
            errors.push((path.key("folder"), RecorderError::EmptyFolder.into()));
            default_folder(file)
        }
        Some(f) => file.parent().unwrap_or(Path::new("")).join(f),
        None => default_folder(file),
    };
    let config = errors
        .is_empty()
        .then_some(RecorderConfig { keep, size, folder });
    (config, errors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_need_their_unit() {
        assert_eq!(parse_size("64MiB"), Some(64 << 20));
        assert_eq!(parse_size("1GiB"), Some(1 << 30));
        assert_eq!(parse_size("500MB"), Some(500_000_000));
        assert_eq!(parse_size("4096B"), Some(4096));
        assert_eq!(parse_size("64"), None);
        assert_eq!(parse_size("64 mb"), None);
        assert_eq!(parse_size("99999999999999GiB"), None);
    }

    #[test]
    fn defaults_beside_the_project_and_errors_name_the_key() {
        let file = Path::new("/p/press/project.yaml");
        let raw = RawRecorder {
            keep: DurationText(Duration::from_secs(600)),
            size: None,
            folder: None,
        };
        let (config, errors) = validate(Some(&raw), file);
        assert!(errors.is_empty());
        let config = config.unwrap();
        assert_eq!(config.size, DEFAULT_SIZE);
        assert!(config.folder.ends_with("project.yaml.record"), "{config:?}");
        let bad = RawRecorder {
            keep: DurationText(Duration::ZERO),
            size: Some("lots".into()),
            folder: Some(String::new()),
        };
        let (config, errors) = validate(Some(&bad), file);
        assert_eq!(config, None);
        let text: Vec<String> = errors.iter().map(|(_, e)| e.to_string()).collect();
        assert_eq!(
            text,
            [
                "recorder.keep must be greater than zero",
                "recorder.size \"lots\" is not a size: write it with a unit, like 64MiB, 1GiB or 500MB",
                "recorder.folder is empty; give a folder (relative to the project file) or leave it out",
            ]
        );
    }
}
