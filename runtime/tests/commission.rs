//! `softplc commission` on a pty served by `softplc sim --pty`, for each family: the address
//! and baud (where the manual lets a host set them) are changed by the module's own means,
//! survive a simulated power cycle and are found there by `softplc discover`; a change the
//! manual forbids is refused with its reason, before anything is written; nothing changes
//! without `--yes`.

use crate::common::sim;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::Duration;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

fn run(args: &[&str]) -> (Output, String) {
    let out = Command::new(BIN).args(args).output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out, text)
}

#[test]
fn address_and_baud_change_survives_a_power_cycle() {
    let (mut sim, pty) = sim::Sim::start(BIN, &["minimod@5"]);
    // Without --yes and without a terminal nothing changes.
    let (out, text) = run(&["commission", &pty, "--address", "5", "--set-address", "7"]);
    assert!(!out.status.success(), "{text}");
    assert!(text.contains("nothing changed"), "{text}");

    let (out, text) = run(&[
        "commission",
        &pty,
        "--address",
        "5",
        "--set-address",
        "7",
        "--set-baud",
        "9600",
        "--set-reply-delay",
        "20ms",
        "--yes",
    ]);
    assert!(out.status.success(), "{text}");
    for frame in [
        r#""@5>RDELAYT=2\r""#,
        r#""@5>SERLINE=9600E\r""#,
        r#""@5>ADDRESS=7\r""#,
        r#""@7>WCONF=1\r""#,
    ] {
        assert!(text.contains(frame), "no {frame} in\n{text}");
    }
    assert!(text.contains("answers at address 7, 9600 8E1"), "{text}");

    sim.send("minimod@5 power-cycle");
    let (out, text) = run(&[
        "discover",
        &pty,
        "--bauds",
        "19200,9600",
        "--formats",
        "8E1",
        "--addresses",
        "5-7",
        "--timeout",
        "40ms",
    ]);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("found minimod at address 7, 9600 8E1"),
        "{text}"
    );
    assert!(text.contains("1 module(s) found"), "{text}");
}

#[test]
fn a_change_the_manual_forbids_is_refused_with_its_reason() {
    let (_sim, pty) = sim::Sim::start(BIN, &["minimod@5", "resi-16di8ro@3:9600:8N1"]);
    let (out, text) = run(&[
        "commission",
        &pty,
        "--address",
        "5",
        "--set-baud",
        "115200",
        "--yes",
    ]);
    assert!(!out.status.success());
    assert!(
        text.contains("refused") && text.contains("4800, 9600, 19200, 38400 or 57600"),
        "{text}"
    );
    assert!(!text.contains("SERLINE"), "nothing is written: {text}");
    let (out, text) = run(&[
        "commission",
        &pty,
        "--address",
        "3",
        "--baud",
        "9600",
        "--format",
        "8N1",
        "--set-baud",
        "19200",
        "--yes",
    ]);
    assert!(!out.status.success());
    assert!(text.contains("DIP switches"), "{text}");
}

/// `softplc commission PTY` to the module at `address` on a 9600 8N1 line, with `extra`.
fn commission(pty: &str, address: &str, extra: &[&str]) -> (Output, String) {
    commission_at(pty, address, "9600", extra)
}

/// `softplc commission PTY` to the module at `address` at `baud` 8N1, with `extra`.
fn commission_at(pty: &str, address: &str, baud: &str, extra: &[&str]) -> (Output, String) {
    let mut args = vec![
        "commission",
        pty,
        "--address",
        address,
        "--baud",
        baud,
        "--format",
        "8N1",
    ];
    args.extend_from_slice(extra);
    run(&args)
}

/// `softplc discover` on `pty` at these bauds, 8N1, and addresses; its output.
fn discover(pty: &str, bauds: &str, addresses: &str) -> String {
    let (out, text) = run(&[
        "discover",
        pty,
        "--bauds",
        bauds,
        "--formats",
        "8N1",
        "--addresses",
        addresses,
        "--timeout",
        "40ms",
    ]);
    // Nothing found is exit status 1, with the same report.
    assert!(out.status.code().is_some_and(|c| c <= 1), "{text}");
    text
}

/// Asserts that `text` holds every one of `wants`.
fn holds(text: &str, wants: &[&str]) {
    for want in wants {
        assert!(text.contains(want), "no {want} in\n{text}");
    }
}

/// A `softplc commission` running in the background, read line by line as it prints.
struct Running {
    child: Child,
    lines: Receiver<String>,
    seen: Vec<String>,
}

impl Running {
    fn start(args: &[&str]) -> Self {
        let mut child = Command::new(BIN)
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let (tx, lines) = channel();
        let stdout = child.stdout.take().unwrap();
        let stderr = child.stderr.take().unwrap();
        let tx2 = tx.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                // The receiver is gone once the test has what it needs.
                drop(tx.send(line));
            }
        });
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                // The receiver is gone once the test has what it needs.
                drop(tx2.send(line));
            }
        });
        Self {
            child,
            lines,
            seen: Vec::new(),
        }
    }

    /// Reads until a line contains `want`; panics with everything seen after a minute.
    fn until(&mut self, want: &str) {
        loop {
            match self.lines.recv_timeout(Duration::from_secs(60)) {
                Ok(line) => {
                    let hit = line.contains(want);
                    self.seen.push(line);
                    if hit {
                        return;
                    }
                }
                Err(_) => panic!("no {want:?} in\n{}", self.seen.join("\n")),
            }
        }
    }

    /// Waits for the end; whether it succeeded, and everything it printed.
    fn finish(mut self) -> (bool, String) {
        let status = self.child.wait().unwrap();
        while let Ok(line) = self.lines.recv_timeout(Duration::from_secs(5)) {
            self.seen.push(line);
        }
        (status.success(), self.seen.join("\n"))
    }
}

#[test]
fn resi_address_change_by_smbadr_survives_a_power_cycle() {
    let (mut sim, pty) = sim::Sim::start(BIN, &["resi-16di8ro@3:9600:8N1"]);
    // Without --yes nothing changes.
    let (out, text) = commission(&pty, "3", &["--set-address", "9"]);
    assert!(!out.status.success(), "{text}");
    assert!(text.contains("nothing changed"), "{text}");
    assert!(!text.contains(r##"-> "#3,SMBADR"##), "{text}");

    let (out, text) = commission(&pty, "3", &["--set-address", "9", "--yes"]);
    assert!(out.status.success(), "{text}");
    holds(
        &text,
        &[
            r##"-> "#3,GDIP\r""##,
            r##"-> "#3,SMBADR:9\r""##,
            r##"-> "#9,RST\r""##,
            r##"-> "#9,GMBADR\r""##,
            r##"<- "#9,GMBADR:9,9,0x9,0x9""##,
            "resi-16di8ro answers at address 9, 9600 8N1; stored in FLASH",
        ],
    );
    // The whole line's power: the FLASH address stays.
    sim.send("power-cycle");
    let text = discover(&pty, "9600", "3-9");
    holds(
        &text,
        &[
            "found resi-16di8ro at address 9, 9600 8N1",
            "1 module(s) found",
        ],
    );
}

#[test]
fn resi_settings_a_host_cannot_make_are_refused_with_the_manuals_reason() {
    let (mut sim, pty) = sim::Sim::start(BIN, &["resi-16di8ro@3:9600:8N1"]);
    let refused = |address: &str, extra: &[&str], wants: &[&str]| {
        let (out, text) = commission(&pty, address, extra);
        assert!(!out.status.success(), "{text}");
        holds(&text, &["refused"]);
        holds(&text, wants);
        assert!(!text.contains(",SMBADR:"), "nothing is written: {text}");
    };
    refused(
        "3",
        &["--set-baud", "38400", "--yes"],
        &[
            "DIP switches",
            "§1.3",
            "DIP5 (BR0) on, DIP6 (BR1) on, DIP7 (BR2) off",
        ],
    );
    refused("3", &["--set-format", "8E1", "--yes"], &["DIP8", "§1.3"]);
    refused(
        "3",
        &["--set-reply-delay", "20ms", "--yes"],
        &["documents no reply delay", "can set nothing"],
    );
    refused("3", &["--set-address", "0", "--yes"], &["broadcast"]);
    // With the ADR switches at 5 the address is theirs, not the FLASH's.
    sim.send("resi-16di8ro@3 address 5");
    refused(
        "5",
        &["--set-address", "9", "--yes"],
        &["ADR switches", "L19908"],
    );
}

#[test]
fn ex9053_address_only_needs_no_init_and_survives_a_power_cycle() {
    let (mut sim, pty) = sim::Sim::start(BIN, &["ex9053d@2:9600:8N1"]);
    let (out, text) = commission(&pty, "2", &["--set-address", "12", "--yes"]);
    assert!(out.status.success(), "{text}");
    holds(
        &text,
        &[
            r##"-> "$022\r""##,
            r##"-> "%020C400600\r""##,
            r##"<- "!0C""##,
        ],
    );
    assert!(!text.contains("INIT*"), "no INIT* for an address: {text}");
    sim.send("ex9053d@2 power-cycle");
    let text = discover(&pty, "9600", "2,12");
    holds(&text, &["found ex9053d at address 12, 9600 8N1"]);
}

#[test]
fn ex9053_baud_and_checksum_change_through_init_and_two_power_cycles() {
    let (mut sim, pty) = sim::Sim::start(BIN, &["ex9053d@2:9600:8N1"]);
    let mut c = Running::start(&[
        "commission",
        &pty,
        "--address",
        "2",
        "--baud",
        "9600",
        "--format",
        "8N1",
        "--set-address",
        "3",
        "--set-baud",
        "38400",
        "--set-checksum",
        "on",
        "--yes",
        "--wait",
        "60s",
    ]);
    // It says what to wire and waits for the module in INIT* mode.
    c.until("connect its INIT* terminal to GND");
    c.until("waiting up to 60.00s");
    sim.send("ex9053d@2 init on");
    sim.send("ex9053d@2 power-cycle");
    c.until("disconnect INIT* from GND");
    c.until("waiting up to 60.00s");
    sim.send("ex9053d@2 init off");
    sim.send("ex9053d@2 power-cycle");
    let (ok, text) = c.finish();
    assert!(ok, "{text}");
    holds(
        &text,
        &[
            r##"-> "$002\r""##,
            // %AANNTTCCFF at INIT*'s address 00: address 03, 38400 Bd (08), checksum on (40).
            r##"-> "%0003400840\r""##,
            r##"<- "!03""##,
            "now talking at 38400 8N1",
            // $03M with its checksum, answered with one.
            r##"-> "$03MD4\r""##,
            "ex9053d answers at address 03h (3), 38400 8N1, checksum on; stored in EEPROM",
        ],
    );
    // Another power cycle: the EEPROM keeps them; the old settings are gone.
    sim.send("power-cycle");
    let (out, text) = commission_at(
        &pty,
        "3",
        "38400",
        &["--checksum", "--set-address", "4", "--yes"],
    );
    assert!(out.status.success(), "{text}");
    holds(
        &text,
        &["answers at address 04h (4), 38400 8N1, checksum on"],
    );
    let text = discover(&pty, "9600", "2-4");
    holds(&text, &["0 module(s) found"]);
}

#[test]
fn ex9053_waits_for_init_and_gives_up_having_changed_nothing() {
    let (_sim, pty) = sim::Sim::start(BIN, &["ex9053d@2:9600:8N1"]);
    let (out, text) = commission(&pty, "2", &["--set-baud", "19200", "--yes", "--wait", "1s"]);
    assert!(!out.status.success(), "{text}");
    holds(&text, &["INIT* mode", "stopped here"]);
    assert!(!text.contains("-> \"%"), "nothing is written: {text}");
    let (out, text) = commission(&pty, "2", &["--set-format", "8E1", "--yes"]);
    assert!(!out.status.success(), "{text}");
    holds(&text, &["refused", "§1.10"]);
    let (out, text) = commission(&pty, "2", &["--set-baud", "230400", "--yes"]);
    assert!(!out.status.success(), "{text}");
    holds(
        &text,
        &[
            "refused",
            "1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200",
        ],
    );
}

/// The engineer sets INIT* and powers on, but never takes INIT* off again: commission gives up
/// after --wait and says what the module has already taken (the new settings in its EEPROM).
#[test]
fn ex9053_a_half_done_change_says_what_the_module_already_took() {
    let (mut sim, pty) = sim::Sim::start(BIN, &["ex9053d@2:9600:8N1"]);
    let mut c = Running::start(&[
        "commission",
        &pty,
        "--address",
        "2",
        "--baud",
        "9600",
        "--format",
        "8N1",
        "--set-baud",
        "19200",
        "--yes",
        "--wait",
        "2s",
    ]);
    c.until("waiting up to 2.00s");
    sim.send("ex9053d@2 init on");
    sim.send("ex9053d@2 power-cycle");
    let (ok, text) = c.finish();
    assert!(!ok, "{text}");
    holds(
        &text,
        &[
            r##"-> "%0002400700\r""##,
            "the module at its new settings",
            "stopped here",
            "already done: the module in INIT* mode",
            "%AANNTTCCFF: address 02h",
        ],
    );
}
