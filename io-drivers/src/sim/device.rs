//! The simulator side of a module.

use std::fmt::Debug;
use std::time::Duration;

use crate::time::LineInstant;

use crate::devices::Protocol;
use crate::point::{PointSpec, Value};

/// A reply a simulator puts on the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SimReply {
    /// The bytes, as they go on the wire.
    pub bytes: Vec<u8>,
    /// Silence between the end of the request and the first reply byte (the module's reply
    /// delay, `RDELAYT` on MiniMod).
    pub delay: Duration,
}

/// A failed command from a person or a test to a simulator.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SimError {
    /// No point of that name on this model.
    #[error("{model} has no point {point}")]
    UnknownPoint {
        /// The model.
        model: &'static str,
        /// The name asked for.
        point: String,
    },
    /// The value does not fit the point.
    #[error("{point} does not take {value}")]
    BadValue {
        /// The point.
        point: String,
        /// The value given.
        value: String,
    },
    /// A model-specific command was not understood.
    #[error("unknown command {0:?}; try `help`")]
    UnknownCommand(String),
}

/// The master's baud and format as a served line conveys them ([`SimDevice::master_line`]):
/// `None` until known; the format `None` where the line carries only the baud (a pty).
pub(crate) type MasterLine = Option<(u32, Option<crate::line::settings::SerialFormat>)>;

/// Whether a UART at `own` reads what a master on `master` sends: same baud, and the same
/// format where it is known. Nothing known yet: it does.
pub(crate) fn hears(own: crate::line::settings::LineSettings, master: MasterLine) -> bool {
    master.is_none_or(|(baud, format)| baud == own.baud && format.is_none_or(|f| f == own.format))
}

/// A simulated module.
pub trait SimDevice: Send + Debug {
    /// The model name (`minimod`).
    fn model(&self) -> &'static str;

    /// The address the module answers at now.
    fn address(&self) -> u8;

    /// Runs the module's own behaviour up to time `t` (its sampling tick, timers, pulsers).
    /// Times before the module's current time are ignored.
    fn advance_to(&mut self, t: LineInstant);

    /// A complete frame seen on the line, ending at time `t` (the device was advanced to `t`).
    /// Every device on the line sees every frame; it answers only if addressed, and never to a
    /// broadcast.
    fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply>;

    /// The model's points (for `get`/`set` and plant models).
    fn points(&self) -> &'static [PointSpec];

    /// Reads a point by the manual's name (`X1`, `Y2`, `XCOUNT1`).
    fn get(&self, point: &str) -> Result<Value, SimError>;

    /// Sets a point as the machine would: inputs are the terminals' levels, outputs and
    /// settings are written as if through the protocol.
    fn set(&mut self, point: &str, value: Value) -> Result<(), SimError>;

    /// A model-specific command from `softplc sim`'s standard input (inject a fault,
    /// power-cycle, flip a dip switch). Returns the text to print.
    fn command(&mut self, words: &[&str]) -> Result<String, SimError> {
        Err(SimError::UnknownCommand(words.join(" ")))
    }

    /// The silence on a line at `settings` that ends a request for this module, when it frames
    /// requests by silence as an RTU slave does (MiniMod: 28 bit times and RDELAYM). The world
    /// then joins what the master sends with shorter pauses into one request and hands it over
    /// once the silence has passed. `None`: every frame the master writes is one request.
    fn frame_silence(&self, settings: crate::line::settings::LineSettings) -> Option<Duration> {
        let _ = settings;
        None
    }

    /// Whether this device's reply to `frame` gives way to an earlier reply to the same frame
    /// (it listens before talking: MiniMod Collect slots, where a slave that hears an earlier
    /// slave answer stays silent until the next Collect).
    fn yields_to_earlier_reply(&self, frame: &[u8]) -> bool {
        let _ = frame;
        false
    }

    /// Brings the module up speaking `protocol`, as its installer would have configured it
    /// (a project's `protocol:` for a module that speaks one protocol at a time). Modules that
    /// answer every protocol at once need nothing.
    fn set_protocol(&mut self, protocol: Protocol) -> Result<(), SimError> {
        let _ = protocol;
        Ok(())
    }

    /// The line's master now talks at `baud` and `format` (`None`: not known, as on a pty,
    /// which carries no parity). A module that models its own UART settings compares them.
    fn master_line(&mut self, baud: u32, format: Option<crate::line::settings::SerialFormat>) {
        let _ = (baud, format);
    }

    /// The module is installed for `settings`: its DIP switches or stored baud and format are
    /// set to them. True if the module models its own UART from then on (its own settings
    /// change with its configuration and a power cycle, and it compares them with
    /// [`SimDevice::master_line`] itself); false leaves the comparison to the world, with
    /// `settings` fixed.
    fn set_uart(&mut self, settings: crate::line::settings::LineSettings) -> bool {
        let _ = settings;
        false
    }

    /// The master's line settings as the device last took them (a `line` console command
    /// sets them on a module that models its own UART); `None` for a device that does not.
    fn master_settings(&self) -> Option<crate::line::settings::LineSettings> {
        None
    }

    /// Help text for [`SimDevice::command`].
    fn command_help(&self) -> &'static str {
        ""
    }
}
