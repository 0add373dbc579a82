//! Retained variables: memory tags marked `retain: true` keep their value across a restart and
//! a program reload.
//!
//! - **Load** ([`Retainer::open`]): at start-up, before the first scan, the values in the file
//!   replace the tags' initial values. A missing file (first start) or a corrupt one is
//!   reported and the initial values are used; a corrupt file is kept aside as
//!   `FILE.corrupt` for inspection. A tag absent from the file, or whose saved value does not
//!   fit its type, keeps its initial value (reported).
//! - **Save** ([`Retainer::tick`], [`Retainer::finish`]): between two cycles, at most once per
//!   `retain.period`, the scan copies the retained values (a few words) when they changed and
//!   hands them to a writer thread (`save_thread`), without waiting: if the writer is
//!   still busy with the previous copy, the scan hands the newest over after a later cycle. On stop the last values are
//!   written before the process exits. A program reload keeps the image, so nothing is lost.
//! - **Atomic write**: the writer writes `FILE.tmp`, fsyncs it, renames it over `FILE` and
//!   fsyncs the folder. A crash or a power cut at any point leaves either the previous file or
//!   the new one, never a torn one; a leftover `FILE.tmp` is ignored.
//!
//! The file is JSON: `{"softplc_retain": 1, "values": {"run_seconds": 5321, "alarm": false}}`.

use crate::log_limit::{limited, Site};
use std::collections::BTreeMap;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use serde_json::{Map, Number, Value as Json};
use softplc_io::point::{Value, ValueType};

use crate::image::{ProcessImage, TagId};
use crate::project::Project;
use crate::save_thread::{Handed, SaveThread};
use softplc_io::time::ScanInstant;

/// The format marker and version in every file.
const MARKER: &str = "softplc_retain";
const VERSION: u64 = 1;

/// Why a retain file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RetainError {
    /// An OS error on the file, its temporary copy or its folder.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
}

/// What loading found, for the log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LoadNote {
    /// No file: the initial values are used (normal at the first start).
    Missing(PathBuf),
    /// The file could not be read or parsed; the initial values are used.
    Corrupt {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
        /// Where the bad file was moved, if it could be.
        kept_as: Option<PathBuf>,
    },
    /// A retained tag not in the file.
    NotSaved(String),
    /// A saved value that does not fit its tag.
    BadValue {
        /// The tag.
        tag: String,
        /// Its type.
        ty: ValueType,
        /// The saved JSON.
        saved: String,
    },
    /// Values restored.
    Restored {
        /// The file.
        path: PathBuf,
        /// How many tags.
        count: usize,
    },
}

impl std::fmt::Display for LoadNote {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoadNote::Missing(p) => write!(
                f,
                "retain: no file {} yet; retained tags start from their initial values",
                p.display()
            ),
            LoadNote::Corrupt {
                path,
                reason,
                kept_as,
            } => {
                write!(
                    f,
                    "retain: {} is unreadable ({reason}); retained tags start from their initial values",
                    path.display()
                )?;
                if let Some(k) = kept_as {
                    write!(f, "; the bad file is kept as {}", k.display())?;
                }
                Ok(())
            }
            LoadNote::NotSaved(t) => {
                write!(f, "retain: tag {t} is not in the file; it starts from its initial value")
            }
            LoadNote::BadValue { tag, ty, saved } => write!(
                f,
                "retain: saved value {saved} of tag {tag} is not a {ty}; it starts from its initial value"
            ),
            LoadNote::Restored { path, count } => {
                write!(f, "retain: {count} value(s) restored from {}", path.display())
            }
        }
    }
}

impl LoadNote {
    /// True for notes that deserve a warning (not the normal first start or a restore).
    pub fn is_warning(&self) -> bool {
        !matches!(self, LoadNote::Missing(_) | LoadNote::Restored { .. })
    }
}

/// The retained tags of a running PLC and their writer.
#[derive(Debug)]
pub struct Retainer {
    path: PathBuf,
    period: Duration,
    tags: Vec<(TagId, String)>,
    /// Values last handed to the writer.
    saved: Vec<Value>,
    last: Option<ScanInstant>,
    writer: SaveThread<Snapshot>,
    /// Why the last save failed; `None` once one succeeds.
    failing: SaveFailure,
}

/// Why the last save of the retained values failed (`None`: it did not), shared with whoever
/// reports the PLC's state.
pub type SaveFailure = Arc<Mutex<Option<String>>>;

/// The values to write, by tag name.
type Snapshot = BTreeMap<String, Value>;

impl Retainer {
    /// The retained tags of `project`, their saved values applied to `image`; `None` when no
    /// tag is retained. Also returns what loading found.
    pub fn open(project: &Project, image: &mut ProcessImage) -> (Option<Self>, Vec<LoadNote>) {
        let tags: Vec<(TagId, String)> = project
            .tags
            .iter()
            .enumerate()
            .filter(|(_, t)| t.retain)
            .map(|(i, t)| (TagId(i as u32), t.name.clone()))
            .collect();
        if tags.is_empty() {
            return (None, Vec::new());
        }
        let path = project.retain.file.clone();
        let notes = load_into(&path, &tags, image);
        let saved = tags.iter().map(|(id, _)| image.get(*id)).collect();
        let failing = SaveFailure::default();
        let (to, why) = (path.clone(), failing.clone());
        let writer = SaveThread::new(
            "retain",
            Arc::new(move |snap: &Snapshot| save(&to, snap, &why)),
        );
        (
            Some(Self {
                path,
                period: project.retain.period,
                tags,
                saved,
                last: None,
                writer,
                failing,
            }),
            notes,
        )
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Why the last save failed, while it does.
    pub fn save_failure(&self) -> SaveFailure {
        self.failing.clone()
    }

    /// Called between cycles with the scan time: at most once per period, hands the values to
    /// the writer if they changed; hands over what waited for a busy writer. Never waits.
    pub fn tick(&mut self, image: &ProcessImage, now: ScanInstant) {
        if self.writer.flush() == Handed::Waiting {
            if let Some(why) = self.writer.not_started() {
                *self.failing.lock().unwrap_or_else(PoisonError::into_inner) = Some(why.into());
            }
        }
        if self.last.is_some_and(|l| now - l < self.period) {
            return;
        }
        self.last = Some(now);
        let current: Vec<Value> = self.tags.iter().map(|(id, _)| image.get(*id)).collect();
        if current == self.saved {
            return;
        }
        // Taken or waiting, these are the values the file gets next.
        self.writer.offer(self.snapshot(&current));
        self.saved = current;
    }

    fn snapshot(&self, values: &[Value]) -> Snapshot {
        self.tags
            .iter()
            .zip(values)
            .map(|((_, name), v)| (name.clone(), *v))
            .collect()
    }

    /// On stop: waits for the writer, then writes the current values (always, so the file
    /// holds the last scan's values).
    pub fn finish(&mut self, image: &ProcessImage) {
        let current: Vec<Value> = self.tags.iter().map(|(id, _)| image.get(*id)).collect();
        self.writer.finish_with(&self.snapshot(&current));
        self.saved = current;
    }
}

/// A log site a full disk repeats at every save (see [`crate::log_limit`]).
const SAVE_FAILED: Site = Site::new("retain.save", "retain: failed saves");

/// Writes `values` to `path`, keeping `failing` up to date; whether it was written.
fn save(path: &Path, values: &Snapshot, failing: &SaveFailure) -> bool {
    let result = write_atomic(path, values);
    let mut failing = failing.lock().unwrap_or_else(PoisonError::into_inner);
    match result {
        Ok(()) => {
            if failing.take().is_some() {
                tracing::warn!("retain: saving to {} again", path.display());
            }
            true
        }
        Err(e) => {
            let why = e.to_string();
            limited!(ERROR, SAVE_FAILED, why, "retain: cannot save: {e}");
            *failing = Some(why);
            false
        }
    }
}

/// `FILE.tmp` beside `FILE`.
fn temp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `values` to `path` atomically: temporary file, fsync, rename, fsync of the folder.
pub fn write_atomic(path: &Path, values: &Snapshot) -> Result<(), RetainError> {
    let mut map = Map::new();
    for (name, v) in values {
        map.insert(name.clone(), to_json(*v));
    }
    let doc = serde_json::json!({ MARKER: VERSION, "values": Json::Object(map) });
    let mut text = serde_json::to_vec_pretty(&doc).unwrap_or_default();
    text.push(b'\n');
    write_file_atomic(path, &text)
}

/// Replaces `path` with `bytes` so that a crash or power cut at any moment leaves either the
/// old file or the new one, never a mix: temporary file, fsync, rename, fsync of the folder.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<(), RetainError> {
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |source| RetainError::Io { path: p, source }
    };
    let tmp = temp_path(path);
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    fs::create_dir_all(&folder).map_err(io(&folder))?;
    {
        let mut f = File::create(&tmp).map_err(io(&tmp))?;
        f.write_all(bytes).map_err(io(&tmp))?;
        f.sync_all().map_err(io(&tmp))?;
    }
    fs::rename(&tmp, path).map_err(io(path))?;
    // The rename is durable only once the folder's entry is on disk.
    File::open(&folder)
        .and_then(|d| d.sync_all())
        .map_err(io(&folder))?;
    Ok(())
}

fn to_json(v: Value) -> Json {
    match v {
        Value::Bool(b) => Json::Bool(b),
        Value::U16(x) => Json::from(x),
        Value::I32(x) => Json::from(x),
        Value::F32(x) => Number::from_f64(f64::from(x)).map_or(Json::Null, Json::Number),
    }
}

fn from_json(j: &Json, ty: ValueType) -> Option<Value> {
    match (ty, j) {
        (ValueType::Bool, Json::Bool(b)) => Some(Value::Bool(*b)),
        (ValueType::U16, Json::Number(n)) => n
            .as_u64()
            .and_then(|x| u16::try_from(x).ok())
            .map(Value::U16),
        (ValueType::I32, Json::Number(n)) => n
            .as_i64()
            .and_then(|x| i32::try_from(x).ok())
            .map(Value::I32),
        (ValueType::F32, Json::Number(n)) => n.as_f64().map(|x| Value::F32(x as f32)),
        _ => None,
    }
}

/// Reads the file and applies what fits to `image`.
fn load_into(path: &Path, tags: &[(TagId, String)], image: &mut ProcessImage) -> Vec<LoadNote> {
    let text = match fs::read(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return vec![LoadNote::Missing(path.to_path_buf())]
        }
        Err(e) => return vec![corrupt(path, e.to_string())],
    };
    let doc: Json = match serde_json::from_slice(&text) {
        Ok(d) => d,
        Err(e) => return vec![corrupt(path, e.to_string())],
    };
    let values = match (doc.get(MARKER).and_then(Json::as_u64), doc.get("values")) {
        (Some(VERSION), Some(Json::Object(m))) => m,
        _ => {
            return vec![corrupt(
                path,
                format!("not a version {VERSION} softplc retain file"),
            )]
        }
    };
    let mut notes = Vec::new();
    let mut count = 0;
    for (id, name) in tags {
        let ty = image.value_type(*id);
        match values.get(name) {
            None => notes.push(LoadNote::NotSaved(name.clone())),
            Some(j) => match from_json(j, ty) {
                Some(v) => {
                    image.set(*id, v, ScanInstant::ZERO);
                    count += 1;
                }
                None => notes.push(LoadNote::BadValue {
                    tag: name.clone(),
                    ty,
                    saved: j.to_string(),
                }),
            },
        }
    }
    notes.push(LoadNote::Restored {
        path: path.to_path_buf(),
        count,
    });
    notes
}

/// Moves a bad file aside so the next save does not erase the evidence.
fn corrupt(path: &Path, reason: String) -> LoadNote {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".corrupt");
    let aside = path.with_file_name(name);
    let kept_as = fs::rename(path, &aside).ok().map(|()| aside);
    LoadNote::Corrupt {
        path: path.to_path_buf(),
        reason,
        kept_as,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("softplc-retain-{}-{name}", std::process::id()));
        // Best effort: the test's scratch folder, possibly absent.
        drop(fs::remove_dir_all(&d));
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn image() -> (ProcessImage, Vec<(TagId, String)>) {
        let img = ProcessImage::new([
            ("hours".to_string(), Value::I32(0)),
            ("on".to_string(), Value::Bool(false)),
            ("temp".to_string(), Value::F32(0.0)),
            ("word".to_string(), Value::U16(0)),
        ]);
        let tags = img
            .names()
            .iter()
            .enumerate()
            .map(|(i, n)| (TagId(i as u32), n.clone()))
            .collect();
        (img, tags)
    }

    #[test]
    fn round_trip_and_atomic_replacement() {
        let d = dir("rt");
        let path = d.join("p.retain.json");
        let snap: Snapshot = [
            ("hours".to_string(), Value::I32(-42)),
            ("on".to_string(), Value::Bool(true)),
            ("temp".to_string(), Value::F32(21.5)),
            ("word".to_string(), Value::U16(65535)),
        ]
        .into_iter()
        .collect();
        write_atomic(&path, &snap).unwrap();
        // A torn write of a later save left a temporary file: it is ignored.
        fs::write(temp_path(&path), b"{\"softplc_ret").unwrap();
        let (mut img, tags) = image();
        let notes = load_into(&path, &tags, &mut img);
        assert_eq!(
            notes,
            vec![LoadNote::Restored {
                path: path.clone(),
                count: 4
            }]
        );
        assert_eq!(img.get(TagId(0)), Value::I32(-42));
        assert_eq!(img.get(TagId(1)), Value::Bool(true));
        assert_eq!(img.get(TagId(2)), Value::F32(21.5));
        assert_eq!(img.get(TagId(3)), Value::U16(65535));
        write_atomic(&path, &snap).unwrap();
        assert!(
            !temp_path(&path).exists(),
            "the temporary file became the file"
        );
    }

    #[test]
    fn missing_corrupt_and_mismatched_files_use_the_defaults() {
        let d = dir("bad");
        let path = d.join("r.json");
        let (mut img, tags) = image();
        assert_eq!(
            load_into(&path, &tags, &mut img),
            vec![LoadNote::Missing(path.clone())]
        );
        fs::write(&path, b"{\"softplc_retain\": 1, \"values\": {\"hours\": 1").unwrap();
        let notes = load_into(&path, &tags, &mut img);
        assert!(matches!(
            &notes[0],
            LoadNote::Corrupt {
                kept_as: Some(_),
                ..
            }
        ));
        assert!(notes[0].is_warning());
        assert!(!path.exists() && d.join("r.json.corrupt").exists());
        assert_eq!(img.get(TagId(0)), Value::I32(0));
        fs::write(
            &path,
            br#"{"softplc_retain": 1, "values": {"hours": 70000000000, "on": 1, "temp": 2}}"#,
        )
        .unwrap();
        let notes = load_into(&path, &tags, &mut img);
        let shown: Vec<String> = notes.iter().map(ToString::to_string).collect();
        assert_eq!(notes.len(), 4, "{shown:#?}");
        assert!(
            shown[0].contains("70000000000 of tag hours is not a i32"),
            "{shown:#?}"
        );
        assert!(
            shown[2].contains("tag word is not in the file"),
            "{shown:#?}"
        );
        assert_eq!(img.get(TagId(2)), Value::F32(2.0));
        fs::write(&path, br#"{"values": {}}"#).unwrap();
        assert!(matches!(
            load_into(&path, &tags, &mut img)[0],
            LoadNote::Corrupt { .. }
        ));
    }
}
