//! What other processes read: the `#[repr(C)]` messages on mosaicd's iceoryx2 services
//! ([`messages`]), the MCAP recording schemas with their encoders and decoders ([`schema`]), the
//! topic names ([`Topics`]) and reading recordings back ([`RecordingInfo`], [`for_each_message`],
//! [`read_json_topic`], …, from the private `read.rs`). The two formats stay public modules: their
//! docs are the format's specification.
//!
//! The daemon's writers (`publish/`, `record/`, the pipeline's sinks) and its readers
//! (`capture::mcap_source`, `mosaicd listen`, tests, subscribers in other processes) all import
//! these definitions from here, so the format has one home and nothing in it depends on who writes.

pub mod messages;
pub(crate) mod read;
pub mod schema;

pub use read::{
    for_each_message, read_annotations, read_detections, read_json_topic, read_stats, read_summary,
    ChannelInfo, Logged, RecordingInfo,
};

use std::path::PathBuf;

/// Errors from recording and reading recordings.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// Invalid recorder options.
    #[error("invalid recorder option {name} = {value}: {why}")]
    Option {
        /// Option name.
        name: &'static str,
        /// Offending value.
        value: String,
        /// Allowed values.
        why: &'static str,
    },
    /// The output file could not be created.
    #[error("cannot create recording {path}: {source}")]
    Create {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Writing failed (disk full, I/O error); the recorder has stopped.
    #[error("recording to {path} failed, recording stopped: {}", mcap_detail(.source))]
    Write {
        /// File (or `<writer>`).
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<mcap::McapError>,
    },
    /// The recorder stopped after an earlier write error (reported once as [`RecordError::Write`]).
    #[error("recorder stopped after an earlier error: {first}")]
    Stopped {
        /// The first error, as text.
        first: String,
    },
    /// The recorder was already finished.
    #[error("recorder already finished")]
    Finished,
    /// Reading a recording failed.
    #[error("cannot read recording {path}: {}", mcap_detail(.source))]
    Read {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<mcap::McapError>,
    },
    /// I/O error opening a recording.
    #[error("cannot open recording {path}: {source}")]
    Open {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// A message in a recording does not decode.
    #[error("{path}: message {sequence} on {topic}: {source}")]
    Decode {
        /// File.
        path: PathBuf,
        /// Topic.
        topic: String,
        /// MCAP message sequence.
        sequence: u32,
        /// Cause.
        #[source]
        source: Box<schema::SchemaError>,
    },
}

/// Topic names for one camera.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topics {
    /// `/<camera>/raw` (`mosaicd.RawFrame`).
    pub raw: String,
    /// `/<camera>/preview` (`foxglove.RawImage`).
    pub preview: String,
    /// `/<camera>/annotations` (`foxglove.ImageAnnotations`).
    pub annotations: String,
    /// `/<camera>/detections` (`mosaicd.Detections`).
    pub detections: String,
    /// `/<camera>/stats` (`mosaicd.Stats`).
    pub stats: String,
    /// `/<camera>/keypoints` (`foxglove.ImageAnnotations`, POINTS).
    pub keypoints: String,
    /// `/<camera>/sift` (`mosaicd.SiftFeatures`).
    pub sift: String,
}

impl Topics {
    /// The topics of camera `camera`.
    pub fn new(camera: &str) -> Self {
        Self {
            raw: format!("/{camera}/raw"),
            preview: format!("/{camera}/preview"),
            annotations: format!("/{camera}/annotations"),
            detections: format!("/{camera}/detections"),
            stats: format!("/{camera}/stats"),
            keypoints: format!("/{camera}/keypoints"),
            sift: format!("/{camera}/sift"),
        }
    }
}

/// The message of an MCAP error including its I/O cause (which `McapError`'s own text omits).
pub fn mcap_detail(e: &mcap::McapError) -> String {
    match e {
        mcap::McapError::Io(io) => format!("I/O error: {io}"),
        other => {
            // A write error while the writer encodes a record comes wrapped in a parse error
            // ("Record parse failed"): name what is under it (the OS error).
            let mut text = other.to_string();
            let mut cause = std::error::Error::source(other);
            while let Some(c) = cause {
                text.push_str(": ");
                text.push_str(&c.to_string());
                cause = c.source();
            }
            text
        }
    }
}
