//! A wall-clock step (NTP at boot, or someone setting the date) in the middle of a recorded
//! run: wall time is only a label (the record's run id and wall origin, read once at start;
//! segment names are that origin plus scan time), so the record stays whole, in order and
//! replayable.
//!
//! The step is made for the child only, with libfaketime (Debian's `libfaketime`, installed by
//! `scripts/test`): its wall clock goes back an hour, then a day forward. Stepping the
//! machine's own clock would need privilege and disturb everything else on it. The run is on
//! the virtual clock: libfaketime's wrapper of `clock_nanosleep(TIMER_ABSTIME)` fails with
//! EINVAL even for CLOCK_MONOTONIC, so it cannot stand for a real step under the real-clock
//! scan, whose deadlines are on CLOCK_MONOTONIC, which a step does not move.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use softplc::recorder::{read_record, replay, ReplayOptions};
use softplc_io::time::ScanInstant;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
const FAKETIME: &str = "/usr/lib/x86_64-linux-gnu/faketime/libfaketimeMT.so.1";

#[test]
fn a_wall_clock_step_back_and_forward_leaves_the_record_whole_and_in_order() {
    assert!(
        Path::new(FAKETIME).exists(),
        "{FAKETIME} is missing: run scripts/test, which installs libfaketime"
    );
    let dir = std::env::temp_dir().join(format!("softplc-wall-step-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    let yaml = "project: wall\n\
                scan: { period: 100ms }\n\
                tags:\n  - { name: n, type: i32 }\n  - { name: pulse, type: bool }\n\
                program: { file: count.rhai, kind: rhai }\n\
                recorder: { keep: 1000h, size: 64MiB, folder: rec }\n";
    std::fs::write(dir.join("count.rhai"), "n = n + 1;\npulse = n % 4 == 0;\n").unwrap();
    let project = dir.join("project.yaml");
    std::fs::write(&project, yaml).unwrap();
    let offset = dir.join("faketime");
    std::fs::write(&offset, "+0").unwrap();
    let faked = |c: &mut Command| {
        c.env("LD_PRELOAD", FAKETIME)
            .env("FAKETIME_TIMESTAMP_FILE", &offset)
            .env("FAKETIME_NO_CACHE", "1")
            .env("FAKETIME_DONT_FAKE_MONOTONIC", "1");
    };
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
    faked(&mut run);
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
    let date = |fake: bool| {
        let mut c = Command::new("date");
        c.arg("+%s");
        if fake {
            faked(&mut c);
        }
        let out = c.output().unwrap();
        String::from_utf8_lossy(&out.stdout)
            .trim()
            .parse::<i64>()
            .unwrap()
    };
    let stepped = date(true) - date(false);
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
