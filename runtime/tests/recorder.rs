//! The flight recorder and replay, end to end: the quick start with its simulated plant is
//! recorded on the virtual clock, read back and replayed, against its own program and against
//! one with a rung changed; a torn tail, rotation, and `kill -9` of a real-clock run; a full
//! disk, through the fault-injecting disk and as a real tmpfs filled by another program.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use softplc::clock::VirtualClock;
use softplc::plc::Plc;
use softplc::recorder::format::{self, BlockKind, Framed};
use softplc::recorder::{
    read_record, replay, segments_in, FaultDisk, Record, ReplayError, ReplayOptions, Settings,
    WriterState,
};
use softplc::scan::{CycleBoundary, ScanEngine, ScanStats};
use softplc_io::point::Value;
use softplc_io::time::ScanInstant;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

fn quickstart() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/quickstart/project.yaml")
}

fn tempdir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-recorder-{name}-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A copy of the quick start in `dir`, with `program` as its program (the original's when
/// `None`).
fn quickstart_copy(dir: &Path, program: Option<&str>) -> PathBuf {
    let original = std::fs::read_to_string(quickstart()).unwrap();
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../programs/conveyor.expr");
    let text = match program {
        Some(p) => p.to_string(),
        None => std::fs::read_to_string(source).unwrap(),
    };
    std::fs::write(dir.join("conveyor.expr"), text).unwrap();
    crate::common::host::copy_quickstart_plant(dir);
    // No web page: a test opens no fixed port.
    let yaml = original
        .replace("file: ../../programs/conveyor.expr", "file: conveyor.expr")
        .replace("service:\n  web: { bind: 127.0.0.1:8080 }\n", "");
    assert!(
        yaml.contains("file: conveyor.expr") && !yaml.contains("8080"),
        "the quick start names its program and its web page as expected"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, yaml).unwrap();
    path
}

/// Operator requests at cycle boundaries, as the control socket would make them.
struct Operator;

impl CycleBoundary for Operator {
    fn between_cycles(&mut self, plc: &mut Plc, stats: &ScanStats, _now: ScanInstant) {
        match stats.cycles {
            // The motor forced on while no box is on its way, then released.
            20 => drop(plc.force("motor", "1")),
            26 => drop(plc.unforce(Some("motor"))),
            // The stop button forced pressed for a while.
            60 => drop(plc.force("stop", "true")),
            71 => drop(plc.unforce(None)),
            _ => {}
        }
    }
}

/// Records `project` for `run_for` of virtual time into `folder`.
fn record(project: &Path, settings: Settings, run_for: Duration) -> Record {
    let folder = settings.folder.clone();
    let project = softplc::project::load(project).unwrap();
    let mut plc = Plc::build(project, Arc::new(VirtualClock::new())).unwrap();
    let handle = plc.record(settings).unwrap();
    let mut engine = ScanEngine::new(plc)
        .run_for(run_for)
        .with_boundary(Operator);
    engine.run();
    drop(engine);
    let outcome = handle.finish();
    assert_eq!(outcome.error, None);
    read_record(&folder).unwrap()
}

/// Records `project` for `secs` seconds of virtual time into `dir/rec`, with the defaults.
fn record_in(project: &Path, dir: &Path, secs: u64) -> Record {
    record(
        project,
        settings(&dir.join("rec")),
        Duration::from_secs(secs),
    )
}

/// `softplc replay FOLDER PROJECT`: how it ended, and what it printed.
fn replay_cli(folder: &Path, project: &Path) -> (std::process::Output, String) {
    let out = Command::new(BIN)
        .arg("replay")
        .arg(folder)
        .arg(project)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    (out, stdout)
}

fn settings(folder: &Path) -> Settings {
    Settings::new(folder.to_path_buf(), Duration::from_secs(600), 256 << 20)
}

/// Tag value after every cycle, from the record alone: (cycle, seen state, wrote state).
fn states(record: &Record, tag: &str) -> Vec<(u64, ScanInstant, Value, Value)> {
    let seg = &record.segments[0];
    let i = seg.header.tags.iter().position(|t| t.name == tag).unwrap() as u32;
    let mut value = seg.keyframe.slots[i as usize].0;
    let mut out = Vec::new();
    for c in record.cycles() {
        for ch in c.seen.iter().filter(|ch| ch.tag == i) {
            value = ch.value;
        }
        let seen = value;
        for ch in c.wrote.iter().filter(|ch| ch.tag == i) {
            value = ch.value;
        }
        out.push((c.cycle, c.now, seen, value));
    }
    out
}

#[test]
fn a_recorded_quickstart_replays_with_identical_outputs() {
    let dir = tempdir("identical");
    let record = record_in(&quickstart(), &dir, 30);
    assert_eq!(record.segments.len(), 1);
    let seg = &record.segments[0];
    assert_eq!(seg.header.project, "quickstart");
    assert_eq!(seg.cycles.len(), 300, "30 s at 100 ms");
    assert_eq!(seg.end.map(|e| e.cycles), Some(300), "a clean end");
    assert_eq!(seg.torn, None);
    // The run did something worth replaying: boxes came and went, the motor ran.
    let motor = states(&record, "motor");
    let on = motor.iter().filter(|s| s.3 == Value::Bool(true)).count();
    assert!(on > 30 && on < 270, "motor on in {on} cycles");
    // The forces are in the record, at the cycles they were applied.
    let forced: Vec<u64> = record
        .cycles()
        .filter(|c| !c.events.is_empty())
        .map(|c| c.cycle)
        .collect();
    // Applied after scan N, a request goes with scan N + 1's record (the first scan is 1).
    assert_eq!(forced, [21, 27, 61, 72]);

    let project = softplc::project::load(&quickstart()).unwrap();
    let mut cycles = 0;
    let report = replay(&record, &project, ReplayOptions::default(), |c| {
        assert_eq!(c.recorded.len(), c.replayed.len());
        cycles += 1;
    })
    .unwrap();
    assert_eq!(cycles, 300);
    assert_eq!(report.cycles, 300);
    assert_eq!(report.plant_time, Duration::from_secs(30));
    assert_eq!(report.differing_cycles, 0, "{:?}", report.differences);
    assert!(report.identical());
    assert_eq!(report.recorded_program, report.replayed_program);
    assert!(!report.project_file_differs);
    assert!(report.notes.is_empty(), "{:?}", report.notes);
}

#[test]
fn a_changed_rung_differs_first_where_the_recorded_inputs_say() {
    let dir = tempdir("changed");
    let original = quickstart_copy(&dir, None);
    let record = record_in(&original, &dir, 30);
    // The lamp now also lights while start is pressed.
    let changed_dir = dir.join("changed");
    std::fs::create_dir_all(&changed_dir).unwrap();
    let changed = quickstart_copy(
        &changed_dir,
        Some(
            "motor = (rising(start) | motor) & !stop & !box_at_exit\n\
             lamp = box_at_exit | start\n",
        ),
    );
    // Computed from the record alone: the first cycle where the new rung on the recorded
    // inputs gives another lamp than the recorded scan wrote.
    let start = states(&record, "start");
    let exit = states(&record, "box_at_exit");
    let lamp = states(&record, "lamp");
    let expected: Vec<(u64, ScanInstant, bool)> = start
        .iter()
        .zip(&exit)
        .zip(&lamp)
        .filter_map(|((s, e), l)| {
            let new = s.2.as_bool() || e.2.as_bool();
            (Value::Bool(new) != l.3).then_some((s.0, s.1, new))
        })
        .collect();
    assert!(!expected.is_empty(), "start was pressed in the run");

    let project = softplc::project::load(&changed).unwrap();
    let options = ReplayOptions {
        differences: usize::MAX,
    };
    let report = replay(&record, &project, options, |_| {}).unwrap();
    assert_ne!(report.recorded_program, report.replayed_program);
    assert_eq!(report.differing_cycles, expected.len() as u64);
    let first = &report.differences[0];
    assert_eq!((first.cycle, first.now), (expected[0].0, expected[0].1));
    assert_eq!(first.tags.len(), 1, "{first:?}");
    assert_eq!(first.tags[0].tag, "lamp");
    assert_eq!(first.tags[0].recorded, Value::Bool(!expected[0].2));
    assert_eq!(first.tags[0].replayed, Value::Bool(expected[0].2));
    let cycles: Vec<u64> = report.differences.iter().map(|d| d.cycle).collect();
    let want: Vec<u64> = expected.iter().map(|e| e.0).collect();
    assert_eq!(cycles, want, "cycle by cycle");
}

#[test]
fn the_cli_replays_a_record_and_exports_both_outputs() {
    let dir = tempdir("cli");
    let project = quickstart_copy(&dir, None);
    let run = Command::new(BIN)
        .args(["run", "--quiet", "--no-control", "--virtual", "--for", "5s"])
        .args(["--record", "10m"])
        .arg(&project)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let folder = dir.join("project.yaml.record");
    let csv = dir.join("out.csv");
    let vcd = dir.join("out.vcd");
    let replayed = Command::new(BIN)
        .arg("replay")
        .arg(&folder)
        .arg(&project)
        .arg("--csv")
        .arg(&csv)
        .arg("--vcd")
        .arg(&vcd)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&replayed.stdout);
    assert_eq!(replayed.status.code(), Some(0), "{stdout}");
    assert!(
        stdout.ends_with("50 cycles, 5.00s of plant time, outputs identical\n"),
        "{stdout}"
    );
    assert!(stdout.contains(": the same program"), "{stdout}");
    let csv = std::fs::read_to_string(&csv).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(
        header.contains("rec.motor") && header.contains("new.lamp"),
        "{header}"
    );
    assert_eq!(csv.lines().count(), 51, "a header and one line per cycle");
    let vcd = std::fs::read_to_string(&vcd).unwrap();
    assert!(vcd.contains("$scope module rec $end"), "{vcd}");

    // The same record against a changed rung: the first difference, exit status 1.
    std::fs::write(
        dir.join("conveyor.expr"),
        "motor = (rising(start) | motor) & !stop & !box_at_exit\nlamp = !box_at_exit\n",
    )
    .unwrap();
    let (replayed, stdout) = replay_cli(&folder, &project);
    assert_eq!(replayed.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains("first difference at cycle 1 (t=")
            && stdout.contains("lamp  recorded 0  replayed 1"),
        "{stdout}"
    );
    assert!(stdout.contains("a different program"), "{stdout}");
    assert!(
        !stdout.contains("note: the project file differs"),
        "{stdout}"
    );
}

#[test]
fn a_record_of_another_project_is_refused_naming_what_differs() {
    let dir = tempdir("mismatch");
    let record = record_in(&quickstart(), &dir, 1);
    let other_dir = dir.join("other");
    std::fs::create_dir_all(&other_dir).unwrap();
    let project = quickstart_copy(&other_dir, None);
    let text = std::fs::read_to_string(&project).unwrap().replace(
        "{ name: lamp,         point: mm2.Y1, safe: false }",
        "{ name: lamp, type: bool }",
    );
    std::fs::write(&project, text).unwrap();
    let project = softplc::project::load(&project).unwrap();
    let err = replay(&record, &project, ReplayOptions::default(), |_| {}).unwrap_err();
    assert_eq!(
        err.to_string(),
        "tag 5: the record has lamp (bool, output), the project has lamp (bool, memory)"
    );
    assert!(matches!(err, ReplayError::Tag { index: 5, .. }));
}

/// The whole blocks of a segment file: offset, kind, and cycle records in it.
fn blocks(bytes: &[u8], tags: usize) -> Vec<(usize, BlockKind, usize)> {
    let mut at = format::PREAMBLE;
    let mut out = Vec::new();
    while let Framed::Block(kind, payload, next) = format::next_block(bytes, at) {
        let cycles = match kind {
            BlockKind::Cycles => format::Dec::new(payload).cycles(tags).unwrap().len(),
            _ => 0,
        };
        out.push((at, kind, cycles));
        at = next;
    }
    out
}

#[test]
fn a_torn_tail_is_read_up_to_the_last_good_block() {
    let dir = tempdir("torn");
    let mut s = settings(&dir.join("rec"));
    s.block_time = Duration::from_millis(500);
    let full = record(&quickstart(), s, Duration::from_secs(10));
    let path = full.segments[0].path.clone();
    let bytes = std::fs::read(&path).unwrap();
    let all = blocks(&bytes, full.segments[0].header.tags.len());
    let cycles: Vec<&(usize, BlockKind, usize)> =
        all.iter().filter(|b| b.1 == BlockKind::Cycles).collect();
    // A block closes once it spans 500 ms: six cycles of 100 ms.
    assert!(
        cycles[..cycles.len() - 1].iter().all(|b| b.2 == 6),
        "{all:?}"
    );
    assert_eq!(all.last().unwrap().1, BlockKind::End);
    // Cut the last cycles block in its middle, as a kill -9 during its write would.
    let (last, _, in_last) = **cycles.last().unwrap();
    let good = 100 - in_last;
    let end = all.last().unwrap().0;
    let cut = last + (end - last) / 2;
    std::fs::write(&path, &bytes[..cut]).unwrap();
    let torn = read_record(&dir.join("rec")).unwrap();
    let seg = &torn.segments[0];
    assert_eq!(seg.end, None);
    let t = seg.torn.expect("a torn tail");
    assert_eq!((t.offset, t.ignored), (last, cut - last));
    assert_eq!(seg.cycles.len(), good, "every cycle of the good blocks");
    assert_eq!(seg.cycles[..], full.segments[0].cycles[..good]);
    let project = softplc::project::load(&quickstart()).unwrap();
    let report = replay(&torn, &project, ReplayOptions::default(), |_| {}).unwrap();
    assert_eq!(report.cycles as usize, good);
    assert!(report.identical());
    assert!(
        report.notes[0].contains("torn tail at byte"),
        "{:?}",
        report.notes
    );
}

fn s_block_time() -> Duration {
    Duration::from_millis(200)
}

#[test]
fn rotation_keeps_the_time_and_size_bounds() {
    let dir = tempdir("rotation");
    let keep = Duration::from_secs(4);
    let mut s = Settings::new(dir.join("rec"), keep, 256 << 20);
    s.block_time = s_block_time();
    let rec = record(&quickstart(), s, Duration::from_secs(60));
    // Segments are cut every keep/4 = 1 s (at the first block boundary after it); when one
    // starts, the oldest go while the next one starts before now - keep. What is left covers
    // at least `keep`, and at most keep and two segments.
    let first = rec.cycles().next().unwrap().now;
    let last = rec.cycles().last().unwrap().now;
    let span = last - first;
    let segment = keep / 4 + s_block_time();
    assert!(span >= keep, "{span:?}");
    assert!(span <= keep + 2 * segment, "{span:?}");
    assert!(rec.segments[0].header.segment > 40, "old segments went");
    // The record still replays, from its first keyframe, and says so.
    let project = softplc::project::load(&quickstart()).unwrap();
    let report = replay(&rec, &project, ReplayOptions::default(), |_| {}).unwrap();
    assert!(
        report.notes[0].contains("rotated out"),
        "{:?}",
        report.notes
    );

    // The size bound: with 16 KiB segments and 48 KiB at most.
    let dir = tempdir("rotation-size");
    let mut s = Settings::new(dir.join("rec"), Duration::from_secs(3600), 48 << 10);
    s.segment_bytes = 16 << 10;
    s.block_bytes = 2 << 10;
    record(&quickstart(), s.clone(), Duration::from_secs(600));
    let files = segments_in(&s.folder);
    let total: u64 = files.iter().map(|f| f.bytes).sum();
    assert!(files.len() >= 3, "{files:?}");
    assert!(
        total <= s.max_bytes + s.segment_bytes + s.block_bytes as u64 + 64,
        "{total} bytes in {} segments",
        files.len()
    );
}

#[test]
fn kill_9_of_a_recorded_run_leaves_a_readable_record() {
    let dir = tempdir("kill9");
    let project = quickstart_copy(&dir, None);
    let mut plc = Command::new(BIN)
        .args(["run", "--quiet", "--no-control", "--record", "10m"])
        .arg(&project)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let folder = dir.join("project.yaml.record");
    // Real time: blocks are written every second of scan time.
    let begin = Instant::now();
    let mut seen = 0;
    while begin.elapsed() < Duration::from_secs(30) {
        std::thread::sleep(Duration::from_millis(200));
        if let Ok(r) = read_record(&folder) {
            seen = r.cycles().count();
            if seen >= 25 {
                break;
            }
        }
    }
    #[allow(unsafe_code)]
    // SAFETY: kill with a valid pid and signal.
    unsafe {
        libc::kill(plc.id() as i32, libc::SIGKILL)
    };
    let status = plc.wait().unwrap();
    assert!(!status.success());
    assert!(seen >= 25, "only {seen} cycles recorded in 30 s");
    let record = read_record(&folder).unwrap();
    let seg = record.segments.last().unwrap();
    assert_eq!(seg.end, None, "no clean end after kill -9");
    assert!(!seg.header.virtual_clock);
    let cycles = record.cycles().count();
    assert!(cycles >= seen);
    // Every cycle up to the kill replays on the virtual clock with the same outputs.
    let loaded = softplc::project::load(&project).unwrap();
    let report = replay(&record, &loaded, ReplayOptions::default(), |_| {}).unwrap();
    assert_eq!(report.cycles as usize, cycles);
    assert!(report.identical(), "{:?}", report.differences);
}

#[test]
fn the_service_unit_records_into_its_state_directory() {
    let dir = tempdir("unit");
    let project = quickstart_copy(&dir, None);
    let state = dir.join("state");
    let unit = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/softplc@.service"),
    )
    .unwrap();
    // The unit's own command line, with this binary and this project.
    let exec = unit
        .lines()
        .find_map(|l| l.strip_prefix("ExecStart="))
        .unwrap();
    let args: Vec<String> = exec
        .split_whitespace()
        .skip(1)
        .map(|a| {
            if a == "/etc/softplc/%i/project.yaml" {
                project.display().to_string()
            } else {
                a.to_string()
            }
        })
        .collect();
    assert!(args.iter().any(|a| a == "--record"), "{exec}");
    let plc = Command::new(BIN)
        .args(&args)
        .arg("--no-control")
        .env("STATE_DIRECTORY", &state)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The record is in the state directory, per project folder, as retained values are.
    let folder = state
        .join(dir.file_name().unwrap())
        .join("project.yaml.record");
    let begin = Instant::now();
    while begin.elapsed() < Duration::from_secs(30)
        && read_record(&folder).map_or(0, |r| r.cycles().count()) < 15
    {
        std::thread::sleep(Duration::from_millis(200));
    }
    #[allow(unsafe_code)]
    // SAFETY: kill with a valid pid and signal.
    unsafe {
        libc::kill(plc.id() as i32, libc::SIGTERM)
    };
    let out = plc.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let record = read_record(&folder).unwrap();
    let end = record
        .segments
        .last()
        .unwrap()
        .end
        .expect("a clean end on SIGTERM");
    assert_eq!(end.cycles as usize, record.cycles().count());
    assert!(end.cycles >= 15);
}

#[test]
fn the_cycle_a_program_faults_in_is_recorded_and_replayed() {
    let dir = tempdir("fault");
    // The quick start's rungs in Rhai, and a fault when a box reaches the exit.
    let rhai = "motor = (start || motor) && !stop && !box_at_exit;\n\
                lamp = box_at_exit;\n\
                if box_at_exit { throw \"box jammed at the exit\"; }\n";
    let project = quickstart_copy(&dir, Some(rhai));
    let yaml = std::fs::read_to_string(&project).unwrap().replace(
        "file: conveyor.expr\n  kind: expr",
        "file: conveyor.expr\n  kind: rhai",
    );
    assert!(yaml.contains("kind: rhai"));
    std::fs::write(&project, yaml).unwrap();
    let record = record_in(&project, &dir, 30);
    let last = record.cycles().last().unwrap().clone();
    assert!(last.faulted, "{last:?}");
    assert!(last.wrote.is_empty());
    let exit = states(&record, "box_at_exit");
    let first_exit = exit.iter().find(|s| s.2 == Value::Bool(true)).unwrap();
    assert_eq!(
        last.cycle, first_exit.0,
        "the cycle that first saw the box at the exit"
    );
    assert_eq!(record.segments[0].end.map(|e| e.cycles), Some(last.cycle));

    // The same program faults at the same cycle: that is a match.
    let loaded = softplc::project::load(&project).unwrap();
    let report = replay(&record, &loaded, ReplayOptions::default(), |_| {}).unwrap();
    assert_eq!(report.recorded_fault, Some(last.cycle));
    assert_eq!(report.fault.as_ref().map(|f| f.0), Some(last.cycle));
    assert!(report.identical(), "{report:?}");
    // The fix does not fault there: the summary says so.
    std::fs::write(
        dir.join("conveyor.expr"),
        "motor = (start || motor) && !stop && !box_at_exit;\nlamp = box_at_exit;\n",
    )
    .unwrap();
    let out = Command::new(BIN)
        .arg("replay")
        .arg(dir.join("rec"))
        .arg(&project)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "the recorded program faulted at cycle {}; the replayed one did not",
            last.cycle
        )),
        "{stdout}"
    );
}

#[test]
fn replay_names_what_it_cannot_read() {
    let dir = tempdir("unreadable");
    let project = quickstart_copy(&dir, None);
    let run = |record: &Path| {
        let out = Command::new(BIN)
            .arg("replay")
            .arg(record)
            .arg(&project)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let missing = dir.join("nothing.record");
    let (code, err) = run(&missing);
    assert_eq!(code, Some(2));
    assert!(
        err.contains(&format!("{}: no record there", missing.display())),
        "{err}"
    );
    let empty = dir.join("empty.record");
    std::fs::create_dir_all(&empty).unwrap();
    let (code, err) = run(&empty);
    assert_eq!(code, Some(2));
    assert!(
        err.contains("no record segments (*.splrec) in this folder"),
        "{err}"
    );
    let (code, err) = run(&project);
    assert_eq!(code, Some(2));
    assert!(
        err.contains(&format!(
            "{}: not a softplc record segment",
            project.display()
        )),
        "{err}"
    );
}

/// Fills the recorder's disk at cycle 100 and, once the recorder has had to let cycles go,
/// frees it at cycle 400, waiting (real time) until it writes again.
struct DiskFiller {
    full: Arc<std::sync::atomic::AtomicBool>,
    state: Arc<std::sync::Mutex<WriterState>>,
}

impl DiskFiller {
    fn wait_for(&self, what: &str, ok: impl Fn(&WriterState) -> bool) {
        let begin = Instant::now();
        loop {
            let state = self.state.lock().unwrap().clone();
            if ok(&state) {
                return;
            }
            assert!(
                begin.elapsed() < Duration::from_secs(60),
                "never {what}: {state:?}"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
    }
}

impl CycleBoundary for DiskFiller {
    fn between_cycles(&mut self, _plc: &mut Plc, stats: &ScanStats, _now: ScanInstant) {
        use std::sync::atomic::Ordering;
        match stats.cycles {
            100 => self.full.store(true, Ordering::SeqCst),
            400 => {
                self.wait_for("losing cycles", |s| {
                    matches!(s, WriterState::Held { losing: true, .. })
                });
                self.full.store(false, Ordering::SeqCst);
                self.wait_for("writing again", |s| *s == WriterState::Writing);
            }
            _ => {}
        }
    }
}

/// The quick start recorded for 60 s of virtual time on a disk full from cycle 100 until
/// the recorder has lost cycles; the record's folder.
fn record_through_a_full_disk(dir: &Path, project: &Path) -> PathBuf {
    let folder = dir.join("rec");
    let mut s = settings(&folder);
    s.block_bytes = 128;
    s.hold_bytes = 256;
    let disk = FaultDisk::new(&folder, 1 << 30);
    let full = disk.full_switch();
    let loaded = softplc::project::load(project).unwrap();
    let mut plc = Plc::build(loaded, Arc::new(VirtualClock::new())).unwrap();
    let handle = plc.record_on(s, Box::new(disk)).unwrap();
    let filler = DiskFiller {
        full,
        state: handle.state_cell(),
    };
    let mut engine = ScanEngine::new(plc)
        .run_for(Duration::from_secs(60))
        .with_boundary(filler);
    engine.run();
    drop(engine);
    let outcome = handle.finish();
    assert_eq!((outcome.error, outcome.gaps), (None, 1));
    folder
}

#[test]
fn a_full_disk_leaves_a_gap_that_replay_names_and_the_record_resumes() {
    let dir = tempdir("fulldisk");
    let project = quickstart_copy(&dir, None);
    let folder = record_through_a_full_disk(&dir, &project);
    let record = read_record(&folder).unwrap();
    let gap = record
        .segments
        .iter()
        .find_map(|s| s.gap)
        .expect("a gap block");
    // The writer lags the scan a little: its first refused block may hold cycles before 100.
    // The disk is back after scan 400 (the first scan is cycle 1).
    assert!(gap.first <= gap.last && gap.last <= 400, "{gap:?}");
    let cycles: Vec<u64> = record.cycles().map(|c| c.cycle).collect();
    assert_eq!(*cycles.last().unwrap(), 600, "recording resumed to the end");
    assert!(!cycles.contains(&gap.first) && !cycles.contains(&gap.last));
    assert!(cycles.contains(&(gap.last + 1)));

    let (_, stdout) = replay_cli(&folder, &project);
    let note = format!(
        "note: no record from cycle {} to {}: the recorder could not write them (a full disk); \
         replay goes on from cycle {}",
        gap.first,
        gap.last,
        gap.last + 1
    );
    assert!(stdout.contains(&note), "{note}\nin\n{stdout}");
    assert!(
        stdout.contains(&format!("{} cycles, ", cycles.len())),
        "every recorded cycle replayed: {stdout}"
    );
}

/// The recorder's entry of a `status --json` saved in `file`.
fn recorder_status(file: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(file).unwrap();
    let status: serde_json::Value = serde_json::from_str(&text).unwrap();
    let services = status["services"].as_array().unwrap().clone();
    services
        .into_iter()
        .find(|s| s["service"] == "recorder")
        .unwrap()
}

/// What a run of `dir/project.yaml` (its record in `disk/rec`) went through on a real 1.5 MiB
/// tmpfs that another program filled for 3 s, 2 s into its 12 s: its log and standard
/// output, the recorder's `status` while the disk was full and 4 s after it was emptied (the
/// writer tries again 0.25, 0.75, 1.75 and 3.75 s after its first refusal); the record is copied
/// out of the namespace to `dir/rec-copy`.
struct FilledTmpfs {
    log: String,
    stdout: String,
    full: serde_json::Value,
    after: serde_json::Value,
}

fn run_on_a_tmpfs_filled_for_three_seconds(dir: &Path) -> FilledTmpfs {
    std::fs::create_dir_all(dir.join("disk")).unwrap();
    // The run, the filler and the copy out all inside the namespace, where the tmpfs is.
    let script = format!(
        "set -e
mount -t tmpfs -o size=1536k tmpfs {d}/disk
{bin} run {d}/project.yaml --quiet --socket {d}/ctl.sock --for 12s >{d}/out 2>{d}/log &
pid=$!
sleep 2
dd if=/dev/zero of={d}/disk/filler bs=4k 2>/dev/null || true
sleep 1.5
{bin} status --json --socket {d}/ctl.sock >{d}/status-full.json
sleep 1.5
rm {d}/disk/filler
sleep 4
{bin} status --json --socket {d}/ctl.sock >{d}/status-after.json
wait $pid
cp -r {d}/disk/rec {d}/rec-copy",
        d = dir.display(),
        bin = BIN
    );
    let out = Command::new("unshare")
        .args(["-rm", "sh", "-c", &script])
        .output()
        .unwrap();
    let log = std::fs::read_to_string(dir.join("log")).unwrap_or_default();
    assert!(out.status.success(), "{out:?}\n{log}");
    FilledTmpfs {
        stdout: std::fs::read_to_string(dir.join("out")).unwrap(),
        full: recorder_status(&dir.join("status-full.json")),
        after: recorder_status(&dir.join("status-after.json")),
        log,
    }
}

/// Asserts `record` holds every cycle from its first, `at_least` of them, ends cleanly and
/// replays identically against `project`; the cycles.
fn assert_whole_and_identical(
    record: &Record,
    project: &softplc::project::Project,
    at_least: usize,
) -> Vec<u64> {
    let cycles: Vec<u64> = record.cycles().map(|c| c.cycle).collect();
    let expected: Vec<u64> = (cycles[0]..cycles[0] + cycles.len() as u64).collect();
    assert_eq!(cycles, expected, "no cycle missing");
    assert!(cycles.len() >= at_least, "{} cycles in 12 s", cycles.len());
    assert!(record.segments.last().unwrap().end.is_some(), "a clean end");
    let report = replay(record, project, ReplayOptions::default(), |_| {}).unwrap();
    assert!(report.identical(), "{:?}", report.differences);
    cycles
}

#[test]
fn a_real_tmpfs_filled_for_three_seconds_is_reported_loses_nothing_and_recording_resumes() {
    let dir = tempdir("tmpfs");
    let project = quickstart_copy(&dir, None);
    if !crate::common::host::tmpfs_allowed() {
        // The seam's full disk instead, so the case never goes untested.
        eprintln!("no tmpfs in a mount namespace on this machine: the fault-injecting disk runs");
        let folder = record_through_a_full_disk(&dir, &project);
        assert!(read_record(&folder).is_ok());
        return;
    }
    // 2 ms cycles: a tmpfs page (4 KiB) of records in well under a second, so the full
    // tmpfs refuses the next one (a write into a page the file has already goes through).
    let mut yaml = std::fs::read_to_string(&project)
        .unwrap()
        .replace("period: 100ms", "period: 2ms");
    yaml.push_str("recorder: { keep: 10m, size: 1MiB, folder: disk/rec }\n");
    std::fs::write(&project, yaml).unwrap();
    let run = run_on_a_tmpfs_filled_for_three_seconds(&dir);
    let log = &run.log;
    assert!(log.contains("No space left on device"), "{log}");
    assert!(
        log.contains("again after")
            && log.contains("nothing lost (the records were held in memory)"),
        "{log}"
    );
    // What `status` said of the recorder while the disk was full, and after.
    let full = &run.full;
    assert_eq!(full["state"], "degraded", "{full}");
    assert!(
        full["reason"]
            .as_str()
            .unwrap()
            .starts_with("cannot write (No space left on device (os error 28)); "),
        "{full}"
    );
    assert_eq!(run.after["state"], "running");
    let record = read_record(&dir.join("rec-copy")).unwrap();
    let loaded = softplc::project::load(&project).unwrap();
    assert_whole_and_identical(&record, &loaded, 80);
}

#[test]
fn a_real_tmpfs_filled_under_two_tasks_holds_each_tasks_records_and_both_resume() {
    if !crate::common::host::tmpfs_allowed() {
        // The seam's full disk under two tasks instead, so the case never goes untested.
        eprintln!("no tmpfs in a mount namespace on this machine: the fault-injecting disk runs");
        crate::task_record::a_gap_in_a_tasks_record_is_named_with_its_task_by_replay();
        return;
    }
    let dir = tempdir("tmpfs-tasks");
    // The tasks' example of two lines, at 2 ms and 10 ms: both records fill pages quickly.
    let project = crate::task_record::PROJECT
        .replace("period: 20ms", "period: 2ms")
        .replace("period: 100ms", "period: 10ms")
        + "recorder: { keep: 10m, size: 1MiB, folder: disk/rec }\n";
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    std::fs::write(dir.join("fast.rhai"), crate::task_record::FAST).unwrap();
    std::fs::write(dir.join("slow.rhai"), crate::task_record::SLOW).unwrap();
    let run = run_on_a_tmpfs_filled_for_three_seconds(&dir);
    let log = &run.log;
    // Each task's writer held its own records and came back by itself.
    for task in ["fast", "slow"] {
        let folder = dir.join("disk/rec").join(task);
        let refused = format!(
            "flight recorder: cannot write to {}: No space left on device",
            folder.display()
        );
        let back = format!(
            "flight recorder: writing to {} again after",
            folder.display()
        );
        assert!(
            log.contains(&refused) && log.contains(&back),
            "{task}: {log}"
        );
    }
    assert!(
        !log.contains("no record from cycle"),
        "the hold took the 3 s: {log}"
    );
    // The status names each task the disk refused.
    let full = &run.full;
    assert_eq!(full["state"], "degraded", "{full}");
    let reason = full["reason"].as_str().unwrap();
    assert!(
        reason.contains("task fast: cannot write (No space left on device")
            && reason.contains("task slow: cannot write (No space left on device"),
        "{full}"
    );
    assert_eq!(run.after["state"], "running", "{}", run.after);
    // Every scan of each task is in its record, which replays identically.
    let loaded = softplc::project::load(&dir.join("project.yaml")).unwrap();
    for (task, at_least) in [("fast", 400), ("slow", 80)] {
        let record = read_record(&dir.join("rec-copy").join(task)).unwrap();
        let cycles = assert_whole_and_identical(&record, &loaded, at_least);
        let scans = crate::task_record::scans(&run.stdout, task);
        assert_eq!(
            (cycles[0], cycles.len() as u64),
            (1, scans),
            "task {task}: {}",
            run.stdout
        );
    }
}
