//! A family's commissioning protocol, sans-IO: what a host asks of a module to set its
//! address, line settings and reply delay and make them permanent by the module's own means,
//! as a [`Plan`] of steps that a runner (the runtime's `softplc commission`) prints, confirms
//! and executes on a real port. A family reads what it needs through a [`Conversation`]
//! before planning, and refuses what its manual forbids before anything is written.

use std::error::Error;
use std::time::Duration;

use crate::line::{LineSettings, SerialFormat};

/// What the engineer asks for (`softplc commission`'s options).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommissionRequest {
    /// The module's address now.
    pub address: u8,
    /// The line settings the module answers at now.
    pub now: LineSettings,
    /// The module checks and sends DCON checksums now.
    pub checksum: bool,
    /// The new address.
    pub set_address: Option<u8>,
    /// The new baud rate.
    pub set_baud: Option<u32>,
    /// The new character format.
    pub set_format: Option<SerialFormat>,
    /// DCON checksums on or off from the next power-on.
    pub set_checksum: Option<bool>,
    /// The new reply delay.
    pub set_reply_delay: Option<Duration>,
}

/// Whether an answer is the one a step expects; the error says what it is instead.
pub type Check = Box<dyn Fn(&str) -> Result<(), String>>;

/// What a [`Step::Send`] waits for.
pub enum Expect {
    /// An answer the check accepts.
    Answer(Check),
    /// No answer: the manual says the module gives none.
    Silence,
}

/// One thing commissioning does, in order.
pub enum Step {
    /// Sends a frame at the settings in use.
    Send {
        /// What it does, in words.
        what: String,
        /// The frame.
        frame: Vec<u8>,
        /// The answer it waits for.
        expect: Expect,
    },
    /// Talks at other settings from here on (the module has switched).
    Switch(LineSettings),
    /// The engineer acts on the module (wiring, power); then `frame` is asked at `settings`
    /// until the module answers as `check` wants, for at most `within` (or the runner's own
    /// wait).
    Await {
        /// What is awaited, in words.
        what: String,
        /// What the engineer does first, in order.
        instructions: Vec<String>,
        /// The settings the module answers at afterwards.
        settings: LineSettings,
        /// The question.
        frame: Vec<u8>,
        /// The answer it waits for.
        check: Check,
        /// How long at most, when the family knows.
        within: Option<Duration>,
    },
}

impl std::fmt::Debug for Expect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Expect::Answer(_) => f.write_str("Answer(..)"),
            Expect::Silence => f.write_str("Silence"),
        }
    }
}

impl std::fmt::Debug for Step {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Step::Send {
                what,
                frame,
                expect,
            } => f
                .debug_struct("Send")
                .field("what", what)
                .field("frame", frame)
                .field("expect", expect)
                .finish(),
            Step::Switch(s) => f.debug_tuple("Switch").field(s).finish(),
            Step::Await {
                what,
                instructions,
                settings,
                frame,
                within,
                ..
            } => f
                .debug_struct("Await")
                .field("what", what)
                .field("instructions", instructions)
                .field("settings", settings)
                .field("frame", frame)
                .field("within", within)
                .finish_non_exhaustive(),
        }
    }
}

/// What a family plans: the steps, and what is true when they have all passed.
#[derive(Debug)]
pub struct Plan {
    /// The steps, in order.
    pub steps: Vec<Step>,
    /// What is true once they passed, in words.
    pub done: String,
}

/// The line to the module while a family plans: questions asked at the settings in use, and
/// notes for the engineer.
pub trait Conversation {
    /// Sends `frame` (`what` it asks, in words) and returns the answer without its CR, `None`
    /// without one.
    fn ask(&mut self, what: &str, frame: &[u8]) -> Result<Option<String>, LineFailed>;

    /// The settings the line is at.
    fn settings(&self) -> LineSettings;

    /// Tells the engineer something the family read (`   DIP1..8 = 00000000`).
    fn note(&mut self, line: &str) -> Result<(), LineFailed>;
}

/// The line or the terminal failed while a family asked: the runner's own error.
#[derive(Debug, thiserror::Error)]
#[error(transparent)]
pub struct LineFailed(pub Box<dyn Error + Send + Sync>);

/// Why a family gives no plan.
#[derive(Debug, thiserror::Error)]
pub enum CommissionError {
    /// The family's manual forbids it, or the module's answer did not allow it: the family's
    /// own typed refusal.
    #[error(transparent)]
    Refused(Box<dyn Error + Send + Sync>),
    /// The line failed.
    #[error(transparent)]
    Line(#[from] LineFailed),
    /// The family has no commissioning a host can do.
    #[error("a {family} module is not commissioned by a host")]
    NotCommissioned {
        /// The family's name.
        family: &'static str,
    },
}

impl CommissionError {
    /// A family's typed refusal.
    pub fn refused(why: impl Error + Send + Sync + 'static) -> Self {
        CommissionError::Refused(Box::new(why))
    }
}
