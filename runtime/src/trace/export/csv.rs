//! CSV (RFC 4180): one header row, then one row per sample.
//!
//! ```text
//! time_s,cycle,x1 [bool],speed [f32],phase.logic [i32 us]
//! 0.010000000,1,0,0,12
//! 0.020000000,2,1,1.5,11
//! ```
//!
//! `time_s` is the scan's timestamp in seconds with nine decimals (exact to the nanosecond, as
//! the clock keeps it); each value column's header names the signal and its type (and unit),
//! so a reader knows a `u16` from a `bool` without the project file.

use std::io::Write;

use super::{check_width, fmt_value, ExportError, Sample, Signal};

/// Writes samples as CSV rows.
#[derive(Debug)]
pub struct CsvWriter<W: Write> {
    out: W,
    width: usize,
    line: String,
}

impl<W: Write> CsvWriter<W> {
    /// Writes the header row for `signals`.
    pub fn new(out: W, signals: &[Signal]) -> Result<Self, ExportError> {
        Self::with_cycle_column(out, signals, "cycle")
    }

    /// Writes the header row for `signals`, the cycle's column headed `cycle` (a trace of one
    /// task of several names it: `cycle [task press]`).
    pub fn with_cycle_column(
        mut out: W,
        signals: &[Signal],
        cycle: &str,
    ) -> Result<Self, ExportError> {
        let mut line = String::from("time_s,");
        push_field(&mut line, cycle);
        for s in signals {
            let head = match s.unit {
                Some(u) => format!("{} [{} {u}]", s.name, s.ty),
                None => format!("{} [{}]", s.name, s.ty),
            };
            line.push(',');
            push_field(&mut line, &head);
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
        Ok(Self {
            out,
            width: signals.len(),
            line,
        })
    }

    /// Writes one sample's row.
    pub fn write(&mut self, sample: &Sample<'_>) -> Result<(), ExportError> {
        use std::fmt::Write as _;
        check_width(self.width, sample)?;
        self.line.clear();
        let _ = write!(
            self.line,
            "{}.{:09},{}",
            sample.time.since_origin().as_secs(),
            sample.time.since_origin().subsec_nanos(),
            sample.cycle
        );
        for v in sample.values {
            self.line.push(',');
            self.line.push_str(&fmt_value(*v));
        }
        self.line.push('\n');
        self.out.write_all(self.line.as_bytes())?;
        Ok(())
    }

    /// Flushes and hands back the output.
    pub fn finish(mut self) -> Result<W, ExportError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// Appends `text` as one field, quoted when it holds a comma, a quote or a line break.
fn push_field(line: &mut String, text: &str) {
    if text.contains([',', '"', '\n', '\r']) {
        line.push('"');
        line.push_str(&text.replace('"', "\"\""));
        line.push('"');
    } else {
        line.push_str(text);
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use softplc_io::point::{Value, ValueType};

    use super::*;
    use softplc_io::time::ScanInstant;

    #[test]
    fn rows_carry_the_time_to_the_nanosecond_the_cycle_and_each_value() {
        let signals = [
            Signal::new("x1", ValueType::Bool),
            Signal::new("count", ValueType::U16),
            Signal::new("speed", ValueType::F32),
            Signal::new("phase.logic", ValueType::I32).with_unit("us"),
            Signal::new("odd,name", ValueType::I32),
        ];
        let mut w = CsvWriter::new(Vec::new(), &signals).unwrap();
        let row = |v: [Value; 5]| v;
        w.write(&Sample::new(
            ScanInstant::after_origin(Duration::from_millis(10)),
            1,
            &row([
                Value::Bool(false),
                Value::U16(0),
                Value::F32(0.0),
                Value::I32(12),
                Value::I32(-1),
            ]),
        ))
        .unwrap();
        w.write(&Sample::new(
            ScanInstant::after_origin(Duration::new(3, 1)),
            2,
            &row([
                Value::Bool(true),
                Value::U16(65535),
                Value::F32(0.1),
                Value::I32(11),
                Value::I32(-2147483648),
            ]),
        ))
        .unwrap();
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        assert_eq!(
            text,
            "time_s,cycle,x1 [bool],count [u16],speed [f32],phase.logic [i32 us],\"odd,name [i32]\"\n\
             0.010000000,1,0,0,0,12,-1\n\
             3.000000001,2,1,65535,0.1,11,-2147483648\n"
        );
    }

    #[test]
    fn a_sample_of_the_wrong_width_is_refused() {
        let mut w = CsvWriter::new(Vec::new(), &[Signal::new("x1", ValueType::Bool)]).unwrap();
        let e = w
            .write(&Sample::new(ScanInstant::ZERO, 1, &[]))
            .unwrap_err();
        assert!(
            matches!(
                e,
                ExportError::Width {
                    expected: 1,
                    got: 0
                }
            ),
            "{e}"
        );
    }
}
