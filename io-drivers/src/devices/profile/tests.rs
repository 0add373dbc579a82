//! Tests of the profile driver and simulator.
