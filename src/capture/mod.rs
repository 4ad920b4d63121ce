//! Frame sources behind one [`Source`] trait: V4L2 cameras, MCAP replay, raw files.
//!
//! A source yields [`RawFrame`]s with their metadata filled in (sequence, sensor sequence,
//! capture timestamp, pattern, bit depth, levels). Whether it is live decides the queueing policy
//! downstream: a live source's oldest queued frame is dropped when compute falls behind, a replay
//! source is back-pressured and never dropped, so replay output is deterministic.

use crate::raw::RawFrame;

/// How frames from a source may be treated when compute falls behind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceKind {
    /// A camera: frames arrive in real time; the oldest queued frame is dropped under load.
    Live,
    /// A recording or files: the reader waits (backpressure); nothing is dropped.
    Replay,
}

/// Errors from sources.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// Loading a frame failed.
    #[error(transparent)]
    Raw(#[from] crate::raw::RawError),
    /// Other I/O failure, with context.
    #[error("{context}: {source}")]
    Io {
        /// What was being done.
        context: String,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

/// A producer of raw frames.
pub trait Source: Send {
    /// The next frame, `Ok(None)` at the end of the stream. An error for one frame does not
    /// necessarily end the stream: callers may count it and call again, unless
    /// [`Source::is_finished`] says otherwise.
    fn next_frame(&mut self) -> Result<Option<RawFrame>, CaptureError>;

    /// Live or replay (decides the drop policy).
    fn kind(&self) -> SourceKind;

    /// A short human-readable description (device path, file name).
    fn describe(&self) -> String;

    /// True once the source can produce no more frames (after end of stream or a fatal error).
    fn is_finished(&self) -> bool {
        false
    }
}
