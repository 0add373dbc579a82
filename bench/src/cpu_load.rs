//! A competing CPU load: busy threads in this process, one per CPU, bounded in time.

use std::hint::black_box;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Busy threads that spin until dropped or until their time limit, whichever comes first.
#[derive(Debug)]
pub(crate) struct CpuLoad {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<u64>>,
}

impl CpuLoad {
    /// Starts `threads` busy threads that stop by themselves after `limit`.
    pub(crate) fn start(threads: usize, limit: Duration) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let end = Instant::now() + limit;
        let threads = (0..threads)
            .filter_map(|i| {
                let stop = stop.clone();
                std::thread::Builder::new()
                    .name(format!("bench-load-{i}"))
                    .spawn(move || spin(&stop, end))
                    .ok()
            })
            .collect();
        Self { stop, threads }
    }

    /// One busy thread per CPU the process may use.
    pub(crate) fn per_cpu(limit: Duration) -> Self {
        Self::start(
            std::thread::available_parallelism().map_or(2, |n| n.get()),
            limit,
        )
    }
}

/// Integer work with no memory traffic and no system calls, checking the clock now and then.
fn spin(stop: &AtomicBool, end: Instant) -> u64 {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    while !stop.load(Ordering::Relaxed) && Instant::now() < end {
        for _ in 0..10_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
        }
        x = black_box(x);
    }
    x
}

impl Drop for CpuLoad {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            // A load thread that panicked has already reported it; the measurement that
            // ran beside it stands on its own.
            drop(t.join());
        }
    }
}
