//! What a recorder is told ([`RecorderOptions`] and its policies, the defaults) and what it reports ([`RecordingSummary`]).

use std::path::PathBuf;

use serde::Serialize;

use crate::clock::WallClockSource;
use crate::wire::RecordError;

/// Default uncompressed chunk size target (bytes): a few 1080p frames per chunk at most.
pub(super) const DEFAULT_CHUNK_SIZE: u64 = 8 * 1024 * 1024;

/// Default flush cadence in frames (a crash loses at most this many frames).
pub(crate) const DEFAULT_FLUSH_FRAMES: u32 = 30;

/// Default zstd level: level 1 is about 4x faster than zstd's default (3) on noisy 12-bit 1080p
/// frames for a file about 2 % larger (measured: docs/recording.md).
pub const DEFAULT_COMPRESSION_LEVEL: u32 = 1;

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Compression {
    /// zstd (default).
    #[default]
    Zstd,
    /// lz4.
    Lz4,
    /// Uncompressed chunks.
    None,
}

/// When to close the open chunk and flush it to the file. A crash loses at most what was
/// written since the last flush. Time is recorded time (frame timestamps), not wall-clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FlushPolicy {
    /// Flush after this many frames.
    pub every_frames: Option<u32>,
    /// Flush when this much recorded time (ns) passed since the last flush.
    pub every_ns: Option<u64>,
}

impl Default for FlushPolicy {
    fn default() -> Self {
        Self {
            every_frames: Some(DEFAULT_FLUSH_FRAMES),
            every_ns: None,
        }
    }
}

/// When to start a new file. Both limits are checked before each frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RotatePolicy {
    /// Start a new file once the current one holds at least this many bytes (flushed chunks).
    pub bytes: Option<u64>,
    /// Start a new file once a frame is this much recorded time (ns) after the file's first frame.
    pub duration_ns: Option<u64>,
}

impl RotatePolicy {
    /// From limits in MiB and seconds of recorded time, `None` or `0` meaning never (the CLI's
    /// `--rotate-mb` / `--rotate-secs`, a recipe's and the daemon's `rotate_mb` / `rotate_secs`).
    pub fn from_limits(mib: Option<u64>, secs: Option<u64>) -> Self {
        Self {
            bytes: mib.filter(|&m| m > 0).map(|m| m.saturating_mul(1024 * 1024)),
            duration_ns: secs.filter(|&s| s > 0).map(|s| s.saturating_mul(1_000_000_000)),
        }
    }

    /// True when rotation is configured.
    pub fn enabled(&self) -> bool {
        self.bytes.is_some() || self.duration_ns.is_some()
    }
}

/// The 8-bit preview channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PreviewOptions {
    /// Keep one 2x2 tile in `decimation` per axis (1 = full size).
    pub decimation: u32,
}

/// Recorder options.
#[derive(Debug, Clone, PartialEq)]
pub struct RecorderOptions {
    /// Camera name: topics are `/<camera>/raw`, `/<camera>/preview`, ...
    pub camera: String,
    /// Chunk compression.
    pub compression: Compression,
    /// Compression level (0 = zstd's own default, 3; ours is [`DEFAULT_COMPRESSION_LEVEL`]).
    pub compression_level: u32,
    /// Target uncompressed chunk size in bytes.
    pub chunk_size: u64,
    /// Flush cadence.
    pub flush: FlushPolicy,
    /// Rotation.
    pub rotate: RotatePolicy,
    /// Record the lossless raw channel.
    pub raw: bool,
    /// Record the 8-bit Foxglove preview.
    pub preview: Option<PreviewOptions>,
    /// Declare the result channels (`/<camera>/annotations`, `/<camera>/detections`,
    /// `/<camera>/stats`). Off for a recording of frames only (`mosaicd record`), so its file
    /// declares no channel that holds no message; writing results is then refused.
    pub results: bool,
    /// Add the `/<camera>/keypoints` channel (mosaic SIFT keypoints as Foxglove annotations) and
    /// the `/<camera>/sift` channel (`mosaicd.SiftFeatures`: full-frame keypoints and descriptors).
    pub keypoints: bool,
    /// Frame timestamps are `CLOCK_MONOTONIC` (a live camera): each file then starts with a
    /// `mosaicd.clock` metadata record holding this reading of the wall clock against it, taken
    /// when the file is opened ([`WALL_CLOCK_METADATA`](super::WALL_CLOCK_METADATA)). `None` for recorded or synthetic time
    /// (replays, recipes), whose output must not depend on when it was made.
    pub wall_clock: Option<WallClockSource>,
    /// Never overwrite an existing file (the daemon: a restart must not truncate the recording of
    /// the run before it). Files are then numbered as rotation numbers them, `stem-NNNN.mcap`,
    /// after the highest number already in the directory; the plain path is used only while it
    /// does not exist and nothing rotates. Files are opened with `create_new`.
    pub keep_existing: bool,
    /// With rotation and `keep_existing`: keep at most this many `stem-NNNN.mcap` files of this
    /// path (earlier runs' included), deleting the lowest-numbered when a rotation opens a new
    /// file (never at start-up). `None` keeps all.
    pub max_files: Option<u32>,
}

impl Default for RecorderOptions {
    fn default() -> Self {
        Self {
            camera: "camera".into(),
            compression: Compression::Zstd,
            compression_level: DEFAULT_COMPRESSION_LEVEL,
            chunk_size: DEFAULT_CHUNK_SIZE,
            flush: FlushPolicy::default(),
            rotate: RotatePolicy::default(),
            raw: true,
            preview: Some(PreviewOptions { decimation: 2 }),
            results: true,
            wall_clock: None,
            keypoints: false,
            keep_existing: false,
            max_files: None,
        }
    }
}

impl RecorderOptions {
    /// Check every option; errors name the option.
    pub fn validate(&self) -> Result<(), RecordError> {
        let bad = |name, value: String, why| Err(RecordError::Option { name, value, why });
        if self.camera.is_empty() || self.camera.contains(['/', ' ']) {
            return bad(
                "camera",
                self.camera.clone(),
                "a non-empty name without '/' or spaces",
            );
        }
        if self.chunk_size == 0 || self.chunk_size > crate::wire::read::MAX_RECORD_BYTES / 4 {
            return bad("chunk_size", self.chunk_size.to_string(), "1 byte ..= 64 MiB");
        }
        if self.flush.every_frames == Some(0) {
            return bad("flush.every_frames", "0".into(), "at least 1 frame, or unset");
        }
        if self.flush.every_ns == Some(0) {
            return bad("flush.every_ns", "0".into(), "at least 1 ns, or unset");
        }
        if self.rotate.bytes == Some(0) {
            return bad("rotate.bytes", "0".into(), "at least 1 byte, or unset");
        }
        if self.rotate.duration_ns == Some(0) {
            return bad("rotate.duration_ns", "0".into(), "at least 1 ns, or unset");
        }
        if let Some(p) = self.preview {
            if p.decimation == 0 {
                return bad("preview.decimation", "0".into(), "at least 1");
            }
        }
        if let Some(n) = self.max_files {
            if n == 0 || !self.rotate.enabled() || !self.keep_existing {
                return bad(
                    "max_files",
                    n.to_string(),
                    "at least 1, and only with rotation and keep_existing (a new run would restart at \
                     0001 and its files would be the lowest numbers, the first deleted)",
                );
            }
        }
        if self.compression_level > 22 {
            return bad("compression_level", self.compression_level.to_string(), "0..=22");
        }
        Ok(())
    }
}

/// What a finished recording holds.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RecordingSummary {
    /// Files written, in order (one unless rotating).
    pub files: Vec<PathBuf>,
    /// Frames written to the raw (or preview) channel.
    pub frames: u64,
    /// Detection messages written.
    pub detections: u64,
    /// Stats messages written.
    pub stats: u64,
}
