//! Device profile files: any Modbus device described in YAML (see `raw` for the format),
//! read into a typed [`Profile`] once, with every error at its file:line:col as for the
//! project file.
//!
//! A project names a profile as a module's model, `model: profile:PATH`, PATH relative to
//! the project file's folder (a shared folder is a relative or absolute path to it). Tags bind
//! to the profile's points by name, as to a built-in model's.

mod error;
pub(crate) mod raw;
pub(crate) mod schema;
mod validate;

use std::path::Path;

pub use error::ProfileError;
pub use softplc_io::devices::profile::Profile;
use softplc_io::devices::profile::{PointAccess, Table, WriteMode};

use super::error::{read_text, ProjectErrors};

/// The tables, in the order errors list them.
pub(crate) const TABLES: [Table; 4] = [Table::Coil, Table::Discrete, Table::Input, Table::Holding];
/// The access words.
pub(crate) const ACCESS: [PointAccess; 3] = [
    PointAccess::Read,
    PointAccess::Write,
    PointAccess::ReadWrite,
];
/// The write words.
pub(crate) const WRITES: [(&str, WriteMode); 2] = [
    ("on_change", WriteMode::OnChange),
    ("cyclic", WriteMode::Cyclic),
];

/// Reads and checks the profile file at `path`.
pub fn load(path: &Path) -> Result<Profile, ProjectErrors> {
    parse_str(&read_text(path)?, path)
}

/// Checks profile text as if read from `file` (errors name `file`).
pub fn parse_str(text: &str, file: &Path) -> Result<Profile, ProjectErrors> {
    super::unknown_keys::read_checked::<raw::RawProfile, _>(text, file, validate::validate)
}
