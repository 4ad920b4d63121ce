//! The daemon pipeline: scheduling, ordering, drop policy, stats, shutdown.
//!
//! One [`Pipeline`] per camera: a capture thread reads the source into a bounded
//! [`FrameQueue`] (live: the oldest frame is dropped when compute falls behind, counted;
//! replay: backpressure, nothing dropped), a dispatcher hands frames to a dedicated
//! `rayon::ThreadPool` (shared by all cameras, sized by `daemon.threads`, never the global pool) with
//! at most `max_in_flight` frames at once, and an orderer emits results strictly in sequence order to
//! the sinks (iceoryx2 publishers, MCAP recorder, results file), each on its own thread.
//! [`run`] wraps the pipelines in a tokio runtime for signals, timers, sd_notify and shutdown.
//!
//! Every frame is accounted for ([`Stats`]): processed, dropped (queue full; driver gaps) or
//! failed (source, compute, sink). Time is injected ([`crate::clock::Clock`]): a replay stamps outputs
//! with recorded timestamps, so its outputs are byte-identical for any thread count; wall-clock
//! values (latency, fps) are kept apart and named as such. Buffers are pooled ([`crate::pool::BufferPool`]):
//! a steady stream allocates nothing per frame.
//!
//! The files (`engine.rs`, `queue.rs`, `stage.rs`, `stats.rs`, `daemon.rs`, `sources.rs`,
//! `textfile.rs`, `sinks/`) are private behind this facade: what other crates use is re-exported
//! here. The sinks each run on their own thread behind the [`Sink`] trait: the JSON-lines results
//! file, the MCAP recording ([`recorder_sink`]), the iceoryx2 services ([`IceoryxSink`]) and the live
//! view ([`LiveView`]).
//!
//! ```
//! use std::sync::Arc;
//! use mosaicd::capture::{SyntheticSource, SyntheticSpec};
//! use mosaicd::clock::ReplayClock;
//! use mosaicd::pipeline::{{Pipeline, PipelineSpec}, CollectSink, {Stage, StageSpec}};
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

pub(crate) mod daemon;
pub(crate) mod engine;
pub(crate) mod queue;
pub(crate) mod sinks;
pub(crate) mod sources;
pub(crate) mod stage;
pub(crate) mod stats;
pub(crate) mod textfile;

/// Re-exported from its home, a leaf.
pub use crate::pool;

pub use daemon::{
    load_detector, run, stage_spec, CameraSummary, DaemonError, RunOptions, RunSummary, SinkBuilder,
};
pub use engine::{AbortHandle, Pipeline, PipelineReport, PipelineSpec};
pub use queue::{FrameQueue, Push};
pub use sinks::foxglove::{LiveView, LiveViewError};
pub use sinks::iceoryx::IceoryxSink;
pub use sinks::mcap::recorder_sink;
pub use sinks::{
    descriptors_json, strip_wall_clock, CollectSink, FrameResult, PooledMaps, Sink, SinkError, SinkEvent,
    SinkFactory,
};
pub use sources::SourceOpenError;
pub use stage::{Descriptor, GradientMaps, Stage, StageError, StageOutput, StageSpec};
pub use stats::{LatencyHistogram, LatencySummary, RecorderState, Stats, StatsSnapshot};
pub use textfile::render as render_textfile;

#[cfg(test)]
mod tests;
