//! SIFT keypoints and descriptors on a grey image or **directly on a Bayer mosaic**.
//!
//! # Overview
//! Two variants share one implementation, parameterised by the distance between same-colour
//! samples (`step`):
//! - **Grey SIFT** ([`Domain::Grey`], `step = 1`) follows OpenCV's `SIFT_create()` defaults:
//!   the image is doubled (`firstOctave = -1`, assumed input blur `SIFT_INIT_SIGMA = 0.5`),
//!   3 layers per octave, `sigma = 1.6`, DoG extrema in 3x3x3, Lowe's quadratic refinement
//!   (5 iterations), contrast threshold `0.04 / 3` and edge threshold 10, a smoothed 36-bin
//!   orientation histogram with every peak >= 80 % of the maximum (parabolic interpolation) and the
//!   4x4x8 descriptor with trilinear interpolation, normalised, clipped at 0.2, renormalised,
//!   scaled by 512 and saturated to `u8` (OpenCV's stored values, also what its float descriptor
//!   holds).
//! - **Mosaic SIFT** ([`Domain::Mosaic`], `step = 2`, the paper's §III-B): the Gaussian pyramid
//!   is built on the 2x2 super-pixel structure: each colour plane (R, G1, G2, B) is blurred with
//!   the mosaic sigma halved (one plane pixel = two mosaic pixels), and the octave step takes the
//!   mean of each 2x2 block of same-colour samples, so every level is still a mosaic of the same
//!   pattern. **Where we differ from OpenCV's step** (every other sample): octave sample `i` sits
//!   at `(i + 0.5) 2^o - 0.5` of its plane, centred between the samples it averages, so the
//!   octave grids are symmetric under flips and quarter turns and the keypoints of a frame turned
//!   by 90° are the turned keypoints exactly ([`SiftOptions::centred_octaves`]; OpenCV's
//!   every-other-super-pixel step is still available). The DoG is taken on
//!   the mosaic, extrema are searched in a **5x5** (space) x 3 (scale) neighbourhood, refinement
//!   and the edge test use same-colour differences two pixels apart, and orientation and descriptor
//!   use the mosaic gradient `I(x+2) - I(x-2)` (the `[-1, 0, 1]` operator on same-colour taps).
//!   Keypoints come back in full-resolution mosaic pixel coordinates. Sigmas are in super-pixel
//!   units by default ([`SiftOptions::sigma_in_super_pixels`]): each colour plane is blurred
//!   exactly as grey SIFT blurs an image of the plane's size (sigma 1.6 plane pixels = 3.2 mosaic
//!   pixels at the first layer, or 1.6 mosaic pixels once the planes are doubled). With sigmas in
//!   mosaic pixels the finest layers are under-sampled on the half-resolution planes and the
//!   four planes' aliasing produces many unstable extrema (measured in `docs/sift.md`).
//!
//! Thresholds are defined on OpenCV's 8-bit range: input of any range is scaled by
//! `255 / max_value` first, so `contrastThreshold` means the same on u8, u16 (any bit depth) and
//! f32 data. The output is sorted by a total order (x, y, size, angle, response) with exact
//! duplicates removed, so it is identical for any thread count.
//!
//! ```
//! use mosaicd::features::sift::{detect_and_compute, SiftOptions};
//! use mosaicd::image::Image;
//! // A bright disc on a dark background gives a blob keypoint near its centre.
//! let img = Image::from_fn(64, 64, |x, y| {
//!     let d2 = (x as f32 - 32.0).powi(2) + (y as f32 - 30.0).powi(2);
//!     if d2 < 36.0 { 200u8 } else { 20u8 }
//! });
//! let spec = SiftOptions::grey().build().unwrap();
//! let f = detect_and_compute(img.view(), &spec).unwrap();
//! assert_eq!(f.keypoints.len(), f.descriptors.len());
//! assert!(f.keypoints.iter().any(|k| (k.x - 32.0).abs() < 1.5 && (k.y - 30.0).abs() < 1.5));
//! ```
//!
//! # The math
//! `L(x, y, sigma) = G(sigma) * I`, `D = L(k sigma) - L(sigma)` with `k = 2^(1/3)`; an extremum
//! `x0` of `D` is refined by `x^ = -H^-1 grad D` (3x3 Hessian in x, y, scale), kept if
//! `|D(x^)| * 3 >= 0.04` (values in [0, 1]) and `tr(H)^2 / det(H) < (r + 1)^2 / r`, `r = 10`.
//! For the mosaic, derivatives use taps `s = 2` apart and offsets are in plane units.
//!
//! # Deviations
//! - Float pyramid; OpenCV >= 4.8 stores it as 16-bit fixed point (`value * 256`) and uses a
//!   polynomial `atan2`, so a few near-threshold keypoints differ (see `docs/sift.md` for the
//!   measured agreement).
//! - Keypoints are sorted by (x, y, size, angle, response) and deduplicated on (x, y, size,
//!   angle), like OpenCV's `removeDuplicatedSorted`; `nfeatures` (retain best) is not offered.
//! - Mosaic SIFT: the neighbourhood compares all 74 neighbours of the 5x5x3 block (the paper's
//!   5x5), including other colours, which is sound because the DoG is band-pass and colour
//!   differences vary slowly.
//!
//! # References
//! D. G. Lowe, "Distinctive image features from scale-invariant keypoints", IJCV 2004.
//! OpenCV `modules/features2d/src/sift.dispatch.cpp` and `sift.simd.hpp` (constants and
//! semantics). Zhou, Zhang, Gao, Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern
//! Images", §III-B and §IV-B.5.

mod buffers;
mod descriptor;
mod detect;
mod kernels;
pub mod matching;
mod scale_space;
mod spec;

use rayon::prelude::*;

pub use descriptor::DESCRIPTOR_LEN;
pub use spec::{Domain, Keypoint, SiftError, SiftOptions, SiftSpec, MIN_SIZE};

use crate::image::{Image, ImageView};
use crate::raw::{RawFrame, RawView};

/// Keypoints with their descriptors (same order).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SiftFeatures {
    /// Keypoints, sorted by (x, y, size, angle, response).
    pub keypoints: Vec<Keypoint>,
    /// 128-byte descriptors, one per keypoint.
    pub descriptors: Vec<[u8; DESCRIPTOR_LEN]>,
}

/// Check the size of a `w` x `h` input for `spec`.
fn check_size(w: usize, h: usize, spec: &SiftSpec) -> Result<(), SiftError> {
    if w < MIN_SIZE || h < MIN_SIZE {
        return Err(SiftError::TooSmall {
            width: w,
            height: h,
            min: MIN_SIZE,
        });
    }
    if spec.o.domain == Domain::Mosaic && !(w.is_multiple_of(2) && h.is_multiple_of(2)) {
        return Err(SiftError::OddSize { width: w, height: h });
    }
    Ok(())
}

/// Scale from the input range to OpenCV's 0..255 (`255 / max_value`).
fn input_scale(spec: &SiftSpec) -> f32 {
    (detect::INTENSITY_RANGE as f64 / spec.o.max_value) as f32
}

/// Check the size and copy the input into a pooled f32 image on OpenCV's 0..255 scale (rows in
/// parallel).
fn prepare<T: Copy + Into<f32> + Sync>(src: ImageView<T>, spec: &SiftSpec) -> Result<Image<f32>, SiftError> {
    let (w, h) = (src.width(), src.height());
    check_size(w, h, spec)?;
    let scale = input_scale(spec);
    let mut img = buffers::take(w, h);
    img.as_mut_slice()
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, out)| {
            for (o, &v) in out.iter_mut().zip(src.row(y)) {
                *o = v.into() * scale;
            }
        });
    Ok(img)
}

/// [`prepare`] of [`normalised_mosaic_from_frame`] in one pass into a pooled image: the same
/// operations per pixel (normalise, clamp, then scale), so the same values.
fn prepare_frame(frame: &RawFrame, spec: &SiftSpec) -> Result<Image<f32>, SiftError> {
    let (w, h) = (frame.width(), frame.height());
    check_size(w, h, spec)?;
    let mut img = buffers::take(w, h);
    fill_normalised(frame, input_scale(spec), &mut img);
    Ok(img)
}

/// Fill `out` (the frame's size) with `((v - black(x, y)) / (white - black(x, y))).clamp(0, 1)`,
/// multiplied by `scale` unless `scale` is `None`; rows in parallel.
fn fill_normalised(frame: &RawFrame, scale: impl Into<Option<f32>>, out: &mut Image<f32>) {
    let scale = scale.into();
    let lv = frame.levels();
    let white = lv.white as f32;
    let tile: [(f32, f32); 4] = std::array::from_fn(|i| {
        let b = frame.black_at(i % 2, i / 2) as f32;
        (b, 1.0 / (white - b).max(1.0))
    });
    // Each row alternates two (black, 1 / range) pairs.
    fn fill<T: Copy + Into<f32> + Sync>(
        src: ImageView<'_, T>,
        tile: &[(f32, f32); 4],
        scale: Option<f32>,
        out: &mut Image<f32>,
    ) {
        let w = out.width();
        out.as_mut_slice()
            .par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                let t = &tile[(y % 2) * 2..(y % 2) * 2 + 2];
                for (x, (o, &v)) in row.iter_mut().zip(src.row(y)).enumerate() {
                    let (b, inv) = t[x % 2];
                    let n = ((v.into() - b) * inv).clamp(0.0, 1.0);
                    *o = match scale {
                        Some(s) => n * s,
                        None => n,
                    };
                }
            });
    }
    match frame.view() {
        RawView::U8(v) => fill(v, &tile, scale, out),
        RawView::U16(v) => fill(v, &tile, scale, out),
    }
}

fn sorted_candidates(pyr: &detect::Pyramid, spec: &SiftSpec) -> Vec<detect::Candidate> {
    let mut c = detect::find_scale_space_extrema(pyr, spec);
    let key = |a: &detect::Candidate| [a.kp.x, a.kp.y, a.kp.size, a.kp.angle, a.kp.response];
    c.sort_by(|a, b| {
        key(a)
            .iter()
            .zip(key(b).iter())
            .map(|(p, q)| p.total_cmp(q))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    c.dedup_by(|b, a| {
        a.kp.x == b.kp.x && a.kp.y == b.kp.y && a.kp.size == b.kp.size && a.kp.angle == b.kp.angle
    });
    c
}

/// Detect keypoints and compute their descriptors. `src` holds grey values or a mosaic (per
/// `spec.domain()`) with full scale `spec.max_value()`.
pub fn detect_and_compute<T: Copy + Into<f32> + Sync>(
    src: ImageView<T>,
    spec: &SiftSpec,
) -> Result<SiftFeatures, SiftError> {
    let t0 = std::time::Instant::now();
    let img = prepare(src, spec)?;
    compute_prepared(img, spec, t0)
}

/// Keypoints and descriptors of the prepared (pooled, 0..255) image `img`; `t0` is when the
/// call started (for the stage times).
fn compute_prepared(
    img: Image<f32>,
    spec: &SiftSpec,
    t0: std::time::Instant,
) -> Result<SiftFeatures, SiftError> {
    let pyr = detect::build_pyramid(&img, spec);
    buffers::give(img);
    let pyr = pyr?;
    let t1 = std::time::Instant::now();
    let cands = sorted_candidates(&pyr, spec);
    let t2 = std::time::Instant::now();
    let s = spec.step();
    let path = crate::kernels::isa();
    let descriptors = cands
        .par_iter()
        .map_init(detect::GradScratch::default, |sc, c| {
            descriptor::descriptor(&pyr.gauss[c.o][c.layer], c, s, path, sc)
        })
        .collect();
    tracing::debug!(
        pyramid_s = (t1 - t0).as_secs_f64(),
        extrema_s = (t2 - t1).as_secs_f64(),
        descriptors_s = t2.elapsed().as_secs_f64(),
        keypoints = cands.len(),
        "sift stages"
    );
    Ok(SiftFeatures {
        keypoints: cands.into_iter().map(|c| c.kp).collect(),
        descriptors,
    })
}

/// Detect keypoints only (no descriptors).
pub fn detect<T: Copy + Into<f32> + Sync>(
    src: ImageView<T>,
    spec: &SiftSpec,
) -> Result<Vec<Keypoint>, SiftError> {
    detect_prepared(prepare(src, spec)?, spec)
}

/// Keypoints of the prepared (pooled, 0..255) image `img`.
fn detect_prepared(img: Image<f32>, spec: &SiftSpec) -> Result<Vec<Keypoint>, SiftError> {
    let pyr = detect::build_pyramid(&img, spec);
    buffers::give(img);
    let pyr = pyr?;
    Ok(sorted_candidates(&pyr, spec).into_iter().map(|c| c.kp).collect())
}

/// Gaussian blur of one plane with OpenCV's float kernel for `sigma` (`BORDER_REFLECT_101`);
/// used by the evaluation to blur test images.
pub fn blur_plane(src: &Image<f32>, sigma: f64) -> Result<Image<f32>, SiftError> {
    let mut out = Image::new(0, 0);
    scale_space::blur_step(src, sigma, 1, &mut out)?;
    Ok(out)
}

/// The spec `spec` for a frame's normalised mosaic: domain mosaic, full scale 1.
fn frame_spec(spec: &SiftSpec) -> SiftSpec {
    let mut spec = *spec;
    spec.o.domain = Domain::Mosaic;
    spec.o.max_value = 1.0;
    spec
}

/// Mosaic keypoints of a raw frame, for the daemon: black level subtracted per tile position,
/// scaled by the white level, then mosaic SIFT with `spec`'s parameters (its domain and
/// `max_value` are overridden: the frame is always a mosaic normalised to full scale). Equals
/// [`detect`] of [`normalised_mosaic_from_frame`], without the intermediate image.
pub fn keypoints_from_frame(frame: &RawFrame, spec: &SiftSpec) -> Result<Vec<Keypoint>, SiftError> {
    let spec = frame_spec(spec);
    detect_prepared(prepare_frame(frame, &spec)?, &spec)
}

/// Mosaic keypoints and descriptors of a raw frame, normalised as [`keypoints_from_frame`]:
/// equals [`detect_and_compute`] of [`normalised_mosaic_from_frame`] with `max_value` 1, but
/// normalises straight into the pyramid's (recycled) input image in one parallel pass.
pub fn features_from_frame(frame: &RawFrame, spec: &SiftSpec) -> Result<SiftFeatures, SiftError> {
    let t0 = std::time::Instant::now();
    let spec = frame_spec(spec);
    compute_prepared(prepare_frame(frame, &spec)?, &spec, t0)
}

/// The frame's mosaic as f32 on [0, 1]: `(v - black(x, y)) / (white - black(x, y))`, clamped.
pub fn normalised_mosaic_from_frame(frame: &RawFrame) -> Image<f32> {
    let mut out = Image::new(frame.width(), frame.height());
    fill_normalised(frame, None, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blobs(w: usize, h: usize) -> Image<u8> {
        Image::from_fn(w, h, |x, y| {
            let (fx, fy) = (x as f32, y as f32);
            let v = 90.0 + 60.0 * (fx * 0.21).sin() * (fy * 0.17).cos() + 40.0 * ((fx + fy) * 0.05).sin();
            v.clamp(0.0, 255.0) as u8
        })
    }

    #[test]
    fn options_are_validated() {
        let mut o = SiftOptions::grey();
        o.sigma = -1.0;
        assert!(matches!(
            o.build(),
            Err(SiftError::InvalidOption { name: "sigma", .. })
        ));
        let mut o = SiftOptions::mosaic();
        o.n_octave_layers = 0;
        assert!(matches!(
            o.build(),
            Err(SiftError::InvalidOption {
                name: "n_octave_layers",
                ..
            })
        ));
        assert!(SiftSpec::grey().with_max_value(0.0).is_err());
    }

    #[test]
    fn tiny_and_odd_inputs_are_refused() {
        let img = Image::<u8>::new(10, 40);
        assert!(matches!(
            detect(img.view(), &SiftSpec::grey()),
            Err(SiftError::TooSmall { .. })
        ));
        let img = Image::<u8>::new(33, 40);
        assert!(matches!(
            detect(img.view(), &SiftSpec::mosaic()),
            Err(SiftError::OddSize { .. })
        ));
    }

    #[test]
    fn flat_images_give_nothing() {
        for v in [0u16, 4095, 65535] {
            let img = Image::filled(64, 48, v);
            let spec = SiftSpec::grey().with_max_value(65535.0).unwrap();
            assert!(detect_and_compute(img.view(), &spec)
                .unwrap()
                .keypoints
                .is_empty());
            let spec = SiftSpec::mosaic().with_max_value(65535.0).unwrap();
            assert!(detect_and_compute(img.view(), &spec)
                .unwrap()
                .keypoints
                .is_empty());
        }
    }

    #[test]
    fn u16_scaled_input_equals_u8_input() {
        let a = blobs(96, 80);
        let b = a.map(|v| v as u16 * 257);
        let fa = detect_and_compute(a.view(), &SiftSpec::grey()).unwrap();
        let spec = SiftSpec::grey().with_max_value(65535.0).unwrap();
        let fb = detect_and_compute(b.view(), &spec).unwrap();
        assert!(!fa.keypoints.is_empty());
        assert_eq!(fa.keypoints.len(), fb.keypoints.len());
        for (p, q) in fa.keypoints.iter().zip(&fb.keypoints) {
            assert!((p.x - q.x).abs() < 1e-3 && (p.y - q.y).abs() < 1e-3);
        }
    }

    #[test]
    fn parallel_equals_serial() {
        let img = blobs(128, 96);
        for spec in [SiftSpec::grey(), SiftSpec::mosaic()] {
            let a = detect_and_compute(img.view(), &spec).unwrap();
            let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
            let b = pool.install(|| detect_and_compute(img.view(), &spec).unwrap());
            assert_eq!(a, b);
            assert!(!a.keypoints.is_empty());
        }
    }

    #[test]
    fn frame_functions_equal_the_normalised_mosaic_path() {
        let img = blobs(128, 96);
        let data: Vec<u16> = img.as_slice().iter().map(|&v| v as u16 * 13 + 40).collect();
        let levels = crate::raw::Levels::uniform(40, 3400);
        let frame = RawFrame::from_u16(128, 96, data, crate::raw::Cfa::Grbg, 12, levels).unwrap();
        let spec = SiftSpec::mosaic().with_max_value(1.0).unwrap();
        let want = detect_and_compute(normalised_mosaic_from_frame(&frame).view(), &spec).unwrap();
        assert!(!want.keypoints.is_empty());
        assert_eq!(features_from_frame(&frame, &SiftSpec::mosaic()).unwrap(), want);
        assert_eq!(keypoints_from_frame(&frame, &spec).unwrap(), want.keypoints);
    }

    #[test]
    fn descriptors_are_normalised() {
        let img = blobs(128, 96);
        let f = detect_and_compute(img.view(), &SiftSpec::grey()).unwrap();
        for d in &f.descriptors {
            let n: f32 = d.iter().map(|&v| (v as f32).powi(2)).sum::<f32>().sqrt();
            // 512 before saturation; clipping at 0.2 * 512 = 102 keeps every entry in u8.
            assert!((n - 512.0).abs() < 8.0, "{n}");
        }
    }
}
