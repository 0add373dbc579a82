//! softplc: a deterministic soft-PLC runtime for RS-485 I/O modules.
//!
//! The public surface is one namespace per part (see DESIGN.md); everything else is internal
//! to the crate:
//! - [`project`]: the project file, validated before the first scan
//!   ([`load`](project::load), [`parse_str`](project::parse_str) into a
//!   [`Project`](project::Project), or every error at once); [`project::profile`] reads
//!   device profile files.
//! - [`image`], [`clock`]: the [`ProcessImage`](image::ProcessImage) and time.
//! - [`logic`]: the [`LogicEngine`](logic::LogicEngine) trait,
//!   [`load_program`](logic::load_program), and one namespace per engine ([`logic::expr`],
//!   [`logic::ladder`], [`logic::rhai`]).
//! - [`offload`]: the push-down planner ([`plan_program`](offload::plan_program)): rungs
//!   compiled into the modules' own logic.
//! - [`scan`]: the [`ScanEngine`](scan::ScanEngine): deadlines, phases, overruns, the task
//!   watchdog, statistics, and the [`CycleBoundary`](scan::CycleBoundary) the layer above
//!   plugs in.
//! - [`plc`]: a project wired into a runnable [`Plc`](plc::Plc) (lines, drivers, image,
//!   program).
//! - [`service`]: running a machine: the [`ServiceBoundary`](service::ServiceBoundary), the
//!   [`service::control`] protocol, the [`service::web`] page, the [`service::mqtt`]
//!   Sparkplug B node, metrics, Modbus TCP and OPC UA.
//! - [`retain`]: retained tags, saved atomically, restored at start-up.
//! - [`recorder`]: the flight recorder (what every cycle saw, crash-safe), its
//!   [`recorder::format`] and its [`replay`](recorder::replay).
//! - [`trace`]: tags sampled every cycle around a trigger; CSV and VCD writers.
//! - [`cli`]: the `softplc` subcommands ([`main`](cli::main)).

pub mod cli;
pub mod clock;
pub mod image;
pub(crate) mod log_limit;
pub mod logic;
pub mod offload;
pub mod plant;
pub mod plc;
pub mod project;
pub mod recorder;
pub mod retain;
mod save_thread;
pub mod scan;
pub mod service;
mod suggest;
pub mod trace;
