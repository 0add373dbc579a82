//! A small SVG writer for the results: cumulative distributions and histograms of durations,
//! several series per plot, no plotting crate.

use crate::report::{Plot, PlotKind, Series};
use std::fmt::Write;

const WIDTH: f64 = 900.0;
const HEIGHT: f64 = 440.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 230.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 55.0;
const BINS: usize = 50;
const COLOURS: [&str; 9] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#17becf",
];

/// `(value in ns, count)` of every recorded bucket, ascending.
fn buckets(s: &Series) -> Vec<(f64, u64)> {
    s.hist
        .raw()
        .iter_recorded()
        .map(|v| (v.value_iterated_to() as f64, v.count_at_value()))
        .collect()
}

/// The x axis: maps nanoseconds to pixels, linear or logarithmic.
#[derive(Debug, Clone, Copy)]
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
}

impl Axis {
    fn new(lo: f64, hi: f64, log: bool) -> Self {
        if log {
            let lo = 10f64.powf(lo.max(1.0).log10().floor());
            let hi = 10f64.powf(hi.max(lo * 10.0).log10().ceil());
            Self { lo, hi, log }
        } else {
            let span = (hi - lo).max(1.0);
            let step = nice_step(span / 8.0);
            Self {
                lo: (lo / step).floor() * step,
                hi: (hi / step).ceil() * step,
                log,
            }
        }
    }

    fn px(&self, v: f64) -> f64 {
        let t = if self.log {
            (v.max(self.lo).log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo).max(1.0)
        };
        LEFT + t.clamp(0.0, 1.0) * (WIDTH - LEFT - RIGHT)
    }

    fn ticks(&self) -> Vec<f64> {
        if self.log {
            let mut t = Vec::new();
            let mut v = self.lo;
            while v <= self.hi * 1.0001 {
                t.push(v);
                v *= 10.0;
            }
            t
        } else {
            let step = nice_step((self.hi - self.lo) / 10.0);
            (0..=((self.hi - self.lo) / step).floor() as usize)
                .map(|i| self.lo + i as f64 * step)
                .collect()
        }
    }
}

/// A tick's time, short: `500µs`, `1ms`, `2.5ms`, `1s`.
fn tick_label(ns: f64) -> String {
    let (v, unit) = if ns >= 1e9 {
        (ns / 1e9, "s")
    } else if ns >= 1e6 {
        (ns / 1e6, "ms")
    } else if ns >= 1e3 {
        (ns / 1e3, "µs")
    } else {
        (ns, "ns")
    };
    let text = format!("{v:.2}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    format!("{text}{unit}")
}

/// 1, 2 or 5 × a power of ten, at least `raw`.
fn nice_step(raw: f64) -> f64 {
    let p = 10f64.powf(raw.max(1e-9).log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * p)
}

fn y_px(fraction: f64) -> f64 {
    HEIGHT - BOTTOM - fraction.clamp(0.0, 1.0) * (HEIGHT - TOP - BOTTOM)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Renders `plot` as an SVG document.
pub(crate) fn svg(plot: &Plot) -> String {
    let data: Vec<Vec<(f64, u64)>> = plot.series.iter().map(buckets).collect();
    let lo = data
        .iter()
        .flatten()
        .map(|b| b.0)
        .fold(f64::INFINITY, f64::min);
    let hi = data.iter().flatten().map(|b| b.0).fold(0.0, f64::max);
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) };
    let log = matches!(plot.kind, PlotKind::Cdf { log_x: true });
    let axis = Axis::new(if log { lo } else { lo.min(hi * 0.9) }, hi, log);

    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{}" y="22" font-size="15" text-anchor="middle">{}</text>"#,
        (LEFT + WIDTH - RIGHT) / 2.0,
        escape(&plot.title)
    );
    let curves: Vec<Vec<(f64, f64)>> = match plot.kind {
        PlotKind::Cdf { .. } => data.iter().map(|d| cdf_points(d, &axis)).collect(),
        PlotKind::Histogram => data.iter().map(|d| histogram_points(d, &axis)).collect(),
    };
    let y_max = match plot.kind {
        PlotKind::Cdf { .. } => 1.0,
        PlotKind::Histogram => {
            let top = curves
                .iter()
                .flatten()
                .map(|p| p.1)
                .fold(0.0, f64::max)
                .max(0.01);
            let step = nice_step(top / 4.0);
            ((top / step).ceil() * step).min(1.0)
        }
    };
    frame(&mut out, &axis, plot, y_max);
    for (i, (curve, series)) in curves.iter().zip(&plot.series).enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let points: Vec<String> = curve
            .iter()
            .map(|(x, y)| format!("{:.1},{:.1}", x, y_px(y / y_max)))
            .collect();
        let _ = writeln!(
            out,
            r#"<polyline fill="none" stroke="{colour}" stroke-width="1.6" points="{}"/>"#,
            points.join(" ")
        );
        let ly = TOP + 10.0 + i as f64 * 18.0;
        let lx = WIDTH - RIGHT + 15.0;
        let _ = writeln!(
            out,
            r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{colour}" stroke-width="3"/><text x="{}" y="{}">{} (n={})</text>"#,
            lx + 20.0,
            lx + 26.0,
            ly + 4.0,
            escape(&series.label),
            series.hist.raw().len()
        );
    }
    out.push_str("</svg>\n");
    out
}

/// Axes, ticks and labels.
fn frame(out: &mut String, axis: &Axis, plot: &Plot, y_max: f64) {
    let (x0, x1, y0, y1) = (LEFT, WIDTH - RIGHT, HEIGHT - BOTTOM, TOP);
    let _ = writeln!(
        out,
        r#"<path d="M{x0},{y1} V{y0} H{x1}" fill="none" stroke="black"/>"#
    );
    for t in axis.ticks() {
        let x = axis.px(t);
        let _ = writeln!(
            out,
            r##"<line x1="{x:.1}" y1="{y0}" x2="{x:.1}" y2="{y1}" stroke="#ddd"/><text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"##,
            y0 + 16.0,
            tick_label(t)
        );
    }
    let y_label = match plot.kind {
        PlotKind::Cdf { .. } => "fraction of samples ≤ x",
        PlotKind::Histogram => "fraction of samples per bin",
    };
    for i in 0..=4 {
        let f = f64::from(i) / 4.0;
        let y = y_px(f);
        let _ = writeln!(
            out,
            r##"<line x1="{x0}" y1="{y:.1}" x2="{x1}" y2="{y:.1}" stroke="#eee"/><text x="{}" y="{:.1}" text-anchor="end">{:.2}</text>"##,
            x0 - 6.0,
            y + 4.0,
            f * y_max
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" text-anchor="middle">{}{}</text>"#,
        (x0 + x1) / 2.0,
        HEIGHT - 14.0,
        escape(&plot.x_label),
        if axis.log { " (log scale)" } else { "" }
    );
    let _ = writeln!(
        out,
        r#"<text x="16" y="{}" text-anchor="middle" transform="rotate(-90 16 {})">{y_label}</text>"#,
        (y0 + y1) / 2.0,
        (y0 + y1) / 2.0
    );
}

/// Step curve of the cumulative fraction, in (pixel x, fraction).
fn cdf_points(data: &[(f64, u64)], axis: &Axis) -> Vec<(f64, f64)> {
    let total: u64 = data.iter().map(|b| b.1).sum();
    let mut points = Vec::with_capacity(data.len() * 2 + 1);
    let mut seen = 0u64;
    if let Some(first) = data.first() {
        points.push((axis.px(first.0), 0.0));
    }
    for (v, c) in data {
        let x = axis.px(*v);
        points.push((x, seen as f64 / total.max(1) as f64));
        seen += c;
        points.push((x, seen as f64 / total.max(1) as f64));
    }
    points
}

/// Outline of a histogram with [`BINS`] equal bins over the axis, in (pixel x, fraction).
fn histogram_points(data: &[(f64, u64)], axis: &Axis) -> Vec<(f64, f64)> {
    let total: u64 = data.iter().map(|b| b.1).sum();
    let mut counts = [0u64; BINS];
    for (v, c) in data {
        let t = ((v - axis.lo) / (axis.hi - axis.lo).max(1.0)).clamp(0.0, 0.999_999);
        counts[(t * BINS as f64) as usize] += c;
    }
    let width = (axis.hi - axis.lo) / BINS as f64;
    let mut points = vec![(axis.px(axis.lo), 0.0)];
    for (i, c) in counts.iter().enumerate() {
        let f = *c as f64 / total.max(1) as f64;
        points.push((axis.px(axis.lo + i as f64 * width), f));
        points.push((axis.px(axis.lo + (i + 1) as f64 * width), f));
    }
    points.push((axis.px(axis.hi), 0.0));
    points
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use softplc::scan::DurationHistogram;

    use super::*;

    fn series(label: &str, ms: &[u64]) -> Series {
        let mut hist = DurationHistogram::new();
        for m in ms {
            hist.record(Duration::from_millis(*m));
        }
        Series {
            label: label.into(),
            hist,
        }
    }

    #[test]
    fn cdf_ends_at_one_and_is_monotonic() {
        let s = series("a", &[1, 2, 2, 3, 10]);
        let axis = Axis::new(1e6, 1e7, false);
        let pts = cdf_points(&buckets(&s), &axis);
        assert!(pts.windows(2).all(|w| w[1].1 >= w[0].1 && w[1].0 >= w[0].0));
        assert!((pts.last().unwrap().1 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn renders_a_complete_svg_with_a_legend_per_series() {
        let plot = Plot {
            file: "t.svg".into(),
            title: "A <test>".into(),
            x_label: "time".into(),
            kind: PlotKind::Cdf { log_x: true },
            series: vec![series("one", &[1, 2, 3]), series("two", &[5, 50])],
        };
        let text = svg(&plot);
        assert!(text.starts_with("<svg") && text.trim_end().ends_with("</svg>"));
        assert_eq!(text.matches("<polyline").count(), 2);
        assert!(text.contains("A &lt;test&gt;"));
        assert!(text.contains("two (n=2)"));
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(500_000.0), "500µs");
        assert_eq!(tick_label(1e6), "1ms");
        assert_eq!(tick_label(2.5e6), "2.5ms");
        assert_eq!(tick_label(1e9), "1s");
    }

    #[test]
    fn nice_steps_are_1_2_5() {
        assert_eq!(nice_step(0.7), 1.0);
        assert_eq!(nice_step(1.3), 2.0);
        assert_eq!(nice_step(3000.0), 5000.0);
    }
}
