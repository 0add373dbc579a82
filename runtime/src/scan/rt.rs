//! Best-effort real-time options for the scan thread: SCHED_FIFO, CPU affinity, mlockall.
//! Each is tried and its outcome reported; a refusal (no CAP_SYS_NICE, a container) is logged
//! and the PLC runs on, with its jitter visible in the statistics.

use crate::project::RealtimeConfig;

/// What happened to each requested option.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RealtimeOutcome {
    /// One line per requested option: what was applied or why not.
    pub notes: Vec<String>,
}

/// Applies `cfg` to the calling thread.
pub fn apply(cfg: &RealtimeConfig) -> RealtimeOutcome {
    let mut out = RealtimeOutcome::default();
    if let Some(prio) = cfg.priority {
        let param = libc::sched_param {
            sched_priority: i32::from(prio),
        };
        // SAFETY: plain syscall on the calling thread (pid 0) with a valid sched_param.
        let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
        out.notes.push(if rc == 0 {
            format!("scan thread runs SCHED_FIFO priority {prio}")
        } else {
            format!(
                "SCHED_FIFO priority {prio} refused ({}); running with normal scheduling",
                std::io::Error::last_os_error()
            )
        });
    }
    if let Some(cpu) = cfg.cpu {
        // SAFETY: cpu_set_t is plain data; CPU_ZERO/CPU_SET only write inside it.
        let rc = unsafe {
            let mut set: libc::cpu_set_t = std::mem::zeroed();
            libc::CPU_ZERO(&mut set);
            if cpu < libc::CPU_SETSIZE as usize {
                libc::CPU_SET(cpu, &mut set);
            }
            libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
        };
        out.notes.push(if rc == 0 {
            format!("scan thread pinned to CPU {cpu}")
        } else {
            format!(
                "pinning to CPU {cpu} refused ({})",
                std::io::Error::last_os_error()
            )
        });
    }
    if cfg.lock_memory {
        // SAFETY: mlockall takes flags only.
        let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
        out.notes.push(if rc == 0 {
            "memory locked (mlockall)".to_string()
        } else {
            format!(
                "mlockall refused ({}); pages may fault during a scan",
                std::io::Error::last_os_error()
            )
        });
    }
    out
}
