//! The process's CPU time, all threads together (`CLOCK_PROCESS_CPUTIME_ID`,
//! nanoseconds): on lavapipe the "GPU" is the process's own threads (the queue's
//! and llvmpipe's rasterizers), so the CPU time from a submission to its
//! completion is what the frame cost the machine, unlike wall time unaffected by
//! other processes competing for the cores (`bench --embedded`'s `cpu_ratio`).
//! One `clock_gettime` call: the per-thread `/proc/self/task/*/schedstat` scan
//! this replaced opened a file per thread, twice a frame, which was 14% of the
//! calling thread's samples on a 16×16 frame (docs/executor.md).
//! Where the clock is missing every reading is 0, and the figures derived are 0.
//!
//! Also the calling thread's CPU clock ([`CpuInstant`]), for what recording costs
//! (`record_ms`, the bench's re-recording figure): drivers record
//! in the calling thread, so its CPU time is a recording's whole cost.

/// CPU time (user and system) the process's threads have run, ended threads
/// included, in nanoseconds; 0 where the clock is missing.
pub fn process_ns() -> u64 {
    clock_ns(CLOCK_PROCESS).unwrap_or(0)
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

#[cfg(unix)]
const CLOCK_PROCESS: libc::clockid_t = libc::CLOCK_PROCESS_CPUTIME_ID;
#[cfg(not(unix))]
const CLOCK_PROCESS: i32 = 0;

/// `clock`'s reading in nanoseconds (`None` where the system has no such clock).
#[cfg(unix)]
fn clock_ns(clock: libc::clockid_t) -> Option<u64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; `clock` is one of the CPU
    // clock ids every supported Unix defines.
    let rc = unsafe { libc::clock_gettime(clock, &mut ts) };
    (rc == 0).then(|| ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64)
}

#[cfg(not(unix))]
fn clock_ns(_clock: i32) -> Option<u64> {
    None
}

/// CPU time of the calling thread, in milliseconds.
#[cfg(unix)]
fn thread_cpu_ms() -> f64 {
    let ns = clock_ns(libc::CLOCK_THREAD_CPUTIME_ID)
        .expect("clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    ns as f64 * 1e-6
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
    fn a_thread_that_ended_keeps_its_cpu_time() {
        if process_ns() == 0 {
            return; // no process clock: nothing to measure
        }
        let start = process_ns();
        // The thread spins until its own clock says 10 ms, then ends.
        std::thread::spawn(|| {
            let t = CpuInstant::now();
            let mut x = 0u64;
            while t.elapsed_ms() < 10.0 {
                x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
            }
            std::hint::black_box(x);
        })
        .join()
        .unwrap();
        let ms = ms_since(start);
        assert!(ms >= 10.0, "{ms} ms");
    }

    #[test]
    fn busy_work_shows_as_cpu_time() {
        if process_ns() == 0 {
            return; // no process clock: nothing to measure
        }
        // Other tests' threads run alongside, so a try may read more than was
        // spun: some try of five must show the spinning, and none more than
        // wall time times a generous thread count.
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
