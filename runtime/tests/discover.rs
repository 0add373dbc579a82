//! `softplc discover` on a pty served by `softplc sim --pty`: modules of the three families at
//! their own bauds on one line are found, identified by their own means, and the project
//! skeleton it writes passes `softplc check`.

use crate::common::sim;

use std::process::Command;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

#[test]
fn finds_every_family_at_mixed_settings_and_its_skeleton_checks() {
    let (_sim, pty) = sim::Sim::start(
        BIN,
        &[
            "minimod@5:19200:8E1",
            "resi-16di8ro@3:9600:8N1",
            "ex9053d@2:9600:8N1",
            // At a baud the probe plan does not try: never heard.
            "minimod@4:57600:8E1",
        ],
    );
    let dir = std::env::temp_dir().join(format!("softplc-discover-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    let project = dir.join("project.yaml");
    let started = Instant::now();
    let out = Command::new(BIN)
        .args([
            "discover",
            &pty,
            "--bauds",
            "9600,19200",
            "--formats",
            "8N1,8E1",
        ])
        .args(["--addresses", "1-6", "--timeout", "40ms", "--out"])
        .arg(&project)
        .output()
        .unwrap();
    let elapsed = started.elapsed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // It says up front how long it takes at most, and keeps to it.
    let first = text.lines().next().unwrap();
    assert!(first.contains("at most"), "{first}");
    assert!(elapsed < Duration::from_secs(10), "{elapsed:?}");
    for want in [
        "found minimod at address 5, 19200",
        "found resi-16di8ro at address 3, 9600",
        "found ex9053d at address 2, 9600 8N1",
    ] {
        assert!(text.contains(want), "no {want:?} in\n{text}");
    }
    assert!(!text.contains("address 4,"), "{text}");
    assert!(text.contains("3 module(s) found"), "{text}");
    // One line has one baud and format: the skeleton's bus is at the settings most modules
    // have, and the odd module gets the command that moves it there, in the report and in
    // the skeleton. (A pty carries no parity: the MiniMod answers the first format asked.)
    let commission = format!(
        "softplc commission {pty} --address 5 --baud 19200 --format 8N1 --set-baud 9600 \
         --set-format 8N1"
    );
    assert!(
        text.contains(
            "1 module(s) answer at other settings than the line's 9600 8N1: one line has one \
             baud and format"
        ),
        "{text}"
    );
    assert!(
        text.contains(&format!("  minimod at address 5 (19200 8N1): {commission}")),
        "{text}"
    );
    let yaml = std::fs::read_to_string(&project).unwrap();
    assert!(yaml.contains("model: ex9053d, address: 2"), "{yaml}");
    assert!(yaml.contains("model: resi-16di8ro, address: 3"), "{yaml}");
    assert!(!yaml.contains("model: minimod, address: 5"), "{yaml}");
    assert!(
        yaml.contains(&format!("# {commission}")) || yaml.contains(&commission),
        "{yaml}"
    );
    assert_eq!(yaml.matches(&format!("port: {pty}")).count(), 1, "{yaml}");
    let check = Command::new(BIN)
        .arg("check")
        .arg(&project)
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "{yaml}\n{}",
        String::from_utf8_lossy(&check.stderr)
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn bad_arguments_are_refused_naming_the_place() {
    let out = Command::new(BIN)
        .args(["discover", "/dev/null", "--addresses", "9-2"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--addresses") && err.contains("backwards"),
        "{err}"
    );
}

/// A MiniMod installed at 9600 8N1 (its SERLINE, `minimod@5:9600:8N1`) shares the pty with
/// one at the factory 19200 8E1: each is found at its own baud, and only there.
#[test]
fn finds_a_minimod_at_its_own_serline_next_to_one_at_the_factory_settings() {
    let (_sim, pty) = sim::Sim::start(BIN, &["minimod@5:9600:8N1", "minimod@6"]);
    let out = Command::new(BIN)
        .args(["discover", &pty, "--bauds", "9600,19200"])
        .args(["--formats", "8N1,8E1", "--addresses", "4-7"])
        .args(["--timeout", "40ms"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for want in [
        "found minimod at address 5, 9600",
        "found minimod at address 6, 19200",
    ] {
        assert!(text.contains(want), "no {want:?} in\n{text}");
    }
    assert!(!text.contains("address 5, 19200"), "{text}");
    assert!(!text.contains("address 6, 9600"), "{text}");
    assert!(text.contains("2 module(s) found"), "{text}");
}
