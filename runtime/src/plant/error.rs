//! What can be wrong in a plant model file, each at its own line:col, and what stops a model
//! while it runs.

/// One error of a plant model file (the project's [`ErrorKind::Plant`] carries it at the
/// model file's line:col).
///
/// [`ErrorKind::Plant`]: crate::project::ErrorKind::Plant
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// Rhai could not parse the file.
    #[error("{message}")]
    Syntax {
        /// Rhai's words.
        message: String,
    },
    /// The file has no `fn plant()`.
    #[error(
        "a plant model declares itself in fn plant(), which returns \
         #{{ reads: [...], drives: [...], states: #{{...}} }}"
    )]
    NoDeclaration,
    /// `fn plant()` failed or returned something else than a map.
    #[error("fn plant() must return a map (#{{ reads: [...], ... }}): {why}")]
    BadDeclaration {
        /// What went wrong.
        why: String,
    },
    /// A key of the declaration map that means nothing.
    #[error("unknown key \"{key}\" in fn plant() (known: step, reads, drives, states, faults)")]
    UnknownKey {
        /// The key.
        key: String,
    },
    /// A declaration key with a value of the wrong shape.
    #[error("{key} must be {expected}, not {given}")]
    BadShape {
        /// The key (`reads`, `states.position.max`).
        key: String,
        /// What it takes.
        expected: &'static str,
        /// What the model wrote (its type).
        given: String,
    },
    /// A name a step could not use as a variable.
    #[error("\"{name}\" is not a name a step can use (letters, digits and _, not first a digit)")]
    BadName {
        /// The name.
        name: String,
    },
    /// A name declared twice (a terminal and a state, two states, ...).
    #[error("\"{name}\" is declared twice (in {first} and in {second})")]
    Duplicate {
        /// The name.
        name: String,
        /// The first list that has it.
        first: &'static str,
        /// The second.
        second: &'static str,
    },
    /// A name the plant API gives every step (`dt`, `time`).
    #[error("\"{name}\" is the plant API's own name (dt: the step in seconds, time: seconds since the start); choose another")]
    Reserved {
        /// The name.
        name: String,
    },
    /// The step is not a duration the world can keep.
    #[error("step \"{given}\" must be a duration from 1ms to 1s, in whole milliseconds ({why})")]
    BadStep {
        /// The text given.
        given: String,
        /// Why not.
        why: String,
    },
    /// A state whose limits are upside down.
    #[error("state {name}: min {min} is above max {max}")]
    LimitsReversed {
        /// The state.
        name: String,
        /// Its min.
        min: f64,
        /// Its max.
        max: f64,
    },
    /// A state whose initial value is outside its limits.
    #[error("state {name}: the initial value {initial} is outside its limits {min}..{max}")]
    InitialOutsideLimits {
        /// The state.
        name: String,
        /// Its initial value.
        initial: f64,
        /// Its min (or -inf).
        min: f64,
        /// Its max (or inf).
        max: f64,
    },
    /// Limits on a state that is not a number.
    #[error("state {name} is a bool: min and max are for numbers")]
    LimitsOnBool {
        /// The state.
        name: String,
    },
    /// A fault whose `at` is not a duration.
    #[error("fault {name}: at \"{given}\" is not a duration ({why})")]
    BadFaultTime {
        /// The fault.
        name: String,
        /// The text given.
        given: String,
        /// Why not.
        why: String,
    },
    /// A name used in the step that the model never declared.
    #[error("unknown name `{name}`: not a terminal, state or variable of the model{hint}")]
    UnknownName {
        /// The name.
        name: String,
        /// `; did you mean ...` or empty.
        hint: String,
    },
    /// A write to a terminal the model reads (a module output: the program drives it).
    #[error("`{name}` is a terminal the model reads (a module output the program drives); a model cannot write it")]
    WritesRead {
        /// The terminal.
        name: String,
    },
    /// A write to `dt` or `time`, which the plant API gives every step.
    #[error("`{name}` is given by the plant API every step (dt: the step in seconds, time: seconds since the start); a model cannot write it")]
    WritesApi {
        /// The name.
        name: String,
    },
}

/// What stopped a running model: Rhai's error or a state that went wrong, where it is known.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RunError {
    /// The step failed (Rhai's words, its line:col when it has one).
    #[error("{message}")]
    Script {
        /// Rhai's words.
        message: String,
    },
    /// A state or terminal set to a value of another type.
    #[error("{what} {name} is a {expected}; the step set it to {given}")]
    WrongType {
        /// `state` or `terminal`.
        what: &'static str,
        /// Its name.
        name: String,
        /// Its type.
        expected: &'static str,
        /// What the step left in it.
        given: String,
    },
    /// A float state that is not a number any more (a division by zero).
    #[error("state {name} is not a number any more ({value})")]
    NotANumber {
        /// The state.
        name: String,
        /// `NaN` or `inf`.
        value: f64,
    },
}
