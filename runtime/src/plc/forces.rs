//! Forces that survive a restart, when asked (`softplc run --keep-forces`): every force and
//! unforce rewrites a small file beside the project (under systemd: in its state directory)
//! atomically, on a writer thread of its own (a force is applied at a cycle boundary, which
//! must not wait for the disk), and the next start applies it before the first scan. Without
//! the option forces are lost on restart, as on most PLCs. With several tasks each task keeps
//! the forces of its own image in a file of its own (`PROJECT.forces.TASK.json`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::Plc;
use crate::log_limit::{limited, Site};
use crate::save_thread::SaveThread;

/// A log site a full disk would repeat at every force (see [`crate::log_limit`]).
const KEEP_FAILED: Site = Site::new("forces.keep", "forces: failed saves");

/// The writer of the kept-forces file.
pub(super) type ForcesWriter = SaveThread<Vec<u8>>;

/// The file that keeps `project_file`'s forces: `PROJECT.forces.json` beside it, or in the
/// unit's state directory under systemd (see `crate::project::state`).
pub fn forces_path(project_file: &Path) -> PathBuf {
    let mut name = project_file.file_name().unwrap_or_default().to_os_string();
    name.push(".forces.json");
    crate::project::state::default_state_folder(project_file).join(name)
}

impl Plc {
    /// Keeps forces in `path` from now on, and applies the ones it holds. A force that no
    /// longer fits the project (tag gone, type changed, now pushed down) is skipped with a log
    /// line, never applied half.
    pub fn keep_forces(&mut self, path: PathBuf) {
        match std::fs::read(&path) {
            Ok(bytes) => match serde_json::from_slice::<BTreeMap<String, String>>(&bytes) {
                Ok(saved) => {
                    for (tag, value) in saved {
                        if self.copies_in(&tag) {
                            // Its task's next copy-in would overwrite the force unseen.
                            tracing::warn!(
                                "kept force {tag}={value} not applied: another task owns {tag} \
                                 now; force it again"
                            );
                        } else if let Err(e) = self.force(&tag, &value) {
                            tracing::warn!("kept force {tag}={value} not applied: {e}");
                        }
                    }
                }
                Err(e) => tracing::error!(
                    "{}: not a forces file ({e}); no force applied",
                    path.display()
                ),
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => tracing::error!("{}: cannot read ({e}); no force applied", path.display()),
        }
        let to = path.clone();
        self.kept_forces = Some(SaveThread::new(
            "forces",
            Arc::new(move |text: &Vec<u8>| {
                crate::retain::write_file_atomic(&to, text)
                    .map_err(|e| {
                        let why = e.to_string();
                        limited!(ERROR, KEEP_FAILED, why, "cannot keep forces: {e}");
                    })
                    .is_ok()
            }),
        ));
        self.save_forces();
    }

    /// Whether `tag` is one this task copies in from the task owning it.
    fn copies_in(&self, tag: &str) -> bool {
        match (&self.task, self.image.id(tag)) {
            (Some(link), Some(id)) => link.foreign.contains(&id),
            _ => false,
        }
    }

    /// Hands the current forces to the kept-forces file's writer, if there is one.
    pub(super) fn save_forces(&mut self) {
        if self.kept_forces.is_none() {
            return;
        }
        let forces: BTreeMap<String, String> = (0..self.image.len())
            .filter_map(|i| {
                let id = crate::image::TagId(i as u32);
                self.image
                    .forced(id)
                    .map(|v| (self.image.name(id).to_string(), v.to_string()))
            })
            .collect();
        let mut text = serde_json::to_vec_pretty(&forces).unwrap_or_default();
        text.push(b'\n');
        if let Some(writer) = self.kept_forces.as_mut() {
            writer.offer(text);
        }
    }
}
