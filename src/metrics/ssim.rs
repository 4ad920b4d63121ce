//! Structural similarity: SSIM map and mean SSIM (Wang et al. 2004), as scikit-image computes it.
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::metrics::{mssim, ssim_map, SsimOptions};
//! let a = Image::<f32>::from_fn(24, 20, |x, y| ((x * 5 + y * 3) % 13) as f32 * 10.0);
//! let b = a.map(|v| v * 0.9 + 5.0);
//! let spec = SsimOptions::with_data_range(255.0).build().unwrap();
//! assert!((mssim(a.view(), a.view(), &spec).unwrap() - 1.0).abs() < 1e-12);
//! let s = mssim(a.view(), b.view(), &spec).unwrap();
//! assert!(s < 1.0 && s > 0.5);
//! assert_eq!(ssim_map(a.view(), b.view(), &spec).unwrap().dimensions(), (24, 20));
//! ```
//!
//! ## Math
//! With local statistics weighted by a normalised Gaussian window `w` (σ = 1.5):
//! ```text
//! μ_x = w * x,  σ_x² = w * x² − μ_x²,  σ_xy = w * (x y) − μ_x μ_y        (population covariance)
//! SSIM = (2 μ_x μ_y + C1)(2 σ_xy + C2) / ((μ_x² + μ_y² + C1)(σ_x² + σ_y² + C2))
//! C1 = (K1 R)²,  C2 = (K2 R)²,  K1 = 0.01, K2 = 0.03,  R = data range (explicit)
//! MSSIM = mean of the SSIM map over the pixels at least `radius` from every border
//! ```
//! The window is the truncated Gaussian of `scipy.ndimage.gaussian_filter` with `truncate = 3.5`
//! (radius `⌊3.5 σ + 0.5⌋ = 5`, 11 taps), the borders are extended by half-sample symmetric
//! reflection (scipy's `mode='reflect'`: `c b a | a b c`), and MSSIM averages only the pixels whose
//! window does not reach past the border (skimage crops `(win_size − 1) / 2 = 5` pixels per side).
//! RGB images give the mean of the three per-channel MSSIMs (skimage's `channel_axis`).
//! Sums are in `f64`.
//!
//! ## Parity
//! Equals `skimage.metrics.structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
//! use_sample_covariance=False, data_range=R)` within 1e-4 (in practice ~1e-12) on Kodak images,
//! grey and per channel (tests/metrics_parity.rs, fixtures by tests/oracle/gen_metrics.py).
//!
//! ## Deviations
//! Wang et al. crop nothing and use an 11x11 Gaussian computed in MATLAB with `filter2(...,'valid')`;
//! we follow scikit-image (the de-facto reference for the paper's Python tooling) instead, which differs
//! only in the border treatment.
//!
//! ## References
//! Z. Wang, A. C. Bovik, H. R. Sheikh, E. P. Simoncelli, "Image quality assessment: from error
//! visibility to structural similarity", IEEE TIP 13(4), 2004. scikit-image
//! `skimage/metrics/_structural_similarity.py`.

use super::{positive, same_size, MetricsError, Pixel, Result};
use crate::image::{Image, ImageView};
use rayon::prelude::*;

/// Gaussian window standard deviation of Wang et al. 2004.
pub(crate) const DEFAULT_SIGMA: f64 = 1.5;
/// Luminance stabiliser constant K1 of Wang et al. 2004.
pub(crate) const DEFAULT_K1: f64 = 0.01;
/// Contrast stabiliser constant K2 of Wang et al. 2004.
pub(crate) const DEFAULT_K2: f64 = 0.03;
/// Truncation of the Gaussian in standard deviations (scikit-image's value).
pub(crate) const DEFAULT_TRUNCATE: f64 = 3.5;
/// Rows per rayon task in the filter passes.
const STRIP_ROWS: usize = 16;

/// SSIM options; [`SsimOptions::build`] validates them into an [`SsimSpec`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsimOptions {
    /// Gaussian window σ in pixels (1.5).
    pub sigma: f64,
    /// Truncation radius in σ (3.5 → an 11x11 window for σ = 1.5).
    pub truncate: f64,
    /// K1 (0.01).
    pub k1: f64,
    /// K2 (0.03).
    pub k2: f64,
    /// Data range R of the pixel values (255 for 8-bit, 1 for [0, 1]); no default on purpose.
    pub data_range: f64,
}

impl SsimOptions {
    /// Wang et al.'s defaults with the given data range.
    pub fn with_data_range(data_range: f64) -> Self {
        Self {
            sigma: DEFAULT_SIGMA,
            truncate: DEFAULT_TRUNCATE,
            k1: DEFAULT_K1,
            k2: DEFAULT_K2,
            data_range,
        }
    }

    /// Validates the options and builds the window.
    pub fn build(&self) -> Result<SsimSpec> {
        let sigma = positive("sigma", self.sigma)?;
        let truncate = positive("truncate", self.truncate)?;
        let k1 = positive("k1", self.k1)?;
        let k2 = positive("k2", self.k2)?;
        let r = positive("data_range", self.data_range)?;
        // scipy.ndimage: radius = int(truncate * sigma + 0.5).
        let radius = (truncate * sigma + 0.5).floor() as usize;
        let mut taps: Vec<f64> = (0..=2 * radius)
            .map(|i| {
                let x = i as f64 - radius as f64;
                (-0.5 * x * x / (sigma * sigma)).exp()
            })
            .collect();
        let sum: f64 = taps.iter().sum();
        taps.iter_mut().for_each(|t| *t /= sum);
        Ok(SsimSpec {
            options: *self,
            c1: (k1 * r).powi(2),
            c2: (k2 * r).powi(2),
            radius,
            taps,
        })
    }
}

/// Validated SSIM parameters with the precomputed window.
#[derive(Debug, Clone, PartialEq)]
pub struct SsimSpec {
    options: SsimOptions,
    c1: f64,
    c2: f64,
    radius: usize,
    taps: Vec<f64>,
}

impl SsimSpec {
    /// The options this spec was built from.
    pub fn options(&self) -> &SsimOptions {
        &self.options
    }
    /// Window radius in pixels (5 for σ = 1.5); the window is `2 radius + 1` wide.
    pub fn radius(&self) -> usize {
        self.radius
    }
    /// The normalised 1-D Gaussian taps.
    pub fn taps(&self) -> &[f64] {
        &self.taps
    }
}

/// Half-sample symmetric reflection (scipy `reflect`) of index `i` into `0..n`.
#[inline]
fn reflect(i: isize, n: usize) -> usize {
    let n = n as isize;
    let period = 2 * n;
    let mut m = i.rem_euclid(period);
    if m >= n {
        m = period - 1 - m;
    }
    m as usize
}

/// Separable Gaussian filtering of a `w`x`h` plane with reflect borders.
fn filter(src: &[f64], w: usize, h: usize, taps: &[f64], parallel: bool) -> Vec<f64> {
    let r = taps.len() / 2;
    let mut tmp = vec![0.0; w * h];
    let mut out = vec![0.0; w * h];
    // Rows (axis 0 first, as scipy does: vertical pass then horizontal).
    let vertical = |y0: usize, strip: &mut [f64]| {
        for (k, row) in strip.chunks_mut(w).enumerate() {
            let y = y0 + k;
            row.iter_mut().for_each(|v| *v = 0.0);
            for (t, &wt) in taps.iter().enumerate() {
                let sy = reflect(y as isize + t as isize - r as isize, h);
                let s = &src[sy * w..sy * w + w];
                for x in 0..w {
                    row[x] += wt * s[x];
                }
            }
        }
    };
    let horizontal = |y0: usize, strip: &mut [f64], tmp: &[f64]| {
        for (k, row) in strip.chunks_mut(w).enumerate() {
            let y = y0 + k;
            let s = &tmp[y * w..y * w + w];
            for (x, o) in row.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (t, &wt) in taps.iter().enumerate() {
                    acc += wt * s[reflect(x as isize + t as isize - r as isize, w)];
                }
                *o = acc;
            }
        }
    };
    if parallel {
        tmp.par_chunks_mut(w * STRIP_ROWS)
            .enumerate()
            .for_each(|(i, s)| vertical(i * STRIP_ROWS, s));
        out.par_chunks_mut(w * STRIP_ROWS)
            .enumerate()
            .for_each(|(i, s)| horizontal(i * STRIP_ROWS, s, &tmp));
    } else {
        vertical(0, &mut tmp);
        horizontal(0, &mut out, &tmp);
    }
    out
}

fn check<P: Copy>(a: &ImageView<'_, P>, b: &ImageView<'_, P>, spec: &SsimSpec) -> Result<(usize, usize)> {
    let (w, h) = same_size(a, b)?;
    let win = 2 * spec.radius + 1;
    if w < win || h < win {
        return Err(MetricsError::TooSmall {
            width: w,
            height: h,
            window: win,
        });
    }
    Ok((w, h))
}

fn plane<P: Pixel>(v: &ImageView<'_, P>, c: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(v.width() * v.height());
    for y in 0..v.height() {
        out.extend(v.row(y).iter().map(|p| p.channel(c)));
    }
    out
}

/// SSIM map of two planes in f64.
fn ssim_plane(x: &[f64], y: &[f64], w: usize, h: usize, spec: &SsimSpec, parallel: bool) -> Vec<f64> {
    let xx: Vec<f64> = x.iter().map(|v| v * v).collect();
    let yy: Vec<f64> = y.iter().map(|v| v * v).collect();
    let xy: Vec<f64> = x.iter().zip(y).map(|(a, b)| a * b).collect();
    let ux = filter(x, w, h, &spec.taps, parallel);
    let uy = filter(y, w, h, &spec.taps, parallel);
    let uxx = filter(&xx, w, h, &spec.taps, parallel);
    let uyy = filter(&yy, w, h, &spec.taps, parallel);
    let uxy = filter(&xy, w, h, &spec.taps, parallel);
    let (c1, c2) = (spec.c1, spec.c2);
    (0..w * h)
        .map(|i| {
            let (mx, my) = (ux[i], uy[i]);
            let vx = uxx[i] - mx * mx;
            let vy = uyy[i] - my * my;
            let vxy = uxy[i] - mx * my;
            ((2.0 * mx * my + c1) * (2.0 * vxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))
        })
        .collect()
}

fn cropped_mean(map: &[f64], w: usize, h: usize, pad: usize) -> f64 {
    let mut sum = 0.0;
    for y in pad..h - pad {
        sum += map[y * w + pad..y * w + w - pad].iter().sum::<f64>();
    }
    sum / ((w - 2 * pad) * (h - 2 * pad)) as f64
}

fn ssim_map_impl(
    a: ImageView<'_, f32>,
    b: ImageView<'_, f32>,
    spec: &SsimSpec,
    dst: &mut Image<f32>,
    parallel: bool,
) -> Result<()> {
    let (w, h) = check(&a, &b, spec)?;
    let m = ssim_plane(&plane(&a, 0), &plane(&b, 0), w, h, spec, parallel);
    dst.reshape(w, h);
    for (d, s) in dst.as_mut_slice().iter_mut().zip(&m) {
        *d = *s as f32;
    }
    Ok(())
}

/// SSIM map of two grey images into `dst` (resized to the input size). Each window is computed
/// in `f64`; the map is stored as `f32`.
pub(crate) fn ssim_map_into(
    a: ImageView<'_, f32>,
    b: ImageView<'_, f32>,
    spec: &SsimSpec,
    dst: &mut Image<f32>,
) -> Result<()> {
    ssim_map_impl(a, b, spec, dst, true)
}

/// Allocating form of `ssim_map_into`.
pub fn ssim_map(a: ImageView<'_, f32>, b: ImageView<'_, f32>, spec: &SsimSpec) -> Result<Image<f32>> {
    let mut dst = Image::new(0, 0);
    ssim_map_into(a, b, spec, &mut dst)?;
    Ok(dst)
}

/// Mean SSIM per channel (one entry for grey, three for RGB).
pub fn mssim_per_channel<P: Pixel>(
    a: ImageView<'_, P>,
    b: ImageView<'_, P>,
    spec: &SsimSpec,
) -> Result<Vec<f64>> {
    let (w, h) = check(&a, &b, spec)?;
    Ok((0..P::CHANNELS)
        .map(|c| {
            let m = ssim_plane(&plane(&a, c), &plane(&b, c), w, h, spec, true);
            cropped_mean(&m, w, h, spec.radius)
        })
        .collect())
}

/// Mean SSIM (MSSIM) of two images; the mean over channels for RGB. 1 for identical images.
pub fn mssim<P: Pixel>(a: ImageView<'_, P>, b: ImageView<'_, P>, spec: &SsimSpec) -> Result<f64> {
    let v = mssim_per_channel(a, b, spec)?;
    Ok(v.iter().sum::<f64>() / v.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(w: usize, h: usize, seed: usize) -> Image<f32> {
        Image::from_fn(w, h, |x, y| {
            (((x * 31 + y * 17 + seed * 7) * 2654435761) % 251) as f32
        })
    }

    #[test]
    fn window_matches_scipy() {
        let spec = SsimOptions::with_data_range(1.0).build().unwrap();
        assert_eq!(spec.radius(), 5);
        assert_eq!(spec.taps().len(), 11);
        assert!((spec.taps().iter().sum::<f64>() - 1.0).abs() < 1e-15);
        // centre tap = 1 / Σ exp(-x²/4.5), x = -5..5
        let s: f64 = (-5..=5).map(|x: i32| (-(x * x) as f64 / 4.5).exp()).sum();
        assert!((spec.taps()[5] - 1.0 / s).abs() < 1e-15);
    }

    #[test]
    fn reflect_is_half_sample_symmetric() {
        let idx: Vec<usize> = (-3..7).map(|i| reflect(i, 4)).collect();
        assert_eq!(idx, vec![2, 1, 0, 0, 1, 2, 3, 3, 2, 1]);
    }

    #[test]
    fn identical_is_one() {
        let a = texture(30, 25, 1);
        let spec = SsimOptions::with_data_range(255.0).build().unwrap();
        assert!((mssim(a.view(), a.view(), &spec).unwrap() - 1.0).abs() < 1e-12);
        let m = ssim_map(a.view(), a.view(), &spec).unwrap();
        assert!(m.as_slice().iter().all(|&v| (v - 1.0).abs() < 1e-6));
    }

    #[test]
    fn constant_images_hand_computed() {
        // Flat images: σ = 0 everywhere, so SSIM = (2 μx μy + C1) / (μx² + μy² + C1).
        let a = Image::<f32>::filled(12, 12, 100.0);
        let b = Image::<f32>::filled(12, 12, 120.0);
        let spec = SsimOptions::with_data_range(255.0).build().unwrap();
        let c1 = (0.01f64 * 255.0).powi(2);
        let expected = (2.0 * 100.0 * 120.0 + c1) / (100.0f64 * 100.0 + 120.0 * 120.0 + c1);
        let got = mssim(a.view(), b.view(), &spec).unwrap();
        assert!((got - expected).abs() < 1e-9, "{got} vs {expected}");
    }

    #[test]
    fn symmetric_and_below_one() {
        let a = texture(40, 33, 1);
        let b = texture(40, 33, 2);
        let spec = SsimOptions::with_data_range(255.0).build().unwrap();
        let ab = mssim(a.view(), b.view(), &spec).unwrap();
        let ba = mssim(b.view(), a.view(), &spec).unwrap();
        assert!((ab - ba).abs() < 1e-12);
        assert!(ab < 0.9);
    }

    #[test]
    fn rgb_is_mean_of_channels() {
        let a = texture(20, 20, 1);
        let b = texture(20, 20, 3);
        let rgb_a = Image::from_fn(20, 20, |x, y| [a.get(x, y), b.get(x, y), 7.0]);
        let rgb_b = Image::from_fn(20, 20, |x, y| [b.get(x, y), b.get(x, y), 7.0]);
        let spec = SsimOptions::with_data_range(255.0).build().unwrap();
        let per = mssim_per_channel(rgb_a.view(), rgb_b.view(), &spec).unwrap();
        assert_eq!(per.len(), 3);
        assert!((per[1] - 1.0).abs() < 1e-12 && (per[2] - 1.0).abs() < 1e-12);
        let grey = mssim(a.view(), b.view(), &spec).unwrap();
        assert!((per[0] - grey).abs() < 1e-12);
        let all = mssim(rgb_a.view(), rgb_b.view(), &spec).unwrap();
        assert!((all - (grey + 2.0) / 3.0).abs() < 1e-12);
    }

    #[test]
    fn parallel_equals_serial() {
        let a = texture(53, 71, 4);
        let b = texture(53, 71, 5);
        let spec = SsimOptions::with_data_range(255.0).build().unwrap();
        let mut p = Image::new(0, 0);
        let mut s = Image::new(0, 0);
        ssim_map_impl(a.view(), b.view(), &spec, &mut p, true).unwrap();
        ssim_map_impl(a.view(), b.view(), &spec, &mut s, false).unwrap();
        assert_eq!(p, s);
    }

    #[test]
    fn bad_inputs() {
        let spec = SsimOptions::with_data_range(255.0).build().unwrap();
        let small = Image::<f32>::new(10, 20);
        assert!(matches!(
            mssim(small.view(), small.view(), &spec),
            Err(MetricsError::TooSmall { window: 11, .. })
        ));
        assert!(matches!(
            SsimOptions::with_data_range(0.0).build(),
            Err(MetricsError::InvalidParameter {
                name: "data_range",
                ..
            })
        ));
        assert!(matches!(
            SsimOptions::with_data_range(f64::NAN).build(),
            Err(MetricsError::InvalidParameter { .. })
        ));
    }
}
