//! softplc: a deterministic soft-PLC runtime for RS-485 I/O modules.
//!
//! - [`project`]: the project file, validated before the first scan.
//! - [`image`], [`clock`]: the process image and time.
//! - [`logic`]: the `LogicEngine` trait and the engines.
//! - [`offload`]: the push-down planner: rungs compiled into the modules' own logic.
//! - [`scan`]: the scan thread: deadlines, phases, overruns, the task watchdog, statistics.
//! - [`retain`]: retained tags, saved atomically, restored at start-up.
//! - [`plc`]: a project wired into a runnable PLC (lines, drivers, image, program).
//! - [`recorder`]: the flight recorder (what every cycle saw, crash-safe) and its replay.
//! - [`trace`]: tags sampled every cycle around a trigger; CSV and VCD writers.
//! - [`cli`]: the `softplc` subcommands.

pub mod cli;
pub mod clock;
pub mod image;
pub mod logic;
pub mod offload;
pub mod plc;
pub mod project;
pub mod recorder;
pub mod retain;
pub mod scan;
pub mod service;
mod suggest;
pub mod trace;
