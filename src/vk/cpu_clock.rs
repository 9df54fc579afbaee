//! The process's CPU time, all threads together. On a CPU device (lavapipe) the
//! device's work is done by the process's own rasterizer threads, so the CPU time
//! a frame takes is the work it cost, independent of how long other jobs on a
//! shared machine kept those threads waiting (wall and timestamp times are not).

/// CPU time of the whole process since it started, in milliseconds (0 where the
/// platform does not say).
pub fn process_cpu_ms() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: writes one `timespec` that lives on this stack frame.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
        if rc == 0 {
            return ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6;
        }
    }
    0.0
}

#[cfg(test)]
mod tests {
    #[test]
    fn process_cpu_time_grows_with_work() {
        let t0 = super::process_cpu_ms();
        let mut x = 0u64;
        for i in 0..20_000_000u64 {
            x = x.wrapping_mul(31).wrapping_add(i);
        }
        std::hint::black_box(x);
        assert!(super::process_cpu_ms() > t0);
    }
}
