//! The system tests: drivers, lines, simulators and the runtime together, one binary with a
//! module per subject (run one with `cargo test -p softplc-tests --test system SUBJECT::`, for
//! example `fuzz_wire::`). Their shared helpers are the `softplc_tests` library (`src/`).

mod bus_discipline;
mod bus_threads;
mod conveyor_plant;
mod determinism;
mod fuzz_text;
mod fuzz_wire;
mod fuzz_wire_decoder;
mod line_faults;
mod offload_equivalence;
mod profile_resi;
mod pty_end_to_end;
mod tcp_bus;
