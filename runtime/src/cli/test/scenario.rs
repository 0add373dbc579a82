//! Scenario files: inputs over virtual time and the outputs expected, against a project.
//!
//! ```yaml
//! name: a press lights the stairs; a second press extends the light
//! project: ../../examples/stairway/project.yaml   # relative to this file
//! programs: [stairway.ladder.yaml, stairway.rhai]   # optional: run once per variant (same
//!                                   # trace required; see `variants.rs`); default: the project's
//! watch: [light]          # optional: tags in the trace (default: expected tags and outputs)
//! plant: false            # optional: keep the project's plant model (default: removed)
//! until: 70s              # optional: run length (default: last step + 1 s)
//! steps:
//!   - { at: 0s,    set: { button: 1 } }     # a module input, set on its simulated module
//!   - { at: 200ms, set: { button: 0 } }
//!   - { at: 29s,   expect: { light: 1 } }   # checked after the last scan that starts by 29 s
//!   - { at: 31s,   expect: { light: 0 } }
//! expect_retained: { presses: 1 }           # optional: values in the retain file after the run
//! ```
//!
//! With `plant: true` the project's plant model closes the loop, and a step may also switch
//! the model's faults and expect its states (a comparison or a value):
//!
//! ```yaml
//!   - { at: 5s,  fault: { jammed: on } }
//!   - { at: 12s, expect: { plant.position: ">= 99", door_fault: 1 } }
//! ```
//!
//! A step may expect an alarm's state (`raised`, `active`, `cleared` or `inactive`,
//! `acknowledged`, `unacknowledged`, or several joined by commas) and acknowledge alarms
//! (`ack: door_fault`, `ack: [door_fault, lost.door]`, `ack: all`), evaluated by the
//! service's own alarm book (see `super::alarms`):
//!
//! ```yaml
//!   - { at: 16.3s, expect: { alarm.door_fault: raised } }
//!   - { at: 17s,   ack: door_fault }
//!   - { at: 25s,   expect: { alarm.door_fault: "cleared, acknowledged" } }
//! ```
//!
//! A step may also make a simulated module stop answering (`module: { mm2: silent }`) and
//! answer again (`module: { mm2: answers }`).

use std::path::{Path, PathBuf};
use std::time::Duration;

use schemars::JsonSchema;
use serde::Deserialize;
use softplc_io::point::{Access, Value};

use super::alarms::{alarm_names, check_name, AlarmState, AlarmStep, AlarmStepKind, ALARM_PREFIX};
use super::variants::ProgramVariant;
use crate::project::raw::{DurationText, Settings};
use crate::project::span::{Locator, YPath};
use crate::project::{self, Binding, PortConfig, ProgramKind, Project};

/// A scenario file: inputs over virtual time and the outputs expected, run against a project
/// by `softplc test`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a scenario: a mapping with project, steps and optionally name, programs, watch, plant, until, expect_retained"
)]
struct RawScenario {
    /// What the scenario shows (default: the file's name).
    #[serde(default)]
    name: Option<String>,
    /// The project file, relative to this file.
    project: String,
    /// Program variants to run the scenario with, once each, all to the same trace; files
    /// relative to this file, the language told by the name (`.ladder.yaml`, `.rhai`,
    /// `.expr`). Each variant is a file or a list of files (the one task's programs, in
    /// running order) or, for a project of several tasks, a mapping of task names to those
    /// (`{ press: press.rhai, panel: panel.rhai }`). Default: the project's programs.
    #[serde(default)]
    programs: Vec<super::variants::RawVariant>,
    /// Tags in the trace (default: the expected tags and the outputs).
    #[serde(default)]
    watch: Vec<String>,
    /// Keep the project's plant model (default false: removed, the steps drive the inputs).
    #[serde(default)]
    plant: Option<bool>,
    /// Run length on the virtual clock (default: the last step + 1 s).
    #[serde(default)]
    until: Option<DurationText>,
    /// Inputs set and values expected, by time.
    steps: Vec<RawStep>,
    /// Values in the retain file after the run, by tag.
    #[serde(default)]
    expect_retained: Option<Settings>,
}

/// One step: at a time, inputs to set and/or tag values to expect.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a step: a mapping with at and set, expect, fault and/or ack"
)]
struct RawStep {
    /// Scenario time of the step, from the start of the run.
    at: DurationText,
    /// Module inputs of simulated modules to set, by tag: `{ button: 1 }`.
    #[serde(default)]
    set: Option<Settings>,
    /// Tag values expected after the last scan that starts by `at`: `{ light: 1 }`; plant
    /// states by `plant.NAME`, with a value or a comparison: `{ plant.position: ">= 99" }`;
    /// alarms by `alarm.NAME`, with a state (`raised`, `active`, `cleared` or `inactive`,
    /// `acknowledged`, `unacknowledged`, or several joined by commas):
    /// `{ alarm.door_fault: raised }`.
    #[serde(default)]
    expect: Option<Settings>,
    /// Plant faults switched on or off (`plant: true`): `{ jammed: on }`.
    #[serde(default)]
    fault: Option<Settings>,
    /// Simulated modules made to stop answering (`silent`) or to answer again (`answers`), by
    /// module name: `{ mm2: silent }`; a module that stops answering is lost, as on a real
    /// line, and its `lost.MODULE` alarm raised.
    #[serde(default)]
    module: Option<Settings>,
    /// Alarms acknowledged after the last scan that starts by `at` (after its expectations):
    /// one name (the tag's, `lost.MODULE`), a list of names, or `all` those waiting.
    #[serde(default)]
    ack: Option<AckNames>,
}

/// The alarms a step acknowledges: `door_fault`, `[door_fault, lost.door]`, `all`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(
    untagged,
    expecting = "an alarm's name, `all`, or a list of alarm names"
)]
enum AckNames {
    /// One alarm, or `all`.
    One(String),
    /// Several.
    Many(Vec<String>),
}

/// The JSON Schema of a scenario file (`softplc schema scenario`).
pub(crate) fn file_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
    generator.root_schema_for::<RawScenario>()
}

/// An input set by a step: the tag and the simulated module point that feeds it.
#[derive(Debug, Clone, PartialEq)]
pub struct SetInput {
    /// Scenario time.
    pub at: Duration,
    /// The tag (for messages).
    pub tag: String,
    /// The module's name in the project.
    pub module: String,
    /// The point.
    pub point: String,
    /// The value.
    pub value: Value,
}

/// An expected tag value.
#[derive(Debug, Clone, PartialEq)]
pub struct Expect {
    /// Scenario time.
    pub at: Duration,
    /// The tag's index.
    pub tag: usize,
    /// The expected value.
    pub value: Value,
    /// The line of the expectation in the scenario file.
    pub line: usize,
}

/// A plant state expected (`plant.position: ">= 99"`).
#[derive(Debug, Clone, PartialEq)]
pub struct PlantExpect {
    /// Scenario time.
    pub at: Duration,
    /// The state.
    pub state: String,
    /// How it compares.
    pub cmp: Comparison,
    /// The line of the expectation in the scenario file.
    pub line: usize,
}

/// A plant state's test: a comparison with a number, or a level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Comparison {
    /// `>= 99`, `< 0.5`, `== 3`, `!= 0`: with a number.
    Number(CmpOp, f64),
    /// `true` / `false` (or `1` / `0`, `on` / `off` for a bool state).
    Level(bool),
}

/// The operator of a [`Comparison::Number`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CmpOp {
    /// `==` (or a bare number).
    Eq,
    /// `!=`.
    Ne,
    /// `<`.
    Lt,
    /// `<=`.
    Le,
    /// `>`.
    Gt,
    /// `>=`.
    Ge,
}

impl CmpOp {
    fn text(self) -> &'static str {
        match self {
            CmpOp::Eq => "==",
            CmpOp::Ne => "!=",
            CmpOp::Lt => "<",
            CmpOp::Le => "<=",
            CmpOp::Gt => ">",
            CmpOp::Ge => ">=",
        }
    }
}

impl Comparison {
    /// Reads `>= 99`, `42`, `true`.
    fn parse(text: &str) -> Option<Self> {
        let t = text.trim();
        match t.to_ascii_lowercase().as_str() {
            "true" | "on" => return Some(Comparison::Level(true)),
            "false" | "off" => return Some(Comparison::Level(false)),
            _ => {}
        }
        let ops = [
            (">=", CmpOp::Ge),
            ("<=", CmpOp::Le),
            ("==", CmpOp::Eq),
            ("!=", CmpOp::Ne),
            (">", CmpOp::Gt),
            ("<", CmpOp::Lt),
        ];
        let (op, rest) = ops
            .iter()
            .find_map(|(s, op)| t.strip_prefix(s).map(|r| (*op, r)))
            .unwrap_or((CmpOp::Eq, t));
        let x: f64 = rest.trim().parse().ok()?;
        x.is_finite().then_some(Comparison::Number(op, x))
    }

    /// Whether `v` passes.
    pub fn holds(self, v: softplc_io::sim::plant::StateValue) -> bool {
        use softplc_io::sim::plant::StateValue as S;
        let x = match v {
            S::Bool(b) => {
                return match self {
                    Comparison::Level(want) => b == want,
                    Comparison::Number(op, n) => Self::Number(op, n).holds(S::Int(i64::from(b))),
                }
            }
            S::Int(i) => i as f64,
            S::Float(x) => x,
        };
        match self {
            Comparison::Level(want) => (x != 0.0) == want,
            Comparison::Number(op, n) => match op {
                CmpOp::Eq => x == n,
                CmpOp::Ne => x != n,
                CmpOp::Lt => x < n,
                CmpOp::Le => x <= n,
                CmpOp::Gt => x > n,
                CmpOp::Ge => x >= n,
            },
        }
    }
}

impl std::fmt::Display for Comparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Comparison::Level(b) => write!(f, "{b}"),
            Comparison::Number(op, n) => write!(f, "{} {n}", op.text()),
        }
    }
}

/// A plant fault switched by a step.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultStep {
    /// Scenario time.
    pub at: Duration,
    /// The fault.
    pub fault: String,
    /// On or off.
    pub on: bool,
}

/// A simulated module silenced or made to answer again by a step.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModuleStep {
    /// Scenario time.
    pub at: Duration,
    /// The module's name in the project.
    pub module: String,
    /// Silent (true) or answering again.
    pub silent: bool,
}

/// A program to run the scenario with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramSpec {
    /// The file.
    pub path: PathBuf,
    /// Its language.
    pub kind: ProgramKind,
}

/// A validated scenario.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// The file.
    pub file: PathBuf,
    /// Its name (the file name when not given).
    pub name: String,
    /// The project, as loaded.
    pub project: Project,
    /// The program variants to run (empty: the project's programs).
    pub programs: Vec<ProgramVariant>,
    /// Tags recorded in the trace.
    pub watch: Vec<usize>,
    /// Keep the project's plant.
    pub plant: bool,
    /// Run length.
    pub until: Duration,
    /// Inputs, by time.
    pub sets: Vec<SetInput>,
    /// Expectations, by time.
    pub expects: Vec<Expect>,
    /// Plant states expected, by time.
    pub plant_expects: Vec<PlantExpect>,
    /// Plant faults switched, by time.
    pub faults: Vec<FaultStep>,
    /// Plant states recorded in the trace (`watch: [plant.position]`).
    pub watch_states: Vec<String>,
    /// Alarms expected and acknowledged, by time.
    pub alarm_steps: Vec<AlarmStep>,
    /// Modules silenced and answering again, by time.
    pub module_steps: Vec<ModuleStep>,
    /// Retained values expected after the run: tag name and value.
    pub retained: Vec<(String, Value)>,
}

/// Errors of a scenario file, each `file:line:col: error: message`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScenarioErrors(pub Vec<String>);

impl std::fmt::Display for ScenarioErrors {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0.join("\n"))
    }
}

/// The language of a program file, by its name.
pub(crate) fn kind_of(path: &Path) -> Option<ProgramKind> {
    let name = path.file_name()?.to_str()?;
    if name.ends_with(".rhai") {
        Some(ProgramKind::Rhai)
    } else if name.ends_with(".expr") {
        Some(ProgramKind::Expr)
    } else if name.ends_with(".yaml") || name.ends_with(".yml") {
        Some(ProgramKind::Ladder)
    } else {
        None
    }
}

/// Reads and validates a scenario file; every error found.
pub(crate) fn load(file: &Path) -> Result<Scenario, ScenarioErrors> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| ScenarioErrors(vec![format!("{}: error: {e}", file.display())]))?;
    parse(&text, file)
}

/// Validates scenario text as read from `file`.
pub fn parse(text: &str, file: &Path) -> Result<Scenario, ScenarioErrors> {
    let raw: RawScenario = yaml_serde::from_str(text).map_err(|e| {
        let (line, col) = e.location().map_or((1, 1), |l| (l.line(), l.column()));
        let mut msg = e.to_string();
        if let Some(at) = msg.find(" at line ") {
            msg.truncate(at);
        }
        ScenarioErrors(vec![format!(
            "{}:{line}:{col}: error: {msg}",
            file.display()
        )])
    })?;
    let loc = Locator::new(text);
    let mut errors = Vec::new();
    let mut error = |path: YPath, msg: String| {
        let (line, col) = loc.position(&path);
        errors.push(format!("{}:{line}:{col}: error: {msg}", file.display()));
    };
    let root = YPath::root();
    let folder = file.parent().unwrap_or(Path::new(""));
    let project = match project::load(&folder.join(&raw.project)) {
        Ok(p) => p,
        Err(e) => {
            error(root.key("project"), format!("the project has errors:\n{e}"));
            return Err(ScenarioErrors(errors));
        }
    };
    let tag = |name: &str| project.tags.iter().position(|t| t.name == name);
    let unknown = |name: &str| {
        let names = project.tags.iter().map(|t| t.name.as_str());
        format!(
            "unknown tag `{name}`{}",
            crate::suggest::did_you_mean(name, names)
        )
    };

    let (programs, variant_errors) =
        super::variants::read(&raw.programs, folder, &project, &root.key("programs"));
    for (at, msg) in variant_errors {
        error(at, msg);
    }

    let mut sets = Vec::new();
    let mut expects = Vec::new();
    let mut plant_expects = Vec::new();
    let mut faults = Vec::new();
    let mut alarm_steps = Vec::new();
    let mut module_steps = Vec::new();
    // The alarms the book has, as `softplc run` and the runner build it: the tags' alarms and
    // every module's `lost.MODULE`, whichever task owns them.
    let alarms = alarm_names(&project);
    let plant_on = raw.plant.unwrap_or(false);
    for (i, step) in raw.steps.iter().enumerate() {
        let at = step.at.0;
        let spath = root.key("steps").index(i);
        if step.set.is_none()
            && step.expect.is_none()
            && step.fault.is_none()
            && step.ack.is_none()
            && step.module.is_none()
        {
            error(
                spath.clone(),
                "a step needs `set:`, `expect:`, `fault:`, `module:` or `ack:`".into(),
            );
        }
        for (name, text) in step.module.iter().flat_map(|s| &s.0) {
            let kpath = spath.key("module").key_itself(name);
            let Some(m) = project.modules.iter().find(|m| m.name == *name) else {
                let names = project.modules.iter().map(|m| m.name.as_str());
                error(
                    kpath,
                    format!(
                        "no module `{name}`{}",
                        crate::suggest::did_you_mean(name, names)
                    ),
                );
                continue;
            };
            if project.buses[m.bus].port != PortConfig::Sim {
                error(
                    kpath,
                    format!("module `{name}` is not simulated (its bus is not `port: sim`)"),
                );
                continue;
            }
            match text.trim() {
                "silent" | "answers" => module_steps.push(ModuleStep {
                    at,
                    module: name.clone(),
                    silent: text.trim() == "silent",
                }),
                _ => error(
                    spath.key("module").key(name),
                    format!("`{text}` is not `silent` or `answers`"),
                ),
            }
        }
        let acks: Vec<(&String, YPath)> = match &step.ack {
            None => Vec::new(),
            Some(AckNames::One(name)) => vec![(name, spath.key("ack"))],
            Some(AckNames::Many(names)) => names
                .iter()
                .enumerate()
                .map(|(k, n)| (n, spath.key("ack").index(k)))
                .collect(),
        };
        for (name, apath) in acks {
            match check_name(&alarms, name, true) {
                Ok(()) => alarm_steps.push(AlarmStep {
                    at,
                    alarm: name.clone(),
                    kind: AlarmStepKind::Ack,
                    line: loc.line(&apath),
                }),
                Err(msg) => error(apath, msg),
            }
        }
        for (name, text) in step.fault.iter().flat_map(|s| &s.0) {
            let kpath = spath.key("fault").key_itself(name);
            match plant_has(&project, plant_on, PlantPart::Fault, name) {
                Err(msg) => error(kpath, msg),
                Ok(()) => match Comparison::parse(text) {
                    Some(Comparison::Level(on)) => faults.push(FaultStep {
                        at,
                        fault: name.clone(),
                        on,
                    }),
                    _ => error(
                        spath.key("fault").key(name),
                        format!("`{text}` is not on or off"),
                    ),
                },
            }
        }
        for (name, text) in step.set.iter().flat_map(|s| &s.0) {
            let kpath = spath.key("set").key_itself(name);
            let Some(t) = tag(name) else {
                error(kpath, unknown(name));
                continue;
            };
            let cfg = &project.tags[t];
            let Binding::Point { module, point } = cfg.binding else {
                error(
                    kpath,
                    format!("tag `{name}` is a memory tag; a scenario sets module inputs"),
                );
                continue;
            };
            let m = &project.modules[module];
            let spec = &m.model.points[point];
            if spec.access == Access::Output || project.buses[m.bus].port != PortConfig::Sim {
                error(
                    kpath,
                    format!(
                        "tag `{name}` is not an input of a simulated module (it is {}.{})",
                        m.name, spec.name
                    ),
                );
                continue;
            }
            match Value::parse(cfg.ty, text) {
                Some(value) => sets.push(SetInput {
                    at,
                    tag: name.clone(),
                    module: m.name.clone(),
                    point: spec.name.to_string(),
                    value,
                }),
                None => error(
                    spath.key("set").key(name),
                    format!("`{text}` is not a {}", cfg.ty),
                ),
            }
        }
        for (name, text) in step.expect.iter().flat_map(|s| &s.0) {
            let kpath = spath.key("expect").key_itself(name);
            if let Some(state) = name.strip_prefix(PLANT_PREFIX) {
                match (plant_has(&project, plant_on, PlantPart::State, state), Comparison::parse(text)) {
                    (Err(msg), _) => error(kpath, msg),
                    (Ok(()), Some(cmp)) => plant_expects.push(PlantExpect {
                        at,
                        state: state.to_owned(),
                        cmp,
                        line: loc.line(&kpath),
                    }),
                    (Ok(()), None) => error(
                        spath.key("expect").key(name),
                        format!(
                            "`{text}` is not a value or a comparison (>= 99, < 0.5, == 3, != 0, true)"
                        ),
                    ),
                }
                continue;
            }
            if let (None, Some(alarm)) = (tag(name), name.strip_prefix(ALARM_PREFIX)) {
                match (
                    check_name(&alarms, alarm, false),
                    AlarmState::parse_all(text),
                ) {
                    (Err(msg), _) => error(kpath, msg),
                    (Ok(()), Some(states)) => alarm_steps.push(AlarmStep {
                        at,
                        alarm: alarm.to_owned(),
                        kind: AlarmStepKind::Expect(states),
                        line: loc.line(&kpath),
                    }),
                    (Ok(()), None) => error(
                        spath.key("expect").key(name),
                        format!(
                            "`{text}` is not an alarm's state ({}, or several joined by commas)",
                            AlarmState::words()
                        ),
                    ),
                }
                continue;
            }
            let Some(t) = tag(name) else {
                error(kpath, unknown(name));
                continue;
            };
            let line = loc.line(&kpath);
            match Value::parse(project.tags[t].ty, text) {
                Some(value) => expects.push(Expect {
                    at,
                    tag: t,
                    value,
                    line,
                }),
                None => error(
                    spath.key("expect").key(name),
                    format!("`{text}` is not a {}", project.tags[t].ty),
                ),
            }
        }
    }
    let mut retained = Vec::new();
    for (name, text) in raw.expect_retained.iter().flat_map(|s| &s.0) {
        let kpath = root.key("expect_retained").key_itself(name);
        match tag(name) {
            Some(t) if project.tags[t].retain => match Value::parse(project.tags[t].ty, text) {
                Some(v) => retained.push((name.clone(), v)),
                None => error(kpath, format!("`{text}` is not a {}", project.tags[t].ty)),
            },
            Some(_) => error(
                kpath,
                format!("tag `{name}` is not retained (`retain: true`)"),
            ),
            None => error(kpath, unknown(name)),
        }
    }
    let mut watch = Vec::new();
    let mut watch_states = Vec::new();
    for (i, name) in raw.watch.iter().enumerate() {
        if let Some(state) = name.strip_prefix(PLANT_PREFIX) {
            match plant_has(&project, plant_on, PlantPart::State, state) {
                Ok(()) => watch_states.push(state.to_owned()),
                Err(msg) => error(root.key("watch").index(i), msg),
            }
            continue;
        }
        match tag(name) {
            Some(t) => watch.push(t),
            None => error(root.key("watch").index(i), unknown(name)),
        }
    }
    if raw.watch.is_empty() {
        watch = (0..project.tags.len())
            .filter(|&t| {
                expects.iter().any(|e| e.tag == t)
                    || matches!(project.tags[t].binding, Binding::Point { module, point }
                        if project.modules[module].model.points[point].access == Access::Output)
            })
            .collect();
    }
    if !errors.is_empty() {
        return Err(ScenarioErrors(errors));
    }
    sets.sort_by_key(|s| s.at);
    expects.sort_by_key(|e| e.at);
    plant_expects.sort_by_key(|e| e.at);
    faults.sort_by_key(|f| f.at);
    module_steps.sort_by_key(|m| m.at);
    let last = raw.steps.iter().map(|s| s.at.0).max().unwrap_or_default();
    Ok(Scenario {
        file: file.to_path_buf(),
        name: raw.name.unwrap_or_else(|| {
            file.file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
        }),
        project,
        programs,
        watch,
        plant: raw.plant.unwrap_or(false),
        until: raw.until.map_or(last + Duration::from_secs(1), |d| d.0),
        sets,
        expects,
        plant_expects,
        faults,
        watch_states,
        alarm_steps,
        module_steps,
        retained,
    })
}

/// How a scenario names a plant state: `plant.position`.
const PLANT_PREFIX: &str = "plant.";

/// The project's plant, when the scenario keeps it.
fn kept_plant(project: &Project, plant_on: bool) -> Result<&crate::plant::PlantModel, String> {
    match &project.plant {
        None => Err("the project has no plant".into()),
        Some(_) if !plant_on => {
            Err("the plant is removed unless the scenario says `plant: true`".into())
        }
        Some(p) => Ok(&p.model),
    }
}

/// What of the plant a scenario names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PlantPart {
    State,
    Fault,
}

/// Checks that the kept plant has the state (or fault) `name`.
fn plant_has(project: &Project, plant_on: bool, part: PlantPart, name: &str) -> Result<(), String> {
    let model = kept_plant(project, plant_on)?;
    let (what, all): (&str, Vec<&str>) = match part {
        PlantPart::State => (
            "state",
            model.decl.states.iter().map(|s| s.name.as_str()).collect(),
        ),
        PlantPart::Fault => (
            "fault",
            model.decl.faults.iter().map(|f| f.name.as_str()).collect(),
        ),
    };
    if all.contains(&name) {
        return Ok(());
    }
    Err(format!(
        "plant {} has no {what} `{name}` (its {what}s: {}){}",
        model.name,
        if all.is_empty() {
            "none".to_owned()
        } else {
            all.join(", ")
        },
        crate::suggest::did_you_mean(name, all.iter().copied())
    ))
}
