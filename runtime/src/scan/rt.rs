//! Best-effort real-time options for the scan thread: SCHED_FIFO, CPU affinity, mlockall.
//! Each is tried and its outcome reported; a refusal (no CAP_SYS_NICE, a container) is logged
//! and the PLC runs on, with its jitter visible in the statistics.

use crate::project::RealtimeConfig;

/// What happened to each requested option.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RealtimeOutcome {
    /// One per requested option: what was applied or why not.
    pub notes: Vec<RealtimeNote>,
}

/// One requested option's outcome.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RealtimeNote {
    /// Whether the option took effect (a refusal is worth a warning: the scan's jitter is
    /// then the normal scheduler's).
    pub applied: bool,
    /// What was applied, or why not.
    pub text: String,
}

impl RealtimeNote {
    fn of(rc: i32, applied: String, refused: impl FnOnce(std::io::Error) -> String) -> Self {
        if rc == 0 {
            Self {
                applied: true,
                text: applied,
            }
        } else {
            Self {
                applied: false,
                text: refused(std::io::Error::last_os_error()),
            }
        }
    }
}

/// Applies `cfg` to the calling thread.
#[allow(unsafe_code)]
pub fn apply(cfg: &RealtimeConfig) -> RealtimeOutcome {
    let mut out = RealtimeOutcome::default();
    if let Some(prio) = cfg.priority {
        let param = libc::sched_param {
            sched_priority: i32::from(prio),
        };
        // SAFETY: plain syscall on the calling thread (pid 0) with a valid sched_param.
        let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
        out.notes.push(RealtimeNote::of(
            rc,
            format!("scan thread runs SCHED_FIFO priority {prio}"),
            |e| format!("SCHED_FIFO priority {prio} refused ({e}); running with normal scheduling"),
        ));
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
        out.notes.push(RealtimeNote::of(
            rc,
            format!("scan thread pinned to CPU {cpu}"),
            |e| format!("pinning to CPU {cpu} refused ({e})"),
        ));
    }
    if cfg.lock_memory {
        // SAFETY: mlockall takes flags only.
        let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
        out.notes.push(RealtimeNote::of(
            rc,
            "memory locked (mlockall)".to_string(),
            |e| format!("mlockall refused ({e}); pages may fault during a scan"),
        ));
    }
    out
}
