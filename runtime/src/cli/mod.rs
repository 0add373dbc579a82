//! The `softplc` subcommands.

mod alarms;
mod args;
mod audit;
mod built_services;
mod check;
mod commission;
mod control;
mod discover;
mod error_line;
mod journal;
mod models;
mod monitor;
mod out;
mod plant_services;
mod replay;
mod run;
mod run_tasks;
mod schema;
mod schema_doc;
mod sim;
mod task_record;
mod task_web;
pub(crate) mod test;
mod trace;
mod trace_bus;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub use args::parse_duration;
pub use test::alarms::{AlarmState, AlarmStep, AlarmStepKind};
pub use test::scenario::{
    parse as parse_scenario, CmpOp, Comparison, Expect, FaultStep, ModuleStep, PlantExpect,
    ProgramSpec, Scenario, ScenarioErrors, SetInput,
};
pub use test::variants::ProgramVariant;

/// softplc: a deterministic soft-PLC for RS-485 I/O modules.
#[derive(Debug, Parser)]
#[command(name = "softplc", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a project until SIGINT/SIGTERM (or for --for), then write every output's safe value.
    Run(run::RunArgs),
    /// Validate a project, print its I/O map and each line's time budget.
    Check(check::CheckArgs),
    /// Serve simulated modules on a serial device (one end of a pty pair) for any Modbus master.
    #[command(long_about = sim::LONG_HELP)]
    Sim(sim::SimArgs),
    /// Show a running instance's scan figures, modules, tags and forces.
    Status(control::StatusArgs),
    /// Force a tag of a running instance (applied after the input read and before the write).
    Force(control::TagValueArgs),
    /// Write a tag of a running instance once, at the next cycle boundary; the program (or the
    /// module) owns it again from its next scan. Refused for an input or a forced tag.
    Write(control::TagValueArgs),
    /// Remove a force (or every force with --all).
    Unforce(control::UnforceArgs),
    /// Reload the program of a running instance at a cycle boundary (like SIGHUP).
    Reload(control::ReloadArgs),
    /// Show the audit file's latest entries: every write, force, unforce and reload, with who
    /// asked (cli, web and its client, opcua, modbus and its client, mqtt) and when.
    Audit(audit::AuditArgs),
    /// Show a running instance's alarms (active or waiting for acknowledgement, those waiting
    /// first, by priority) and the latest events; `alarms ack NAME|all` acknowledges.
    Alarms(alarms::AlarmsArgs),
    /// Find the modules on a serial line (every family, baud and format) and print a project
    /// skeleton; says first how long it takes at most.
    Discover(discover::DiscoverArgs),
    /// Set a module's address, baud/format and reply delay, save them in the module and read
    /// them back; refuses what the module's manual forbids. Asks first unless --yes.
    Commission(commission::CommissionArgs),
    /// Run scenario files (inputs over virtual time, expected outputs) on the simulator.
    Test(test::TestArgs),
    /// List the module models a project can name, with protocols, addresses and point counts.
    Models(models::ModelsArgs),
    /// List a model's points: the name a tag's `point:` takes, direction, type, manual name.
    Points(models::PointsArgs),
    /// Arm a trace of a running instance, show its state, save its samples as CSV or VCD.
    #[command(subcommand)]
    Trace(trace::TraceCommand),
    /// Re-run a project's program on a flight record's inputs and say where its outputs first
    /// differ from the recorded ones (or that they match).
    Replay(replay::ReplayArgs),
    /// Print the JSON Schema of the project file, ladder programs or scenario files (the
    /// repository's schema/*.schema.json), for an editor's completion and checks.
    Schema(schema::SchemaArgs),
    /// Listen on a serial line without sending and print every frame heard, decoded (Modbus
    /// RTU, MiniMod text, RESI ASCII, DCON), with the silence before it.
    Monitor(monitor::MonitorArgs),
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging();
    let result = match cli.command {
        Command::Run(a) => run::run(a),
        Command::Check(a) => check::check(a),
        Command::Sim(a) => sim::sim(a),
        Command::Status(a) => control::status(a),
        Command::Force(a) => control::force(a),
        Command::Write(a) => control::write(a),
        Command::Unforce(a) => control::unforce(a),
        Command::Reload(a) => control::reload(a),
        Command::Audit(a) => audit::audit(a),
        Command::Alarms(a) => alarms::alarms(a),
        Command::Test(a) => test::test(a),
        Command::Trace(c) => trace::trace(c),
        Command::Replay(a) => replay::replay_cmd(a),
        Command::Discover(a) => discover::discover(a),
        Command::Commission(a) => commission::commission(a),
        Command::Models(a) => models::models(a),
        Command::Points(a) => models::points(a),
        Command::Monitor(a) => monitor::monitor(a),
        Command::Schema(a) => schema::schema(a),
    };
    match result {
        Ok(code) => code,
        // The reader of stdout went away (`softplc check p.yaml | head`): end quietly.
        Err(e) if out::is_closed(&e) => ExitCode::from(out::CLOSED_STATUS),
        Err(e) => {
            out::errln(&format!("error: {}", error_line::error_line(&e)));
            ExitCode::from(2)
        }
    }
}

fn init_logging() {
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;
    // `Targets` (levels per module path: `debug`, `info,softplc_io=debug`) rather than
    // `EnvFilter`: EnvFilter's span and field filters pull the regex engines in, 0.4 MB of a
    // binary that aims at 8 MB without the plant services, for filters nobody set on a PLC.
    let (filter, refused) = log_filter(std::env::var("SOFTPLC_LOG").ok().as_deref());
    let filter = || filter.clone();
    // Under systemd (stderr is the journal stream), log natively to the journal, with the
    // project, bus and module as fields; a journal that cannot be reached leaves stderr.
    let mut unreachable = None;
    if journal::stderr_is_journal() {
        match journal::JournalLayer::new() {
            Ok(layer) => {
                // Refused only when a subscriber is already installed: that one keeps logging.
                drop(
                    tracing_subscriber::registry()
                        .with(filter())
                        .with(crate::log_limit::LibraryLines)
                        .with(layer)
                        .try_init(),
                );
                return;
            }
            Err(e) => unreachable = Some(e),
        }
    }
    // Colour only for a person at a terminal: piped into a file, a journal or another
    // program, escape codes are noise.
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    // Refused only when a subscriber is already installed: that one keeps logging.
    drop(
        tracing_subscriber::fmt()
            .with_writer(std::io::stderr)
            .with_ansi(ansi)
            .with_target(false)
            .finish()
            .with(filter())
            .with(crate::log_limit::LibraryLines)
            .try_init(),
    );
    if let Some(e) = unreachable {
        tracing::warn!("the journal cannot be reached ({e}); logging to stderr");
    }
    if let Some(refusal) = refused {
        tracing::warn!("{refusal}");
    }
}

/// The log filter `SOFTPLC_LOG` asks for, `info` when unset; a value that is not a filter
/// gives `info` and the refusal to log once logging runs (a typo must not silence the log).
fn log_filter(setting: Option<&str>) -> (tracing_subscriber::filter::Targets, Option<String>) {
    let default = || {
        tracing_subscriber::filter::Targets::new()
            .with_default(tracing_subscriber::filter::LevelFilter::INFO)
    };
    match setting.map(str::trim).filter(|s| !s.is_empty()) {
        None => (default(), None),
        Some(text) => match parse_targets(text) {
            Ok(targets) => (targets, None),
            Err(e) => (
                default(),
                Some(format!(
                    "SOFTPLC_LOG={text:?} is not a log filter ({e}): give a level (off, error, warn, \
                     info, debug, trace) or TARGET=LEVEL pairs separated by commas; logging at info"
                )),
            ),
        },
    }
}

/// `Targets` reads a bare word as a target at every level, so a mistyped level would silence
/// the log: here a directive is a level or `TARGET=LEVEL`.
fn parse_targets(text: &str) -> Result<tracing_subscriber::filter::Targets, String> {
    for directive in text.split(',').map(str::trim) {
        if !directive.contains('=')
            && directive
                .parse::<tracing_subscriber::filter::LevelFilter>()
                .is_err()
        {
            return Err(format!("`{directive}` is not a level"));
        }
    }
    text.parse().map_err(|e| format!("{e}"))
}

#[cfg(test)]
mod tests {
    use super::log_filter;
    use tracing::Level;

    #[test]
    fn the_log_filter_takes_a_level_or_targets_and_refuses_a_typo_loudly() {
        let (unset, none) = log_filter(None);
        assert!(none.is_none());
        assert!(unset.would_enable("softplc::scan", &Level::INFO));
        assert!(!unset.would_enable("softplc::scan", &Level::DEBUG));
        let (debug, _) = log_filter(Some("debug"));
        assert!(debug.would_enable("softplc_io::line", &Level::DEBUG));
        let (targets, _) = log_filter(Some("warn,softplc_io=debug"));
        assert!(targets.would_enable("softplc_io::line", &Level::DEBUG));
        assert!(!targets.would_enable("softplc::scan", &Level::INFO));
        let (fallback, refusal) = log_filter(Some("verbose!"));
        assert!(fallback.would_enable("softplc::scan", &Level::INFO));
        let refusal = refusal.unwrap_or_default();
        assert!(
            refusal.starts_with("SOFTPLC_LOG=\"verbose!\" is not a log filter"),
            "{refusal}"
        );
    }
}
