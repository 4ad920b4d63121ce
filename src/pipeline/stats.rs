//! Every frame accounted for: counters by outcome and reason, and a latency histogram.
//!
//! Counters are atomics shared by the capture thread, the dispatcher and the sink thread. The
//! invariant at the end of a run is `captured == processed + dropped_queue_full + failed_compute
//! + (frames still queued, 0 after a drain)`; source errors are counted apart (they have no frame).
//!
//! Latency uses a log-linear histogram ([`LatencyHistogram`]): 8 buckets per octave from 1 µs, so a
//! percentile is reported with at most 9 % relative error and memory stays constant in a
//! long-running daemon.
//!
//! ```
//! use mosaicd::pipeline::LatencyHistogram;
//! let mut h = LatencyHistogram::default();
//! for us in 1..=100u64 { h.record_ns(us * 1000); }
//! let p50 = h.percentile_us(0.5);
//! assert!((46.0..=55.0).contains(&p50), "{p50}");
//! ```

use std::sync::atomic::{AtomicU64, AtomicU8, Ordering};
use std::sync::Mutex;

use serde::Serialize;

use crate::wire::messages::StatsMsg;

/// Buckets per octave of the latency histogram.
const SUB_BUCKETS: usize = 8;
/// Octaves covered above 1 µs (2^40 µs is 12 days).
const OCTAVES: usize = 40;

/// A log-linear latency histogram in microseconds.
#[derive(Debug, Clone)]
pub struct LatencyHistogram {
    counts: Vec<u64>,
    total: u64,
    /// Sum of every sample, µs (a Prometheus summary's `_sum`).
    sum_us: f64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        Self {
            counts: vec![0; SUB_BUCKETS * OCTAVES + 1],
            total: 0,
            sum_us: 0.0,
        }
    }
}

impl LatencyHistogram {
    fn bucket(us: f64) -> usize {
        if us <= 1.0 {
            return 0;
        }
        let b = (us.log2() * SUB_BUCKETS as f64).ceil() as usize;
        b.min(SUB_BUCKETS * OCTAVES)
    }

    fn upper_us(bucket: usize) -> f64 {
        (bucket as f64 / SUB_BUCKETS as f64).exp2()
    }

    /// Record one latency.
    pub fn record_ns(&mut self, ns: u64) {
        let us = ns as f64 / 1000.0;
        self.counts[Self::bucket(us)] += 1;
        self.total += 1;
        self.sum_us += us;
    }

    /// Sum of every sample, in microseconds.
    pub fn sum_us(&self) -> f64 {
        self.sum_us
    }

    /// Number of samples.
    pub fn count(&self) -> u64 {
        self.total
    }

    /// The `q` quantile (0..=1) in microseconds (bucket upper bound); 0 when empty.
    pub fn percentile_us(&self, q: f64) -> f64 {
        if self.total == 0 {
            return 0.0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.total as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (b, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return Self::upper_us(b);
            }
        }
        Self::upper_us(self.counts.len() - 1)
    }
}

/// Shared counters of one camera's pipeline.
#[derive(Debug, Default)]
pub struct Stats {
    /// Frames delivered by the source.
    pub captured: AtomicU64,
    /// Frames processed and handed to the sinks.
    pub processed: AtomicU64,
    /// Live frames dropped because the queue was full (the oldest goes).
    pub dropped_queue_full: AtomicU64,
    /// Frames the driver skipped (sensor sequence gaps).
    pub dropped_driver: AtomicU64,
    /// Source errors.
    pub failed_source: AtomicU64,
    /// Frames whose compute failed.
    pub failed_compute: AtomicU64,
    /// Sink (publish or record) errors.
    pub failed_sink: AtomicU64,
    /// Frames a sink received but did not write (a recording paused or stopped by a write
    /// error), summed over sinks.
    pub sink_frames_lost: AtomicU64,
    /// Boxes found.
    pub detections: AtomicU64,
    /// Boxes beyond the message capacity.
    pub box_overflow: AtomicU64,
    latency: Mutex<LatencyHistogram>,
    /// The MCAP recorder's [`RecorderState`], set by the engine from the sink.
    recorder: AtomicU8,
}

/// What the camera's MCAP recorder is doing (the metrics textfile's `mosaicd_recorder_state`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum RecorderState {
    /// No recorder (`record.enabled = false`).
    #[default]
    Off = 0,
    /// Writing.
    Recording = 1,
    /// Paused by a write error, trying again in a new file every `record.retry_ms`.
    Paused = 2,
    /// Stopped by an error for the rest of the run.
    Failed = 3,
    /// Finished: the run ended and the file is complete.
    Finished = 4,
}

impl RecorderState {
    /// Every state, in order.
    pub const ALL: [Self; 5] = [
        Self::Off,
        Self::Recording,
        Self::Paused,
        Self::Failed,
        Self::Finished,
    ];

    /// The label value.
    pub fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Recording => "recording",
            Self::Paused => "paused",
            Self::Failed => "failed",
            Self::Finished => "finished",
        }
    }
}

/// Latency quantiles, count and sum over the whole run ([`Stats::latency_summary`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LatencySummary {
    /// `(q, seconds)` for each quantile asked for.
    pub quantiles: Vec<(f64, f64)>,
    /// Samples.
    pub count: u64,
    /// Sum of the samples, seconds.
    pub sum_s: f64,
}

/// A point-in-time copy of [`Stats`], serialisable for the summary.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct StatsSnapshot {
    /// Frames delivered by the source.
    pub captured: u64,
    /// Frames processed and published.
    pub processed: u64,
    /// Dropped: queue full (live).
    pub dropped_queue_full: u64,
    /// Dropped: by the driver.
    pub dropped_driver: u64,
    /// Failed: source errors.
    pub failed_source: u64,
    /// Failed: compute.
    pub failed_compute: u64,
    /// Failed: sinks.
    pub failed_sink: u64,
    /// Frames a sink received but did not write, summed over sinks.
    pub sink_frames_lost: u64,
    /// Boxes found.
    pub detections: u64,
    /// Boxes beyond the message capacity.
    pub box_overflow: u64,
    /// Latency p50, µs (wall clock).
    pub latency_p50_us: f64,
    /// Latency p99, µs (wall clock).
    pub latency_p99_us: f64,
}

impl Stats {
    /// Add a latency sample.
    pub fn record_latency_ns(&self, ns: u64) {
        self.latency
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .record_ns(ns);
    }

    /// Latency quantiles `qs` (each in 0..=1), count and sum, in seconds.
    pub fn latency_summary(&self, qs: &[f64]) -> LatencySummary {
        let h = self.latency.lock().unwrap_or_else(|e| e.into_inner());
        LatencySummary {
            quantiles: qs.iter().map(|&q| (q, h.percentile_us(q) / 1e6)).collect(),
            count: h.count(),
            sum_s: h.sum_us() / 1e6,
        }
    }

    /// The recorder's state.
    pub fn recorder_state(&self) -> RecorderState {
        let v = self.recorder.load(Ordering::Relaxed);
        RecorderState::ALL
            .into_iter()
            .find(|s| *s as u8 == v)
            .unwrap_or_default()
    }

    /// Sets the recorder's state.
    pub fn set_recorder_state(&self, s: RecorderState) {
        self.recorder.store(s as u8, Ordering::Relaxed);
    }

    /// Increment a counter.
    pub fn inc(counter: &AtomicU64) {
        counter.fetch_add(1, Ordering::Relaxed);
    }

    /// Copy the counters.
    pub fn snapshot(&self) -> StatsSnapshot {
        let l = |c: &AtomicU64| c.load(Ordering::Relaxed);
        let h = self.latency.lock().unwrap_or_else(|e| e.into_inner());
        StatsSnapshot {
            captured: l(&self.captured),
            processed: l(&self.processed),
            dropped_queue_full: l(&self.dropped_queue_full),
            dropped_driver: l(&self.dropped_driver),
            failed_source: l(&self.failed_source),
            failed_compute: l(&self.failed_compute),
            failed_sink: l(&self.failed_sink),
            sink_frames_lost: l(&self.sink_frames_lost),
            detections: l(&self.detections),
            box_overflow: l(&self.box_overflow),
            latency_p50_us: h.percentile_us(0.5),
            latency_p99_us: h.percentile_us(0.99),
        }
    }
}

impl StatsSnapshot {
    /// As a stats message (fps over the last interval supplied by the caller).
    pub fn to_msg(&self, timestamp_ns: u64, fps: f32, is_final: bool) -> StatsMsg {
        StatsMsg {
            timestamp_ns,
            captured: self.captured,
            processed: self.processed,
            dropped_queue_full: self.dropped_queue_full,
            dropped_driver: self.dropped_driver,
            failed_source: self.failed_source,
            failed_compute: self.failed_compute,
            failed_sink: self.failed_sink,
            sink_frames_lost: self.sink_frames_lost,
            detections: self.detections,
            box_overflow: self.box_overflow,
            fps,
            latency_p50_us: self.latency_p50_us as f32,
            latency_p99_us: self.latency_p99_us as f32,
            is_final: is_final as u32,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_of_a_constant_are_that_constant_within_a_bucket() {
        let mut h = LatencyHistogram::default();
        for _ in 0..1000 {
            h.record_ns(2_000_000);
        }
        for q in [0.0, 0.5, 0.99, 1.0] {
            let p = h.percentile_us(q);
            assert!((2000.0..=2000.0 * 1.091).contains(&p), "{q}: {p}");
        }
    }

    #[test]
    fn p99_sees_the_tail() {
        let mut h = LatencyHistogram::default();
        for i in 0..1000 {
            h.record_ns(if i < 985 { 1_000_000 } else { 100_000_000 });
        }
        assert!(h.percentile_us(0.5) < 1100.0);
        assert!(h.percentile_us(0.99) > 90_000.0);
        assert_eq!(LatencyHistogram::default().percentile_us(0.5), 0.0);
    }
}
