//! RS-485 lines: serial settings and the wire-time model, transports, and the bus owner.
//!
//! - [`LineSettings`]: baud and character format, and DESIGN.md's timing model; the line's
//!   time budget ([`line_budget`], [`LineBudget`], [`AdapterTiming`]).
//! - [`Transport`]: the byte pipe a bus owner drives: a real serial port ([`SerialTransport`])
//!   or the virtual line.
//! - [`BusOwner`]: runs drivers' transactions on one line with its [`Discipline`] (response
//!   timeout, t3.5 gap, guard + flush after a timeout, retries, [`Counters`]); [`BusThread`]
//!   runs it on its own thread.
//! - [`LineLink`]: how the scan drives a line on either clock, against one deadline per phase.
//! - [`CollectFloor`]: FC 70 Collect rounds for the modules in event mode (MiniMod).
//! - [`EchoMode`]: adapters that hear their own transmission (`echo: discard`).
//! - [`AdapterLatency`]: USB adapters' latency timer: read, lowered, and counted in the budget.
//! - [`TcpEndpoint`]: buses over TCP: Modbus TCP (`tcp://`) and RTU over TCP (`rtu+tcp://`).

pub(crate) mod budget;
pub(crate) mod bus;
pub(crate) mod collect;
pub(crate) mod cycle_mix;
pub(crate) mod echo;
pub(crate) mod health;
pub(crate) mod housekeeping;
pub(crate) mod latency;
pub(crate) mod link;
pub(crate) mod read_back;
pub(crate) mod settings;
pub(crate) mod tcp;
pub(crate) mod transport;

pub use budget::{
    failed_attempt, input_floor, line_budget, line_budget_on, members_floor, modbus_reply_len,
    transaction_time, transaction_time_on, AdapterTiming, LineBudget, ModuleBudget,
};
pub use bus::{
    BusCommand, BusEvent, BusOwner, BusThread, Counters, Discipline, InputFrame, Module,
    ModuleSnapshot, OutputFrame, StartupError, TxError, WriteReport,
};
pub use collect::{
    floor::{CollectFloor, REPLY_LEN as COLLECT_REPLY_LEN, REQUEST_LEN as COLLECT_REQUEST_LEN},
    CollectStats,
};
pub use cycle_mix::{CycleMix, DrivenModule, FullRead, ModuleMix, Prediction};
pub use echo::{echo_margin, BadEchoMode, EchoDiscard, EchoFault, EchoMode};
pub use latency::{
    AdapterLatency, Assumed, LatencyRefused, LowLatencyRefused, Lowered, NoTimer, Probe, Source,
    SysfsRoot,
};
pub use link::{Delivery, LineLink, WriteEnd};
pub use settings::{BadFormat, LineSettings, Parity, SerialFormat};
pub use tcp::{
    EndpointError, ModbusTcpTransport, NetFraming, RtuOverTcpTransport, TcpEndpoint,
    CONNECT_TIMEOUT,
};
pub use transport::{
    open_tty, pty_pair, CallMiss, LineError, LineFault, PduChannel, Rs485Mode, SerialTransport,
    TTYPort, Transport,
};
