//! The recorder's writer thread: cycle records into checksummed blocks, blocks into bounded
//! segment files, the oldest segments deleted beyond the time and size bounds.
//!
//! On a full disk the recorder keeps recording where it can: it owns its folder, so it first
//! deletes its own oldest segments (never the one being written) and writes again. When that
//! is not enough (the disk is full of other files), it holds what it cannot write in memory, up
//! to [`Settings::hold_bytes`], and tries again with a backoff (a quarter second, doubling up to
//! [`MAX_BACKOFF`]); past the bound it keeps only its state. Once a write goes through, what
//! it held is written, and if cycles were lost it starts a new segment with the state as a
//! keyframe and a gap block naming the first and last cycle missing, so replay says "no
//! record from cycle A to B" instead of passing over them. A write that fails halfway is cut
//! back to the last whole block first, so a full disk never leaves a torn block behind.
//!
//! A block is written (and `fdatasync`ed) when it holds [`Settings::block_bytes`] or spans
//! [`Settings::block_time`] of scan time, and after a second of wall-clock time without a
//! record (a stopped or hung scan), so a `kill -9` — or a power cut — loses at most the block
//! being filled. A segment is closed when it reaches [`Settings::segment_bytes`] or spans a
//! quarter of `keep`, and the next one starts with a header and a keyframe of the whole state,
//! so any segment can be read (and replayed) without the ones before it.

mod disk;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, VecDeque};
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError};
use softplc_io::point::{Quality, Value};

use crate::project::{Project, RecorderConfig};
use crate::recorder::format::{
    self, BlockKind, CycleRecord, Enc, End, Event, Gap, Header, Keyframe,
};
use crate::recorder::tap::TapCounters;
use softplc_io::time::ScanInstant;

pub use disk::{Disk, FaultDisk, FileDisk};

/// The longest wait between two tries to write to a disk that refused.
pub const MAX_BACKOFF: Duration = Duration::from_secs(8);
/// The first wait after a refused write.
const FIRST_BACKOFF: Duration = Duration::from_millis(250);

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
    /// Bytes of blocks held in memory while the disk refuses them; past it cycles are lost
    /// (and the gap marked).
    pub hold_bytes: usize,
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
            hold_bytes: usize::try_from((max_bytes / 16).clamp(256 << 10, 16 << 20))
                .unwrap_or(16 << 20),
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

    /// Task `task`'s record, one of `tasks` a project of several tasks keeps: a folder of its
    /// own in the record's folder (`FOLDER/TASK`), the same `keep` (each task keeps at least
    /// that much of its own cycles) and an equal share of the size bound, so the whole record
    /// stays within the bound the project sets. Why not one record for every task: each task
    /// counts its own cycles on its own thread, and a record per task replays on its own.
    pub fn for_task(&self, task: &str, tasks: usize) -> Self {
        let share = self.max_bytes / tasks.max(1) as u64;
        Self {
            block_bytes: self.block_bytes,
            block_time: self.block_time,
            channel: self.channel,
            ..Self::new(self.folder.join(task), self.keep, share)
        }
    }
}

/// What the writer did, when it ends.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct WriterOutcome {
    /// Cycle records written.
    pub records: u64,
    /// Segments it created.
    pub segments: u32,
    /// Segments it deleted (rotation, and to make room on a full disk).
    pub deleted: u32,
    /// Gaps it marked: times the disk refused for longer than it could hold the records.
    pub gaps: u32,
    /// Cycles missing in those gaps.
    pub lost: u64,
    /// Why the record ends before the run did, if it does.
    pub error: Option<String>,
}

/// How the writer is doing, for the service's status.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum WriterState {
    /// Writing every cycle.
    Writing,
    /// The disk refuses: holding records in memory and trying again.
    Held {
        /// What the disk said.
        reason: String,
        /// Bytes held.
        held_bytes: usize,
        /// Whether cycles are being lost (more than can be held).
        losing: bool,
    },
    /// The writer has ended before the run (its last records not written).
    Stopped {
        /// Why.
        reason: String,
    },
}

/// A running recorder: its writer thread and the counts the scan keeps.
#[derive(Debug)]
pub struct RecorderHandle {
    thread: JoinHandle<WriterOutcome>,
    counters: Arc<TapCounters>,
    folder: PathBuf,
    state: Arc<Mutex<WriterState>>,
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

    /// How the writer is doing now.
    pub fn state(&self) -> WriterState {
        self.state
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// A shared view of the writer's state, for a thread that reports it.
    pub fn state_cell(&self) -> Arc<Mutex<WriterState>> {
        self.state.clone()
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

/// Starts the writer thread for a run described by `header`, from the state `keyframe`,
/// writing through `disk`.
pub(crate) fn start(
    settings: Settings,
    header: Header,
    keyframe: Keyframe,
    rx: Receiver<CycleRecord>,
    counters: Arc<TapCounters>,
    disk: Box<dyn Disk>,
) -> std::io::Result<RecorderHandle> {
    std::fs::create_dir_all(&settings.folder)?;
    let folder = settings.folder.clone();
    let mut writer = Writer::new(settings, header, keyframe, counters.clone(), disk);
    // The first segment is written here, so a folder that cannot be written fails the start;
    // a full disk does not: the PLC runs, and the record starts when there is room.
    let first = writer.new_segment(None);
    writer.held.push_back(first);
    writer.drain(true);
    if let Some(stall) = writer.stall.as_ref().filter(|s| !s.full) {
        return Err(std::io::Error::new(stall.kind, stall.reason.clone()));
    }
    let state = writer.state.clone();
    let thread = std::thread::Builder::new()
        .name("recorder".into())
        .spawn(move || writer.run(rx))?;
    Ok(RecorderHandle {
        thread,
        counters,
        folder,
        state,
    })
}

/// A block being filled.
#[derive(Debug)]
struct OpenBlock {
    enc: Enc,
    /// The last record's cycle and time (the next one's deltas count from it).
    prev: (u64, ScanInstant),
    first: ScanInstant,
    first_cycle: u64,
}

/// What waits to be written, in order.
#[derive(Debug)]
enum Held {
    /// A new segment: its file and opening bytes (preamble, header, keyframe, maybe a gap).
    Segment {
        path: PathBuf,
        bytes: Vec<u8>,
        start_ms: u64,
        now: ScanInstant,
    },
    /// A block of the segment before it, and the first cycle it holds.
    Block { bytes: Vec<u8>, first: u64 },
}

impl Held {
    fn len(&self) -> usize {
        match self {
            Held::Segment { bytes, .. } | Held::Block { bytes, .. } => bytes.len(),
        }
    }
}

/// The disk refusing.
#[derive(Debug)]
struct Stall {
    since: Instant,
    backoff: Duration,
    retry_at: Instant,
    reason: String,
    kind: std::io::ErrorKind,
    /// A full disk (the others: a folder gone read-only, an I/O error).
    full: bool,
    /// The gap it left, once one is marked.
    gap: Option<Gap>,
}

struct Writer {
    settings: Settings,
    header: Header,
    /// The whole state after the last record, for the next segment's keyframe.
    slots: Vec<(Value, Quality)>,
    forces: BTreeMap<u32, Value>,
    next_cycle: u64,
    now: ScanInstant,
    /// The segment being written and its path (never deleted to make room).
    file: Option<(File, PathBuf)>,
    segment_bytes: u64,
    segment_start: ScanInstant,
    block: Option<OpenBlock>,
    outcome: WriterOutcome,
    counters: Arc<TapCounters>,
    disk: Box<dyn Disk>,
    held: VecDeque<Held>,
    held_bytes: usize,
    stall: Option<Stall>,
    /// Cycles not held (past `hold_bytes`): a gap, marked once the disk takes writes again.
    lost: Option<Gap>,
    state: Arc<Mutex<WriterState>>,
}

impl std::fmt::Debug for Writer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Writer")
            .field("folder", &self.settings.folder)
            .field("next_cycle", &self.next_cycle)
            .field("held", &self.held.len())
            .field("stall", &self.stall)
            .finish_non_exhaustive()
    }
}

impl Writer {
    fn new(
        settings: Settings,
        header: Header,
        keyframe: Keyframe,
        counters: Arc<TapCounters>,
        disk: Box<dyn Disk>,
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
            disk,
            held: VecDeque::new(),
            held_bytes: 0,
            stall: None,
            lost: None,
            state: Arc::new(Mutex::new(WriterState::Writing)),
        }
    }

    fn run(mut self, rx: Receiver<CycleRecord>) -> WriterOutcome {
        loop {
            // While the disk refuses, wake for the next try even if no record comes.
            let wait = self.stall.as_ref().map_or(Duration::from_secs(1), |s| {
                s.retry_at
                    .saturating_duration_since(Instant::now())
                    .min(Duration::from_secs(1))
            });
            match rx.recv_timeout(wait) {
                Ok(record) => self.add(&record),
                Err(RecvTimeoutError::Timeout) => self.flush(),
                Err(RecvTimeoutError::Disconnected) => break,
            }
        }
        self.flush();
        if let Some(gap) = self.lost.take() {
            self.queue_gap(gap);
        }
        let end = End {
            // The last cycle's number is the count of cycles (the first is 1).
            cycles: self.next_cycle.saturating_sub(1),
            dropped: self.dropped(),
        };
        self.hold(
            format::frame(BlockKind::End, &Enc::end(&end)),
            self.next_cycle,
            self.next_cycle,
        );
        // The run is over: one last try whatever the backoff says.
        self.drain(true);
        if let Some(stall) = &self.stall {
            let msg = format!(
                "flight recorder: cannot write to {}: {}; the record misses the run's last \
                 cycles, from cycle {}",
                self.settings.folder.display(),
                stall.reason,
                self.first_held_cycle()
            );
            tracing::error!("{msg}");
            self.set_state(WriterState::Stopped {
                reason: stall.reason.clone(),
            });
            self.outcome.error = Some(msg);
        }
        self.outcome
    }

    /// The first cycle of what is still held (the record's end, when the disk never came back).
    fn first_held_cycle(&self) -> u64 {
        match self.held.front() {
            Some(Held::Segment { .. }) | None => self.next_cycle,
            Some(Held::Block { first, .. }) => *first,
        }
    }

    /// Records the scan dropped over the run (the trailing ones too, which no record after
    /// them reports).
    fn dropped(&self) -> u64 {
        self.counters
            .dropped
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    fn add(&mut self, r: &CycleRecord) {
        self.apply(r);
        let block = self.block.get_or_insert_with(|| OpenBlock {
            enc: Enc::cycles_block(r.cycle, r.now),
            prev: (r.cycle, r.now),
            first: r.now,
            first_cycle: r.cycle,
        });
        block.enc.cycle(r, block.prev);
        block.prev = (r.cycle, r.now);
        self.outcome.records += 1;
        let full = block.enc.0.len() >= self.settings.block_bytes
            || r.now.saturating_duration_since(block.first) >= self.settings.block_time;
        if full {
            self.flush();
        }
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

    /// Hands the block being filled to the disk, and starts a new segment when this one is
    /// done.
    fn flush(&mut self) {
        let Some(block) = self.block.take() else {
            self.drain(false);
            return;
        };
        self.hold(
            format::frame(BlockKind::Cycles, &block.enc.0),
            block.first_cycle,
            block.prev.0,
        );
        self.drain(false);
        let span = self.now.saturating_duration_since(self.segment_start);
        let done =
            self.segment_bytes >= self.settings.segment_bytes || span >= self.settings.keep / 4;
        if done && self.stall.is_none() {
            self.header.segment += 1;
            let next = self.new_segment(None);
            self.held.push_back(next);
            self.drain(false);
        }
    }

    /// Queues a block of cycles `first..=last`, or counts them lost when the hold is full
    /// (or cycles before them were lost: the blocks after a gap only make sense from a
    /// keyframe, which the gap's segment gives).
    fn hold(&mut self, bytes: Vec<u8>, first: u64, last: u64) {
        if let Some(gap) = &mut self.lost {
            gap.last = last;
            return;
        }
        if !self.held.is_empty() && self.held_bytes + bytes.len() > self.settings.hold_bytes {
            self.lost = Some(Gap { first, last });
            self.publish();
            return;
        }
        self.held_bytes += bytes.len();
        self.held.push_back(Held::Block { bytes, first });
    }

    /// A segment of cycles missing: the state as it is now, and the gap before it.
    fn queue_gap(&mut self, gap: Gap) {
        self.header.segment += 1;
        let segment = self.new_segment(Some(gap));
        self.outcome.gaps += 1;
        self.outcome.lost += gap.last.saturating_sub(gap.first) + 1;
        if let Some(stall) = &mut self.stall {
            stall.gap = Some(gap);
        }
        self.held_bytes += segment.len();
        self.held.push_back(segment);
    }

    /// Writes what is held, in order, unless the disk refused less than a backoff ago
    /// (`force`: try anyway).
    fn drain(&mut self, force: bool) {
        if let Some(s) = &self.stall {
            if !force && Instant::now() < s.retry_at {
                return;
            }
        }
        loop {
            let Some(item) = self.held.pop_front() else {
                match self.lost.take() {
                    Some(gap) => {
                        self.queue_gap(gap);
                        continue;
                    }
                    None => break,
                }
            };
            let written = match &item {
                Held::Segment {
                    path,
                    bytes,
                    start_ms,
                    now,
                } => self.write_segment(path, bytes, *start_ms, *now),
                Held::Block { bytes, .. } => self.append(bytes),
            };
            match written {
                Ok(()) => self.held_bytes = self.held_bytes.saturating_sub(item.len()),
                Err(e) => {
                    self.held.push_front(item);
                    self.stalled(&e);
                    return;
                }
            }
        }
        if let Some(stall) = self.stall.take() {
            let lost = match stall.gap {
                Some(g) => format!("; no record from cycle {} to {}", g.first, g.last),
                None => ", nothing lost (the records were held in memory)".to_owned(),
            };
            tracing::warn!(
                "flight recorder: writing to {} again after {:.1} s{lost}",
                self.settings.folder.display(),
                stall.since.elapsed().as_secs_f64()
            );
            self.set_state(WriterState::Writing);
        }
    }

    /// The disk refused `e`: hold on, try again after a backoff.
    fn stalled(&mut self, e: &std::io::Error) {
        let now = Instant::now();
        match &mut self.stall {
            Some(s) => {
                s.backoff = (s.backoff * 2).min(MAX_BACKOFF);
                s.retry_at = now + s.backoff;
                s.reason = e.to_string();
            }
            None => {
                tracing::error!(
                    "flight recorder: cannot write to {}: {e}; holding up to {} of records in \
                     memory and trying again",
                    self.settings.folder.display(),
                    crate::project::Bytes(self.settings.hold_bytes as u64)
                );
                self.stall = Some(Stall {
                    since: now,
                    backoff: FIRST_BACKOFF,
                    retry_at: now + FIRST_BACKOFF,
                    reason: e.to_string(),
                    kind: e.kind(),
                    full: disk::is_full(e),
                    gap: None,
                });
            }
        }
        self.publish();
    }

    /// The state as the service shows it, from where the writer is.
    fn publish(&self) {
        if let Some(s) = &self.stall {
            self.set_state(WriterState::Held {
                reason: s.reason.clone(),
                held_bytes: self.held_bytes,
                losing: self.lost.is_some(),
            });
        }
    }

    fn set_state(&self, state: WriterState) {
        *self.state.lock().unwrap_or_else(PoisonError::into_inner) = state;
    }

    /// Appends a block to the segment being written. A write the disk refuses halfway is cut
    /// back to the last whole block; a full disk gives up the record's oldest segments first.
    fn append(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        loop {
            let Some((file, _)) = self.file.as_mut() else {
                return Ok(());
            };
            let Err(e) = self.disk.append(file, bytes) else {
                self.segment_bytes += bytes.len() as u64;
                return Ok(());
            };
            // What went down of it would be a torn block in the middle of the segment.
            drop(file.set_len(self.segment_bytes));
            if !(disk::is_full(&e) && self.drop_oldest()) {
                return Err(e);
            }
        }
    }

    /// Creates a segment with its opening bytes; then rotates.
    fn write_segment(
        &mut self,
        path: &Path,
        bytes: &[u8],
        start_ms: u64,
        now: ScanInstant,
    ) -> std::io::Result<()> {
        let file = loop {
            let result = self
                .disk
                .create(path)
                .and_then(|mut f| self.disk.append(&mut f, bytes).map(|()| f));
            match result {
                Ok(file) => break file,
                Err(e) => {
                    // A file cut short would be read as a segment without its start; it goes.
                    drop(std::fs::remove_file(path));
                    if !(disk::is_full(&e) && self.drop_oldest()) {
                        return Err(e);
                    }
                }
            }
        };
        if let Ok(dir) = File::open(&self.settings.folder) {
            // The new name must survive a power cut too; a folder that refuses is no error.
            drop(dir.sync_all());
        }
        self.file = Some((file, path.to_path_buf()));
        self.segment_bytes = bytes.len() as u64;
        self.segment_start = now;
        self.outcome.segments += 1;
        self.rotate(start_ms, path);
        Ok(())
    }

    /// On a full disk: deletes the record's oldest segment, never the one being written.
    /// False when there is none to delete.
    fn drop_oldest(&mut self) -> bool {
        let current = self.file.as_ref().map(|(_, p)| p.as_path());
        let segments = segments_in(&self.settings.folder);
        let Some(oldest) = segments
            .first()
            .filter(|s| Some(s.path.as_path()) != current)
        else {
            return false;
        };
        match std::fs::remove_file(&oldest.path) {
            Ok(()) => {
                self.outcome.deleted += 1;
                tracing::warn!(
                    "flight recorder: the disk is full; deleted the record's oldest segment {} \
                     to keep recording",
                    oldest.path.display()
                );
                true
            }
            Err(_) => false,
        }
    }

    /// A new segment's opening bytes from the state now: preamble, header, keyframe, and the
    /// gap before it when cycles were lost.
    fn new_segment(&self, gap: Option<Gap>) -> Held {
        let start_ms = self.wall_ms(self.now);
        let name = format!(
            "{start_ms:013}-{:016x}-{:05}.{SEGMENT_EXT}",
            self.header.run_id, self.header.segment
        );
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
        if let Some(gap) = gap {
            bytes.extend(format::frame(BlockKind::Gap, &Enc::gap(&gap)));
        }
        Held::Segment {
            path: self.settings.folder.join(name),
            bytes,
            start_ms,
            now: self.now,
        }
    }

    /// Wall-clock milliseconds of scan time `now` in this run.
    fn wall_ms(&self, now: ScanInstant) -> u64 {
        let ns = u128::from(self.header.wall_origin) + now.since_origin().as_nanos();
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
