//! Boxes in frame coordinates, shared by the detector, the metrics, the daemon and subscribers: a
//! leaf that imports nothing from the crate.

use serde::{Deserialize, Serialize};

/// One detected person: a box in full-frame pixel coordinates and its SVM score.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Left edge, pixels.
    pub x: f32,
    /// Top edge, pixels.
    pub y: f32,
    /// Width, pixels.
    pub width: f32,
    /// Height, pixels.
    pub height: f32,
    /// Linear SVM score (w·x + b); larger is more confident.
    pub score: f32,
}

/// An axis-aligned box (ground truth), top-left corner and size in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rect {
    /// Left edge.
    pub x: f32,
    /// Top edge.
    pub y: f32,
    /// Width.
    pub width: f32,
    /// Height.
    pub height: f32,
}

impl From<&Detection> for Rect {
    fn from(d: &Detection) -> Self {
        Rect {
            x: d.x,
            y: d.y,
            width: d.width,
            height: d.height,
        }
    }
}
