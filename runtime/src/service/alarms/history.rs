//! The alarm history file, `PROJECT.alarms.jsonl` in the state folder: one event a line, the
//! oldest first, the latest `alarms.history` of them, rewritten whole and atomically (a
//! temporary file renamed over it) after each batch, so it is never torn.
//!
//! A file that cannot be read back (a line that is no event: a disk fault, a hand edit) must
//! not stop the machine: it is set aside as `PROJECT.alarms.jsonl.damaged` with a log line
//! naming it and the bad line, and the history starts afresh.

use std::path::{Path, PathBuf};

use super::book::AlarmEvent;

/// The alarm history file of `project_file`: `PROJECT.alarms.jsonl` in its state folder.
pub fn history_path(project_file: &Path) -> PathBuf {
    let mut name = project_file.file_name().unwrap_or_default().to_os_string();
    name.push(".alarms.jsonl");
    crate::project::state::default_state_folder(project_file).join(name)
}

/// Why the history file cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// The file cannot be opened or read.
    #[error("{path}: cannot read the alarm history: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A line is not an event.
    #[error("{path}:{line}: not an alarm event: {source}")]
    Bad {
        /// The file.
        path: PathBuf,
        /// The line (from 1).
        line: usize,
        /// Why.
        source: serde_json::Error,
    },
}

/// The events of the history file at `path`, the oldest first; none when it does not exist.
pub fn read(path: &Path) -> Result<Vec<AlarmEvent>, HistoryError> {
    use crate::service::json_lines::{read, LinesError};
    read(path).map_err(|e| match e {
        LinesError::Io(source) => HistoryError::Io {
            path: path.to_path_buf(),
            source,
        },
        LinesError::Bad(line, source) => HistoryError::Bad {
            path: path.to_path_buf(),
            line,
            source,
        },
    })
}

/// The history kept at `path`, for a start: a damaged file is renamed to `.damaged` (and
/// logged) and the history starts empty.
pub(crate) fn load(path: &Path) -> Vec<AlarmEvent> {
    match read(path) {
        Ok(events) => events,
        Err(e) => {
            let mut aside = path.as_os_str().to_os_string();
            aside.push(".damaged");
            let aside = PathBuf::from(aside);
            match std::fs::rename(path, &aside) {
                Ok(()) => tracing::error!(
                    "alarms: {e}; the file is set aside as {} and the history starts afresh",
                    aside.display()
                ),
                Err(r) => tracing::error!(
                    "alarms: {e}; it cannot be set aside ({r}) and will be overwritten"
                ),
            }
            Vec::new()
        }
    }
}

/// Rewrites the file at `path` with `events`, atomically.
pub(crate) fn write<'a>(
    path: &Path,
    events: impl Iterator<Item = &'a AlarmEvent>,
) -> Result<(), crate::retain::RetainError> {
    let text = crate::service::json_lines::text(events);
    crate::retain::write_file_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::alarms::EventKind;

    fn event(cycle: u64) -> AlarmEvent {
        AlarmEvent {
            utc: "2026-01-01T00:00:00.000Z".into(),
            cycle,
            alarm: "jam".into(),
            event: EventKind::Raised,
            priority: 750,
            text: "Door jammed".into(),
            by: None,
        }
    }

    #[test]
    fn the_file_is_written_whole_and_a_damaged_one_is_set_aside() {
        let dir = std::env::temp_dir().join(format!("softplc-alarm-hist-{}", std::process::id()));
        drop(std::fs::remove_dir_all(&dir));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.yaml.alarms.jsonl");
        assert_eq!(load(&path), vec![], "none yet");
        let events = [event(1), event(2)];
        write(&path, events.iter()).unwrap();
        assert_eq!(load(&path), events);
        // A torn or edited line: set aside, named, and the history starts afresh.
        std::fs::write(&path, "{\"utc\":\"x\",\"cycle\":1}\nnot json\n").unwrap();
        let e = read(&path).unwrap_err().to_string();
        assert!(
            e.contains("p.yaml.alarms.jsonl:1: not an alarm event"),
            "{e}"
        );
        assert_eq!(load(&path), vec![]);
        assert!(!path.exists());
        let aside = dir.join("p.yaml.alarms.jsonl.damaged");
        assert!(std::fs::read_to_string(aside).unwrap().contains("not json"));
        drop(std::fs::remove_dir_all(dir));
    }
}
