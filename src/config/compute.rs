//! `[compute]`: the per-frame stages and the detector. Its string keys are typed: `detector`,
//! `svm`, `mosaic_taps`, `mosaic_tone` and `wb_gains` are parsed when the file is read
//! ([`super::value`]).

use serde::{Deserialize, Serialize};

use super::value::{self, SvmSetting};
use crate::detect::people::DetectorKind;
use crate::features::hog::MosaicTaps;
use crate::raw::levels::Gains;
use crate::raw::tone::MosaicTone;

/// The default `compute.acf_model`: the shipped raw-mosaic ACF model (`models/acf-mosaic.json`,
/// installed into [`SYSTEM_MODEL_DIR`](super::SYSTEM_MODEL_DIR)).
pub const DEFAULT_ACF_MODEL: &str = "acf-mosaic.json";

/// `[compute]`: the per-frame stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ComputeConfig {
    /// Run pedestrian detection on the mosaic (the detector of `detector`).
    pub detect: bool,
    /// Which detector: `"hog"` (multi-scale HOG + linear SVM with the model of `model`; the
    /// default) or `"acf"` (aggregated channel features, boosted trees with a soft cascade, with
    /// the model file of `acf_model`; docs/acf.md).
    #[serde(
        deserialize_with = "value::detector_de",
        serialize_with = "value::detector_ser"
    )]
    pub detector: DetectorKind,
    /// With `detector = "acf"`: the ACF model file (`mosaicd train --detector acf`; default
    /// `acf-mosaic.json`, the shipped raw-mosaic model `models/acf-mosaic.json`). A relative path
    /// is looked for like `model`'s: in the config file's directory, then in [`SYSTEM_MODEL_DIR`](super::SYSTEM_MODEL_DIR).
    /// The HOG-only keys (`model`, `scale_step`, `approx_levels`, `svm`, `mosaic_taps`) do not
    /// apply to it; `hit_threshold`, `max_levels`, `upsample`, `mosaic_tone` and `wb_gains` do.
    pub acf_model: String,
    /// Detector model: a built-in name ([`crate::detect::shipped::SHIPPED`]; default
    /// [`crate::detect::DEFAULT_MODEL`], compiled into the binary), `opencv-default` (OpenCV's
    /// people detector from the shared data directory,
    /// `opencv_hog/default_people_detector_64x128.npy`) or a model file (`.json` ours; `.npy`,
    /// `.yml`, text: OpenCV vectors).
    pub model: String,
    /// Score a window needs: the SVM's (OpenCV `hitThreshold`, `-10..=10`), or with
    /// `detector = "acf"` the trees' sum (`-100..=100`; a window the soft cascade rejects is never
    /// a hit).
    pub hit_threshold: f32,
    /// Scale factor between pyramid levels (`1.01..=2.0`, OpenCV 1.05).
    pub scale_step: f64,
    /// Maximum pyramid levels (`1..=64`).
    pub max_levels: usize,
    /// Start the pyramid magnified (`1.0..=4.0`; 2 finds people ~64 px tall; below 1 would drop
    /// the full-resolution level).
    pub upsample: f64,
    /// Feature-pyramid approximation (Dollár et al. 2014): every n-th level is computed exactly,
    /// the levels between are approximated from its micro-cells (`1..=64`; 1 = exact, 14 ≈ one
    /// exact level per octave; default [`crate::detect::DEFAULT_APPROX_LEVELS`]).
    pub approx_levels: usize,
    /// SVM arithmetic: `"f32"` (OpenCV's scores within 1e-6), `"i8"` (8-bit blocks and weights,
    /// exact integer sums, scores within ≈0.04 of f32: measured faster than f32 on x86-64, most
    /// with AVX-512 VNNI or AVX-VNNI; on aarch64 without the dot product it is not, which is
    /// warned about at start-up) or `"auto"` (`"i8"` where it was measured faster, `"f32"`
    /// elsewhere: [`ScorePrecision::auto_for`](crate::detect::ScorePrecision::auto_for); the default).
    #[serde(deserialize_with = "value::svm_de", serialize_with = "value::svm_ser")]
    pub svm: SvmSetting,
    /// Derivative of the detector's mosaic features: `"model"` (what the model file says; OpenCV
    /// weights and files without the field: same-site), `"same-site"` (`(I(x+2) − I(x−2))/2`) or
    /// `"paper"` (`I(x+1) − I(x−1)`, the paper's `[-1, 0, 1]` on the mosaic: better on clean
    /// frames, worse under noise; docs/detection.md, "The mosaic derivative"). `None` is `"model"`.
    #[serde(
        deserialize_with = "value::mosaic_taps_de",
        serialize_with = "value::mosaic_taps_ser"
    )]
    pub mosaic_taps: Option<MosaicTaps>,
    /// How raw values become the detector's mosaic: `"model"` (what the model file says; OpenCV's
    /// weights and files without the field: `linear`), `"linear"` (black-subtracted and
    /// scaled, the paper's raw mosaic) or `"srgb"` (each site white balanced, clipped and
    /// sRGB-encoded; no demosaicing: docs/detection.md, "The mosaic's tone"). `None` is `"model"`.
    #[serde(
        deserialize_with = "value::mosaic_tone_de",
        serialize_with = "value::mosaic_tone_ser"
    )]
    pub mosaic_tone: Option<MosaicTone>,
    /// White-balance gains of the `srgb` tone: `"auto"` (the frame's own when its source has them,
    /// otherwise a grey-world estimate from each frame), `"file"` (the frame's own; a frame
    /// without them is an error), `"grey-world"`, `"none"` or `"R,G,B"` (fixed, e.g. the
    /// camera's daylight gains; each finite, > 0 and < 16).
    #[serde(
        deserialize_with = "value::wb_gains_de",
        serialize_with = "value::wb_gains_ser"
    )]
    pub wb_gains: Gains,
    /// Orientation bins over 0..180 degrees (`1..=36`, the paper uses 9).
    pub orientation_bins: usize,
    /// Rows per parallel strip (`2..=4096`, even).
    pub strip_rows: usize,
    /// Also compute mosaic SIFT keypoints (super-pixel DoG, 5x5 extrema) and publish them on
    /// `<prefix>/<camera>/keypoints` and record them on `/<camera>/keypoints` (Foxglove points)
    /// and `/<camera>/sift` (full-frame keypoints, with descriptors when computed).
    pub keypoints: bool,
    /// With `keypoints`: also compute each keypoint's 128-byte SIFT descriptor (on the mosaic
    /// gradient) and publish and record it beside the keypoint.
    pub keypoint_descriptors: bool,
    /// With `keypoints`: double the colour planes first (the mosaic's analogue of OpenCV's
    /// `firstOctave = -1`): finer keypoints, at 4-5x the cost of the stage.
    pub keypoints_double: bool,
}

impl Default for ComputeConfig {
    fn default() -> Self {
        Self {
            detect: true,
            detector: DetectorKind::Hog,
            acf_model: DEFAULT_ACF_MODEL.into(),
            model: crate::detect::DEFAULT_MODEL.into(),
            hit_threshold: 0.0,
            scale_step: 1.05,
            max_levels: 64,
            upsample: 1.0,
            approx_levels: crate::detect::DEFAULT_APPROX_LEVELS,
            svm: SvmSetting::Auto,
            mosaic_taps: None,
            mosaic_tone: None,
            wb_gains: Gains::Auto,
            orientation_bins: 9,
            strip_rows: 64,
            keypoints: false,
            keypoint_descriptors: false,
            keypoints_double: false,
        }
    }
}

impl ComputeConfig {
    /// The model file or name the configured detector reads, and its key: `acf_model` for
    /// `detector = "acf"`, else `model`.
    pub fn model_key(&self) -> (&'static str, &str) {
        match self.detector {
            DetectorKind::Hog => ("compute.model", &self.model),
            DetectorKind::Acf => ("compute.acf_model", &self.acf_model),
        }
    }
}
