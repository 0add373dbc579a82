//! `softplc check` prints the floor of a Collect round for a line with MiniMods in event mode
//! (MiniMod manual, "The Modbus function Collect"), with what it includes, and nothing of the
//! kind for a line that is only polled.

use std::path::PathBuf;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

/// A project folder: bus `events` at `baud` with MiniMods 1..=4 in event mode, bus `polled`
/// with one MiniMod polled.
fn folder(case: &str, baud: u32) -> PathBuf {
    folder_with(case, baud, ALONE)
}

/// A member's keys besides its name, bus, model and address in [`folder`].
const ALONE: &str = "watchdog: off, settings: { events: true }";

/// [`folder`] with mm2's keys besides its name, bus, model and address (`ALONE` in `folder`).
fn folder_with(case: &str, baud: u32, mm2: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "softplc-collect-floor-{}-{case}",
        std::process::id()
    ));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("run.expr"), "lamp = button\n").unwrap();
    let mut modules = String::new();
    for a in 1..=4 {
        modules.push_str(&format!(
            "  - {{ name: mm{a}, bus: events, model: minimod, address: {a}, {} }}\n",
            if a == 2 { mm2 } else { ALONE }
        ));
    }
    let text = format!(
        "project: collect
scan: {{ period: 100ms }}
buses:
  - {{ name: events, port: sim, baud: {baud} }}
  - {{ name: polled, port: sim }}
modules:
{modules}  - {{ name: mm9, bus: polled, model: minimod, address: 9, watchdog: off, settings: {{ events: false }} }}
tags:
  - {{ name: button, point: mm1.X1 }}
  - {{ name: lamp, point: mm9.Y1, safe: false }}
program: {{ file: run.expr, kind: expr }}
"
    );
    std::fs::write(dir.join("project.yaml"), text).unwrap();
    dir
}

fn check(dir: &PathBuf) -> String {
    let out = Command::new(BIN)
        .arg("check")
        .arg(dir.join("project.yaml"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
    stdout
}

fn floor_lines(report: &str) -> Vec<&str> {
    report
        .lines()
        .map(str::trim_start)
        .filter(|l| l.starts_with("collect floor"))
        .collect()
}

#[test]
fn check_prints_the_collect_floor_of_a_line_in_event_mode() {
    let report = check(&folder("19200", 19200));
    // 8 characters of 11 bits at 19200 (4.583 ms) + 4 × 3 ms + 1 ms + t3.5 (2.005 ms);
    // an event: 8 + 9 characters (9.740 ms) + t3.5 − its 3 ms slot.
    assert_eq!(
        floor_lines(&report),
        [
            "collect floor (event mode, window 1–4, 4 member(s)): idle round 19.59ms (a Collect \
          request of 8 characters, 4 slots × 3 ms + 1 ms, t3.5); each event 8.74ms more (its \
          9-character reply from the start of its slot, t3.5, the next Collect; less from \
          address 4, which ends the round); no reply delay applies"
        ],
        "{report}"
    );
    // Printed with the bus it belongs to, not the polled one.
    let events = report.find("bus events:").unwrap();
    let polled = report.find("bus polled:").unwrap();
    let at = report.find("collect floor").unwrap();
    assert!(events < at && at < polled, "{report}");
}

#[test]
fn above_19200_the_floor_uses_the_fixed_t3_5() {
    let report = check(&folder("57600", 57600));
    // 8 × 190.97 µs = 1.528 ms + 13 ms + 1.75 ms.
    let lines = floor_lines(&report);
    assert_eq!(lines.len(), 1, "{report}");
    assert!(lines[0].contains("idle round 16.28ms"), "{}", lines[0]);
    // 17 × 190.97 µs = 3.247 ms + 1.75 ms − 3 ms = 1.997 ms.
    assert!(lines[0].contains("each event 2.00ms more"), "{}", lines[0]);
}

/// The line of `report` that starts (after its indent) with `start`.
fn line_of<'a>(report: &'a str, start: &str) -> &'a str {
    report
        .lines()
        .map(str::trim_start)
        .find(|l| l.starts_with(start))
        .unwrap_or_else(|| panic!("no {start:?} in {report}"))
}

#[test]
fn a_members_rdelaym_lengthens_the_collect_floor_the_budget_and_the_watchdog() {
    // RDELAYM=50: mm2 waits 5 ms more for a request's end (manual, "Setting the Modbus
    // communication timeout"), so every Collect's slots start 5 ms later and each of mm2's
    // own transactions turns round 5 ms later.
    // mm2 keeps its module watchdog, whose WDTTIME is derived from the line's timing.
    let plain = check(&folder_with(
        "rdelaym-0",
        19200,
        "settings: { events: true }",
    ));
    let late = check(&folder_with(
        "rdelaym-50",
        19200,
        "settings: { events: true, RDELAYM: 50 }",
    ));
    assert!(
        line_of(&late, "collect floor").contains(
            "idle round 24.59ms (a Collect request of 8 characters, 4 slots × 3 ms + 1 ms, \
             t3.5, the members' longest RDELAYM 5.00ms per Collect); each event 13.74ms more"
        ),
        "{late}"
    );
    assert!(
        !line_of(&plain, "collect floor").contains("RDELAYM"),
        "{plain}"
    );
    // mm2's read and write each take 5 ms more to turn round, and 4.45 ms more of silence
    // before them (28 bit times + 5 ms, less the t3.5 every request has: 1.458 + 5 − 2.005);
    // mm1's do not.
    let read = |report: &str, m: &str| line_of(report, &format!("{m}: read")).to_string();
    assert_eq!(
        read(&late, "mm1").split(" (").next(),
        read(&plain, "mm1").split(" (").next()
    );
    assert!(
        read(&plain, "mm2").starts_with("mm2: read 20.60ms in 1 tx, write 21.17ms"),
        "{plain}"
    );
    assert!(
        read(&late, "mm2").starts_with("mm2: read 30.05ms in 1 tx, write 30.62ms"),
        "{late}"
    );
    // The module watchdog is derived from the longer line floor and start-up.
    let wdt = |report: &str| -> u32 {
        let line = line_of(report, "module watchdog: WDTTIME ");
        line["module watchdog: WDTTIME ".len()..]
            .split(' ')
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{line}"))
    };
    assert!(wdt(&late) > wdt(&plain), "{plain}\n{late}");
}

#[test]
fn a_module_with_rdelaym_polled_after_a_collect_round_answers_every_request() {
    // mm2 waits 28 bit times + 10 ms of silence for a request's end; polled right after the
    // others' Collect round, its request would be heard as the end of that round and go
    // unanswered (before the owner left it that silence: 21 timeouts in 71 requests).
    let dir = folder_with(
        "rdelaym-polled",
        19200,
        "watchdog: off, settings: { events: false, RDELAYM: 100 }",
    );
    let out = Command::new(BIN)
        .arg("run")
        .arg(dir.join("project.yaml"))
        .args(["--virtual", "--for", "5s", "--no-socket"])
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &*String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    let mm2 = line_of(&text, "module mm2 (events):");
    let requests: u32 = mm2
        .split("requests ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{mm2}"));
    assert!(requests >= 50, "read every cycle: {mm2}");
    assert!(mm2.contains(" timeouts 0 "), "{mm2}");
    assert!(mm2.starts_with("module mm2 (events): good"), "{mm2}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
