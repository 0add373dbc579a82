//! The project file: a valid project parses to the expected `Project`; each error is reported
//! at its exact `line:column`, all together.
//!
//! The inline projects resolve `program.file` against `tests/fixtures/projects/`, where
//! `conveyor.expr` exists.

use std::path::{Path, PathBuf};
use std::time::Duration;

use softplc::project::{
    load, parse_str, Binding, ErrorKind, Item, PortConfig, ProgramKind, ProjectError,
};
use softplc_io::devices::Protocol;
use softplc_io::line::SerialFormat;
use softplc_io::point::{Value, ValueType};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/projects")
}

/// The file name inline projects pretend to come from.
fn file() -> PathBuf {
    fixtures().join("inline.yaml")
}

/// Every error of `text`, which must fail.
fn errors(text: &str) -> Vec<ProjectError> {
    match parse_str(text, &file()) {
        Ok(p) => panic!("expected errors, got {p:#?}"),
        Err(e) => e.errors,
    }
}

/// The single error of `text`.
fn one(text: &str) -> ProjectError {
    let mut e = errors(text);
    assert_eq!(e.len(), 1, "expected one error, got {e:#?}");
    e.remove(0)
}

fn at(e: &ProjectError) -> (usize, usize) {
    (e.line, e.column)
}

/// Lines 1..=6: a project with a program and no I/O.
const HEAD: &str = "\
project: t
scan:
  period: 20ms
program:
  file: conveyor.expr
  kind: expr
";

/// Lines 7..=9: one simulated bus.
const BUS: &str = "\
buses:
  - name: line1
    port: sim
";

/// Lines 10..=14: one MiniMod at address 1 on line1.
const MM1: &str = "\
modules:
  - name: mm1
    bus: line1
    model: minimod
    address: 1
";

/// A terminal of the built-in conveyor: its name and whether the plant drives it.
struct Role {
    name: String,
    drives_input: bool,
}

/// The built-in conveyor's terminals, in its order.
struct Spec {
    roles: Vec<Role>,
}

fn conveyor() -> Spec {
    let model = softplc::plant::builtin("conveyor").expect("the conveyor plant exists");
    let roles = model
        .terminals()
        .map(|(name, drives_input)| Role {
            name: name.to_owned(),
            drives_input,
        })
        .collect();
    Spec { roles }
}

/// `terminal: point` lines wiring every terminal of the conveyor plant: driven ones to X1, X2,
/// X3, X9, X10 of `module`, read ones to Y1..Y4, in the plant's terminal order.
fn conveyor_wiring(indent: &str, module: &str) -> (String, Vec<(String, String)>) {
    let spec = conveyor();
    let mut inputs = ["X1", "X2", "X3", "X9", "X10"].into_iter();
    let mut outputs = ["Y1", "Y2", "Y3", "Y4"].into_iter();
    let mut text = String::new();
    let mut wiring = Vec::new();
    for role in &spec.roles {
        let point = if role.drives_input {
            inputs.next()
        } else {
            outputs.next()
        }
        .expect("enough MiniMod points for the conveyor's roles");
        text.push_str(&format!("{indent}{}: {module}.{point}\n", role.name));
        wiring.push((role.name.clone(), point.to_owned()));
    }
    (text, wiring)
}

#[test]
fn a_full_project_parses_to_the_expected_project() {
    let (wiring_text, wiring) = conveyor_wiring("    ", "mm2");
    let text = format!(
        "\
project: quickstart
scan:
  period: 20ms
  watchdog: {{ time: 100ms, sensitivity: 4 }}
  realtime: {{ priority: 50, cpu: 1, lock_memory: true }}
buses:
  - name: line1
    port: sim
    baud: 57600
    format: 8N1
    response_timeout: 50ms
    retries: 2
    output_refresh: 1.5s
  - name: field
    port: /dev/ttyUSB0
modules:
  - name: mm1
    bus: field
    model: minimod
    address: 3
    protocol: modbus
  - name: mm2
    bus: line1
    model: minimod
    address: 1
tags:
  - {{ name: start,  point: mm1.X2 }}
  - {{ name: motor,  point: mm1.Y1, safe: false }}
  - {{ name: lamp,   point: mm1.Y2, type: bool, safe: 1 }}
  - {{ name: count,  type: u16, initial: 0x10 }}
  - {{ name: ratio,  type: f32 }}
program:
  file: conveyor.expr
  kind: expr
plant:
  model: conveyor
  wiring:
{wiring_text}"
    );
    let p = parse_str(&text, &file()).unwrap_or_else(|e| panic!("{e}"));

    assert_eq!(p.name, "quickstart");
    assert_eq!(p.source, file());
    assert_eq!(p.scan.period, Duration::from_millis(20));
    assert_eq!(p.scan.watchdog.time, Duration::from_millis(100));
    assert_eq!(p.scan.watchdog.sensitivity, 4);
    assert_eq!(p.scan.realtime.priority, Some(50));
    assert_eq!(p.scan.realtime.cpu, Some(1));
    assert!(p.scan.realtime.lock_memory);

    assert_eq!(p.buses.len(), 2);
    let b = &p.buses[0];
    assert_eq!(b.name, "line1");
    assert_eq!(b.port, PortConfig::Sim);
    assert_eq!(b.settings.baud, 57600);
    assert_eq!(b.settings.format, "8N1".parse::<SerialFormat>().unwrap());
    assert_eq!(b.response_timeout, Duration::from_millis(50));
    assert_eq!(b.retries, 2);
    assert_eq!(b.output_refresh, Duration::from_millis(1500));
    // Defaults.
    let b = &p.buses[1];
    assert_eq!(b.port, PortConfig::Serial(PathBuf::from("/dev/ttyUSB0")));
    assert_eq!(b.settings.baud, 19200);
    assert_eq!(b.settings.format, SerialFormat::EVEN_8E1);
    assert_eq!(b.response_timeout, Duration::from_millis(100));
    assert_eq!(b.retries, 1);
    assert_eq!(b.output_refresh, Duration::from_secs(1));

    assert_eq!(p.modules.len(), 2);
    let m = &p.modules[0];
    assert_eq!(m.name, "mm1");
    assert_eq!(m.bus, 1);
    assert_eq!(m.model.name, "minimod");
    assert_eq!(m.device.name, "mm1");
    assert_eq!(m.device.address.get(), 3);
    assert_eq!(m.device.protocol, Protocol::Modbus);
    assert!(only_planned(&m.device.settings));
    let m = &p.modules[1];
    assert_eq!(
        (m.name.as_str(), m.bus, m.device.address.get()),
        ("mm2", 0, 1)
    );
    // Default protocol: the model's first.
    assert_eq!(m.device.protocol, m.model.protocols[0]);

    let minimod = p.modules[0].model;
    let idx = |name: &str| minimod.point_index(name).unwrap();
    assert_eq!(p.tags.len(), 5);
    let t = &p.tags[0];
    assert_eq!(t.name, "start");
    assert_eq!(t.ty, ValueType::Bool);
    assert_eq!(
        t.binding,
        Binding::Point {
            module: 0,
            point: idx("X2")
        }
    );
    assert_eq!(t.safe, None);
    assert_eq!(t.initial, Value::Bool(false));
    let t = &p.tags[1];
    assert_eq!(
        t.binding,
        Binding::Point {
            module: 0,
            point: idx("Y1")
        }
    );
    assert_eq!(t.safe, Some(Value::Bool(false)));
    assert_eq!(p.tags[2].safe, Some(Value::Bool(true)));
    let t = &p.tags[3];
    assert_eq!(
        (t.ty, t.binding, t.initial),
        (ValueType::U16, Binding::Memory, Value::U16(16))
    );
    let t = &p.tags[4];
    assert_eq!((t.ty, t.initial), (ValueType::F32, Value::F32(0.0)));

    assert_eq!(p.programs[0].path, fixtures().join("conveyor.expr"));
    assert_eq!(p.programs[0].kind, ProgramKind::Expr);

    let plant = p.plant.expect("a plant");
    assert_eq!(plant.model.name, "conveyor");
    let expected: Vec<(String, usize, String)> = wiring
        .into_iter()
        .map(|(role, point)| (role, 1, point))
        .collect();
    assert_eq!(plant.wiring, expected);
}

#[test]
fn defaults_of_a_minimal_project() {
    let p = parse_str(HEAD, &file()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(p.scan.watchdog.time, Duration::from_millis(100)); // 5 × period
    assert_eq!(p.scan.watchdog.sensitivity, 3);
    assert_eq!(p.scan.realtime.priority, None);
    assert_eq!(p.scan.realtime.cpu, None);
    assert!(!p.scan.realtime.lock_memory);
    assert!(p.buses.is_empty() && p.modules.is_empty() && p.tags.is_empty());
    assert!(p.plant.is_none());
}

#[test]
fn module_settings_are_kept_in_order_as_text() {
    // Settings are checked by the model; whatever it accepts is handed over as text.
    let text = format!("{HEAD}{BUS}{MM1}    settings: {{ }}\n");
    let p = parse_str(&text, &file()).unwrap_or_else(|e| panic!("{e}"));
    assert!(only_planned(&p.modules[0].device.settings));
}

/// Whether a module's settings hold nothing the file wrote: at most the input mode that the
/// line's plan chose for it (`project/line_plan`: Collect where cheaper).
fn only_planned(settings: &softplc_io::devices::ModuleSettings) -> bool {
    use softplc_io::devices::minimod::Setting;
    match settings {
        softplc_io::devices::ModuleSettings::MiniMod(s) => {
            s.items().iter().all(|i| matches!(i, Setting::Events(true)))
        }
        other => other.is_empty(),
    }
}

#[test]
fn load_reads_a_file_and_resolves_the_program_beside_it() {
    let path = fixtures().join("line.yaml");
    let p = load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(p.name, "line");
    assert_eq!(p.buses[0].settings.baud, 38400);
    assert_eq!(p.modules[0].device.address.get(), 7);
    assert_eq!(p.tags[2].safe, Some(Value::Bool(false)));
    assert_eq!(p.programs[0].path, fixtures().join("conveyor.expr"));
}

#[test]
fn load_of_a_missing_file_names_the_file() {
    let path = fixtures().join("no-such-project.yaml");
    let e = load(&path).unwrap_err();
    assert_eq!(e.len(), 1);
    assert_eq!(at(&e.errors[0]), (0, 0));
    assert!(matches!(e.errors[0].kind, ErrorKind::Io { .. }));
    let shown = e.to_string();
    assert!(
        shown.starts_with(&format!("{}: error: cannot read", path.display())),
        "{shown}"
    );
}

#[test]
fn display_is_like_rustc() {
    let text = format!("{HEAD}{BUS}{MM1}").replace("model: minimod", "model: minimodd");
    let e = one(&text);
    assert_eq!(at(&e), (13, 12));
    let shown = e.to_string();
    let expected = format!(
        "{}:13:12: error: unknown model \"minimodd\" (known: ",
        file().display()
    );
    assert!(shown.starts_with(&expected), "{shown}");
    assert!(shown.contains("minimod"), "{shown}");
}

// ---- errors of the YAML reader ----

#[test]
fn syntax_error() {
    let e = one("project: t\nscan:\n  period: 20ms\n  watchdog: \"100ms\n");
    assert!(matches!(e.kind, ErrorKind::Yaml { .. }), "{e:?}");
    assert_eq!(at(&e), (5, 1));
    assert!(e.to_string().ends_with(
        "inline.yaml:5:1: error: found unexpected end of stream, while scanning a quoted scalar \
         at line 4 column 13"
    ), "{e}");
}

#[test]
fn unknown_key_points_at_the_key() {
    let text = format!("{HEAD}{BUS}    bawd: 9600\n");
    let e = one(&text);
    assert_eq!(at(&e), (10, 5));
    match &e.kind {
        ErrorKind::UnknownKey {
            section,
            key,
            expected,
        } => {
            assert_eq!((section.as_str(), key.as_str()), ("buses[0]", "bawd"));
            assert!(expected.contains("`baud`"), "{expected}");
        }
        other => panic!("{other:?}"),
    }
    assert!(
        e.to_string()
            .contains("unknown key `bawd` in buses[0]; expected one of"),
        "{e}"
    );
}

#[test]
fn every_unknown_key_comes_with_the_other_errors() {
    // Two typos in a bus (one with a nested value), one in a flow mapping, and a module on a
    // bus that does not exist: all four at once, each at its place in the file.
    let text = format!(
        "{HEAD}{BUS}    format: 8E1\n    parity:\n      even: true\n    bawd: 9600\n\
         modules:\n  - {{ name: m1, bus: line9, model: minimod, address: 1, adres: 2 }}\n"
    );
    let e = errors(&text);
    let found: Vec<((usize, usize), String)> = e
        .iter()
        .map(|e| {
            let text = e.to_string();
            let message = text.split_once("error: ").map_or("", |(_, m)| m);
            let message = message.split_once(';').map_or(message, |(m, _)| m);
            (at(e), message.to_owned())
        })
        .collect();
    assert_eq!(
        found,
        vec![
            ((11, 5), "unknown key `parity` in buses[0]".to_owned()),
            ((13, 5), "unknown key `bawd` in buses[0]".to_owned()),
            ((15, 22), "unknown bus \"line9\" (known: line1)".to_owned()),
            ((15, 57), "unknown key `adres` in modules[0]".to_owned()),
        ],
        "in file order"
    );
}

#[test]
fn unknown_key_at_the_top_level() {
    let e = one(&format!("{HEAD}modles: []\n"));
    assert_eq!(at(&e), (7, 1));
    assert!(e.to_string().ends_with("error: unknown key `modles` at the top level; expected one of `project`, `scan`, `tasks`, `buses`, `modules`, `tags`, `program`, `programs`, `blocks`, `instances`, `plant`, `service`, `retain`, `offload`, `recorder`, `traces`, `trace_budget`, `alarms`; did you mean `modules`?"), "{e}");
}

#[test]
fn an_unknown_key_one_edit_from_a_known_one_gets_it_suggested() {
    // Two neighbours swapped are one edit (suggest.rs).
    let text = format!(
        "{HEAD}{BUS}modules:\n  - {{ name: m1, bus: line1, model: minimod, address: 1 }}\n\
         tags:\n  - {{ name: t, point: m1.X1, retian: true }}\n"
    );
    let e = one(&text);
    let message = e.to_string();
    assert!(
        message.contains("unknown key `retian` in tags[0]; expected one of"),
        "{message}"
    );
    assert!(message.ends_with("; did you mean `retain`?"), "{message}");
}

#[test]
fn wrong_type_points_at_the_value() {
    let text = format!("{HEAD}{BUS}    baud: fast\n");
    let e = one(&text);
    assert_eq!(at(&e), (10, 11));
    assert!(
        matches!(&e.kind, ErrorKind::WrongType { key, .. } if key == "buses[0].baud"),
        "{e:?}"
    );
    assert!(
        e.to_string().ends_with(
            "error: buses[0].baud: invalid type: string \"fast\", expected a whole number"
        ),
        "{e}"
    );
}

#[test]
fn missing_key_points_at_the_mapping() {
    let e = one(&format!(
        "{HEAD}{BUS}modules:\n  - name: mm1\n    bus: line1\n    address: 1\n"
    ));
    assert_eq!(at(&e), (11, 5));
    assert!(
        matches!(&e.kind, ErrorKind::MissingKey { section, key } if section == "modules[0]" && key == "model"),
        "{e:?}"
    );
}

#[test]
fn bare_number_is_not_a_duration() {
    let e = one("project: t\nscan:\n  period: 20\nprogram: { file: conveyor.expr, kind: expr }\n");
    assert_eq!(at(&e), (3, 11));
    assert!(matches!(e.kind, ErrorKind::WrongType { .. }), "{e:?}");
    assert!(e.to_string().contains("bare number is ambiguous"), "{e}");
}

#[test]
fn unknown_duration_unit() {
    let e = one(
        "project: t\nscan:\n  period: 20 parsecs\nprogram: { file: conveyor.expr, kind: expr }\n",
    );
    assert_eq!(at(&e), (3, 11));
    assert!(e.to_string().contains("unknown unit \"parsecs\""), "{e}");
}

#[test]
fn duplicate_setting_key() {
    let e = one(&format!("{HEAD}{BUS}{MM1}    settings: {{ A: 1, A: 2 }}\n"));
    assert_eq!(e.line, 15);
    assert!(
        matches!(&e.kind, ErrorKind::DuplicateKey { key, .. } if key == "A"),
        "{e:?}"
    );
}

// ---- semantic errors ----

#[test]
fn zero_period() {
    let e = one(&HEAD.replace("20ms", "0ms"));
    assert_eq!(at(&e), (3, 11));
    assert_eq!(e.kind, ErrorKind::ZeroDuration { key: "scan.period" });
    assert!(
        e.to_string()
            .ends_with("error: scan.period must be greater than zero"),
        "{e}"
    );
}

#[test]
fn watchdog_and_realtime_ranges() {
    let text = "\
project: t
scan:
  period: 20ms
  watchdog: { time: 0s, sensitivity: 0 }
  realtime: { priority: 100, cpu: -1 }
program: { file: conveyor.expr, kind: expr }
";
    let e = errors(text);
    let got: Vec<_> = e.iter().map(|e| (at(e), e.kind.clone())).collect();
    assert_eq!(
        got,
        vec![
            (
                (4, 21),
                ErrorKind::ZeroDuration {
                    key: "watchdog time"
                }
            ),
            ((4, 38), ErrorKind::BadSensitivity { value: 0 }),
            ((5, 25), ErrorKind::BadPriority { value: 100 }),
            ((5, 35), ErrorKind::BadCpu { value: -1 }),
        ]
    );
}

#[test]
fn bus_fields() {
    let text = format!(
        "{HEAD}buses:
  - name: line1
    port: ttyUSB0
    baud: 0
    format: 8X1
    retries: 300
    response_timeout: 0ms
    output_refresh: 0s
"
    );
    let got: Vec<_> = errors(&text)
        .iter()
        .map(|e| (at(e), e.kind.clone()))
        .collect();
    assert_eq!(
        got,
        vec![
            (
                (9, 11),
                ErrorKind::BadPort {
                    port: "ttyUSB0".into()
                }
            ),
            ((10, 11), ErrorKind::BadBaud { value: 0 }),
            (
                (11, 13),
                ErrorKind::BadFormat {
                    format: "8X1".into()
                }
            ),
            ((12, 14), ErrorKind::BadRetries { value: 300 }),
            (
                (13, 23),
                ErrorKind::ZeroDuration {
                    key: "response_timeout"
                }
            ),
            (
                (14, 21),
                ErrorKind::ZeroDuration {
                    key: "output_refresh"
                }
            ),
        ]
    );
}

#[test]
fn names_must_be_identifiers_and_unique() {
    let text = format!(
        "{HEAD}{BUS}  - name: line1
    port: sim
modules:
  - name: 1mm
    bus: line1
    model: minimod
    address: 1
"
    );
    let got: Vec<_> = errors(&text)
        .iter()
        .map(|e| (at(e), e.kind.clone()))
        .collect();
    assert_eq!(
        got,
        vec![
            (
                (10, 11),
                ErrorKind::DuplicateName {
                    item: Item::Bus,
                    name: "line1".into(),
                    first_line: 8
                }
            ),
            (
                (13, 11),
                ErrorKind::InvalidName {
                    item: Item::Module,
                    name: "1mm".into()
                }
            ),
        ]
    );
    assert!(got[0]
        .1
        .to_string()
        .contains("bus name \"line1\" is already used by the bus at line 8"));
}

#[test]
fn unknown_bus() {
    let text = format!("{HEAD}{BUS}{MM1}").replace("bus: line1", "bus: line2");
    let e = one(&text);
    assert_eq!(at(&e), (12, 10));
    assert_eq!(
        e.kind,
        ErrorKind::UnknownBus {
            name: "line2".into(),
            known: vec!["line1".into()]
        }
    );
    assert!(
        e.to_string()
            .ends_with("error: unknown bus \"line2\" (known: line1)"),
        "{e}"
    );
}

#[test]
fn unknown_model_lists_the_known_ones() {
    let text = format!("{HEAD}{BUS}{MM1}").replace("model: minimod", "model: minimodd");
    let e = one(&text);
    assert_eq!(at(&e), (13, 12));
    match &e.kind {
        ErrorKind::UnknownModel { name, known } => {
            assert_eq!(name, "minimodd");
            assert!(known.contains(&"minimod"), "{known:?}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn duplicate_address_names_the_other_module() {
    let text = format!(
        "{HEAD}{BUS}modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
  - {{ name: mm2, bus: line1, model: minimod, address: 1 }}
"
    );
    let e = one(&text);
    assert_eq!(at(&e), (12, 55));
    assert!(
        e.to_string()
            .ends_with("error: address 1 is already used by module mm1 on bus line1 (line 11)"),
        "{e}"
    );
}

#[test]
fn same_address_on_two_buses_is_fine() {
    let text = format!(
        "{HEAD}{BUS}  - {{ name: line2, port: sim }}
modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
  - {{ name: mm2, bus: line2, model: minimod, address: 1 }}
"
    );
    parse_str(&text, &file()).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn address_out_of_range() {
    let e = one(&format!("{HEAD}{BUS}{MM1}").replace("address: 1", "address: 300"));
    assert_eq!(at(&e), (14, 14));
    assert!(matches!(
        e.kind,
        ErrorKind::AddressOutOfRange {
            address: 300,
            model: "minimod",
            ..
        }
    ));
    assert!(
        e.to_string().contains("address 300 is outside the range "),
        "{e}"
    );
}

#[test]
fn baud_above_the_models_max_is_reported_at_the_module() {
    let text = format!("{HEAD}{BUS}    baud: 115200\n{MM1}");
    let e = one(&text);
    // The module's `bus:` (line 13), naming the bus's baud line (10).
    assert_eq!(at(&e), (13, 10));
    match &e.kind {
        ErrorKind::BaudTooHigh {
            module,
            baud,
            baud_line,
            max,
            ..
        } => {
            assert_eq!((module.as_str(), *baud, *baud_line), ("mm1", 115200, 10));
            assert!(*max < 115200);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn unknown_protocol() {
    let e = one(&format!("{HEAD}{BUS}{MM1}    protocol: profibus\n"));
    assert_eq!(at(&e), (15, 15));
    assert!(
        e.to_string()
            .contains("unknown protocol \"profibus\" (known: modbus, text)"),
        "{e}"
    );
}

#[test]
fn protocol_the_model_does_not_speak() {
    let minimod = softplc_io::devices::model("minimod").expect("minimod is in the catalog");
    if minimod.protocols.contains(&Protocol::Text) {
        return; // nothing to refuse
    }
    let e = one(&format!("{HEAD}{BUS}{MM1}    protocol: text\n"));
    assert_eq!(at(&e), (15, 15));
    assert!(
        e.to_string()
            .contains("model minimod does not speak text (it speaks: modbus"),
        "{e}"
    );
}

#[test]
fn setting_refused_by_the_model() {
    let e = one(&format!(
        "{HEAD}{BUS}{MM1}    settings:\n      NO_SUCH_SETTING: 1\n"
    ));
    assert_eq!(at(&e), (16, 24));
    assert!(
        matches!(&e.kind, ErrorKind::BadSetting { module, key, .. } if module == "mm1" && key == "NO_SUCH_SETTING"),
        "{e:?}"
    );
}

#[test]
fn a_misspelt_setting_gets_the_models_close_keys() {
    let e = one(&format!("{HEAD}{BUS}{MM1}    settings:\n      RDELAY: 5\n"));
    assert_eq!(at(&e), (16, 15), "at the value");
    assert!(
        e.to_string()
            .ends_with("setting `RDELAY`: not a minimod setting; accepted: readback, counters, status, events, event_refresh, event_resync, RDELAYT, RDELAYM, XLATUP1..3, XLATDN1..3, XCOUNT1..3, Y1AON1..Y4AON3, Y1AOFF1..Y4AOFF3, YLAMP1..4, WDTTIME, WDTYMASK, FBENABLE, WDTFB1..2, EVFB1..2, XEVMASK, YEVMASK; did you mean RDELAYT, RDELAYM?"),
        "{e}"
    );
    // A value out of range names the range; a condition names where it goes wrong.
    let e = one(&format!(
        "{HEAD}{BUS}{MM1}    settings:\n      Y1AON1: X1 X7\n"
    ));
    assert!(
        e.to_string().ends_with(
            "setting `Y1AON1`: Y1AON1 takes a 16-bit mask or a condition such as X1-X2; the value \
             goes wrong at character 4"
        ),
        "{e}"
    );
}

#[test]
fn a_dcon_setting_on_a_modbus_module_is_refused_not_ignored() {
    let module = "modules:\n  - name: ex1\n    bus: line1\n    model: ex9053d-m\n    address: 2\n    settings:\n      Sync: lead\n";
    let e = one(&format!("{HEAD}{BUS}{module}"));
    assert_eq!(at(&e), (16, 13));
    assert!(
        e.to_string().ends_with(
            "module ex1: setting `Sync`: sync is a DCON setting and the module speaks Modbus \
             (protocol: modbus); remove it, or use protocol: text"
        ),
        "{e}"
    );
    // On its DCON side the same setting is the module's own.
    let text = format!("{HEAD}{BUS}{module}    protocol: text\n");
    assert!(parse_str(&text, &file()).is_ok());
}

#[test]
fn bad_point_suggests_close_matches() {
    let text = format!("{HEAD}{BUS}{MM1}tags:\n  - name: motor\n    point: mm1.Y9\n");
    let e = one(&text);
    assert_eq!(at(&e), (17, 12));
    match &e.kind {
        ErrorKind::UnknownPoint {
            module,
            point,
            close,
            ..
        } => {
            assert_eq!((module.as_str(), point.as_str()), ("mm1", "Y9"));
            assert!(close.contains(&"Y1") && close.contains(&"Y4"), "{close:?}");
        }
        other => panic!("{other:?}"),
    }
    assert!(
        e.to_string()
            .contains("module mm1 (minimod) has no point \"Y9\"; did you mean "),
        "{e}"
    );
}

#[test]
fn bad_point_without_close_matches_lists_the_points() {
    let e = one(&format!(
        "{HEAD}{BUS}{MM1}tags:\n  - name: motor\n    point: mm1.MOTOR_RUNNING\n"
    ));
    assert_eq!(at(&e), (17, 12));
    assert!(e.to_string().contains("its points: X1, X2, X3"), "{e}");
}

#[test]
fn point_references() {
    let text = format!(
        "{HEAD}{BUS}{MM1}tags:
  - {{ name: a, point: mm1Y1 }}
  - {{ name: b, point: mm9.Y1 }}
"
    );
    let got: Vec<_> = errors(&text)
        .iter()
        .map(|e| (at(e), e.kind.clone()))
        .collect();
    assert_eq!(
        got,
        vec![
            (
                (16, 23),
                ErrorKind::BadPointRef {
                    text: "mm1Y1".into()
                }
            ),
            (
                (17, 23),
                ErrorKind::UnknownModule {
                    name: "mm9".into(),
                    known: vec!["mm1".into()]
                }
            ),
        ]
    );
}

#[test]
fn two_owners_of_one_output() {
    let text = format!(
        "{HEAD}{BUS}{MM1}tags:
  - name: motor
    point: mm1.Y1
  - name: motor_again
    point: mm1.Y1
  - {{ name: in1, point: mm1.X1 }}
  - {{ name: in1_alias, point: mm1.X1 }}
"
    );
    let e = one(&text);
    assert_eq!(at(&e), (19, 12));
    assert!(
        e.to_string().ends_with(
            "error: output mm1.Y1 is written by two owners: tag motor (line 17) and tag motor_again"
        ),
        "{e}"
    );
}

#[test]
fn tag_types_and_values() {
    let text = format!(
        "{HEAD}{BUS}{MM1}tags:
  - {{ name: a }}
  - {{ name: b, type: int }}
  - {{ name: c, point: mm1.X1, type: u16 }}
  - {{ name: d, point: mm1.X1, safe: true }}
  - {{ name: e, type: bool, safe: true }}
  - {{ name: f, point: mm1.Y1, safe: maybe }}
  - {{ name: g, point: mm1.Y2, initial: 1 }}
  - {{ name: h, type: u16, initial: -1 }}
"
    );
    let got: Vec<_> = errors(&text)
        .iter()
        .map(|e| (at(e), e.kind.clone()))
        .collect();
    let s = |x: &str| x.to_owned();
    assert_eq!(
        got,
        vec![
            ((16, 5), ErrorKind::TagNeedsPointOrType { tag: s("a") }),
            ((17, 22), ErrorKind::UnknownType { name: s("int") }),
            (
                (18, 37),
                ErrorKind::TypeMismatch {
                    tag: s("c"),
                    declared: ValueType::U16,
                    point: s("mm1.X1"),
                    actual: ValueType::Bool
                }
            ),
            (
                (19, 37),
                ErrorKind::SafeNotOnOutput {
                    tag: s("d"),
                    point: Some(s("mm1.X1")),
                    access: Some(softplc_io::point::Access::Input)
                }
            ),
            (
                (20, 34),
                ErrorKind::SafeNotOnOutput {
                    tag: s("e"),
                    point: None,
                    access: None
                }
            ),
            (
                (21, 37),
                ErrorKind::BadValue {
                    tag: s("f"),
                    key: "safe",
                    value: s("maybe"),
                    ty: ValueType::Bool
                }
            ),
            (
                (22, 40),
                ErrorKind::InitialOnPointTag {
                    tag: s("g"),
                    point: s("mm1.Y2")
                }
            ),
            (
                (23, 36),
                ErrorKind::BadValue {
                    tag: s("h"),
                    key: "initial",
                    value: s("-1"),
                    ty: ValueType::U16
                }
            ),
        ]
    );
    let shown: Vec<String> = errors(&text).iter().map(|e| e.kind.to_string()).collect();
    assert_eq!(
        shown[3],
        "tag d: `safe` is only allowed on tags bound to an output point, and mm1.X1 is an input"
    );
    assert_eq!(shown[5], "tag f: safe value maybe is not a bool");
}

#[test]
fn descriptions_are_kept_on_tags_and_modules() {
    let text = format!(
        "{HEAD}{BUS}modules:
  - name: mm1
    bus: line1
    model: minimod
    address: 1
    description: >
      Cabinet 1, left rail,
      beside the door
tags:
  - {{ name: start, point: mm1.X1, description: \"Start button, green\" }}
  - {{ name: count, type: u16, description: '   ' }}
"
    );
    let project = parse_str(&text, &file()).unwrap();
    let module = project.modules[0].description.as_ref().map(|d| d.as_str());
    assert_eq!(module, Some("Cabinet 1, left rail, beside the door"));
    let start = project.tags[0].description.as_ref().map(|d| d.as_str());
    assert_eq!(start, Some("Start button, green"));
    assert_eq!(project.tags[1].description, None, "blank is no description");
}

#[test]
fn a_description_too_long_or_of_several_lines_is_refused_at_its_value() {
    let long = "x".repeat(257);
    let text = format!(
        "{HEAD}{BUS}{MM1}    description: {long}
tags:
  - {{ name: a, type: bool, description: \"one\\ntwo\" }}
"
    );
    let got: Vec<(usize, usize, String)> = errors(&text)
        .iter()
        .map(|e| (e.line, e.column, e.to_string()))
        .collect();
    let file = file();
    assert_eq!(
        got,
        [
            (
                15,
                18,
                format!(
                    "{}:15:18: error: module mm1: description: 257 characters, at most 256 are \
                     allowed",
                    file.display()
                )
            ),
            (
                17,
                41,
                format!(
                    "{}:17:41: error: tag a: description: a line break at character 4: this \
                     text is one line (a YAML folded block `>-` joins lines)",
                    file.display()
                )
            ),
        ]
    );
    // A list is not a text: the reader stops there, at the value.
    let text = format!("{HEAD}{BUS}{MM1}tags:\n  - {{ name: a, type: bool, description: [x] }}\n");
    let e = one(&text);
    assert_eq!(at(&e), (16, 41));
    assert!(e.to_string().contains("expected a string"), "{e}");
}

#[test]
fn program_kind_and_file() {
    let text = "\
project: t
scan: { period: 20ms }
program:
  file: missing.expr
  kind: sfc
";
    let got = errors(text);
    assert_eq!(got.len(), 2, "{got:#?}");
    assert_eq!(at(&got[0]), (4, 9));
    assert!(
        matches!(&got[0].kind, ErrorKind::ProgramNotFound { path, .. } if *path == fixtures().join("missing.expr"))
    );
    assert_eq!(at(&got[1]), (5, 9));
    assert_eq!(
        got[1].kind.to_string(),
        "unknown program kind \"sfc\" (known: expr, ladder, rhai)"
    );
}

#[test]
fn several_errors_are_reported_together_in_file_order() {
    let text = format!(
        "\
project: t
scan:
  period: 0ms
program:
  file: conveyor.expr
  kind: expr
{BUS}modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
  - {{ name: mm2, bus: line1, model: minimod, address: 1 }}
  - {{ name: mm3, bus: line1, model: maximod, address: 2 }}
tags:
  - {{ name: x, point: mm1.Y9 }}
"
    );
    let e = errors(&text);
    let positions: Vec<_> = e.iter().map(at).collect();
    assert_eq!(positions, vec![(3, 11), (12, 55), (13, 37), (15, 23)]);
    assert!(
        matches!(e[0].kind, ErrorKind::ZeroDuration { .. }),
        "{:?}",
        e[0]
    );
    assert!(
        matches!(e[1].kind, ErrorKind::DuplicateAddress { .. }),
        "{:?}",
        e[1]
    );
    assert!(
        matches!(e[2].kind, ErrorKind::UnknownModel { .. }),
        "{:?}",
        e[2]
    );
    assert!(
        matches!(e[3].kind, ErrorKind::UnknownPoint { .. }),
        "{:?}",
        e[3]
    );
    let shown = parse_str(&text, &file()).unwrap_err().to_string();
    assert_eq!(shown.lines().count(), 4, "{shown}");
    assert!(shown.lines().all(|l| l.contains(": error: ")), "{shown}");
}

// ---- the plant ----

#[test]
fn plant_model_must_exist() {
    let e = one(&format!("{HEAD}plant:\n  model: boiler\n"));
    assert_eq!(at(&e), (8, 10));
    assert!(
        e.to_string()
            .contains("unknown plant model \"boiler\" (known: "),
        "{e}"
    );
}

#[test]
fn plant_unknown_role_points_at_the_key_and_missing_roles_at_the_wiring() {
    let (wiring, _) = conveyor_wiring("    ", "mm1");
    let first_role = conveyor().roles[0].name.clone();
    // Rename the first role: an unknown role, and the first role missing.
    let wiring = wiring.replacen(&first_role, "belt", 1);
    let text = format!("{HEAD}{BUS}{MM1}plant:\n  model: conveyor\n  wiring:\n{wiring}");
    let got = errors(&text);
    assert_eq!(got.len(), 2, "{got:#?}");
    // The missing role at the `wiring` key (line 17), the unknown one at its key (line 18).
    assert_eq!(at(&got[0]), (17, 3));
    assert!(
        matches!(&got[0].kind, ErrorKind::MissingPlantRole { role, .. } if *role == first_role)
    );
    assert_eq!(at(&got[1]), (18, 5));
    assert!(matches!(&got[1].kind, ErrorKind::UnknownPlantRole { role, .. } if role == "belt"));
}

#[test]
fn plant_roles_must_have_the_right_direction() {
    let spec = conveyor();
    let (wiring, _) = conveyor_wiring("    ", "mm1");
    // Swap directions of the first driven and the first read role.
    let driven = spec.roles.iter().position(|r| r.drives_input).unwrap();
    let read = spec.roles.iter().position(|r| !r.drives_input).unwrap();
    let mut lines: Vec<String> = wiring.lines().map(str::to_owned).collect();
    lines[driven] = format!("    {}: mm1.Y4", spec.roles[driven].name);
    lines[read] = format!("    {}: mm1.X10", spec.roles[read].name);
    let text = format!(
        "{HEAD}{BUS}{MM1}plant:\n  model: conveyor\n  wiring:\n{}\n",
        lines.join("\n")
    );
    let mut got = errors(&text);
    got.sort_by_key(|e| e.line);
    assert_eq!(got.len(), 2, "{got:#?}");
    // Wiring starts at line 18; a value starts after "    ROLE: ".
    let col = |role: usize| 4 + spec.roles[role].name.len() + 3;
    let (first, second) = (driven.min(read), driven.max(read));
    assert_eq!(at(&got[0]), (18 + first, col(first)));
    assert_eq!(at(&got[1]), (18 + second, col(second)));
    let msg = |r: usize| {
        got.iter()
            .find(|e| e.line == 18 + r)
            .unwrap()
            .kind
            .to_string()
    };
    assert_eq!(
        msg(driven),
        format!(
            "plant terminal {} drives a module input, but mm1.Y4 is an output",
            spec.roles[driven].name
        )
    );
    assert_eq!(
        msg(read),
        format!(
            "plant terminal {} reads a module output, but mm1.X10 is an input",
            spec.roles[read].name
        )
    );
}

#[test]
fn plant_needs_simulated_buses() {
    let (wiring, _) = conveyor_wiring("    ", "mm1");
    let text = format!("{HEAD}{BUS}{MM1}plant:\n  model: conveyor\n  wiring:\n{wiring}")
        .replace("port: sim", "port: /dev/ttyUSB0");
    let got = errors(&text);
    assert_eq!(got.len(), conveyor().roles.len(), "{got:#?}");
    let first_role = conveyor().roles[0].name.clone();
    assert_eq!(at(&got[0]), (18, 4 + first_role.len() + 3));
    assert!(
        got[0]
            .to_string()
            .contains("on bus line1, which is not `port: sim`"),
        "{}",
        got[0]
    );
}

#[test]
fn one_input_driven_by_two_roles() {
    let spec = conveyor();
    let driven: Vec<usize> = spec
        .roles
        .iter()
        .enumerate()
        .filter(|(_, r)| r.drives_input)
        .map(|(i, _)| i)
        .collect();
    if driven.len() < 2 {
        return; // this plant cannot drive one input twice
    }
    let (wiring, _) = conveyor_wiring("    ", "mm1");
    let mut lines: Vec<String> = wiring.lines().map(str::to_owned).collect();
    lines[driven[1]] = format!("    {}: mm1.X1", spec.roles[driven[1]].name);
    let text = format!(
        "{HEAD}{BUS}{MM1}plant:\n  model: conveyor\n  wiring:\n{}\n",
        lines.join("\n")
    );
    let e = one(&text);
    assert_eq!(
        at(&e),
        (18 + driven[1], 4 + spec.roles[driven[1]].name.len() + 3)
    );
    assert_eq!(
        e.kind.to_string(),
        format!(
            "input mm1.X1 is driven by two plant terminals: {} and {}",
            spec.roles[driven[1]].name, spec.roles[driven[0]].name
        )
    );
}

#[test]
fn nesting_deeper_than_the_limit_is_refused_at_the_collection_past_it() {
    use softplc::project::MAX_DEPTH;
    // The top-level mapping is one level; 63 brackets more are accepted, 64 are not.
    let ok = format!(
        "{HEAD}plant: {}{}\n",
        "[".repeat(MAX_DEPTH - 1),
        "]".repeat(MAX_DEPTH - 1)
    );
    assert!(
        errors(&ok)
            .iter()
            .all(|e| e.kind != ErrorKind::TooDeep { limit: MAX_DEPTH }),
        "{:?}",
        errors(&ok)
    );
    let deep = format!("{HEAD}plant: {}\n", "[{a: ".repeat(MAX_DEPTH));
    let e = one(&deep);
    assert_eq!(e.kind, ErrorKind::TooDeep { limit: MAX_DEPTH });
    // `plant: ` is 7 characters, each `[{a: ` 5: the 32nd `{` is the 64th bracket, a level
    // too many.
    assert_eq!(at(&e), (7, 8 + 5 * 31 + 1), "{e}");
    assert!(
        e.to_string().ends_with(
            "inline.yaml:7:164: error: lists and mappings nested more than 64 deep (a project \
             needs a handful); this one goes past it"
        ),
        "{e}"
    );
}

#[test]
fn thousands_of_errors_in_a_large_file_are_located_quickly() {
    // N tags with a bad name each: N errors, each at its own line; 4000 make about 200 KB.
    let file = |n: usize| {
        let mut text = format!("{HEAD}tags:\n");
        for i in 0..n {
            text.push_str(&format!(
                "  - {{ name: \"bad-{i}\", type: u16, initial: {i} }}   # a comment to fill the file\n"
            ));
        }
        text
    };
    let (small, large) = (file(400), file(4000));
    assert!(large.len() > 200_000, "{}", large.len());
    // The best of three, so one slow spell of the machine does not decide.
    let timed = |text: &str| {
        (0..3)
            .map(|_| {
                let started = std::time::Instant::now();
                let e = errors(text);
                (started.elapsed(), e)
            })
            .min_by_key(|(took, _)| *took)
            .unwrap()
    };
    let (took_small, _) = timed(&small);
    let (took, e) = timed(&large);
    assert_eq!(e.len(), 4000);
    for (i, e) in e.iter().enumerate() {
        assert_eq!(at(e), (8 + i, 13), "{e}");
    }
    // Each error once cost a reading of the whole file (minutes for these, 100 times the 400
    // errors' time); now a few readings in all, so ten times the errors take about ten times
    // as long. Compared within this run, not with a fixed time, so a loaded machine does not
    // fail it.
    assert!(
        took < took_small * 30 + Duration::from_millis(200),
        "4000 errors took {took:?}, 400 took {took_small:?}"
    );
}

#[test]
fn network_bus_urls_and_keys() {
    use softplc_io::line::{EndpointError, NetFraming, TcpEndpoint};
    // A good one of each framing.
    let text = format!(
        "{HEAD}buses:
  - {{ name: gw, port: \"tcp://10.0.0.7:502\" }}
  - {{ name: ser, port: \"rtu+tcp://moxa.local:4001\", baud: 9600 }}
"
    );
    let p = parse_str(&text, &file()).unwrap();
    assert_eq!(
        p.buses[0].port,
        PortConfig::Tcp(TcpEndpoint {
            framing: NetFraming::ModbusTcp,
            host: "10.0.0.7".into(),
            port: 502
        })
    );
    assert_eq!(
        p.buses[1].port,
        PortConfig::Tcp(TcpEndpoint {
            framing: NetFraming::RtuOverTcp,
            host: "moxa.local".into(),
            port: 4001
        })
    );
    assert_eq!(p.buses[1].settings.baud, 9600);

    let text = format!(
        "{HEAD}buses:
  - name: a
    port: udp://10.0.0.7:502
  - name: b
    port: tcp://10.0.0.7
  - name: c
    port: tcp://:502
  - name: d
    port: tcp://10.0.0.7:70000
  - name: e
    port: tcp://10.0.0.8:502
    baud: 9600
    rs485: {{ rts_on_send: true }}
  - name: f
    port: rtu+tcp://10.0.0.8:502
"
    );
    let got: Vec<_> = errors(&text)
        .iter()
        .map(|e| (at(e), e.kind.clone(), e.to_string()))
        .collect();
    let url = |port: &str, reason| ErrorKind::BadPortUrl {
        port: port.into(),
        reason,
    };
    let kinds: Vec<_> = got.iter().map(|(at, k, _)| (*at, k.clone())).collect();
    assert_eq!(
        kinds,
        vec![
            (
                (9, 11),
                url("udp://10.0.0.7:502", EndpointError::UnknownScheme)
            ),
            ((11, 11), url("tcp://10.0.0.7", EndpointError::MissingPort)),
            ((13, 11), url("tcp://:502", EndpointError::MissingHost)),
            (
                (15, 11),
                url("tcp://10.0.0.7:70000", EndpointError::BadPort)
            ),
            (
                (18, 11),
                ErrorKind::NotOnNetworkBus {
                    key: "baud",
                    scheme: "tcp",
                    hint: ": the gateway's RTU side is set in the gateway"
                }
            ),
            (
                (19, 12),
                ErrorKind::NotOnNetworkBus {
                    key: "rs485",
                    scheme: "tcp",
                    hint: ": that is the serial server's own business"
                }
            ),
            (
                (21, 11),
                ErrorKind::DuplicateEndpoint {
                    endpoint: "rtu+tcp://10.0.0.8:502".into(),
                    other: "e".into(),
                    other_line: 17
                }
            ),
        ]
    );
    let messages: Vec<&str> = got.iter().map(|(_, _, m)| m.as_str()).collect();
    assert!(
        messages[1].ends_with(
            ":11:11: error: port \"tcp://10.0.0.7\": no port (expected tcp://HOST:PORT; Modbus TCP's \
             port is 502)"
        ),
        "{}",
        messages[1]
    );
}

#[test]
fn text_protocols_and_watchdog_by_name_stay_off_modbus_tcp() {
    let text = format!(
        "{HEAD}buses:
  - {{ name: gw, port: \"tcp://127.0.0.1:1502\" }}
modules:
  - {{ name: mm1, bus: gw, model: minimod, address: 1, protocol: text }}
  - {{ name: ex, bus: gw, model: ex9053d, address: 2 }}
  - name: mm3
    bus: gw
    model: minimod
    address: 3
    settings: {{ WDTTIME: 100 }}
"
    );
    let got: Vec<_> = errors(&text)
        .iter()
        .map(|e| (at(e), e.kind.clone()))
        .collect();
    assert_eq!(
        got,
        vec![
            (
                (10, 65),
                ErrorKind::TextOnModbusTcp {
                    module: "mm1".into(),
                    model: "minimod",
                    bus: "gw".into()
                }
            ),
            (
                (11, 33),
                ErrorKind::TextOnModbusTcp {
                    module: "ex".into(),
                    model: "ex9053d",
                    bus: "gw".into()
                }
            ),
            (
                (16, 26),
                ErrorKind::TextSettingOnModbusTcp { key: "WDTTIME" }
            ),
        ]
    );
}

#[test]
fn two_buses_on_one_serial_device_are_refused_at_the_second() {
    // A device that is not on this machine: the written paths are compared.
    let text = format!(
        "{HEAD}buses:
  - {{ name: fast, port: /dev/ttyUSB7, baud: 19200 }}
  - {{ name: slow, port: /dev/ttyUSB7, baud: 9600 }}
"
    );
    let e = one(&text);
    assert_eq!(at(&e), (9, 25));
    assert_eq!(
        e.kind,
        ErrorKind::DuplicateDevice {
            port: "/dev/ttyUSB7".into(),
            same: String::new(),
            other: "fast".into(),
            other_line: 8,
        }
    );
    assert!(
        e.to_string().ends_with(
            ":9:25: error: /dev/ttyUSB7 is already bus fast's serial device (line 8): one line \
             has one baud and format, so one bus; commission the odd modules to that bus's baud \
             and format (softplc commission), or move them to a line of their own"
        ),
        "{e}"
    );
    // A device that exists, named twice: through a link (as /dev/serial/by-id/ names an
    // adapter) and by its own name.
    let dir = crate::common::host::scratch_dir("project-errors", "one-device");
    let device = dir.join("ttyUSB0");
    std::fs::write(&device, "").unwrap();
    let link = dir.join("usb-FTDI_FT232R-if00-port0");
    std::os::unix::fs::symlink(&device, &link).unwrap();
    let text = format!(
        "{HEAD}buses:
  - {{ name: a, port: {} }}
  - {{ name: b, port: {} }}
",
        link.display(),
        device.display()
    );
    let e = one(&text);
    let resolved = std::fs::canonicalize(&device).unwrap();
    assert_eq!(
        e.kind,
        ErrorKind::DuplicateDevice {
            port: device.display().to_string(),
            same: format!(" (both are {})", resolved.display()),
            other: "a".into(),
            other_line: 8,
        }
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
