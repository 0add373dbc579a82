//! What `check` prints of a bus's adapter latency and echo, with sysfs a fake tree.

use std::path::{Path, PathBuf};

use super::*;

/// A tempdir holding a project on `port` (one MiniMod, `bus_extra` added to the bus) and a
/// fake sysfs tree where `ttyUSB7` is an FTDI adapter whose latency timer reads `ms`.
struct Fixture(PathBuf);

impl Fixture {
    fn new(tag: &str, port: &str, bus_extra: &str, ms: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("softplc-check-{tag}-{}", std::process::id()));
        // Best effort: the test's scratch folder, possibly absent.
        drop(std::fs::remove_dir_all(&dir));
        let attr = dir.join("sys/class/tty/ttyUSB7/device");
        std::fs::create_dir_all(&attr).unwrap();
        std::fs::write(attr.join("latency_timer"), ms).unwrap();
        std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
        // The project the end-to-end adapter tests run, its module's watchdog off here (the
        // budget lines are the same; its start-up settings would only add output).
        let project = include_str!("../../../tests/fixtures/adapter/project.yaml")
            .replace("{port}", port)
            .replace("{bus_extra}", bus_extra)
            .replace("address: 1,", "address: 1, watchdog: off,");
        std::fs::write(dir.join("project.yaml"), project).unwrap();
        Self(dir)
    }

    fn report(&self) -> String {
        let project = crate::project::load(&self.0.join("project.yaml")).unwrap();
        report_with(&project, &SysfsRoot(self.0.join("sys")))
    }

    fn sys(&self) -> &Path {
        &self.0
    }
}

impl Drop for Fixture {
    fn drop(&mut self) {
        // Best effort: the test's scratch folder.
        drop(std::fs::remove_dir_all(&self.0));
    }
}

/// The report's lines that start with `prefix` (trimmed of the indentation).
fn lines<'a>(report: &'a str, prefixes: &[&str]) -> Vec<&'a str> {
    report
        .lines()
        .map(str::trim_start)
        .filter(|l| prefixes.iter().any(|p| l.starts_with(p)))
        .collect()
}

const BUDGET: &[&str] = &[
    "adapter latency:",
    "echo:",
    "budget:",
    "on failure:",
    "lines are polled",
];

#[test]
fn a_16_ms_latency_timer_is_counted_in_every_transaction_of_the_budget() {
    let usb = Fixture::new("ftdi", "/dev/ttyUSB7", "", "16\n");
    let report = usb.report();
    assert_eq!(
        lines(&report, BUDGET),
        [
            format!(
                "adapter latency: 16 ms, read from {}/sys/class/tty/ttyUSB7/device/latency_timer",
                usb.sys().display()
            )
            .as_str(),
            "budget: inputs 36.60ms (1 transactions, each with up to 16.00ms of adapter latency), \
             full output write 37.17ms, cycle floor 73.77ms",
            "on failure: a silent module costs the line 313.18ms in its first failed cycle, then \
             156.59ms per cycle until lost (3 cycles), then one probe of 156.59ms per backoff \
             (1 s to 30 s); the scan waits 45.00ms for inputs, then goes on with the line's last \
             values (stale)",
            "lines are polled in parallel: an ordinary cycle's input phase can be no shorter than \
             36.60ms (the slowest line's; a refresh or an input change makes a cycle longer: \
             each line's cycle mix says by how much)",
        ]
    );
    assert!(
        report.contains(
            "warning: bus line1: 13.3% of cycles will overrun at the period 50.00ms (159 a \
             minute with idle inputs: the cycles that carry a refresh, up to 71.77ms)"
        ),
        "{report}"
    );

    // The same line with the udev rule applied: 1 ms.
    let tuned = Fixture::new("ftdi1", "/dev/ttyUSB7", "", "1\n");
    assert_eq!(
        lines(&tuned.report(), &["budget:"]),
        [
            "budget: inputs 21.60ms (1 transactions, each with up to 1.00ms of adapter latency), \
          full output write 22.17ms, cycle floor 43.77ms"
        ]
    );
}

#[test]
fn without_a_latency_timer_the_budget_is_the_wire_time() {
    let uart = Fixture::new("none", "/dev/ttyUSB8", ", adapter_latency: 0ms", "16\n");
    assert_eq!(
        lines(&uart.report(), BUDGET),
        [
            "adapter latency: 0 ms, configured",
            "budget: inputs 20.60ms (1 transactions), full output write 21.17ms, cycle floor 41.77ms",
            "on failure: a silent module costs the line 313.18ms in its first failed cycle, then \
             156.59ms per cycle until lost (3 cycles), then one probe of 156.59ms per backoff \
             (1 s to 30 s); the scan waits 45.00ms for inputs, then goes on with the line's last \
             values (stale)",
            "lines are polled in parallel: an ordinary cycle's input phase can be no shorter than \
             20.60ms (the slowest line's; a refresh or an input change makes a cycle longer: \
             each line's cycle mix says by how much)",
        ]
    );
    let sim = Fixture::new("sim", "sim", ", echo: discard", "16\n");
    assert_eq!(
        lines(&sim.report(), &["adapter latency:", "echo:", "budget:"]),
        [
            "adapter latency: none: simulated line",
            "echo: discard (every request is read back and verified; it comes back while it is \
             sent, so the budget counts nothing for it)",
            "budget: inputs 20.60ms (1 transactions), full output write 21.17ms, cycle floor 41.77ms",
        ]
    );
}

#[test]
fn a_configured_latency_is_what_check_assumes_for_a_port_it_cannot_see() {
    let remote = Fixture::new(
        "remote",
        "/dev/ttyUSB9",
        ", adapter_latency: 4ms, echo: discard",
        "16\n",
    );
    let report = remote.report();
    let got = lines(&report, &["adapter latency:", "budget:", "on failure:"]);
    assert_eq!(got[0], "adapter latency: 4 ms, configured");
    assert_eq!(
        got[1],
        "budget: inputs 24.60ms (1 transactions, each with up to 4.00ms of adapter latency), \
         full output write 25.17ms, cycle floor 49.77ms"
    );
    // The response timeout starts once the echo is back, which the adapter holds back too.
    assert!(
        got[2].contains("then 160.59ms per cycle until lost"),
        "{}",
        got[2]
    );

    let absent = Fixture::new("absent", "/dev/ttyUSB9", "", "16\n");
    assert_eq!(
        lines(&absent.report(), &["adapter latency:"]),
        [
            "adapter latency: 0 ms assumed: /dev/ttyUSB9 is not on this machine (set \
          adapter_latency to the adapter's: 16 ms for an FTDI adapter without the udev rule, 1 \
          ms with it); `run` starts with this line lost and takes the port when it appears"
        ]
    );
}

#[test]
fn the_collect_floor_counts_the_adapter_latency_once_per_collect() {
    let usb = Fixture::new("collect", "/dev/ttyUSB7", "", "1\n");
    let path = usb.sys().join("project.yaml");
    let project = std::fs::read_to_string(&path)
        .unwrap()
        .replace("events: false", "events: true");
    std::fs::write(&path, project).unwrap();
    // 8 characters (4.583 ms) + 1 slot of 3 ms + 1 ms + t3.5 (2.005 ms) + 1 ms held back;
    // an event: 17 characters (9.740 ms) + t3.5 + 1 ms − its 3 ms slot.
    assert_eq!(
        lines(&usb.report(), &["collect floor"]),
        [
            "collect floor (event mode, window 1–1, 1 member(s)): idle round 11.59ms (a Collect \
             request of 8 characters, 1 slot × 3 ms + 1 ms, t3.5, per Collect up to 1.00ms of \
             adapter latency); each event 9.74ms more (its 9-character reply from the start of \
             its slot, t3.5, the next Collect; less from address 1, which ends the round); no \
             reply delay applies"
        ]
    );
}

#[test]
fn the_io_map_shows_each_modules_and_tags_description() {
    let fixture = Fixture::new("described", "sim", "", "1\n");
    let file = fixture.sys().join("project.yaml");
    let text = std::fs::read_to_string(&file)
        .unwrap()
        .replace(
            "settings: { events: false }",
            "settings: { events: false }, description: \"Cabinet 1, left rail\"",
        )
        .replace(
            "point: mm1.X1 }",
            "point: mm1.X1, description: \"Door button, green\" }",
        )
        .replace(
            "program:",
            "  - { name: count, type: u16, description: Doors opened today }\nprogram:",
        );
    std::fs::write(&file, text).unwrap();
    let report = fixture.report();
    assert_eq!(
        lines(&report, &["module mm1", "in  X1", "out Y1", "count"]),
        [
            "module mm1 = minimod @1 (modbus)  — Cabinet 1, left rail",
            "in  X1       bool → tag #0 button  — Door button, green",
            "out Y1       bool → tag #1 lamp safe=0",
            "count u16 = 0  — Doors opened today",
        ]
    );
}
