//! The per-frame compute stage: raw mosaic → gradient magnitude and orientation bin → detections.
//!
//! Until the shared fused kernel (`features::gradient`) and the HOG detector (`detect`) are merged,
//! the daemon runs this local stage: central differences with **same-colour taps** (two pixels
//! apart, as in the paper's mosaic operator), so every difference subtracts pixels of one colour
//! and the black level cancels:
//!
//! ```text
//! gx(x, y) = (I(x+2, y) - I(x-2, y)) / (white - black)      gy likewise in y
//! m = sqrt(gx² + gy²),   θ = atan2(gy, gx) mod π,   bin = floor(θ / π · bins)
//! ```
//!
//! The two-pixel border where a tap would leave the frame is zero. Detection publishes an empty
//! list until the detector lands (the message format and counters are already final).
//!
//! Rows are split into strips of `strip_rows` (even, so every strip starts on the same CFA phase)
//! processed on the caller's rayon pool; per-strip sums are added in strip order, so the result —
//! including `mean_magnitude` — is identical for any thread count (tested).
//!
//! ```
//! use mosaicd::pipeline::stage::{GradientMaps, StageSpec, compute};
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! let f = RawFrame::from_u16(8, 8, vec![100; 64], Cfa::Rggb, 12, Levels::uniform(0, 4095)).unwrap();
//! let mut maps = GradientMaps::default();
//! let out = compute(&f, &StageSpec::default(), &mut maps).unwrap();
//! assert_eq!(out.mean_magnitude, 0.0); // a flat mosaic has no gradient
//! assert!(out.detections.is_empty());
//! ```

use rayon::prelude::*;

use crate::detect::types::Detection;
use crate::raw::{RawFrame, RawView};

/// Distance between same-colour taps in a Bayer mosaic.
const TAP: usize = 2;

/// Errors of the compute stage.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum StageError {
    /// The frame is too small for the operator.
    #[error("frame {width}x{height} is too small: at least 5x5 pixels are needed")]
    TooSmall {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// The frame's size differs from the stream's.
    #[error("frame {sequence} is {width}x{height} but the stream is {expected_width}x{expected_height}")]
    FrameSize {
        /// The frame's sequence number.
        sequence: u64,
        /// Its width.
        width: usize,
        /// Its height.
        height: usize,
        /// The stream's width.
        expected_width: usize,
        /// The stream's height.
        expected_height: usize,
    },
    /// Invalid spec.
    #[error("invalid stage spec: {field} = {value} (allowed {allowed})")]
    Spec {
        /// Field.
        field: &'static str,
        /// Value.
        value: usize,
        /// Allowed range.
        allowed: &'static str,
    },
}

/// Validated stage parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StageSpec {
    /// Orientation bins over 0..180° (Dalal–Triggs: 9).
    pub orientation_bins: usize,
    /// Rows per parallel strip (even).
    pub strip_rows: usize,
    /// Run detection.
    pub detect: bool,
}

impl Default for StageSpec {
    fn default() -> Self {
        Self {
            orientation_bins: 9,
            strip_rows: 64,
            detect: true,
        }
    }
}

impl StageSpec {
    /// Check the parameters.
    pub fn validate(&self) -> Result<(), StageError> {
        if !(1..=36).contains(&self.orientation_bins) {
            return Err(StageError::Spec {
                field: "orientation_bins",
                value: self.orientation_bins,
                allowed: "1..=36",
            });
        }
        if self.strip_rows < 2 || !self.strip_rows.is_multiple_of(2) {
            return Err(StageError::Spec {
                field: "strip_rows",
                value: self.strip_rows,
                allowed: "even, >= 2",
            });
        }
        Ok(())
    }
}

/// Gradient maps of one frame (reused between frames through the buffer pool).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GradientMaps {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Magnitude, normalised units, row-major.
    pub magnitude: Vec<f32>,
    /// Orientation bin, row-major.
    pub bins: Vec<u8>,
    /// Number of orientation bins over 0..180°.
    pub orientation_bins: usize,
}

impl GradientMaps {
    /// Resize for a frame, reusing capacity (no allocation when the size does not grow).
    pub fn reset(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.magnitude.resize(width * height, 0.0);
        self.bins.resize(width * height, 0);
    }
}

/// What the stage produced for one frame (besides the maps).
#[derive(Debug, Clone, PartialEq)]
pub struct StageOutput {
    /// Detections, highest score first.
    pub detections: Vec<Detection>,
    /// Mean gradient magnitude over the frame.
    pub mean_magnitude: f32,
}

/// Run the stage on `frame` into `maps` (on the current rayon pool).
pub fn compute(
    frame: &RawFrame,
    spec: &StageSpec,
    maps: &mut GradientMaps,
) -> Result<StageOutput, StageError> {
    spec.validate()?;
    let (w, h) = (frame.width(), frame.height());
    if w < 2 * TAP + 1 || h < 2 * TAP + 1 {
        return Err(StageError::TooSmall { width: w, height: h });
    }
    maps.reset(w, h);
    maps.orientation_bins = spec.orientation_bins;
    let scale = 1.0 / (frame.levels().white as f32 - frame.levels().max_black() as f32).max(1.0);
    let bins = spec.orientation_bins;
    let strip = spec.strip_rows;
    let view = frame.view();
    let sums: Vec<f64> = maps
        .magnitude
        .par_chunks_mut(strip * w)
        .zip(maps.bins.par_chunks_mut(strip * w))
        .enumerate()
        .map(|(s, (mag, bin))| match view {
            RawView::U8(v) => strip_kernel(|x, y| v.row(y)[x] as f32, w, h, s * strip, scale, bins, mag, bin),
            RawView::U16(v) => {
                strip_kernel(|x, y| v.row(y)[x] as f32, w, h, s * strip, scale, bins, mag, bin)
            }
        })
        .collect();
    let total: f64 = sums.iter().sum();
    Ok(StageOutput {
        detections: Vec::new(),
        mean_magnitude: (total / (w * h) as f64) as f32,
    })
}

/// One strip of rows starting at `y0`; returns the strip's magnitude sum.
#[allow(clippy::too_many_arguments)]
fn strip_kernel(
    px: impl Fn(usize, usize) -> f32,
    w: usize,
    h: usize,
    y0: usize,
    scale: f32,
    bins: usize,
    mag: &mut [f32],
    bin: &mut [u8],
) -> f64 {
    let rows = mag.len() / w;
    let mut sum = 0.0f64;
    for r in 0..rows {
        let y = y0 + r;
        let (mrow, brow) = (&mut mag[r * w..(r + 1) * w], &mut bin[r * w..(r + 1) * w]);
        if y < TAP || y + TAP >= h {
            mrow.fill(0.0);
            brow.fill(0);
            continue;
        }
        let mut row_sum = 0.0f32;
        for x in 0..w {
            if x < TAP || x + TAP >= w {
                mrow[x] = 0.0;
                brow[x] = 0;
                continue;
            }
            let gx = (px(x + TAP, y) - px(x - TAP, y)) * scale;
            let gy = (px(x, y + TAP) - px(x, y - TAP)) * scale;
            let m = (gx * gx + gy * gy).sqrt();
            let mut theta = gy.atan2(gx);
            if theta < 0.0 {
                theta += std::f32::consts::PI;
            }
            let b = ((theta / std::f32::consts::PI) * bins as f32) as usize;
            mrow[x] = m;
            brow[x] = b.min(bins - 1) as u8;
            row_sum += m;
        }
        sum += row_sum as f64;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::{Cfa, Levels};

    fn ramp_x() -> RawFrame {
        // I(x, y) = 10 x: every same-colour difference is 40.
        let px: Vec<u16> = (0..16 * 12).map(|i| (i % 16) as u16 * 10).collect();
        RawFrame::from_u16(16, 12, px, Cfa::Rggb, 12, Levels::uniform(0, 4000)).unwrap()
    }

    #[test]
    fn horizontal_ramp_hand_computed() {
        let mut maps = GradientMaps::default();
        let out = compute(&ramp_x(), &StageSpec::default(), &mut maps).unwrap();
        // interior: gx = 40 / 4000 = 0.01, gy = 0, orientation 0 -> bin 0
        assert!((maps.magnitude[5 * 16 + 5] - 0.01).abs() < 1e-7);
        assert_eq!(maps.bins[5 * 16 + 5], 0);
        // border is zero
        assert_eq!(maps.magnitude[16 + 5], 0.0);
        assert_eq!(maps.magnitude[5 * 16 + 1], 0.0);
        // 12 interior columns x 8 interior rows
        let expect = 0.01 * 12.0 * 8.0 / (16.0 * 12.0);
        assert!((out.mean_magnitude - expect).abs() < 1e-6);
    }

    #[test]
    fn vertical_edge_goes_to_the_middle_bin() {
        let px: Vec<u16> = (0..16 * 12).map(|i| (i / 16) as u16 * 10).collect();
        let f = RawFrame::from_u16(16, 12, px, Cfa::Bggr, 12, Levels::uniform(0, 4000)).unwrap();
        let mut maps = GradientMaps::default();
        compute(&f, &StageSpec::default(), &mut maps).unwrap();
        assert_eq!(maps.bins[5 * 16 + 5], 4); // 90 degrees of 9 bins of 20 degrees
    }

    #[test]
    fn parallel_equals_serial_for_any_pool_and_strip() {
        let px: Vec<u16> = (0..64 * 50u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 20) as u16 & 4095)
            .collect();
        let f = RawFrame::from_u16(64, 50, px, Cfa::Grbg, 12, Levels::uniform(64, 4095)).unwrap();
        let spec = StageSpec {
            strip_rows: 4,
            ..StageSpec::default()
        };
        let serial = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let mut m1 = GradientMaps::default();
        let o1 = serial.install(|| compute(&f, &spec, &mut m1)).unwrap();
        for threads in [2, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut m = GradientMaps::default();
            let o = pool.install(|| compute(&f, &spec, &mut m)).unwrap();
            assert_eq!(m, m1);
            assert_eq!(o.mean_magnitude.to_bits(), o1.mean_magnitude.to_bits());
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let f = RawFrame::from_u16(4, 4, vec![0; 16], Cfa::Rggb, 12, Levels::uniform(0, 4095)).unwrap();
        assert!(matches!(
            compute(&f, &StageSpec::default(), &mut GradientMaps::default()),
            Err(StageError::TooSmall { .. })
        ));
        let spec = StageSpec {
            strip_rows: 3,
            ..StageSpec::default()
        };
        assert!(spec.validate().is_err());
    }
}
