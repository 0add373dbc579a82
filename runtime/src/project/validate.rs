//! Raw project → validated [`Project`], collecting every error with its position.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use softplc_io::devices::{self, ModelSpec, Protocol};
use softplc_io::line::{LineSettings, SerialFormat};
use softplc_io::point::{Access, Value, ValueType};

use super::doc_text::{DocKind, DocText};
use super::error::{ErrorKind, Item, ProjectError};
use crate::plant::PlantModel;
use softplc_io::line::{NetFraming, TcpEndpoint};

use super::model::{
    Binding, BusConfig, ModuleConfig, PlantConfig, PortConfig, ProgramConfig, ProgramKind, Project,
    RealtimeConfig, ScanConfig, TagConfig, TaskConfig, WatchdogConfig, MAIN_TASK,
};
use softplc_io::line::{AdapterLatency, EchoMode, Rs485Mode};

use super::line_plan::Direction;

use super::raw::{
    Int, RawAdapterLatency, RawBus, RawModule, RawPlant, RawProgram, RawProject, RawRs485, RawScan,
    RawTag,
};
use super::span::{Locator, YPath};
use super::watchdog::WatchdogPolicy;
use softplc_io::devices::{DeviceConfig, ModuleAddress, PushDown, SettingError};

/// Default watchdog time, in periods.
const WATCHDOG_PERIODS: u32 = 5;
/// Default watchdog sensitivity.
const DEFAULT_SENSITIVITY: u32 = 3;
/// Default response timeout.
const DEFAULT_RESPONSE_TIMEOUT: Duration = Duration::from_millis(100);
/// Default retries.
const DEFAULT_RETRIES: u8 = 1;
/// Default output refresh.
const DEFAULT_OUTPUT_REFRESH: Duration = Duration::from_secs(1);
/// Every protocol, for names.
const PROTOCOLS: [Protocol; 2] = [Protocol::Modbus, Protocol::Text];
/// Program kinds, by project-file name.
const PROGRAM_KINDS: [(&str, ProgramKind); 3] = [
    ("expr", ProgramKind::Expr),
    ("ladder", ProgramKind::Ladder),
    ("rhai", ProgramKind::Rhai),
];
/// At most this many "did you mean" suggestions.
const MAX_SUGGESTIONS: usize = 5;

/// Validates `raw` (read from `text`, the file `file`); every error found, sorted by position.
pub(crate) fn validate(
    raw: &RawProject,
    text: &str,
    file: &Path,
) -> Result<Project, Vec<ProjectError>> {
    let mut v = Validator {
        loc: Locator::new(text),
        file,
        errors: Vec::new(),
    };
    let root = YPath::root();

    if raw.project.trim().is_empty() {
        v.error(root.key("project"), ErrorKind::EmptyProjectName);
    }
    let buses: Vec<Option<BusConfig>> = raw
        .buses
        .iter()
        .enumerate()
        .map(|(i, b)| v.bus(b, &root.key("buses").index(i)))
        .collect();
    v.duplicate_endpoints(&buses);
    v.duplicate_devices(&buses);
    let bus_index = v.names(
        Item::Bus,
        raw.buses.iter().map(|b| b.name.as_str()),
        "buses",
    );
    let modules = v.modules(raw, &buses, &bus_index);
    v.dcon_neighbours(raw, &modules);
    let module_index = v.names(
        Item::Module,
        raw.modules.iter().map(|m| m.name.as_str()),
        "modules",
    );
    let mut tags = v.tags(raw, &modules, &module_index);
    let blocks = super::user_blocks::load_all(&raw.blocks, file, &v.loc, &mut v.errors);
    let instances = blocks.as_ref().map(|blocks| {
        let names: Vec<&str> = raw.tags.iter().map(|t| t.name.as_str()).collect();
        let mut found = Vec::new();
        let instances = super::user_blocks::instances(
            &raw.instances,
            blocks,
            &mut tags,
            &names,
            &raw.modules
                .iter()
                .map(|m| m.name.as_str())
                .collect::<Vec<_>>(),
            &v.loc,
            |path, e| found.push((path, e)),
        );
        for (path, e) in found {
            v.error(path, e);
        }
        instances
    });
    let service = {
        let facts = super::scada::facts(raw, &tags, |m, p| {
            let model = modules.get(m).and_then(|(r, _)| r.model)?;
            model.points.get(p).map(|s| s.access)
        });
        let (config, errors) = super::scada::validate(raw, &facts, &v.loc, file);
        for (path, e) in errors {
            v.error(path, e.into());
        }
        config
    };
    let tasks = v.tasks(raw, &bus_index);
    let retain = {
        let (config, errors) = super::retain::validate(raw.retain.as_ref(), file);
        for (path, e) in errors {
            v.error(path, e);
        }
        config
    };
    let offload = {
        let module = |m: usize| modules.get(m).and_then(|(_, c)| c.as_ref());
        let (config, errors) = super::offload::validate(raw, &tags, module);
        for (path, e) in errors {
            v.error(path, e);
        }
        config
    };
    let traces = super::trace::validate_all(raw, &tags, |path, e| v.error(path, e.into()));
    let trace_budget = {
        let (budget, errors) = super::trace_budget::validate(raw.trace_budget.as_ref());
        let names: Vec<&str> = raw.traces.iter().map(|t| t.name.as_str()).collect();
        let start = super::trace_budget::check_start_traces(budget, &traces, &names);
        for (path, e) in errors.into_iter().chain(start) {
            v.error(path, e);
        }
        budget
    };
    let alarms = super::alarm::validate_all(raw, &tags, |path, e| v.error(path, e));
    let recorder = {
        let (config, errors) = super::recorder::validate(raw.recorder.as_ref(), file);
        for (path, e) in errors {
            v.error(path, e);
        }
        config
    };
    let plant = match &raw.plant {
        Some(p) => v.plant(p, raw, &buses, &modules, &module_index).map(Some),
        None => Some(None),
    };

    let mut errors = v.errors;
    let built = (|| {
        Some(Project {
            name: raw.project.clone(),
            source: file.to_path_buf(),
            scan: tasks.as_ref()?.first()?.scan.clone(),
            buses: buses.into_iter().collect::<Option<Vec<_>>>()?,
            modules: modules
                .into_iter()
                .map(|(_, c)| c)
                .collect::<Option<Vec<_>>>()?,
            tags: tags.into_iter().collect::<Option<Vec<_>>>()?,
            programs: tasks.as_ref()?.first()?.programs.clone(),
            tasks: tasks?,
            blocks: blocks?,
            instances: instances?,
            plant: plant?,
            service: service?,
            retain: retain?,
            offload: offload?,
            recorder,
            traces,
            trace_budget,
            alarms,
        })
    })();
    match built {
        Some(mut project) if errors.is_empty() => {
            // What softplc plans for each line (tuning, the input mode), then the modules'
            // own watchdogs, now that the scan and the lines are known.
            super::line_plan::apply(&mut project);
            super::watchdog::arm(&mut project);
            Ok(project)
        }
        _ => {
            if errors.is_empty() {
                // Every refusal above records an error; this is a guard, not a path.
                errors.push(ProjectError {
                    file: file.to_path_buf(),
                    line: 1,
                    column: 1,
                    kind: ErrorKind::Yaml {
                        message: "internal error: incomplete project".into(),
                    },
                });
            }
            errors.sort_by_key(|e| (e.line, e.column));
            Err(errors)
        }
    }
}

/// Is `name` an identifier (`[A-Za-z_][A-Za-z0-9_]*`)?
pub(crate) fn is_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// A module as far as it could be resolved (for tags and the plant, even when the module
/// itself has errors elsewhere).
#[derive(Debug, Clone, Copy)]
struct Resolved {
    /// Its bus, if known.
    bus: Option<usize>,
    /// Its model, if known.
    model: Option<&'static ModelSpec>,
}

/// A resolved point reference.
#[derive(Debug, Clone, Copy)]
struct PointRef {
    module: usize,
    point: usize,
    spec: &'static softplc_io::point::PointSpec,
}

struct Validator<'a> {
    loc: Locator<'a>,
    file: &'a Path,
    errors: Vec<ProjectError>,
}

/// A module's model read from a profile file: `model: profile:PATH`.
const PROFILE_PREFIX: &str = "profile:";

impl Validator<'_> {
    /// The model of the profile at `rel` (relative to the project file's folder); its errors
    /// are the profile file's own, and one at the module's `model:` says it was refused.
    fn profile_model(&mut self, rel: &str, at: &YPath) -> Option<&'static ModelSpec> {
        let rel = rel.trim();
        let dir = self.file.parent().unwrap_or(Path::new(""));
        let file = dir.join(rel);
        if !file.is_file() {
            let message = match std::fs::metadata(&file) {
                Ok(_) => "not a file".to_owned(),
                Err(e) => e.to_string(),
            };
            let e = crate::project::profile::ProfileError::Unreadable {
                path: rel.to_owned(),
                message,
            };
            self.error(at.clone(), ErrorKind::Profile(e));
            return None;
        }
        match crate::project::profile::load(&file) {
            Ok(profile) => Some(softplc_io::devices::profile::model_of(profile)),
            Err(errors) => {
                let count = errors.len();
                self.errors.extend(errors.errors);
                let e = crate::project::profile::ProfileError::Refused {
                    path: rel.to_owned(),
                    count,
                };
                self.error(at.clone(), ErrorKind::Profile(e));
                None
            }
        }
    }

    fn error(&mut self, path: YPath, kind: ErrorKind) {
        let (line, column) = self.loc.position(&path);
        self.errors.push(ProjectError {
            file: self.file.to_path_buf(),
            line,
            column,
            kind,
        });
    }

    /// Checks that names are identifiers and unique; returns name → first index.
    fn names<'n>(
        &mut self,
        item: Item,
        names: impl Iterator<Item = &'n str>,
        list: &str,
    ) -> HashMap<String, usize> {
        let mut index: HashMap<String, usize> = HashMap::new();
        for (i, name) in names.enumerate() {
            let path = YPath::root().key(list).index(i).key("name");
            if !is_identifier(name) {
                // Still indexed, so references to it do not add "unknown" errors.
                self.error(
                    path.clone(),
                    ErrorKind::InvalidName {
                        item,
                        name: name.to_owned(),
                    },
                );
            }
            match index.get(name) {
                Some(&first) => {
                    let first_line = self
                        .loc
                        .line(&YPath::root().key(list).index(first).key("name"));
                    self.error(
                        path,
                        ErrorKind::DuplicateName {
                            item,
                            name: name.to_owned(),
                            first_line,
                        },
                    );
                }
                None => {
                    index.insert(name.to_owned(), i);
                }
            }
        }
        index
    }

    fn positive(&mut self, d: Duration, path: YPath, key: &'static str) -> Option<Duration> {
        if d.is_zero() {
            self.error(path, ErrorKind::ZeroDuration { key });
            None
        } else {
            Some(d)
        }
    }

    /// The project's tasks: the one `scan:` and `program:` describe (`main`, owning every
    /// bus), or the `tasks:` list, each bus owned by exactly one task.
    fn tasks(
        &mut self,
        raw: &RawProject,
        bus_index: &HashMap<String, usize>,
    ) -> Option<Vec<TaskConfig>> {
        let root = YPath::root();
        let Some(list) = &raw.tasks else {
            let scan = match &raw.scan {
                Some(scan) => self.scan(scan, &root.key("scan"), "scan.period"),
                None => {
                    match raw.program.is_some() || raw.programs.is_some() {
                        true => self.error(
                            root.clone(),
                            ErrorKind::MissingKey {
                                section: String::new(),
                                key: "scan".into(),
                            },
                        ),
                        false => self.error(root.clone(), ErrorKind::NoTask),
                    }
                    None
                }
            };
            let programs = self.programs(
                raw.program.as_ref(),
                raw.programs.as_deref(),
                &root,
                raw.scan.is_some(),
            );
            return Some(vec![TaskConfig {
                name: MAIN_TASK.to_owned(),
                scan: scan?,
                programs: programs?,
                buses: (0..raw.buses.len()).collect(),
                copied_io: Vec::new(),
            }]);
        };
        for (key, given) in [
            ("scan", raw.scan.is_some()),
            ("program", raw.program.is_some()),
            ("programs", raw.programs.is_some()),
        ] {
            if given {
                self.error(root.key(key), ErrorKind::TasksBesideScan { key });
            }
        }
        if list.is_empty() {
            self.error(root.key("tasks"), ErrorKind::NoTasks);
            return None;
        }
        self.names(Item::Task, list.iter().map(|t| t.name.as_str()), "tasks");
        // Bus → (task, the path of its naming), for the second naming's error.
        let mut owner: Vec<Option<(usize, YPath)>> = vec![None; raw.buses.len()];
        let mut tasks = Vec::with_capacity(list.len());
        for (i, t) in list.iter().enumerate() {
            let path = root.key("tasks").index(i);
            let scan = self.scan(&t.scan(), &path, "period");
            let programs = self.programs(t.program.as_ref(), t.programs.as_deref(), &path, true);
            let mut buses = Vec::with_capacity(t.buses.len());
            for (j, name) in t.buses.iter().enumerate() {
                let at = path.key("buses").index(j);
                let Some(&b) = bus_index.get(name) else {
                    let known = raw.buses.iter().map(|b| b.name.clone()).collect();
                    let kind = ErrorKind::UnknownBus {
                        name: name.clone(),
                        known,
                    };
                    self.error(at, kind);
                    continue;
                };
                match &owner[b] {
                    Some((first, first_at)) => {
                        let kind = ErrorKind::BusOwnedTwice {
                            bus: name.clone(),
                            first: list[*first].name.clone(),
                            first_line: self.loc.line(first_at),
                        };
                        self.error(at, kind);
                    }
                    None => {
                        owner[b] = Some((i, at));
                        buses.push(b);
                    }
                }
            }
            tasks.push(scan.zip(programs).map(|(scan, programs)| TaskConfig {
                name: t.name.clone(),
                scan,
                programs,
                buses,
                copied_io: Vec::new(),
            }));
        }
        for (b, bus) in raw.buses.iter().enumerate() {
            if owner[b].is_none() && bus_index.get(&bus.name) == Some(&b) {
                let kind = ErrorKind::BusWithoutTask {
                    bus: bus.name.clone(),
                };
                self.error(root.key("buses").index(b).key("name"), kind);
            }
        }
        tasks.into_iter().collect()
    }

    fn scan(
        &mut self,
        raw: &RawScan,
        path: &YPath,
        period_key: &'static str,
    ) -> Option<ScanConfig> {
        let period = self.positive(raw.period.0, path.key("period"), period_key);

        let wd = raw.watchdog.clone().unwrap_or_default();
        let wd_path = path.key("watchdog");
        let time = match wd.time {
            Some(t) => self.positive(t.0, wd_path.key("time"), "watchdog time"),
            None => period.map(|p| p.saturating_mul(WATCHDOG_PERIODS)),
        };
        let sensitivity = match wd.sensitivity {
            None => Some(DEFAULT_SENSITIVITY),
            Some(Int(s)) => match u32::try_from(s) {
                Ok(s) if s >= 1 => Some(s),
                _ => {
                    self.error(
                        wd_path.key("sensitivity"),
                        ErrorKind::BadSensitivity { value: s },
                    );
                    None
                }
            },
        };

        let rt = raw.realtime.clone().unwrap_or_default();
        let rt_path = path.key("realtime");
        let priority = match rt.priority {
            None => Some(None),
            Some(Int(p)) => match u8::try_from(p) {
                Ok(p @ 1..=99) => Some(Some(p)),
                _ => {
                    self.error(rt_path.key("priority"), ErrorKind::BadPriority { value: p });
                    None
                }
            },
        };
        let cpu = match rt.cpu {
            None => Some(None),
            Some(Int(c)) => match usize::try_from(c) {
                Ok(c) => Some(Some(c)),
                Err(_) => {
                    self.error(rt_path.key("cpu"), ErrorKind::BadCpu { value: c });
                    None
                }
            },
        };

        Some(ScanConfig {
            period: period?,
            watchdog: WatchdogConfig {
                time: time?,
                sensitivity: sensitivity?,
            },
            realtime: RealtimeConfig {
                priority: priority?,
                cpu: cpu?,
                lock_memory: rt.lock_memory.unwrap_or(false),
            },
        })
    }

    fn bus(&mut self, raw: &RawBus, path: &YPath) -> Option<BusConfig> {
        let port = if raw.port == "sim" {
            Some(PortConfig::Sim)
        } else if raw.port.contains("://") {
            match TcpEndpoint::parse(&raw.port) {
                Ok(Some(e)) => Some(PortConfig::Tcp(e)),
                Ok(None) => None,
                Err(reason) => {
                    self.error(
                        path.key("port"),
                        ErrorKind::BadPortUrl {
                            port: raw.port.clone(),
                            reason,
                        },
                    );
                    None
                }
            }
        } else if raw.port.contains('/') {
            Some(PortConfig::Serial(PathBuf::from(&raw.port)))
        } else {
            self.error(
                path.key("port"),
                ErrorKind::BadPort {
                    port: raw.port.clone(),
                },
            );
            None
        };
        let baud = match raw.baud {
            None => Some(LineSettings::DEFAULT.baud),
            Some(Int(b)) => match u32::try_from(b) {
                Ok(b) if b > 0 => Some(b),
                _ => {
                    self.error(path.key("baud"), ErrorKind::BadBaud { value: b });
                    None
                }
            },
        };
        let format = match &raw.format {
            None => Some(LineSettings::DEFAULT.format),
            Some(f) => match f.parse::<SerialFormat>() {
                Ok(f) => Some(f),
                Err(_) => {
                    self.error(
                        path.key("format"),
                        ErrorKind::BadFormat { format: f.clone() },
                    );
                    None
                }
            },
        };
        let response_timeout = match raw.response_timeout {
            None => Some(DEFAULT_RESPONSE_TIMEOUT),
            Some(t) => self.positive(t.0, path.key("response_timeout"), "response_timeout"),
        };
        let retries = match raw.retries {
            None => Some(DEFAULT_RETRIES),
            Some(Int(r)) => match u8::try_from(r) {
                Ok(r) => Some(r),
                Err(_) => {
                    self.error(path.key("retries"), ErrorKind::BadRetries { value: r });
                    None
                }
            },
        };
        let output_refresh = match raw.output_refresh {
            None => Some(DEFAULT_OUTPUT_REFRESH),
            Some(t) => self.positive(t.0, path.key("output_refresh"), "output_refresh"),
        };
        let rs485 = match &raw.rs485 {
            None => Some(None),
            Some(r) => self.rs485(r, &port, &path.key("rs485")),
        };
        let echo = match raw.echo.as_deref().map(str::parse::<EchoMode>) {
            None => Some(EchoMode::None),
            Some(Ok(e)) => Some(e),
            Some(Err(_)) => {
                self.error(path.key("echo"), ErrorKind::BadEcho);
                None
            }
        };
        let adapter_latency =
            self.adapter_latency(raw.adapter_latency, &port, &path.key("adapter_latency"));
        if let Some(scheme) = port.as_ref().and_then(PortConfig::scheme) {
            self.network_bus_keys(raw, scheme, path);
        }
        let direction = match raw.direction.as_deref().map(str::parse::<Direction>) {
            None => Some(Direction::default()),
            Some(Ok(d)) => Some(d),
            Some(Err(())) => {
                self.error(path.key("direction"), ErrorKind::BadDirection);
                None
            }
        };
        let tune_reply_delay = match raw.tune.as_deref() {
            None => Some(false),
            Some(super::line_plan::tune::REPLY_DELAY) => Some(true),
            Some(_) => {
                self.error(path.key("tune"), ErrorKind::BadTune);
                None
            }
        };
        let bus = BusConfig {
            direction: direction?,
            tune_reply_delay: tune_reply_delay?,
            plan: Default::default(),
            rs485: rs485?,
            echo: echo?,
            adapter_latency: adapter_latency?,
            name: raw.name.clone(),
            port: port?,
            settings: LineSettings {
                baud: baud?,
                format: format?,
            },
            response_timeout: response_timeout?,
            retries: retries?,
            output_refresh: output_refresh?,
        };
        if bus.tune_reply_delay {
            if let Err(why) = super::line_plan::direction::turnaround(&bus) {
                self.error(path.key("tune"), ErrorKind::TuneNeedsFastTurn { why });
                return None;
            }
        }
        Some(bus)
    }

    /// Refuses the keys of a local serial port on a network bus: a Modbus TCP bus has no
    /// serial line at all; an RTU-over-TCP bus has the server's (`baud`, `format`), but no
    /// UART or adapter here.
    fn network_bus_keys(&mut self, raw: &RawBus, scheme: &'static str, path: &YPath) {
        let modbus_tcp = scheme == NetFraming::ModbusTcp.scheme();
        let serial_hint = ": the gateway's RTU side is set in the gateway";
        let local_hint = ": that is the serial server's own business";
        let keys: [(&'static str, bool, &'static str); 6] = [
            ("baud", modbus_tcp && raw.baud.is_some(), serial_hint),
            ("format", modbus_tcp && raw.format.is_some(), serial_hint),
            ("rs485", raw.rs485.is_some(), local_hint),
            ("echo", raw.echo.is_some(), local_hint),
            ("direction", raw.direction.is_some(), local_hint),
            (
                "adapter_latency",
                matches!(raw.adapter_latency, Some(RawAdapterLatency::Given(_))),
                local_hint,
            ),
        ];
        for (key, given, hint) in keys {
            if given {
                self.error(
                    path.key(key),
                    ErrorKind::NotOnNetworkBus { key, scheme, hint },
                );
            }
        }
    }

    /// Refuses a second bus on a serial device another bus has: one line has one baud and
    /// format, and the second opener would find the port locked. Paths are compared resolved
    /// where the device exists (a `/dev/serial/by-id/` link and its `ttyUSB0` are one device),
    /// as written where it does not.
    fn duplicate_devices(&mut self, buses: &[Option<BusConfig>]) {
        let mut seen: Vec<(PathBuf, usize)> = Vec::new();
        for (b, bus) in buses.iter().enumerate() {
            let Some(BusConfig {
                port: PortConfig::Serial(path),
                ..
            }) = bus
            else {
                continue;
            };
            let device = std::fs::canonicalize(path).unwrap_or_else(|_| path.clone());
            match seen.iter().find(|(d, _)| *d == device) {
                Some(&(_, o)) => {
                    let root = YPath::root().key("buses");
                    let other_line = self.loc.line(&root.index(o).key("port"));
                    let (other, other_path) = buses[o]
                        .as_ref()
                        .map(|c| (c.name.clone(), c.port.clone()))
                        .unzip();
                    let same = match other_path {
                        Some(PortConfig::Serial(p)) if p != *path => {
                            format!(" (both are {})", device.display())
                        }
                        _ => String::new(),
                    };
                    self.error(
                        root.index(b).key("port"),
                        ErrorKind::DuplicateDevice {
                            port: path.display().to_string(),
                            same,
                            other: other.unwrap_or_default(),
                            other_line,
                        },
                    );
                }
                None => seen.push((device, b)),
            }
        }
    }

    /// Refuses a second bus on an endpoint another bus has (one connection per endpoint).
    fn duplicate_endpoints(&mut self, buses: &[Option<BusConfig>]) {
        let mut seen: Vec<(&TcpEndpoint, usize)> = Vec::new();
        for (b, bus) in buses.iter().enumerate() {
            let Some(BusConfig {
                port: PortConfig::Tcp(e),
                ..
            }) = bus
            else {
                continue;
            };
            let other = seen
                .iter()
                .find(|(o, _)| o.host == e.host && o.port == e.port);
            match other {
                Some(&(_, o)) => {
                    let root = YPath::root().key("buses");
                    let other_line = self.loc.line(&root.index(o).key("port"));
                    let other = buses[o]
                        .as_ref()
                        .map(|c| c.name.clone())
                        .unwrap_or_default();
                    self.error(
                        root.index(b).key("port"),
                        ErrorKind::DuplicateEndpoint {
                            endpoint: e.to_string(),
                            other,
                            other_line,
                        },
                    );
                }
                None => seen.push((e, b)),
            }
        }
    }

    /// A bus's `adapter_latency:`: `auto` anywhere, a duration on a device port only, in whole
    /// ms up to the 255 ms an FTDI latency timer holds.
    fn adapter_latency(
        &mut self,
        raw: Option<RawAdapterLatency>,
        port: &Option<PortConfig>,
        path: &YPath,
    ) -> Option<AdapterLatency> {
        match raw {
            None | Some(RawAdapterLatency::Auto) => Some(AdapterLatency::Auto),
            Some(RawAdapterLatency::Given(_)) if matches!(port, Some(PortConfig::Sim)) => {
                self.error(path.clone(), ErrorKind::AdapterLatencyOnSim);
                None
            }
            Some(RawAdapterLatency::Given(d))
                if d > AdapterLatency::MAX || d.subsec_nanos() % 1_000_000 != 0 =>
            {
                self.error(path.clone(), ErrorKind::BadAdapterLatency);
                None
            }
            Some(RawAdapterLatency::Given(d)) => Some(AdapterLatency::AtMost(d)),
        }
    }

    /// A bus's `rs485:`: on a device port only, delays in whole ms up to the kernel's 100 ms.
    fn rs485(
        &mut self,
        raw: &RawRs485,
        port: &Option<PortConfig>,
        path: &YPath,
    ) -> Option<Option<Rs485Mode>> {
        if matches!(port, Some(PortConfig::Sim)) {
            self.error(path.clone(), ErrorKind::Rs485OnSim);
            return None;
        }
        let mut delay = |d: Option<super::raw::DurationText>, name: &str, key: &'static str| {
            let d = d.map_or(Duration::ZERO, |d| d.0);
            if d > Rs485Mode::MAX_DELAY || d.subsec_nanos() % 1_000_000 != 0 {
                self.error(path.key(name), ErrorKind::BadRs485Delay { key });
                None
            } else {
                Some(d)
            }
        };
        let before = delay(
            raw.delay_before_send,
            "delay_before_send",
            "rs485.delay_before_send",
        );
        let after = delay(
            raw.delay_after_send,
            "delay_after_send",
            "rs485.delay_after_send",
        );
        Some(Some(Rs485Mode {
            rts_on_send: raw.rts_on_send.unwrap_or(true),
            delay_before_send: before?,
            delay_after_send: after?,
        }))
    }

    /// MiniMods whose text commands an EX-9053 on their bus answers (see `dcon_neighbours`).
    fn dcon_neighbours(&mut self, raw: &RawProject, modules: &[(Resolved, Option<ModuleConfig>)]) {
        let configs = modules.iter().map(|(_, c)| c.as_ref());
        for (mm, ex) in super::dcon_neighbours::clashes(configs) {
            let (Some(Some(mm_cfg)), Some(Some(ex_cfg))) =
                (modules.get(mm).map(|m| &m.1), modules.get(ex).map(|m| &m.1))
            else {
                continue;
            };
            let at = |i: usize| YPath::root().key("modules").index(i).key("address");
            let kind = ErrorKind::HeardByDcon {
                module: mm_cfg.name.clone(),
                address: mm_cfg.device.address.get(),
                other: ex_cfg.name.clone(),
                dcon: ex_cfg.device.address.get(),
                bus: raw
                    .buses
                    .get(mm_cfg.bus)
                    .map(|b| b.name.clone())
                    .unwrap_or_default(),
                other_line: self.loc.line(&at(ex)),
            };
            self.error(at(mm), kind);
        }
    }

    /// Validates every module; returns, per module, what could be resolved and the config.
    fn modules(
        &mut self,
        raw: &RawProject,
        buses: &[Option<BusConfig>],
        bus_index: &HashMap<String, usize>,
    ) -> Vec<(Resolved, Option<ModuleConfig>)> {
        let mut addresses: HashMap<(usize, u8), usize> = HashMap::new();
        let mut out = Vec::with_capacity(raw.modules.len());
        for (i, m) in raw.modules.iter().enumerate() {
            let path = YPath::root().key("modules").index(i);
            let r = self.module(raw, i, m, &path, buses, bus_index, &mut addresses);
            out.push(r);
        }
        out
    }

    #[allow(clippy::too_many_arguments)]
    fn module(
        &mut self,
        raw: &RawProject,
        i: usize,
        m: &RawModule,
        path: &YPath,
        buses: &[Option<BusConfig>],
        bus_index: &HashMap<String, usize>,
        addresses: &mut HashMap<(usize, u8), usize>,
    ) -> (Resolved, Option<ModuleConfig>) {
        let bus = bus_index.get(&m.bus).copied();
        if bus.is_none() {
            let known = raw.buses.iter().map(|b| b.name.clone()).collect();
            self.error(
                path.key("bus"),
                ErrorKind::UnknownBus {
                    name: m.bus.clone(),
                    known,
                },
            );
        }
        let model = match m.model.strip_prefix(PROFILE_PREFIX) {
            Some(rel) => self.profile_model(rel, &path.key("model")),
            None => devices::model(&m.model),
        };
        if model.is_none() && !m.model.starts_with(PROFILE_PREFIX) {
            let known = devices::catalog().iter().map(|s| s.name).collect();
            self.error(
                path.key("model"),
                ErrorKind::UnknownModel {
                    name: m.model.clone(),
                    known,
                },
            );
        }
        let resolved = Resolved { bus, model };
        let Some(model) = model else {
            return (resolved, None);
        };

        // Address: in the model's range, unique on its bus.
        let address = match u8::try_from(m.address.0) {
            Ok(a) if model.addresses.contains(&a) => Some(a),
            _ => {
                self.error(
                    path.key("address"),
                    ErrorKind::AddressOutOfRange {
                        address: m.address.0,
                        model: model.name,
                        min: *model.addresses.start(),
                        max: *model.addresses.end(),
                    },
                );
                None
            }
        };
        if let (Some(b), Some(a)) = (bus, address) {
            match addresses.get(&(b, a)) {
                Some(&other) => {
                    let other_line = self
                        .loc
                        .line(&YPath::root().key("modules").index(other).key("address"));
                    let kind = ErrorKind::DuplicateAddress {
                        address: a,
                        bus: m.bus.clone(),
                        other: raw
                            .modules
                            .get(other)
                            .map(|o| o.name.clone())
                            .unwrap_or_default(),
                        other_line,
                    };
                    self.error(path.key("address"), kind);
                }
                None => {
                    addresses.insert((b, a), i);
                }
            }
        }

        // Baud rate of its bus.
        if let Some(Some(bus_cfg)) = bus.and_then(|b| buses.get(b)) {
            let baud = bus_cfg.settings.baud;
            if baud > model.max_baud {
                let bus_path = YPath::root().key("buses").index(bus.unwrap_or(0));
                let baud_line = self.loc.line(&bus_path.key("baud"));
                let kind = ErrorKind::BaudTooHigh {
                    module: m.name.clone(),
                    model: model.name,
                    max: model.max_baud,
                    bus: m.bus.clone(),
                    baud,
                    baud_line,
                };
                self.error(path.key("bus"), kind);
            }
        }

        // Protocol.
        let supported: Vec<&'static str> = model.protocols.iter().map(|p| p.name()).collect();
        let protocol = match &m.protocol {
            None => match model.protocols.first() {
                Some(&p) => Some(p),
                None => {
                    let kind = ErrorKind::ProtocolNotSupported {
                        protocol: Protocol::Modbus.name(),
                        model: model.name,
                        supported,
                    };
                    self.error(path.key("model"), kind);
                    None
                }
            },
            Some(name) => match PROTOCOLS.iter().find(|p| p.name() == name) {
                None => {
                    let known = PROTOCOLS.iter().map(|p| p.name()).collect();
                    self.error(
                        path.key("protocol"),
                        ErrorKind::UnknownProtocol {
                            name: name.clone(),
                            known,
                        },
                    );
                    None
                }
                Some(&p) if model.protocols.contains(&p) => Some(p),
                Some(&p) => {
                    let kind = ErrorKind::ProtocolNotSupported {
                        protocol: p.name(),
                        model: model.name,
                        supported,
                    };
                    self.error(path.key("protocol"), kind);
                    None
                }
            },
        };

        if let (Some(Protocol::Text), Some(Some(bus_cfg))) =
            (protocol, bus.and_then(|b| buses.get(b)))
        {
            if bus_cfg.port.is_modbus_tcp() {
                let at = if m.protocol.is_some() {
                    path.key("protocol")
                } else {
                    path.key("model")
                };
                let kind = ErrorKind::TextOnModbusTcp {
                    module: m.name.clone(),
                    model: model.name,
                    bus: m.bus.clone(),
                };
                self.error(at, kind);
            }
        }

        // Settings.
        // Parsed once, by the model; every later reader works on the typed value.
        let text = m.settings.clone().unwrap_or_default().0;
        let settings = match model.parse(&text) {
            Ok(settings) => Some(settings),
            Err(errors) => {
                for e in errors {
                    let Some((key, value)) = text.get(e.index) else {
                        continue;
                    };
                    let mut message = e.error.describe(value);
                    if let SettingError::UnknownKey { .. } = e.error {
                        let close = close_matches(key, &(model.setting_keys)());
                        if !close.is_empty() {
                            message.push_str(&format!("; did you mean {}?", close.join(", ")));
                        }
                    }
                    let kind = ErrorKind::BadSetting {
                        module: m.name.clone(),
                        key: key.clone(),
                        message,
                    };
                    self.error(path.key("settings").key(key), kind);
                }
                None
            }
        };

        // A setting that does nothing on the module's protocol (a DCON-only one on a module
        // speaking Modbus): refused, not ignored.
        let off_protocol = settings
            .as_ref()
            .zip(protocol)
            .and_then(|(s, p)| model.family.off_protocol(s, p));
        let settings = match (settings, off_protocol) {
            (Some(_), Some(off)) => {
                let key = text
                    .iter()
                    .map(|(k, _)| k)
                    .find(|k| k.eq_ignore_ascii_case(off.key))
                    .cloned()
                    .unwrap_or_else(|| off.key.to_owned());
                let kind = ErrorKind::BadSetting {
                    module: m.name.clone(),
                    message: off.to_string(),
                    key: key.clone(),
                };
                self.error(path.key("settings").key(&key), kind);
                None
            }
            (settings, _) => settings,
        };

        // The module's own watchdog (see `watchdog.rs`).
        let policy = match &m.watchdog {
            None => Some(WatchdogPolicy::Auto),
            Some(text) => {
                let parsed = super::watchdog::parse_policy(&text.0).and_then(|p| {
                    let conflict = settings
                        .as_ref()
                        .and_then(|s| model.family.watchdog_conflict(s));
                    match conflict {
                        Some(why) if p == WatchdogPolicy::Off => Err(why.to_string()),
                        _ => Ok(p),
                    }
                });
                match parsed {
                    Ok(p) => Some(p),
                    Err(message) => {
                        let kind = ErrorKind::BadSetting {
                            module: m.name.clone(),
                            key: super::watchdog::KEY.into(),
                            message,
                        };
                        self.error(path.key(super::watchdog::KEY), kind);
                        None
                    }
                }
            }
        };

        if let (Some(settings), Some(Some(bus_cfg))) = (&settings, bus.and_then(|b| buses.get(b))) {
            if bus_cfg.port.is_modbus_tcp() {
                for key in model.family.text_only_settings(settings) {
                    self.error(
                        path.key("settings").key(key),
                        ErrorKind::TextSettingOnModbusTcp { key },
                    );
                }
            }
        }
        let address = address.and_then(|a| ModuleAddress::new(model, a).ok());
        let description = self.description(Item::Module, &m.name, m.description.as_deref(), path);
        let config = match (bus, address, protocol, settings, policy, description) {
            (
                Some(bus),
                Some(address),
                Some(protocol),
                Some(settings),
                Some(policy),
                Some(description),
            ) => Some(ModuleConfig {
                name: m.name.clone(),
                description,
                bus,
                model,
                device: DeviceConfig {
                    name: m.name.clone(),
                    address,
                    protocol,
                    settings,
                    push_down: PushDown::None,
                },
                watchdog: super::watchdog::ModuleWatchdog {
                    policy,
                    ..Default::default()
                },
            }),
            _ => None,
        };
        (resolved, config)
    }

    /// Resolves `module.POINT`, reporting at `path`. `None` (no error recorded) when the
    /// module exists but its model is unknown: that error is already reported.
    fn point_ref(
        &mut self,
        text: &str,
        path: &YPath,
        raw: &RawProject,
        modules: &[(Resolved, Option<ModuleConfig>)],
        module_index: &HashMap<String, usize>,
    ) -> Result<PointRef, bool> {
        let Some((module_name, point_name)) = text
            .split_once('.')
            .filter(|(m, p)| !m.is_empty() && !p.is_empty())
        else {
            self.error(
                path.clone(),
                ErrorKind::BadPointRef {
                    text: text.to_owned(),
                },
            );
            return Err(true);
        };
        let Some(&module) = module_index.get(module_name) else {
            let known = raw.modules.iter().map(|m| m.name.clone()).collect();
            self.error(
                path.clone(),
                ErrorKind::UnknownModule {
                    name: module_name.to_owned(),
                    known,
                },
            );
            return Err(true);
        };
        let Some(model) = modules.get(module).and_then(|(r, _)| r.model) else {
            return Err(false);
        };
        match model.point_index(point_name) {
            Some(point) => match model.points.get(point) {
                Some(spec) => Ok(PointRef {
                    module,
                    point,
                    spec,
                }),
                None => Err(false),
            },
            None => {
                let all: Vec<&'static str> = model.points.iter().map(|p| p.name).collect();
                let close = close_matches(point_name, &all);
                let kind = ErrorKind::UnknownPoint {
                    module: module_name.to_owned(),
                    model: model.name,
                    point: point_name.to_owned(),
                    close,
                    all,
                };
                self.error(path.clone(), kind);
                Err(true)
            }
        }
    }

    fn tags(
        &mut self,
        raw: &RawProject,
        modules: &[(Resolved, Option<ModuleConfig>)],
        module_index: &HashMap<String, usize>,
    ) -> Vec<Option<TagConfig>> {
        // Validate names first so duplicate-name errors do not depend on tag order.
        self.names(Item::Tag, raw.tags.iter().map(|t| t.name.as_str()), "tags");
        let mut owners: HashMap<(usize, usize), usize> = HashMap::new();
        let mut out = Vec::with_capacity(raw.tags.len());
        for (i, t) in raw.tags.iter().enumerate() {
            let path = YPath::root().key("tags").index(i);
            out.push(self.tag(raw, i, t, &path, modules, module_index, &mut owners));
        }
        out
    }

    #[allow(clippy::too_many_arguments)]
    fn tag(
        &mut self,
        raw: &RawProject,
        i: usize,
        t: &RawTag,
        path: &YPath,
        modules: &[(Resolved, Option<ModuleConfig>)],
        module_index: &HashMap<String, usize>,
        owners: &mut HashMap<(usize, usize), usize>,
    ) -> Option<TagConfig> {
        let declared = match &t.ty {
            None => Some(None),
            Some(name) => match ValueType::parse(name) {
                Some(ty) => Some(Some(ty)),
                None => {
                    self.error(
                        path.key("type"),
                        ErrorKind::UnknownType { name: name.clone() },
                    );
                    None
                }
            },
        };

        // Binding and type.
        let (binding, ty, point) = match (&t.point, declared) {
            (Some(text), declared) => {
                let r = self
                    .point_ref(text, &path.key("point"), raw, modules, module_index)
                    .ok()?;
                if let Some(Some(d)) = declared {
                    if d != r.spec.ty {
                        let kind = ErrorKind::TypeMismatch {
                            tag: t.name.clone(),
                            declared: d,
                            point: text.clone(),
                            actual: r.spec.ty,
                        };
                        self.error(path.key("type"), kind);
                    }
                }
                (
                    Binding::Point {
                        module: r.module,
                        point: r.point,
                    },
                    r.spec.ty,
                    Some((text, r)),
                )
            }
            (None, Some(Some(ty))) => (Binding::Memory, ty, None),
            (None, Some(None)) => {
                self.error(
                    path.clone(),
                    ErrorKind::TagNeedsPointOrType {
                        tag: t.name.clone(),
                    },
                );
                return None;
            }
            (None, None) => return None,
        };

        // One owner per output.
        if let Some((text, r)) = point {
            if r.spec.access == Access::Output {
                match owners.get(&(r.module, r.point)) {
                    Some(&other) => {
                        let other_line = self
                            .loc
                            .line(&YPath::root().key("tags").index(other).key("point"));
                        let kind = ErrorKind::OutputTwoOwners {
                            point: text.clone(),
                            tag: t.name.clone(),
                            other: raw
                                .tags
                                .get(other)
                                .map(|o| o.name.clone())
                                .unwrap_or_default(),
                            other_line,
                        };
                        self.error(path.key("point"), kind);
                    }
                    None => {
                        owners.insert((r.module, r.point), i);
                    }
                }
            }
        }

        // Safe value: outputs only. `None` here: refused (and reported).
        let safe = match &t.safe {
            None => Some(None),
            Some(v) => match point {
                Some((_, r)) if r.spec.access == Access::Output => self
                    .value(&t.name, "safe", &v.0, ty, path.key("safe"))
                    .map(Some),
                _ => {
                    let kind = ErrorKind::SafeNotOnOutput {
                        tag: t.name.clone(),
                        point: point.map(|(text, _)| text.clone()),
                        access: point.map(|(_, r)| r.spec.access),
                    };
                    self.error(path.key("safe"), kind);
                    None
                }
            },
        };

        // Initial value: memory tags only.
        let initial = match (&t.initial, point) {
            (None, _) => Some(ty.zero()),
            (Some(v), None) => self.value(&t.name, "initial", &v.0, ty, path.key("initial")),
            (Some(_), Some((text, _))) => {
                let kind = ErrorKind::InitialOnPointTag {
                    tag: t.name.clone(),
                    point: text.clone(),
                };
                self.error(path.key("initial"), kind);
                None
            }
        };

        // Retain: memory tags only (an input is re-read, an output is the program's to drive).
        let retain = match (t.retain, point) {
            (None | Some(false), _) => Some(false),
            (Some(true), None) => Some(true),
            (Some(true), Some((text, _))) => {
                let kind = ErrorKind::RetainOnPoint {
                    tag: t.name.clone(),
                    point: text.clone(),
                };
                self.error(path.key("retain"), kind);
                None
            }
        };

        let description = self.description(Item::Tag, &t.name, t.description.as_deref(), path);
        Some(TagConfig {
            name: t.name.clone(),
            description: description?,
            ty,
            binding,
            safe: safe?,
            initial: initial?,
            retain: retain?,
        })
    }

    /// The entry's `description:`; `None` when it is refused (and reported at the key).
    fn description(
        &mut self,
        item: Item,
        name: &str,
        text: Option<&str>,
        path: &YPath,
    ) -> Option<Option<DocText>> {
        let Some(text) = text else {
            return Some(None);
        };
        match DocText::new(DocKind::Description, text) {
            Ok(d) => Some(d),
            Err(error) => {
                let kind = ErrorKind::BadDocText {
                    item,
                    name: name.to_owned(),
                    key: "description",
                    error,
                };
                self.error(path.key("description"), kind);
                None
            }
        }
    }

    fn value(
        &mut self,
        tag: &str,
        key: &'static str,
        text: &str,
        ty: ValueType,
        path: YPath,
    ) -> Option<Value> {
        let v = Value::parse(ty, text);
        if v.is_none() {
            let kind = ErrorKind::BadValue {
                tag: tag.to_owned(),
                key,
                value: text.to_owned(),
                ty,
            };
            self.error(path, kind);
        }
        v
    }

    /// A task's programs at `at`: its `program:` (`one`) or its `programs:` (`list`), not
    /// both and not an empty list; `required`: a missing program is an error (not when the
    /// project's task is missing altogether, which is said once).
    fn programs(
        &mut self,
        one: Option<&RawProgram>,
        list: Option<&[RawProgram]>,
        at: &YPath,
        required: bool,
    ) -> Option<Vec<ProgramConfig>> {
        match (one, list) {
            (Some(_), Some(_)) => {
                let program_line = self.loc.line(&at.key("program"));
                let kind = ErrorKind::ProgramBesidePrograms { program_line };
                self.error(at.key("programs"), kind);
                None
            }
            (Some(p), None) => self.program(p, &at.key("program")).map(|p| vec![p]),
            (None, Some([])) => {
                self.error(at.key("programs"), ErrorKind::NoPrograms);
                None
            }
            (None, Some(list)) => {
                let path = at.key("programs");
                // Every program is checked, so every missing file is said at once.
                let programs: Vec<Option<ProgramConfig>> = (0..list.len())
                    .map(|i| self.program(&list[i], &path.index(i)))
                    .collect();
                programs.into_iter().collect()
            }
            (None, None) => {
                if required {
                    let kind = ErrorKind::MissingKey {
                        section: String::new(),
                        key: "program".into(),
                    };
                    self.error(at.clone(), kind);
                }
                None
            }
        }
    }

    fn program(&mut self, raw: &RawProgram, path: &YPath) -> Option<ProgramConfig> {
        let file = self.file;
        let kind = match PROGRAM_KINDS.iter().find(|(name, _)| *name == raw.kind) {
            Some(&(_, k)) => Some(k),
            None => {
                let known = PROGRAM_KINDS.iter().map(|(n, _)| *n).collect();
                let kind = ErrorKind::UnknownProgramKind {
                    kind: raw.kind.clone(),
                    known,
                };
                self.error(path.key("kind"), kind);
                None
            }
        };
        let folder = file.parent().unwrap_or(Path::new(""));
        let program_path = folder.join(&raw.file);
        let found = match std::fs::metadata(&program_path) {
            Ok(meta) if meta.is_file() && !raw.file.is_empty() => true,
            Ok(_) => {
                let kind = ErrorKind::ProgramNotFound {
                    path: program_path.clone(),
                    message: "not a file".into(),
                };
                self.error(path.key("file"), kind);
                false
            }
            Err(e) => {
                let kind = ErrorKind::ProgramNotFound {
                    path: program_path.clone(),
                    message: e.to_string(),
                };
                self.error(path.key("file"), kind);
                false
            }
        };
        if !found {
            return None;
        }
        Some(ProgramConfig {
            path: program_path,
            kind: kind?,
        })
    }

    fn plant(
        &mut self,
        p: &RawPlant,
        raw: &RawProject,
        buses: &[Option<BusConfig>],
        modules: &[(Resolved, Option<ModuleConfig>)],
        module_index: &HashMap<String, usize>,
    ) -> Option<PlantConfig> {
        let path = YPath::root().key("plant");
        let model = self.plant_model(p, &path)?;
        let roles: Vec<(String, bool)> = model
            .terminals()
            .map(|(name, drives)| (name.to_owned(), drives))
            .collect();
        let wiring_path = path.key("wiring");
        let mut ok = true;
        let mut wired: Vec<Option<(usize, String)>> = vec![None; roles.len()];
        let mut driven: HashMap<(usize, usize), String> = HashMap::new();
        for (role_name, text) in &p.wiring.0 {
            let Some(role_i) = roles.iter().position(|(r, _)| r == role_name) else {
                let kind = ErrorKind::UnknownPlantRole {
                    plant: model.name.clone(),
                    role: role_name.clone(),
                    roles: roles.iter().map(|(r, _)| r.clone()).collect(),
                };
                self.error(wiring_path.key_itself(role_name), kind);
                ok = false;
                continue;
            };
            let Some(&(_, drives_input)) = roles.get(role_i) else {
                continue;
            };
            let point_path = wiring_path.key(role_name);
            let r = match self.point_ref(text, &point_path, raw, modules, module_index) {
                Ok(r) => r,
                Err(_) => {
                    ok = false;
                    continue;
                }
            };
            let wanted = if drives_input {
                Access::Input
            } else {
                Access::Output
            };
            if r.spec.access != wanted {
                let kind = ErrorKind::PlantWrongDirection {
                    role: role_name.clone(),
                    drives_input,
                    point: text.clone(),
                    access: r.spec.access,
                };
                self.error(point_path.clone(), kind);
                ok = false;
            }
            let bus = modules.get(r.module).and_then(|(res, _)| res.bus);
            if let Some(Some(bus_cfg)) = bus.and_then(|b| buses.get(b)) {
                if bus_cfg.port != PortConfig::Sim {
                    let kind = ErrorKind::PlantNeedsSim {
                        role: role_name.clone(),
                        point: text.clone(),
                        bus: bus_cfg.name.clone(),
                    };
                    self.error(point_path.clone(), kind);
                    ok = false;
                }
            }
            if drives_input {
                if let Some(other) = driven.get(&(r.module, r.point)) {
                    let kind = ErrorKind::PlantInputDrivenTwice {
                        point: text.clone(),
                        role: role_name.clone(),
                        other: other.clone(),
                    };
                    self.error(point_path.clone(), kind);
                    ok = false;
                } else {
                    driven.insert((r.module, r.point), role_name.clone());
                }
            }
            if let Some(slot) = wired.get_mut(role_i) {
                *slot = Some((r.module, r.spec.name.to_owned()));
            }
        }
        let mut wiring = Vec::with_capacity(roles.len());
        for ((role, drives_input), slot) in roles.into_iter().zip(wired) {
            match slot {
                Some((module, point)) => wiring.push((role, module, point)),
                None => {
                    // A role that failed to resolve is reported already; only unwired ones here.
                    if !p.wiring.0.iter().any(|(k, _)| *k == role) {
                        let kind = ErrorKind::MissingPlantRole {
                            plant: model.name.clone(),
                            role,
                            drives_input,
                        };
                        self.error(path.key_itself("wiring"), kind);
                    }
                    ok = false;
                }
            }
        }
        ok.then(|| PlantConfig {
            model,
            wiring,
            seed: p.seed.unwrap_or(0),
        })
    }

    /// The plant's model: a built-in by name or the project's file, compiled; the file's
    /// errors at its own line:col.
    fn plant_model(&mut self, p: &RawPlant, path: &YPath) -> Option<PlantModel> {
        match (&p.model, &p.file) {
            (Some(name), None) => {
                let model = crate::plant::builtin(name);
                if model.is_none() {
                    let known = crate::plant::CATALOG.iter().map(|b| b.name).collect();
                    let kind = ErrorKind::UnknownPlant {
                        name: name.clone(),
                        known,
                    };
                    self.error(path.key("model"), kind);
                }
                model
            }
            (None, Some(rel)) => {
                let dir = self.file.parent().unwrap_or(Path::new(""));
                let file = dir.join(rel.trim());
                let source = match std::fs::read_to_string(&file) {
                    Ok(text) => text,
                    Err(e) => {
                        let kind = ErrorKind::PlantFile {
                            path: rel.trim().to_owned(),
                            message: e.to_string(),
                        };
                        self.error(path.key("file"), kind);
                        return None;
                    }
                };
                match crate::plant::compile(&file, &source) {
                    Ok(model) => Some(model),
                    Err(errors) => {
                        self.errors.extend(errors.into_iter().map(|e| ProjectError {
                            file: file.clone(),
                            line: e.line,
                            column: e.column,
                            kind: ErrorKind::PlantModel(e.error),
                        }));
                        None
                    }
                }
            }
            _ => {
                self.error(path.clone(), ErrorKind::PlantModelOrFile);
                None
            }
        }
    }
}

/// Names in `all` that look like `wanted`: same letters ignoring case, or within an edit
/// distance of 1 (2 for names longer than 4), best first.
fn close_matches(wanted: &str, all: &[&'static str]) -> Vec<&'static str> {
    crate::suggest::close_to(wanted, all.iter().copied(), MAX_SUGGESTIONS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifiers() {
        for ok in ["a", "_x", "mm1", "line_1", "Motor"] {
            assert!(is_identifier(ok), "{ok}");
        }
        for bad in ["", "1mm", "a-b", "a.b", "é", "a b"] {
            assert!(!is_identifier(bad), "{bad}");
        }
    }

    #[test]
    fn suggestions() {
        let all = ["X1", "X2", "Y1", "Y2", "XCOUNT1", "YLAMP"];
        assert_eq!(close_matches("Y9", &all), vec!["Y1", "Y2"]);
        assert_eq!(close_matches("y1", &all), vec!["Y1"]);
        assert_eq!(close_matches("XCOUNT", &all), vec!["XCOUNT1"]);
        assert!(close_matches("ZZZZZZZZ", &all).is_empty());
    }
}
