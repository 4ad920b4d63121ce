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
//! | `<prefix>/<camera>/keypoints` | [`KeypointsMsg`] | with `compute.keypoints = true`: up to [`MAX_KEYPOINTS`] mosaic SIFT keypoints, strongest first |
//! | `<prefix>/<camera>/descriptors` | [`DescriptorsMsg`] | with `compute.keypoint_descriptors = true`: their 128-byte SIFT descriptors, same order, published right after the keypoints |
//!
//! ```
//! use mosaicd::wire::messages::{DetectionsMsg, BoxMsg, MAX_BOXES};
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

use crate::features::sift::Keypoint;
use crate::geometry::Detection;

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

/// Capacity of [`KeypointsMsg::keypoints`] (and [`DescriptorsMsg::descriptors`]). The stage sorts
/// keypoints by decreasing |response|, so the strongest are kept; the rest are counted in
/// [`KeypointsMsg::overflow`]. The 1080p bench frame gives 343 mosaic SIFT keypoints, 461 with doubled
/// planes (`compute.keypoints_double`); busier scenes give more.
pub const MAX_KEYPOINTS: usize = 512;

/// One keypoint: full-resolution mosaic pixel coordinates, scale and orientation.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend, Serialize)]
#[type_name("mosaicd.KeypointMsg.v1")]
pub struct KeypointMsg {
    /// Column, pixels (pixel centres at integers, as OpenCV).
    pub x: f32,
    /// Row, pixels.
    pub y: f32,
    /// Diameter of the keypoint's neighbourhood, pixels (OpenCV `size`).
    pub size: f32,
    /// Orientation, degrees in [0, 360) (OpenCV convention).
    pub angle: f32,
    /// |DoG| response at the extremum, on [0, 1] data.
    pub response: f32,
}

impl From<&Keypoint> for KeypointMsg {
    fn from(k: &Keypoint) -> Self {
        Self {
            x: k.x,
            y: k.y,
            size: k.size,
            angle: k.angle,
            response: k.response,
        }
    }
}

/// Mosaic SIFT keypoints of one frame (`<prefix>/<camera>/keypoints`).
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("mosaicd.KeypointsMsg.v1")]
pub struct KeypointsMsg {
    /// The pipeline's dense frame index (the same as the frame's [`DetectionsMsg::index`]).
    pub index: u64,
    /// The source's sequence number.
    pub sequence: u64,
    /// Source timestamp, ns.
    pub capture_timestamp_ns: u64,
    /// Injected-clock timestamp at publication, ns.
    pub publish_timestamp_ns: u64,
    /// Frame width, pixels.
    pub frame_width: u32,
    /// Frame height, pixels.
    pub frame_height: u32,
    /// Number of valid entries in `keypoints`.
    pub keypoint_count: u32,
    /// Keypoints that did not fit ([`MAX_KEYPOINTS`]).
    pub overflow: u32,
    /// The keypoints, `keypoint_count` valid, strongest first.
    pub keypoints: [KeypointMsg; MAX_KEYPOINTS],
}

impl Default for KeypointsMsg {
    fn default() -> Self {
        Self {
            index: 0,
            sequence: 0,
            capture_timestamp_ns: 0,
            publish_timestamp_ns: 0,
            frame_width: 0,
            frame_height: 0,
            keypoint_count: 0,
            overflow: 0,
            keypoints: [KeypointMsg::default(); MAX_KEYPOINTS],
        }
    }
}

impl KeypointsMsg {
    /// Copy keypoints in, counting those beyond [`MAX_KEYPOINTS`] in `overflow`.
    pub fn set_keypoints(&mut self, keypoints: &[Keypoint]) {
        let n = keypoints.len().min(MAX_KEYPOINTS);
        for (d, k) in self.keypoints.iter_mut().zip(&keypoints[..n]) {
            *d = KeypointMsg::from(k);
        }
        self.keypoints[n..].fill(KeypointMsg::default());
        self.keypoint_count = n as u32;
        self.overflow = (keypoints.len() - n) as u32;
    }

    /// The valid keypoints.
    pub fn keypoints(&self) -> &[KeypointMsg] {
        &self.keypoints[..(self.keypoint_count as usize).min(MAX_KEYPOINTS)]
    }
}

/// Bytes of one SIFT descriptor (OpenCV's 128 stored values).
pub const DESCRIPTOR_BYTES: usize = crate::features::sift::DESCRIPTOR_LEN;

/// The SIFT descriptors of one frame's keypoints (`<prefix>/<camera>/descriptors`, only with
/// `compute.keypoint_descriptors = true`): `descriptors[i]` belongs to `keypoints[i]` of the
/// [`KeypointsMsg`] with the same `index`, which is published just before it.
///
/// A service of its own, so that the 64 KiB of descriptors per sample are in shared memory only
/// where they are asked for: iceoryx2 reserves every sample slot a service can hold at once
/// (about `16 · (publish.subscriber_buffer + 2)` per publisher).
#[repr(C)]
#[derive(Debug, Clone, Copy, ZeroCopySend)]
#[type_name("mosaicd.DescriptorsMsg.v1")]
pub struct DescriptorsMsg {
    /// The pipeline's frame index (the keypoints message's `index`).
    pub index: u64,
    /// The source's sequence number.
    pub sequence: u64,
    /// Source timestamp, ns.
    pub capture_timestamp_ns: u64,
    /// Number of valid entries in `descriptors` (the keypoints message's `keypoint_count`).
    pub descriptor_count: u32,
    /// Descriptors that did not fit ([`MAX_KEYPOINTS`]).
    pub overflow: u32,
    /// The descriptors, `descriptor_count` valid, in the keypoints' order.
    pub descriptors: [[u8; DESCRIPTOR_BYTES]; MAX_KEYPOINTS],
}

impl Default for DescriptorsMsg {
    fn default() -> Self {
        Self {
            index: 0,
            sequence: 0,
            capture_timestamp_ns: 0,
            descriptor_count: 0,
            overflow: 0,
            descriptors: [[0; DESCRIPTOR_BYTES]; MAX_KEYPOINTS],
        }
    }
}

impl DescriptorsMsg {
    /// Copy descriptors in (the first [`MAX_KEYPOINTS`], as the keypoints message keeps the first
    /// keypoints), counting the rest in `overflow` and zeroing the unused tail.
    pub fn set_descriptors(&mut self, descriptors: &[[u8; DESCRIPTOR_BYTES]]) {
        let n = descriptors.len().min(MAX_KEYPOINTS);
        self.descriptors[..n].copy_from_slice(&descriptors[..n]);
        self.descriptors[n..].fill([0; DESCRIPTOR_BYTES]);
        self.descriptor_count = n as u32;
        self.overflow = (descriptors.len() - n) as u32;
    }

    /// The valid descriptors.
    pub fn descriptors(&self) -> &[[u8; DESCRIPTOR_BYTES]] {
        &self.descriptors[..(self.descriptor_count as usize).min(MAX_KEYPOINTS)]
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
#[type_name("mosaicd.StatsMsg.v3")]
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
    /// Sinks that failed and stopped (e.g. the recorder on a full disk), counted when they fail:
    /// later messages carry it (a failure among the last frames may reach only the final summary).
    pub failed_sink: u64,
    /// Frames a sink received but did not write, summed over sinks: frames that arrived while a
    /// recording was paused by a write error, the frame a sink stopped on and those after it, and
    /// a recording's frames not flushed when the error came (an upper bound: MCAP may have
    /// written part of that chunk) (v3). Counted as each sink works through its queue, so, like
    /// `failed_sink`, losses among the last frames may reach only the run's final summary.
    pub sink_frames_lost: u64,
    /// Boxes published.
    pub detections: u64,
    /// Boxes beyond the message capacity.
    pub box_overflow: u64,
    /// Frames per second over the last interval (wall clock); in the final message, over the
    /// whole run (the summary's throughput).
    pub fps: f32,
    /// Median latency so far, microseconds (wall clock).
    pub latency_p50_us: f32,
    /// 99th percentile latency so far, microseconds (wall clock).
    pub latency_p99_us: f32,
    /// 1 for the last message before shutdown.
    pub is_final: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kp(i: usize) -> Keypoint {
        Keypoint {
            x: i as f32,
            y: 2.0 * i as f32,
            size: 3.0,
            angle: 45.0,
            response: 1.0 / (1 + i) as f32,
            octave: 0,
            layer: 1,
        }
    }

    #[test]
    fn keypoints_beyond_capacity_are_counted_not_written() {
        let ks: Vec<Keypoint> = (0..MAX_KEYPOINTS + 7).map(kp).collect();
        let mut m = KeypointsMsg::default();
        m.set_keypoints(&ks);
        assert_eq!(m.keypoint_count as usize, MAX_KEYPOINTS);
        assert_eq!(m.overflow, 7);
        assert_eq!(m.keypoints()[3], KeypointMsg::from(&ks[3]));
        // A shorter list afterwards clears the tail and the overflow.
        m.set_keypoints(&ks[..2]);
        assert_eq!(m.keypoints().len(), 2);
        assert_eq!(m.overflow, 0);
        assert_eq!(m.keypoints[2], KeypointMsg::default());
    }

    #[test]
    fn descriptors_keep_the_keypoints_order_and_clear_what_they_do_not_use() {
        let ds: Vec<[u8; DESCRIPTOR_BYTES]> = (0..MAX_KEYPOINTS + 3)
            .map(|i| [(i % 251) as u8; DESCRIPTOR_BYTES])
            .collect();
        let mut m = DescriptorsMsg::default();
        m.set_descriptors(&ds);
        assert_eq!((m.descriptor_count as usize, m.overflow), (MAX_KEYPOINTS, 3));
        assert_eq!(m.descriptors(), &ds[..MAX_KEYPOINTS]);
        // Fewer next frame: the stale descriptors behind them are zeroed.
        m.set_descriptors(&ds[5..7]);
        assert_eq!(m.descriptors(), &ds[5..7]);
        assert_eq!(m.overflow, 0);
        assert_eq!(m.descriptors[2], [0; DESCRIPTOR_BYTES]);
    }

    #[test]
    fn keypoints_message_fits_a_shared_memory_sample() {
        // 512 keypoints x 20 bytes + header: about 10 KiB per sample; descriptors 64 KiB.
        assert_eq!(std::mem::size_of::<KeypointMsg>(), 20);
        assert!(std::mem::size_of::<KeypointsMsg>() <= 48 + 20 * MAX_KEYPOINTS);
        assert_eq!(
            std::mem::size_of::<DescriptorsMsg>(),
            32 + DESCRIPTOR_BYTES * MAX_KEYPOINTS
        );
    }
}
