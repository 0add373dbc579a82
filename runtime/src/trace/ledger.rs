//! The traces armed in a PLC, against its one budget (`trace_budget`: traces armed at once,
//! the memory their samples take). With several tasks each task's scan keeps its own traces,
//! but all of them count against this one ledger, so four tasks cannot arm four budgets'
//! worth, and a trace's name is the PLC's, armed in one task at a time.

use std::sync::{Arc, Mutex, MutexGuard};

use super::set::TraceRefusal;
use crate::project::TraceBudget;

/// One armed trace: its task (`None`: the PLC's one task), its name, the bytes of its ring.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Held {
    task: Option<String>,
    name: String,
    bytes: u64,
}

/// Every trace armed in the PLC, shared by its tasks' trace sets (and the request router,
/// which finds the task holding a trace). Locked only to arm, disarm or look a name up,
/// never while sampling.
#[derive(Debug, Clone, Default)]
pub struct TraceLedger(Arc<Mutex<Vec<Held>>>);

impl TraceLedger {
    /// An empty ledger.
    pub fn new() -> Self {
        Self::default()
    }

    fn held(&self) -> MutexGuard<'_, Vec<Held>> {
        // A panic elsewhere while it was held leaves a list still whole: go on with it.
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Takes `bytes` of `budget` for trace `name` in `task`, replacing what a trace of that
    /// name in that task held; refused when the name is armed in another task, or the budget
    /// has no room beside the other traces armed. Nothing changes when refused.
    pub(crate) fn reserve(
        &self,
        task: Option<&str>,
        name: &str,
        bytes: u64,
        budget: TraceBudget,
    ) -> Result<(), TraceRefusal> {
        let mut held = self.held();
        if let Some(other) = held
            .iter()
            .find(|h| h.name == name && h.task.as_deref() != task)
        {
            return Err(TraceRefusal::ArmedElsewhere {
                name: name.to_owned(),
                task: other.task.clone().unwrap_or_default(),
            });
        }
        let others = held.iter().filter(|h| h.name != name);
        let (count, used) = others.fold((0usize, 0u64), |(n, b), h| (n + 1, b + h.bytes));
        if count >= budget.armed {
            return Err(TraceRefusal::TooMany {
                armed: budget.armed,
            });
        }
        let left = budget.memory.saturating_sub(used);
        if bytes > left {
            return Err(TraceRefusal::OverBudget {
                name: name.to_owned(),
                needs: bytes,
                left,
                memory: budget.memory,
            });
        }
        held.retain(|h| h.name != name);
        held.push(Held {
            task: task.map(str::to_owned),
            name: name.to_owned(),
            bytes,
        });
        Ok(())
    }

    /// Gives back what trace `name` held.
    pub(crate) fn release(&self, name: &str) {
        self.held().retain(|h| h.name != name);
    }

    /// The task holding the armed trace `name` (`Some(None)`: the PLC's one task), if any.
    pub fn holder(&self, name: &str) -> Option<Option<String>> {
        self.held()
            .iter()
            .find(|h| h.name == name)
            .map(|h| h.task.clone())
    }

    /// The names of the traces armed, in the order they were armed.
    pub fn names(&self) -> Vec<String> {
        self.held().iter().map(|h| h.name.clone()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BUDGET: TraceBudget = TraceBudget {
        armed: 2,
        memory: 1000,
    };

    #[test]
    fn every_task_draws_on_one_budget_and_a_name_is_armed_in_one_task() {
        let ledger = TraceLedger::new();
        let (fast, slow) = (Some("fast"), Some("slow"));
        assert_eq!(ledger.reserve(fast, "a", 600, BUDGET), Ok(()));
        // The memory left is the PLC's, not the task's.
        assert!(matches!(
            ledger.reserve(slow, "b", 500, BUDGET),
            Err(TraceRefusal::OverBudget { left: 400, .. })
        ));
        assert_eq!(ledger.reserve(slow, "b", 400, BUDGET), Ok(()));
        assert_eq!(
            ledger.reserve(slow, "c", 1, BUDGET),
            Err(TraceRefusal::TooMany { armed: 2 })
        );
        // Arming a name again in its task replaces it; in another task it is refused.
        assert_eq!(ledger.reserve(fast, "a", 500, BUDGET), Ok(()));
        assert_eq!(
            ledger.reserve(slow, "a", 1, BUDGET),
            Err(TraceRefusal::ArmedElsewhere {
                name: "a".into(),
                task: "fast".into()
            })
        );
        assert_eq!(ledger.holder("a"), Some(Some("fast".into())));
        ledger.release("a");
        assert_eq!(ledger.holder("a"), None);
        assert_eq!(ledger.names(), ["b"]);
        assert_eq!(ledger.reserve(slow, "c", 600, BUDGET), Ok(()));
    }
}
