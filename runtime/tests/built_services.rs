//! A project asking for an optional service (cargo features `opcua`, `mqtt`) runs on a binary
//! built with it and is refused, at the service's key, by one built without it. The test runs
//! in either build: CI builds and tests both (`.ci/run`).

use std::process::Command;

use crate::common::host::repo;
use crate::common::scratch::Scratch;

#[test]
fn check_accepts_or_refuses_a_service_as_the_binary_was_built() {
    let scratch = Scratch::new("built_services", "check");
    let quickstart = repo().join("examples/quickstart");
    let base = std::fs::read_to_string(quickstart.join("project.yaml")).expect("quick start");
    let lines = base.lines().count();
    let text = format!(
        "{}  opcua:\n    port: 0\n  mqtt:\n    host: 127.0.0.1\n    group: g\n    node: n\n",
        crate::common::host::quickstart_plant_absolute(&base).replace(
            "../../programs/conveyor.expr",
            &repo().join("programs/conveyor.expr").display().to_string()
        )
    );
    let file = scratch.write("project.yaml", &text);
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .arg("check")
        .arg(&file)
        .env("SOFTPLC_LOG", "warn")
        .output()
        .expect("softplc runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let mut refused = Vec::new();
    for (key, built, line) in [
        ("opcua", cfg!(feature = "opcua"), lines + 1),
        ("mqtt", cfg!(feature = "mqtt"), lines + 3),
    ] {
        let error = format!(
            "{}:{line}:3: error: service.{key} asks for ",
            file.display()
        );
        assert_eq!(stderr.contains(&error), !built, "{key}: {stderr}");
        if !built {
            refused.push(key);
        }
    }
    assert_eq!(
        out.status.success(),
        refused.is_empty(),
        "{stdout}\n{stderr}"
    );
    if cfg!(feature = "opcua") && refused.is_empty() {
        assert!(stdout.contains("OPC UA server at"), "{stdout}");
    }
}
