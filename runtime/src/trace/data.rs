//! A trace's samples taken out of the scan: what `softplc trace save` and the web page get,
//! serialisable for the control socket, and written as CSV or VCD with [`super::export`].

use std::io::Write;
use std::time::Duration;

use serde::{Deserialize, Serialize};
use softplc_io::point::{Value, ValueType};

use super::capture::{Capture, TraceState};
use super::export::{CsvWriter, ExportError, Sample, Signal, VcdWriter};
use softplc_io::time::ScanInstant;

/// One signal of a trace, as sent.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignalInfo {
    /// Its name.
    pub name: String,
    /// Its type (`bool`, `u16`, `i32`, `f32`).
    #[serde(rename = "type")]
    pub ty: String,
    /// The unit of its values.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
}

/// A trace's samples, oldest first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TraceData {
    /// The project.
    pub project: String,
    /// The trace.
    pub name: String,
    /// Where it was when read.
    pub state: TraceState,
    /// Its signals.
    pub signals: Vec<SignalInfo>,
    /// Each sample's timestamp, ns on the PLC's clock.
    pub time_ns: Vec<u64>,
    /// Each sample's cycle.
    pub cycle: Vec<u64>,
    /// Each sample's values, one per signal (bools as 0 and 1).
    pub values: Vec<Vec<f64>>,
    /// The trigger sample's index, once triggered.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trigger: Option<usize>,
    /// With several tasks: the task whose cycles it sampled (`cycle` counts that task's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task: Option<String>,
}

impl TraceData {
    /// A copy of what `capture` holds; `signals` describe its probes.
    pub fn of(project: &str, capture: &Capture, signals: &[Signal]) -> Self {
        let mut time_ns = Vec::with_capacity(capture.len());
        let mut cycle = Vec::with_capacity(capture.len());
        let mut values = Vec::with_capacity(capture.len());
        for (t, c, row) in capture.samples() {
            time_ns.push(u64::try_from(t.since_origin().as_nanos()).unwrap_or(u64::MAX));
            cycle.push(c);
            values.push(row.iter().map(|v| super::capture::as_f64(*v)).collect());
        }
        Self {
            project: project.to_owned(),
            name: capture.config().name.clone(),
            state: capture.state(),
            signals: signals
                .iter()
                .map(|s| SignalInfo {
                    name: s.name.clone(),
                    ty: s.ty.name().to_owned(),
                    unit: s.unit.map(str::to_owned),
                })
                .collect(),
            time_ns,
            cycle,
            values,
            trigger: capture.trigger().map(|(k, _)| k),
            task: None,
        }
    }

    /// The signals, typed (a type name this version does not know reads as `f32`).
    fn export_signals(&self) -> Vec<(Signal, ValueType)> {
        self.signals
            .iter()
            .map(|s| {
                let ty = ValueType::parse(&s.ty).unwrap_or(ValueType::F32);
                let mut signal = Signal::new(s.name.clone(), ty);
                signal.unit = unit(s.unit.as_deref());
                (signal, ty)
            })
            .collect()
    }

    /// Hands each sample, typed again, to `write`.
    fn each_sample(
        &self,
        types: &[ValueType],
        mut write: impl FnMut(&Sample<'_>) -> Result<(), ExportError>,
    ) -> Result<(), ExportError> {
        let mut row = Vec::with_capacity(types.len());
        for ((t, c), values) in self.time_ns.iter().zip(&self.cycle).zip(&self.values) {
            row.clear();
            row.extend(values.iter().zip(types).map(|(v, ty)| typed(*v, *ty)));
            write(&Sample::new(
                ScanInstant::after_origin(Duration::from_nanos(*t)),
                *c,
                &row,
            ))?;
        }
        Ok(())
    }

    /// Writes it as CSV; with several tasks the cycle column names the task
    /// (`cycle [task press]`).
    pub fn write_csv<W: Write>(&self, out: W) -> Result<W, ExportError> {
        let (signals, types): (Vec<Signal>, Vec<ValueType>) =
            self.export_signals().into_iter().unzip();
        let cycle = match &self.task {
            Some(t) => format!("cycle [task {t}]"),
            None => "cycle".to_owned(),
        };
        let mut w = CsvWriter::with_cycle_column(out, &signals, &cycle)?;
        self.each_sample(&types, |s| w.write(s))?;
        w.finish()
    }

    /// Writes it as VCD, in a scope named after the trace; with several tasks a comment
    /// first names the task whose cycles `cycle` counts.
    pub fn write_vcd<W: Write>(&self, mut out: W) -> Result<W, ExportError> {
        let (signals, types): (Vec<Signal>, Vec<ValueType>) =
            self.export_signals().into_iter().unzip();
        if let Some(t) = &self.task {
            writeln!(out, "$comment cycles of task {t} $end")?;
        }
        let mut w = VcdWriter::new(out, &self.name, &signals)?;
        self.each_sample(&types, |s| w.write(s))?;
        w.finish()
    }
}

/// The units signals have (the export's units are static names).
fn unit(u: Option<&str>) -> Option<&'static str> {
    match u {
        Some("us") => Some("us"),
        _ => None,
    }
}

/// A number back as a value of `ty` (it was one: the conversion is exact).
fn typed(v: f64, ty: ValueType) -> Value {
    match ty {
        ValueType::Bool => Value::Bool(v != 0.0),
        ValueType::U16 => Value::U16(v as u16),
        ValueType::I32 => Value::I32(v as i32),
        ValueType::F32 => Value::F32(v as f32),
    }
}
