//! softplc's integration tests: one binary, a module per subject (ripgrep's layout), so the
//! runtime is linked once. Run one subject with `cargo test -p softplc --test integration
//! SUBJECT::` (for example `opcua::`). The helpers the subjects share live in `common/`.
//!
//! Tests that need a process of their own (kill -9, a namespace, an environment, a faked wall
//! clock) spawn the `softplc` binary; everything here shares one process otherwise, so a test
//! never changes the process's state (current folder, signal handlers) and names what it
//! creates after itself (scratch folders, environment variables with the process id).

mod common;

mod adapter;
mod alarm_scenarios;
mod alarms;
mod built_services;
mod check_catches;
mod cli;
mod collect_floor;
mod commission;
mod cycle_mix;
mod cycle_numbers;
mod dead_line;
mod discover;
mod docs;
mod error_chain;
mod hostile;
mod journal;
mod kill9;
mod late_port;
mod line_plan;
mod log_flood;
mod long_day;
mod module_watchdog;
mod monitor;
#[cfg(feature = "mqtt")]
mod mqtt;
#[cfg(feature = "opcua")]
mod opcua;
#[cfg(feature = "opcua")]
mod opcua_alarms;
mod plant;
mod plant_view;
mod profiles;
mod programs;
mod project_errors;
mod project_offload;
mod project_service;
mod project_web;
mod quality;
mod recorder;
mod retain;
mod rs485;
mod scada;
mod schema;
mod service;
mod task_control;
mod task_programs;
mod task_push_down;
mod task_record;
mod task_runtime;
mod task_scenario_alarms;
mod task_scenarios;
mod task_services;
mod tasks;
mod tcp_bus;
mod trace;
mod trace_bus;
mod trace_cli;
mod transients;
mod user_blocks;
mod wall_clock;
mod web;
