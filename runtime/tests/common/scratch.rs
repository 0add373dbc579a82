//! A project folder of a test's own, removed when the test ends.

use std::path::PathBuf;

/// Two simulated lines with a MiniMod each, for a project of two tasks: `fast_line` (57600
/// Bd, module `f1`) and `slow_line` (9600 Bd, module `s1`); a project text's `{lines}`.
pub(crate) const TWO_LINES: &str = "\
buses:
  - { name: fast_line, port: sim, baud: 57600 }
  - { name: slow_line, port: sim, baud: 9600 }
modules:
  - { name: f1, bus: fast_line, model: minimod, address: 1 }
  - { name: s1, bus: slow_line, model: minimod, address: 1 }
";

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
