//! The recorder's writer thread: cycle records into checksummed blocks, blocks into bounded
//! segment files, the oldest segments deleted beyond the time and size bounds.
//!
//! A block is written (and `fdatasync`ed) when it holds [`Settings::block_bytes`] or spans
//! [`Settings::block_time`] of scan time, and after a second of wall-clock time without a
//! record (a stopped or hung scan), so a `kill -9` — or a power cut — loses at most the block
//! being filled. A segment is closed when it reaches [`Settings::segment_bytes`] or spans a
//! quarter of `keep`, and the next one starts with a header and a keyframe of the whole state,
//! so any segment can be read (and replayed) without the ones before it.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crossbeam_channel::{Receiver, RecvTimeoutError};
use softplc_io::point::{Quality, Value};

use crate::project::{Project, RecorderConfig};
use crate::recorder::format::{self, BlockKind, CycleRecord, Enc, End, Event, Header, Keyframe};
use crate::recorder::tap::TapCounters;

/// The extension of segment files.
pub(crate) const SEGMENT_EXT: &str = "splrec";

/// How the writer cuts and bounds the record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Settings {
    /// The record's folder (created if missing).
    pub folder: PathBuf,
    /// How much scan time the record keeps at least.
    pub keep: Duration,
    /// The most bytes the record's segments may take together.
    pub max_bytes: u64,
    /// A segment is closed past this size.
    pub segment_bytes: u64,
    /// A block is written past this size.
    pub block_bytes: usize,
    /// A block is written once it spans this much scan time.
    pub block_time: Duration,
    /// Records the channel holds before the scan drops them.
    pub channel: usize,
}

impl Settings {
    /// The defaults for a record in `folder` keeping `keep` within `max_bytes`.
    pub fn new(folder: PathBuf, keep: Duration, max_bytes: u64) -> Self {
        Self {
            folder,
            keep,
            max_bytes,
            segment_bytes: (max_bytes / 8).clamp(64 << 10, 16 << 20),
            block_bytes: 16 << 10,
            block_time: Duration::from_secs(1),
            channel: 1024,
        }
    }
}

impl Settings {
    /// The settings for a run of `project`: its `recorder:` section, with `keep` from
    /// `softplc run --record KEEP` when given (which turns the recorder on with the defaults
    /// when the project has no section). `None`: the run is not recorded.
    pub fn for_run(project: &Project, keep: Option<Duration>) -> Option<Self> {
        let config = match (&project.recorder, keep) {
            (Some(c), Some(keep)) => RecorderConfig { keep, ..c.clone() },
            (Some(c), None) => c.clone(),
            (None, Some(keep)) => RecorderConfig::defaults(&project.source, keep),
            (None, None) => return None,
        };
        Some(Self::new(config.folder, config.keep, config.size))
    }
}

/// What the writer did, when it ends.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct WriterOutcome {
    /// Cycle records written.
    pub records: u64,
    /// Segments it created.
    pub segments: u32,
    /// Segments it deleted (rotation).
    pub deleted: u32,
    /// Why it stopped writing early, if it did.
    pub error: Option<String>,
}

/// A running recorder: its writer thread and the counts the scan keeps.
#[derive(Debug)]
pub struct RecorderHandle {
    thread: JoinHandle<WriterOutcome>,
    counters: Arc<TapCounters>,
    folder: PathBuf,
}

impl RecorderHandle {
    /// The record's folder.
    pub fn folder(&self) -> &Path {
        &self.folder
    }

    /// Records dropped so far because the writer fell behind.
    pub fn dropped(&self) -> u64 {
        self.counters
            .dropped
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Waits for the writer to write what it holds and its end block (once the PLC, and with
    /// it the scan's side, is gone).
    pub fn finish(self) -> WriterOutcome {
        self.thread.join().unwrap_or_else(|_| WriterOutcome {
            error: Some("the recorder's writer thread panicked".into()),
            ..WriterOutcome::default()
        })
    }
}

/// Starts the writer thread for a run described by `header`, from the state `keyframe`.
pub(crate) fn start(
    settings: Settings,
    header: Header,
    keyframe: Keyframe,
    rx: Receiver<CycleRecord>,
    counters: Arc<TapCounters>,
) -> std::io::Result<RecorderHandle> {
    std::fs::create_dir_all(&settings.folder)?;
    let folder = settings.folder.clone();
    let mut writer = Writer::new(settings, header, keyframe, counters.clone());
    // The first segment is opened here, so a folder that cannot be written fails the start.
    writer.open_segment()?;
    let thread = std::thread::Builder::new()
        .name("recorder".into())
        .spawn(move || writer.run(rx))?;
    Ok(RecorderHandle {
        thread,
        counters,
        folder,
    })
}

/// A block being filled.
#[derive(Debug)]
struct OpenBlock {
    enc: Enc,
    /// The last record's cycle and time (the next one's deltas count from it).
    prev: (u64, Duration),
    first: Duration,
}

#[derive(Debug)]
struct Writer {
    settings: Settings,
    header: Header,
    /// The whole state after the last record, for the next segment's keyframe.
    slots: Vec<(Value, Quality)>,
    forces: BTreeMap<u32, Value>,
    next_cycle: u64,
    now: Duration,
    file: Option<File>,
    segment_bytes: u64,
    segment_start: Duration,
    block: Option<OpenBlock>,
    outcome: WriterOutcome,
    counters: Arc<TapCounters>,
}

impl Writer {
    fn new(
        settings: Settings,
        header: Header,
        keyframe: Keyframe,
        counters: Arc<TapCounters>,
    ) -> Self {
        Self {
            counters,
            settings,
            header,
            forces: keyframe.forces.iter().copied().collect(),
            slots: keyframe.slots,
            next_cycle: keyframe.next_cycle,
            now: keyframe.now,
            file: None,
            segment_bytes: 0,
            segment_start: keyframe.now,
            block: None,
            outcome: WriterOutcome::default(),
        }
    }

    fn run(mut self, rx: Receiver<CycleRecord>) -> WriterOutcome {
        let result = (|| -> std::io::Result<()> {
            loop {
                match rx.recv_timeout(Duration::from_secs(1)) {
                    Ok(record) => self.add(&record)?,
                    Err(RecvTimeoutError::Timeout) => self.flush()?,
                    Err(RecvTimeoutError::Disconnected) => break,
                }
            }
            self.flush()?;
            let end = End {
                // The last cycle's number is the count of cycles (the first is 1).
                cycles: self.next_cycle.saturating_sub(1),
                dropped: self.dropped(),
            };
            self.write(&format::frame(BlockKind::End, &Enc::end(&end)))
        })();
        if let Err(e) = result {
            let msg = format!(
                "flight recorder: cannot write to {}: {e}; recording stopped",
                self.settings.folder.display()
            );
            tracing::error!("{msg}");
            self.outcome.error = Some(msg);
        }
        self.outcome
    }

    /// Records the scan dropped over the run (the trailing ones too, which no record after
    /// them reports).
    fn dropped(&self) -> u64 {
        self.counters
            .dropped
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    fn add(&mut self, r: &CycleRecord) -> std::io::Result<()> {
        self.apply(r);
        let block = self.block.get_or_insert_with(|| OpenBlock {
            enc: Enc::cycles_block(r.cycle, r.now),
            prev: (r.cycle, r.now),
            first: r.now,
        });
        block.enc.cycle(r, block.prev);
        block.prev = (r.cycle, r.now);
        self.outcome.records += 1;
        let full = block.enc.0.len() >= self.settings.block_bytes
            || r.now.saturating_sub(block.first) >= self.settings.block_time;
        if full {
            self.flush()?;
        }
        Ok(())
    }

    /// Brings the writer's copy of the state up to `r`.
    fn apply(&mut self, r: &CycleRecord) {
        for ev in &r.events {
            match ev {
                Event::Force { tag, value } => {
                    self.forces.insert(*tag, *value);
                }
                Event::Unforce { tag } => {
                    self.forces.remove(tag);
                }
                Event::UnforceAll => self.forces.clear(),
                Event::Write { .. } => {}
                Event::Reload { program_hash } => self.header.program_hash = *program_hash,
            }
        }
        for c in r.seen.iter().chain(&r.wrote) {
            if let Some(slot) = self.slots.get_mut(c.tag as usize) {
                *slot = (c.value, c.quality);
            }
        }
        self.next_cycle = r.cycle + 1;
        self.now = r.now;
    }

    /// Writes the block being filled, and starts a new segment when this one is done.
    fn flush(&mut self) -> std::io::Result<()> {
        let Some(block) = self.block.take() else {
            return Ok(());
        };
        self.write(&format::frame(BlockKind::Cycles, &block.enc.0))?;
        let span = self.now.saturating_sub(self.segment_start);
        if self.segment_bytes >= self.settings.segment_bytes || span >= self.settings.keep / 4 {
            self.header.segment += 1;
            self.open_segment()?;
        }
        Ok(())
    }

    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let Some(file) = self.file.as_mut() else {
            return Ok(());
        };
        file.write_all(bytes)?;
        // On the writer's thread, at most about once a second: a power cut loses no more.
        file.sync_data()?;
        self.segment_bytes += bytes.len() as u64;
        Ok(())
    }

    /// Starts a segment: preamble, header and keyframe in one write; then rotates.
    fn open_segment(&mut self) -> std::io::Result<()> {
        let start_ms = self.wall_ms(self.now);
        let name = format!(
            "{start_ms:013}-{:016x}-{:05}.{SEGMENT_EXT}",
            self.header.run_id, self.header.segment
        );
        let path = self.settings.folder.join(name);
        let keyframe = Keyframe {
            next_cycle: self.next_cycle,
            now: self.now,
            slots: self.slots.clone(),
            forces: self.forces.iter().map(|(&t, &v)| (t, v)).collect(),
        };
        let mut bytes = format::preamble();
        bytes.extend(format::frame(BlockKind::Header, &Enc::header(&self.header)));
        bytes.extend(format::frame(
            BlockKind::Keyframe,
            &Enc::keyframe(&keyframe),
        ));
        let mut file = File::options().write(true).create_new(true).open(&path)?;
        file.write_all(&bytes)?;
        file.sync_data()?;
        if let Ok(dir) = File::open(&self.settings.folder) {
            // The new name must survive a power cut too; a folder that refuses is no error.
            drop(dir.sync_all());
        }
        self.file = Some(file);
        self.segment_bytes = bytes.len() as u64;
        self.segment_start = self.now;
        self.outcome.segments += 1;
        self.rotate(start_ms, &path);
        Ok(())
    }

    /// Wall-clock milliseconds of scan time `now` in this run.
    fn wall_ms(&self, now: Duration) -> u64 {
        let ns = u128::from(self.header.wall_origin) + now.as_nanos();
        u64::try_from(ns / 1_000_000).unwrap_or(u64::MAX)
    }

    /// Deletes the oldest segments (never `current`) while the one after them starts more
    /// than `keep` before `now_ms` (they hold only older cycles) or while the record is over
    /// its size bound.
    fn rotate(&mut self, now_ms: u64, current: &Path) {
        let mut segments = segments_in(&self.settings.folder);
        let mut total: u64 = segments.iter().map(|s| s.bytes).sum();
        let keep_ms = u64::try_from(self.settings.keep.as_millis()).unwrap_or(u64::MAX);
        while segments.len() > 1 && segments[0].path != current {
            let expired = segments[1].start_ms.saturating_add(keep_ms) <= now_ms;
            if !expired && total <= self.settings.max_bytes {
                break;
            }
            let old = segments.remove(0);
            match std::fs::remove_file(&old.path) {
                Ok(()) => {
                    total = total.saturating_sub(old.bytes);
                    self.outcome.deleted += 1;
                }
                Err(e) => {
                    tracing::warn!(
                        "flight recorder: cannot delete the old segment {}: {e}",
                        old.path.display()
                    );
                    break;
                }
            }
        }
    }
}

/// A segment file found in a record's folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SegmentFile {
    /// Its path.
    pub path: PathBuf,
    /// Wall-clock time of its first cycle, ms since the Unix epoch (from its name).
    pub start_ms: u64,
    /// Its size.
    pub bytes: u64,
}

/// The segments in `folder`, oldest first (their names sort by start time).
pub fn segments_in(folder: &Path) -> Vec<SegmentFile> {
    let Ok(entries) = std::fs::read_dir(folder) else {
        return Vec::new();
    };
    let mut out: Vec<SegmentFile> = entries
        .filter_map(Result::ok)
        .filter_map(|e| {
            let path = e.path();
            if path.extension().and_then(|x| x.to_str()) != Some(SEGMENT_EXT) {
                return None;
            }
            let name = path.file_name()?.to_str()?;
            let start_ms = name.split('-').next()?.parse().ok()?;
            let bytes = e.metadata().ok()?.len();
            Some(SegmentFile {
                path,
                start_ms,
                bytes,
            })
        })
        .collect();
    out.sort_by(|a, b| a.path.cmp(&b.path));
    out
}
