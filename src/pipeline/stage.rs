//! The per-frame compute stage: raw mosaic → gradient magnitude and orientation bin → detections.
//!
//! * **Gradients**: the shared fused kernel [`crate::features::gradient::mag_bin`] (central
//!   difference with same-colour taps on the mosaic, `u16` magnitude `round(√(gx²+gy²) / 2^s)` and
//!   `u8` orientation bin over 0..180°, reflect-101 borders), into pooled buffers, on the calling
//!   rayon pool.
//! * **Detection** (optional): the mosaic is brought into the model's tone in a pooled `f32`
//!   buffer in 8-bit units and handed, with the frame's CFA, to the [`PeopleDetector`]: the
//!   multi-scale HOG + linear SVM detector or the ACF detector (`compute.detector`). Linear:
//!   `(v − black) · 255 / (white − black)`, clamped at 0
//!   ([`crate::features::hog::mosaic_from_raw_into`]; the tone module's linear tables are tested
//!   equal to it). sRGB: each
//!   site white balanced with [`StageSpec::wb_gains`] (for [`Gains::Auto`] the frame's own gains,
//!   else a grey-world estimate of this frame), clipped and sRGB-encoded
//!   ([`crate::raw::MosaicTone`]), through lookup tables the stage keeps while frames' levels
//!   and gains stay the same. A frame smaller than the detection window gives no detections (not
//!   an error).
//! * **Keypoints** (optional, `compute.keypoints`): the paper's mosaic SIFT
//!   ([`crate::features::sift::keypoints_from_frame`]: black level subtracted per tile, super-pixel
//!   DoG pyramid, 5x5 extrema), sorted by decreasing |response| with ties broken by position, so
//!   the order — and which keypoints fit a message — is the same for any thread count. With
//!   `compute.keypoint_descriptors` each keypoint also gets its 128-byte descriptor
//!   ([`crate::features::sift::features_from_frame`]), kept in the keypoints' order; with
//!   `compute.keypoints_double` the colour planes are doubled first (finer keypoints, 4-5x the
//!   cost). A frame smaller than SIFT's minimum size gives empty lists (not an error).
//! * **Odd-sized frames** (a file source can deliver one): detection and keypoints run on the
//!   frame's even part from (0, 0), in the frame's coordinates, instead of failing the frame;
//!   the gradients cover the whole frame.
//! * **mean_magnitude**: `Σ mag · 2^s / (white − max black) / (w·h)`, a cheap liveness signal in
//!   normalised units. The sum is an exact integer, so it is identical for any thread count.
//!
//! ```
//! use mosaicd::pipeline::{GradientMaps, Stage, StageSpec};
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! let f = RawFrame::from_u16(8, 8, vec![100; 64], Cfa::Rggb, 12, Levels::uniform(0, 4095)).unwrap();
//! let stage = Stage::new(StageSpec { detect: false, ..StageSpec::default() }, None).unwrap();
//! let mut maps = GradientMaps::default();
//! let out = stage.compute(&f, &mut maps).unwrap();
//! assert_eq!(out.mean_magnitude, 0.0); // a flat mosaic has no gradient
//! assert!(out.detections.is_empty());
//! ```

use std::sync::Arc;

use rayon::prelude::*;

use crate::detect::input::MosaicInput;
use crate::detect::people::{PeopleDetector, PeopleError, PeopleInput};
use crate::features::gradient::{mag_bin, AngleRange, Border, MagBinOptions, MagBinSpec, Operator};
use crate::features::sift::{
    features_from_frame, keypoints_from_frame, Keypoint, SiftError, SiftOptions, SiftSpec, DESCRIPTOR_LEN,
};
use crate::geometry::Detection;
use crate::image::{Image, ImageViewMut};
use crate::raw::levels::{Compression, Gains, NormaliseOptions};
use crate::raw::RawFrame;

/// One SIFT descriptor (OpenCV's 128 stored bytes).
pub type Descriptor = [u8; DESCRIPTOR_LEN];

/// Errors of the compute stage.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
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
    /// The gradient kernel refused the frame.
    #[error("gradients: {0}")]
    Gradient(#[from] crate::features::gradient::GradientError),
    /// The detector refused the frame.
    #[error("detection: {0}")]
    Detect(#[from] PeopleError),
    /// The white balance of the detector's mosaic failed (bad gains, or `file` gains on a frame
    /// without any).
    #[error("white balance: {0}")]
    Gains(#[from] crate::raw::RawError),
    /// Mosaic SIFT refused the frame (other than for being too small).
    #[error("keypoints: {0}")]
    Keypoints(#[from] SiftError),
    /// An internal buffer did not match the frame.
    #[error("buffer: {0}")]
    Buffer(#[from] crate::image::ImageError),
}

/// Stage parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StageSpec {
    /// Orientation bins over 0..180° (Dalal–Triggs: 9).
    pub orientation_bins: usize,
    /// Rows per parallel strip for the normalisation (even).
    pub strip_rows: usize,
    /// Run detection.
    pub detect: bool,
    /// Compute mosaic SIFT keypoints.
    pub keypoints: bool,
    /// With `keypoints`: also compute their descriptors.
    pub keypoint_descriptors: bool,
    /// With `keypoints`: double the colour planes first (OpenCV's `firstOctave = -1` on the
    /// mosaic).
    pub keypoints_double: bool,
    /// White-balance gains of the detector's mosaic when the model's tone is
    /// [`crate::raw::tone::MosaicTone::Srgb`] (`compute.wb_gains`; [`Gains::Auto`]: the frame's own, else grey
    /// world).
    pub wb_gains: Gains,
}

impl Default for StageSpec {
    fn default() -> Self {
        Self {
            orientation_bins: 9,
            strip_rows: 64,
            detect: true,
            keypoints: false,
            keypoint_descriptors: false,
            keypoints_double: false,
            wb_gains: Gains::Auto,
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
        NormaliseOptions {
            gains: self.wb_gains,
            compression: Compression::None,
        }
        .build()?;
        Ok(())
    }
}

/// The validated stage: gradient kernel spec and the detector, shared by every task.
#[derive(Debug, Clone)]
pub struct Stage {
    spec: StageSpec,
    gradient: MagBinSpec,
    detector: Option<Arc<PeopleDetector>>,
    sift: Option<SiftSpec>,
    /// The detector's input in its model's tone (tone tables kept between frames).
    input: Option<Arc<MosaicInput>>,
}

impl Stage {
    /// Validate and build. `detector` is used when `spec.detect` is set; without one, detection
    /// publishes empty lists.
    pub fn new(spec: StageSpec, detector: Option<Arc<PeopleDetector>>) -> Result<Self, StageError> {
        spec.validate()?;
        let gradient = MagBinSpec::new(MagBinOptions {
            operator: Operator::Central,
            border: Border::Reflect101,
            bins: spec.orientation_bins,
            range: AngleRange::Unsigned,
            serial: false,
        })?;
        let sift = if spec.keypoints {
            Some(
                SiftOptions::mosaic()
                    .build()?
                    .with_double_image(spec.keypoints_double),
            )
        } else {
            None
        };
        Ok(Self {
            spec,
            gradient,
            input: detector
                .as_ref()
                .filter(|_| spec.detect)
                .map(|d| Arc::new(MosaicInput::new(d.mosaic_prep(spec.wb_gains)))),
            detector: if spec.detect { detector } else { None },
            sift,
        })
    }

    /// The parameters.
    pub fn spec(&self) -> &StageSpec {
        &self.spec
    }

    /// Run on `frame` into `maps` (on the current rayon pool).
    pub fn compute(&self, frame: &RawFrame, maps: &mut GradientMaps) -> Result<StageOutput, StageError> {
        let (w, h) = (frame.width(), frame.height());
        maps.reset(w, h);
        maps.orientation_bins = self.spec.orientation_bins;
        maps.mag_shift = self.gradient.mag_shift(frame.bit_depth());
        {
            let mut mag = ImageViewMut::new(&mut maps.magnitude, w, h, w)?;
            let mut bin = ImageViewMut::new(&mut maps.bins, w, h, w)?;
            mag_bin(
                frame.view(),
                frame.bit_depth(),
                &self.gradient,
                &mut mag,
                &mut bin,
            )?;
        }
        let sum: u64 = maps
            .magnitude
            .par_chunks(self.spec.strip_rows * w)
            // u32 sums of 16 384 values (< 2^30 each) vectorise; the total is exact either way.
            .map(|c| {
                c.chunks(1 << 14)
                    .map(|k| u64::from(k.iter().map(|&m| u32::from(m)).sum::<u32>()))
                    .sum::<u64>()
            })
            .sum();
        let range = (frame.levels().white as f64 - frame.levels().max_black() as f64).max(1.0);
        let mean = sum as f64 * f64::from(1u32 << maps.mag_shift) / range / (w * h) as f64;
        // Detection and SIFT need whole 2x2 tiles: an odd-sized frame (a file source may deliver
        // one) gives the detections and keypoints of its even part, from (0, 0), so coordinates
        // stay the frame's. The gradients above cover the whole frame.
        let (ew, eh) = (w & !1, h & !1);
        let wanted = self.detector.is_some() || self.sift.is_some();
        let even = if (ew, eh) != (w, h) && wanted && ew >= 2 && eh >= 2 {
            Some(frame.crop(0, 0, ew, eh).expect("an even part inside the frame"))
        } else {
            None
        };
        let part = even.as_ref().unwrap_or(frame);
        let detections = match &self.detector {
            Some(det) => {
                let (ww, wh) = det.window();
                if ew < ww || eh < wh {
                    Vec::new()
                } else {
                    let input = self.input.as_ref().expect("built with the detector");
                    input.mosaic_into(part, self.spec.strip_rows, &mut maps.mosaic)?;
                    let img = std::mem::take(&mut maps.mosaic);
                    let image = Image::from_vec(ew, eh, img)?;
                    let r = det.detect(&PeopleInput::Mosaic {
                        image: image.view(),
                        cfa: part.cfa(),
                    });
                    maps.mosaic = image.into_vec();
                    let (mut d, _) = r?;
                    d.sort_by(|a, b| b.score.total_cmp(&a.score));
                    d
                }
            }
            None => Vec::new(),
        };
        // A part below SIFT's minimum size (an odd 1-pixel-wide frame has no even part and is
        // below it too) gives empty lists: SIFT reports TooSmall before OddSize.
        let (keypoints, descriptors) = match &self.sift {
            Some(spec) if self.spec.keypoint_descriptors => {
                let (k, d) = features_sorted(part, spec)?;
                (Some(k), Some(d))
            }
            Some(spec) => (Some(keypoints_sorted(part, spec)?), None),
            None => (None, None),
        };
        Ok(StageOutput {
            detections,
            keypoints,
            descriptors,
            mean_magnitude: mean as f32,
        })
    }
}

/// The stage's keypoint order: |response| descending, then x, y, size, angle (a total order on
/// the library's deduplicated keypoints).
fn strongest_first(a: &Keypoint, b: &Keypoint) -> std::cmp::Ordering {
    b.response
        .abs()
        .total_cmp(&a.response.abs())
        .then(a.x.total_cmp(&b.x))
        .then(a.y.total_cmp(&b.y))
        .then(a.size.total_cmp(&b.size))
        .then(a.angle.total_cmp(&b.angle))
}

/// Mosaic SIFT keypoints of `frame`, strongest first ([`strongest_first`]); an empty list for a
/// frame below SIFT's minimum size.
fn keypoints_sorted(frame: &RawFrame, spec: &SiftSpec) -> Result<Vec<Keypoint>, SiftError> {
    let mut k = match keypoints_from_frame(frame, spec) {
        Ok(k) => k,
        Err(SiftError::TooSmall { .. }) => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    k.sort_by(strongest_first);
    Ok(k)
}

/// Mosaic SIFT keypoints of `frame` with their descriptors, both strongest first
/// ([`strongest_first`]); empty lists for a frame below SIFT's minimum size.
fn features_sorted(frame: &RawFrame, spec: &SiftSpec) -> Result<(Vec<Keypoint>, Vec<Descriptor>), SiftError> {
    let f = match features_from_frame(frame, spec) {
        Ok(f) => f,
        Err(SiftError::TooSmall { .. }) => return Ok((Vec::new(), Vec::new())),
        Err(e) => return Err(e),
    };
    let mut pairs: Vec<(Keypoint, Descriptor)> = f.keypoints.into_iter().zip(f.descriptors).collect();
    pairs.sort_by(|a, b| strongest_first(&a.0, &b.0));
    Ok(pairs.into_iter().unzip())
}

/// Gradient maps of one frame (reused between frames through the buffer pool).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GradientMaps {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Magnitude `round(√(gx² + gy²) / 2^mag_shift)` in raw units, row-major.
    pub magnitude: Vec<u16>,
    /// Orientation bin, row-major.
    pub bins: Vec<u8>,
    /// Right shift applied to the magnitude.
    pub mag_shift: u32,
    /// Number of orientation bins over 0..180°.
    pub orientation_bins: usize,
    /// Scratch: the normalised mosaic the detector reads.
    pub mosaic: Vec<f32>,
}

impl GradientMaps {
    /// Resize for a frame, reusing capacity (no allocation when the size does not grow).
    pub fn reset(&mut self, width: usize, height: usize) {
        self.width = width;
        self.height = height;
        self.magnitude.resize(width * height, 0);
        self.bins.resize(width * height, 0);
    }
}

/// What the stage produced for one frame (besides the maps).
#[derive(Debug, Clone, PartialEq)]
pub struct StageOutput {
    /// Detections, highest score first.
    pub detections: Vec<Detection>,
    /// Mosaic SIFT keypoints, strongest first; `None` when the stage does not compute them.
    pub keypoints: Option<Vec<Keypoint>>,
    /// The keypoints' descriptors, in the same order; `None` unless the stage computes them
    /// (`keypoint_descriptors`).
    pub descriptors: Option<Vec<Descriptor>>,
    /// Mean gradient magnitude over the frame, normalised units.
    pub mean_magnitude: f32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::tone::{MosaicTone, ToneTables};
    use crate::raw::{Cfa, Levels};

    fn stage() -> Stage {
        Stage::new(
            StageSpec {
                detect: false,
                strip_rows: 4,
                ..StageSpec::default()
            },
            None,
        )
        .unwrap()
    }

    #[test]
    fn horizontal_ramp_hand_computed() {
        // I(x, y) = 10 x: every central difference I(x+1) - I(x-1) is 20.
        let px: Vec<u16> = (0..16 * 12).map(|i| (i % 16) as u16 * 10).collect();
        let f = RawFrame::from_u16(16, 12, px, Cfa::Rggb, 12, Levels::uniform(0, 4000)).unwrap();
        let mut maps = GradientMaps::default();
        let out = stage().compute(&f, &mut maps).unwrap();
        assert_eq!(maps.magnitude[5 * 16 + 5], 20);
        assert_eq!(maps.bins[5 * 16 + 5], 0);
        assert_eq!(maps.mag_shift, 0);
        // reflect-101: the border columns have zero x-difference
        assert_eq!(maps.magnitude[5 * 16], 0);
        let expect = 20.0 * 14.0 * 12.0 / 4000.0 / (16.0 * 12.0);
        assert!(
            (out.mean_magnitude - expect).abs() < 1e-6,
            "{}",
            out.mean_magnitude
        );
    }

    #[test]
    fn parallel_equals_serial_for_any_pool() {
        let px: Vec<u16> = (0..64 * 50u32)
            .map(|i| (i.wrapping_mul(2654435761) >> 20) as u16 & 4095)
            .collect();
        let f = RawFrame::from_u16(64, 50, px, Cfa::Grbg, 12, Levels::uniform(64, 4095)).unwrap();
        let serial = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let mut m1 = GradientMaps::default();
        let o1 = serial.install(|| stage().compute(&f, &mut m1)).unwrap();
        for threads in [2, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut m = GradientMaps::default();
            let o = pool.install(|| stage().compute(&f, &mut m)).unwrap();
            assert_eq!(m, m1);
            assert_eq!(o.mean_magnitude.to_bits(), o1.mean_magnitude.to_bits());
        }
    }

    /// Bright Gaussian blobs on a dark 12-bit RGGB mosaic (G planes brighter, as raw is).
    fn blobs(w: usize, h: usize) -> RawFrame {
        let centres = [
            (40.0, 36.0, 5.0),
            (100.0, 70.0, 8.0),
            (60.0, 100.0, 4.0),
            (130.0, 30.0, 6.0),
        ];
        let px: Vec<u16> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let v: f32 = centres
                    .iter()
                    .map(|&(cx, cy, s)| {
                        3000.0 * (-((x - cx).powi(2) + (y - cy).powi(2)) / (2.0 * s * s)).exp()
                    })
                    .sum();
                let gain = if (x as usize + y as usize) % 2 == 1 {
                    1.0
                } else {
                    0.6
                };
                (64.0 + v * gain).min(4095.0) as u16
            })
            .collect();
        RawFrame::from_u16(w, h, px, Cfa::Rggb, 12, Levels::uniform(64, 4095)).unwrap()
    }

    fn keypoint_stage() -> Stage {
        sift_stage(false, false)
    }

    /// A stage computing keypoints, with descriptors and doubled planes as asked.
    fn sift_stage(descriptors: bool, double: bool) -> Stage {
        Stage::new(
            StageSpec {
                detect: false,
                keypoints: true,
                keypoint_descriptors: descriptors,
                keypoints_double: double,
                strip_rows: 4,
                ..StageSpec::default()
            },
            None,
        )
        .unwrap()
    }

    /// `got` holds the same keypoints as `spec`'s library call on `f`, in any order.
    fn assert_library_keypoints(got: &[Keypoint], f: &RawFrame, spec: &SiftSpec) {
        let mut lib = keypoints_from_frame(f, spec).unwrap();
        let mut got = got.to_vec();
        let key = |p: &Keypoint| (p.x.to_bits(), p.y.to_bits(), p.size.to_bits(), p.angle.to_bits());
        lib.sort_by_key(key);
        got.sort_by_key(key);
        assert_eq!(got, lib);
    }

    #[test]
    fn keypoints_are_off_by_default_and_found_on_blobs_when_on() {
        let f = blobs(160, 128);
        let mut maps = GradientMaps::default();
        assert_eq!(stage().compute(&f, &mut maps).unwrap().keypoints, None);
        let k = keypoint_stage()
            .compute(&f, &mut maps)
            .unwrap()
            .keypoints
            .unwrap();
        assert!(!k.is_empty(), "no keypoints on four blobs");
        // Each blob centre is near some keypoint (full-resolution mosaic coordinates).
        for (cx, cy) in [(40.0f32, 36.0f32), (100.0, 70.0)] {
            let d = k
                .iter()
                .map(|p| ((p.x - cx).powi(2) + (p.y - cy).powi(2)).sqrt())
                .fold(f32::INFINITY, f32::min);
            assert!(d < 4.0, "no keypoint within 4 px of ({cx}, {cy}): nearest {d}");
        }
        // Strongest first.
        assert!(k.windows(2).all(|p| p[0].response.abs() >= p[1].response.abs()));
        // The same keypoints as the library call, reordered.
        assert_library_keypoints(&k, &f, &SiftOptions::mosaic().build().unwrap());
    }

    fn descriptor_stage(double: bool) -> Stage {
        sift_stage(true, double)
    }

    #[test]
    fn descriptors_follow_their_keypoints_in_the_stage_order() {
        let f = blobs(160, 128);
        let mut maps = GradientMaps::default();
        let plain = keypoint_stage().compute(&f, &mut maps).unwrap();
        assert_eq!(plain.descriptors, None, "descriptors are off unless asked for");
        let out = descriptor_stage(false).compute(&f, &mut maps).unwrap();
        let (k, d) = (out.keypoints.unwrap(), out.descriptors.unwrap());
        // The same keypoints in the same order as without descriptors, one descriptor each.
        assert_eq!(Some(&k), plain.keypoints.as_ref());
        assert_eq!(d.len(), k.len());
        // Each is the library's descriptor of that keypoint.
        let spec = SiftOptions::mosaic().build().unwrap();
        let lib = features_from_frame(&f, &spec).unwrap();
        for (kp, desc) in k.iter().zip(&d) {
            let i = lib
                .keypoints
                .iter()
                .position(|q| q == kp)
                .expect("library keypoint");
            assert_eq!(desc, &lib.descriptors[i]);
        }
        assert!(d.iter().all(|x| x.iter().any(|&v| v > 0)), "an empty descriptor");
        // Identical for any pool.
        let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
        let again = pool
            .install(|| descriptor_stage(false).compute(&f, &mut maps))
            .unwrap();
        assert_eq!((again.keypoints, again.descriptors), (Some(k), Some(d)));
        // Tiny frames give empty lists of both.
        let tiny = RawFrame::from_u16(8, 8, vec![100; 64], Cfa::Rggb, 12, Levels::uniform(0, 4095)).unwrap();
        let out = descriptor_stage(false).compute(&tiny, &mut maps).unwrap();
        assert_eq!(
            (out.keypoints, out.descriptors),
            (Some(Vec::new()), Some(Vec::new()))
        );
    }

    #[test]
    fn doubled_planes_add_the_finer_octave() {
        let f = blobs(160, 128);
        let mut maps = GradientMaps::default();
        let out = descriptor_stage(true).compute(&f, &mut maps).unwrap();
        let k = out.keypoints.unwrap();
        assert_eq!(out.descriptors.unwrap().len(), k.len());
        assert!(
            k.iter().any(|p| p.octave == -1),
            "no keypoint from the doubled octave"
        );
        let undoubled = keypoint_stage()
            .compute(&f, &mut maps)
            .unwrap()
            .keypoints
            .unwrap();
        assert!(undoubled.iter().all(|p| p.octave >= 0));
        let spec = SiftOptions::mosaic().build().unwrap().with_double_image(true);
        assert_library_keypoints(&k, &f, &spec);
    }

    #[test]
    fn odd_frames_give_the_detections_and_keypoints_of_their_even_part() {
        use crate::detect::{DetectorOptions, Domain, LinearModel, NmsMethod};
        let f = blobs(161, 129);
        let even = f.crop(0, 0, 160, 128).unwrap();
        let mut maps = GradientMaps::default();
        for stage in [keypoint_stage(), descriptor_stage(false)] {
            let odd = stage.compute(&f, &mut maps).unwrap();
            let want = stage.compute(&even, &mut maps).unwrap();
            assert!(!odd.keypoints.as_ref().unwrap().is_empty());
            assert_eq!(
                (odd.keypoints, odd.descriptors),
                (want.keypoints, want.descriptors)
            );
        }
        // Detection (a window fits the even part) and keypoints together.
        let v: Vec<f32> = (0..3781).map(|i| (i as f32 * 0.37).sin() * 0.05).collect();
        let m = LinearModel::from_opencv_vector(&v, Domain::Mosaic, "test").unwrap();
        let o = DetectorOptions {
            hit_threshold: -1e6,
            nms: NmsMethod::None,
            ..DetectorOptions::default()
        };
        let det = Arc::new(PeopleDetector::from(crate::detect::Detector::new(m, &o).unwrap()));
        let spec = StageSpec {
            keypoints: true,
            strip_rows: 4,
            ..StageSpec::default()
        };
        let stage = Stage::new(spec, Some(det)).unwrap();
        let odd = stage.compute(&f, &mut maps).unwrap();
        let want = stage.compute(&even, &mut maps).unwrap();
        assert!(!odd.detections.is_empty() && !odd.keypoints.as_ref().unwrap().is_empty());
        assert_eq!(
            (&odd.detections, &odd.keypoints),
            (&want.detections, &want.keypoints)
        );
        // Odd and too small for SIFT once even (15 -> 14): empty, not an error.
        let tiny = blobs(15, 33);
        let out = descriptor_stage(false).compute(&tiny, &mut maps).unwrap();
        assert_eq!(
            (out.keypoints, out.descriptors),
            (Some(Vec::new()), Some(Vec::new()))
        );
        let out = keypoint_stage().compute(&tiny, &mut maps).unwrap();
        assert_eq!((out.keypoints, out.descriptors), (Some(Vec::new()), None));
    }

    #[test]
    fn keypoints_are_identical_for_any_pool_and_empty_on_tiny_frames() {
        let f = blobs(160, 128);
        let serial = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let mut m = GradientMaps::default();
        let k1 = serial.install(|| keypoint_stage().compute(&f, &mut m)).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
        let k3 = pool.install(|| keypoint_stage().compute(&f, &mut m)).unwrap();
        assert_eq!(k1, k3);
        let tiny = RawFrame::from_u16(8, 8, vec![100; 64], Cfa::Rggb, 12, Levels::uniform(0, 4095)).unwrap();
        let out = keypoint_stage().compute(&tiny, &mut m).unwrap();
        assert_eq!(out.keypoints, Some(Vec::new()));
    }

    #[test]
    fn bad_spec_is_an_error() {
        let spec = StageSpec {
            strip_rows: 3,
            ..StageSpec::default()
        };
        assert!(Stage::new(spec, None).is_err());
        let spec = StageSpec {
            wb_gains: Gains::Fixed([1.0, f32::NAN, 1.0]),
            ..StageSpec::default()
        };
        assert!(Stage::new(spec, None).is_err());
    }

    #[test]
    fn the_detector_reads_the_mosaic_in_the_models_tone_with_the_configured_gains() {
        use crate::detect::{DetectorOptions, Domain, LinearModel, NmsMethod};
        use crate::features::hog::HogInput;
        use crate::raw::tone::{mosaic_from_raw, mosaic_from_raw_toned};
        // a textured 12-bit GBRG frame, dark like raw (values in the lower quarter)
        let (w, h) = (80, 144);
        let px: Vec<u16> = (0..(w * h) as u32)
            .map(|i| 64 + ((i.wrapping_mul(2654435761) >> 22) as u16 & 1023))
            .collect();
        let plain = RawFrame::from_u16(w, h, px, Cfa::Gbrg, 12, Levels::uniform(64, 4095)).unwrap();
        let with_gains = plain.clone().with_wb_gains([1.8, 1.0, 1.4]);
        let v: Vec<f32> = (0..3781).map(|i| (i as f32 * 0.37).sin() * 0.05).collect();
        let detector = |tone| {
            let mut m = LinearModel::from_opencv_vector(&v, Domain::Mosaic, "test").unwrap();
            m.mosaic_tone = tone;
            let o = DetectorOptions {
                hit_threshold: -1e6,
                nms: NmsMethod::None,
                ..DetectorOptions::default()
            };
            Arc::new(crate::detect::Detector::new(m, &o).unwrap())
        };
        let direct = |det: &crate::detect::Detector, m: Image<f32>| {
            let mut d = det.detect(&HogInput::Mosaic(m.view())).unwrap().0;
            d.sort_by(|a, b| b.score.total_cmp(&a.score));
            d
        };
        let srgb = detector(MosaicTone::Srgb);
        let run = |frame: &RawFrame, gains: Gains, det: &Arc<crate::detect::Detector>| {
            let spec = StageSpec {
                wb_gains: gains,
                strip_rows: 4,
                ..StageSpec::default()
            };
            Stage::new(spec, Some(Arc::new(PeopleDetector::from((**det).clone()))))
                .unwrap()
                .compute(frame, &mut GradientMaps::default())
        };
        let gw = crate::raw::levels::grey_world_gains(&plain);
        for (frame, gains, want) in [
            (&with_gains, Gains::Auto, [1.8, 1.0, 1.4]),
            (&plain, Gains::Auto, gw),
            (&with_gains, Gains::GreyWorld, gw),
            (&plain, Gains::Fixed([2.0, 1.0, 3.0]), [2.0, 1.0, 3.0]),
        ] {
            let got = run(frame, gains, &srgb).unwrap().detections;
            assert!(!got.is_empty());
            let want = direct(&srgb, mosaic_from_raw_toned(frame, MosaicTone::Srgb, want));
            assert_eq!(got, want, "{gains:?}");
        }
        // linear ignores the gains and reads the affine mosaic; the two tones score differently
        let linear = detector(MosaicTone::Linear);
        let lin = run(&with_gains, Gains::FromFile, &linear).unwrap().detections;
        assert_eq!(lin, direct(&linear, mosaic_from_raw(&with_gains)));
        let s = run(&with_gains, Gains::FromFile, &srgb).unwrap().detections;
        assert_ne!(lin[0].score, s[0].score);
        // `file` gains on a frame that has none: a clear error for this frame
        let e = run(&plain, Gains::FromFile, &srgb).unwrap_err();
        assert!(matches!(e, StageError::Gains(_)), "{e}");
        assert!(e.to_string().contains("white balance"), "{e}");
    }

    #[test]
    fn an_acf_detector_reads_the_toned_mosaic_with_the_frames_cfa() {
        use crate::detect::people::PeopleInput;
        use crate::raw::tone::mosaic_from_raw_toned;
        let det = Arc::new(crate::detect::people::every_window_acf());
        // an odd-sized textured 12-bit frame with its own gains: detections of the even part
        let (w, h) = (161, 257);
        let px: Vec<u16> = (0..(w * h) as u32)
            .map(|i| 64 + ((i.wrapping_mul(2654435761) >> 20) as u16 & 4095).min(4000))
            .collect();
        for cfa in [Cfa::Rggb, Cfa::Gbrg] {
            let f = RawFrame::from_u16(w, h, px.clone(), cfa, 12, Levels::uniform(64, 4095))
                .unwrap()
                .with_wb_gains([1.8, 1.0, 1.4]);
            let spec = StageSpec {
                strip_rows: 4,
                ..StageSpec::default()
            };
            let stage = Stage::new(spec, Some(det.clone())).unwrap();
            let got = stage
                .compute(&f, &mut GradientMaps::default())
                .unwrap()
                .detections;
            let even = f.crop(0, 0, 160, 256).unwrap();
            let m = mosaic_from_raw_toned(&even, MosaicTone::Srgb, [1.8, 1.0, 1.4]);
            let mut want = det
                .detect(&PeopleInput::Mosaic { image: m.view(), cfa })
                .unwrap()
                .0;
            want.sort_by(|a, b| b.score.total_cmp(&a.score));
            assert!(!got.is_empty(), "{cfa:?}: no boxes");
            assert_eq!(got, want, "{cfa:?}");
        }
    }

    #[test]
    fn tone_tables_are_kept_while_levels_and_gains_stay_and_rebuilt_when_they_change() {
        use crate::detect::{DetectorOptions, Domain, LinearModel};
        use crate::features::hog::HogInput;
        use crate::raw::tone::mosaic_from_raw_toned;
        let (w, h) = (64, 128);
        let px: Vec<u16> = (0..(w * h) as u32)
            .map(|i| 64 + ((i.wrapping_mul(2654435761) >> 22) as u16 & 1023))
            .collect();
        let a = RawFrame::from_u16(w, h, px.clone(), Cfa::Rggb, 12, Levels::uniform(64, 4095))
            .unwrap()
            .with_wb_gains([1.8, 1.0, 1.4]);
        let b = a.clone().with_wb_gains([2.2, 1.0, 1.3]);
        let c = RawFrame::from_u16(w, h, px, Cfa::Rggb, 12, Levels::uniform(80, 4095))
            .unwrap()
            .with_wb_gains([2.2, 1.0, 1.3]);
        let v: Vec<f32> = (0..3781).map(|i| (i as f32 * 0.37).sin() * 0.05).collect();
        let mut m = LinearModel::from_opencv_vector(&v, Domain::Mosaic, "test").unwrap();
        m.mosaic_tone = MosaicTone::Srgb;
        let o = DetectorOptions {
            hit_threshold: -1e6,
            ..DetectorOptions::default()
        };
        let det = Arc::new(crate::detect::Detector::new(m, &o).unwrap());
        let stage = Stage::new(
            StageSpec::default(),
            Some(Arc::new(PeopleDetector::from((*det).clone()))),
        )
        .unwrap();
        let mut maps = GradientMaps::default();
        let kept = || {
            stage
                .input
                .as_ref()
                .and_then(|i| i.kept_tables())
                .expect("tables after a frame")
        };
        let mut last: Option<Arc<ToneTables>> = None;
        for (frame, gains, rebuilt) in [
            (&a, [1.8, 1.0, 1.4], true),
            (&a, [1.8, 1.0, 1.4], false),
            (&b, [2.2, 1.0, 1.3], true), // new gains
            (&c, [2.2, 1.0, 1.3], true), // new black level
            (&c, [2.2, 1.0, 1.3], false),
        ] {
            let got = stage.compute(frame, &mut maps).unwrap().detections;
            let mut want = det
                .detect(&HogInput::Mosaic(
                    mosaic_from_raw_toned(frame, MosaicTone::Srgb, gains).view(),
                ))
                .unwrap()
                .0;
            want.sort_by(|a, b| b.score.total_cmp(&a.score));
            assert_eq!(got, want);
            let now = kept();
            assert!(now.built_for(frame, MosaicTone::Srgb, gains));
            if let Some(prev) = &last {
                assert_eq!(!Arc::ptr_eq(prev, &now), rebuilt);
            }
            last = Some(now);
        }
    }
}
