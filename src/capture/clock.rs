//! Injected time: sources that pace frames or back off take a [`Clock`], so tests run on a
//! [`FakeClock`] and never sleep.
//!
//! ```
//! use mosaicd::capture::clock::{Clock, FakeClock};
//! let c = FakeClock::new(100);
//! c.sleep_until_ns(250);
//! assert_eq!(c.now_ns(), 250);
//! ```

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// A monotonic clock in nanoseconds.
pub trait Clock: Send + Sync + std::fmt::Debug {
    /// Now, ns since an arbitrary origin.
    fn now_ns(&self) -> u64;
    /// Block until `now_ns() >= t` (returns at once when already past).
    fn sleep_until_ns(&self, t: u64);
}

/// The real monotonic clock (origin: creation).
#[derive(Debug, Clone, Copy)]
pub struct MonotonicClock {
    origin: Instant,
}

impl MonotonicClock {
    /// A clock starting at 0 now.
    pub fn new() -> Self {
        Self {
            origin: Instant::now(),
        }
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for MonotonicClock {
    fn now_ns(&self) -> u64 {
        self.origin.elapsed().as_nanos() as u64
    }
    fn sleep_until_ns(&self, t: u64) {
        let now = self.now_ns();
        if t > now {
            std::thread::sleep(Duration::from_nanos(t - now));
        }
    }
}

/// A test clock: sleeping jumps time forward; nothing waits.
#[derive(Debug, Default)]
pub struct FakeClock {
    now: AtomicU64,
    slept: AtomicU64,
}

impl FakeClock {
    /// A fake clock at `start` ns.
    pub fn new(start: u64) -> Self {
        Self {
            now: AtomicU64::new(start),
            slept: AtomicU64::new(0),
        }
    }
    /// Move time forward by `dt` ns.
    pub fn advance(&self, dt: u64) {
        self.now.fetch_add(dt, Ordering::SeqCst);
    }
    /// Total ns "slept" through [`Clock::sleep_until_ns`].
    pub fn slept_ns(&self) -> u64 {
        self.slept.load(Ordering::SeqCst)
    }
}

impl Clock for FakeClock {
    fn now_ns(&self) -> u64 {
        self.now.load(Ordering::SeqCst)
    }
    fn sleep_until_ns(&self, t: u64) {
        let now = self.now.fetch_max(t, Ordering::SeqCst);
        if t > now {
            self.slept.fetch_add(t - now, Ordering::SeqCst);
        }
    }
}
