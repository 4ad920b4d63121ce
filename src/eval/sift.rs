//! SIFT repeatability on Kodak, grey SIFT vs mosaic SIFT (paper §IV-B.5, eqs. 25–28, Fig. 12).
//!
//! For each image, each transform (Gaussian blur, scaling, rotation) and each level, features of
//! the original and of the transformed image are matched (nearest neighbour, Lowe ratio 0.8,
//! mutual); a match is correct when the ground-truth transform maps the first keypoint within
//! `t = 3` pixels of the second. With `n1`, `n2` the keypoints of each image that fall inside the
//! other image under the ground truth,
//!
//! `repeatability = correct matches / min(n1, n2)`.
//!
//! **Interior repeatability** (reported beside it, not instead): the same ratio counting only
//! keypoints whose whole descriptor window lies in the common region, i.e. whose distance to the
//! boundary of the part of the scene both images show is at least the descriptor radius
//! [`DESCRIPTOR_RADIUS_PER_SIZE`] `× size` (OpenCV's `3σ · √2 · (4 + 1) / 2` with `σ = size / 2`),
//! and correct matches between two such keypoints. A keypoint nearer the boundary is described
//! partly from content the other image does not have (black bands of a rotation, a cropped
//! border), so whether it matches depends on its size relative to that boundary as much as on the
//! detector. Mosaic keypoints are coarser than grey SIFT's (no doubled octave; the smallest sigma
//! is 3.2 mosaic pixels), so more of them sit within a descriptor radius of the boundary: this
//! separates that share from the detector's own repeatability (docs/sift.md).
//!
//! The grey path is OpenCV-equivalent SIFT on `grey = 0.299 R + 0.587 G + 0.114 B` (rounded, as
//! `cv2.cvtColor`), transformed in the grey domain. The mosaic path samples an RGGB mosaic from the
//! same RGB image and transforms it **in the mosaic domain**, as the paper does: blur and resize
//! per colour plane (super-pixel), rotation of the R, G1, G2 and B sub-images separately, then
//! re-interleaving. Ground truth is the transform in input-pixel coordinates (half-pixel centres
//! for the resize, rotation about the image centre); the per-plane versions differ from it by less
//! than a pixel, well inside `t`.
//!
//! ```
//! use mosaicd::eval::{Transform, ground_truth};
//! let h = ground_truth(Transform::Scale(2.0), 100, 50);
//! let (x, y) = mosaicd::features::sift::matching::apply(&h, (10.0, 10.0));
//! assert!((x - 20.5).abs() < 1e-9 && (y - 20.5).abs() < 1e-9);
//! ```

use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;

use crate::features::sift::matching::{apply, match_descriptors, Match, LOWE_RATIO};
use crate::features::sift::{detect_and_compute, SiftError, SiftFeatures, SiftSpec};
use crate::image::Image;
use crate::isp::grey::grey_f32;

/// Correctness threshold on the reprojection error, pixels (the paper's `t`).
pub const MATCH_THRESHOLD_PX: f64 = 3.0;

/// Descriptor window radius in units of keypoint `size`: OpenCV's
/// `SIFT_DESCR_SCL_FCTR · σ · √2 · (SIFT_DESCR_WIDTH + 1) / 2` with `σ = size / 2`, i.e.
/// `3 · √2 · 5 / 4`.
pub(crate) const DESCRIPTOR_RADIUS_PER_SIZE: f64 = 3.0 * std::f64::consts::SQRT_2 * 5.0 / 4.0;

/// A transform applied to the test image.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Transform {
    /// Gaussian blur with this sigma (input pixels).
    Blur(f64),
    /// Resize by this factor (sizes rounded to even).
    Scale(f64),
    /// Rotation by this angle in degrees about the image centre (same canvas, black outside).
    Rotate(f64),
}

impl Transform {
    /// Family name: `blur`, `scale` or `rotation`.
    pub fn family(&self) -> &'static str {
        match self {
            Transform::Blur(_) => "blur",
            Transform::Scale(_) => "scale",
            Transform::Rotate(_) => "rotation",
        }
    }

    /// The level value (sigma, factor or degrees).
    pub fn level(&self) -> f64 {
        match *self {
            Transform::Blur(v) | Transform::Scale(v) | Transform::Rotate(v) => v,
        }
    }
}

/// The default levels: blur sigma 1–4, scale 0.5–2, rotation 15–90°.
pub fn default_transforms() -> Vec<Transform> {
    let mut t: Vec<Transform> = [1.0, 2.0, 3.0, 4.0].into_iter().map(Transform::Blur).collect();
    t.extend([0.5, 0.75, 1.25, 1.5, 2.0].into_iter().map(Transform::Scale));
    t.extend(
        [15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
            .into_iter()
            .map(Transform::Rotate),
    );
    t
}

/// Output size of `t` applied to a `w` x `h` image.
pub(crate) fn output_size(t: Transform, w: usize, h: usize) -> (usize, usize) {
    match t {
        Transform::Scale(f) => (
            even((w as f64 * f).round() as usize),
            even((h as f64 * f).round() as usize),
        ),
        _ => (w, h),
    }
}

fn even(v: usize) -> usize {
    (v / 2 * 2).max(2)
}

/// Ground-truth map from original to transformed input-pixel coordinates (row-vector 3x3).
pub fn ground_truth(t: Transform, w: usize, h: usize) -> [[f64; 3]; 3] {
    match t {
        Transform::Blur(_) => [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        Transform::Scale(_) => {
            let (ow, oh) = output_size(t, w, h);
            let (fx, fy) = (ow as f64 / w as f64, oh as f64 / h as f64);
            // x' = (x + 0.5) fx - 0.5
            [
                [fx, 0.0, 0.0],
                [0.0, fy, 0.0],
                [0.5 * fx - 0.5, 0.5 * fy - 0.5, 1.0],
            ]
        }
        Transform::Rotate(deg) => {
            let (s, c) = deg.to_radians().sin_cos();
            let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
            // x' = c (x - cx) - s (y - cy) + cx ; y' = s (x - cx) + c (y - cy) + cy
            [
                [c, s, 0.0],
                [-s, c, 0.0],
                [cx - c * cx + s * cy, cy - s * cx - c * cy, 1.0],
            ]
        }
    }
}

/// Bilinear sample of `src` at (x, y); `None` outside the image (constant border).
fn bilinear(src: &Image<f32>, x: f64, y: f64, replicate: bool) -> Option<f32> {
    let (w, h) = (src.width() as f64, src.height() as f64);
    let (x, y) = if replicate {
        (x.clamp(0.0, w - 1.0), y.clamp(0.0, h - 1.0))
    } else {
        if x < -0.5 || y < -0.5 || x > w - 0.5 || y > h - 0.5 {
            return None;
        }
        (x.clamp(0.0, w - 1.0), y.clamp(0.0, h - 1.0))
    };
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(src.width() - 1), (y0 + 1).min(src.height() - 1));
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let top = src.get(x0, y0) * (1.0 - fx) + src.get(x1, y0) * fx;
    let bot = src.get(x0, y1) * (1.0 - fx) + src.get(x1, y1) * fx;
    Some(top * (1.0 - fy) + bot * fy)
}

/// Apply `t` to one plane (grey image or one colour plane) of size `w` x `h` into `ow` x `oh`.
fn transform_plane(src: &Image<f32>, t: Transform, ow: usize, oh: usize) -> Image<f32> {
    let (w, h) = src.dimensions();
    match t {
        Transform::Blur(s) => crate::features::sift::blur_plane(src, s).unwrap_or_else(|_| src.clone()),
        Transform::Scale(_) => {
            let (fx, fy) = (w as f64 / ow as f64, h as f64 / oh as f64);
            Image::from_fn(ow, oh, |x, y| {
                bilinear(
                    src,
                    (x as f64 + 0.5) * fx - 0.5,
                    (y as f64 + 0.5) * fy - 0.5,
                    true,
                )
                .unwrap_or(0.0)
            })
        }
        Transform::Rotate(deg) => {
            let (s, c) = deg.to_radians().sin_cos();
            let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
            Image::from_fn(ow, oh, |x, y| {
                let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                // Inverse rotation.
                let sx = c * dx + s * dy + cx;
                let sy = -s * dx + c * dy + cy;
                bilinear(src, sx, sy, false).unwrap_or(0.0)
            })
        }
    }
}

/// Transform a grey image.
pub fn grey_transformed(src: &Image<f32>, t: Transform) -> Image<f32> {
    let (ow, oh) = output_size(t, src.width(), src.height());
    transform_plane(src, t, ow, oh)
}

/// How the mosaic path resamples a colour plane under a geometric transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
pub enum PlaneWarp {
    /// Each plane is warped as a small image about its own centre (the paper's wording); the
    /// 2x2 phase offsets are not transformed, so the colour planes end up misregistered by up to
    /// about a pixel (for a 90° rotation, exactly one pixel, but the planes are permuted without
    /// interpolation).
    OwnCentre,
    /// Each plane is still resampled on its own (no colour mixing), but at the exact positions
    /// of its pixels in mosaic coordinates: output pixel (x, y) of colour phase (px, py) samples
    /// its plane at `((X - px) / 2, (Y - py) / 2)`, (X, Y) the inverse-transformed position.
    PhaseCorrect,
    /// [`PlaneWarp::OwnCentre`] for every transform except a rotation by a multiple of 90°, which
    /// is done exactly: each plane is rotated about the *image* centre and re-interleaved at the
    /// 2x2 phase its samples land on. On an even-sized mosaic that is a lossless permutation of
    /// the pixels, the same permutation that rotates the grey image, and the CFA pattern turns
    /// with the image (what a raw frame rotated by 90° looks like). The default.
    #[default]
    Lattice,
}

impl PlaneWarp {
    /// Name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            PlaneWarp::OwnCentre => "own-centre",
            PlaneWarp::PhaseCorrect => "phase-correct",
            PlaneWarp::Lattice => "lattice",
        }
    }
}

/// Whether `deg` is a multiple of 90°.
fn quarter_turn(deg: f64) -> bool {
    let q = deg / 90.0;
    (q - q.round()).abs() < 1e-9
}

/// Transform a mosaic in the mosaic domain: each of the four colour planes is transformed
/// separately (blur sigma halved: plane pixels are two mosaic pixels) and re-interleaved.
pub fn mosaic_transformed(src: &Image<f32>, t: Transform, warp: PlaneWarp) -> Image<f32> {
    let (w, h) = src.dimensions();
    let (ow, oh) = output_size(t, w, h);
    let planes: Vec<Image<f32>> = (0..4)
        .map(|i| {
            let (px, py) = (i % 2, i / 2);
            Image::from_fn(w / 2, h / 2, |x, y| src.get(2 * x + px, 2 * y + py))
        })
        .collect();
    match (t, warp) {
        (Transform::Rotate(deg), PlaneWarp::Lattice) if quarter_turn(deg) => {
            // Integer source pixel of every output pixel (exact up to rounding of sin/cos).
            let hinv = invert_affine(&ground_truth(t, w, h));
            Image::from_fn(ow, oh, |x, y| {
                let (sx, sy) = apply(&hinv, (x as f64, y as f64));
                let (sx, sy) = (sx.round(), sy.round());
                if sx < 0.0 || sy < 0.0 || sx >= w as f64 || sy >= h as f64 {
                    0.0
                } else {
                    src.get(sx as usize, sy as usize)
                }
            })
        }
        (Transform::Blur(_), _) | (_, PlaneWarp::OwnCentre | PlaneWarp::Lattice) => {
            let t_plane = match t {
                Transform::Blur(s0) => Transform::Blur(s0 / 2.0),
                other => other,
            };
            let out: Vec<Image<f32>> = planes
                .iter()
                .map(|p| transform_plane(p, t_plane, ow / 2, oh / 2))
                .collect();
            Image::from_fn(ow, oh, |x, y| out[(y % 2) * 2 + (x % 2)].get(x / 2, y / 2))
        }
        (_, PlaneWarp::PhaseCorrect) => {
            let hinv = invert_affine(&ground_truth(t, w, h));
            let replicate = matches!(t, Transform::Scale(_));
            Image::from_fn(ow, oh, |x, y| {
                let (px, py) = (x % 2, y % 2);
                let (sx, sy) = apply(&hinv, (x as f64, y as f64));
                let (u, v) = ((sx - px as f64) / 2.0, (sy - py as f64) / 2.0);
                bilinear(&planes[py * 2 + px], u, v, replicate).unwrap_or(0.0)
            })
        }
    }
}

/// `round(0.299 R + 0.587 G + 0.114 B)` per pixel (OpenCV `COLOR_RGB2GRAY` weights): the float
/// form of [`grey_from_rgb_u8`](crate::isp::grey_from_rgb_u8), rounded.
pub fn grey_from_rgb8(rgb: &Image<[u8; 3]>) -> Image<f32> {
    rgb.map(|p| grey_f32(p.map(f32::from)).round())
}

/// RGGB mosaic sampled from an RGB image (cropped to even size), as f32:
/// [`crate::raw::mosaic_from_rgb`] on the even crop.
pub fn rggb_mosaic_from_rgb8(rgb: &Image<[u8; 3]>) -> Image<f32> {
    let (w, h) = (rgb.width() / 2 * 2, rgb.height() / 2 * 2);
    let even = rgb
        .view()
        .crop(0, 0, w, h)
        .expect("an even crop lies inside the image");
    crate::raw::mosaic_from_rgb(&even, crate::raw::Cfa::Rggb).map(f32::from)
}

/// Repeatability and match statistics of one image pair.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PairScore {
    /// Keypoints of image 1 that map inside image 2.
    pub n1: usize,
    /// Keypoints of image 2 that map back inside image 1.
    pub n2: usize,
    /// Descriptor matches (ratio + mutual).
    pub matches: usize,
    /// Matches within `t` of the ground truth.
    pub correct: usize,
    /// `correct / min(n1, n2)` (0 when either is 0).
    pub repeatability: f64,
    /// The same counts restricted to keypoints whose descriptor window lies in the common region
    /// (see the module docs).
    pub interior: InteriorScore,
}

/// Repeatability counted on keypoints at least a descriptor radius inside the common region.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct InteriorScore {
    /// Interior keypoints of image 1.
    pub n1: usize,
    /// Interior keypoints of image 2.
    pub n2: usize,
    /// Correct matches between two interior keypoints.
    pub correct: usize,
    /// `correct / min(n1, n2)` (0 when either is 0).
    pub repeatability: f64,
}

fn invert_affine(h: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    // Row-vector affine: [x' y'] = [x y] M + t, M = [[a, b], [c, d]].
    let (a, b, c, d) = (h[0][0], h[0][1], h[1][0], h[1][1]);
    let det = a * d - b * c;
    let (ia, ib, ic, id) = (d / det, -b / det, -c / det, a / det);
    let (tx, ty) = (h[2][0], h[2][1]);
    [
        [ia, ib, 0.0],
        [ic, id, 0.0],
        [-(tx * ia + ty * ic), -(tx * ib + ty * id), 1.0],
    ]
}

/// Score a pair: features of the original (`size1`) and of the transformed image (`size2`), and
/// the ground truth `h` (affine, row vectors). Also returns the descriptor matches.
pub fn score_pair(
    f1: &SiftFeatures,
    size1: (usize, usize),
    f2: &SiftFeatures,
    size2: (usize, usize),
    h: &[[f64; 3]; 3],
    t: f64,
) -> (PairScore, Vec<Match>) {
    // Distance to the border of a `w x h` image (negative outside).
    let margin =
        |(x, y): (f64, f64), (w, h): (usize, usize)| x.min(y).min(w as f64 - 1.0 - x).min(h as f64 - 1.0 - y);
    let hinv = invert_affine(h);
    // Linear scale of the ground truth (the transforms are similarities up to size rounding).
    let gain = (h[0][0] * h[1][1] - h[0][1] * h[1][0]).abs().sqrt();
    // For the keypoints of one image (`own` size, mapped by `map` into the `other` image, whose
    // pixels are `g` of its own): how many land inside the other image, and which are interior.
    // A keypoint's distance to the boundary of the common region is the smaller of its distances
    // to each image's border (the region is the intersection of two convex sets), the other
    // image's measured through the map.
    let classify = |f: &SiftFeatures, map: &[[f64; 3]; 3], own, other, g: f64| {
        let mut landed = 0;
        let interior: Vec<bool> = f
            .keypoints
            .iter()
            .map(|k| {
                let p = (k.x as f64, k.y as f64);
                let there = margin(apply(map, p), other);
                landed += usize::from(there >= 0.0);
                margin(p, own).min(there / g) >= DESCRIPTOR_RADIUS_PER_SIZE * k.size as f64
            })
            .collect();
        (landed, interior)
    };
    let (n1, interior1) = classify(f1, h, size1, size2, gain);
    let (n2, interior2) = classify(f2, &hinv, size2, size1, 1.0 / gain);
    let matches = match_descriptors(&f1.descriptors, &f2.descriptors, LOWE_RATIO, true);
    let is_correct = |m: &Match| {
        let (a, b) = (&f1.keypoints[m.query], &f2.keypoints[m.train]);
        let (u, v) = apply(h, (a.x as f64, a.y as f64));
        (u - b.x as f64).hypot(v - b.y as f64) <= t
    };
    let correct = matches.iter().filter(|m| is_correct(m)).count();
    let ratio = |c: usize, a: usize, b: usize| {
        let denom = a.min(b);
        if denom == 0 {
            0.0
        } else {
            c as f64 / denom as f64
        }
    };
    let (i1, i2) = (
        interior1.iter().filter(|&&b| b).count(),
        interior2.iter().filter(|&&b| b).count(),
    );
    let ic = matches
        .iter()
        .filter(|m| interior1[m.query] && interior2[m.train] && is_correct(m))
        .count();
    (
        PairScore {
            n1,
            n2,
            matches: matches.len(),
            correct,
            repeatability: ratio(correct, n1, n2),
            interior: InteriorScore {
                n1: i1,
                n2: i2,
                correct: ic,
                repeatability: ratio(ic, i1, i2),
            },
        },
        matches,
    )
}

/// One row of the evaluation: an image, a transform level, both methods.
#[derive(Debug, Clone, Serialize)]
pub struct EvalRow {
    /// Image file stem.
    pub image: String,
    /// Transform family.
    pub family: &'static str,
    /// Transform level.
    pub level: f64,
    /// Grey SIFT score.
    pub grey: PairScore,
    /// Mosaic SIFT score.
    pub mosaic: PairScore,
}

/// Errors of the SIFT evaluation.
#[derive(Debug, thiserror::Error)]
pub enum EvalSiftError {
    /// An image could not be read.
    #[error("cannot read image {path}: {source}")]
    Image {
        /// Path.
        path: String,
        /// Cause (the decoder's, or the frame-size limit's).
        source: image::ImageError,
    },
    /// SIFT failed.
    #[error(transparent)]
    Sift(#[from] SiftError),
}

/// Evaluate one RGB image under every transform in `transforms`.
pub(crate) fn evaluate_image(
    path: &Path,
    transforms: &[Transform],
    grey_spec: &SiftSpec,
    mosaic_spec: &SiftSpec,
    warp: PlaneWarp,
) -> Result<Vec<EvalRow>, EvalSiftError> {
    let rgb = crate::image_io::load_rgb8(path).map_err(|e| EvalSiftError::Image {
        path: path.display().to_string(),
        source: e.source,
    })?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let grey = grey_from_rgb8(&rgb);
    let mosaic = rggb_mosaic_from_rgb8(&rgb);
    let g1 = detect_and_compute(grey.view(), grey_spec)?;
    let m1 = detect_and_compute(mosaic.view(), mosaic_spec)?;
    transforms
        .iter()
        .map(|&t| {
            let g2img = grey_transformed(&grey, t);
            let m2img = mosaic_transformed(&mosaic, t, warp);
            let g2 = detect_and_compute(g2img.view(), grey_spec)?;
            let m2 = detect_and_compute(m2img.view(), mosaic_spec)?;
            let hg = ground_truth(t, grey.width(), grey.height());
            let hm = ground_truth(t, mosaic.width(), mosaic.height());
            let (grey_score, _) = score_pair(
                &g1,
                grey.dimensions(),
                &g2,
                g2img.dimensions(),
                &hg,
                MATCH_THRESHOLD_PX,
            );
            let (mosaic_score, _) = score_pair(
                &m1,
                mosaic.dimensions(),
                &m2,
                m2img.dimensions(),
                &hm,
                MATCH_THRESHOLD_PX,
            );
            Ok(EvalRow {
                image: name.clone(),
                family: t.family(),
                level: t.level(),
                grey: grey_score,
                mosaic: mosaic_score,
            })
        })
        .collect()
}

/// Per (family, level) summary over images.
#[derive(Debug, Clone, Serialize)]
pub struct LevelSummary {
    /// Transform family.
    pub family: &'static str,
    /// Level.
    pub level: f64,
    /// Images.
    pub n: usize,
    /// Mean grey repeatability.
    pub grey_mean: f64,
    /// Mean mosaic repeatability.
    pub mosaic_mean: f64,
    /// Grey quartiles (25, 50, 75 %).
    pub grey_q: [f64; 3],
    /// Mosaic quartiles (25, 50, 75 %).
    pub mosaic_q: [f64; 3],
    /// Mean grey interior repeatability.
    pub grey_interior_mean: f64,
    /// Mean mosaic interior repeatability.
    pub mosaic_interior_mean: f64,
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let pos = q * (sorted.len() - 1) as f64;
    let (i, f) = (pos.floor() as usize, pos - pos.floor());
    if i + 1 < sorted.len() {
        sorted[i] * (1.0 - f) + sorted[i + 1] * f
    } else {
        sorted[i]
    }
}

/// Summarise rows per transform level (in the order levels first appear).
pub fn summarise(rows: &[EvalRow]) -> Vec<LevelSummary> {
    let mut keys: Vec<(&'static str, f64)> = Vec::new();
    for r in rows {
        if !keys.iter().any(|&(f, l)| f == r.family && l == r.level) {
            keys.push((r.family, r.level));
        }
    }
    keys.into_iter()
        .map(|(family, level)| {
            let sel: Vec<&EvalRow> = rows
                .iter()
                .filter(|r| r.family == family && r.level == level)
                .collect();
            let mut g: Vec<f64> = sel.iter().map(|r| r.grey.repeatability).collect();
            let mut m: Vec<f64> = sel.iter().map(|r| r.mosaic.repeatability).collect();
            g.sort_by(f64::total_cmp);
            m.sort_by(f64::total_cmp);
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
            LevelSummary {
                family,
                level,
                n: sel.len(),
                grey_mean: mean(&g),
                mosaic_mean: mean(&m),
                grey_q: [quantile(&g, 0.25), quantile(&g, 0.5), quantile(&g, 0.75)],
                mosaic_q: [quantile(&m, 0.25), quantile(&m, 0.5), quantile(&m, 0.75)],
                grey_interior_mean: mean(
                    &sel.iter()
                        .map(|r| r.grey.interior.repeatability)
                        .collect::<Vec<_>>(),
                ),
                mosaic_interior_mean: mean(
                    &sel.iter()
                        .map(|r| r.mosaic.interior.repeatability)
                        .collect::<Vec<_>>(),
                ),
            }
        })
        .collect()
}

/// Evaluate many images (in parallel over images; rows in input order).
pub fn evaluate(
    paths: &[std::path::PathBuf],
    transforms: &[Transform],
    grey_spec: &SiftSpec,
    mosaic_spec: &SiftSpec,
    warp: PlaneWarp,
) -> Result<Vec<EvalRow>, EvalSiftError> {
    let per: Vec<Result<Vec<EvalRow>, EvalSiftError>> = paths
        .par_iter()
        .map(|p| evaluate_image(p, transforms, grey_spec, mosaic_spec, warp))
        .collect();
    let mut rows = Vec::new();
    for r in per {
        rows.extend(r?);
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rggb_mosaic_is_cropped_to_even_size_and_samples_r_g_b() {
        let rgb = Image::from_fn(5, 3, |x, y| {
            [(10 * x + y) as u8, 100 + (10 * x + y) as u8, 200 + y as u8]
        });
        let m = rggb_mosaic_from_rgb8(&rgb);
        assert_eq!(m.dimensions(), (4, 2));
        assert_eq!(m.row(0), &[0.0, 110.0, 20.0, 130.0]);
        assert_eq!(m.row(1), &[101.0, 201.0, 121.0, 201.0]);
        assert_eq!(rggb_mosaic_from_rgb8(&Image::new(1, 1)).dimensions(), (0, 0));
    }

    #[test]
    fn ground_truth_rotation_keeps_the_centre() {
        let h = ground_truth(Transform::Rotate(37.0), 101, 51);
        let (x, y) = apply(&h, (50.0, 25.0));
        assert!((x - 50.0).abs() < 1e-9 && (y - 25.0).abs() < 1e-9);
        let hi = invert_affine(&h);
        let (u, v) = apply(&hi, apply(&h, (3.0, 7.0)));
        assert!((u - 3.0).abs() < 1e-9 && (v - 7.0).abs() < 1e-9);
        // 90 degrees: (cx + 10, cy) goes to (cx, cy + 10) (y down).
        let h = ground_truth(Transform::Rotate(90.0), 101, 51);
        let (x, y) = apply(&h, (60.0, 25.0));
        assert!((x - 50.0).abs() < 1e-9 && (y - 35.0).abs() < 1e-9);
    }

    #[test]
    fn rotation_of_the_image_agrees_with_the_ground_truth() {
        let mut img = Image::<f32>::new(41, 31);
        img.set(30, 15, 1.0);
        let r = grey_transformed(&img, Transform::Rotate(90.0));
        let (x, y) = apply(&ground_truth(Transform::Rotate(90.0), 41, 31), (30.0, 15.0));
        assert!((r.get(x.round() as usize, y.round() as usize) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn mosaic_transform_keeps_the_pattern() {
        let m = Image::from_fn(40, 30, |x, y| (10 * (1 + (x % 2) + 2 * (y % 2))) as f32);
        for t in [Transform::Blur(2.0), Transform::Scale(0.5), Transform::Scale(1.5)] {
            for warp in [PlaneWarp::OwnCentre, PlaneWarp::PhaseCorrect, PlaneWarp::Lattice] {
                let o = mosaic_transformed(&m, t, warp);
                for y in 0..o.height() {
                    for x in 0..o.width() {
                        assert!((o.get(x, y) - m.get(x % 2, y % 2)).abs() < 1e-3);
                    }
                }
            }
        }
    }

    #[test]
    fn lattice_quarter_turns_permute_the_mosaic_like_the_grey_image() {
        let m = Image::from_fn(40, 30, |x, y| (x + 100 * y) as f32);
        for deg in [90.0, 180.0, 270.0, -90.0] {
            let t = Transform::Rotate(deg);
            let lattice = mosaic_transformed(&m, t, PlaneWarp::Lattice);
            let grey = grey_transformed(&m, t);
            let hinv = invert_affine(&ground_truth(t, 40, 30));
            for y in 0..30 {
                for x in 0..40 {
                    let (sx, sy) = apply(&hinv, (x as f64, y as f64));
                    let inside = sx > -0.5 && sy > -0.5 && sx < 39.5 && sy < 29.5;
                    let v = lattice.get(x, y);
                    if inside {
                        // Exactly one source pixel, whose colour phase may differ from (x, y)'s.
                        let (sx, sy) = (sx.round() as usize, sy.round() as usize);
                        assert_eq!(v, m.get(sx, sy), "{deg}° at ({x}, {y})");
                        assert!((grey.get(x, y) - v).abs() < 1e-2, "{deg}° at ({x}, {y})");
                    } else {
                        assert_eq!(v, 0.0);
                    }
                }
            }
        }
        // Other angles are the paper's per-plane recipe.
        let t = Transform::Rotate(30.0);
        assert_eq!(
            mosaic_transformed(&m, t, PlaneWarp::Lattice).as_slice(),
            mosaic_transformed(&m, t, PlaneWarp::OwnCentre).as_slice()
        );
    }

    fn features(points: &[(f32, f32, f32)]) -> SiftFeatures {
        use crate::features::sift::Keypoint;
        SiftFeatures {
            keypoints: points
                .iter()
                .map(|&(x, y, size)| Keypoint {
                    x,
                    y,
                    size,
                    angle: 0.0,
                    response: 0.1,
                    octave: 0,
                    layer: 1,
                })
                .collect(),
            // Distinct descriptors, so keypoint i matches keypoint i of the other set.
            descriptors: (0..points.len())
                .map(|i| std::array::from_fn(|k| if k == i { 200 } else { 0 }))
                .collect(),
        }
    }

    #[test]
    fn interior_keeps_only_keypoints_whose_descriptor_window_is_in_the_common_region() {
        // Size 2: descriptor radius ≈ 10.6 px.
        let pts = [
            (50.0, 50.0, 2.0),
            (5.0, 50.0, 2.0),
            (50.0, 90.0, 2.0),
            (50.0, 50.0, 12.0),
        ];
        let f = features(&pts);
        let id = ground_truth(Transform::Blur(1.0), 100, 100);
        let (s, _) = score_pair(&f, (100, 100), &f, (100, 100), &id, 3.0);
        assert_eq!((s.n1, s.n2, s.correct), (4, 4, 4));
        assert_eq!((s.interior.n1, s.interior.n2, s.interior.correct), (1, 1, 1));
        assert_eq!(s.interior.repeatability, 1.0);
        // A quarter turn of a 200x100 image keeps only its central 100x100: the common region is
        // x in [50, 149] of image 1: (60, 50) is 10 px inside it, (100, 50) 49 px.
        let t = Transform::Rotate(90.0);
        let h = ground_truth(t, 200, 100);
        let f1 = features(&[(60.0, 50.0, 2.0), (100.0, 50.0, 1.0), (100.0, 50.0, 5.0)]);
        let moved: Vec<(f32, f32, f32)> = f1
            .keypoints
            .iter()
            .map(|k| {
                let (x, y) = apply(&h, (k.x as f64, k.y as f64));
                (x as f32, y as f32, k.size)
            })
            .collect();
        let f2 = features(&moved);
        let (s, _) = score_pair(&f1, (200, 100), &f2, (200, 100), &h, 3.0);
        assert_eq!((s.n1, s.n2, s.correct), (3, 3, 3));
        // Radii 10.6, 5.3 and 26.5 px against depths 10, 49 and 49.
        assert_eq!((s.interior.n1, s.interior.n2, s.interior.correct), (2, 2, 2));
    }

    #[test]
    fn quantiles_by_hand() {
        let v = [0.0, 1.0, 2.0, 3.0, 4.0];
        assert_eq!(quantile(&v, 0.25), 1.0);
        assert_eq!(quantile(&v, 0.5), 2.0);
        assert_eq!(quantile(&v, 1.0), 4.0);
    }
}
