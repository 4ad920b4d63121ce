//! `[record]`: the MCAP recording.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// `[record]`: results (and frames) to MCAP.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    /// Record at all.
    pub enabled: bool,
    /// Output file; `{camera}` is replaced by the camera name.
    pub path: PathBuf,
    /// Also record the raw frames (lossless, full bit depth), not only results.
    pub frames: bool,
    /// Also record an 8-bit `foxglove.RawImage` preview, keeping every n-th 2x2 tile (`0` = no
    /// preview, `1..=16`).
    pub preview_decimation: u32,
    /// Flush (close the chunk) every n frames: what a crash can lose (`1..=10000`).
    pub flush_frames: u32,
    /// Start a new file after this many MiB (`0` = never, `0..=1048576`).
    pub rotate_mb: u64,
    /// Start a new file after this many seconds of recorded time (`0` = never, `0..=31536000`).
    pub rotate_secs: u64,
    /// With rotation, keep at most this many files of this path, deleting the oldest (`0` = keep
    /// all, `0..=1000000`; not with `overwrite`).
    pub max_files: u32,
    /// Overwrite an existing file at `path` instead of numbering the new recording after it
    /// (`mosaicd replay --out` sets it: a command-line output).
    pub overwrite: bool,
    /// After a write error (disk full, I/O error), try again in a new file this many
    /// milliseconds later, and then as often, until a write succeeds (`0` = stop recording for
    /// the rest of the run, `0..=86400000`). Only without `overwrite`: resuming must not
    /// truncate the file that failed.
    pub retry_ms: u64,
}

impl Default for RecordConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            path: PathBuf::from("out/{camera}.mcap"),
            frames: false,
            preview_decimation: 0,
            flush_frames: 30,
            rotate_mb: 0,
            rotate_secs: 0,
            max_files: 0,
            overwrite: false,
            retry_ms: 30_000,
        }
    }
}
