//! What can be wrong in a profile file beyond its YAML: each error is placed at its node, with
//! the profile file's own file:line:col (a [`crate::project::ProjectError`] of kind
//! [`crate::project::ErrorKind::Profile`]).

/// One semantic error of a profile file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProfileError {
    /// A word-valued key with a word it does not take.
    #[error("unknown {what} {given:?} (known: {})", known.join(", "))]
    UnknownWord {
        /// What the key names (`table`).
        what: &'static str,
        /// The word given.
        given: String,
        /// The words it takes.
        known: Vec<&'static str>,
    },
    /// A name that programs could not use.
    #[error(
        "{what} name {name:?} is not an identifier (letters, digits and _, not first a digit)"
    )]
    BadName {
        /// A point, a bit field, a poll group.
        what: &'static str,
        /// The name.
        name: String,
    },
    /// A model name that is empty or has other than letters, digits, `-` and `_`.
    #[error("model name {0:?} must be letters, digits, - and _")]
    BadModel(String),
    /// Two points (or bit fields) of one name.
    #[error("{what} {name} is already defined at line {line}")]
    Duplicate {
        /// A point or a poll group.
        what: &'static str,
        /// The name.
        name: String,
        /// Line of the first one.
        line: usize,
    },
    /// A number outside what the key takes.
    #[error("{key} takes {min}..={max}, not {given}")]
    OutOfRange {
        /// The key.
        key: &'static str,
        /// The number given.
        given: i64,
        /// Lowest accepted.
        min: i64,
        /// Highest accepted.
        max: i64,
    },
    /// A point whose registers run past the last address.
    #[error("a {data} at address {address} runs past address 65535")]
    PastEnd {
        /// The type.
        data: &'static str,
        /// Its address.
        address: u16,
    },
    /// A type that does not fit the table.
    #[error("{table} points are {expected}; {given} does not fit")]
    TypeNotInTable {
        /// The table.
        table: &'static str,
        /// The types it takes.
        expected: &'static str,
        /// The type given.
        given: &'static str,
    },
    /// A write to a table the master cannot write.
    #[error("{table} points can only be read (access: read)")]
    ReadOnlyTable {
        /// The table.
        table: &'static str,
    },
    /// A key that has no meaning for this point.
    #[error("{key} does not apply to {why}")]
    DoesNotApply {
        /// The key.
        key: &'static str,
        /// What the point is, in words.
        why: &'static str,
    },
    /// A scale of 0 (every raw value would read the same).
    #[error("scale must not be 0")]
    ZeroScale,
    /// A range whose low end is not below its high end, or not finite (the place shows
    /// the numbers).
    #[error("range must be two finite numbers, low below high: [low, high]")]
    BadRange,
    /// A bit field outside its register.
    #[error("bits {first}..={last} do not fit a {bits}-bit register")]
    BitsOutside {
        /// Its first bit.
        first: i64,
        /// Its last bit.
        last: i64,
        /// The register's width.
        bits: u8,
    },
    /// A name that is neither a point nor a group of the profile.
    #[error("no {what} {name:?} in this profile (known: {})", known.join(", "))]
    NoSuch {
        /// A point or a poll group.
        what: &'static str,
        /// The name.
        name: String,
        /// Those there are.
        known: Vec<String>,
    },
    /// A duration that is not one.
    #[error("period {given:?}: {why}; expected cycle or a duration like 10s")]
    BadPeriod {
        /// The text.
        given: String,
        /// Why.
        why: String,
    },
    /// A lag that follows itself, or a point that no program writes and nothing reads.
    #[error("{0}")]
    BadBehaviour(&'static str),
    /// The profile a module names cannot be read.
    #[error("cannot read profile {path}: {message}")]
    Unreadable {
        /// The path as written (after `profile:`).
        path: String,
        /// The system's reason.
        message: String,
    },
    /// A profile with errors (listed before, in the profile's own file).
    #[error("profile {path} has {count} error(s)")]
    Refused {
        /// The path as written.
        path: String,
        /// How many.
        count: usize,
    },
}
