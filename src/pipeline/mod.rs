//! The daemon pipeline: scheduling, ordering, drop policy, stats, shutdown.
//!
//! One [`engine::Pipeline`] per camera: a capture thread reads the source into a bounded
//! [`queue::FrameQueue`] (live: the oldest frame is dropped when compute falls behind, counted;
//! replay: backpressure, nothing dropped), a dispatcher hands frames to a dedicated
//! `rayon::ThreadPool` (shared by all cameras, sized by `daemon.threads`, never the global pool) with
//! at most `max_in_flight` frames at once, and an orderer emits results strictly in sequence order to
//! the sinks (iceoryx2 publishers, MCAP recorder, results file), each on its own thread.
//! [`daemon`] wraps the pipelines in a tokio runtime for signals, timers, sd_notify and shutdown.
//!
//! Every frame is accounted for ([`stats::Stats`]): processed, dropped (queue full; driver gaps) or
//! failed (source, compute, sink). Time is injected ([`crate::clock::Clock`]): a replay stamps outputs
//! with recorded timestamps, so its outputs are byte-identical for any thread count; wall-clock
//! values (latency, fps) are kept apart and named as such. Buffers are pooled ([`crate::pool::BufferPool`]):
//! a steady stream allocates nothing per frame.
//!
//! ```
//! use std::sync::Arc;
//! use mosaicd::capture::synthetic::{SyntheticSource, SyntheticSpec};
//! use mosaicd::clock::ReplayClock;
//! use mosaicd::pipeline::{engine::{Pipeline, PipelineSpec}, sinks::CollectSink, stage::{Stage, StageSpec}};
//! use mosaicd::pool::BufferPool;
//! let pool = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap());
//! let frames = BufferPool::new(8);
//! let src = SyntheticSource::with_pool(SyntheticSpec { width: 64, height: 48, frames: 5, ..Default::default() }, frames.clone());
//! let sink = CollectSink::default();
//! let spec = PipelineSpec { camera: "doc".into(), queue_depth: 2, max_in_flight: 2,
//!     stage: Stage::new(StageSpec::default(), None).unwrap(), keep_frames: false };
//! let p = Pipeline::start(spec, Box::new(src), pool, Arc::new(ReplayClock::default()), vec![sink.factory("doc")], frames).unwrap();
//! let report = p.join();
//! assert_eq!(report.stats.processed, 5);
//! let records = sink.take();
//! assert_eq!(records.len(), 6); // 5 frames + final stats
//! assert_eq!(records[4]["index"], 4);
//! ```

pub mod daemon;
pub mod engine;
pub mod queue;
pub mod sinks;
pub mod sources;
pub mod stage;
pub mod stats;
pub mod textfile;

/// Re-exported from their homes: the pool is a leaf, the synthetic source a capture source.
pub use crate::{capture::synthetic, pool};

#[cfg(test)]
mod tests;
