//! Device profiles from the user's side: bad profiles get every error at its file:line:col
//! with the exact message; a project names a profile as a module's model and `check` prints
//! its I/O map; and a drive described by a profile, served by `softplc sim --profile` on a pty
//! next to a MiniMod, is driven by `softplc run`: its output frequency follows the setpoint
//! the program writes, and the MiniMod's lamp lights once the drive is up to speed.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use softplc::project::profile::parse_str;

use crate::common::sim;

use crate::common::host::repo;
use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

/// Every error of profile `text`, one line each, as `check` prints them.
fn errors(text: &str) -> Vec<String> {
    match parse_str(text, Path::new("meter.yaml")) {
        Ok(p) => panic!("expected errors, got {p:#?}"),
        Err(e) => e.iter().map(ToString::to_string).collect(),
    }
}

#[test]
fn bad_points_get_their_place_and_reason() {
    let text = "\
model: meter
source: test
points:
  - { name: v, table: holdng, address: 0 }
  - { name: a, table: input, address: 70000, type: f32 }
  - { name: b, table: coil, address: 1, type: u16 }
  - { name: c, table: input, address: 2, access: write }
  - { name: d, table: holding, address: 3, order: CDAB, scale: 0 }
  - { name: v, table: holding, address: 4, poll: slow }
  - { name: e, table: holding, address: 65535, type: u32 }
  - { name: 2x, table: holding, address: 5, type: float }
";
    assert_eq!(
        errors(text),
        [
            "meter.yaml:4:23: error: unknown table \"holdng\" (known: coil, discrete, input, holding)",
            "meter.yaml:5:39: error: address takes 0..=65535, not 70000",
            "meter.yaml:6:47: error: coil points are bool; u16 does not fit",
            "meter.yaml:7:50: error: input points can only be read (access: read)",
            "meter.yaml:8:51: error: order does not apply to a 16-bit or bit point",
            "meter.yaml:8:64: error: scale must not be 0",
            "meter.yaml:9:13: error: point v is already defined at line 4",
            "meter.yaml:9:50: error: no poll group \"slow\" in this profile (known: cycle)",
            "meter.yaml:10:41: error: a u32 at address 65535 runs past address 65535",
            "meter.yaml:11:13: error: point name \"2x\" is not an identifier (letters, digits and _, not first a digit)",
            "meter.yaml:11:51: error: unknown type \"float\" (known: bool, u16, i16, u32, i32, f32)",
        ]
    );
}

#[test]
fn bad_groups_bits_and_behaviours() {
    let text = "\
model: drive
source: test
requests: { max_registers: 200 }
poll:
  - { name: fast, period: cycle }
  - { name: fast, period: 10 }
points:
  - name: status
    table: holding
    address: 5
    bits:
      - { name: hi, bit: 15, width: 2 }
  - { name: run, table: coil, address: 0, write: cyclic }
simulate:
  - { point: status, follows: nothing, time_constant: 1s }
  - { point: run, follows: status, time_constant: 1s }
";
    assert_eq!(
        errors(text),
        [
            "meter.yaml:3:28: error: max_registers takes 1..=125, not 200",
            "meter.yaml:6:13: error: poll group fast is already defined at line 5",
            "meter.yaml:6:27: error: period \"10\": no unit (ns, us, ms, s, m or h); expected cycle or a duration like 10s",
            "meter.yaml:12:26: error: bits 15..=16 do not fit a 16-bit register",
            "meter.yaml:13:50: error: write does not apply to a point the program does not write (access: read)",
            "meter.yaml:15:31: error: no point \"nothing\" in this profile (known: status, run)",
            "meter.yaml:16:14: error: a lag moves registers, not bits",
        ]
    );
}

#[test]
fn a_range_must_run_from_low_to_high() {
    assert_eq!(
        errors(
            "model: m\nsource: s\npoints:\n  - { name: v, table: input, address: 0, unit: V, \
             range: [300, 100] }\n"
        ),
        ["meter.yaml:4:58: error: range must be two finite numbers, low below high: [low, high]"]
    );
}

#[test]
fn yaml_errors_and_unknown_keys_are_placed_too() {
    assert_eq!(
        errors("model: m\nsource: s\npoints:\n  - { name: v, table: input, adress: 0 }\n"),
        [
            "meter.yaml:4:30: error: unknown key `adress` in points[0]; expected one of `name`, `table`, `address`, `type`, `order`, `scale`, `offset`, `unit`, `range`, `access`, `manual`, `poll`, `write`, `initial`, `bits`; did you mean `address`?",
            "meter.yaml:4:5: error: missing key `address` in points[0]",
        ]
    );
    assert_eq!(
        errors("model: m\nsource: s\npoints:\n  - { name: v, table: input, address: zero }\n"),
        ["meter.yaml:4:39: error: points[0].address: invalid type: string \"zero\", expected a whole number"]
    );
    assert_eq!(
        errors("model: m\npoints: []\n"),
        ["meter.yaml:1:1: error: missing key `source` at the top level"]
    );
}

/// A scratch folder of this test's own.
fn scratch(name: &str) -> PathBuf {
    crate::common::host::scratch_dir("profiles", name)
}

#[test]
fn a_project_names_its_profile_and_check_prints_its_map() {
    let dir = scratch("check");
    std::fs::write(dir.join("p.expr"), "lamp = on\n").unwrap();
    let project = |model: &str| {
        format!(
            "project: p\nscan: {{ period: 500ms }}\n\
             buses:\n  - {{ name: line1, port: sim, baud: 9600, format: 8N1 }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n  - {{ name: meter, bus: line1, model: \"{model}\", address: 3 }}\n\
             tags:\n  - {{ name: on, type: bool }}\n  - {{ name: lamp, point: mm1.Y1 }}\n  - {{ name: power, point: meter.active_power }}\n\
             program: {{ file: p.expr, kind: expr }}\n"
        )
    };
    let sdm120 = repo().join("examples/profiles/sdm120.yaml");
    std::fs::write(
        dir.join("good.yaml"),
        project(&format!("profile:{}", sdm120.display())),
    )
    .unwrap();
    let out = Command::new(BIN)
        .arg("check")
        .arg(dir.join("good.yaml"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for line in [
        "  module meter = sdm120 @3 (modbus)",
        "      active_power   input 12 f32 ABCD W, read, live every cycle — 30013 Active power → tag power",
        "      import_energy  input 72 f32 ABCD kWh, read, energy every 10s — 30073 Import active energy",
        "    in  active_power f32  → tag #2 power",
    ] {
        assert!(text.lines().any(|l| l == line), "{line:?} in\n{text}");
    }
    assert!(
        text.lines().any(|l| l.starts_with("    meter: read ") && l.ends_with("of the line's cycle floor)")),
        "{text}"
    );

    // A missing profile, and one with an error: each at its place, the profile's in its file.
    std::fs::write(dir.join("missing.yaml"), project("profile:nowhere.yaml")).unwrap();
    let out = Command::new(BIN)
        .arg("check")
        .arg(dir.join("missing.yaml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains(
            "missing.yaml:7:39: error: cannot read profile nowhere.yaml: No such file or directory (os error 2)"
        ),
        "{err}"
    );
    std::fs::write(
        dir.join("bad-profile.yaml"),
        "model: m\nsource: s\npoints:\n  - { name: active_power, table: input, address: 0, type: f64 }\n",
    )
    .unwrap();
    std::fs::write(dir.join("bad.yaml"), project("profile:bad-profile.yaml")).unwrap();
    let out = Command::new(BIN)
        .arg("check")
        .arg(dir.join("bad.yaml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad-profile.yaml:4:59: error: unknown type \"f64\" (known: bool, u16, i16, u32, i32, f32)"),
        "{err}"
    );
    assert!(
        err.contains("bad.yaml:7:39: error: profile bad-profile.yaml has 1 error(s)"),
        "{err}"
    );
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn a_profiled_drive_and_a_minimod_on_one_pty_line() {
    let vfd = repo().join("examples/profiles/delta-vfd-el.yaml");
    let vfd = vfd.to_str().unwrap();
    let (mut sim, pty) = Sim::start(
        BIN,
        &["--baud", "19200", "--profile", vfd, "vfd-el@2", "minimod@1"],
    );
    let dir = scratch("pty");
    std::fs::write(
        dir.join("drive.rhai"),
        "setpoint = if start { 40.0 } else { 0.0 };\n\
         command = if start { 0x12 } else { 0x01 };\n\
         at_speed = speed > 35.0;\n",
    )
    .unwrap();
    let project = format!(
        "project: drive\nscan: {{ period: 100ms }}\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 100ms }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n  - {{ name: vfd, bus: line1, model: \"profile:{vfd}\", address: 2 }}\n\
         tags:\n  - {{ name: start, point: mm1.X1 }}\n  - {{ name: at_speed, point: mm1.Y1, safe: false }}\n  - {{ name: setpoint, point: vfd.frequency_command, safe: 0.0 }}\n  - {{ name: command, point: vfd.command, safe: 1 }}\n  - {{ name: speed, point: vfd.output_frequency }}\n\
         program: {{ file: drive.rhai, kind: rhai }}\n"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
    let plc = Command::new(BIN)
        .args(["run", "--quiet", "--no-socket", "--for", "8s"])
        .arg(&path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    sim.send("set minimod@1.X1 1");
    assert!(
        sim.wait_for("vfd-el@2.command", "18", Duration::from_secs(5))
            .is_some(),
        "the PLC writes the run command 0x12"
    );
    assert!(
        sim.wait_for("vfd-el@2.frequency_command", "40", Duration::from_secs(2))
            .is_some(),
        "and the setpoint, 40 Hz, in the same write phase"
    );
    // 35 of 40 Hz with a 1.5 s lag: about 3.1 s after the setpoint.
    let up = sim.wait_for("minimod@1.Y1", "1", Duration::from_secs(6));
    assert!(
        up.is_some(),
        "the lamp lights once the drive is up to speed"
    );
    let out = plc.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Stopped: the safe state writes the stop command and 0 Hz.
    assert_eq!(sim.get("vfd-el@2.command"), "vfd-el@2.command=1");
    assert_eq!(
        sim.get("vfd-el@2.frequency_command"),
        "vfd-el@2.frequency_command=0"
    );
    drop(std::fs::remove_dir_all(&dir));
}
