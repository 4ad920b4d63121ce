//! Mosaic gradients (paper §III-A): central difference `[-1, 0, 1]` and 3x3 Sobel applied directly
//! to a Bayer mosaic (or to a grey image — it is the same code), gradient magnitude and orientation,
//! and the fused raw → (magnitude, orientation bin) kernel the daemon uses.
//!
//! # Overview
//!
//! On a Bayer mosaic the pixels at `x - 1` and `x + 1` (and at `y - 1`, `y + 1`) always have the same
//! colour filter, so a central difference or a Sobel difference only ever subtracts pixels of one
//! colour. Under colour-difference constancy (G − R and G − B vary slowly) the gradient of whichever
//! channel sits at a pixel approximates the scene gradient, which is why HOG and SIFT can run on the
//! mosaic with no demosaicing (the paper's eqs. 5–6 and 13–20).
//!
//! Two APIs:
//!
//! * **Reference, float**: [`gradient_xy`] (any `u8`/`u16`/`f32` view → `gx`, `gy` in `f32`),
//!   [`magnitude`], [`orientation`], and the allocating [`gradients_from_image`]. These match
//!   `cv2.filter2D(src, CV_32F, [-1, 0, 1])` / `cv2.Sobel(src, CV_32F, dx, dy, ksize)` (tests
//!   `tests/gradient_oracle.rs`) for the OpenCV-compatible borders.
//! * **Fused, integer**: [`mag_bin`] (a `u8`/`u16` mosaic → `u16` magnitude + `u8` orientation bin,
//!   one pass over the rows, rayon over row strips, no allocation), [`mag_bin_from_raw`] (allocating,
//!   from a [`RawFrame`](crate::raw::RawFrame)). [`mag_bin_scalar`] is its straightforward scalar oracle; every kernel path
//!   ([`mag_bin_with_isa`]: the baseline build, AVX2, AVX-512, NEON, dispatched through
//!   [`crate::kernels`]) equals it bit for bit (tests loop over [`Isa::available`](crate::kernels::Isa::available)).
//!
//! ```
//! use mosaicd::features::gradient::{gradients_from_image, mag_bin_from_raw, AngleRange, GradientSpec, MagBinOptions, MagBinSpec};
//! use mosaicd::image::Image;
//! use mosaicd::raw::{Cfa, Levels, RawFrame};
//! // A horizontal ramp: every central difference is 2 * 10 = 20.
//! let ramp = Image::from_fn(8, 4, |x, _| (100 + 10 * x) as u16);
//! let g = gradients_from_image(&ramp.view(), &GradientSpec::default()).unwrap();
//! assert_eq!(g.gx.get(3, 2), 20.0);
//! assert_eq!(g.gy.get(3, 2), 0.0);
//! // The fused kernel on a raw frame: magnitude 20, orientation bin 0 (0°) of 9 over 0–180°.
//! let f = RawFrame::from_u16(8, 4, ramp.into_vec(), Cfa::Rggb, 12, Levels::uniform(64, 4095)).unwrap();
//! let spec = MagBinSpec::new(MagBinOptions::default()).unwrap();
//! let mb = mag_bin_from_raw(&f, &spec).unwrap();
//! assert_eq!((mb.mag.get(3, 2), mb.bin.get(3, 2)), (20, 0));
//! ```
//!
//! # Math
//!
//! Central difference (OpenCV `Sobel` with `ksize = 1`, `filter2D` with `[-1, 0, 1]`, no 1/2 factor):
//! `gx = I(x+1, y) − I(x−1, y)`, `gy = I(x, y+1) − I(x, y−1)`.
//! Sobel: `gx = [1 2 1]ᵀ ⊗ [−1 0 1]`, `gy = [−1 0 1]ᵀ ⊗ [1 2 1]` (gain 4 on a ramp). Magnitude
//! `√(gx² + gy²)`; orientation `atan2(gy, gx)` in degrees, signed in `[0, 360)` (SIFT) or unsigned
//! folded into `[0, 180)` (HOG). An orientation bin is `⌊θ / (range / bins)⌋`.
//!
//! **Black level** cancels: both taps of every difference have the same colour, hence the same
//! tile position and the same black level (even with a per-position black level), so the fused
//! kernel reads raw values and never subtracts the black level. Pixels below black (noise) are not
//! clamped: clamping would bend the difference and is what a normalised image would show instead.
//!
//! **Fused magnitude is `u16`**, not `f32`: half the store bandwidth, exact integers that HOG votes
//! with, and enough range. It is `round(√(gx² + gy²) · 2^−s)` evaluated in f32 (error ≤ 0.5 + 2⁻¹⁰
//! relative to exact), where the shift `s` ([`MagBinSpec::mag_shift`]) is the smallest that fits the
//! largest possible magnitude `√2 · gain · (2^bits − 1)` in a `u16`: `s = 0` up to 15-bit central and
//! 13-bit Sobel, 1 for 16-bit central and 14-bit Sobel.
//!
//! **Fused orientation bin** without `atan2`: fold the vector into the upper half-plane, then into
//! `[0°, 90°]` by the mirror symmetry of the bin edges `k·180°/n`, and count the edges below the angle
//! with cross products `cos(e)·gy − sin(e)·|gx| ≥ 0` — `⌊n/2⌋` multiply-compares per pixel, eight
//! lanes at a time. A zero vector gets bin 0. The result equals `⌊atan2 / width⌋` except for vectors
//! within float rounding (≈1e-5°) of an edge (test `bins_agree_with_atan2`).
//!
//! # Borders ([`Border`])
//!
//! * [`Border::Reflect101`] (default; OpenCV's `BORDER_REFLECT_101`/`BORDER_DEFAULT`): `I(−1) = I(1)`.
//!   **Colour is preserved** on a mosaic — reflect-101 mirrors about the edge pixel, so `x = −1` maps
//!   to `x = 1`, which has the colour `x = −1` would have (same parity) — but the difference across
//!   the border row/column is zero (`gx(0, y) = I(1) − I(1) = 0`).
//! * [`Border::Replicate`] (OpenCV `BORDER_REPLICATE`): `I(−1) = I(0)`. On a mosaic this **mixes
//!   colours** at the border (`x = 0` has the other colour), so `gx(0, y) = I(1) − I(0)` is a
//!   colour difference, not a gradient. Offered for OpenCV parity and to show the artefact.
//! * [`Border::MosaicExtrapolate`] (mosaic-aware): the missing pixel is linearly extrapolated within
//!   its own colour plane, `I(−1) = 2·I(1) − I(3)` (steps of 2 keep the colour), so
//!   `gx(0, y) = I(3) − I(1)`: a one-sided same-colour difference with the same spacing. A linear
//!   ramp gives the same gradient at the border as inside. Needs at least 4x4 pixels.
//!
//! # Deviations from the paper / OpenCV
//!
//! * The paper does not specify borders; we default to OpenCV's for parity.
//! * OpenCV's `phase` uses a fast atan approximation (≈0.3° worst case in older releases); our float
//!   [`orientation`] uses `f32::atan2`; the oracle tests state the tolerance.
//! * Fused magnitude is rounded to an integer and may be scaled down by `2^s` for deep bit depths.
//!
//! # References
//!
//! W. Zhou, L. Zhang, S. Gao, X. Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern
//! Images", §III-A. OpenCV `imgproc/src/deriv.cpp` (`Sobel`, `getDerivKernels`), `core/mathfuncs`
//! (`magnitude`, `phase`). N. Dalal, B. Triggs, "Histograms of Oriented Gradients", CVPR 2005 (the
//! `[-1, 0, 1]` mask and unsigned 9-bin orientation).

use std::ops::{Add, Sub};

use rayon::prelude::*;
use thiserror::Error;

use crate::image::{Image, ImageView, ImageViewMut};

mod mag_bin;

pub use mag_bin::{
    mag_bin, mag_bin_from_raw, mag_bin_scalar, mag_bin_with_isa, mag_of, MagBin, MagBinOptions, MagBinSpec,
};

/// Rows per rayon task (one strip). 16 rows of a 4000-pixel 16-bit frame is 128 KiB of input.
pub const STRIP_ROWS: usize = 16;
/// Pixels per inner chunk of the fused kernel (stack arrays; fits L1 comfortably).
const CHUNK: usize = 256;
/// HOG's default number of unsigned orientation bins (Dalal & Triggs).
pub const DEFAULT_BINS: usize = 9;
/// Most bins an `u8` bin index can address.
pub const MAX_BINS: usize = 255;

/// Errors from the gradient operators.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum GradientError {
    /// The image is smaller than the border mode needs.
    #[error("image {width}x{height} too small for border {border:?}: needs at least {min}x{min}")]
    TooSmall {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Border mode.
        border: Border,
        /// Minimum width and height.
        min: usize,
    },
    /// An output does not have the input's size.
    #[error("{what} is {got_w}x{got_h} but the input is {want_w}x{want_h}")]
    SizeMismatch {
        /// Which output.
        what: &'static str,
        /// Output width.
        got_w: usize,
        /// Output height.
        got_h: usize,
        /// Input width.
        want_w: usize,
        /// Input height.
        want_h: usize,
    },
    /// Unsupported number of orientation bins.
    #[error("{bins} orientation bins over {range:?}: need 1..=255 (and an even number for signed 0–360°)")]
    Bins {
        /// Requested bins.
        bins: usize,
        /// Requested range.
        range: AngleRange,
    },
    /// Bit depth outside 1..=16.
    #[error("bit depth {bit_depth} outside 1..=16")]
    BitDepth {
        /// Requested bit depth.
        bit_depth: u8,
    },
}

/// The derivative operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Operator {
    /// `[-1, 0, 1]` (paper eqs. 5–6; HOG's mask).
    #[default]
    Central,
    /// 3x3 Sobel, `[1 2 1]ᵀ ⊗ [-1 0 1]` (gain 4).
    Sobel,
}

impl Operator {
    /// Response of the operator to a unit ramp (`I = x`): 2 for central, 8 for Sobel.
    pub fn ramp_gain(self) -> u32 {
        match self {
            Operator::Central => 2,
            Operator::Sobel => 8,
        }
    }

    /// Largest |gx| relative to the largest pixel value: 1 for central, 4 for Sobel.
    pub fn max_gain(self) -> u32 {
        match self {
            Operator::Central => 1,
            Operator::Sobel => 4,
        }
    }
}

impl std::str::FromStr for Operator {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "central" => Ok(Operator::Central),
            "sobel" => Ok(Operator::Sobel),
            _ => Err(format!("unknown operator {s:?}: expected central or sobel")),
        }
    }
}

/// How pixels outside the image are made up (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Border {
    /// OpenCV's default `BORDER_REFLECT_101`: `I(−1) = I(1)`. Keeps the colour; zero across the edge.
    #[default]
    Reflect101,
    /// OpenCV's `BORDER_REPLICATE`: `I(−1) = I(0)`. Mixes colours on a mosaic.
    Replicate,
    /// Same-colour linear extrapolation `I(−1) = 2·I(1) − I(3)`. Keeps the colour and the gradient.
    MosaicExtrapolate,
}

impl Border {
    /// Smallest width and height the mode supports.
    pub fn min_size(self) -> usize {
        match self {
            Border::Reflect101 => 2,
            Border::Replicate => 1,
            Border::MosaicExtrapolate => 4,
        }
    }
}

/// Orientation range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AngleRange {
    /// `[0°, 180°)`: a direction and its opposite are the same (HOG).
    #[default]
    Unsigned,
    /// `[0°, 360°)` (SIFT).
    Signed,
}

impl AngleRange {
    /// 180 or 360.
    pub fn degrees(self) -> f32 {
        match self {
            AngleRange::Unsigned => 180.0,
            AngleRange::Signed => 360.0,
        }
    }
}

/// Options of the float operators; already valid, so it is its own spec.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GradientSpec {
    /// Derivative operator.
    pub operator: Operator,
    /// Border mode.
    pub border: Border,
    /// Run row strips on the current rayon pool (`false`: on the calling thread).
    pub serial: bool,
}

/// Input pixel types: `u8`, `u16`, `f32`.
pub trait Sample: Copy + Send + Sync + 'static {
    /// As f32 (exact for u8/u16).
    fn to_f32(self) -> f32;
}

impl Sample for u8 {
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
}
impl Sample for u16 {
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
}
impl Sample for f32 {
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
}

/// Integer raw pixel types the fused kernel reads: `u8`, `u16`.
pub trait RawSample: Sample {
    /// As i32.
    fn to_i32(self) -> i32;
}
impl RawSample for u8 {
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self as i32
    }
}
impl RawSample for u16 {
    #[inline(always)]
    fn to_i32(self) -> i32 {
        self as i32
    }
}

fn check_size(w: usize, h: usize, border: Border) -> Result<(), GradientError> {
    let min = border.min_size();
    if w < min || h < min {
        return Err(GradientError::TooSmall {
            width: w,
            height: h,
            border,
            min,
        });
    }
    Ok(())
}

fn check_same(what: &'static str, got: (usize, usize), want: (usize, usize)) -> Result<(), GradientError> {
    if got != want {
        return Err(GradientError::SizeMismatch {
            what,
            got_w: got.0,
            got_h: got.1,
            want_w: want.0,
            want_h: want.1,
        });
    }
    Ok(())
}

/// The value at (x, y), which may lie one pixel outside the image, under `border`.
/// `get` reads an inside pixel. Requires the image to be at least `border.min_size()` square.
#[inline]
pub fn tap<V, F>(get: &F, w: usize, h: usize, border: Border, x: isize, y: isize) -> V
where
    V: Copy + Add<Output = V> + Sub<Output = V>,
    F: Fn(usize, usize) -> V,
{
    let (wi, hi) = (w as isize, h as isize);
    if x < 0 || x >= wi {
        return match border {
            Border::Reflect101 => tap(get, w, h, border, if x < 0 { -x } else { 2 * wi - 2 - x }, y),
            Border::Replicate => tap(get, w, h, border, x.clamp(0, wi - 1), y),
            Border::MosaicExtrapolate => {
                let (n1, n3) = if x < 0 { (x + 2, x + 4) } else { (x - 2, x - 4) };
                let a = tap(get, w, h, border, n1, y);
                let b = tap(get, w, h, border, n3, y);
                a + (a - b)
            }
        };
    }
    if y < 0 || y >= hi {
        return match border {
            Border::Reflect101 => tap(get, w, h, border, x, if y < 0 { -y } else { 2 * hi - 2 - y }),
            Border::Replicate => tap(get, w, h, border, x, y.clamp(0, hi - 1)),
            Border::MosaicExtrapolate => {
                let (n1, n3) = if y < 0 { (y + 2, y + 4) } else { (y - 2, y - 4) };
                let a = tap(get, w, h, border, x, n1);
                let b = tap(get, w, h, border, x, n3);
                a + (a - b)
            }
        };
    }
    get(x as usize, y as usize)
}

/// `(gx, gy)` at one pixel, through [`tap`] (so valid at the border). The scalar definition.
#[inline]
pub fn gradient_at<V, F>(
    get: &F,
    w: usize,
    h: usize,
    op: Operator,
    border: Border,
    x: usize,
    y: usize,
) -> (V, V)
where
    V: Copy + Add<Output = V> + Sub<Output = V>,
    F: Fn(usize, usize) -> V,
{
    let (x, y) = (x as isize, y as isize);
    let t = |dx: isize, dy: isize| tap(get, w, h, border, x + dx, y + dy);
    match op {
        Operator::Central => (t(1, 0) - t(-1, 0), t(0, 1) - t(0, -1)),
        Operator::Sobel => {
            let (a, b, c) = (t(1, -1) - t(-1, -1), t(1, 0) - t(-1, 0), t(1, 1) - t(-1, 1));
            let gx = a + b + b + c;
            let (d, e, f) = (t(-1, 1) - t(-1, -1), t(0, 1) - t(0, -1), t(1, 1) - t(1, -1));
            let gy = d + e + e + f;
            (gx, gy)
        }
    }
}

/// Run `f(y, row_a, row_b)` for every row of two equally tall outputs, in strips of [`STRIP_ROWS`],
/// on the current rayon pool unless `serial`.
fn for_each_row2<A: Send + Copy, B: Send + Copy>(
    a: &mut ImageViewMut<'_, A>,
    b: &mut ImageViewMut<'_, B>,
    serial: bool,
    f: impl Fn(usize, &mut [A], &mut [B]) + Sync,
) {
    let (w, h) = (a.width(), a.height());
    debug_assert_eq!((w, h), (b.width(), b.height()));
    if w == 0 || h == 0 {
        return;
    }
    let (sa, sb) = (a.stride(), b.stride());
    let strip = |(s, (ca, cb)): (usize, (&mut [A], &mut [B]))| {
        let y0 = s * STRIP_ROWS;
        for (i, y) in (y0..(y0 + STRIP_ROWS).min(h)).enumerate() {
            f(y, &mut ca[i * sa..i * sa + w], &mut cb[i * sb..i * sb + w]);
        }
    };
    let (da, db) = (a.as_mut_slice(), b.as_mut_slice());
    if serial {
        da.chunks_mut(sa * STRIP_ROWS)
            .zip(db.chunks_mut(sb * STRIP_ROWS))
            .enumerate()
            .for_each(strip);
    } else {
        da.par_chunks_mut(sa * STRIP_ROWS)
            .zip(db.par_chunks_mut(sb * STRIP_ROWS))
            .enumerate()
            .for_each(strip);
    }
}

/// `gx`, `gy` of `src` (a mosaic or a grey image) as f32. Matches `cv2.Sobel(src, CV_32F, 1, 0,
/// ksize)` / `(0, 1)` with `ksize` 1 (central) or 3 (Sobel) and the same border.
pub fn gradient_xy<T: Sample>(
    src: &ImageView<'_, T>,
    spec: &GradientSpec,
    gx: &mut ImageViewMut<'_, f32>,
    gy: &mut ImageViewMut<'_, f32>,
) -> Result<(), GradientError> {
    let (w, h) = (src.width(), src.height());
    check_size(w, h, spec.border)?;
    check_same("gx", (gx.width(), gx.height()), (w, h))?;
    check_same("gy", (gy.width(), gy.height()), (w, h))?;
    let get = |x: usize, y: usize| src.get(x, y).to_f32();
    let (op, border) = (spec.operator, spec.border);
    for_each_row2(gx, gy, spec.serial, |y, ox, oy| {
        let interior_row = y >= 1 && y + 1 < h;
        if !interior_row {
            for x in 0..w {
                (ox[x], oy[x]) = gradient_at(&get, w, h, op, border, x, y);
            }
            return;
        }
        let (rp, r0, rn) = (src.row(y - 1), src.row(y), src.row(y + 1));
        for x in [0, w - 1] {
            (ox[x], oy[x]) = gradient_at(&get, w, h, op, border, x, y);
        }
        for x in 1..w - 1 {
            let f = |r: &[T], i: usize| r[i].to_f32();
            match op {
                Operator::Central => {
                    ox[x] = f(r0, x + 1) - f(r0, x - 1);
                    oy[x] = f(rn, x) - f(rp, x);
                }
                Operator::Sobel => {
                    let b = f(r0, x + 1) - f(r0, x - 1);
                    ox[x] = (f(rp, x + 1) - f(rp, x - 1)) + b + b + (f(rn, x + 1) - f(rn, x - 1));
                    let e = f(rn, x) - f(rp, x);
                    oy[x] = (f(rn, x - 1) - f(rp, x - 1)) + e + e + (f(rn, x + 1) - f(rp, x + 1));
                }
            }
        }
    });
    Ok(())
}

/// `gx` and `gy` of an image, as f32.
#[derive(Debug, Clone, PartialEq)]
pub struct Gradients {
    /// Horizontal derivative.
    pub gx: Image<f32>,
    /// Vertical derivative.
    pub gy: Image<f32>,
}

impl Gradients {
    /// `√(gx² + gy²)`.
    pub fn magnitude(&self) -> Image<f32> {
        let mut m = Image::new(self.gx.width(), self.gx.height());
        magnitude(&self.gx.view(), &self.gy.view(), &mut m.view_mut()).expect("same size by construction");
        m
    }

    /// Orientation in degrees over `range`.
    pub fn orientation(&self, range: AngleRange) -> Image<f32> {
        let mut o = Image::new(self.gx.width(), self.gx.height());
        orientation(&self.gx.view(), &self.gy.view(), range, &mut o.view_mut())
            .expect("same size by construction");
        o
    }
}

/// Allocating wrapper of [`gradient_xy`].
pub fn gradients_from_image<T: Sample>(
    src: &ImageView<'_, T>,
    spec: &GradientSpec,
) -> Result<Gradients, GradientError> {
    let mut gx = Image::new(src.width(), src.height());
    let mut gy = Image::new(src.width(), src.height());
    gradient_xy(src, spec, &mut gx.view_mut(), &mut gy.view_mut())?;
    Ok(Gradients { gx, gy })
}

fn map2(
    a: &ImageView<'_, f32>,
    b: &ImageView<'_, f32>,
    dst: &mut ImageViewMut<'_, f32>,
    f: impl Fn(f32, f32) -> f32 + Sync,
) -> Result<(), GradientError> {
    let want = (a.width(), a.height());
    check_same("gy", (b.width(), b.height()), want)?;
    check_same("output", (dst.width(), dst.height()), want)?;
    let (w, h, s) = (dst.width(), dst.height(), dst.stride());
    if w == 0 || h == 0 {
        return Ok(());
    }
    dst.as_mut_slice()
        .par_chunks_mut(s * STRIP_ROWS)
        .enumerate()
        .for_each(|(k, chunk)| {
            let y0 = k * STRIP_ROWS;
            for (i, y) in (y0..(y0 + STRIP_ROWS).min(h)).enumerate() {
                for ((o, &p), &q) in chunk[i * s..i * s + w].iter_mut().zip(a.row(y)).zip(b.row(y)) {
                    *o = f(p, q);
                }
            }
        });
    Ok(())
}

/// Magnitude `√(gx² + gy²)` (as `cv2.magnitude`).
pub fn magnitude(
    gx: &ImageView<'_, f32>,
    gy: &ImageView<'_, f32>,
    dst: &mut ImageViewMut<'_, f32>,
) -> Result<(), GradientError> {
    map2(gx, gy, dst, |x, y| (x * x + y * y).sqrt())
}

/// Orientation of one gradient in degrees: `atan2(gy, gx)` in `[0, 360)` (signed) or folded into
/// `[0, 180)` (unsigned). A zero vector gives 0.
#[inline]
pub fn orientation_deg(gx: f32, gy: f32, range: AngleRange) -> f32 {
    let mut a = gy.atan2(gx).to_degrees();
    if a < 0.0 {
        a += 360.0;
    }
    let r = range.degrees();
    if a >= r {
        a -= r;
    }
    // Rounding can land exactly on the range end; fold it to 0.
    if a >= r {
        0.0
    } else {
        a
    }
}

/// Orientation in degrees (as `cv2.phase(gx, gy, angleInDegrees=True)`, folded for unsigned).
pub fn orientation(
    gx: &ImageView<'_, f32>,
    gy: &ImageView<'_, f32>,
    range: AngleRange,
    dst: &mut ImageViewMut<'_, f32>,
) -> Result<(), GradientError> {
    map2(gx, gy, dst, |x, y| orientation_deg(x, y, range))
}

/// A seeded synthetic raw mosaic with realistic content, for benchmarks and tests: smooth
/// illumination, a few dozen sharp-edged objects of random reflectance and colour, raw colour balance
/// (R and B about half as bright as G, as before white balance), Bayer-sampled as RGGB, with
/// signal-dependent noise, at `bits` bits (LSB-aligned in a `u16`). The same seed gives the same frame.
pub fn synthetic_mosaic(width: usize, height: usize, bits: u8, seed: u64) -> Image<u16> {
    use rand::{Rng, SeedableRng};
    /// Objects (rectangles and discs) scattered over the frame.
    const OBJECTS: usize = 48;
    /// Raw channel gains R, G, B relative to the scene (raw R and B are dimmer than G).
    const RAW_GAINS: [f32; 3] = [0.5, 1.0, 0.6];
    /// Noise standard deviation at full scale, as a fraction of full scale.
    const NOISE: f32 = 0.01;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let max = ((1u32 << bits.clamp(1, 16)) - 1) as f32;
    let (wf, hf) = (width.max(1) as f32, height.max(1) as f32);
    struct Obj {
        cx: f32,
        cy: f32,
        r: f32,
        disc: bool,
        rgb: [f32; 3],
    }
    let objs: Vec<Obj> = (0..OBJECTS)
        .map(|_| Obj {
            cx: rng.random_range(0.0..wf),
            cy: rng.random_range(0.0..hf),
            r: rng.random_range(0.02..0.15) * wf.min(hf),
            disc: rng.random_bool(0.5),
            rgb: [
                rng.random_range(0.05..0.9),
                rng.random_range(0.05..0.9),
                rng.random_range(0.05..0.9),
            ],
        })
        .collect();
    Image::from_fn(width, height, |x, y| {
        let (xf, yf) = (x as f32, y as f32);
        let light = 0.6 + 0.4 * ((xf / wf * 3.1).sin() * (yf / hf * 2.3).cos());
        let mut rgb = [0.35f32, 0.4, 0.3];
        for o in &objs {
            let (dx, dy) = (xf - o.cx, yf - o.cy);
            let inside = if o.disc {
                dx * dx + dy * dy < o.r * o.r
            } else {
                dx.abs() < o.r && dy.abs() < 0.6 * o.r
            };
            if inside {
                rgb = o.rgb;
            }
        }
        let c = match (x & 1, y & 1) {
            (0, 0) => 0,
            (1, 1) => 2,
            _ => 1,
        };
        let v = rgb[c] * RAW_GAINS[c] * light;
        let n: f32 = rng.random_range(-1.0..1.0) * NOISE * (v.max(0.0)).sqrt() * 1.7;
        ((v + n).clamp(0.0, 1.0) * max).round() as u16
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::Isa;
    use crate::raw::RawView;

    fn grad(img: &Image<f32>, op: Operator, border: Border) -> Gradients {
        let spec = GradientSpec {
            operator: op,
            border,
            serial: false,
        };
        gradients_from_image(&img.view(), &spec).unwrap()
    }

    #[test]
    fn hand_computed_central_and_sobel() {
        // 3x3 image, values chosen by hand:
        // 1 2 4
        // 3 5 9
        // 0 7 8
        let img = Image::from_vec(3, 3, vec![1.0, 2.0, 4.0, 3.0, 5.0, 9.0, 0.0, 7.0, 8.0]).unwrap();
        let g = grad(&img, Operator::Central, Border::Reflect101);
        assert_eq!(g.gx.get(1, 1), 9.0 - 3.0);
        assert_eq!(g.gy.get(1, 1), 7.0 - 2.0);
        // Reflect101 at the left border: I(-1) = I(1) so gx = 0; gy at (0,0): I(0,1) - I(0,-1)=I(0,1)
        assert_eq!(g.gx.get(0, 1), 0.0);
        assert_eq!(g.gy.get(0, 0), 0.0);
        let s = grad(&img, Operator::Sobel, Border::Reflect101);
        // gx = (4-1) + 2(9-3) + (8-0) = 3 + 12 + 8 = 23; gy = (0-1) + 2(7-2) + (8-4) = -1 + 10 + 4 = 13
        assert_eq!(s.gx.get(1, 1), 23.0);
        assert_eq!(s.gy.get(1, 1), 13.0);
        // Replicate: gx(0,1) = I(1,1) - I(0,1) = 5 - 3 = 2
        let r = grad(&img, Operator::Central, Border::Replicate);
        assert_eq!(r.gx.get(0, 1), 2.0);
        // Magnitude of (6, 5) is √61; orientation atan2(5, 6) = 39.8°.
        let m = g.magnitude();
        assert!((m.get(1, 1) - 61f32.sqrt()).abs() < 1e-6);
        let o = g.orientation(AngleRange::Signed);
        assert!((o.get(1, 1) - 39.805_57).abs() < 1e-3);
    }

    #[test]
    fn mosaic_extrapolate_keeps_colour_and_ramp() {
        // Ramp I = 3x + 5y: every mode gives gx = 6, gy = 10 inside; only MosaicExtrapolate at borders.
        let img = Image::from_fn(6, 5, |x, y| (3 * x + 5 * y) as f32);
        let g = grad(&img, Operator::Central, Border::MosaicExtrapolate);
        for y in 0..5 {
            for x in 0..6 {
                assert_eq!((g.gx.get(x, y), g.gy.get(x, y)), (6.0, 10.0), "at ({x}, {y})");
            }
        }
        let s = grad(&img, Operator::Sobel, Border::MosaicExtrapolate);
        assert!(s.gx.as_slice().iter().all(|&v| v == 24.0));
        assert!(s.gy.as_slice().iter().all(|&v| v == 40.0));
        // Colour: the virtual pixel x = -1 is built from x = 1 and x = 3 only (same colour).
        // Put a spike on x = 0 (other colour): gx at x = 0 must not see it.
        let mut spiky = img.clone();
        spiky.set(0, 2, 1000.0);
        let g2 = grad(&spiky, Operator::Central, Border::MosaicExtrapolate);
        assert_eq!(g2.gx.get(0, 2), 6.0);
        // Replicate does see it (colour mixing).
        let g3 = grad(&spiky, Operator::Central, Border::Replicate);
        assert_eq!(g3.gx.get(0, 2), 3.0 + 10.0 - 1000.0);
    }

    #[test]
    fn too_small_and_size_mismatch_are_errors() {
        let img = Image::<f32>::new(3, 3);
        let spec = GradientSpec {
            border: Border::MosaicExtrapolate,
            ..Default::default()
        };
        assert!(matches!(
            gradients_from_image(&img.view(), &spec),
            Err(GradientError::TooSmall { min: 4, .. })
        ));
        let mut gx = Image::new(3, 3);
        let mut gy = Image::new(2, 3);
        assert!(matches!(
            gradient_xy(
                &img.view(),
                &GradientSpec::default(),
                &mut gx.view_mut(),
                &mut gy.view_mut()
            ),
            Err(GradientError::SizeMismatch { what: "gy", .. })
        ));
        for (bins, range) in [
            (0, AngleRange::Unsigned),
            (256, AngleRange::Unsigned),
            (9, AngleRange::Signed),
        ] {
            assert!(MagBinSpec::new(MagBinOptions {
                bins,
                range,
                ..Default::default()
            })
            .is_err());
        }
    }

    #[test]
    fn mag_shift_fits_u16() {
        for op in [Operator::Central, Operator::Sobel] {
            let spec = MagBinSpec::new(MagBinOptions {
                operator: op,
                ..Default::default()
            })
            .unwrap();
            for bits in 1..=16u8 {
                let s = spec.mag_shift(bits);
                let g = (op.max_gain() * ((1u32 << bits) - 1)) as f32;
                assert!(mag_of(g, g, 1.0 / (1u32 << s) as f32) < u16::MAX || s == 0);
                if s > 0 {
                    // One less would overflow.
                    assert!((2f64.sqrt() * g as f64) / f64::from(1u32 << (s - 1)) + 0.5 >= 65536.0);
                }
            }
            assert_eq!(spec.mag_shift(8), 0);
            assert_eq!(spec.mag_shift(12), 0);
        }
        let sobel = MagBinSpec::new(MagBinOptions {
            operator: Operator::Sobel,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(sobel.mag_shift(14), 1);
    }

    #[test]
    fn synthetic_mosaic_is_seeded_and_in_range() {
        let a = synthetic_mosaic(64, 48, 12, 1);
        assert_eq!(a, synthetic_mosaic(64, 48, 12, 1));
        assert_ne!(a, synthetic_mosaic(64, 48, 12, 2));
        assert!(a.as_slice().iter().all(|&v| v <= 4095));
        // Raw colour balance: green photosites brighter than red on average.
        let mean = |ox: usize, oy: usize| {
            let v: Vec<f64> = (0..24)
                .flat_map(|y| (0..32).map(move |x| (2 * x + ox, 2 * y + oy)))
                .map(|(x, y)| a.get(x, y) as f64)
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        assert!(mean(1, 0) > mean(0, 0));
    }

    /// A seeded mosaic with smooth structure plus noise (so every orientation occurs), or full-range
    /// noise with `full_range` (magnitudes up to the u16 limit and the shifted ones).
    fn test_mosaic(w: usize, h: usize, bits: u8, seed: u64, full_range: bool) -> Image<u16> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let max = ((1u32 << bits) - 1) as f64;
        Image::from_fn(w, h, |x, y| {
            if full_range {
                return rng.random_range(0..=max as u32) as u16;
            }
            let s = 0.5 + 0.35 * ((x as f64 * 0.21).sin() * (y as f64 * 0.13).cos());
            let n: f64 = rng.random_range(-0.08..0.08);
            ((s + n).clamp(0.0, 1.0) * max).round() as u16
        })
    }

    /// Every kernel path this CPU has (the baseline build, AVX2, AVX-512 on x86-64; NEON on
    /// aarch64) equals the per-pixel oracle bit for bit: u8/u16, 8/12/16-bit, both operators, three
    /// borders, 9/12/36/8 bins, odd sizes and chunk tails (widths beyond one chunk of 256).
    #[test]
    fn kernel_paths_equal_scalar_oracle_bit_for_bit() {
        let ops = [Operator::Central, Operator::Sobel];
        let borders = [Border::Reflect101, Border::Replicate, Border::MosaicExtrapolate];
        let run = |src: RawView<'_>, bits: u8, spec: &MagBinSpec, isa: Option<Isa>| {
            let (w, h) = (src.width(), src.height());
            let (mut m, mut b) = (Image::new(w, h), Image::new(w, h));
            match isa {
                Some(isa) => mag_bin_with_isa(src, bits, spec, isa, &mut m.view_mut(), &mut b.view_mut()),
                None => mag_bin_scalar(src, bits, spec, &mut m.view_mut(), &mut b.view_mut()),
            }
            .unwrap();
            (m, b)
        };
        let paths = Isa::available();
        assert!(paths.contains(&Isa::Scalar));
        assert_eq!(paths.contains(&Isa::Neon), cfg!(target_arch = "aarch64"));
        for (w, h, full) in [
            (4, 4, false),
            (5, 7, false),
            (301, 37, false),
            (530, 19, false),
            (300, 9, true),
        ] {
            let img12 = test_mosaic(w, h, 12, (w * h) as u64, full);
            let img16 = test_mosaic(w, h, 16, (w * h) as u64 + 1, full);
            let img8 = img12.map(|v| (v >> 4) as u8);
            for op in ops {
                for border in borders {
                    for (bins, range) in [
                        (9, AngleRange::Unsigned),
                        (12, AngleRange::Unsigned),
                        (36, AngleRange::Signed),
                        (8, AngleRange::Signed),
                    ] {
                        let spec = MagBinSpec::new(MagBinOptions {
                            operator: op,
                            border,
                            bins,
                            range,
                            serial: false,
                        })
                        .unwrap();
                        for (src, bits) in [
                            (RawView::U16(img12.view()), 12u8),
                            (RawView::U16(img16.view()), 16u8),
                            (RawView::U8(img8.view()), 8u8),
                        ] {
                            let (m0, b0) = run(src, bits, &spec, None);
                            for &isa in &paths {
                                let (m, b) = run(src, bits, &spec, Some(isa));
                                assert_eq!(m, m0, "{w}x{h} {op:?} {border:?} {bins} {bits} {isa} magnitude");
                                assert_eq!(b, b0, "{w}x{h} {op:?} {border:?} {bins} {bits} {isa} bin");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn bins_hand_computed() {
        let hog = MagBinSpec::new(MagBinOptions::default()).unwrap(); // 9 over 180
        assert_eq!(hog.bin_of(1.0, 0.0), 0); // 0°
        assert_eq!(hog.bin_of(-1.0, 0.0), 0); // 180° ≡ 0°
        assert_eq!(hog.bin_of(0.0, 1.0), 4); // 90° -> [80, 100)
        assert_eq!(hog.bin_of(0.0, -1.0), 4);
        assert_eq!(hog.bin_of(1.0, 1.0), 2); // 45° -> [40, 60)
        assert_eq!(hog.bin_of(-1.0, 1.0), 6); // 135° -> [120, 140)
        assert_eq!(hog.bin_of(1.0, -1.0), 6); // -45° ≡ 135°
        assert_eq!(hog.bin_of(-1.0, 0.01), 8); // 179.4° -> [160, 180)
        assert_eq!(hog.bin_of(-1.0, -0.01), 0); // 180.6° ≡ 0.6°
        assert_eq!(hog.bin_of(0.0, 0.0), 0);
        let sift = MagBinSpec::new(MagBinOptions {
            bins: 36,
            range: AngleRange::Signed,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(sift.bin_of(1.0, 0.0), 0);
        assert_eq!(sift.bin_of(0.0, 1.0), 9); // 90°
        assert_eq!(sift.bin_of(-1.0, 0.0), 18); // 180°
        assert_eq!(sift.bin_of(0.0, -1.0), 27); // 270°
        assert_eq!(sift.bin_of(1.0, -0.001), 35); // 359.9°
        let eight = MagBinSpec::new(MagBinOptions {
            bins: 8,
            range: AngleRange::Signed,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(eight.bin_of(1.0, 1.0), 1); // 45° is an edge: upper bin
        assert_eq!(eight.bin_of(-1.0, -1.0), 5); // 225°
    }

    #[test]
    fn bins_agree_with_atan2() {
        for (bins, range) in [
            (9, AngleRange::Unsigned),
            (8, AngleRange::Unsigned),
            (1, AngleRange::Unsigned),
            (36, AngleRange::Signed),
            (8, AngleRange::Signed),
            (2, AngleRange::Signed),
        ] {
            let spec = MagBinSpec::new(MagBinOptions {
                bins,
                range,
                ..Default::default()
            })
            .unwrap();
            let width = range.degrees() as f64 / bins as f64;
            for gy in -60i32..=60 {
                for gx in -60i32..=60 {
                    if gx == 0 && gy == 0 {
                        continue;
                    }
                    let mut a = (gy as f64).atan2(gx as f64).to_degrees();
                    if a < 0.0 {
                        a += 360.0;
                    }
                    let a = a % range.degrees() as f64;
                    let want = (a / width).floor() as usize % bins;
                    let near_edge = ((a / width).round() - a / width).abs() * width < 1e-5;
                    let got = spec.bin_of(gx as f32, gy as f32) as usize;
                    if !near_edge || (a / width).fract().abs() < 1e-12 {
                        assert_eq!(got, want, "bins {bins} {range:?} ({gx}, {gy}) angle {a}");
                    } else {
                        assert!(got == want || (got + 1) % bins == want || (want + 1) % bins == got);
                    }
                }
            }
        }
    }
}
