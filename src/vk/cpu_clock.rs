//! The process's CPU time, all threads together (Linux `/proc/self/task/*/schedstat`,
//! nanoseconds): on lavapipe the "GPU" is the process's own threads (the queue's
//! and llvmpipe's rasterizers), so the CPU time from a submission to its
//! completion is what the frame cost the machine, unlike wall time unaffected by
//! other processes competing for the cores (`bench --embedded`'s `cpu_ratio`).
//! Where `/proc` is missing every reading is 0, and the figures derived are 0.

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn busy_work_shows_as_cpu_time() {
        let start = process_ns();
        if start == 0 {
            return; // no /proc: nothing to measure
        }
        let t = std::time::Instant::now();
        let mut x = 0u64;
        while t.elapsed().as_millis() < 30 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let ms = ms_since(start);
        // 30 ms of spinning ran at least partly on a CPU, and no more than wall
        // time times a generous thread count.
        assert!(ms > 1.0 && ms < 30.0 * 64.0 + 1000.0, "{ms} ms");
    }
}
