//! The writer on a disk that fills: through the [`Disk`] seam ([`FaultDisk`]), a disk of a few KiB (the
//! record's own oldest segments make room) and a disk another program fills and empties (held,
//! then a gap, then recording again by itself), each read back as replay reads it.

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use softplc_io::point::{Quality, Value, ValueType};

use super::*;
use crate::recorder::format::{Change, TagInfo, TagRole};
use crate::recorder::reader::read_record;

/// Far longer than any step here takes on a loaded machine.
const PATIENCE: Duration = Duration::from_secs(30);

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-writer-{name}-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn header() -> Header {
    Header {
        project: "disk".into(),
        project_hash: format::digest(b"project"),
        program_hash: format::digest(b"program"),
        program_file: "count.rhai".into(),
        period: Duration::from_millis(10),
        virtual_clock: true,
        run_id: 1_764_000_000_000_000_000,
        wall_origin: 1_764_000_000_000_000_000,
        segment: 0,
        tags: vec![TagInfo {
            name: "n".into(),
            ty: ValueType::I32,
            role: TagRole::Memory,
        }],
        task: None,
    }
}

/// Cycle `c`: the tag holds `c`, 10 ms a cycle.
fn record(c: u64) -> CycleRecord {
    CycleRecord {
        cycle: c,
        now: ScanInstant::after_origin(Duration::from_millis(10 * c)),
        wrote: vec![Change {
            tag: 0,
            value: Value::I32(c as i32),
            quality: Quality::Good,
        }],
        ..CycleRecord::default()
    }
}

struct Run {
    tx: crossbeam_channel::Sender<CycleRecord>,
    handle: RecorderHandle,
}

fn start_on(dir: &Path, disk: FaultDisk, tune: impl FnOnce(&mut Settings)) -> Run {
    let mut settings = Settings::new(dir.to_path_buf(), Duration::from_secs(3600), 256 << 20);
    settings.segment_bytes = 4 << 10;
    settings.block_bytes = 512;
    tune(&mut settings);
    let keyframe = Keyframe {
        next_cycle: 0,
        now: ScanInstant::ZERO,
        slots: vec![(Value::I32(-1), Quality::Good)],
        forces: Vec::new(),
    };
    let (tx, rx) = crossbeam_channel::bounded(64);
    let counters = Arc::new(TapCounters::default());
    let handle = start(settings, header(), keyframe, rx, counters, Box::new(disk)).unwrap();
    Run { tx, handle }
}

impl Run {
    fn send(&self, cycles: std::ops::Range<u64>) {
        for c in cycles {
            self.tx.send(record(c)).unwrap();
        }
    }

    fn wait_for(&self, what: &str, ok: impl Fn(&WriterState) -> bool) {
        let begin = Instant::now();
        while !ok(&self.handle.state()) {
            assert!(
                begin.elapsed() < PATIENCE,
                "never {what}: {:?}",
                self.handle.state()
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    fn finish(self) -> WriterOutcome {
        drop(self.tx);
        self.handle.finish()
    }
}

/// The record's cycles as runs of consecutive cycles (first, last, the gap marked before the
/// run), checking that each cycle has its value and that each segment's keyframe is the state
/// its cycles start from.
fn runs(dir: &Path) -> Vec<(u64, u64, Option<format::Gap>)> {
    let record = read_record(dir).unwrap();
    let mut out: Vec<(u64, u64, Option<format::Gap>)> = Vec::new();
    for seg in &record.segments {
        assert_eq!(seg.torn, None, "{}", seg.path.display());
        let Value::I32(mut n) = seg.keyframe.slots[0].0 else {
            panic!("an i32")
        };
        assert_eq!(i64::from(n) + 1, seg.keyframe.next_cycle as i64, "keyframe");
        for (k, c) in seg.cycles.iter().enumerate() {
            if let Some(ch) = c.wrote.first() {
                let Value::I32(v) = ch.value else { panic!() };
                n = v;
            }
            assert_eq!(
                i64::from(n),
                c.cycle as i64,
                "the value of cycle {}",
                c.cycle
            );
            let gap = if k == 0 { seg.gap } else { None };
            match out.last_mut() {
                Some(run) if gap.is_none() && run.1 + 1 == c.cycle => run.1 = c.cycle,
                _ => out.push((c.cycle, c.cycle, gap)),
            }
        }
    }
    out
}

#[test]
fn a_small_disk_gives_up_the_oldest_segments_and_loses_no_cycle() {
    let dir = folder("small");
    let disk = FaultDisk::new(&dir, 24 << 10);
    let probe = disk.clone();
    let run = start_on(&dir, disk, |_| {});
    run.send(0..20_000);
    let outcome = run.finish();
    assert_eq!(outcome.error, None);
    assert_eq!(outcome.gaps, 0);
    assert!(probe.refused() > 0, "the disk filled");
    assert!(outcome.deleted > 0, "{outcome:?}");
    assert!(probe.used() <= 24 << 10);
    // From the oldest kept on, every cycle, each with its value: the writes the disk cut
    // halfway left no torn block behind.
    let runs = runs(&dir);
    assert_eq!(runs.len(), 1, "{runs:?}");
    assert!(runs[0].0 > 0, "the oldest went");
    assert_eq!(runs[0].1, 19_999);
}

#[test]
fn a_disk_filled_by_others_is_waited_for_and_the_gap_marked() {
    let dir = folder("filled");
    let disk = FaultDisk::new(&dir, 1 << 30);
    let full = disk.full_switch();
    let run = start_on(&dir, disk, |s| s.hold_bytes = 2 << 10);
    run.send(0..2_000);
    full.store(true, Ordering::SeqCst);
    run.send(2_000..6_000);
    run.wait_for("losing", |s| {
        matches!(s, WriterState::Held { losing: true, reason, .. } if reason.contains("No space"))
    });
    full.store(false, Ordering::SeqCst);
    // Nothing is sent meanwhile: the writer tries again on its own.
    run.wait_for("writing again", |s| *s == WriterState::Writing);
    run.send(6_000..8_000);
    let outcome = run.finish();
    assert_eq!(outcome.error, None);
    assert_eq!(outcome.gaps, 1);

    // Its own oldest segments went first (the disk stayed full), then the gap; after it,
    // every cycle to the end.
    let runs = runs(&dir);
    assert_eq!(runs.len(), 2, "{runs:?}");
    let gap = runs[1].2.unwrap();
    assert_eq!(outcome.lost, gap.last - gap.first + 1);
    assert!(gap.first >= 2_000 && gap.last < 6_000, "{gap:?}");
    assert_eq!(runs[0].1 + 1, gap.first, "{runs:?}");
    assert_eq!((runs[1].0, runs[1].1), (gap.last + 1, 7_999));
    let record = read_record(&dir).unwrap();
    assert_eq!(
        record.parts().len(),
        2,
        "replay starts afresh after the gap"
    );
}

#[test]
fn held_records_are_written_when_the_disk_comes_back_soon_enough() {
    let dir = folder("held");
    let disk = FaultDisk::new(&dir, 1 << 30);
    let full = disk.full_switch();
    let run = start_on(&dir, disk, |_| {});
    run.send(0..500);
    full.store(true, Ordering::SeqCst);
    run.send(500..1_500);
    run.wait_for("held", |s| {
        matches!(s, WriterState::Held { losing: false, .. })
    });
    full.store(false, Ordering::SeqCst);
    run.wait_for("writing again", |s| *s == WriterState::Writing);
    let outcome = run.finish();
    assert_eq!((outcome.gaps, outcome.lost, outcome.error), (0, 0, None));
    let runs = runs(&dir);
    assert_eq!(runs.len(), 1, "{runs:?}");
    assert_eq!(runs[0].1, 1_499, "every cycle held was written");
}

#[test]
fn a_disk_that_never_comes_back_ends_the_record_saying_where() {
    let dir = folder("never");
    let disk = FaultDisk::new(&dir, 1 << 30);
    let full = disk.full_switch();
    let run = start_on(&dir, disk, |_| {});
    run.send(0..500);
    full.store(true, Ordering::SeqCst);
    run.send(500..1_000);
    run.wait_for("held", |s| matches!(s, WriterState::Held { .. }));
    let outcome = run.finish();
    let error = outcome.error.unwrap();
    let next = runs(&dir).last().unwrap().1 + 1;
    assert!(
        error.ends_with(&format!(
            "No space left on device (os error 28); the record misses the run's last \
             cycles, from cycle {next}"
        )),
        "{error}"
    );
}

#[test]
fn a_tasks_record_is_a_folder_of_its_own_with_an_equal_share_of_the_size() {
    let mut project = Settings::new(
        PathBuf::from("/r/p.record"),
        Duration::from_secs(600),
        256 << 20,
    );
    project.block_bytes = 128;
    let press = project.for_task("press", 2);
    assert_eq!(press.folder, PathBuf::from("/r/p.record/press"));
    assert_eq!(
        press.keep, project.keep,
        "each task keeps its own cycles that long"
    );
    assert_eq!(
        press.max_bytes,
        128 << 20,
        "the tasks together stay within the size"
    );
    assert_eq!(press.segment_bytes, 16 << 20);
    assert_eq!(press.block_bytes, 128, "what a run tuned stays");
    let one = project.for_task("main", 1);
    assert_eq!(one.max_bytes, project.max_bytes);
}
