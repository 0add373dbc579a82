//! Fuzzing everything a person or a program hands to softplc as text: project files, programs
//! in the three languages (compiled and, when they compile, scanned), scenario files, control
//! requests and HTTP request heads. Inputs are the repository's own files, mutated, so the
//! cases reach past the first token. No input may panic.
//!
//! Bounded in the test suite; a long run: `PROPTEST_CASES=100000 cargo test --release -p
//! softplc-tests --test system fuzz_text::`. Failing cases land in `proptest-regressions/`: commit them.

use std::path::{Path, PathBuf};
use std::time::Duration;

use proptest::collection::vec;
use proptest::prelude::*;
use softplc::image::{ProcessImage, TagId};
use softplc::logic::{expr, ladder, rhai, tag_table, LogicEngine, ScanContext};
use softplc::project;
use softplc_io::point::Value;
use softplc_io::time::{LineInstant, ScanInstant};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(repo().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// Snippets that make mutations meaningful in YAML and in the three languages.
const SNIPPETS: &[&str] = &[
    "\n",
    " ",
    ":",
    "- ",
    "{",
    "}",
    "[",
    "]",
    "(",
    ")",
    "&",
    "|",
    "!",
    "^",
    "=",
    "->",
    "=>",
    "/",
    ",",
    ";",
    "\"",
    "'",
    "#",
    "0",
    "1",
    "65536",
    "-1",
    "1e99",
    "10ms",
    "0s",
    "2h",
    "true",
    "null",
    "start",
    "motor",
    "mm1",
    "X1",
    "Y1",
    "ton(",
    "TON t(",
    "rising(",
    "set ",
    "reset ",
    "let ",
    "fn ",
    "loop {",
    "while true {",
    "\t",
    "\u{feff}",
    "holding",
    "f32",
    "CDAB",
    "65535",
    "scale: 0",
    "bits: [{ name: b, bit: 15, width: 9 }]",
    "é",
    "\u{0}",
];

/// `seed` with a few random edits: deletions, insertions of snippets, duplicated spans.
fn mutated(seeds: Vec<String>) -> impl Strategy<Value = String> {
    (
        proptest::sample::select(seeds),
        vec((any::<usize>(), 0u8..3, any::<usize>()), 0..6),
    )
        .prop_map(|(seed, edits)| {
            let mut s: Vec<char> = seed.chars().collect();
            for (at, op, arg) in edits {
                let at = at % (s.len() + 1);
                match op {
                    0 => {
                        let end = (at + arg % 8).min(s.len());
                        s.drain(at..end);
                    }
                    1 => {
                        let snippet = SNIPPETS[arg % SNIPPETS.len()];
                        s.splice(at..at, snippet.chars());
                    }
                    _ => {
                        let end = (at + arg % 16).min(s.len());
                        let span: Vec<char> = s[at..end].to_vec();
                        s.splice(at..at, span);
                    }
                }
            }
            s.into_iter().collect()
        })
}

fn project_seeds() -> Vec<String> {
    [
        "quickstart",
        "mixed-lines",
        "resi",
        "conveyor",
        "pump_station",
        "stairway",
        "traffic_light",
        "energy-meter",
    ]
    .iter()
    .map(|e| read(&format!("examples/{e}/project.yaml")))
    .collect()
}

fn profile_seeds() -> Vec<String> {
    ["sdm120", "delta-vfd-el", "resi-32di"]
        .iter()
        .map(|p| read(&format!("examples/profiles/{p}.yaml")))
        .collect()
}

/// Drives and simulates a profile that read: its reads and full writes planned, each request
/// served by its simulator, every point read and set through the console's path.
fn exercise_profile(profile: project::profile::Profile) {
    use softplc_io::devices::profile::model_of;
    use softplc_io::devices::Protocol;
    use softplc_io::driver::Outgoing;
    let model = model_of(profile);
    let address = *model.addresses.start();
    let Ok(config) = model.device_config("fuzz", address, Protocol::Modbus, &[]) else {
        return;
    };
    let mut driver = (model.driver)(&config);
    let mut sim = model.simulate(address);
    let mut plan = Vec::new();
    driver.advance_to(LineInstant::after_origin(Duration::from_secs(1)));
    driver.plan_read(&mut plan);
    let desired: Vec<_> = model.points.iter().map(|p| Some(p.ty.zero())).collect();
    driver.plan_write(&desired, true, &mut plan);
    for (i, tx) in plan.iter().enumerate() {
        if let Outgoing::Modbus { unit, request } = &tx.frame {
            let mut frame = Vec::new();
            if softplc_io::modbus::encode_request(unit.get(), request, &mut frame).is_ok() {
                drop(sim.on_frame(
                    &frame,
                    LineInstant::after_origin(Duration::from_millis(i as u64)),
                ));
            }
        }
        driver.on_failure(tx.tag);
    }
    for p in model.points {
        drop(sim.get(p.name));
        drop(sim.set(p.name, p.ty.zero()));
    }
    sim.advance_to(LineInstant::after_origin(Duration::from_secs(10)));
}

/// The conveyor example's tags, which the program seeds use.
fn conveyor() -> (project::Project, ProcessImage) {
    let p =
        project::load(&repo().join("examples/conveyor/project.yaml")).expect("the example loads");
    let image = ProcessImage::new(p.tags.iter().map(|t| (t.name.clone(), t.initial)));
    (p, image)
}

/// Scans a compiled program a few times with changing inputs: a fault is fine, a panic is not.
fn scan_a_little(engine: &mut dyn LogicEngine, image: &mut ProcessImage, salt: usize) {
    for cycle in 0..20u64 {
        for i in 0..image.len() {
            let id = TagId(i as u32);
            let ty = image.value_type(id);
            let bit = (salt >> (i % 16)) & 1 == (cycle as usize) & 1;
            image.update(
                id,
                Some(softplc::image::convert(Value::Bool(bit), ty)),
                softplc_io::point::Quality::Good,
                ScanInstant::ZERO,
            );
        }
        let ctx = ScanContext {
            now: ScanInstant::after_origin(Duration::from_millis(cycle * 50)),
            delta: Duration::from_millis(50),
            cycle,
        };
        if engine.scan(image, &ctx).is_err() {
            break;
        }
    }
}

// Each property is only that the parser returns, Ok or Err, without panicking: the results
// are dropped.
proptest! {
    #![proptest_config(ProptestConfig { cases: std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(128), ..ProptestConfig::default() })]

    #[test]
    fn project_files(text in mutated(project_seeds())) {
        // Relative program paths resolve against the example's folder, as `load` would.
        drop(project::parse_str(&text, &repo().join("examples/conveyor/project.yaml")));
    }

    #[test]
    fn profile_files(text in mutated(profile_seeds())) {
        // A profile that reads is driven and simulated: plans, writes, and its simulator
        // answering the plan's requests and its console's questions.
        if let Ok(profile) = project::profile::parse_str(&text, Path::new("fuzz.yaml")) {
            exercise_profile(profile);
        }
    }

    #[test]
    fn expr_programs(text in mutated(vec![read("programs/conveyor.expr")]), salt in any::<usize>()) {
        let (p, mut image) = conveyor();
        let table = tag_table(&p, &image);
        if let Ok(mut prog) = expr::compile(&text, Path::new("f.expr"), &table) {
            scan_a_little(&mut prog, &mut image, salt);
        }
    }

    #[test]
    fn ladder_programs(text in mutated(vec![read("programs/conveyor/conveyor.ladder.yaml"), read("programs/pump_station/pump_station.ladder.yaml")]), salt in any::<usize>()) {
        let (p, mut image) = conveyor();
        let table = tag_table(&p, &image);
        if let Ok(mut prog) = ladder::compile(&text, Path::new("f.ladder.yaml"), &table) {
            scan_a_little(&mut prog, &mut image, salt);
        }
    }

    #[test]
    fn rhai_programs(text in mutated(vec![read("programs/conveyor/conveyor.rhai"), read("programs/traffic_light/traffic_light.rhai")]), salt in any::<usize>()) {
        let (p, mut image) = conveyor();
        let table = tag_table(&p, &image);
        if let Ok(mut prog) = rhai::compile(&text, Path::new("f.rhai"), &table, Duration::from_millis(50)) {
            scan_a_little(&mut prog, &mut image, salt);
        }
    }

    #[test]
    fn scenario_files(text in mutated(vec![read("programs/conveyor/jam_and_count.scenario.yaml"), read("programs/pump_station/dry_run.scenario.yaml")])) {
        drop(softplc::cli::parse_scenario(&text, &repo().join("programs/conveyor/x.scenario.yaml")));
    }

    #[test]
    fn control_requests(text in mutated(vec![
        r#"{"cmd":"force","tag":"motor","value":"1"}"#.to_string(),
        r#"{"cmd":"unforce"}"#.to_string(),
        r#"{"cmd":"write","values":[{"tag":"motor","value":"1"}]}"#.to_string(),
    ])) {
        drop(softplc::service::control::parse_request(&text));
    }

    #[test]
    fn http_request_heads(bytes in prop_oneof![
        vec(any::<u8>(), 0..200),
        mutated(vec![
            "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n".to_string(),
            "POST /api/force HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer abcdefgh\r\nContent-Type: application/json\r\nContent-Length: 29\r\n\r\n{\"tag\":\"motor\",\"value\":\"1\"}".to_string(),
        ]).prop_map(String::into_bytes),
    ]) {
        drop(softplc::service::parse_metrics_head(&bytes));
        drop(softplc::service::web::parse_http(&bytes));
    }
}
