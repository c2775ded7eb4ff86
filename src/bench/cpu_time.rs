//! The CPU time of the calling thread: on a shared machine another job slows a timing by
//! this clock less than by the wall clock (the examples that time one thread use it).

/// Seconds of CPU time this thread has used; where no such clock is read, wall-clock
/// seconds since the first call.
pub fn thread_cpu_seconds() -> f64 {
    #[cfg(target_os = "linux")]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid timespec for the call to write.
        unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    }
    #[cfg(not(target_os = "linux"))]
    {
        static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
        START
            .get_or_init(std::time::Instant::now)
            .elapsed()
            .as_secs_f64()
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_thread_clock_advances_with_work() {
        // Busy for up to a second of wall time: the thread's clock must pass 10 ms in it
        // (a clock that stood still would end the loop by the wall clock and fail).
        let (start, wall) = (super::thread_cpu_seconds(), std::time::Instant::now());
        let mut x = 0u64;
        while super::thread_cpu_seconds() - start < 0.01 && wall.elapsed().as_secs_f64() < 1.0 {
            x = std::hint::black_box(x.wrapping_add(1));
        }
        assert!(super::thread_cpu_seconds() - start >= 0.01, "{x} steps");
    }
}
