//! What a scenario reports: rows of the results table (figures as percentiles, each against the
//! bounds measured or computed in the same run, or single quantities against their goals) and
//! the plots that go with them.

use std::time::Duration;

use softplc::scan::{DurationHistogram, Percentiles};

/// A bound a figure is compared with: the wire-time floor, a manual's figure, or a baseline
/// measured in the same run. A constant bound has `p50 == p99`; a measured baseline gives its
/// own percentiles, so p50 is compared with p50 and p99 with p99.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Bound {
    /// What the bound is, as a reader needs it ("wire-time floor", "tokio interval loop").
    pub name: String,
    /// The bound at the median.
    pub p50: Duration,
    /// The bound at the 99th percentile.
    pub p99: Duration,
}

impl Bound {
    /// A bound that is one number (a floor, a figure from a manual).
    pub(crate) fn fixed(name: impl Into<String>, value: Duration) -> Self {
        Self {
            name: name.into(),
            p50: value,
            p99: value,
        }
    }

    /// A baseline measured in the same run: percentile against percentile.
    pub(crate) fn baseline(name: impl Into<String>, of: &Percentiles) -> Self {
        Self {
            name: name.into(),
            p50: of.p50,
            p99: of.p99,
        }
    }

    /// `figure / bound` at the median and at the 99th percentile (`None` for a zero bound).
    pub(crate) fn ratios(&self, figure: &Percentiles) -> (Option<f64>, Option<f64>) {
        let r =
            |a: Duration, b: Duration| (!b.is_zero()).then(|| a.as_secs_f64() / b.as_secs_f64());
        (r(figure.p50, self.p50), r(figure.p99, self.p99))
    }
}

/// One measured number that is not a distribution of times: a binary's size, a process's
/// memory or CPU share, a single time. Each kind keeps its unit, so a size is compared with a
/// size goal only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Quantity {
    /// Bytes (a file's size, a process's resident memory).
    Bytes(u64),
    /// Percent of one CPU core over a window.
    PercentOfCore(f64),
    /// A count of things.
    Count(u64),
    /// One time (a median of a few runs: the row's note says of what).
    Time(Duration),
}

impl Quantity {
    /// The number in the unit the JSON file stores (bytes, %, count, µs).
    pub(crate) fn number(&self) -> f64 {
        match *self {
            Quantity::Bytes(b) => b as f64,
            Quantity::PercentOfCore(p) => p,
            Quantity::Count(n) => n as f64,
            Quantity::Time(d) => d.as_nanos() as f64 / 1e3,
        }
    }

    /// The unit's name in the JSON file.
    pub(crate) fn unit(&self) -> &'static str {
        match self {
            Quantity::Bytes(_) => "bytes",
            Quantity::PercentOfCore(_) => "percent_of_core",
            Quantity::Count(_) => "count",
            Quantity::Time(_) => "us",
        }
    }

    /// `self / of`, for quantities of the same kind (`None` across kinds or for a zero `of`).
    pub(crate) fn ratio_to(&self, of: &Quantity) -> Option<f64> {
        let same = std::mem::discriminant(self) == std::mem::discriminant(of);
        (same && of.number() != 0.0).then(|| self.number() / of.number())
    }
}

/// A goal a [`Quantity`] is held to (a size, a memory or CPU budget), by name.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Goal {
    /// What the goal is ("goal", "issue 30's goal").
    pub name: String,
    /// The most the figure may be.
    pub limit: Quantity,
}

/// The figure of a row.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Figure {
    /// A measured distribution.
    Measured(Percentiles),
    /// One measured number, with the goal it is held to if any.
    Scalar {
        /// The figure.
        value: Quantity,
        /// Its goal.
        goal: Option<Goal>,
    },
    /// The scenario needs a feature that has not landed: say so rather than invent a figure.
    /// No scenario waits for one at present; kept for the next (README "Scenarios").
    #[cfg_attr(not(test), allow(dead_code))]
    NotYet {
        /// The missing feature.
        feature: String,
        /// The issue that brings it.
        issue: String,
    },
    /// The measurement could not be made on this machine (a tool missing, a run that failed).
    Unavailable(String),
}

/// One row of the results table.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Row {
    /// The measured situation ("N=4, 19200 8E1, reply delay 10 ms").
    pub case: String,
    /// What is measured ("I/O cycle", "wake-up lateness").
    pub metric: String,
    /// The figure.
    pub figure: Figure,
    /// Bounds the figure is compared with, first one first in the table.
    pub bounds: Vec<Bound>,
    /// Scalars that belong with the figure (transactions per second, a floor in ms), for the
    /// JSON file.
    pub values: Vec<(String, f64)>,
    /// One line for the reader.
    pub note: String,
}

impl Row {
    /// A measured row.
    pub(crate) fn measured(
        case: impl Into<String>,
        metric: impl Into<String>,
        p: Percentiles,
    ) -> Self {
        Self {
            case: case.into(),
            metric: metric.into(),
            figure: Figure::Measured(p),
            bounds: Vec::new(),
            values: Vec::new(),
            note: String::new(),
        }
    }

    /// A row of one number, held to `goal` if given.
    pub(crate) fn scalar(
        case: impl Into<String>,
        metric: impl Into<String>,
        value: Quantity,
        goal: Option<Goal>,
    ) -> Self {
        Self {
            case: case.into(),
            metric: metric.into(),
            figure: Figure::Scalar { value, goal },
            bounds: Vec::new(),
            values: Vec::new(),
            note: String::new(),
        }
    }

    /// A row for a scenario whose feature has not landed yet.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(crate) fn not_yet(case: impl Into<String>, feature: &str, issue: &str) -> Self {
        Self {
            case: case.into(),
            metric: "—".into(),
            figure: Figure::NotYet {
                feature: feature.into(),
                issue: issue.into(),
            },
            bounds: Vec::new(),
            values: Vec::new(),
            note: String::new(),
        }
    }

    /// A row for a measurement that could not be made.
    pub(crate) fn unavailable(
        case: impl Into<String>,
        metric: impl Into<String>,
        why: impl Into<String>,
    ) -> Self {
        Self {
            case: case.into(),
            metric: metric.into(),
            figure: Figure::Unavailable(why.into()),
            bounds: Vec::new(),
            values: Vec::new(),
            note: String::new(),
        }
    }

    /// Adds a bound.
    pub(crate) fn bound(mut self, b: Bound) -> Self {
        self.bounds.push(b);
        self
    }

    /// Adds a scalar for the JSON file.
    pub(crate) fn value(mut self, name: &str, v: f64) -> Self {
        self.values.push((name.to_string(), v));
        self
    }

    /// Sets the note.
    pub(crate) fn note(mut self, note: impl Into<String>) -> Self {
        self.note = note.into();
        self
    }

    /// The measured percentiles, if any.
    pub(crate) fn percentiles(&self) -> Option<&Percentiles> {
        match &self.figure {
            Figure::Measured(p) => Some(p),
            _ => None,
        }
    }
}

/// One curve of a plot.
#[derive(Debug, Clone)]
pub(crate) struct Series {
    /// Legend text.
    pub label: String,
    /// The samples.
    pub hist: DurationHistogram,
}

/// How a plot shows its series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PlotKind {
    /// Cumulative distribution; `log_x` for figures spanning decades (µs to ms).
    Cdf {
        /// Logarithmic time axis.
        log_x: bool,
    },
    /// Histogram of counts per bin (bins shared by every series).
    Histogram,
}

/// A plot a scenario asks for.
#[derive(Debug, Clone)]
pub(crate) struct Plot {
    /// File name inside the results folder (`scheduler-lateness.svg`).
    pub file: String,
    /// Title.
    pub title: String,
    /// Label of the time axis.
    pub x_label: String,
    /// Kind.
    pub kind: PlotKind,
    /// Curves.
    pub series: Vec<Series>,
}

/// Everything one scenario produced.
#[derive(Debug, Default)]
pub(crate) struct Outcome {
    /// Table rows.
    pub rows: Vec<Row>,
    /// Plots.
    pub plots: Vec<Plot>,
}
