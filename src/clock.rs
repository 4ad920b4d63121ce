//! Injected time, and the stop signal that interrupts waiting on it: the one clock of the crate.
//!
//! Nothing reads "now" or sleeps directly. Everything that stamps, paces or backs off takes a
//! [`Clock`]:
//! * [`MonotonicClock`]: `CLOCK_MONOTONIC` in ns, the clock V4L2 stamps frames with, so capture and
//!   publication timestamps are comparable. The live daemon's clock, and the one sources pace on.
//! * [`ReplayClock`]: "now" is the recorded timestamp of the latest frame handled
//!   ([`Clock::observe`]), so everything a replay writes is a function of the recording alone —
//!   byte-identical run after run and for any thread count. It never waits.
//! * [`FakeClock`]: for tests; waiting jumps time forward, nothing sleeps.
//!
//! Waiting is interruptible: [`Clock::wait_until_ns`] returns early, with `false`, as soon as its
//! [`Stop`] is raised (a condition variable, not `thread::sleep`), so a source pacing a recording
//! whose next timestamp is centuries away still stops at once on SIGTERM.
//!
//! ```
//! use mosaicd::clock::{Clock, FakeClock, ReplayClock, Stop};
//! let c = FakeClock::new(100);
//! assert!(c.wait_until_ns(250, &Stop::new()));
//! assert_eq!(c.now_ns(), 250);
//! let stop = Stop::new();
//! stop.stop();
//! assert!(!c.wait_until_ns(1_000, &stop), "a raised stop ends the wait");
//! let r = ReplayClock::default();
//! r.observe(1_000);
//! assert_eq!(r.now_ns(), 1_000);
//! ```

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// The longest single condition-variable wait (a longer wait is made of several; keeps deadline
/// arithmetic far from overflow for waits of centuries).
const MAX_WAIT_CHUNK: Duration = Duration::from_secs(3600);

/// A monotonic source of "now" in nanoseconds, and waiting on it.
pub trait Clock: Send + Sync + std::fmt::Debug {
    /// Now, ns.
    fn now_ns(&self) -> u64;
    /// Tell the clock the timestamp of the frame being handled (a replay clock follows it).
    fn observe(&self, _frame_timestamp_ns: u64) {}
    /// Wait until `now_ns() >= t` or until `stop` is raised, whichever is first. True when `t`
    /// was reached (at once if already past), false when the stop ended the wait.
    fn wait_until_ns(&self, t: u64, stop: &Stop) -> bool;
    /// [`Clock::wait_until_ns`] with nobody to interrupt it (true when `t` was reached).
    fn sleep_until_ns(&self, t: u64) -> bool {
        self.wait_until_ns(t, &Stop::new())
    }
}

/// `clock` (a `CLOCK_*` id every Linux has) in nanoseconds; a time before its epoch reads 0.
fn clock_ns(clock: libc::clockid_t) -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC and CLOCK_REALTIME, the only
    // ids passed here, are always available on Linux.
    let rc = unsafe { libc::clock_gettime(clock, &mut ts) };
    debug_assert_eq!(rc, 0);
    (ts.tv_sec.max(0) as u64) * 1_000_000_000 + ts.tv_nsec as u64
}

/// `CLOCK_MONOTONIC` in nanoseconds.
pub fn monotonic_ns() -> u64 {
    clock_ns(libc::CLOCK_MONOTONIC)
}

/// `CLOCK_REALTIME` (the wall clock, UTC) in nanoseconds since the Unix epoch; 0 before 1970.
pub fn realtime_ns() -> u64 {
    clock_ns(libc::CLOCK_REALTIME)
}

/// One reading of the wall clock against the monotonic clock: what turns a `CLOCK_MONOTONIC`
/// timestamp (a live frame's, since boot) into wall-clock time,
/// `realtime = monotonic + offset_ns()`. Recordings of live cameras store it per file
/// (`mosaicd.clock` metadata, docs/recording.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WallClock {
    /// `CLOCK_REALTIME`, ns since the Unix epoch.
    pub realtime_ns: u64,
    /// `CLOCK_MONOTONIC`, ns since boot, at the same instant.
    pub monotonic_ns: u64,
}

impl WallClock {
    /// Read both clocks now: the monotonic reading is the midpoint of two taken around the
    /// realtime one, so the pair is off by at most half the time between them (well under 1 µs).
    pub fn now() -> Self {
        let before = monotonic_ns();
        let realtime_ns = realtime_ns();
        let after = monotonic_ns();
        Self {
            realtime_ns,
            monotonic_ns: before + (after - before) / 2,
        }
    }

    /// `CLOCK_REALTIME − CLOCK_MONOTONIC` in ns.
    pub fn offset_ns(&self) -> i128 {
        self.realtime_ns as i128 - self.monotonic_ns as i128
    }

    /// The wall-clock time (ns since the epoch) of a `CLOCK_MONOTONIC` timestamp.
    pub fn realtime_of(&self, monotonic_ns: u64) -> i128 {
        monotonic_ns as i128 + self.offset_ns()
    }
}

/// Where a wall-clock reading comes from: the system's clocks, read when asked, or a fixed
/// reading (tests, so that a file's bytes do not depend on when it was written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WallClockSource {
    /// [`WallClock::now`].
    System,
    /// This reading.
    Fixed(WallClock),
}

impl WallClockSource {
    /// A reading.
    pub fn read(self) -> WallClock {
        match self {
            WallClockSource::System => WallClock::now(),
            WallClockSource::Fixed(w) => w,
        }
    }
}

/// The system monotonic clock (live operation, and pacing).
#[derive(Debug, Default, Clone, Copy)]
pub struct MonotonicClock;

impl MonotonicClock {
    /// The clock (a unit value; every instance reads the same `CLOCK_MONOTONIC`).
    pub const fn new() -> Self {
        Self
    }
}

impl Clock for MonotonicClock {
    fn now_ns(&self) -> u64 {
        monotonic_ns()
    }
    fn wait_until_ns(&self, t: u64, stop: &Stop) -> bool {
        loop {
            if stop.is_stopped() {
                return false;
            }
            let now = monotonic_ns();
            if now >= t {
                return true;
            }
            if stop.wait_timeout(Duration::from_nanos(t - now)) {
                return false;
            }
        }
    }
}

/// A clock that reads the recording: "now" is the latest observed frame timestamp. Waiting on it
/// returns at once (there is nothing to wait for: time moves only with the frames).
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
    fn wait_until_ns(&self, _t: u64, stop: &Stop) -> bool {
        !stop.is_stopped()
    }
}

/// A test clock: waiting jumps time forward; nothing sleeps.
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
    /// Total ns "slept" through [`Clock::wait_until_ns`].
    pub fn slept_ns(&self) -> u64 {
        self.slept.load(Ordering::SeqCst)
    }
}

impl Clock for FakeClock {
    fn now_ns(&self) -> u64 {
        self.now.load(Ordering::SeqCst)
    }
    fn wait_until_ns(&self, t: u64, stop: &Stop) -> bool {
        if stop.is_stopped() {
            return false;
        }
        let now = self.now.fetch_max(t, Ordering::SeqCst);
        if t > now {
            self.slept.fetch_add(t - now, Ordering::SeqCst);
        }
        true
    }
}

/// A stop flag that wakes whoever waits on it: raised once ([`Stop::stop`]), seen by every clone.
#[derive(Debug, Clone, Default)]
pub struct Stop {
    inner: Arc<StopInner>,
}

#[derive(Debug, Default)]
struct StopInner {
    stopped: Mutex<bool>,
    wake: Condvar,
}

impl Stop {
    /// A flag not raised yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Raise the flag and wake every waiter.
    pub fn stop(&self) {
        *self.lock() = true;
        self.inner.wake.notify_all();
    }

    /// True once raised.
    pub fn is_stopped(&self) -> bool {
        *self.lock()
    }

    /// Wait up to `d` (any length: a wait of centuries is fine). True when the flag is raised
    /// (before or during the wait), false when `d` passed without it.
    pub fn wait_timeout(&self, d: Duration) -> bool {
        let start = Instant::now();
        let mut stopped = self.lock();
        loop {
            if *stopped {
                return true;
            }
            let left = d.saturating_sub(start.elapsed());
            if left.is_zero() {
                return false;
            }
            stopped = self
                .inner
                .wake
                .wait_timeout(stopped, left.min(MAX_WAIT_CHUNK))
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, bool> {
        // The flag is a plain bool: a panic elsewhere cannot leave it half-written.
        self.inner.stopped.lock().unwrap_or_else(|e| e.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wall_clock_reading_maps_monotonic_to_realtime() {
        let w = WallClock::now();
        // After 2020-01-01 and consistent with a second reading.
        assert!(w.realtime_ns > 1_577_836_800_000_000_000, "{w:?}");
        let later = WallClock::now();
        let drift = (later.offset_ns() - w.offset_ns()).abs();
        assert!(drift < 50_000_000, "offset moved {drift} ns between two readings");
        assert_eq!(w.realtime_of(w.monotonic_ns), w.realtime_ns as i128);
        let fixed = WallClock {
            realtime_ns: 1_000,
            monotonic_ns: 400,
        };
        assert_eq!((fixed.offset_ns(), fixed.realtime_of(500)), (600, 1_100));
    }

    #[test]
    fn replay_clock_follows_frames_and_never_goes_back() {
        let c = ReplayClock::default();
        c.observe(5);
        c.observe(3);
        assert_eq!(c.now_ns(), 5);
        assert!(c.sleep_until_ns(u64::MAX), "a replay clock never waits");
    }

    #[test]
    fn monotonic_clock_does_not_go_back_and_waits() {
        let c = MonotonicClock::new();
        let a = c.now_ns();
        assert!(c.sleep_until_ns(a + 2_000_000));
        let b = c.now_ns();
        assert!(b >= a + 2_000_000 && a > 0, "{a} {b}");
    }

    #[test]
    fn a_stop_wakes_a_wait_of_centuries_at_once() {
        let stop = Stop::new();
        let waiter = {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let t0 = Instant::now();
                let reached = MonotonicClock.wait_until_ns(u64::MAX, &stop);
                (reached, t0.elapsed())
            })
        };
        std::thread::sleep(Duration::from_millis(50));
        stop.stop();
        let (reached, took) = waiter.join().unwrap();
        assert!(!reached);
        assert!(took < Duration::from_secs(5), "woke after {took:?}");
        assert!(stop.is_stopped() && stop.wait_timeout(Duration::from_secs(100)));
    }

    #[test]
    fn stop_wait_timeout_times_out_when_not_raised() {
        let t0 = Instant::now();
        assert!(!Stop::new().wait_timeout(Duration::from_millis(20)));
        assert!(t0.elapsed() >= Duration::from_millis(20));
    }

    #[test]
    fn fake_clock_jumps_and_counts_and_respects_the_stop() {
        let c = FakeClock::new(10);
        assert!(c.sleep_until_ns(30));
        assert!(c.sleep_until_ns(20), "already past");
        assert_eq!((c.now_ns(), c.slept_ns()), (30, 20));
        let stop = Stop::new();
        stop.stop();
        assert!(!c.wait_until_ns(100, &stop));
        assert_eq!(c.now_ns(), 30);
    }
}
