//! `softplc commission` on a pty served by `softplc sim --pty`: a MiniMod's address, baud and
//! reply delay are changed and saved with WCONF, survive a simulated power cycle, and a change
//! the manual forbids is refused with its reason, before anything is written.

#[path = "common/sim.rs"]
#[allow(dead_code)]
mod sim;

use std::process::{Command, Output};

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
