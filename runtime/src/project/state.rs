//! Where a PLC keeps what it must find again after a restart: retained values, kept forces.
//!
//! Under systemd the unit's `StateDirectory=` is the place (`$STATE_DIRECTORY`, which systemd
//! sets for every `Exec*` command, `check` included): the unit's dynamic user cannot write
//! beside the project under `/etc/softplc/NAME/`. One state folder serves every instance of
//! `softplc@.service`, so each project gets a subfolder named after the project's own folder
//! (`/var/lib/softplc/NAME/`). Without systemd the files stay beside the project file.
//!
//! Only defaults move: a `retain.file` the project names is still relative to its folder.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// The folder for `project_file`'s state, given the value of `$STATE_DIRECTORY` (systemd
/// may list several, separated by colons: the first is used).
pub(crate) fn state_folder(project_file: &Path, state_directory: Option<&OsStr>) -> PathBuf {
    let beside = project_file.parent().unwrap_or(Path::new("")).to_path_buf();
    let Some(dirs) = state_directory.and_then(OsStr::to_str) else {
        return beside;
    };
    let Some(first) = dirs.split(':').find(|d| !d.is_empty()) else {
        return beside;
    };
    // A project given as `project.yaml` lives in the current folder: name it by that.
    let named = if beside.as_os_str().is_empty() {
        Path::new(".")
    } else {
        beside.as_path()
    };
    let instance = named
        .canonicalize()
        .unwrap_or_else(|_| named.to_path_buf())
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "project".into());
    Path::new(first).join(instance)
}

/// [`state_folder`] with this process's `$STATE_DIRECTORY`.
pub(crate) fn default_state_folder(project_file: &Path) -> PathBuf {
    state_folder(project_file, std::env::var_os("STATE_DIRECTORY").as_deref())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beside_the_project_without_systemd() {
        let p = Path::new("/etc/softplc/press/project.yaml");
        assert_eq!(state_folder(p, None), Path::new("/etc/softplc/press"));
        assert_eq!(
            state_folder(p, Some(OsStr::new(""))),
            Path::new("/etc/softplc/press")
        );
    }

    #[test]
    fn in_the_state_directory_per_instance_under_systemd() {
        let p = Path::new("/etc/softplc/press/project.yaml");
        assert_eq!(
            state_folder(p, Some(OsStr::new("/var/lib/softplc"))),
            Path::new("/var/lib/softplc/press")
        );
        assert_eq!(
            state_folder(p, Some(OsStr::new("/var/lib/softplc:/var/lib/other"))),
            Path::new("/var/lib/softplc/press"),
            "the first of several"
        );
    }
}
