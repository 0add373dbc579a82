//! A wall-clock step (NTP at boot, or someone setting the date) in the middle of a running
//! PLC: wall time is only a label (the record's run id and wall origin, read once at start;
//! segment names, OPC UA and Sparkplug timestamps are that origin plus scan time), so the
//! scan keeps its period on the monotonic clock and the record and the traces stay whole, in
//! order and on the scan's time.
//!
//! The step is made for the child only, with libfaketime (Debian's `libfaketime`, installed by
//! `scripts/test`): its wall clock goes back an hour, then a day forward. Stepping the
//! machine's own clock would need privilege and disturb everything else on it. libfaketime
//! refuses `clock_nanosleep(TIMER_ABSTIME)` even for CLOCK_MONOTONIC, where the scan then
//! waits in relative sleeps on the same clock (`MonotonicClock::sleep_until`): so the runs
//! below on the real clock also show that a refused absolute wait never lets the scan run
//! flat out. The first test runs on the virtual clock, where every cycle's scan time is exact.
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use softplc::recorder::{read_record, replay, segments_in, ReplayOptions};
use softplc_io::time::ScanInstant;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
const FAKETIME: &str = "/usr/lib/x86_64-linux-gnu/faketime/libfaketimeMT.so.1";

/// Runs `c` with its wall clock offset by what the file `offset` says (libfaketime's `+0`,
/// `-1h`, `+1d`, read at every call); its monotonic clock is the machine's.
fn faked(c: &mut Command, offset: &Path) {
    c.env("LD_PRELOAD", FAKETIME)
        .env("FAKETIME_TIMESTAMP_FILE", offset)
        .env("FAKETIME_NO_CACHE", "1")
        .env("FAKETIME_DONT_FAKE_MONOTONIC", "1");
}

/// How far (s) the wall clock seen under `offset` is from the machine's: proves the step
/// reached a child (the same library and file move `date`).
fn stepped_by(offset: &Path) -> i64 {
    let date = |fake: bool| {
        let mut c = Command::new("date");
        c.arg("+%s");
        if fake {
            faked(&mut c, offset);
        }
        let out = c.output().unwrap();
        String::from_utf8_lossy(&out.stdout)
            .trim()
            .parse::<i64>()
            .unwrap()
    };
    date(true) - date(false)
}

/// A scratch folder for `case`, empty, with libfaketime's offset file at `+0`.
fn scratch(case: &str) -> (PathBuf, PathBuf) {
    assert!(
        Path::new(FAKETIME).exists(),
        "{FAKETIME} is missing: run scripts/test, which installs libfaketime"
    );
    let dir = std::env::temp_dir().join(format!("softplc-wall-{case}-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    let offset = dir.join("faketime");
    std::fs::write(&offset, "+0").unwrap();
    (dir, offset)
}

#[test]
fn a_wall_clock_step_back_and_forward_leaves_the_record_whole_and_in_order() {
    let (dir, offset) = scratch("virtual");
    let yaml = "project: wall\n\
                scan: { period: 100ms }\n\
                tags:\n  - { name: n, type: i32 }\n  - { name: pulse, type: bool }\n\
                program: { file: count.rhai, kind: rhai }\n\
                recorder: { keep: 1000h, size: 64MiB, folder: rec }\n";
    std::fs::write(dir.join("count.rhai"), "n = n + 1;\npulse = n % 4 == 0;\n").unwrap();
    let project = dir.join("project.yaml");
    std::fs::write(&project, yaml).unwrap();
    let mut run = Command::new(BIN);
    run.args([
        "run",
        "--no-control",
        "--quiet",
        "--virtual",
        "--for",
        "10000h",
    ])
    .arg(&project)
    .stdout(Stdio::null())
    .stderr(Stdio::piped());
    faked(&mut run, &offset);
    let child = run.spawn().unwrap();
    std::thread::sleep(Duration::from_millis(800));
    std::fs::write(&offset, "-1h").unwrap();
    std::thread::sleep(Duration::from_millis(800));
    std::fs::write(&offset, "+1d").unwrap();
    std::thread::sleep(Duration::from_millis(800));
    #[allow(unsafe_code)]
    // SAFETY: kill has no memory preconditions; the pid is our own child's.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM)
    };
    let out = child.wait_with_output().unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    // The child's wall clock did step: the same library and offset file move `date` a day.
    let stepped = stepped_by(&offset);
    assert!(
        (86_390..86_410).contains(&stepped),
        "stepped by {stepped} s"
    );

    let record = read_record(&dir.join("rec")).unwrap();
    let cycles: Vec<_> = record.cycles().collect();
    assert!(cycles.len() > 100, "{} cycles", cycles.len());
    assert_eq!(cycles[0].cycle, 1, "the first scan is cycle 1");
    // The virtual clock runs flat out and the writer may fall behind: a record it could not
    // take is counted in the next one. Every cycle is accounted for, in order, each on the
    // 100 ms grid of scan time whatever the wall clock did.
    for w in cycles.windows(2) {
        assert_eq!(
            w[1].cycle,
            w[0].cycle + 1 + w[1].dropped_before,
            "{:?}",
            w[1].cycle
        );
    }
    assert!(
        cycles
            .iter()
            .all(|c| c.now == ScanInstant::after_origin(Duration::from_millis(100 * (c.cycle - 1)))),
        "scan times on the 100 ms grid"
    );
    assert_eq!(record.parts().len(), 1, "one run, its segments in order");
    assert!(record.segments.last().unwrap().end.is_some(), "a clean end");
    let loaded = softplc::project::load(&project).unwrap();
    let report = replay(&record, &loaded, ReplayOptions::default(), |_| {}).unwrap();
    assert_eq!(report.cycles as usize, cycles.len(), "replay reads it all");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// How long the real-clock runs scan (`--for`).
const RUN_FOR: Duration = Duration::from_secs(5);

/// A run of the project in `dir` on the real clock, for [`RUN_FOR`], whose wall clock steps
/// back an hour one second into its scan and a day forward a second later; after the steps,
/// each trace of `traces` is saved as `NAME.csv` while it still runs. The run's standard
/// output, and how long it took by the test's own monotonic clock.
fn stepped_real_run(dir: &Path, offset: &Path, traces: &[&str]) -> (String, Duration) {
    let socket = dir.join("ctl.sock");
    let mut run = Command::new(BIN);
    run.args(["run", "project.yaml", "--quiet", "--for", "5s", "--socket"])
        .arg(&socket)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    faked(&mut run, offset);
    let begin = Instant::now();
    let child = run.spawn().unwrap();
    // The socket opens just before the first scan.
    while !socket.exists() {
        assert!(
            begin.elapsed() < Duration::from_secs(60),
            "no control socket"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_secs(1));
    std::fs::write(offset, "-1h").unwrap();
    std::thread::sleep(Duration::from_secs(1));
    std::fs::write(offset, "+1d").unwrap();
    std::thread::sleep(Duration::from_millis(200));
    for name in traces {
        let out = Command::new(BIN)
            .args(["trace", "save", name, "--csv"])
            .arg(dir.join(format!("{name}.csv")))
            .arg("--socket")
            .arg(&socket)
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
    }
    let out = child.wait_with_output().unwrap();
    let took = begin.elapsed();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    let stepped = stepped_by(offset);
    assert!(
        (86_390..86_410).contains(&stepped),
        "stepped by {stepped} s"
    );
    (String::from_utf8_lossy(&out.stdout).into_owned(), took)
}

/// Every `scans N` of a run's summary (one per task).
fn scans(stdout: &str) -> Vec<u64> {
    stdout
        .lines()
        .filter_map(|l| l.trim().strip_prefix("scans "))
        .map(|rest| rest.split_whitespace().next().unwrap().parse().unwrap())
        .collect()
}

/// A trace's CSV samples: (seconds of scan time, cycle).
fn trace_samples(csv: &Path) -> Vec<(f64, u64)> {
    let text = std::fs::read_to_string(csv).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let mut cols = l.split(',');
            let t = cols.next().unwrap().parse().unwrap();
            let c = cols.next().unwrap().parse().unwrap();
            (t, c)
        })
        .collect()
}

/// Asserts what the wall-clock step must not break in a real-clock run of `dir`: the run
/// waited its scan time on the monotonic clock, each task scanned, each trace in `traces`
/// holds consecutive cycles from the first at increasing scan times (a step would show as a
/// jump of an hour or a day), each record in `records` is one whole part with scan times in
/// order, named after the wall time at start (not the stepped one), and replays identically.
fn assert_unbroken(dir: &Path, offset: &Path, traces: &[&str], records: &[&str], periods: &[u64]) {
    let wall_at_start = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64;
    let (stdout, took) = stepped_real_run(dir, offset, traces);
    // Flat out (an absolute wait refused and not replaced) the run ends in a fraction of a
    // second, its scans still counted on the grid.
    assert!(
        took >= RUN_FOR - Duration::from_millis(100) && took < Duration::from_secs(120),
        "the run took {took:?}"
    );
    let counted = scans(&stdout);
    assert_eq!(counted.len(), periods.len(), "{stdout}");
    for (n, period_ms) in counted.iter().zip(periods) {
        let due = RUN_FOR.as_millis() as u64 / period_ms;
        // Overruns on a loaded machine skip deadlines: never more than due, at least a few.
        assert!((due / 4..=due).contains(n), "{n} of {due} scans: {stdout}");
    }
    for name in traces {
        let samples = trace_samples(&dir.join(format!("{name}.csv")));
        assert!(samples.len() >= 10, "{name}: {samples:?}");
        assert_eq!(samples[0].1, 1, "{name} starts at the first scan");
        assert!(samples[0].0 < 2.0, "{name}: {samples:?}");
        for w in samples.windows(2) {
            assert_eq!(w[1].1, w[0].1 + 1, "{name}: {w:?}");
            let dt = w[1].0 - w[0].0;
            assert!(dt > 0.0 && dt < 1.0, "{name}: {w:?}");
        }
    }
    let project = softplc::project::load(&dir.join("project.yaml")).unwrap();
    for folder in records {
        let folder = dir.join(folder);
        let record = read_record(&folder).unwrap();
        let cycles: Vec<_> = record.cycles().collect();
        assert_eq!(cycles[0].cycle, 1, "{folder:?}");
        for w in cycles.windows(2) {
            assert_eq!(w[1].cycle, w[0].cycle + 1 + w[1].dropped_before);
            let dt = w[1].now.saturating_duration_since(w[0].now);
            assert!(w[1].now > w[0].now && dt < Duration::from_secs(1), "{w:?}");
        }
        assert_eq!(record.parts().len(), 1, "one run, its segments in order");
        assert!(record.segments.last().unwrap().end.is_some(), "a clean end");
        for segment in segments_in(&folder) {
            let off = segment.start_ms.abs_diff(wall_at_start);
            assert!(off < 60_000, "{segment:?} named {off} ms from the start");
        }
        let report = replay(&record, &project, ReplayOptions::default(), |_| {}).unwrap();
        assert_eq!(report.cycles as usize, cycles.len(), "replay reads it all");
        assert!(report.identical(), "{:?}", report.differences);
    }
}

#[test]
fn a_wall_clock_step_on_the_real_clock_leaves_the_scan_its_trace_and_record_in_step() {
    let (dir, offset) = scratch("real");
    std::fs::write(
        dir.join("project.yaml"),
        "project: wall\n\
         scan: { period: 20ms }\n\
         tags:\n  - { name: n, type: i32 }\n  - { name: pulse, type: bool }\n\
         program: { file: count.rhai, kind: rhai }\n\
         recorder: { keep: 1000h, size: 64MiB, folder: rec }\n\
         traces:\n  - { name: counting, tags: [n, pulse], pre: 0, post: 1000 }\n",
    )
    .unwrap();
    std::fs::write(dir.join("count.rhai"), "n = n + 1;\npulse = n % 4 == 0;\n").unwrap();
    assert_unbroken(&dir, &offset, &["counting"], &["rec"], &[20]);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

#[test]
fn a_wall_clock_step_leaves_every_task_its_scan_trace_and_record() {
    let (dir, offset) = scratch("tasks");
    // Two tasks on simulated lines, each with a trace of its own tags and a record.
    std::fs::write(
        dir.join("project.yaml"),
        "project: counted\n\
         tasks:\n\
         \x20 - { name: fast, period: 20ms, program: { file: fast.rhai, kind: rhai }, buses: [fast_line] }\n\
         \x20 - { name: slow, period: 100ms, program: { file: slow.rhai, kind: rhai }, buses: [slow_line] }\n\
         buses:\n\
         \x20 - { name: fast_line, port: sim, baud: 57600, response_timeout: 20ms }\n\
         \x20 - { name: slow_line, port: sim, baud: 57600, response_timeout: 20ms }\n\
         modules:\n\
         \x20 - { name: a, bus: fast_line, model: minimod, address: 1 }\n\
         \x20 - { name: b, bus: slow_line, model: minimod, address: 1 }\n\
         tags:\n\
         \x20 - { name: beat, point: a.Y1, safe: false }\n\
         \x20 - { name: scaled, type: i32 }\n\
         \x20 - { name: ticks, type: i32 }\n\
         \x20 - { name: lamp, point: b.Y1, safe: false }\n\
         recorder: { keep: 1000h, size: 64MiB, folder: rec }\n\
         traces:\n\
         \x20 - { name: fast_trace, tags: [scaled, beat], pre: 0, post: 1000 }\n\
         \x20 - { name: slow_trace, tags: [ticks, lamp], pre: 0, post: 1000 }\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("fast.rhai"),
        "scaled = ticks * 10;\nbeat = ticks % 2 == 0;\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("slow.rhai"),
        "ticks += 1;\nlamp = scaled % 20 == 10;\n",
    )
    .unwrap();
    assert_unbroken(
        &dir,
        &offset,
        &["fast_trace", "slow_trace"],
        &["rec/fast", "rec/slow"],
        &[20, 100],
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}
