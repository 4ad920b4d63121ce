//! Where results leave the pipeline: the [`Sink`] trait, what a sink receives ([`FrameResult`],
//! [`SinkEvent`]) and the sinks themselves, each on its own thread (built there by a
//! [`SinkFactory`], since iceoryx2 ports are not `Send`).
//!
//! | sink | file | writes |
//! |---|---|---|
//! | [`jsonl::JsonlSink`] | `jsonl.rs` | the deterministic JSON-lines results file (and [`jsonl::CollectSink`] for tests) |
//! | [`mcap::McapSink`] | `mcap.rs` | the MCAP recording through [`crate::record::McapRecorder`] |
//! | [`iceoryx::IceoryxSink`] | `iceoryx.rs` | the iceoryx2 services of [`crate::publish`] |
//! | [`foxglove::FoxgloveSink`] | `foxglove.rs` | the live view: Foxglove's WebSocket server ([`foxglove::LiveView`]) |
//!
//! The engine ([`super::engine`]) imports this module, never the other way round.

pub(crate) mod foxglove;
pub(crate) mod iceoryx;
pub(crate) mod jsonl;
pub(crate) mod mcap;

use std::sync::Arc;

use super::stage::{GradientMaps, StageOutput};
use crate::pool::BufferPool;
use crate::raw::{FrameMeta, RawFrame};
use crate::wire::messages::StatsMsg;

pub use jsonl::{descriptors_json, strip_wall_clock, CollectSink};
pub(crate) use jsonl::{stats_json, JsonlSink};

/// Events a sink thread receives.
#[derive(Debug, Clone)]
pub enum SinkEvent {
    /// A processed frame, in index order.
    Frame(Arc<FrameResult>),
    /// A periodic stats snapshot.
    Stats(StatsMsg),
    /// Start new output files where a sink has them (SIGHUP: the recorder starts its next
    /// numbered file before the next frame). Comes between two frames.
    Reopen,
}

/// Errors from sinks (publishers, recorders).
#[derive(Debug, thiserror::Error)]
pub enum SinkError {
    /// The sink could not be created.
    #[error("sink {sink}: cannot start: {message}")]
    Start {
        /// Sink name.
        sink: String,
        /// Cause.
        message: String,
    },
    /// Writing failed; the sink stops.
    #[error("sink {sink}: {message}")]
    Write {
        /// Sink name.
        sink: String,
        /// Cause.
        message: String,
    },
    /// Writing failed, but the sink goes on and tries again itself (the recorder after a full
    /// disk): counted in `failed_sink` and logged like [`SinkError::Write`], the sink keeps
    /// receiving events.
    #[error("sink {sink}: {message}")]
    Interrupted {
        /// Sink name.
        sink: String,
        /// Cause, and what the sink does next.
        message: String,
    },
}

/// A consumer of results, living on its own thread.
pub trait Sink {
    /// Short name for logs and errors.
    fn name(&self) -> String;
    /// One processed frame (called in index order).
    fn frame(&mut self, result: &FrameResult) -> Result<(), SinkError>;
    /// A stats snapshot (periodic, and the final one with `is_final = 1`).
    fn stats(&mut self, stats: &StatsMsg) -> Result<(), SinkError>;
    /// Flush and close (MCAP: summary and index).
    fn finish(&mut self) -> Result<(), SinkError>;
    /// Start new output files before the next frame, if the sink has files (SIGHUP). Default:
    /// nothing to do.
    fn reopen(&mut self) -> Result<(), SinkError> {
        Ok(())
    }
    /// Frames this sink received but did not write, so far (a cumulative count; the engine adds
    /// what is new to `sink_frames_lost` after every event). Default: none; a sink that pauses
    /// on errors (the recorder) counts its own. Frames that reach a sink after it stopped are
    /// counted by the engine.
    fn frames_not_written(&self) -> u64 {
        0
    }
    /// The sink's state when it is a recorder (`None`: not one). The engine reads it after every
    /// event and sets [`crate::pipeline::stats::Stats::set_recorder_state`]; a recorder that
    /// stops on an error or finishes is marked by the engine.
    fn recorder_state(&self) -> Option<crate::pipeline::stats::RecorderState> {
        None
    }
}

/// Builds a sink inside its own thread (ports that are not `Send` are created there).
pub type SinkFactory = Box<dyn FnOnce() -> Result<Box<dyn Sink>, SinkError> + Send>;

/// Gradient maps that return to their pool when the last sink lets go.
#[derive(Debug)]
pub struct PooledMaps {
    pub(super) maps: Option<GradientMaps>,
    pub(super) pool: Option<BufferPool<GradientMaps>>,
}

impl PooledMaps {
    /// The maps.
    pub fn get(&self) -> &GradientMaps {
        self.maps.as_ref().expect("present until drop")
    }
}

impl Drop for PooledMaps {
    fn drop(&mut self) {
        if let (Some(m), Some(p)) = (self.maps.take(), self.pool.as_ref()) {
            p.give(m);
        }
    }
}

/// The result of one processed frame, as the sinks see it.
#[derive(Debug)]
pub struct FrameResult {
    /// Camera name.
    pub camera: Arc<str>,
    /// Dense index in emission order.
    pub index: u64,
    /// Source metadata.
    pub meta: FrameMeta,
    /// Frame width.
    pub width: usize,
    /// Frame height.
    pub height: usize,
    /// Detections and frame statistics.
    pub output: StageOutput,
    /// Gradient maps.
    pub maps: PooledMaps,
    /// The frame itself, when the pipeline keeps frames for the sinks.
    pub frame: Option<Arc<RawFrame>>,
    /// Injected-clock publication time, ns.
    pub publish_timestamp_ns: u64,
    /// Wall-clock latency from pipeline entry (live: capture) to emission, ns.
    pub latency_ns: u64,
}
