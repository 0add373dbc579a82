//! Trace: chosen tags, module counters and phase times sampled at every cycle boundary.

pub mod export;
