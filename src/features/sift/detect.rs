//! Gaussian and DoG pyramids, scale-space extrema, sub-pixel refinement and orientation
//! assignment (OpenCV `sift.dispatch.cpp` / `sift.simd.hpp` semantics, generalised to a
//! same-colour step of 1 (grey) or 2 (mosaic)).

use rayon::prelude::*;

use super::buffers;
use super::kernels;
use super::scale_space::{blur_step_with, downsample2_step_into, upsample2_step};
use super::spec::{Keypoint, SiftSpec};
use crate::image::Image;
use crate::kernels::Isa;

/// Width of the border (in octave pixels) in which no extremum is searched (`SIFT_IMG_BORDER`).
pub(crate) const SIFT_IMG_BORDER: usize = 5;
/// Maximum refinement steps before an extremum is dropped (`SIFT_MAX_INTERP_STEPS`).
const SIFT_MAX_INTERP_STEPS: usize = 5;
/// Orientation histogram bins (`SIFT_ORI_HIST_BINS`).
pub(crate) const SIFT_ORI_HIST_BINS: usize = 36;
/// Gaussian sigma of the orientation window, in keypoint scales (`SIFT_ORI_SIG_FCTR`).
const SIFT_ORI_SIG_FCTR: f32 = 1.5;
/// Radius of the orientation window, in keypoint scales (`SIFT_ORI_RADIUS = 3 * 1.5`).
const SIFT_ORI_RADIUS: f32 = 3.0 * SIFT_ORI_SIG_FCTR;
/// Secondary orientation peaks at least this fraction of the highest make new keypoints.
const SIFT_ORI_PEAK_RATIO: f32 = 0.8;
/// Blur assumed already present in the input image, in input pixels (`SIFT_INIT_SIGMA`).
pub(crate) const SIFT_INIT_SIGMA: f64 = 0.5;
/// Intensity range the thresholds are expressed in (OpenCV works on 8-bit data).
pub(crate) const INTENSITY_RANGE: f32 = 255.0;

/// The Gaussian and difference-of-Gaussian pyramids of one image.
pub(crate) struct Pyramid {
    /// `gauss[o][i]`, `i` in `0..n_octave_layers + 3`.
    pub gauss: Vec<Vec<Image<f32>>>,
    /// `dog[o][i] = gauss[o][i + 1] - gauss[o][i]`, `i` in `0..n_octave_layers + 2`.
    pub dog: Vec<Vec<Image<f32>>>,
}

impl Drop for Pyramid {
    fn drop(&mut self) {
        for img in self.gauss.drain(..).chain(self.dog.drain(..)).flatten() {
            buffers::give(img);
        }
    }
}

/// A keypoint together with where it lives in the pyramid (needed by the descriptor).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Candidate {
    /// The public keypoint (input-pixel coordinates).
    pub kp: Keypoint,
    /// Pyramid octave index (0 = the base, which is the doubled image when `double_image`).
    pub o: usize,
    /// Layer inside the octave (1..=n_octave_layers).
    pub layer: usize,
    /// Position in octave pixels.
    pub ox: f32,
    /// Position in octave pixels.
    pub oy: f32,
    /// Scale in octave pixels (sigma of the keypoint; OpenCV's `size * 0.5` at that octave).
    pub scl: f32,
}

/// Per-layer blur increments in input pixels: `sig[0] = sigma`, `sig[i]` takes layer `i - 1`
/// to total sigma `sigma * k^i`, `k = 2^(1/n_octave_layers)`.
fn layer_sigmas(spec: &SiftSpec) -> Vec<f64> {
    let n = spec.o.n_octave_layers;
    let k = 2f64.powf(1.0 / n as f64);
    let mut sig = vec![spec.sigma_px(); n + 3];
    for (i, s) in sig.iter_mut().enumerate().skip(1) {
        let prev = k.powi(i as i32 - 1) * spec.sigma_px();
        let total = prev * k;
        *s = (total * total - prev * prev).sqrt();
    }
    sig
}

/// Number of octaves as OpenCV: `round(log2(min(base w, h)) - 2)` (base already doubled when
/// `double_image`, which adds the `-firstOctave = 1`), capped so every octave keeps at least
/// one same-colour sample per axis.
fn octave_count(base_w: usize, base_h: usize, spec: &SiftSpec) -> usize {
    let m = base_w.min(base_h).max(1) as f64;
    let first = if spec.o.double_image { 1.0 } else { 0.0 };
    let want = ((m.log2() - 2.0).round() + first).max(1.0) as usize;
    let step = spec.step();
    let mut n = 1;
    let (mut w, mut h) = (base_w, base_h);
    while n < want {
        let (nw, nh) = (step * ((w / step) / 2), step * ((h / step) / 2));
        if nw < step || nh < step {
            break;
        }
        w = nw;
        h = nh;
        n += 1;
    }
    n
}

/// Build the Gaussian and DoG pyramids. `src` is already scaled to the 0..255 range.
pub(crate) fn build_pyramid(src: &Image<f32>, spec: &SiftSpec) -> Result<Pyramid, super::SiftError> {
    let step = spec.step();
    let st = step as f64;
    let tp0 = std::time::Instant::now();
    let doubled;
    let init = if spec.o.double_image {
        doubled = upsample2_step(src, step)?;
        &doubled
    } else {
        src
    };
    // The doubled image carries twice the input blur (SIFT_INIT_SIGMA * 2 in its pixels).
    let init_sigma = if spec.o.double_image {
        2.0 * SIFT_INIT_SIGMA
    } else {
        SIFT_INIT_SIGMA
    };
    let init_sigma = init_sigma * spec.unit();
    let sig_diff = (spec.sigma_px() * spec.sigma_px() - init_sigma * init_sigma)
        .max(0.01)
        .sqrt();
    let path = crate::kernels::isa();
    // Scratch image of the blurs' horizontal pass, reused by every blur of the pyramid. All
    // large images come from `buffers` (recycled between frames, every pixel overwritten).
    let (iw, ih) = init.dimensions();
    let mut tmp = buffers::take(iw, ih);
    let mut base = buffers::take(iw, ih);
    blur_step_with(init, sig_diff / st, step, &mut base, &mut tmp, None, path)?;
    let tp1 = std::time::Instant::now();
    let n_oct = octave_count(base.width(), base.height(), spec);
    let sig = layer_sigmas(spec);
    let nl = spec.o.n_octave_layers;
    let mut gauss: Vec<Vec<Image<f32>>> = Vec::with_capacity(n_oct);
    let mut dog: Vec<Vec<Image<f32>>> = Vec::with_capacity(n_oct);
    for o in 0..n_oct {
        let mut layers = Vec::with_capacity(nl + 3);
        let mut dogs = Vec::with_capacity(nl + 2);
        layers.push(if o == 0 {
            std::mem::replace(&mut base, Image::new(0, 0))
        } else {
            let prev: &Image<f32> = &gauss[o - 1][nl];
            let (pw, ph) = prev.dimensions();
            let mut d = buffers::take(step * ((pw / step) / 2), step * ((ph / step) / 2));
            downsample2_step_into(prev, step, spec.centred_octaves(), &mut d)?;
            d
        });
        let (lw, lh) = layers[0].dimensions();
        for s in sig.iter().skip(1) {
            let mut dst = buffers::take(lw, lh);
            // dog[i] = gauss[i + 1] - gauss[i], written by the blur that makes gauss[i + 1].
            let mut d = buffers::take(lw, lh);
            blur_step_with(
                layers.last().expect("layer 0 exists"),
                s / st,
                step,
                &mut dst,
                &mut tmp,
                Some(&mut d),
                path,
            )?;
            layers.push(dst);
            dogs.push(d);
        }
        gauss.push(layers);
        dog.push(dogs);
    }
    buffers::give(tmp);
    tracing::debug!(
        base_s = (tp1 - tp0).as_secs_f64(),
        layers_s = tp1.elapsed().as_secs_f64(),
        "sift pyramid"
    );
    Ok(Pyramid { gauss, dog })
}

/// Is `val` at (x, y) of `cur` an extremum over the `(2 reach + 1)^2 x 3` neighbourhood
/// (non-strict, as OpenCV)?
#[inline]
fn is_extremum(
    prev: &Image<f32>,
    cur: &Image<f32>,
    next: &Image<f32>,
    x: usize,
    y: usize,
    reach: usize,
) -> bool {
    let val = cur.get(x, y);
    let w = cur.width();
    let (x0, x1) = (x - reach, x + reach);
    // The centre row first (its neighbours are the closest, so they reject most often), then
    // the others: the same test in another order.
    let rows = std::iter::once(y).chain((y - reach..=y + reach).filter(|&yy| yy != y));
    if val > 0.0 {
        for yy in rows {
            let off = yy * w;
            for img in [prev, cur, next] {
                let row = &img.as_slice()[off + x0..=off + x1];
                if row.iter().any(|&v| val < v) {
                    return false;
                }
            }
        }
        true
    } else if val < 0.0 {
        for yy in rows {
            let off = yy * w;
            for img in [prev, cur, next] {
                let row = &img.as_slice()[off + x0..=off + x1];
                if row.iter().any(|&v| val > v) {
                    return false;
                }
            }
        }
        true
    } else {
        false
    }
}

/// Solve the 3x3 system `h x = b` by LU without pivoting, as OpenCV's `solve_LU`.
fn solve_lu(h: [[f32; 3]; 3], b: [f32; 3]) -> [f32; 3] {
    let (u00, u01, u02) = (h[0][0], h[0][1], h[0][2]);
    let l10 = h[1][0] / u00;
    let l20 = h[2][0] / u00;
    let u11 = h[1][1] - l10 * u01;
    let u12 = h[1][2] - l10 * u02;
    let l21 = (h[2][1] - l20 * u01) / u11;
    let u22 = (h[2][2] - l20 * u02) - l21 * u12;
    let v0 = b[0];
    let v1 = b[1] - l10 * v0;
    let v2 = b[2] - l20 * v0 - l21 * v1;
    let x2 = v2 / u22;
    let x1 = (v1 - x2 * u12) / u11;
    let x0 = (v0 - x2 * u02 - x1 * u01) / u00;
    [x0, x1, x2]
}

/// Result of refining one extremum: position (octave pixels, integer), layer and offsets.
struct Refined {
    r: usize,
    c: usize,
    layer: usize,
    xr: f32,
    xc: f32,
    xi: f32,
    contr: f32,
}

/// Lowe's quadratic refinement (OpenCV `adjustLocalExtrema`) with same-colour finite differences
/// `s` pixels apart; offsets are in plane units (one plane unit = `s` octave pixels).
fn adjust_local_extrema(
    dog: &[Image<f32>],
    spec: &SiftSpec,
    mut layer: usize,
    mut r: usize,
    mut c: usize,
) -> Option<Refined> {
    let s = spec.step();
    let img_scale = 1.0 / INTENSITY_RANGE;
    let deriv_scale = img_scale * 0.5;
    let second_deriv_scale = img_scale;
    let cross_deriv_scale = img_scale * 0.25;
    let nl = spec.o.n_octave_layers;
    let (cols, rows) = dog[0].dimensions();
    let (mut xi, mut xr, mut xc) = (0.0f32, 0.0f32, 0.0f32);
    let mut converged = false;
    for _ in 0..SIFT_MAX_INTERP_STEPS {
        let (img, prev, next) = (&dog[layer], &dog[layer - 1], &dog[layer + 1]);
        let at = |m: &Image<f32>, y: usize, x: usize| m.get(x, y);
        let d_d = [
            (at(img, r, c + s) - at(img, r, c - s)) * deriv_scale,
            (at(img, r + s, c) - at(img, r - s, c)) * deriv_scale,
            (at(next, r, c) - at(prev, r, c)) * deriv_scale,
        ];
        let v2 = at(img, r, c) * 2.0;
        let dxx = (at(img, r, c + s) + at(img, r, c - s) - v2) * second_deriv_scale;
        let dyy = (at(img, r + s, c) + at(img, r - s, c) - v2) * second_deriv_scale;
        let dss = (at(next, r, c) + at(prev, r, c) - v2) * second_deriv_scale;
        let dxy = (at(img, r + s, c + s) - at(img, r + s, c - s) - at(img, r - s, c + s)
            + at(img, r - s, c - s))
            * cross_deriv_scale;
        let dxs = (at(next, r, c + s) - at(next, r, c - s) - at(prev, r, c + s) + at(prev, r, c - s))
            * cross_deriv_scale;
        let dys = (at(next, r + s, c) - at(next, r - s, c) - at(prev, r + s, c) + at(prev, r - s, c))
            * cross_deriv_scale;
        let x = solve_lu([[dxx, dxy, dxs], [dxy, dyy, dys], [dxs, dys, dss]], d_d);
        xi = -x[2];
        xr = -x[1];
        xc = -x[0];
        if !(xi.is_finite() && xr.is_finite() && xc.is_finite()) {
            return None;
        }
        if xi.abs() < 0.5 && xr.abs() < 0.5 && xc.abs() < 0.5 {
            converged = true;
            break;
        }
        if xi.abs() > (i32::MAX / 3) as f32
            || xr.abs() > (i32::MAX / 3) as f32
            || xc.abs() > (i32::MAX / 3) as f32
        {
            return None;
        }
        let nc = c as i64 + s as i64 * xc.round() as i64;
        let nr = r as i64 + s as i64 * xr.round() as i64;
        let nlayer = layer as i64 + xi.round() as i64;
        let b = SIFT_IMG_BORDER as i64;
        if nlayer < 1
            || nlayer > nl as i64
            || nc < b
            || nc >= cols as i64 - b
            || nr < b
            || nr >= rows as i64 - b
        {
            return None;
        }
        c = nc as usize;
        r = nr as usize;
        layer = nlayer as usize;
    }
    if !converged {
        return None;
    }
    let (img, prev, next) = (&dog[layer], &dog[layer - 1], &dog[layer + 1]);
    let at = |m: &Image<f32>, y: usize, x: usize| m.get(x, y);
    let d_d = [
        (at(img, r, c + s) - at(img, r, c - s)) * deriv_scale,
        (at(img, r + s, c) - at(img, r - s, c)) * deriv_scale,
        (at(next, r, c) - at(prev, r, c)) * deriv_scale,
    ];
    let t = d_d[0] * xc + d_d[1] * xr + d_d[2] * xi;
    let contr = at(img, r, c) * img_scale + t * 0.5;
    if contr.abs() * (nl as f32) < spec.o.contrast_threshold as f32 {
        return None;
    }
    let v2 = at(img, r, c) * 2.0;
    let dxx = (at(img, r, c + s) + at(img, r, c - s) - v2) * second_deriv_scale;
    let dyy = (at(img, r + s, c) + at(img, r - s, c) - v2) * second_deriv_scale;
    let dxy = (at(img, r + s, c + s) - at(img, r + s, c - s) - at(img, r - s, c + s) + at(img, r - s, c - s))
        * cross_deriv_scale;
    let tr = dxx + dyy;
    let det = dxx * dyy - dxy * dxy;
    let e = spec.o.edge_threshold as f32;
    if det <= 0.0 || tr * tr * e >= (e + 1.0) * (e + 1.0) * det {
        return None;
    }
    Some(Refined {
        r,
        c,
        layer,
        xr,
        xc,
        xi,
        contr,
    })
}

/// Reusable buffers of the two-pass gradient windows (orientation histogram and descriptor):
/// the gradients of the samples kept, two per-sample values, weights, and the polar form.
#[derive(Debug, Default)]
pub(crate) struct GradScratch {
    /// Horizontal same-colour differences.
    pub dx: Vec<f32>,
    /// Vertical same-colour differences (up minus down).
    pub dy: Vec<f32>,
    /// First per-sample value (row bin of the descriptor).
    pub a: Vec<f32>,
    /// Second per-sample value (column bin of the descriptor).
    pub b: Vec<f32>,
    /// Gaussian weights (descriptor) or `i² + j²` (orientation, as f32, exact below 2^24).
    pub w: Vec<f32>,
    /// Magnitudes from [`kernels::polar`].
    pub mag: Vec<f32>,
    /// Orientations in degrees from [`kernels::polar`].
    pub ori: Vec<f32>,
    /// Weight table.
    pub table: Vec<f32>,
}

impl GradScratch {
    /// Empty every list (capacity kept).
    pub(super) fn clear(&mut self) {
        for v in [
            &mut self.dx,
            &mut self.dy,
            &mut self.a,
            &mut self.b,
            &mut self.w,
            &mut self.table,
        ] {
            v.clear();
        }
    }

    /// Fill `mag` and `ori` from `dx` and `dy`.
    pub(super) fn polar(&mut self, path: Isa) {
        let n = self.dx.len();
        self.mag.resize(n, 0.0);
        self.ori.resize(n, 0.0);
        kernels::polar(path, &self.dx, &self.dy, &mut self.mag, &mut self.ori);
    }
}

/// `x.floor()` without the libm call the baseline x86-64 target makes for it; equal to it for
/// `|x| < 2^31` (the descriptor's bins lie in (-9, 9)), except that -0 gives +0, which adds the
/// same zero to the histogram.
#[inline]
pub(crate) fn floor(x: f32) -> f32 {
    debug_assert!(x.abs() < 2_147_483_648.0);
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// `x.round()` (half away from zero) for `0 <= x < 2^31` without the libm call: `x - trunc(x)`
/// is exact there.
#[inline]
fn round_non_negative(x: f32) -> f32 {
    debug_assert!((0.0..2_147_483_648.0).contains(&x));
    let t = x as i32 as f32;
    if x - t >= 0.5 {
        t + 1.0
    } else {
        t
    }
}

/// Smoothed 36-bin gradient-orientation histogram around (x, y) of `img` (OpenCV
/// `calcOrientationHist`); gradients use same-colour taps `s` pixels apart. Returns the maximum.
///
/// Two passes as the descriptor: collect the gradients, [`kernels::polar`] for magnitude and
/// orientation, then accumulate in OpenCV's order. The weight `exp((i² + j²) · expf_scale)` is
/// computed once per distinct `i² + j²` (a lazily filled table), so the result is bit-equal to
/// the single loop.
#[allow(clippy::too_many_arguments)]
fn orientation_hist(
    img: &Image<f32>,
    x: usize,
    y: usize,
    radius: i64,
    sigma: f32,
    s: usize,
    path: Isa,
    sc: &mut GradScratch,
    hist: &mut [f32; SIFT_ORI_HIST_BINS],
) -> f32 {
    let n = SIFT_ORI_HIST_BINS;
    let expf_scale = -1.0 / (2.0 * sigma * sigma);
    let mut temp = [0.0f32; SIFT_ORI_HIST_BINS + 4];
    let (cols, rows) = (img.width() as i64, img.height() as i64);
    let si = s as i64;
    sc.clear();
    // The columns inside the image are one interval, the same on every row.
    let (xi, ja) = (x as i64, (-radius).max(si - x as i64));
    let jb = radius.min(cols - si - 1 - xi);
    for i in -radius..=radius {
        let yy = y as i64 + i;
        if yy < si || yy >= rows - si || ja > jb {
            continue;
        }
        let yu = yy as usize;
        let (above, row, below) = (img.row(yu - s), img.row(yu), img.row(yu + s));
        let (n, c0) = ((jb - ja + 1) as usize, (xi + ja) as usize);
        // Exact-size iterators: `extend` writes in place (no zero fill first) and vectorises.
        sc.dx.extend(
            row[c0 + s..c0 + s + n]
                .iter()
                .zip(&row[c0 - s..c0 - s + n])
                .map(|(&a, &b)| a - b),
        );
        sc.dy.extend(
            above[c0..c0 + n]
                .iter()
                .zip(&below[c0..c0 + n])
                .map(|(&a, &b)| a - b),
        );
        // `i² + j²` in i32 (exact: the radius is small), which vectorises.
        let (ii, ja32) = ((i * i) as i32, ja as i32);
        sc.w.extend((0..n).map(|k| (ii + (ja32 + k as i32) * (ja32 + k as i32)) as f32));
    }
    sc.polar(path);
    // NaN marks a weight not computed yet (every real weight is finite).
    sc.table
        .resize((2 * radius * radius + 1).max(1) as usize, f32::NAN);
    for k in 0..sc.dx.len() {
        let r2 = sc.w[k];
        let slot = &mut sc.table[r2 as usize];
        if slot.is_nan() {
            *slot = (r2 * expf_scale).exp();
        }
        let w = *slot;
        let mut bin = round_non_negative((n as f32 / 360.0) * sc.ori[k]) as i64;
        if bin >= n as i64 {
            bin -= n as i64;
        }
        if bin < 0 {
            bin += n as i64;
        }
        temp[2 + bin as usize] += w * sc.mag[k];
    }
    temp[1] = temp[n + 1];
    temp[0] = temp[n];
    temp[n + 2] = temp[2];
    temp[n + 3] = temp[3];
    let mut maxval = 0.0f32;
    for i in 0..n {
        hist[i] = (temp[i] + temp[i + 4]) * (1.0 / 16.0)
            + (temp[i + 1] + temp[i + 3]) * (4.0 / 16.0)
            + temp[i + 2] * (6.0 / 16.0);
        if i == 0 || hist[i] > maxval {
            maxval = hist[i];
        }
    }
    maxval
}

#[cfg(test)]
/// `atan2(y, x)` in degrees in `[0, 360)` by OpenCV's `fastAtan2` polynomial (max error about
/// 0.01°; the same constants as `atan2_bitexact` in `sift.simd.hpp`), several times cheaper than
/// `f32::atan2`. The reference for the branch-free copy in `kernels`, which the code runs.
#[inline]
pub(crate) fn fast_atan2_deg(y: f32, x: f32) -> f32 {
    /// Polynomial coefficients (degrees) of OpenCV's `atan2` approximation on [0, 1].
    const P1: f32 = 57.283_627;
    const P3: f32 = -18.667_446;
    const P5: f32 = 8.914_001;
    const P7: f32 = -2.539_725;
    /// Guards the division when both components are zero (OpenCV adds `DBL_EPSILON` as float).
    const EPS: f32 = f64::EPSILON as f32;
    let (ax, ay) = (x.abs(), y.abs());
    let mut a = if ax >= ay {
        let c = ay / (ax + EPS);
        let c2 = c * c;
        (((P7 * c2 + P5) * c2 + P3) * c2 + P1) * c
    } else {
        let c = ax / (ay + EPS);
        let c2 = c * c;
        90.0 - (((P7 * c2 + P5) * c2 + P3) * c2 + P1) * c
    };
    if x < 0.0 {
        a = 180.0 - a;
    }
    if y < 0.0 {
        a = 360.0 - a;
    }
    a
}

/// Map a refined octave position to input-image coordinates.
///
/// For `step = 1` this is OpenCV's `(c + xc) * 2^o`, halved when the image was doubled. For the
/// mosaic the keypoint lives on the colour plane of the pixel it was found at (phase `p`): plane
/// coordinate `u = (c - p) / 2 + xc` at octave `o` is `u * 2^o` at the pyramid base, undone from
/// the x2 plane upsampling when doubled (`(u + 0.5) / 2 - 0.5`), then `2 u + p` in the mosaic.
/// With centred octaves an octave sample `u` sits at `(u + 0.5) 2^o - 0.5` of the base (of its
/// plane for the mosaic) instead of `u 2^o`.
fn to_input(c: usize, xc: f32, o: usize, spec: &SiftSpec) -> f32 {
    let scale = (1u64 << o) as f32;
    let centre = if spec.centred_octaves() {
        0.5 * (scale - 1.0)
    } else {
        0.0
    };
    if spec.step() == 1 {
        let v = (c as f32 + xc) * scale + centre;
        if spec.o.double_image {
            v * 0.5
        } else {
            v
        }
    } else {
        let p = c % 2;
        let mut u = ((c - p) / 2) as f32 + xc;
        u = u * scale + centre;
        if spec.o.double_image {
            u = (u + 0.5) * 0.5 - 0.5;
        }
        2.0 * u + p as f32
    }
}

/// Indices `x >= from` with `flags[x] != 0`, in increasing order. Most flags are zero (the
/// pre-test passes a few pixels per row), so zero runs are skipped eight bytes at a time.
fn flagged(flags: &[u8], from: usize) -> impl Iterator<Item = usize> + '_ {
    let mut x = from;
    std::iter::from_fn(move || {
        while x < flags.len() {
            if let Some(word) = flags.get(x..x + 8) {
                if u64::from_ne_bytes(word.try_into().expect("8 bytes")) == 0 {
                    x += 8;
                    continue;
                }
            }
            x += 1;
            if flags[x - 1] != 0 {
                return Some(x - 1);
            }
        }
        None
    })
}

/// Rows of DoG handed to one rayon task while searching extrema.
const EXTREMA_ROW_STRIP: usize = 8;

/// Find, refine and orient the scale-space extrema of every octave and layer. Output order is the
/// pyramid's scan order (octave, layer, row, column, orientation peak) for any thread count.
pub(crate) fn find_scale_space_extrema(pyr: &Pyramid, spec: &SiftSpec) -> Vec<Candidate> {
    let nl = spec.o.n_octave_layers;
    let s = spec.step();
    let reach = s;
    let threshold = (0.5 * spec.o.contrast_threshold / nl as f64 * INTENSITY_RANGE as f64) as f32;
    let path = crate::kernels::isa();
    let mut out = Vec::new();
    for (o, dog) in pyr.dog.iter().enumerate() {
        let (cols, rows) = dog[0].dimensions();
        if cols <= 2 * SIFT_IMG_BORDER || rows <= 2 * SIFT_IMG_BORDER {
            continue;
        }
        // All layers of a row at once, so that the DoG rows each layer's test shares with the
        // next are still in cache; the candidates are regrouped by layer below.
        let rows_range: Vec<usize> = (SIFT_IMG_BORDER..rows - SIFT_IMG_BORDER).collect();
        let mut found: Vec<Vec<Vec<Candidate>>> = rows_range
            .par_chunks(EXTREMA_ROW_STRIP)
            .map(|strip| {
                let mut v = vec![Vec::new(); nl];
                let mut hist = [0.0f32; SIFT_ORI_HIST_BINS];
                let mut sc = GradScratch::default();
                let mut flags = vec![0u8; cols];
                for &r in strip {
                    for (i, v) in (1..=nl).zip(v.iter_mut()) {
                        let cur = &dog[i];
                        let row = cur.row(r);
                        kernels::extremum_pretest(
                            path,
                            dog[i - 1].row(r),
                            row,
                            dog[i + 1].row(r),
                            reach,
                            threshold,
                            &mut flags,
                        );
                        let (lo, hi) = (SIFT_IMG_BORDER, cols - SIFT_IMG_BORDER);
                        for c in flagged(&flags[..hi], lo) {
                            // The pre-test checks the threshold and some neighbours; the full
                            // test decides (same result as the full test alone).
                            if !is_extremum(&dog[i - 1], cur, &dog[i + 1], c, r, reach) {
                                continue;
                            }
                            let Some(rf) = adjust_local_extrema(dog, spec, i, r, c) else {
                                continue;
                            };
                            orient(pyr, spec, o, &rf, (path, &mut sc), &mut hist, v);
                        }
                    }
                }
                v
            })
            .collect();
        for layer in 0..nl {
            for strip in &mut found {
                out.append(&mut strip[layer]);
            }
        }
    }
    out
}

/// Orientation assignment for one refined extremum: one candidate per histogram peak.
fn orient(
    pyr: &Pyramid,
    spec: &SiftSpec,
    o: usize,
    rf: &Refined,
    (path, sc): (Isa, &mut GradScratch),
    hist: &mut [f32; SIFT_ORI_HIST_BINS],
    out: &mut Vec<Candidate>,
) {
    let nl = spec.o.n_octave_layers as f32;
    let s = spec.step();
    let n = SIFT_ORI_HIST_BINS;
    // Keypoint sigma in octave pixels.
    let scl_octv = spec.sigma_px() as f32 * 2f32.powf((rf.layer as f32 + rf.xi) / nl);
    let omax = orientation_hist(
        &pyr.gauss[o][rf.layer],
        rf.c,
        rf.r,
        (SIFT_ORI_RADIUS * scl_octv).round() as i64,
        SIFT_ORI_SIG_FCTR * scl_octv,
        s,
        path,
        sc,
        hist,
    );
    let mag_thr = omax * SIFT_ORI_PEAK_RATIO;
    let octave_scale = (1u64 << o) as f32;
    let doubled = if spec.o.double_image { 0.5 } else { 1.0 };
    let x = to_input(rf.c, rf.xc, o, spec);
    let y = to_input(rf.r, rf.xr, o, spec);
    let size = scl_octv * 2.0 * octave_scale * doubled;
    let octave = o as i32 - i32::from(spec.o.double_image);
    for j in 0..n {
        let l = if j > 0 { j - 1 } else { n - 1 };
        let r2 = if j < n - 1 { j + 1 } else { 0 };
        if hist[j] > hist[l] && hist[j] > hist[r2] && hist[j] >= mag_thr {
            let mut bin = j as f32 + 0.5 * (hist[l] - hist[r2]) / (hist[l] - 2.0 * hist[j] + hist[r2]);
            if bin < 0.0 {
                bin += n as f32;
            } else if bin >= n as f32 {
                bin -= n as f32;
            }
            let mut angle = 360.0 - (360.0 / n as f32) * bin;
            if (angle - 360.0).abs() < f32::EPSILON {
                angle = 0.0;
            }
            // Octave-pixel position of the refined extremum (mosaic offsets are in plane units).
            let ox = rf.c as f32 + s as f32 * rf.xc;
            let oy = rf.r as f32 + s as f32 * rf.xr;
            out.push(Candidate {
                kp: Keypoint {
                    x,
                    y,
                    size,
                    angle,
                    response: rf.contr.abs(),
                    octave,
                    layer: rf.layer as u32,
                },
                o,
                layer: rf.layer,
                ox,
                oy,
                scl: scl_octv,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flagged_finds_every_set_flag_in_order() {
        let mut flags = vec![0u8; 45];
        for x in [0, 3, 7, 8, 9, 23, 31, 40, 44] {
            flags[x] = 1;
        }
        for from in [0, 1, 5, 8, 30, 44, 45] {
            let want: Vec<usize> = (from..flags.len()).filter(|&x| flags[x] != 0).collect();
            assert_eq!(flagged(&flags, from).collect::<Vec<_>>(), want, "from {from}");
        }
    }

    #[test]
    fn solve_lu_by_hand() {
        let x = solve_lu(
            [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]],
            [3.0, 5.0, 5.0],
        );
        for v in x {
            assert!((v - 1.0).abs() < 1e-5, "{x:?}");
        }
    }

    #[test]
    fn atan_range() {
        assert!((fast_atan2_deg(1.0, 0.0) - 90.0).abs() < 1e-4);
        assert!((fast_atan2_deg(-1.0, 0.0) - 270.0).abs() < 1e-4);
        assert!((fast_atan2_deg(0.0, -1.0) - 180.0).abs() < 1e-4);
        assert_eq!(fast_atan2_deg(0.0, 1.0), 0.0);
        assert_eq!(fast_atan2_deg(0.0, 0.0), 0.0);
        for i in 0..3600 {
            let t = (i as f32 * 0.1).to_radians();
            let (y, x) = (3.0 * t.sin(), 3.0 * t.cos());
            let exact = y.atan2(x).to_degrees().rem_euclid(360.0);
            let d = (fast_atan2_deg(y, x) - exact).abs();
            assert!(d.min(360.0 - d) < 0.02, "{i}: {d}");
        }
    }

    #[test]
    fn layer_sigmas_compose_to_the_next_layer() {
        let spec = SiftSpec::grey();
        let sig = layer_sigmas(&spec);
        let k = 2f64.powf(1.0 / 3.0);
        let mut total = sig[0];
        for (i, s) in sig.iter().enumerate().skip(1) {
            total = (total * total + s * s).sqrt();
            assert!((total - 1.6 * k.powi(i as i32)).abs() < 1e-9);
        }
    }

    #[test]
    fn mosaic_coordinates_map_back_to_the_phase() {
        let spec = SiftSpec::mosaic().with_centred_octaves(false);
        // Pixel 9 (plane index 4, phase 1) at octave 1 sits at plane 8 of the base: mosaic 17.
        assert_eq!(to_input(9, 0.0, 1, &spec), 17.0);
        assert_eq!(to_input(8, 0.5, 0, &spec), 9.0);
        // Centred octaves: plane index 4 at octave 1 is the mean of base planes 8 and 9 (8.5),
        // mosaic 2 * 8.5 + 1 = 18; at octave 2, of base planes 16..=19 (17.5): mosaic 36.
        let spec = SiftSpec::mosaic();
        assert_eq!(to_input(9, 0.0, 1, &spec), 18.0);
        assert_eq!(to_input(9, 0.0, 2, &spec), 36.0);
        assert_eq!(to_input(8, 0.5, 0, &spec), 9.0);
        // Doubled planes: plane index 8 of the doubled plane is plane coordinate 3.75 originally.
        let spec = SiftSpec::mosaic().with_double_image(true);
        assert_eq!(to_input(16, 0.0, 0, &spec), 7.5);
        assert_eq!(to_input(17, 0.0, 0, &spec), 8.5);
    }
}
