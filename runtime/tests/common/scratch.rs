//! A project folder of a test's own, removed when the test ends.

use std::path::PathBuf;

/// A folder of its own for one case, removed on drop.
pub(crate) struct Scratch {
    pub(crate) dir: PathBuf,
}

impl Scratch {
    /// An empty folder for `case` of `subject`.
    pub(crate) fn new(subject: &str, case: &str) -> Self {
        Self {
            dir: super::host::scratch_dir(subject, case),
        }
    }

    /// Writes `text` to the file `name` in the folder; its path.
    pub(crate) fn write(&self, name: &str, text: &str) -> PathBuf {
        let path = self.dir.join(name);
        std::fs::write(&path, text).expect("write a scratch file");
        path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        // Best effort: the test's scratch folder (it may not exist).
        drop(std::fs::remove_dir_all(&self.dir));
    }
}
