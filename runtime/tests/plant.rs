//! Plant models written in the project: the examples close the loop in their scenarios on the
//! virtual clock (the same trace twice, in one process and in two), `check` places a model's
//! errors at its file:line:col, a scenario names only the states and faults the model has, and
//! a model that fails while it runs stops with its place while the PLC runs on.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::clock::VirtualClock;
use softplc::plc::Plc;
use softplc::scan::{ScanEngine, StopReason};
use softplc::service::PlantReport;

use crate::common::host::{repo, softplc};
use crate::common::scratch::Scratch;

#[test]
fn the_examples_close_the_loop_and_a_second_run_gives_the_same_trace() {
    for (example, plant_scenarios) in [("garage_door", 2), ("pump_station", 4), ("conveyor", 2)] {
        let project = format!("examples/{example}/project.yaml");
        let (ok, text) = softplc(&["test", &project]);
        assert!(ok, "{project}:\n{text}");
        assert!(!text.contains("FAIL"), "{text}");
        // One line per program run with the plant kept.
        assert_eq!(
            text.matches("two runs give the same trace").count(),
            plant_scenarios,
            "{project}:\n{text}"
        );
    }
}

#[test]
fn a_closed_loop_scenario_gives_the_same_trace_in_another_process() {
    let scenario = "examples/garage_door/open_close.scenario.yaml";
    let (ok, first) = softplc(&["test", "--verbose", scenario]);
    assert!(ok, "{first}");
    // The door's position moves every scan while the motor runs: a long trace to compare.
    assert!(first.matches("plant.position = ").count() > 200, "{first}");
    let (ok, second) = softplc(&["test", "--verbose", scenario]);
    assert!(ok, "{second}");
    assert_eq!(first, second);
}

/// A project on one simulated MiniMod whose plant is `model` (the model file's text).
fn project_with(scratch: &Scratch, model: &str, wiring: &str) -> std::path::PathBuf {
    scratch.write("follow.expr", "y = x\n");
    scratch.write("lamp.plant.rhai", model);
    scratch.write(
        "project.yaml",
        &format!(
            "project: plant-errors
scan: {{ period: 100ms }}
buses:
  - {{ name: line1, port: sim }}
modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
tags:
  - {{ name: x, point: mm1.X1 }}
  - {{ name: y, point: mm1.Y1, safe: false }}
  - {{ name: s, point: mm1.X2 }}
program: {{ file: follow.expr, kind: expr }}
plant:
  file: lamp.plant.rhai
  wiring:
{wiring}"
        ),
    )
}

const LAMP: &str = "\
// A lamp and the light sensor that sees it, 200 ms late.
fn plant() {
    #{
        reads: [\"lamp\"],
        drives: [\"seen\"],
        states: #{ glow: #{ initial: 0.0, min: 0.0, max: 1.0 } },
    }
}
glow = lag(glow, if lamp { 1.0 } else { 0.0 }, 0.2);
seen = glow > 0.5;
";

#[test]
fn check_places_a_model_error_at_its_file_line_and_column() {
    let scratch = Scratch::new("plant", "model-error");
    let wiring = "    lamp: mm1.Y1\n    seen: mm1.X1\n";
    let project = project_with(&scratch, &LAMP.replace("seen = glow", "seen = glw"), wiring);
    let (ok, text) = softplc(&["check", project.to_str().unwrap()]);
    assert!(!ok, "{text}");
    let model = scratch.dir.join("lamp.plant.rhai");
    assert!(
        text.contains(&format!(
            "{}:10:8: error: unknown name `glw`: not a terminal, state or variable of the model; \
             did you mean `glow`?",
            model.display()
        )),
        "{text}"
    );
    // A limit its initial value violates.
    let project = project_with(
        &scratch,
        &LAMP.replace("initial: 0.0", "initial: 2.0"),
        wiring,
    );
    let (ok, text) = softplc(&["check", project.to_str().unwrap()]);
    assert!(!ok, "{text}");
    assert!(
        text.contains(&format!(
            "{}:6:20: error: state glow: the initial value 2 is outside its limits 0..1",
            model.display()
        )),
        "{text}"
    );
}

#[test]
fn check_holds_the_wiring_to_the_model_s_terminals() {
    let scratch = Scratch::new("plant", "wiring");
    let project = project_with(&scratch, LAMP, "    lamp: mm1.X2\n    seenn: mm1.X1\n");
    let (ok, text) = softplc(&["check", project.to_str().unwrap()]);
    assert!(!ok, "{text}");
    let file = project.display();
    for want in [
        format!("{file}:16:5: error: plant lamp has no terminal \"seenn\" (its terminals: lamp, seen)"),
        format!("{file}:14:3: error: plant lamp needs terminal seen wired (to a module input)"),
        format!("{file}:15:11: error: plant terminal lamp reads a module output, but mm1.X2 is an input"),
    ] {
        assert!(text.contains(&want), "{want}\nnot in:\n{text}");
    }
    // Wired right, `check` shows the plant, its terminals and states.
    let project = project_with(&scratch, LAMP, "    lamp: mm1.Y1\n    seen: mm1.X1\n");
    let (ok, text) = softplc(&["check", project.to_str().unwrap()]);
    assert!(ok, "{text}");
    assert!(text.contains("a step every 10.00ms, random seed 0\n  reads  lamp ← mm1.Y1\n  drives seen → mm1.X1\n  state  glow = 0 (0..1)\n"), "{text}");
}

#[test]
fn a_scenario_names_only_the_states_and_faults_its_plant_has() {
    let scratch = Scratch::new("plant", "scenario-names");
    project_with(&scratch, LAMP, "    lamp: mm1.Y1\n    seen: mm1.X1\n");
    let scenario = scratch.write(
        "bad.scenario.yaml",
        "project: project.yaml
plant: true
steps:
  - { at: 1s, expect: { plant.glw: \">= 0.5\" } }
  - { at: 1s, fault: { burnt: on } }
  - { at: 2s, expect: { plant.glow: \"about 1\" } }
",
    );
    let (ok, text) = softplc(&["test", scenario.to_str().unwrap()]);
    assert!(!ok, "{text}");
    let file = scenario.display();
    for want in [
        format!("{file}:4:25: error: plant lamp has no state `glw` (its states: glow); did you mean `glow`?"),
        format!("{file}:5:24: error: plant lamp has no fault `burnt` (its faults: none)"),
        format!("{file}:6:37: error: `about 1` is not a value or a comparison (>= 99, < 0.5, == 3, != 0, true)"),
    ] {
        assert!(text.contains(&want), "{want}\nnot in:\n{text}");
    }
    let scenario = scratch.write(
        "removed.scenario.yaml",
        "project: project.yaml\nsteps:\n  - { at: 1s, expect: { plant.glow: 1 } }\n",
    );
    let (ok, text) = softplc(&["test", scenario.to_str().unwrap()]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("error: the plant is removed unless the scenario says `plant: true`"),
        "{text}"
    );
}

#[test]
fn a_lagging_sensor_answers_the_lamp_in_a_scenario() {
    let scratch = Scratch::new("plant", "lamp-scenario");
    project_with(&scratch, LAMP, "    lamp: mm1.Y1\n    seen: mm1.X2\n");
    let scenario = scratch.write(
        "lamp.scenario.yaml",
        "project: project.yaml
plant: true
steps:
  - { at: 1s,   set: { x: 1 } }
  - { at: 1.1s, expect: { y: 1, s: 0, plant.glow: \"< 0.5\" } }
  - { at: 1.5s, expect: { s: 1, plant.glow: \">= 0.5\" } }
  - { at: 3s,   expect: { plant.glow: \"> 0.99\" } }
  - { at: 3s,   set: { x: 0 } }
  - { at: 3.5s, expect: { y: 0, s: 0, plant.glow: \"< 0.5\" } }
",
    );
    let (ok, text) = softplc(&["test", scenario.to_str().unwrap()]);
    assert!(ok, "{text}");
}

/// A model that divides by zero on its 20th step (200 ms in).
const FAILING: &str = "\
fn plant() { #{ reads: [\"lamp\"], drives: [\"seen\"], states: #{ n: 0 } } }
n += 1;
seen = n > 5;
if n == 20 {
    let broken = 1 / 0;
}
";

#[test]
fn a_model_that_fails_stops_with_its_place_and_the_plc_runs_on() {
    let scratch = Scratch::new("plant", "runtime-error");
    let path = project_with(&scratch, FAILING, "    lamp: mm1.Y1\n    seen: mm1.X2\n");
    let project = softplc::project::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let plc = Plc::build(project, Arc::new(VirtualClock::new())).expect("builds");
    let reports: Arc<Mutex<Vec<(Duration, PlantReport, bool)>>> = Arc::default();
    let sink = reports.clone();
    let begin = plc.clock().now();
    let mut engine = ScanEngine::new(plc)
        .run_for(Duration::from_secs(2))
        .on_cycle(Box::new(move |plc, ctx| {
            let report = PlantReport::of(plc).expect("a plant");
            let x = plc.image().get(softplc::image::TagId(2)).as_bool();
            sink.lock().unwrap().push((ctx.now - begin, report, x));
        }));
    assert_eq!(
        engine.run().reason,
        StopReason::TimeUp,
        "the PLC ran its time"
    );
    let reports = reports.lock().unwrap();
    assert_eq!(reports.len(), 20, "a scan every 100 ms for 2 s");
    let file = scratch.dir.join("lamp.plant.rhai");
    let (_, first, _) = &reports[0];
    assert_eq!(first.state, "running");
    let (_, last, seen) = reports.last().unwrap();
    assert_eq!(last.state, "stopped");
    assert_eq!(
        last.error.as_deref(),
        Some(format!("{}:5:20: Division by zero: 1 / 0", file.display()).as_str())
    );
    assert_eq!(
        last.states,
        [("n".to_owned(), "19".to_owned())],
        "the failed step's change is dropped"
    );
    assert!(*seen, "the terminal the model drove holds its last value");
    assert_eq!(
        last.to_string(),
        format!(
            "plant lamp: stopped: {}:5:20: Division by zero: 1 / 0 (its terminals hold their last values); n 19",
            file.display()
        )
    );
}

#[test]
fn the_quick_start_plant_is_the_built_in_conveyor() {
    let file = repo().join("examples/quickstart/conveyor.plant.rhai");
    let text = std::fs::read_to_string(&file).expect("the quick start's plant file");
    assert_eq!(
        text,
        softplc::plant::CATALOG[0].source,
        "examples/quickstart/conveyor.plant.rhai and the built-in conveyor must be the same text"
    );
}

#[test]
fn a_missing_model_file_is_named_at_the_project_s_plant_file_key() {
    let scratch = Scratch::new("plant", "missing-file");
    let project = project_with(&scratch, LAMP, "    lamp: mm1.Y1\n    seen: mm1.X2\n");
    std::fs::remove_file(scratch.dir.join("lamp.plant.rhai")).expect("remove the model");
    let (ok, text) = softplc(&["check", project.to_str().unwrap()]);
    assert!(!ok, "{text}");
    let want = format!(
        "{}:13:9: error: cannot read the plant model file lamp.plant.rhai: No such file or \
         directory (os error 2)",
        project.display()
    );
    assert!(text.contains(&want), "{want}\nnot in:\n{text}");
    // Both a built-in and a file: one of the two.
    let text = std::fs::read_to_string(&project).unwrap().replace(
        "  file: lamp.plant.rhai\n",
        "  model: conveyor\n  file: lamp.plant.rhai\n",
    );
    std::fs::write(&project, text).unwrap();
    let (ok, text) = softplc(&["check", project.to_str().unwrap()]);
    assert!(!ok, "{text}");
    assert!(text.contains(":13:3: error: a plant names a built-in model (model: conveyor) or a model file (file: door.plant.rhai), one of the two"), "{text}");
}

#[test]
fn softplc_sim_serves_a_project_s_plant_on_a_pty_and_a_master_sees_it_answer() {
    crate::cli::require_mbpoll();
    let scratch = Scratch::new("plant", "sim-pty");
    scratch.write("follow.expr", "y = x\n");
    scratch.write("lamp.plant.rhai", LAMP);
    let project = scratch.write(
        "project.yaml",
        "project: served-plant
scan: { period: 100ms }
buses:
  - { name: line1, port: sim, baud: 19200, format: 8E1 }
modules:
  - { name: mm1, bus: line1, model: minimod, address: 5 }
tags:
  - { name: x, point: mm1.X1 }
  - { name: y, point: mm1.Y1, safe: false }
program: { file: follow.expr, kind: expr }
plant:
  file: lamp.plant.rhai
  wiring: { lamp: mm1.Y1, seen: mm1.X2 }
",
    );
    let mut sim =
        crate::cli::Sim::start_with(&["sim", "--pty", "--project", project.to_str().unwrap()]);
    // Discrete input 10002 is X2, which the plant drives: dark while the lamp is off.
    assert_eq!(
        sim.mbpoll(&["-t", "1", "-r", "2"], &[]),
        [(2, "0".to_owned())]
    );
    // The master lights the lamp (coil 00001, Y1); the sensor follows 200 ms later.
    assert!(sim.mbpoll(&["-t", "0", "-r", "1"], &["1"]).is_empty());
    std::thread::sleep(Duration::from_millis(600));
    assert_eq!(
        sim.mbpoll(&["-t", "1", "-r", "2"], &[]),
        [(2, "1".to_owned())]
    );
    // The console names the modules as the project does.
    assert_eq!(sim.command("get mm1.X2"), "mm1.X2=1");
    assert!(sim.mbpoll(&["-t", "0", "-r", "1"], &["0"]).is_empty());
    std::thread::sleep(Duration::from_millis(600));
    assert_eq!(sim.command("get mm1.X2"), "mm1.X2=0");
    assert!(sim.command("plant").starts_with("running: glow="));
    assert_eq!(
        sim.command("plant fault burnt on"),
        "error: plant lamp has no fault \"burnt\" (its faults: none)"
    );
}

/// One GET of `path` on `port`: the body.
fn get(port: u16, path: &str) -> String {
    use std::io::{Read, Write};
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).expect("connect to the page");
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut text = String::new();
    s.read_to_string(&mut text).expect("an answer");
    text.split_once("\r\n\r\n")
        .map(|(_, b)| b.to_owned())
        .unwrap_or_default()
}

#[test]
fn the_web_page_shows_the_plant_s_states_live() {
    use std::io::BufRead;
    let scratch = Scratch::new("plant", "web");
    let example = repo().join("examples/pump_station");
    std::fs::copy(
        example.join("sump.plant.rhai"),
        scratch.dir.join("sump.plant.rhai"),
    )
    .unwrap();
    let program = repo().join("programs/pump_station/pump_station.ladder.yaml");
    let text = std::fs::read_to_string(example.join("project.yaml"))
        .unwrap()
        .replace(
            "../../programs/pump_station/pump_station.ladder.yaml",
            program.to_str().unwrap(),
        )
        + "\nservice:\n  web: { bind: 127.0.0.1:0 }\n";
    let project = scratch.write("project.yaml", &text);
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args([
            "run",
            project.to_str().unwrap(),
            "--for",
            "60s",
            "--no-socket",
        ])
        .env("SOFTPLC_LOG", "info")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("softplc run starts");
    let stderr = child.stderr.take().expect("piped stderr");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr)
            .lines()
            .map_while(Result::ok)
        {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let port: u16 = loop {
        let line = rx
            .recv_timeout(Duration::from_secs(30))
            .expect("the run logs its page");
        if let Some(rest) = line.split("web page: http://127.0.0.1:").nth(1) {
            break rest.split('/').next().unwrap().parse().unwrap();
        }
    };
    // The page's state, once the first cycle is published (bounded: 50 looks).
    let state = || {
        for _ in 0..50 {
            let j: serde_json::Value = serde_json::from_str(&get(port, "/api/state")).unwrap();
            if j["state"]["published"] == true {
                return j["state"].clone();
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        panic!("nothing published in 5 s");
    };
    let level = |state: &serde_json::Value| -> f64 {
        let plant = &state["plant"];
        assert_eq!(plant["model"], "sump", "{state}");
        assert_eq!(plant["state"], "running", "{state}");
        let states = plant["states"].as_array().expect("states");
        let level = states
            .iter()
            .find(|s| s[0] == "level")
            .expect("the level state");
        level[1].as_str().unwrap().parse().unwrap()
    };
    // The page's state carries the plant; the pit's level moves between two looks (the rain
    // runs in at about 1.5 %/s): the panel is live. Bounded: 30 looks, 200 ms apart.
    let first = level(&state());
    let mut moved = false;
    for _ in 0..30 {
        std::thread::sleep(Duration::from_millis(200));
        let now = level(&state());
        if now != first {
            moved = true;
            break;
        }
    }
    // The page draws it: the panel and its renderer are served.
    let page = get(port, "/");
    let script = get(port, "/app.js");
    drop(child.kill());
    drop(child.wait());
    assert!(moved, "the level stayed at {first}");
    assert!(page.contains("id=\"plant-panel\""), "{page}");
    assert!(
        script.contains("function renderPlant"),
        "app.js draws the plant panel"
    );
}

#[test]
fn the_guide_shows_the_garage_door_s_model_as_it_is() {
    let guide = std::fs::read_to_string(repo().join("docs/plant.md")).expect("docs/plant.md");
    let model = std::fs::read_to_string(repo().join("examples/garage_door/door.plant.rhai"))
        .expect("the door's model");
    assert!(
        guide.contains(&format!("```rhai\n{model}```")),
        "docs/plant.md shows examples/garage_door/door.plant.rhai other than it is"
    );
    // A few dozen lines, as the guide promises.
    assert!(
        model.lines().count() <= 40,
        "{} lines",
        model.lines().count()
    );
}
