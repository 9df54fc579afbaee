//! The calling thread's CPU clock, for what recording costs (issue 9 §3: `record_ms`
//! and the bench's re-recording figure). Lavapipe, like every Vulkan driver,
//! records commands in the calling thread, so this thread's CPU time is the whole
//! cost of a recording; unlike wall time it does not grow while the thread waits
//! for a core on a loaded machine. (Here rather than beside its users because
//! `unsafe` lives in `vk/`.)

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
