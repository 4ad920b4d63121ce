//! The detection result type shared by the detector, the daemon and subscribers.

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
