//! Files of one JSON object a line (the audit file, the alarm history): read whole, written
//! whole. Each file's own module names its errors; this is the reading and writing they share.

use std::path::Path;

use serde::de::DeserializeOwned;
use serde::Serialize;

/// Why a file of JSON lines cannot be read.
#[derive(Debug)]
pub(crate) enum LinesError {
    /// The file cannot be opened or read.
    Io(std::io::Error),
    /// Line `.0` (from 1) is not an item.
    Bad(usize, serde_json::Error),
}

/// The items of the file at `path`, in file order; none when it does not exist.
pub(crate) fn read<T: DeserializeOwned>(path: &Path) -> Result<Vec<T>, LinesError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(LinesError::Io(e)),
    };
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| serde_json::from_str(l).map_err(|e| LinesError::Bad(i + 1, e)))
        .collect()
}

/// `items` as the file's text, one a line.
pub(crate) fn text<'a, T: Serialize + 'a>(items: impl Iterator<Item = &'a T>) -> String {
    items
        .filter_map(|x| serde_json::to_string(x).ok())
        .fold(String::new(), |mut s, l| {
            s.push_str(&l);
            s.push('\n');
            s
        })
}
