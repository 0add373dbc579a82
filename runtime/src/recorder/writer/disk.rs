//! Where the writer's bytes go: the file system, behind a seam so a test can make it fail as
//! a full disk does (ENOSPC at any write, after part of the bytes went down).

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

/// The file operations the recorder's writer makes. [`FileDisk`] is the file system; a test
/// puts in one that refuses writes as a full or a small disk does.
pub trait Disk: Send + 'static {
    /// Creates `path`, which must not exist, for appending.
    fn create(&mut self, path: &Path) -> std::io::Result<File>;
    /// Appends `bytes` to `file` and syncs them to the device.
    fn append(&mut self, file: &mut File, bytes: &[u8]) -> std::io::Result<()>;
}

/// The file system.
#[derive(Debug, Clone, Copy, Default)]
pub struct FileDisk;

impl Disk for FileDisk {
    fn create(&mut self, path: &Path) -> std::io::Result<File> {
        File::options().append(true).create_new(true).open(path)
    }

    fn append(&mut self, file: &mut File, bytes: &[u8]) -> std::io::Result<()> {
        file.write_all(bytes)?;
        // On the writer's thread, at most about once a second: a power cut loses no more.
        file.sync_data()
    }
}

/// Whether `e` says the disk (or the user's quota on it) is full: then deleting the record's
/// own oldest segments can make room.
pub(crate) fn is_full(e: &std::io::Error) -> bool {
    matches!(e.raw_os_error(), Some(libc::ENOSPC | libc::EDQUOT))
        || e.kind() == std::io::ErrorKind::StorageFull
}

/// A disk that fails as a full one does, for tests of what the recorder does then: a disk of
/// `capacity` bytes for one folder (what fits of a write goes down, then ENOSPC, as a real
/// full disk leaves it), and a switch that fills it at once (another program took the space).
#[derive(Debug, Clone)]
pub struct FaultDisk {
    folder: PathBuf,
    capacity: u64,
    full: Arc<AtomicBool>,
    refused: Arc<AtomicU64>,
}

impl FaultDisk {
    /// A disk as large as `capacity` bytes for the files of `folder`.
    pub fn new(folder: &Path, capacity: u64) -> Self {
        Self {
            folder: folder.to_path_buf(),
            capacity,
            full: Arc::new(AtomicBool::new(false)),
            refused: Arc::new(AtomicU64::new(0)),
        }
    }

    /// The switch: on, every write is refused.
    pub fn full_switch(&self) -> Arc<AtomicBool> {
        self.full.clone()
    }

    /// Writes refused so far.
    pub fn refused(&self) -> u64 {
        self.refused.load(Ordering::SeqCst)
    }

    /// Bytes the folder's files take.
    pub fn used(&self) -> u64 {
        std::fs::read_dir(&self.folder)
            .map(|entries| {
                entries
                    .filter_map(Result::ok)
                    .filter_map(|e| e.metadata().ok())
                    .map(|m| m.len())
                    .sum()
            })
            .unwrap_or(0)
    }
}

impl Disk for FaultDisk {
    fn create(&mut self, path: &Path) -> std::io::Result<File> {
        FileDisk.create(path)
    }

    fn append(&mut self, file: &mut File, bytes: &[u8]) -> std::io::Result<()> {
        let room = match self.full.load(Ordering::SeqCst) {
            true => 0,
            false => usize::try_from(self.capacity.saturating_sub(self.used())).unwrap_or(0),
        };
        if bytes.len() <= room {
            return FileDisk.append(file, bytes);
        }
        FileDisk.append(file, &bytes[..room])?;
        self.refused.fetch_add(1, Ordering::SeqCst);
        Err(std::io::Error::from_raw_os_error(libc::ENOSPC))
    }
}
