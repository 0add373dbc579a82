//! Writers for sampled signals: CSV for spreadsheets and scripts, VCD (IEEE 1364 value change
//! dump) for waveform viewers (GTKWave, PulseView).
//!
//! The API is typed and streaming so that any producer of per-cycle samples can use it (the
//! trace's save, the flight recorder's replay): declare the [`Signal`]s once, then hand one
//! [`Sample`] per cycle, oldest first, and [`finish`](csv::CsvWriter::finish). Nothing is held
//! back but the previous values (VCD dumps only changes), so a long replay streams to disk.
//!
//! ```
//! use std::time::Duration;
//! use softplc::scan::ScanInstant;
//! use softplc::trace::{Sample, Signal, VcdWriter};
//! use softplc_io::point::{Value, ValueType};
//!
//! let signals = [Signal::new("x1", ValueType::Bool), Signal::new("speed", ValueType::F32)];
//! let mut vcd = VcdWriter::new(Vec::new(), "demo", &signals).unwrap();
//! vcd.write(&Sample::new(ScanInstant::ZERO, 1, &[Value::Bool(false), Value::F32(0.0)])).unwrap();
//! let t = ScanInstant::after_origin(Duration::from_millis(10));
//! vcd.write(&Sample::new(t, 2, &[Value::Bool(true), Value::F32(0.0)])).unwrap();
//! let text = String::from_utf8(vcd.finish().unwrap()).unwrap();
//! // x1's identifier, from its declaration; at 10 ms (timescale 1 us) it changes to 1.
//! let id = text
//!     .lines()
//!     .find(|l| l.starts_with("$var") && l.contains(" x1 "))
//!     .and_then(|l| l.split_whitespace().nth(3))
//!     .unwrap();
//! let at_10ms = text.split("#10000\n").nth(1).unwrap();
//! assert!(at_10ms.lines().any(|l| l == format!("1{id}")), "{text}");
//! ```

pub(crate) mod csv;
pub(crate) mod vcd;

use softplc_io::point::{Value, ValueType};
use softplc_io::time::ScanInstant;

pub use csv::CsvWriter;
pub use vcd::{Timescale, VcdWriter};

/// One recorded signal: a tag, a module counter, a phase time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Signal {
    /// Its name. A dotted name (`mm1.errors`, `phase.logic`) is put in a VCD scope per prefix.
    pub name: String,
    /// The type of its values.
    pub ty: ValueType,
    /// The unit of its values (`us`), when it has one.
    pub unit: Option<&'static str>,
}

impl Signal {
    /// A signal without a unit (a tag).
    pub fn new(name: impl Into<String>, ty: ValueType) -> Self {
        Self {
            name: name.into(),
            ty,
            unit: None,
        }
    }

    /// The same signal with values in `unit`.
    pub fn with_unit(mut self, unit: &'static str) -> Self {
        self.unit = Some(unit);
        self
    }
}

/// The values of every signal at one cycle boundary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample<'a> {
    /// The scan's timestamp (virtual or monotonic clock).
    pub time: ScanInstant,
    /// The scan cycle it was taken after (1 = the first).
    pub cycle: u64,
    /// One value per signal, in the order the signals were declared.
    pub values: &'a [Value],
}

impl<'a> Sample<'a> {
    /// A sample.
    pub fn new(time: ScanInstant, cycle: u64, values: &'a [Value]) -> Self {
        Self {
            time,
            cycle,
            values,
        }
    }
}

/// Why a writer refused a sample or could not write.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The output failed.
    #[error("cannot write: {0}")]
    Io(#[from] std::io::Error),
    /// A sample's value count differs from the signal count.
    #[error("a sample has {got} value(s) for {expected} signal(s)")]
    Width {
        /// Signals declared.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// A sample is older than the one before it (VCD times only go forward).
    #[error("sample of cycle {cycle} is older than the one before it")]
    TimeBackwards {
        /// The sample's cycle.
        cycle: u64,
    },
}

fn check_width(expected: usize, sample: &Sample<'_>) -> Result<(), ExportError> {
    if sample.values.len() == expected {
        Ok(())
    } else {
        Err(ExportError::Width {
            expected,
            got: sample.values.len(),
        })
    }
}

/// A value as both formats print it: bools as 0/1, floats in their shortest exact form.
fn fmt_value(v: Value) -> String {
    v.to_string()
}

#[cfg(test)]
mod tests {
    //! Both writers against byte-exact files: a conveyor start and stop, as a viewer gets it.

    use super::*;
    use std::time::Duration;

    fn signals() -> Vec<Signal> {
        vec![
            Signal::new("start", ValueType::Bool),
            Signal::new("motor", ValueType::Bool),
            Signal::new("parts", ValueType::U16),
            Signal::new("speed", ValueType::F32),
            Signal::new("phase.logic", ValueType::I32).with_unit("us"),
        ]
    }

    /// Six 10 ms cycles: start pressed at cycle 2, the motor follows, a part counted at 4,
    /// the speed ramps, stop at 6.
    fn samples() -> Vec<(Duration, u64, Vec<Value>)> {
        let rows = [
            (false, false, 0, 0.0, 14),
            (true, true, 0, 0.0, 15),
            (false, true, 0, 0.5, 15),
            (false, true, 1, 1.0, 14),
            (false, true, 1, 1.0, 14),
            (false, false, 1, 0.25, 16),
        ];
        rows.into_iter()
            .enumerate()
            .map(|(i, (start, motor, parts, speed, logic))| {
                (
                    Duration::from_millis(10 * i as u64),
                    i as u64 + 1,
                    vec![
                        Value::Bool(start),
                        Value::Bool(motor),
                        Value::U16(parts),
                        Value::F32(speed),
                        Value::I32(logic),
                    ],
                )
            })
            .collect()
    }

    #[test]
    fn csv_matches_the_golden_file() {
        let mut w = CsvWriter::new(Vec::new(), &signals()).unwrap();
        for (t, c, v) in samples() {
            w.write(&Sample::new(ScanInstant::after_origin(t), c, &v))
                .unwrap();
        }
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        assert_eq!(text, include_str!("golden/conveyor.csv"));
    }

    #[test]
    fn vcd_matches_the_golden_file() {
        let mut w = VcdWriter::new(Vec::new(), "conveyor", &signals()).unwrap();
        for (t, c, v) in samples() {
            w.write(&Sample::new(ScanInstant::after_origin(t), c, &v))
                .unwrap();
        }
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        assert_eq!(text, include_str!("golden/conveyor.vcd"));
    }
}
