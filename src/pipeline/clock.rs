//! Injected time: the pipeline never reads "now" directly.
//!
//! A live daemon uses [`MonotonicClock`] (`CLOCK_MONOTONIC`, the clock V4L2 stamps frames with, so
//! capture and publication timestamps are comparable). A replay uses [`ReplayClock`]: "now" is the
//! recorded timestamp of the frame being handled, so everything the replay writes is a function of
//! the recording alone — byte-identical run after run and for any thread count.
//!
//! ```
//! use mosaicd::pipeline::clock::{Clock, ReplayClock};
//! let c = ReplayClock::default();
//! c.observe(1_000);
//! assert_eq!(c.now_ns(), 1_000);
//! ```

use std::sync::atomic::{AtomicU64, Ordering};

/// A source of "now" in nanoseconds.
pub trait Clock: Send + Sync {
    /// Current time, ns.
    fn now_ns(&self) -> u64;
    /// Tell the clock the timestamp of the frame being handled (replay clocks follow it).
    fn observe(&self, _frame_timestamp_ns: u64) {}
}

/// `CLOCK_MONOTONIC` in nanoseconds.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC is always available on Linux.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    debug_assert_eq!(rc, 0);
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// The system monotonic clock (live operation).
#[derive(Debug, Default, Clone, Copy)]
pub struct MonotonicClock;

impl Clock for MonotonicClock {
    fn now_ns(&self) -> u64 {
        monotonic_ns()
    }
}

/// A clock that reads the recording: "now" is the latest observed frame timestamp.
#[derive(Debug, Default)]
pub struct ReplayClock {
    now: AtomicU64,
}

impl Clock for ReplayClock {
    fn now_ns(&self) -> u64 {
        self.now.load(Ordering::Acquire)
    }
    fn observe(&self, t: u64) {
        self.now.fetch_max(t, Ordering::AcqRel);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replay_clock_follows_frames_and_never_goes_back() {
        let c = ReplayClock::default();
        c.observe(5);
        c.observe(3);
        assert_eq!(c.now_ns(), 5);
    }

    #[test]
    fn monotonic_clock_does_not_go_back() {
        let a = MonotonicClock.now_ns();
        let b = MonotonicClock.now_ns();
        assert!(b >= a && a > 0);
    }
}
