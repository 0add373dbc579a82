//! The sandboxed Rhai engine: a raw engine with only the packages a control program needs,
//! strict variables, and limits on operations, call depth, expression depth, sizes and time.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use rhai::packages::{BasicArrayPackage, BasicMapPackage, BasicMathPackage, CorePackage, Package};
use rhai::{Dynamic, Engine, OptimizationLevel};

/// The limits a script runs under.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Operations per scan (deterministic; a runaway loop hits it).
    pub operations: u64,
    /// Nested function calls.
    pub call_levels: usize,
    /// Expression nesting, at top level and in functions.
    pub expr_depth: (usize, usize),
    /// Longest string, in bytes.
    pub string_size: usize,
    /// Largest array.
    pub array_size: usize,
    /// Largest object map.
    pub map_size: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            operations: 5_000_000,
            call_levels: 32,
            expr_depth: (64, 32),
            string_size: 4096,
            array_size: 4096,
            map_size: 1024,
        }
    }
}

/// When the running scan must stop, in nanoseconds since `origin`; shared with the
/// engine's progress callback.
#[derive(Debug, Clone)]
pub(crate) struct Deadline {
    origin: Instant,
    nanos: Arc<AtomicU64>,
}

impl Deadline {
    pub(crate) fn new() -> Self {
        Self {
            origin: Instant::now(),
            nanos: Arc::new(AtomicU64::new(u64::MAX)),
        }
    }

    /// Arms the deadline `budget` from now (monotonic time: this guard alone reads a clock).
    pub(crate) fn arm(&self, budget: std::time::Duration) {
        let at = self.origin.elapsed().saturating_add(budget);
        let nanos = u64::try_from(at.as_nanos()).unwrap_or(u64::MAX);
        self.nanos.store(nanos, Ordering::Relaxed);
    }

    fn passed(&self) -> bool {
        let now = u64::try_from(self.origin.elapsed().as_nanos()).unwrap_or(u64::MAX);
        now > self.nanos.load(Ordering::Relaxed)
    }
}

/// Operations between two looks at the clock.
const CLOCK_EVERY: u64 = 1024;

/// A raw engine with the core language, math, arrays and maps; no file, module, time or `eval`
/// access; strict variables; no optimization (the tag declarations must not be folded away).
pub(crate) fn sandboxed(limits: Limits, variables: usize, deadline: &Deadline) -> Engine {
    let mut engine = Engine::new_raw();
    engine.register_global_module(CorePackage::new().as_shared_module());
    engine.register_global_module(BasicMathPackage::new().as_shared_module());
    engine.register_global_module(BasicArrayPackage::new().as_shared_module());
    engine.register_global_module(BasicMapPackage::new().as_shared_module());
    engine.set_strict_variables(true);
    engine.set_optimization_level(OptimizationLevel::None);
    engine.disable_symbol("eval");
    engine.set_max_operations(limits.operations);
    engine.set_max_call_levels(limits.call_levels);
    engine.set_max_expr_depths(limits.expr_depth.0, limits.expr_depth.1);
    engine.set_max_string_size(limits.string_size);
    engine.set_max_array_size(limits.array_size);
    engine.set_max_map_size(limits.map_size);
    engine.set_max_variables(variables);
    let deadline = deadline.clone();
    engine.on_progress(move |ops| {
        (ops % CLOCK_EVERY == 0 && deadline.passed()).then(|| Dynamic::from("budget"))
    });
    engine.on_print(|s| tracing::debug!(target: "rhai", "{s}"));
    engine.on_debug(|s, _, pos| tracing::debug!(target: "rhai", "{pos:?}: {s}"));
    engine
}
