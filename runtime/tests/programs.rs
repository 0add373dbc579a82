//! Every scenario under `programs/` passes in every program it names (ladder and Rhai), with
//! the same trace; a failing scenario exits non-zero and shows what differs.

use crate::common::host;

use host::{repo, softplc};

#[test]
fn every_program_scenario_passes_in_both_engines() {
    let (ok, text) = softplc(&["test", "programs"]);
    assert!(ok, "{text}");
    for program in [
        "stairway",
        "conveyor",
        "pump_station",
        "traffic_light",
        "warning_lamp",
    ] {
        for ext in ["ladder.yaml", "rhai"] {
            assert!(
                text.contains(&format!("[{program}.{ext}]")),
                "{program}.{ext} ran:\n{text}"
            );
        }
    }
    assert!(!text.contains("FAIL"), "{text}");
    assert!(text.matches("give the same trace").count() >= 5, "{text}");
}

#[test]
fn every_example_project_checks_and_finds_its_scenarios() {
    for example in [
        "stairway",
        "conveyor",
        "pump_station",
        "traffic_light",
        "energy-meter",
        "warning_lamp",
    ] {
        let project = format!("examples/{example}/project.yaml");
        let (ok, text) = softplc(&["check", &project]);
        assert!(ok, "{project}: {text}");
        let (ok, text) = softplc(&["test", &project]);
        assert!(
            ok && text.contains(" passed, 0 failed"),
            "{project}: {text}"
        );
    }
}

#[test]
fn a_failing_scenario_exits_non_zero_with_a_readable_diff() {
    let dir = std::env::temp_dir().join(format!("softplc-programs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let project = repo().join("examples/stairway/project.yaml");
    let other = repo().join("programs/stairway/stairway.rhai");
    // A Rhai variant whose light stays on 31 s instead of 30: the traces differ.
    let variant = dir.join("slow.rhai");
    let text = std::fs::read_to_string(&other)
        .unwrap()
        .replace("\"30s\"", "\"31s\"");
    std::fs::write(&variant, text).unwrap();
    let scenario = dir.join("wrong.scenario.yaml");
    std::fs::write(
        &scenario,
        format!(
            "project: {}\nprograms: [{}, slow.rhai]\nsteps:\n  - {{ at: 1s, set: {{ button_top: 1 }} }}\n  - {{ at: 2s, set: {{ button_top: 0 }} }}\n  - {{ at: 31.5s, expect: {{ light: 0 }} }}\n",
            project.display(),
            repo().join("programs/stairway/stairway.ladder.yaml").display()
        ),
    )
    .unwrap();
    let (ok, text) = softplc(&["test", scenario.to_str().unwrap()]);
    assert!(!ok, "{text}");
    assert!(text.contains("[stairway.ladder.yaml]"), "{text}");
    assert!(text.contains("light expected 0, got 1"), "{text}");
    assert!(
        text.contains("traces differ between stairway.ladder.yaml (-) and slow.rhai (+)"),
        "{text}"
    );
    assert!(text.contains("-     31.000s  light = 0"), "{text}");
    assert!(text.contains("+     32.000s  light = 0"), "{text}");
    assert!(text.contains("1 passed, 2 failed"), "{text}");

    std::fs::write(&scenario, "project: nowhere.yaml\nsteps: []\n").unwrap();
    let (ok, text) = softplc(&["test", scenario.to_str().unwrap()]);
    assert!(
        !ok && text.contains("wrong.scenario.yaml:1:10: error: the project has errors"),
        "{text}"
    );
    std::fs::write(
        &scenario,
        format!("project: {}\nsteps:\n  - {{ at: 1s, set: {{ lihgt: 1 }} }}\n  - {{ at: 1s, set: {{ light: 1 }} }}\n", project.display()),
    )
    .unwrap();
    let (ok, text) = softplc(&["test", scenario.to_str().unwrap()]);
    assert!(!ok, "{text}");
    assert!(
        text.contains(
            "wrong.scenario.yaml:3:22: error: unknown tag `lihgt`; did you mean `light`?"
        ),
        "{text}"
    );
    assert!(
        text.contains("wrong.scenario.yaml:4:22: error: tag `light` is not an input"),
        "{text}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
