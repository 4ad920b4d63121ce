//! MCAP recording: channels, schemas, chunking, rotation, clean finalisation.
//!
//! [`McapRecorder`] writes raw frames losslessly at full bit depth (`mosaicd.RawFrame`), an 8-bit
//! `foxglove.RawImage` preview (`bayer_*8`, optionally decimated) so Foxglove Studio shows the
//! stream, detections as `foxglove.ImageAnnotations` (boxes as LINE_LOOP, scores as text) plus our
//! own `mosaicd.Detections` JSON, and stats. The schemas are documented in [`crate::wire::schema`]; reading a
//! recording back is in [`crate::wire`] ([`RecordingInfo`](crate::wire::RecordingInfo)), and frames are
//! replayed by [`crate::capture::McapSource`].
//!
//! Chunks are zstd-compressed (`chunk_size` bounds their uncompressed size); a flush cadence
//! ([`FlushPolicy`], in frames and/or recorded nanoseconds) closes the open chunk so that a crash
//! loses at most one flush interval; rotation ([`RotatePolicy`]) by size or recorded time makes
//! `name-0001.mcap`, `name-0002.mcap`, ... A write error (disk full) is returned once as
//! [`RecordError::Write`]; the recorder then stops (every later call returns
//! [`RecordError::Stopped`] at once) so the caller can count it and go on detecting.
//!
//! Output is deterministic: every log time is the frame's capture timestamp, no wall clock is
//! written, and zstd runs single-threaded.
//!
//! ```
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! use mosaicd::record::{McapRecorder, RecorderOptions};
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("rec.mcap");
//! let mut rec = McapRecorder::create(&path, RecorderOptions::default()).unwrap();
//! let f = RawFrame::from_u16(4, 2, vec![100; 8], Cfa::Rggb, 12, Levels::uniform(64, 4095)).unwrap();
//! rec.write_frame(&f).unwrap();
//! rec.write_detections(0, 0, 4, 2, &[]).unwrap();
//! let summary = rec.finish().unwrap();
//! assert_eq!(summary.frames, 1);
//! let info = mosaicd::wire::RecordingInfo::read(&path).unwrap();
//! assert_eq!(info.count("/camera/raw"), 1);
//! ```

pub(crate) mod preview;
pub(crate) mod recipe;
pub(crate) mod recorder;

/// Re-exported from [`crate::wire`], where they live (what other processes read).
pub use crate::wire::{RecordError, Topics};

pub use preview::{preview_from_raw, Preview};
pub use recipe::{
    build_recording, crop_origin, Align, Motion, Recipe, RecipeError, RecipeRecorder, SourceSpec,
};
pub use recorder::{
    Compression, FlushPolicy, McapRecorder, PreviewOptions, RecordSink, RecorderOptions, RecordingSummary,
    RotatePolicy, DEFAULT_COMPRESSION_LEVEL, WALL_CLOCK_METADATA,
};
