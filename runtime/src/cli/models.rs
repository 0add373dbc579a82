//! `softplc models` and `softplc points MODEL`: the module catalog, read from the same
//! [`ModelSpec`]s the project file is checked against, so what they print is what a project
//! may name (before, one had to start `softplc sim` and type `list`).

use std::fmt::Write as _;
use std::process::ExitCode;

use softplc_io::devices::{self, ModelSpec};
use softplc_io::point::{Access, PointSpec};

use crate::suggest::edit_distance;

/// Arguments of `softplc models`.
#[derive(Debug, clap::Args)]
pub(crate) struct ModelsArgs {}

/// Arguments of `softplc points`.
#[derive(Debug, clap::Args)]
pub(crate) struct PointsArgs {
    /// The model, as a project file names it (`minimod`, `resi-16di8ro`, `ex9053d`).
    model: String,
    /// Only the points of one direction.
    #[arg(long, value_enum)]
    only: Option<Direction>,
}

/// Who writes a point, as `softplc points --only` names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Direction {
    /// Read from the module.
    Input,
    /// Written by the program.
    Output,
    /// Module settings: read, and writable (counters, latencies, masks).
    Setting,
}

impl Direction {
    fn of(access: Access) -> Self {
        match access {
            Access::Input => Direction::Input,
            Access::Output => Direction::Output,
            Access::ReadWrite => Direction::Setting,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Direction::Input => "input",
            Direction::Output => "output",
            Direction::Setting => "setting",
        }
    }
}

pub(super) fn models(_: ModelsArgs) -> anyhow::Result<ExitCode> {
    super::out::out(&catalog_table(devices::catalog()))?;
    Ok(ExitCode::SUCCESS)
}

pub(super) fn points(args: PointsArgs) -> anyhow::Result<ExitCode> {
    let Some(model) = devices::model(&args.model) else {
        super::out::errln(&unknown_model(&args.model, devices::catalog()));
        return Ok(ExitCode::FAILURE);
    };
    super::out::out(&points_table(model, args.only))?;
    Ok(ExitCode::SUCCESS)
}

/// One line per model: its name, protocols, addresses, fastest baud, reply delay at power-on,
/// how many inputs and outputs it has, and what it is.
fn catalog_table(catalog: &[&ModelSpec]) -> String {
    let width = catalog.iter().map(|m| m.name.len()).max().unwrap_or(0);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<width$}  {:<11}  {:<9}  {:>6}  {:>7}  {:>3} {:>3} {:>3}  what",
        "model", "protocols", "addresses", "≤ baud", "delay", "in", "out", "set"
    );
    for m in catalog {
        let protocols: Vec<&str> = m.protocols.iter().map(|p| p.name()).collect();
        let count = |d: Direction| {
            m.points
                .iter()
                .filter(|p| Direction::of(p.access) == d)
                .count()
        };
        let _ = writeln!(
            out,
            "{:<width$}  {:<11}  {:<9}  {:>6}  {:>7}  {:>3} {:>3} {:>3}  {}",
            m.name,
            protocols.join(","),
            format!("{}..{}", m.addresses.start(), m.addresses.end()),
            m.max_baud,
            crate::scan::fmt_duration(m.default_reply_delay),
            count(Direction::Input),
            count(Direction::Output),
            count(Direction::Setting),
            m.summary
        );
    }
    let _ = writeln!(
        out,
        "\n`softplc points MODEL` lists a model's points; delay is the reply delay at power-on."
    );
    out
}

/// One line per point, in the model's order: the name a tag's `point:` takes, its direction
/// and type, and the manual's name and address.
fn points_table(model: &ModelSpec, only: Option<Direction>) -> String {
    let shown: Vec<&PointSpec> = model
        .points
        .iter()
        .filter(|p| only.is_none_or(|d| Direction::of(p.access) == d))
        .collect();
    let width = shown.iter().map(|p| p.name.len()).max().unwrap_or(5).max(5);
    let mut out = String::new();
    let _ = writeln!(out, "{}: {}", model.name, model.summary);
    let _ = writeln!(
        out,
        "{:<width$}  {:<7}  {:<4}  manual",
        "point", "dir", "type"
    );
    for p in &shown {
        let _ = writeln!(
            out,
            "{:<width$}  {:<7}  {:<4}  {}",
            p.name,
            Direction::of(p.access).name(),
            p.ty.name(),
            p.doc
        );
    }
    let _ = writeln!(out, "{} point(s)", shown.len());
    out
}

/// The error for a model the catalog does not have, with the nearest names.
fn unknown_model(name: &str, catalog: &[&ModelSpec]) -> String {
    let wanted = name.to_ascii_lowercase();
    let mut near: Vec<(usize, &str)> = catalog
        .iter()
        .map(|m| (edit_distance(&wanted, m.name), m.name))
        .filter(|(d, n)| *d <= 2 || n.contains(&wanted) || wanted.contains(n))
        .collect();
    near.sort();
    let all: Vec<&str> = catalog.iter().map(|m| m.name).collect();
    match near.first() {
        Some((_, n)) => format!(
            "error: unknown model `{name}`; did you mean `{n}`? (models: {})",
            all.join(", ")
        ),
        None => format!("error: unknown model `{name}` (models: {})", all.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_of_the_catalog_is_listed_once() {
        let table = catalog_table(devices::catalog());
        for m in devices::catalog() {
            let lines = table
                .lines()
                .filter(|l| l.split_whitespace().next() == Some(m.name))
                .count();
            assert_eq!(lines, 1, "{}:\n{table}", m.name);
        }
    }

    #[test]
    fn the_minimod_lists_inputs_outputs_and_settings_with_manual_names() {
        let model = devices::model("minimod").expect("minimod in the catalog");
        let all = points_table(model, None);
        let x1 = all
            .lines()
            .find(|l| l.starts_with("X1 "))
            .unwrap_or_else(|| panic!("no X1 in:\n{all}"));
        assert!(x1.contains("input") && x1.contains("bool"), "{x1}");
        let y1 = all.lines().find(|l| l.starts_with("Y1 ")).expect("Y1");
        assert!(y1.contains("output") && y1.contains("bool"), "{y1}");
        let outputs = points_table(model, Some(Direction::Output));
        assert!(
            outputs.lines().skip(2).all(|l| !l.contains(" input ")),
            "{outputs}"
        );
        assert!(outputs.ends_with(&format!(
            "{} point(s)\n",
            model
                .points
                .iter()
                .filter(|p| p.access == Access::Output)
                .count()
        )));
    }

    #[test]
    fn an_unknown_model_names_the_nearest() {
        let e = unknown_model("minmod", devices::catalog());
        assert!(
            e.starts_with(
                "error: unknown model `minmod`; did you mean `minimod`? (models: minimod, "
            ),
            "{e}"
        );
        let e = unknown_model("plc9000", devices::catalog());
        assert!(
            e.starts_with("error: unknown model `plc9000` (models: "),
            "{e}"
        );
    }
}
