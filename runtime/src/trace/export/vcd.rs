//! VCD, the value change dump of IEEE 1364 (§18, "Value change dump (VCD) files"), as GTKWave
//! and PulseView (libsigrok's `vcd` input) read it.
//!
//! ```text
//! $version softplc $end
//! $timescale 1 us $end
//! $scope module quickstart $end
//! $var real 64 ! cycle $end
//! $var wire 1 " x1 $end
//! $scope module phase $end
//! $var real 64 # logic $end
//! $upscope $end
//! $upscope $end
//! $enddefinitions $end
//! #10000
//! r1 !
//! 0"
//! r12 #
//! #20000
//! r2 !
//! 1"
//! ```
//!
//! Choices the standard leaves open, made for the two viewers:
//! - bools are `wire 1`; every number (`u16`, `i32`, `f32`) is `real 64`, which both viewers
//!   plot as an analog trace and which holds every `u16` and `i32` exactly (an `integer` var is
//!   a bit vector, which PulseView shows as unsigned);
//! - the scan cycle is a `real` var of its own, `cycle`, so a viewer's cursor gives it;
//! - the first sample dumps every value after its timestamp rather than in `$dumpvars`, which
//!   libsigrok does not read; later samples dump only what changed;
//! - times are absolute scan timestamps in the chosen [`Timescale`]. The trace uses 1 µs:
//!   PulseView expands a VCD into samples at the timescale's rate, so 1 ns would turn one
//!   second of trace into 10⁹ samples; sub-microsecond parts of a monotonic timestamp are
//!   truncated;
//! - a dotted signal name (`phase.logic`) is the var `logic` in a nested scope `phase`;
//!   whitespace in a name becomes `_` (a VCD reference is one word). No `$date`, so the same
//!   samples give the same file.

use std::io::Write;
use std::time::Duration;

use softplc_io::point::{Value, ValueType};

use super::{check_width, fmt_value, ExportError, Sample, Signal};
use softplc_io::time::ScanInstant;

/// The unit of the `#` timestamps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Timescale {
    /// `1 us`: what the trace writes (see the module docs for why).
    #[default]
    Micros,
    /// `1 ns`: exact for any timestamp.
    Nanos,
}

impl Timescale {
    fn declaration(self) -> &'static str {
        match self {
            Timescale::Micros => "1 us",
            Timescale::Nanos => "1 ns",
        }
    }

    fn ticks(self, t: Duration) -> u128 {
        match self {
            Timescale::Micros => t.as_micros(),
            Timescale::Nanos => t.as_nanos(),
        }
    }
}

/// Writes samples as a value change dump.
#[derive(Debug)]
pub struct VcdWriter<W: Write> {
    out: W,
    timescale: Timescale,
    /// Each signal's type, for how its values are dumped.
    types: Vec<ValueType>,
    /// The values last dumped (none before the first sample) and the cycle.
    last: Option<(ScanInstant, u64, Vec<Value>)>,
    last_tick: Option<u128>,
    text: String,
}

impl<W: Write> VcdWriter<W> {
    /// Writes the header declaring `signals` in a scope named `scope`, timescale 1 µs.
    pub fn new(out: W, scope: &str, signals: &[Signal]) -> Result<Self, ExportError> {
        Self::with_timescale(out, scope, signals, Timescale::default())
    }

    /// Writes the header declaring `signals` in a scope named `scope`, in `timescale`.
    pub fn with_timescale(
        mut out: W,
        scope: &str,
        signals: &[Signal],
        timescale: Timescale,
    ) -> Result<Self, ExportError> {
        let mut h = String::new();
        h.push_str("$version softplc $end\n");
        h.push_str(&format!("$timescale {} $end\n", timescale.declaration()));
        h.push_str(&format!("$scope module {} $end\n", word(scope)));
        h.push_str(&format!("$var real 64 {} cycle $end\n", code(0)));
        let mut open: Vec<&str> = Vec::new();
        for (i, s) in signals.iter().enumerate() {
            let mut path: Vec<&str> = s.name.split('.').collect();
            let leaf = path.pop().unwrap_or_default();
            let common = open.iter().zip(&path).take_while(|(a, b)| a == b).count();
            for _ in common..open.len() {
                h.push_str("$upscope $end\n");
            }
            open.truncate(common);
            for p in &path[common..] {
                h.push_str(&format!("$scope module {} $end\n", word(p)));
                open.push(p);
            }
            let (kind, width) = match s.ty {
                ValueType::Bool => ("wire", 1),
                _ => ("real", 64),
            };
            h.push_str(&format!(
                "$var {kind} {width} {} {} $end\n",
                code(i + 1),
                word(leaf)
            ));
        }
        for _ in 0..=open.len() {
            h.push_str("$upscope $end\n");
        }
        h.push_str("$enddefinitions $end\n");
        out.write_all(h.as_bytes())?;
        Ok(Self {
            out,
            timescale,
            types: signals.iter().map(|s| s.ty).collect(),
            last: None,
            last_tick: None,
            text: String::new(),
        })
    }

    /// Dumps what changed since the previous sample (everything, for the first).
    pub fn write(&mut self, sample: &Sample<'_>) -> Result<(), ExportError> {
        check_width(self.types.len(), sample)?;
        if let Some((t, _, _)) = &self.last {
            if sample.time < *t {
                return Err(ExportError::TimeBackwards {
                    cycle: sample.cycle,
                });
            }
        }
        self.text.clear();
        let tick = self.timescale.ticks(sample.time.since_origin());
        // Two samples in one tick share its timestamp; a viewer takes the later values.
        if self.last_tick != Some(tick) {
            self.text.push_str(&format!("#{tick}\n"));
            self.last_tick = Some(tick);
        }
        let first = self.last.is_none();
        let (last_cycle, last_values) = match &self.last {
            Some((_, c, v)) => (Some(*c), v.as_slice()),
            None => (None, &[][..]),
        };
        if last_cycle != Some(sample.cycle) {
            self.text
                .push_str(&format!("r{} {}\n", sample.cycle, code(0)));
        }
        for (i, (v, ty)) in sample.values.iter().zip(&self.types).enumerate() {
            if !first && last_values[i] == *v {
                continue;
            }
            match ty {
                ValueType::Bool => {
                    self.text
                        .push_str(&format!("{}{}\n", u8::from(v.as_bool()), code(i + 1)));
                }
                _ => {
                    self.text
                        .push_str(&format!("r{} {}\n", fmt_value(*v), code(i + 1)));
                }
            }
        }
        self.out.write_all(self.text.as_bytes())?;
        match &mut self.last {
            Some((t, c, v)) => {
                *t = sample.time;
                *c = sample.cycle;
                v.copy_from_slice(sample.values);
            }
            None => self.last = Some((sample.time, sample.cycle, sample.values.to_vec())),
        }
        Ok(())
    }

    /// Flushes and hands back the output.
    pub fn finish(mut self) -> Result<W, ExportError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

/// The identifier code of the `n`th var: printable ASCII `!`..`~`, as short as it can be.
fn code(mut n: usize) -> String {
    const BASE: usize = (b'~' - b'!' + 1) as usize;
    let mut s = String::new();
    loop {
        s.push(char::from(b'!' + (n % BASE) as u8));
        n /= BASE;
        if n == 0 {
            return s;
        }
        n -= 1;
    }
}

/// A name as one VCD word.
fn word(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifier_codes_are_unique_and_printable() {
        assert_eq!(code(0), "!");
        assert_eq!(code(93), "~");
        assert_eq!(code(94), "!!");
        let all: std::collections::HashSet<String> = (0..20_000).map(code).collect();
        assert_eq!(all.len(), 20_000);
        assert!(all
            .iter()
            .all(|c| c.bytes().all(|b| (b'!'..=b'~').contains(&b))));
    }

    #[test]
    fn only_changes_are_dumped_in_nested_scopes() {
        let signals = [
            Signal::new("x1", ValueType::Bool),
            Signal::new("phase.read", ValueType::I32).with_unit("us"),
            Signal::new("phase.logic", ValueType::I32).with_unit("us"),
            Signal::new("speed", ValueType::F32),
        ];
        let mut w = VcdWriter::new(Vec::new(), "demo", &signals).unwrap();
        let ms = Duration::from_millis;
        let rows = [
            (ms(10), false, 5, 12, 0.0),
            (ms(20), true, 5, 11, 0.0),
            (ms(30), true, 5, 11, 0.1),
        ];
        for (n, (t, x1, read, logic, speed)) in rows.into_iter().enumerate() {
            let values = [
                Value::Bool(x1),
                Value::I32(read),
                Value::I32(logic),
                Value::F32(speed),
            ];
            w.write(&Sample::new(
                ScanInstant::after_origin(t),
                n as u64 + 1,
                &values,
            ))
            .unwrap();
        }
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        assert_eq!(
            text,
            "$version softplc $end\n$timescale 1 us $end\n$scope module demo $end\n\
             $var real 64 ! cycle $end\n$var wire 1 \" x1 $end\n$scope module phase $end\n\
             $var real 64 # read $end\n$var real 64 $ logic $end\n$upscope $end\n\
             $var real 64 % speed $end\n$upscope $end\n$enddefinitions $end\n\
             #10000\nr1 !\n0\"\nr5 #\nr12 $\nr0 %\n\
             #20000\nr2 !\n1\"\nr11 $\n\
             #30000\nr3 !\nr0.1 %\n"
        );
    }

    #[test]
    fn time_that_goes_back_is_refused() {
        let mut w = VcdWriter::new(Vec::new(), "d", &[]).unwrap();
        w.write(&Sample::new(
            ScanInstant::after_origin(Duration::from_millis(2)),
            1,
            &[],
        ))
        .unwrap();
        let e = w
            .write(&Sample::new(
                ScanInstant::after_origin(Duration::from_millis(1)),
                2,
                &[],
            ))
            .unwrap_err();
        assert!(matches!(e, ExportError::TimeBackwards { cycle: 2 }), "{e}");
    }
}
