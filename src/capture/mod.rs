//! Frame sources behind one [`Source`] trait: V4L2 cameras, MCAP replay, raw files.
//!
//! A source yields [`RawFrame`]s with their metadata filled in (sequence, sensor sequence,
//! capture timestamp, pattern, bit depth, levels). Whether it is live decides the queueing policy
//! downstream: a live source's oldest queued frame is dropped when compute falls behind, a replay
//! source is back-pressured and never dropped, so replay output is deterministic.

use std::path::PathBuf;

use crate::raw::RawFrame;

pub(crate) mod files;
mod mcap_guard;
pub(crate) mod mcap_source;
pub(crate) mod synthetic;
pub(crate) mod v4l2;
pub(crate) mod v4l2_formats;

pub use crate::clock::{Clock, FakeClock, MonotonicClock, Stop};
pub use files::{Black, FileSource, FileSourceOptions, Sidecar, DEFAULT_FPS, DIR_SIDECAR};
pub use mcap_guard::{ChunkOverrun, RecordPastEnd};
pub use mcap_source::{McapSource, McapSourceOptions, Pacing};
pub use synthetic::{SyntheticSource, SyntheticSpec};
pub use v4l2::{Backoff, Negotiated, V4l2Options, V4l2Source};
pub use v4l2_formats::{
    bayer_format, parse_fourcc, raw_frame_from_v4l2, unpack_into, unpack_into_serial, BayerFormat, Packing,
    V4l2FormatError, SUPPORTED, SUPPORTED_PACKED12,
};

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
    /// A recording ends in the middle of a record: every complete frame before was delivered.
    #[error("{path} is truncated after {frames} complete frame(s) (an interrupted recording?): {}", crate::wire::read::mcap_detail(.source))]
    Truncated {
        /// File.
        path: PathBuf,
        /// Frames delivered before the cut.
        frames: u64,
        /// What the reader saw.
        #[source]
        source: mcap::McapError,
    },
    /// A recording (or a message in it) is damaged; nothing after the damage is used.
    #[error("{path} is corrupt after {frames} frame(s): {source}")]
    Corrupt {
        /// File.
        path: PathBuf,
        /// Frames delivered before the damage.
        frames: u64,
        /// What is wrong.
        #[source]
        source: Damage,
    },
    /// A recording holds no raw-frame channel (or not the requested one).
    #[error("{path}: no raw-frame channel {wanted} (channels found: {found})")]
    NoRawChannel {
        /// File.
        path: PathBuf,
        /// Requested topic, or the schema name.
        wanted: String,
        /// Topics present.
        found: String,
    },
    /// A V4L2 format or buffer that cannot be interpreted.
    #[error(transparent)]
    Format(#[from] v4l2_formats::V4l2FormatError),
    /// The driver delivered a buffer that is not a usable frame (marked failed, short, values
    /// out of range). That frame is lost and counted; the stream goes on.
    #[error("camera {path}: the frame with driver sequence {sequence} is unusable: {reason}")]
    BadBuffer {
        /// Device path.
        path: PathBuf,
        /// The driver's sequence number of the buffer.
        sequence: u32,
        /// What is wrong with it.
        reason: String,
    },
    /// A looped file source went through all its files without delivering a frame: every file
    /// failed (each failure was reported), so the loop stops instead of repeating them.
    #[error("{what}: none of its {files} file(s) could be read in a whole pass; the loop stops")]
    NothingPlayable {
        /// The source ([`Source::describe`]).
        what: String,
        /// Files in the loop.
        files: usize,
    },
    /// The camera device node does not exist.
    #[error("camera {path} does not exist (is the camera connected and its driver loaded? `v4l2-ctl --list-devices` lists cameras)")]
    DeviceMissing {
        /// Device path.
        path: PathBuf,
    },
    /// The device cannot stream video capture.
    #[error("{path} ({card}) is not a streaming video-capture device")]
    NotCapture {
        /// Device path.
        path: PathBuf,
        /// The driver's card name.
        card: String,
    },
    /// The device offers no Bayer format we can read.
    #[error("the device offers no Bayer format we support (offered: {offered}; preferred: {preferred:?}); see capture::v4l2_formats for the list")]
    NoBayerFormat {
        /// FourCCs offered.
        offered: String,
        /// FourCC asked for.
        preferred: Option<String>,
    },
    /// The device stopped delivering frames (unplugged, driver error); reopening follows.
    #[error("camera {path} was lost: {source}; reopening with back-off")]
    DeviceLost {
        /// Device path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// A reopen attempt failed; the next one is after the back-off.
    #[error("camera {path} unavailable (attempt {attempt}, next in {retry_in_ms} ms): {source}")]
    DeviceUnavailable {
        /// Device path.
        path: PathBuf,
        /// Failed attempts so far.
        attempt: u32,
        /// Delay before the next attempt (ms).
        retry_in_ms: u64,
        /// Why this attempt failed.
        #[source]
        source: Box<CaptureError>,
    },
    /// A sidecar that does not parse.
    #[error("sidecar {path} does not parse: {source}")]
    Sidecar {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// A sidecar value out of range.
    #[error("sidecar {path}: {key} = {value} is invalid: expected {why}")]
    SidecarValue {
        /// File.
        path: PathBuf,
        /// Key.
        key: &'static str,
        /// Value.
        value: String,
        /// Allowed values.
        why: &'static str,
    },
    /// An invalid source option.
    #[error("invalid source option {name} = {value}: {why}")]
    Option {
        /// Option name.
        name: &'static str,
        /// Offending value.
        value: String,
        /// Allowed values.
        why: &'static str,
    },
}

impl CaptureError {
    /// The sensor (driver) sequence number of the frame this error cost, when the source knows
    /// it ([`CaptureError::BadBuffer`]): the pipeline counts that frame as failed and not also
    /// as a driver drop.
    pub fn sensor_sequence(&self) -> Option<u64> {
        match self {
            CaptureError::BadBuffer { sequence, .. } => Some(*sequence as u64),
            _ => None,
        }
    }
}

/// What is wrong in a corrupt recording.
#[derive(Debug, thiserror::Error)]
pub enum Damage {
    /// The MCAP structure (magic, CRC, record, compression).
    #[error("{}", crate::wire::read::mcap_detail(.0))]
    Mcap(#[from] mcap::McapError),
    /// A raw-frame message that does not decode.
    #[error(transparent)]
    Message(#[from] crate::wire::schema::SchemaError),
    /// A record that overruns its uncompressed chunk, stopped before the `mcap` reader reads it
    /// (which would overflow: see [`ChunkOverrun`]).
    #[error(transparent)]
    ChunkOverrun(#[from] ChunkOverrun),
    /// A record on which the `mcap` reader panicked (caught; the replay ends there). mcap 0.26
    /// slices an Attachment record's body without checking its length (docs/fuzzing.md,
    /// finding 6).
    #[error("the mcap reader failed on a malformed record: {message}")]
    ReaderPanic {
        /// The panic's message.
        message: String,
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

    /// The pipeline's stop flag, given before the first frame: a source that waits (pacing, a
    /// back-off) waits on it, so raising it ends the wait at once. Default: the source does not
    /// wait long enough to need it.
    fn set_stop(&mut self, _stop: Stop) {}
}
