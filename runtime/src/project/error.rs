//! Errors of a project file: every one found, each with `file:line:col`, printed like rustc.

use std::fmt;
use std::path::{Path, PathBuf};

use softplc_io::point::{Access, ValueType};

/// Every error found in a project file (at least one).
///
/// Validation does not stop at the first semantic error; it stops at a YAML syntax or
/// structure error (an unknown key, a wrong type), since nothing after it can be read.
/// Errors are sorted by position.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectErrors {
    /// The errors, sorted by line and column.
    pub errors: Vec<ProjectError>,
}

impl ProjectErrors {
    /// The number of errors.
    pub fn len(&self) -> usize {
        self.errors.len()
    }

    /// True when there is no error (never the case for a returned `Err`).
    pub fn is_empty(&self) -> bool {
        self.errors.is_empty()
    }

    /// The errors, in order.
    pub fn iter(&self) -> std::slice::Iter<'_, ProjectError> {
        self.errors.iter()
    }
}

/// The text of the file at `path`; a failed read is the one error, at the file, so a project
/// and a profile report it alike.
pub(crate) fn read_text(path: &Path) -> Result<String, ProjectErrors> {
    std::fs::read_to_string(path).map_err(|e| ProjectErrors {
        errors: vec![ProjectError {
            file: path.to_path_buf(),
            line: 0,
            column: 0,
            kind: ErrorKind::Io {
                message: e.to_string(),
            },
        }],
    })
}

impl<'a> IntoIterator for &'a ProjectErrors {
    type Item = &'a ProjectError;
    type IntoIter = std::slice::Iter<'a, ProjectError>;

    fn into_iter(self) -> Self::IntoIter {
        self.errors.iter()
    }
}

impl fmt::Display for ProjectErrors {
    /// One error per line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.errors.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ProjectErrors {}

/// One error, with its position in the project file.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectError {
    /// The project file.
    pub file: PathBuf,
    /// 1-based line; 0 when the error concerns the whole file (it could not be read).
    pub line: usize,
    /// 1-based column; 0 when the error concerns the whole file.
    pub column: usize,
    /// What is wrong.
    pub kind: ErrorKind,
}

impl fmt::Display for ProjectError {
    /// `file:line:col: error: message`, or `file: error: message` for the whole file.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}: error: {}", self.file.display(), self.kind)
        } else {
            write!(
                f,
                "{}:{}:{}: error: {}",
                self.file.display(),
                self.line,
                self.column,
                self.kind
            )
        }
    }
}

impl std::error::Error for ProjectError {}

/// The kinds of named things in a project file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Item {
    /// A `buses:` entry.
    Bus,
    /// A `modules:` entry.
    Module,
    /// A `tags:` entry.
    Tag,
    /// A `tasks:` entry.
    Task,
}

impl fmt::Display for Item {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Item::Bus => "bus",
            Item::Module => "module",
            Item::Tag => "tag",
            Item::Task => "task",
        })
    }
}

/// What is wrong with a project file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ErrorKind {
    /// The file could not be read.
    #[error("cannot read the project file: {message}")]
    Io {
        /// The OS's reason.
        message: String,
    },
    /// The text is not valid YAML, or another error of the YAML reader.
    #[error("{message}")]
    Yaml {
        /// The reader's message.
        message: String,
    },
    /// Collections nested deeper than the reader accepts (see `nesting.rs`).
    #[error(
        "lists and mappings nested more than {limit} deep (a project needs a handful); this \
         one goes past it"
    )]
    TooDeep {
        /// The deepest nesting accepted.
        limit: usize,
    },
    /// A key the schema does not have (a typo?).
    #[error(
        "unknown key `{key}`{}; expected {expected}{}",
        within(section),
        key_hint(key, expected)
    )]
    UnknownKey {
        /// Where (`buses[0]`; empty at the top level).
        section: String,
        /// The key.
        key: String,
        /// The keys allowed there, as the reader lists them.
        expected: String,
    },
    /// A required key is missing.
    #[error("missing key `{key}`{}", within(section))]
    MissingKey {
        /// Where (`buses[0]`; empty at the top level).
        section: String,
        /// The key.
        key: String,
    },
    /// A key given twice in one mapping.
    #[error("key `{key}` is given twice{}", within(section))]
    DuplicateKey {
        /// Where.
        section: String,
        /// The key.
        key: String,
    },
    /// A value of the wrong type or form (`baud: fast`, `period: 10`).
    #[error("{}{message}", prefix(key))]
    WrongType {
        /// The key's path (`buses[0].baud`).
        key: String,
        /// What was found and what was expected.
        message: String,
    },
    /// The project's name is empty.
    #[error("the project name is empty")]
    EmptyProjectName,
    /// A bus, module or tag name that is not an identifier.
    #[error(
        "{item} name \"{name}\" is not an identifier (letters, digits and `_`, not starting \
         with a digit)"
    )]
    InvalidName {
        /// What it names.
        item: Item,
        /// The name.
        name: String,
    },
    /// Two buses, modules or tags with one name.
    #[error("{item} name \"{name}\" is already used by the {item} at line {first_line}")]
    DuplicateName {
        /// What it names.
        item: Item,
        /// The name.
        name: String,
        /// The line of the first use.
        first_line: usize,
    },
    /// A duration that must be positive is zero.
    #[error("{key} must be greater than zero")]
    ZeroDuration {
        /// Which one (`scan.period`).
        key: &'static str,
    },
    /// Watchdog sensitivity below 1 or too large.
    #[error(
        "watchdog sensitivity must be at least 1 (consecutive overruns tolerated), got {value}"
    )]
    BadSensitivity {
        /// The value given.
        value: i64,
    },
    /// Real-time priority outside 1..=99.
    #[error("real-time priority {value} is outside 1..=99 (SCHED_FIFO priorities)")]
    BadPriority {
        /// The value given.
        value: i64,
    },
    /// A negative CPU number.
    #[error("cpu {value} is not a CPU number (0, 1, ...)")]
    BadCpu {
        /// The value given.
        value: i64,
    },
    /// A port that is neither `sim`, a device path nor a URL.
    #[error(
        "port \"{port}\" is neither `sim`, a device path (like /dev/ttyUSB0) nor a network \
         endpoint (tcp://HOST:PORT for Modbus TCP, rtu+tcp://HOST:PORT for RTU over TCP)"
    )]
    BadPort {
        /// The value given.
        port: String,
    },
    /// A `port:` URL that is not a valid endpoint.
    #[error("port \"{port}\": {reason}")]
    BadPortUrl {
        /// The value given.
        port: String,
        /// What is wrong with it.
        reason: softplc_io::line::EndpointError,
    },
    /// A serial-port key on a bus whose port has no such thing (`rs485:` on `tcp://`).
    #[error("{key} is for a serial line; a {scheme}:// bus has none{hint}")]
    NotOnNetworkBus {
        /// The key (`baud`, `rs485`).
        key: &'static str,
        /// The bus's scheme (`tcp`, `rtu+tcp`).
        scheme: &'static str,
        /// What to do instead.
        hint: &'static str,
    },
    /// Two buses on one serial device.
    #[error(
        "{port} is already bus {other}'s serial device{same} (line {other_line}): one line has one \
         baud and format, so one bus; commission the odd modules to that bus's baud and format \
         (softplc commission), or move them to a line of their own"
    )]
    DuplicateDevice {
        /// The port as written.
        port: String,
        /// ` (both are /dev/ttyUSB0)` when the two paths differ but lead to one device.
        same: String,
        /// The bus that has it first.
        other: String,
        /// That bus's `port` line.
        other_line: usize,
    },
    /// Two buses with one network endpoint.
    #[error(
        "endpoint {endpoint} is already bus {other}'s (line {other_line}): one connection per \
         endpoint, shared by every unit id behind it; put these modules on bus {other}"
    )]
    DuplicateEndpoint {
        /// The endpoint.
        endpoint: String,
        /// The bus that has it first.
        other: String,
        /// That bus's `port` line.
        other_line: usize,
    },
    /// A MiniMod setting its driver writes by name (a text command) on a Modbus TCP bus.
    #[error(
        "{key} is written by name with a text command (>{key}=), which a Modbus TCP bus cannot \
         carry: set it in the module's flash (WCONF) on a line of its own, or use an \
         rtu+tcp:// bus"
    )]
    TextSettingOnModbusTcp {
        /// The setting.
        key: &'static str,
    },
    /// A text-protocol module on a Modbus TCP bus.
    #[error(
        "module {module} ({model}) speaks its text protocol here, which a Modbus TCP bus \
         (bus {bus}) cannot carry: use protocol: modbus, or an rtu+tcp:// bus (a serial \
         server that passes the line's bytes through)"
    )]
    TextOnModbusTcp {
        /// The module.
        module: String,
        /// Its model.
        model: &'static str,
        /// The bus.
        bus: String,
    },
    /// A baud rate that is not a positive 32-bit number.
    #[error("baud {value} is not a baud rate (a positive number of bits per second, like 19200)")]
    BadBaud {
        /// The value given.
        value: i64,
    },
    /// A serial format string that does not parse.
    #[error(
        "serial format \"{format}\" is not valid: write data bits (7|8), parity (N|E|O) and \
         stop bits (1|2), like 8E1 or 8N2"
    )]
    BadFormat {
        /// The value given.
        format: String,
    },
    /// `rs485:` on a `port: sim` bus (the virtual line has no UART).
    #[error("rs485 is for a device port (a UART with an RS-485 transceiver), not port: sim")]
    Rs485OnSim,
    /// An RS-485 delay that is not whole ms in 0..=100 ms.
    #[error("{key} must be whole milliseconds from 0ms to 100ms (the kernel's limit)")]
    BadRs485Delay {
        /// Which one (`rs485.delay_after_send`).
        key: &'static str,
    },
    /// `direction:` other than `host` or `auto`.
    #[error("direction must be host (the host, or nobody said, turns the transceiver round) or auto (the adapter does, within a character)")]
    BadDirection,
    /// `tune:` other than `reply_delay`.
    #[error("tune must be reply_delay (set every MiniMod's reply delay to the least the line allows, for this run)")]
    BadTune,
    /// `tune: reply_delay` on a line that does not turn round within a character.
    #[error("tune: reply_delay needs a line that turns round within a character (MiniMod RDELAYT=0 answers at once): {why}")]
    TuneNeedsFastTurn {
        /// Why this line does not.
        why: super::line_plan::direction::SlowTurn,
    },
    /// `echo:` other than `none` or `discard`.
    #[error("echo must be none (the adapter does not hear itself) or discard (read back and verify every request's echo)")]
    BadEcho,
    /// `adapter_latency:` that is not whole ms in 0..=255 ms.
    #[error("adapter_latency must be auto or whole milliseconds from 0ms to 255ms (an FTDI latency timer's range)")]
    BadAdapterLatency,
    /// An explicit `adapter_latency:` on a `port: sim` bus (the virtual line has no adapter).
    #[error("adapter_latency is for a device port (a USB adapter), not port: sim; leave it out or set auto")]
    AdapterLatencyOnSim,
    /// Retries outside 0..=255.
    #[error("retries {value} is outside 0..=255")]
    BadRetries {
        /// The value given.
        value: i64,
    },
    /// A module on a bus that does not exist.
    #[error("unknown bus \"{name}\" ({})", known_list("buses", known))]
    UnknownBus {
        /// The name given.
        name: String,
        /// The buses of the project.
        known: Vec<String>,
    },
    /// An error of a device profile file (at its own file:line:col), or of the reference to
    /// one.
    #[error(transparent)]
    Profile(#[from] super::profile::ProfileError),
    /// A model that is not in the catalog.
    #[error("unknown model \"{name}\" (known: {})", known.join(", "))]
    UnknownModel {
        /// The name given.
        name: String,
        /// The catalog's models.
        known: Vec<&'static str>,
    },
    /// A unit address outside the model's range.
    #[error("address {address} is outside the range {min}..={max} of model {model}")]
    AddressOutOfRange {
        /// The address given.
        address: i64,
        /// The model.
        model: &'static str,
        /// Lowest valid address.
        min: u8,
        /// Highest valid address.
        max: u8,
    },
    /// Two modules with one address on one bus.
    #[error(
        "address {address} is already used by module {other} on bus {bus} (line {other_line})"
    )]
    DuplicateAddress {
        /// The address.
        address: u8,
        /// The bus.
        bus: String,
        /// The module that has it first.
        other: String,
        /// That module's `address` line.
        other_line: usize,
    },
    /// A MiniMod whose text commands an EX-9053 in DCON mode on its bus takes for its own
    /// (see `dcon_neighbours`).
    #[error(
        "module {module} (minimod, address {address}) gets text commands (`@{address}>WDTTIME=` \
         at start-up) that module {other} (DCON address {dcon:02X}, line {other_line}) on bus \
         {bus} takes for its own and answers `?{dcon:02X}` over the MiniMod's reply; give one \
         of them another address (or turn the EX-9053's checksum on)"
    )]
    HeardByDcon {
        /// The MiniMod.
        module: String,
        /// Its address.
        address: u8,
        /// The EX-9053.
        other: String,
        /// Its address, as DCON writes it (hexadecimal on the wire).
        dcon: u8,
        /// The bus.
        bus: String,
        /// The EX-9053's `address` line.
        other_line: usize,
    },
    /// A bus faster than a module on it accepts.
    #[error(
        "module {module} ({model}) accepts at most {max} Bd, but bus {bus} runs at {baud} Bd \
         (line {baud_line})"
    )]
    BaudTooHigh {
        /// The module.
        module: String,
        /// Its model.
        model: &'static str,
        /// The model's maximum.
        max: u32,
        /// The bus.
        bus: String,
        /// The bus's baud rate.
        baud: u32,
        /// The line of the bus's baud rate (or of the bus when it is the default).
        baud_line: usize,
    },
    /// A protocol name that is not known.
    #[error("unknown protocol \"{name}\" (known: {})", known.join(", "))]
    UnknownProtocol {
        /// The name given.
        name: String,
        /// Every protocol name.
        known: Vec<&'static str>,
    },
    /// A protocol the model does not speak.
    #[error("model {model} does not speak {protocol} (it speaks: {})", supported.join(", "))]
    ProtocolNotSupported {
        /// The protocol.
        protocol: &'static str,
        /// The model.
        model: &'static str,
        /// What it speaks.
        supported: Vec<&'static str>,
    },
    /// A model-specific setting the model refuses.
    #[error("module {module}: setting `{key}`: {message}")]
    BadSetting {
        /// The module.
        module: String,
        /// The setting's key.
        key: String,
        /// The model's reason.
        message: String,
    },
    /// A point reference that is not `module.POINT`.
    #[error("point \"{text}\" must be written module.POINT (like mm1.Y1)")]
    BadPointRef {
        /// The text given.
        text: String,
    },
    /// A point reference to a module that does not exist.
    #[error("unknown module \"{name}\" ({})", known_list("modules", known))]
    UnknownModule {
        /// The name given.
        name: String,
        /// The modules of the project.
        known: Vec<String>,
    },
    /// A point the module's model does not have.
    #[error(
        "module {module} ({model}) has no point \"{point}\"; {}",
        point_hint(close, all)
    )]
    UnknownPoint {
        /// The module.
        module: String,
        /// Its model.
        model: &'static str,
        /// The point given.
        point: String,
        /// The model's points that look like it.
        close: Vec<&'static str>,
        /// All the model's points.
        all: Vec<&'static str>,
    },
    /// A tag with neither `point` nor `type`.
    #[error(
        "tag {tag} needs either `point:` (a module point, like mm1.X1) or `type:` (a memory \
         variable: bool, u16, i32 or f32)"
    )]
    TagNeedsPointOrType {
        /// The tag.
        tag: String,
    },
    /// A type name that is not known.
    #[error("unknown type \"{name}\" (known: bool, u16, i32, f32)")]
    UnknownType {
        /// The name given.
        name: String,
    },
    /// A point-bound tag whose `type` differs from the point's.
    #[error("tag {tag} is declared {declared} but point {point} is {actual}")]
    TypeMismatch {
        /// The tag.
        tag: String,
        /// The type given.
        declared: ValueType,
        /// The point (`mm1.X1`).
        point: String,
        /// The point's type.
        actual: ValueType,
    },
    /// `safe` on a tag that is not bound to an output point.
    #[error(
        "tag {tag}: `safe` is only allowed on tags bound to an output point, and {}",
        what_it_is(point, *access)
    )]
    SafeNotOnOutput {
        /// The tag.
        tag: String,
        /// Its point (`None`: a memory tag).
        point: Option<String>,
        /// The point's access (when bound).
        access: Option<Access>,
    },
    /// `initial` on a tag bound to a point.
    #[error(
        "tag {tag}: `initial` is only allowed on memory tags; {point} gets its value from the \
         module"
    )]
    InitialOnPointTag {
        /// The tag.
        tag: String,
        /// Its point.
        point: String,
    },
    /// A `description:` that cannot document its item (too long, or a line break).
    #[error("{item} {name}: {key}: {error}")]
    BadDocText {
        /// The kind of item.
        item: Item,
        /// Its name.
        name: String,
        /// The key (`description`).
        key: &'static str,
        /// What is wrong with the text.
        error: super::doc_text::DocTextError,
    },
    /// A block file, a block of one's own or an instance of one (see `user_blocks`).
    #[error(transparent)]
    UserBlock(#[from] super::user_blocks::UserBlockError),
    /// A `safe` or `initial` value that is not of the tag's type.
    #[error("tag {tag}: {key} value {value} is not a {ty}")]
    BadValue {
        /// The tag.
        tag: String,
        /// `safe` or `initial`.
        key: &'static str,
        /// The value given.
        value: String,
        /// The tag's type.
        ty: ValueType,
    },
    /// An output point bound to two tags.
    #[error(
        "output {point} is written by two owners: tag {other} (line {other_line}) and tag {tag}"
    )]
    OutputTwoOwners {
        /// The point (`mm1.Y1`).
        point: String,
        /// This tag.
        tag: String,
        /// The tag that owns it first.
        other: String,
        /// That tag's `point` line.
        other_line: usize,
    },
    /// `tasks:` beside `scan:` or `program:`: which task would they describe?
    #[error(
        "`tasks:` and `{key}:` cannot be used together: a project has either `scan:` and \
         `program:` (one task, named `main`) or `tasks:` (each with its period and program)"
    )]
    TasksBesideScan {
        /// The single task's key found beside `tasks:` (`scan` or `program`).
        key: &'static str,
    },
    /// Neither `scan:` nor `tasks:`.
    #[error(
        "the project has no task: give `scan:` and `program:` (one task) or `tasks:` (several, \
         each with its period, program and buses)"
    )]
    NoTask,
    /// `tasks:` with no entry.
    #[error("`tasks:` is empty: give at least one task (name, period, program, buses)")]
    NoTasks,
    /// `program:` and `programs:` in one place: which one runs?
    #[error(
        "`program:` and `programs:` cannot be used together: give one program as `program:` \
         or several, in running order, as `programs:` (the first program is `program:` line \
         {program_line})"
    )]
    ProgramBesidePrograms {
        /// The line of the `program:` given too.
        program_line: usize,
    },
    /// `programs:` with no entry.
    #[error(
        "`programs:` is empty: give at least one program ({{ file, kind }}), or use `program:`"
    )]
    NoPrograms,
    /// A bus named by a second task.
    #[error(
        "bus `{bus}` is already owned by task `{first}` (line {first_line}); a bus belongs to \
         one task, whose thread does all of its I/O"
    )]
    BusOwnedTwice {
        /// The bus.
        bus: String,
        /// The task that named it first.
        first: String,
        /// The line where it named it.
        first_line: usize,
    },
    /// A bus that no task names.
    #[error(
        "bus `{bus}` belongs to no task: with `tasks:`, every bus is named in the `buses:` of \
         exactly one task (its thread does the bus's I/O)"
    )]
    BusWithoutTask {
        /// The bus.
        bus: String,
    },
    /// A program kind that is not known.
    #[error("unknown program kind \"{kind}\" (known: {})", known.join(", "))]
    UnknownProgramKind {
        /// The kind given.
        kind: String,
        /// The kinds softplc runs.
        known: Vec<&'static str>,
    },
    /// The program file is missing.
    #[error("cannot read program file {}: {message}", path.display())]
    ProgramNotFound {
        /// The path, resolved against the project file's folder.
        path: PathBuf,
        /// The OS's reason.
        message: String,
    },
    /// A plant model that is not known.
    #[error("unknown plant model \"{name}\" (known: {})", known.join(", "))]
    UnknownPlant {
        /// The name given.
        name: String,
        /// The plant models.
        known: Vec<&'static str>,
    },
    /// `plant:` with both or neither of `model` and `file`.
    #[error("a plant names a built-in model (model: conveyor) or a model file (file: door.plant.rhai), one of the two")]
    PlantModelOrFile,
    /// A plant model file that cannot be read.
    #[error("cannot read the plant model file {path}: {message}")]
    PlantFile {
        /// The file as the project names it.
        path: String,
        /// The OS's reason.
        message: String,
    },
    /// An error of a plant model file, at its own file:line:col.
    #[error(transparent)]
    PlantModel(#[from] crate::plant::ModelError),
    /// A wiring entry for a terminal the plant does not have.
    #[error("plant {plant} has no terminal \"{role}\" (its terminals: {})", roles.join(", "))]
    UnknownPlantRole {
        /// The plant model.
        plant: String,
        /// The terminal given.
        role: String,
        /// The plant's terminals.
        roles: Vec<String>,
    },
    /// A terminal of the plant left unwired.
    #[error(
        "plant {plant} needs terminal {role} wired (to a module {})",
        if *drives_input { "input" } else { "output" }
    )]
    MissingPlantRole {
        /// The plant model.
        plant: String,
        /// The terminal.
        role: String,
        /// True: the plant drives it (a module input); false: the plant reads it (an output).
        drives_input: bool,
    },
    /// A role wired to a point of the wrong direction.
    #[error(
        "plant terminal {role} {} a module {}, but {point} is {}",
        if *drives_input { "drives" } else { "reads" },
        if *drives_input { "input" } else { "output" },
        access_phrase(*access)
    )]
    PlantWrongDirection {
        /// The role.
        role: String,
        /// True: the plant drives it (must be an input); false: it reads it (an output).
        drives_input: bool,
        /// The point (`mm1.X1`).
        point: String,
        /// The point's access.
        access: Access,
    },
    /// A role wired to a module on a real serial line.
    #[error(
        "plant terminal {role} is wired to {point} on bus {bus}, which is not `port: sim`; a plant \
         only runs on simulated lines"
    )]
    PlantNeedsSim {
        /// The role.
        role: String,
        /// The point.
        point: String,
        /// The module's bus.
        bus: String,
    },
    /// One input driven by two plant terminals.
    #[error("input {point} is driven by two plant terminals: {role} and {other}")]
    PlantInputDrivenTwice {
        /// The point.
        point: String,
        /// This role.
        role: String,
        /// The role that drives it first.
        other: String,
    },
    /// The `service:` section or a tag's `scada:`.
    #[error("{0}")]
    Service(#[from] super::scada::ServiceError),
    /// `retain: true` on a tag bound to a module point.
    #[error(
        "tag {tag} is bound to {point}: only memory tags are retained (a module input is read \
         every scan, an output is driven by the program); keep the value in a memory tag"
    )]
    RetainOnPoint {
        /// The tag.
        tag: String,
        /// Its point.
        point: String,
    },
    /// The `offload:` section or a tag's push-down options.
    #[error("{0}")]
    Offload(#[from] super::offload::OffloadError),
    /// `retain.file` is empty.
    #[error(
        "retain.file is empty; give a file name (relative to the project file) or leave it out"
    )]
    EmptyRetainFile,
    /// The `recorder:` section.
    #[error("{0}")]
    Recorder(#[from] super::recorder::RecorderError),
    /// A `traces:` entry.
    #[error("{0}")]
    Trace(#[from] super::trace::TraceError),
    /// The `trace_budget:` section, or start traces past it.
    #[error("{0}")]
    TraceBudget(#[from] super::trace_budget::TraceBudgetError),
    /// A tag's `alarm:` or the `alarms:` section.
    #[error("{0}")]
    Alarm(#[from] super::alarm::AlarmError),
}

fn within(section: &str) -> String {
    if section.is_empty() {
        " at the top level".to_owned()
    } else {
        format!(" in {section}")
    }
}

/// `; did you mean `retain`?` for an unknown key close to one the reader expected (its list
/// names them in backquotes); empty when none is.
fn key_hint(key: &str, expected: &str) -> String {
    let keys = expected.split('`').skip(1).step_by(2);
    crate::suggest::did_you_mean(key, keys)
}

fn prefix(key: &str) -> String {
    if key.is_empty() {
        String::new()
    } else {
        format!("{key}: ")
    }
}

fn known_list(what: &str, known: &[String]) -> String {
    if known.is_empty() {
        format!("the project has no {what}")
    } else {
        format!("known: {}", known.join(", "))
    }
}

fn point_hint(close: &[&str], all: &[&str]) -> String {
    if !close.is_empty() {
        format!("did you mean {}?", close.join(", "))
    } else if all.is_empty() {
        "the model has no points".to_owned()
    } else {
        format!("its points: {}", all.join(", "))
    }
}

fn access_phrase(access: Access) -> &'static str {
    match access {
        Access::Input => "an input",
        Access::Output => "an output",
        Access::ReadWrite => "a read-write setting",
    }
}

fn what_it_is(point: &Option<String>, access: Option<Access>) -> String {
    match (point, access) {
        (Some(p), Some(a)) => format!("{p} is {}", access_phrase(a)),
        _ => "this is a memory tag".to_owned(),
    }
}
