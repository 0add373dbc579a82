//! The JSON Schemas in `schema/`: they are what `softplc schema` generates from the code, every
//! example project, ladder program and scenario in the repository names its schema on its
//! first line and passes it, and a file with an unknown key or a wrong type fails it, at the
//! place an editor would underline.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::host::repo as root;
use serde_json::Value;

/// Whether a file (its path) is of a kind.
type IsKind = fn(&str) -> bool;

/// The file kinds: `softplc schema` argument, and which files are of that kind.
const KINDS: [(&str, IsKind); 5] = [
    ("blocks", |path| path.ends_with(".blocks.yaml")),
    ("project", |path| path.ends_with("/project.yaml")),
    ("ladder", |path| path.ends_with(".ladder.yaml")),
    ("scenario", |path| path.ends_with(".scenario.yaml")),
    ("profile", |path| {
        path.contains("/examples/profiles/") && path.ends_with(".yaml")
    }),
];

fn schema_file(kind: &str) -> PathBuf {
    root().join("schema").join(format!("{kind}.schema.json"))
}

/// `softplc schema KIND`'s output.
fn generated(kind: &str) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["schema", kind])
        .output()
        .expect("softplc runs");
    assert!(
        out.status.success(),
        "softplc schema {kind}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("UTF-8")
}

fn validator(kind: &str) -> jsonschema::Validator {
    let text = std::fs::read_to_string(schema_file(kind)).expect("the committed schema");
    let schema: Value = serde_json::from_str(&text).expect("the schema is JSON");
    jsonschema::draft7::new(&schema)
        .unwrap_or_else(|e| panic!("schema/{kind}.schema.json is not a valid schema: {e}"))
}

/// The YAML as the editor's language server sees it: a JSON value.
fn as_json(yaml: &str) -> Value {
    let value: yaml_serde::Value = yaml_serde::from_str(yaml).expect("YAML");
    serde_json::to_value(value).expect("JSON-compatible YAML")
}

/// `instance path: message` for every way `yaml` fails schema `kind`.
fn violations(kind: &str, yaml: &str) -> Vec<String> {
    let instance = as_json(yaml);
    validator(kind)
        .iter_errors(&instance)
        .map(|e| format!("{}: {e}", e.instance_path()))
        .collect()
}

/// Every file under `dir` (recursively), sorted.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).expect("a readable folder") {
            let path = entry.expect("an entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// The repository's files of schema `kind`: the examples' projects and device profiles, the
/// programs' ladder programs and scenarios.
fn repository_files(kind: &str) -> Vec<PathBuf> {
    let (_, is_kind) = KINDS.iter().find(|(k, _)| *k == kind).expect("a kind");
    let files: Vec<PathBuf> = ["examples", "programs"]
        .iter()
        .flat_map(|d| files_under(&root().join(d)))
        .filter(|p| is_kind(p.to_str().unwrap_or("")))
        .collect();
    assert!(!files.is_empty(), "no {kind} files found");
    files
}

#[test]
fn committed_schemas_are_what_the_code_generates() {
    for (kind, _) in KINDS {
        let committed = std::fs::read_to_string(schema_file(kind)).unwrap_or_default();
        assert!(
            committed == generated(kind),
            "schema/{kind}.schema.json differs from the code; regenerate it with\n  \
             cargo run -p softplc -- schema {kind} > schema/{kind}.schema.json"
        );
    }
}

#[test]
fn every_example_and_program_passes_its_schema() {
    let mut checked = 0;
    for (kind, _) in KINDS {
        for file in repository_files(kind) {
            let text = std::fs::read_to_string(&file).expect("readable");
            let errors = violations(kind, &text);
            assert!(
                errors.is_empty(),
                "{}:\n{}",
                file.display(),
                errors.join("\n")
            );
            checked += 1;
        }
    }
    // 9 example projects, 4 ladder programs, 8 scenarios, 3 profiles at the time of writing.
    assert!(checked >= 24, "only {checked} files checked");
}

#[test]
fn every_example_and_program_names_its_schema_on_its_first_line() {
    for (kind, _) in KINDS {
        for file in repository_files(kind) {
            let text = std::fs::read_to_string(&file).expect("readable");
            let first = text.lines().next().unwrap_or("");
            let schema = first
                .strip_prefix("# yaml-language-server: $schema=")
                .unwrap_or_else(|| panic!("{}: first line is {first:?}", file.display()));
            // Relative to the file, as the YAML extension resolves it.
            let target = file.parent().expect("a folder").join(schema);
            assert!(
                schema.ends_with(&format!("schema/{kind}.schema.json"))
                    && target.canonicalize().ok() == schema_file(kind).canonicalize().ok(),
                "{}: $schema={schema} is not schema/{kind}.schema.json",
                file.display()
            );
        }
    }
}

/// `docs/project-file.md` is the reference `softplc schema project --markdown` writes from the
/// schema, so the documentation of every key cannot drift from the code.
#[test]
fn the_project_file_reference_is_written_from_the_schema() {
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["schema", "project", "--markdown"])
        .output()
        .expect("softplc runs");
    assert!(out.status.success());
    let generated = String::from_utf8(out.stdout).expect("UTF-8");
    let committed =
        std::fs::read_to_string(root().join("docs/project-file.md")).unwrap_or_default();
    assert!(
        generated == committed,
        "docs/project-file.md differs from `softplc schema project --markdown`: regenerate it \
         with `softplc schema project --markdown > docs/project-file.md` and review the diff"
    );
    // Every key of the schema has its row, every mapping its section.
    for key in [
        "`period`",
        "`watchdog`",
        "`rts_on_send`",
        "`response_timeout`",
        "`opcua`",
    ] {
        assert!(generated.contains(&format!("| {key} |")), "{key}");
    }
    assert!(generated.contains("\n## `buses[]`\n"));
}

/// The README's whole-file snippets (those that name a schema) pass it too.
#[test]
fn readme_snippets_that_name_a_schema_pass_it() {
    let readme = std::fs::read_to_string(root().join("README.md")).expect("README");
    let mut checked = 0;
    for block in readme.split("```yaml\n").skip(1) {
        let body = block.split("\n```").next().unwrap_or("");
        let Some(first) = body.lines().next() else {
            continue;
        };
        let Some(schema) = first.strip_prefix("# yaml-language-server: $schema=") else {
            continue;
        };
        let kind = KINDS
            .iter()
            .map(|(k, _)| *k)
            .find(|k| schema.ends_with(&format!("schema/{k}.schema.json")))
            .unwrap_or_else(|| panic!("README names an unknown schema {schema}"));
        let errors = violations(kind, body);
        assert!(
            errors.is_empty(),
            "README snippet:\n{body}\n{}",
            errors.join("\n")
        );
        checked += 1;
    }
    assert!(checked >= 1, "no README snippet names a schema");
}

const GOOD_PROJECT: &str = "\
project: demo
scan: { period: 20ms, watchdog: { time: 100ms } }
buses:
  - { name: line1, port: sim, baud: 19200, format: 8E1, adapter_latency: auto }
modules:
  - { name: mm1, bus: line1, model: minimod, address: 1, settings: { RDELAYT: 5 }, watchdog: off }
tags:
  - { name: start, point: mm1.X1, debounce: 20ms }
  - { name: motor, point: mm1.Y1, safe: false, scada: write }
  - { name: count, type: u16, initial: 0x1F, scada: { access: read, address: 3 } }
program: { file: p.expr, kind: expr }
offload: { mode: auto, on_stop: keep }
";

#[test]
fn a_project_with_every_written_form_passes() {
    assert_eq!(violations("project", GOOD_PROJECT), Vec::<String>::new());
}

#[test]
fn an_unknown_key_fails_where_it_is() {
    let yaml = GOOD_PROJECT.replace("baud: 19200", "baud: 19200, parity: even");
    let errors = violations("project", &yaml);
    assert!(
        errors.len() == 1 && errors[0].starts_with("/buses/0: ") && errors[0].contains("parity"),
        "{errors:?}"
    );
    let errors = violations("scenario", "project: p.yaml\nsteps: []\nrepeat: 3\n");
    assert!(
        errors.len() == 1 && errors[0].contains("repeat"),
        "{errors:?}"
    );
    let errors = violations("ladder", "rungs: [a -> b]\nrung: [c -> d]\n");
    assert!(
        errors.len() == 1 && errors[0].contains("rung"),
        "{errors:?}"
    );
}

#[test]
fn wrong_types_and_words_fail_where_they_are() {
    let cases = [
        // A bare number is not a duration: the runtime refuses to guess the unit.
        ("period: 20ms", "period: 20", "/scan/period: "),
        ("period: 20ms", "period: 20 parsecs", "/scan/period: "),
        ("baud: 19200", "baud: fast", "/buses/0/baud: "),
        ("format: 8E1", "format: 8X1", "/buses/0/format: "),
        (
            "adapter_latency: auto",
            "adapter_latency: soon",
            "/buses/0/adapter_latency: ",
        ),
        ("kind: expr", "kind: python", "/program/kind: "),
        ("scada: write", "scada: admin", "/tags/1/scada: "),
        ("safe: false", "safe: [1, 2]", "/tags/1/safe: "),
        ("on_stop: keep", "on_stop: later", "/offload: "),
        // Models are the catalog's (`softplc models`), spelled exactly.
        ("model: minimod", "model: MiniMod", "/modules/0/model: "),
        // A tag is bound to a point or has a type.
        ("type: u16, ", "", "/tags/2: "),
    ];
    for (good, bad, at) in cases {
        assert!(GOOD_PROJECT.contains(good), "{good}");
        let errors = violations("project", &GOOD_PROJECT.replace(good, bad));
        assert!(
            !errors.is_empty() && errors.iter().all(|e| e.starts_with(at)),
            "{bad}: {errors:?}"
        );
    }
    let errors = violations(
        "scenario",
        "project: p.yaml\nsteps: [{ at: 1, set: { b: 1 } }]\n",
    );
    assert!(
        errors.len() == 1 && errors[0].starts_with("/steps/0/at: "),
        "{errors:?}"
    );
    let errors = violations("ladder", "rungs: a -> b\n");
    assert!(
        errors.len() == 1 && errors[0].starts_with("/rungs: "),
        "{errors:?}"
    );
}

/// A module's settings keys are offered per model, but only the model judges them (its error
/// says "did you mean"): the schema neither refuses an unknown key nor misses a known one.
#[test]
fn settings_keys_are_offered_per_model_and_judged_by_the_model() {
    let schema: Value =
        serde_json::from_str(&std::fs::read_to_string(schema_file("project")).unwrap()).unwrap();
    let hints = schema["definitions"]["RawModule"]["allOf"]
        .as_array()
        .expect("per-model hints");
    let minimod = hints
        .iter()
        .find(|h| h["if"]["properties"]["model"]["const"] == "minimod")
        .expect("a hint for minimod");
    let keys = &minimod["then"]["properties"]["settings"]["properties"];
    assert!(
        keys.get("RDELAYT").is_some() && keys.get("WDTTIME").is_some(),
        "{keys}"
    );
    let yaml = GOOD_PROJECT.replace("RDELAYT: 5", "RDELAYX: 5");
    assert_eq!(violations("project", &yaml), Vec::<String>::new());
}

#[test]
fn a_profile_with_a_wrong_word_or_key_fails_where_it_is() {
    let text =
        "model: m\nsource: s\npoints:\n  - { name: v, table: holdng, address: 0, sclae: 2 }\n";
    let errors = violations("profile", text);
    assert!(
        errors.iter().any(|e| e.starts_with("/points/0/table: ")),
        "{errors:?}"
    );
    assert!(
        errors
            .iter()
            .any(|e| e.starts_with("/points/0: ") && e.contains("sclae")),
        "{errors:?}"
    );
}

#[test]
fn descriptions_titles_and_comments_are_known_and_bounded() {
    let ok = "rungs:\n  - a -> b\n  - { rung: c -> d, title: Motor latch, comment: \"why\\nand how\" }\n";
    assert_eq!(violations("ladder", ok), Vec::<String>::new());
    let long = format!(
        "rungs:\n  - {{ rung: c -> d, title: {} }}\n",
        "x".repeat(81)
    );
    let errors = violations("ladder", &long);
    assert!(
        errors.len() == 1 && errors[0].starts_with("/rungs/0: "),
        "the rung fits neither form: {errors:?}"
    );
    let typo = violations("ladder", "rungs:\n  - { rung: c -> d, titel: x }\n");
    assert_eq!(typo.len(), 1, "{typo:?}");
    let project = "project: p\nscan: { period: 20ms }\nbuses: []\nmodules: []\ntags:\n  - { name: a, type: bool, description: Door open }\nprogram: { file: p.expr, kind: expr }\n";
    assert_eq!(violations("project", project), Vec::<String>::new());
    let too_long = project.replace("Door open", &"x".repeat(257));
    let errors = violations("project", &too_long);
    assert!(
        errors.len() == 1 && errors[0].starts_with("/tags/0/description: "),
        "{errors:?}"
    );
}
