//! The detector's options and their checks ([`DetectorOptions`], [`DetectorSpec`], [`NmsMethod`]), its errors, a pyramid [`Level`], and what a run reports ([`DetectStats`], [`StageProfile`]).

use std::time::Duration;

use super::super::model::ModelError;
use super::super::score::{ScoreError, ScorePrecision};
use crate::features::hog::{HogError, HogTimings};
use crate::resize::ResizeError;

/// Errors of the detector.
#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    /// HOG failed (e.g. image smaller than a window).
    #[error(transparent)]
    Hog(#[from] HogError),
    /// Pyramid failed.
    #[error(transparent)]
    Pyramid(#[from] ResizeError),
    /// Model invalid.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The scoring setup failed (e.g. a descriptor too long for the 8-bit path).
    #[error(transparent)]
    Score(#[from] ScoreError),
    /// An option out of range.
    #[error("detector option {what} = {value} is out of range ({allowed})")]
    BadOption {
        /// Option name.
        what: &'static str,
        /// Value given.
        value: String,
        /// Allowed range.
        allowed: &'static str,
    },
}

/// Non-maximum suppression method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NmsMethod {
    /// Return every hit.
    None,
    /// Greedy IoU suppression.
    Greedy {
        /// IoU above which the weaker box goes.
        iou: f32,
    },
    /// OpenCV `groupRectangles` (detectMultiScale's `finalThreshold` = 2, eps 0.2).
    Group {
        /// A group needs more than this many boxes.
        threshold: usize,
        /// Similarity tolerance.
        eps: f32,
    },
}

/// Detector options (defaults = OpenCV `detectMultiScale`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorOptions {
    /// Scale factor between pyramid levels (OpenCV `scale` 1.05).
    pub scale_step: f64,
    /// Maximum number of levels (OpenCV `nlevels` 64).
    pub max_levels: usize,
    /// Start the pyramid at this magnification (1 = full resolution; 2 finds people of 64 px).
    pub upsample: f64,
    /// Score a window needs to be a hit (OpenCV `hitThreshold` 0).
    pub hit_threshold: f32,
    /// Suppression.
    pub nms: NmsMethod,
    /// Feature-pyramid approximation (Dollár et al. 2014): levels are taken in groups of this many;
    /// the first of each group is computed exactly, the others are approximated from its
    /// orientation votes pooled into 2x2-pixel micro-cells
    /// ([`crate::features::hog::blocks_from_micro_grid`]). 1 = every level exact
    /// (OpenCV-equivalent); 14 ≈ one exact level per octave at scale step 1.05.
    pub approx_levels: usize,
    /// Arithmetic of the SVM stage: f32 (OpenCV's scores within ≈1e-6) or the 8-bit integer path
    /// (scores within [`ScoreWeightsI8::error_bound`](crate::detect::score::ScoreWeightsI8::error_bound), see
    /// [`crate::detect::score`]; where it is faster
    /// than f32: [`ScorePrecision::auto_for`]). A precision slower than the other on this CPU is
    /// warned about when the detector is built ([`ScorePrecision::slow_reason`]).
    pub svm: ScorePrecision,
}

impl Default for DetectorOptions {
    fn default() -> Self {
        Self {
            scale_step: 1.05,
            max_levels: 64,
            upsample: 1.0,
            hit_threshold: 0.0,
            nms: NmsMethod::Group {
                threshold: 2,
                eps: 0.2,
            },
            approx_levels: 1,
            svm: ScorePrecision::F32,
        }
    }
}

/// Validated detector options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorSpec {
    pub(super) opts: DetectorOptions,
}

impl DetectorSpec {
    /// Validate.
    pub fn new(o: &DetectorOptions) -> Result<Self, DetectError> {
        let bad = |what, value: String, allowed| Err(DetectError::BadOption { what, value, allowed });
        if !(o.scale_step.is_finite() && o.scale_step > 1.0 && o.scale_step <= 4.0) {
            return bad("scale_step", o.scale_step.to_string(), "(1, 4]");
        }
        if !(1..=1000).contains(&o.max_levels) {
            return bad("max_levels", o.max_levels.to_string(), "1..=1000");
        }
        if !(o.upsample.is_finite() && (1.0..=8.0).contains(&o.upsample)) {
            return bad("upsample", o.upsample.to_string(), "[1, 8]");
        }
        if !(1..=64).contains(&o.approx_levels) {
            return bad("approx_levels", o.approx_levels.to_string(), "1..=64");
        }
        if !o.hit_threshold.is_finite() {
            return bad("hit_threshold", o.hit_threshold.to_string(), "finite");
        }
        match o.nms {
            NmsMethod::Greedy { iou } if !(0.0..=1.0).contains(&iou) => {
                return bad("nms iou", iou.to_string(), "[0, 1]")
            }
            NmsMethod::Group { eps, .. } if !(eps.is_finite() && eps >= 0.0) => {
                return bad("nms eps", eps.to_string(), "≥ 0")
            }
            _ => {}
        }
        Ok(Self { opts: *o })
    }
    /// Options.
    pub fn options(&self) -> &DetectorOptions {
        &self.opts
    }
}

/// Per-frame statistics; stage times are summed over levels (CPU time when levels run in parallel).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DetectStats {
    /// Levels scored.
    pub levels: usize,
    /// Windows scored.
    pub windows: usize,
    /// Windows at or above the hit threshold (before NMS).
    pub hits: usize,
    /// Pyramid resizes.
    pub resize: Duration,
    /// HOG stage times.
    pub hog: HogTimings,
    /// Approximated levels: their cells from the exact level's micro-cells, and their blocks.
    pub cell_resample: Duration,
    /// SVM scoring.
    pub svm: Duration,
    /// NMS.
    pub nms: Duration,
    /// Wall time of the whole call.
    pub total: Duration,
}

impl std::ops::AddAssign for DetectStats {
    /// Every count and time summed.
    fn add_assign(&mut self, o: Self) {
        self.levels += o.levels;
        self.windows += o.windows;
        self.hits += o.hits;
        self.resize += o.resize;
        self.hog += o.hog;
        self.cell_resample += o.cell_resample;
        self.svm += o.svm;
        self.nms += o.nms;
        self.total += o.total;
    }
}

/// Per-stage times of one frame from [`Detector::stage_profile`](super::Detector::stage_profile): every stage on one thread,
/// one after another, so each time is that stage's CPU.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageProfile {
    /// Pyramid levels.
    pub levels: usize,
    /// Windows scored.
    pub windows: usize,
    /// Windows at or above the hit threshold (before NMS).
    pub hits: usize,
    /// Resize and gamma of the exactly computed levels.
    pub resize: Duration,
    /// Gradients and orientation binning of the exactly computed levels.
    pub gradients: Duration,
    /// Their weighted cell histograms.
    pub cells: Duration,
    /// Their block assembly and L2-Hys normalisation.
    pub blocks: Duration,
    /// Micro-cell pooling at each group's exact level (approximate pyramid; it computes that
    /// level's gradients again).
    pub micro_cells: Duration,
    /// Approximated levels: cells from the micro-cells and their blocks (one fused pass).
    pub approx_cells_blocks: Duration,
    /// SVM scoring of every level.
    pub svm: Duration,
    /// Non-maximum suppression.
    pub nms: Duration,
}

impl std::ops::AddAssign for StageProfile {
    /// Times and counts summed (levels kept: the same for every frame of one size).
    fn add_assign(&mut self, o: Self) {
        self.levels = o.levels;
        self.windows += o.windows;
        self.hits += o.hits;
        self.resize += o.resize;
        self.gradients += o.gradients;
        self.cells += o.cells;
        self.blocks += o.blocks;
        self.micro_cells += o.micro_cells;
        self.approx_cells_blocks += o.approx_cells_blocks;
        self.svm += o.svm;
        self.nms += o.nms;
    }
}

impl StageProfile {
    /// Sum of the stage times.
    pub fn total(&self) -> Duration {
        self.resize
            + self.gradients
            + self.cells
            + self.blocks
            + self.micro_cells
            + self.approx_cells_blocks
            + self.svm
            + self.nms
    }
}

/// One pyramid level: scale and size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    /// Original size / level size.
    pub scale: f64,
    /// Level width.
    pub width: usize,
    /// Level height.
    pub height: usize,
}
