//! The process's CPU time, all threads together (Linux `/proc/self/task/*/schedstat`,
//! nanoseconds): on lavapipe the "GPU" is the process's own threads (the queue's
//! and llvmpipe's rasterizers), so the CPU time from a submission to its
//! completion is what the frame cost the machine, unlike wall time unaffected by
//! other processes competing for the cores (`bench --embedded`'s `cpu_ratio`).
//! Where `/proc` is missing every reading is 0, and the figures derived are 0.

//!
//! Also the calling thread's CPU clock ([`CpuInstant`]), for what recording costs
//! (issue 9 §3: `record_ms`, the bench's re-recording figure): drivers record
//! in the calling thread, so its CPU time is a recording's whole cost.

use std::fs;

/// CPU time (user and system) the process's threads have run, in nanoseconds; 0
/// without `/proc`. Threads that ended since an earlier reading are missing from
/// a later one: take both readings around work that starts and ends no thread.
pub fn process_ns() -> u64 {
    let Ok(tasks) = fs::read_dir("/proc/self/task") else {
        return 0;
    };
    tasks
        .filter_map(Result::ok)
        .filter_map(|t| fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum()
}

/// Milliseconds of process CPU time since `start` (a [`process_ns`] reading).
pub fn ms_since(start: u64) -> f64 {
    process_ns().saturating_sub(start) as f64 * 1e-6
}

/// A point on the calling thread's CPU clock.
#[derive(Clone, Copy, Debug)]
pub struct CpuInstant(f64);

impl CpuInstant {
    /// Now, on this thread's CPU clock.
    pub fn now() -> CpuInstant {
        CpuInstant(thread_cpu_ms())
    }

    /// This thread's CPU milliseconds since `self` (taken on this thread).
    pub fn elapsed_ms(&self) -> f64 {
        (thread_cpu_ms() - self.0).max(0.0)
    }
}

/// CPU time of the calling thread, in milliseconds.
#[cfg(unix)]
fn thread_cpu_ms() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant that
    // every supported Unix defines.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6
}

/// Elsewhere: wall time since the first call (no per-thread clock in `std`).
#[cfg(not(unix))]
fn thread_cpu_ms() -> f64 {
    use std::sync::OnceLock;
    use std::time::Instant;
    static START: OnceLock<Instant> = OnceLock::new();
    START.get_or_init(Instant::now).elapsed().as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn busy_work_shows_as_cpu_time() {
        if process_ns() == 0 {
            return; // no /proc: nothing to measure
        }
        // The sum is over the threads alive at each reading: a parallel
        // test's thread that ends between the two readings takes its time out
        // of the second, so one try may read less than was spun. Some try of
        // five must show the spinning, and none more than wall time times a
        // generous thread count.
        let tries: Vec<f64> = (0..5)
            .map(|_| {
                let start = process_ns();
                let t = std::time::Instant::now();
                let mut x = 0u64;
                while t.elapsed().as_millis() < 30 {
                    x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
                }
                std::hint::black_box(x);
                ms_since(start)
            })
            .collect();
        assert!(tries.iter().any(|&ms| ms > 1.0), "{tries:?} ms");
        assert!(
            tries.iter().all(|&ms| ms < 30.0 * 64.0 + 1000.0),
            "{tries:?} ms"
        );
    }

    #[test]
    fn busy_work_takes_cpu_time_and_sleeping_takes_none() {
        let t = CpuInstant::now();
        let mut x = 0u64;
        for i in 0..20_000_000u64 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(i);
        }
        std::hint::black_box(x);
        let busy = t.elapsed_ms();
        assert!(busy > 0.0, "{busy}");
        let s = CpuInstant::now();
        std::thread::sleep(std::time::Duration::from_millis(50));
        assert!(
            s.elapsed_ms() < 25.0,
            "sleeping used {} CPU ms",
            s.elapsed_ms()
        );
    }
}
