//! Helpers of softplc's end-to-end tests (the tests themselves are in `tests/tests/`).
//!
//! - [`scripted`]: a fake [`Transport`](softplc_io::line::Transport) on a virtual
//!   time cursor that answers each request with scripted bytes at scripted times, so the bus
//!   owner's discipline (timeouts, guard, flush, retries) is tested deterministically.
//! - [`frames`]: building RTU frames independently of the codec under test (our own CRC).
//! - [`minimod`]: the real MiniMod driver and point indexes, by the manual's names.
//! - [`workspace_root`]: where `examples/` and `programs/` are.

pub mod frames;
pub mod minimod;
pub mod scripted;

use std::path::PathBuf;

/// The workspace's root folder (parent of this crate's folder).
pub fn workspace_root() -> PathBuf {
    let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    here.parent().map(PathBuf::from).unwrap_or(here)
}
