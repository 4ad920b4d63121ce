//! The `#[repr(C)]` message types on mosaicd's iceoryx2 services.
//!
//! Any Rust subscriber links this module and reads the same layout the daemon writes; the types
//! carry an iceoryx2 type name (`#[type_name]`) so a subscriber with a different layout is refused
//! when it opens the service instead of misreading memory.
//!
//! | service | payload | notes |
//! |---|---|---|
//! | `<prefix>/<camera>/detections` | [`DetectionsMsg`] | fixed size, up to [`MAX_BOXES`] boxes |
//! | `<prefix>/<camera>/gradients` | `[u8]` with user header [`GradientsHeader`] | magnitude (u16 LE) then orientation bin (u8) |
//! | `<prefix>/<camera>/stats` | [`StatsMsg`] | one every stats interval and a final one (`is_final = 1`) |
//!
//! ```
//! use mosaicd::publish::messages::{DetectionsMsg, BoxMsg, MAX_BOXES};
//! let mut m = DetectionsMsg::default();
//! m.set_boxes(&[BoxMsg { x: 1.0, y: 2.0, width: 64.0, height: 128.0, score: 0.5 }; 3]);
//! assert_eq!(m.boxes().len(), 3);
//! assert_eq!(m.overflow, 0);
//! assert!(std::mem::size_of::<DetectionsMsg>() < 4096);
//! # let _ = MAX_BOXES;
//! ```
//!
//! Time fields: `capture_timestamp_ns` is the source's timestamp (driver monotonic clock for a live
//! camera, the recorded time in a replay); `publish_timestamp_ns` comes from the pipeline's injected
//! clock (the system monotonic clock live, the recorded timestamp in a replay, so replays are
//! deterministic); `latency_ns` is always measured on the wall (monotonic) clock from the moment the
//! frame entered the pipeline (live: its capture timestamp) to publication — a wall-clock field.

use iceoryx2::prelude::ZeroCopySend;
use serde::Serialize;

use crate::detect::types::Detection;

/// Capacity of [`DetectionsMsg::boxes`]. More boxes in one frame are counted in
/// [`DetectionsMsg::overflow`] (highest scores are kept: the detector sorts by score).
pub const MAX_BOXES: usize = 64;

/// One box: full-frame pixel coordinates and the SVM score.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize)]
#[type_name("mosaicd.BoxMsg.v1")]
pub struct BoxMsg {
    /// Left edge, pixels.
    pub x: f32,
    /// Top edge, pixels.
    pub y: f32,
    /// Width, pixels.
    pub width: f32,
    /// Height, pixels.
    pub height: f32,
    /// Linear SVM score.
    pub score: f32,
}

impl From<&Detection> for BoxMsg {
    fn from(d: &Detection) -> Self {
        Self {
            x: d.x,
            y: d.y,
            width: d.width,
            height: d.height,
            score: d.score,
        }
    }
}

/// Detections of one frame (`<prefix>/<camera>/detections`).
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("mosaicd.DetectionsMsg.v1")]
pub struct DetectionsMsg {
    /// The pipeline's dense frame index (0, 1, 2, ... in publication order).
    pub index: u64,
    /// The source's sequence number.
    pub sequence: u64,
    /// The sensor's sequence number, `u64::MAX` when the source has none.
    pub sensor_sequence: u64,
    /// Source timestamp, ns.
    pub capture_timestamp_ns: u64,
    /// Injected-clock timestamp at publication, ns.
    pub publish_timestamp_ns: u64,
    /// Wall-clock latency from pipeline entry to publication, ns.
    pub latency_ns: u64,
    /// Frame width, pixels.
    pub frame_width: u32,
    /// Frame height, pixels.
    pub frame_height: u32,
    /// Number of valid entries in `boxes`.
    pub box_count: u32,
    /// Boxes that did not fit ([`MAX_BOXES`]).
    pub overflow: u32,
    /// Mean gradient magnitude of the frame (normalised units, full scale 1): a liveness signal.
    pub mean_magnitude: f32,
    /// Padding, zero.
    pub reserved: u32,
    /// The boxes, `box_count` valid.
    pub boxes: [BoxMsg; MAX_BOXES],
}

impl Default for DetectionsMsg {
    fn default() -> Self {
        Self {
            index: 0,
            sequence: 0,
            sensor_sequence: u64::MAX,
            capture_timestamp_ns: 0,
            publish_timestamp_ns: 0,
            latency_ns: 0,
            frame_width: 0,
            frame_height: 0,
            box_count: 0,
            overflow: 0,
            mean_magnitude: 0.0,
            reserved: 0,
            boxes: [BoxMsg::default(); MAX_BOXES],
        }
    }
}

impl DetectionsMsg {
    /// Copy boxes in, counting those beyond [`MAX_BOXES`] in `overflow`.
    pub fn set_boxes(&mut self, boxes: &[BoxMsg]) {
        let n = boxes.len().min(MAX_BOXES);
        self.boxes[..n].copy_from_slice(&boxes[..n]);
        self.boxes[n..].fill(BoxMsg::default());
        self.box_count = n as u32;
        self.overflow = (boxes.len() - n) as u32;
    }

    /// The valid boxes.
    pub fn boxes(&self) -> &[BoxMsg] {
        &self.boxes[..(self.box_count as usize).min(MAX_BOXES)]
    }
}

/// Header of a gradients sample (`<prefix>/<camera>/gradients`, payload `[u8]`).
///
/// The payload holds `width * height` little-endian `u16` magnitudes (raw units `>> mag_shift`, the
/// fused kernel's output) followed by `width * height` orientation bins (`u8`,
/// `0..orientation_bins`), both row-major at the decimated size.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, ZeroCopySend, Serialize)]
#[type_name("mosaicd.GradientsHeader.v2")]
pub struct GradientsHeader {
    /// The pipeline's frame index.
    pub index: u64,
    /// Source timestamp, ns.
    pub capture_timestamp_ns: u64,
    /// Decimated width.
    pub width: u32,
    /// Decimated height.
    pub height: u32,
    /// Every n-th pixel in x and y was kept.
    pub decimation: u32,
    /// Number of orientation bins over 0..180 degrees.
    pub orientation_bins: u32,
    /// Right shift applied to the magnitudes.
    pub mag_shift: u32,
    /// Padding, zero.
    pub reserved: u32,
}

/// Counters of one camera's pipeline (`<prefix>/<camera>/stats`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize)]
#[type_name("mosaicd.StatsMsg.v1")]
pub struct StatsMsg {
    /// Injected-clock time of this snapshot, ns.
    pub timestamp_ns: u64,
    /// Frames delivered by the source.
    pub captured: u64,
    /// Frames processed and published.
    pub processed: u64,
    /// Frames dropped because compute fell behind (live sources only).
    pub dropped_queue_full: u64,
    /// Frames the driver skipped (sensor sequence gaps).
    pub dropped_driver: u64,
    /// Source errors (unreadable frame, truncated recording, device lost).
    pub failed_source: u64,
    /// Frames whose compute failed (e.g. wrong frame size).
    pub failed_compute: u64,
    /// Boxes published.
    pub detections: u64,
    /// Boxes beyond the message capacity.
    pub box_overflow: u64,
    /// Frames per second over the last interval (wall clock).
    pub fps: f32,
    /// Median latency so far, microseconds (wall clock).
    pub latency_p50_us: f32,
    /// 99th percentile latency so far, microseconds (wall clock).
    pub latency_p99_us: f32,
    /// 1 for the last message before shutdown.
    pub is_final: u32,
}
