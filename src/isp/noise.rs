//! Heteroscedastic sensor noise (the paper's eq. 24) and an estimator of its parameters.
//!
//! The paper models raw sensor noise as Poisson–Gaussian and approximates it by a heteroscedastic
//! Gaussian on the **linear** signal `y ∈ [0, 1]` (0 = black level, 1 = white level):
//!
//! ```text
//!   ŷ = y + n,   n ~ N(0, a·y + b)          (paper eq. 24)
//! ```
//!
//! `a` scales the signal-dependent (shot, Poisson) part and `b` is the signal-independent (read)
//! part. The paper's three levels are the presets [`NoiseLevel::Low`], [`NoiseLevel::Medium`] and
//! [`NoiseLevel::High`]. `a = b = 0` leaves the signal untouched.
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::isp::{add_noise, NoiseLevel};
//! let mut img = Image::<f32>::filled(64, 64, 0.5);
//! add_noise(&mut img, NoiseLevel::Medium.params(), 7).unwrap();
//! let mean = img.as_slice().iter().sum::<f32>() / 4096.0;
//! assert!((mean - 0.5).abs() < 0.01);
//! ```
//!
//! ## Reproducibility
//!
//! Noise is drawn from ChaCha8 seeded with `seed`; the image is cut into strips of
//! [`NOISE_STRIP_ROWS`] rows and strip `i` uses ChaCha stream `i`, so the result depends only on
//! the seed and the image size, never on the number of threads (a test checks parallel == serial).
//!
//! ## Estimating (a, b)
//!
//! [`estimate_noise`] works on a raw frame: each CFA plane (R, Gr, Gb, B) is taken as its own
//! image so colours never mix; a residual `r = y − mean of the 4 plane neighbours` removes locally
//! linear structure (for independent noise `Var r = (1 + 1/4)·σ²`); the plane is cut into square
//! patches whose mean signal and residual variance form (mean, variance) pairs; patches with any
//! clipped pixel (0 or white) are dropped; pairs are pooled into signal bins, and in each bin
//! patches whose variance exceeds [`EDGE_REJECT_FACTOR`] × the bin median (edges, texture) are
//! dropped; finally a weighted least-squares line `var = a·mean + b` is fitted over the bins, then
//! refitted once without bins whose residual exceeds 3 robust standard deviations.
//! This is in the spirit of Foi et al. 2008 (local mean/variance pairs on smooth regions), simpler.
//!
//! Accuracy (tests `tests/isp_reverse_noise.rs`): on a smooth synthetic 1024² frame with each
//! preset injected, `a` comes out 1–4 % low (cutting the upper tail of the patch variances at
//! 1.5× the median removes a little true noise too) and `b` within about ±12 %; on the real
//! Nikon rose frame the injected `(a, b)` is recovered within 9 % / 3 % (Low, Medium), while at
//! High `b` is ~15 % low because dark patches clip below the black level and are dropped.
//!
//! ## References
//! - W. Zhou, L. Zhang, S. Gao, X. Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern
//!   Images", eq. 24 and Sec. V (noise levels).
//! - A. Foi, M. Trimeche, V. Katkovnik, K. Egiazarian, "Practical Poissonian-Gaussian noise
//!   modeling and fitting for single-image raw-data", IEEE TIP 2008.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

/// Re-exported from `isp::quantise`, where it lives.
pub use super::quantise::linear_from_raw;
use super::quantise::raw_from_linear_mosaic;
use super::IspError;
use crate::image::Image;
use crate::raw::{CfaChannel, RawFrame};

/// Rows per noise strip; strip `i` draws from ChaCha stream `i`.
pub(crate) const NOISE_STRIP_ROWS: usize = 32;

/// Patches whose residual variance exceeds this multiple of their bin's median are treated as
/// structure (edges, texture) and dropped by the estimator.
pub(crate) const EDGE_REJECT_FACTOR: f64 = 1.5;

/// `Var(y − mean of 4 independent neighbours) = σ² (1 + 4/16)`.
const RESIDUAL_VARIANCE_GAIN: f64 = 1.25;

/// Parameters `(a, b)` of the heteroscedastic noise `N(0, a·y + b)` on `y ∈ [0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NoiseParams {
    /// Signal-dependent (shot noise) coefficient.
    pub a: f64,
    /// Signal-independent (read noise) variance.
    pub b: f64,
}

impl NoiseParams {
    /// No noise.
    pub const ZERO: NoiseParams = NoiseParams { a: 0.0, b: 0.0 };

    /// Check `a, b` finite and `>= 0`.
    pub fn validate(&self) -> Result<(), IspError> {
        for (name, v) in [("noise.a", self.a), ("noise.b", self.b)] {
            if !v.is_finite() || v < 0.0 {
                return Err(IspError::Param {
                    name,
                    value: v,
                    why: "noise parameters must be finite and >= 0",
                });
            }
        }
        Ok(())
    }

    /// Noise variance at signal level `y` (negative signal counts as 0).
    #[inline]
    pub fn variance(&self, y: f64) -> f64 {
        self.a * y.max(0.0) + self.b
    }
}

/// The paper's three noise levels (Sec. V).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum NoiseLevel {
    /// (a, b) = (9.63e-4, 3.43e-5).
    Low,
    /// (a, b) = (4.80e-3, 2.00e-4).
    Medium,
    /// (a, b) = (3.59e-2, 3.40e-3).
    High,
}

impl NoiseLevel {
    /// All presets, low to high.
    pub const ALL: [NoiseLevel; 3] = [NoiseLevel::Low, NoiseLevel::Medium, NoiseLevel::High];

    /// The preset's `(a, b)`.
    pub fn params(self) -> NoiseParams {
        match self {
            NoiseLevel::Low => NoiseParams {
                a: 9.63e-4,
                b: 3.43e-5,
            },
            NoiseLevel::Medium => NoiseParams {
                a: 4.80e-3,
                b: 2.00e-4,
            },
            NoiseLevel::High => NoiseParams {
                a: 3.59e-2,
                b: 3.40e-3,
            },
        }
    }

    /// Lower-case name (`low`, `medium`, `high`).
    pub fn name(self) -> &'static str {
        match self {
            NoiseLevel::Low => "low",
            NoiseLevel::Medium => "medium",
            NoiseLevel::High => "high",
        }
    }
}

impl std::str::FromStr for NoiseLevel {
    type Err = IspError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().as_str() {
            "low" => Ok(NoiseLevel::Low),
            "medium" => Ok(NoiseLevel::Medium),
            "high" => Ok(NoiseLevel::High),
            _ => Err(IspError::Param {
                name: "noise level",
                value: f64::NAN,
                why: "expected low, medium or high",
            }),
        }
    }
}

fn noise_strip(rows: &mut [f32], strip: usize, params: NoiseParams, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(strip as u64);
    for v in rows.iter_mut() {
        let n: f64 = StandardNormal.sample(&mut rng);
        let sd = params.variance(*v as f64).sqrt();
        *v = (*v as f64 + sd * n) as f32;
    }
}

/// Add `N(0, a·y + b)` noise to every pixel of a linear image in `[0, 1]` (no clipping), seeded.
pub fn add_noise(img: &mut Image<f32>, params: NoiseParams, seed: u64) -> Result<(), IspError> {
    params.validate()?;
    if params == NoiseParams::ZERO {
        return Ok(());
    }
    let w = img.width().max(1);
    img.as_mut_slice()
        .par_chunks_mut(w * NOISE_STRIP_ROWS)
        .enumerate()
        .for_each(|(i, rows)| noise_strip(rows, i, params, seed));
    Ok(())
}

/// Serial twin of [`add_noise`] (the test oracle for parallel == serial).
#[cfg(test)]
fn add_noise_serial(img: &mut Image<f32>, params: NoiseParams, seed: u64) {
    let w = img.width().max(1);
    for (i, rows) in img.as_mut_slice().chunks_mut(w * NOISE_STRIP_ROWS).enumerate() {
        noise_strip(rows, i, params, seed);
    }
}

/// A copy of `frame` with `N(0, a·y + b)` noise added on its linear signal, re-quantised to the
/// frame's bit depth and clipped to `[0, white]`. Pattern, levels, gains and metadata are kept.
pub fn add_noise_to_raw(frame: &RawFrame, params: NoiseParams, seed: u64) -> Result<RawFrame, IspError> {
    params.validate()?;
    let mut lin = linear_from_raw(frame);
    add_noise(&mut lin, params, seed)?;
    let mut out = raw_from_linear_mosaic(&lin, frame.cfa(), frame.bit_depth(), *frame.levels())?;
    out.wb_gains = frame.wb_gains;
    out.meta = frame.meta.clone();
    Ok(out)
}

/// Options of [`estimate_noise`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseEstimateOptions {
    /// Patch side in plane pixels (each plane is half the frame in each direction).
    pub patch: usize,
    /// Number of signal bins over `[0, 1]`.
    pub bins: usize,
    /// Minimum number of patches for a bin to be used.
    pub min_patches_per_bin: usize,
    /// Patches whose variance exceeds this multiple of their bin's median are dropped as
    /// structure (default `EDGE_REJECT_FACTOR`).
    pub reject_factor: f64,
}

impl Default for NoiseEstimateOptions {
    fn default() -> Self {
        Self {
            patch: 8,
            bins: 40,
            min_patches_per_bin: 8,
            reject_factor: EDGE_REJECT_FACTOR,
        }
    }
}

/// Result of [`estimate_noise`].
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseEstimate {
    /// Fitted parameters.
    pub params: NoiseParams,
    /// The (mean signal, noise variance, patch count) of each bin used in the final fit.
    pub bins: Vec<(f64, f64, usize)>,
}

/// Smallest number of bins a line fit is accepted on.
const MIN_BINS: usize = 3;

/// Estimate `(a, b)` of `N(0, a·y + b)` from one raw frame (see the module docs for the method).
pub fn estimate_noise(frame: &RawFrame, opts: &NoiseEstimateOptions) -> Result<NoiseEstimate, IspError> {
    if opts.patch < 2 || opts.bins == 0 {
        return Err(IspError::Param {
            name: "patch",
            value: opts.patch as f64,
            why: "patch must be >= 2 and bins >= 1",
        });
    }
    let lin = linear_from_raw(frame);
    let white = frame.levels().white;
    let cfa = frame.cfa();
    // (mean, residual variance / gain) pairs per bin
    let mut per_bin: Vec<Vec<f64>> = vec![Vec::new(); opts.bins];
    let mut mean_bin: Vec<Vec<f64>> = vec![Vec::new(); opts.bins];
    for ch in CfaChannel::ALL {
        let (ox, oy) = cfa.offset_of(ch);
        let pw = (frame.width().saturating_sub(ox)).div_ceil(2);
        let ph = (frame.height().saturating_sub(oy)).div_ceil(2);
        if pw < 3 || ph < 3 {
            continue;
        }
        let plane = |px: usize, py: usize| lin.get(ox + 2 * px, oy + 2 * py) as f64;
        let clipped = |px: usize, py: usize| {
            let v = frame.value(ox + 2 * px, oy + 2 * py);
            v == 0 || v >= white
        };
        let p = opts.patch;
        let mut py = 1;
        while py + p < ph {
            let mut px = 1;
            while px + p < pw {
                let mut any_clip = false;
                let (mut s, mut rs, mut rss) = (0.0, 0.0, 0.0);
                'patch: for y in py..py + p {
                    for x in px..px + p {
                        // neighbours y-1..y+1 exist: py >= 1 and py + p < ph
                        if clipped(x, y)
                            || clipped(x - 1, y)
                            || clipped(x + 1, y)
                            || clipped(x, y - 1)
                            || clipped(x, y + 1)
                        {
                            any_clip = true;
                            break 'patch;
                        }
                        let c = plane(x, y);
                        let r = c - 0.25
                            * (plane(x - 1, y) + plane(x + 1, y) + plane(x, y - 1) + plane(x, y + 1));
                        s += c;
                        rs += r;
                        rss += r * r;
                    }
                }
                if !any_clip {
                    let n = (p * p) as f64;
                    let mean = s / n;
                    // Divide by n, not n - 1: the residual is a zero-DC high-pass, so its patch
                    // mean has (almost) no variance and removing it costs no degree of freedom.
                    let var = (rss - rs * rs / n) / n / RESIDUAL_VARIANCE_GAIN;
                    if (0.0..1.0).contains(&mean) {
                        let bin = ((mean * opts.bins as f64) as usize).min(opts.bins - 1);
                        per_bin[bin].push(var);
                        mean_bin[bin].push(mean);
                    }
                }
                px += p;
            }
            py += p;
        }
    }
    let mut points: Vec<(f64, f64, usize)> = Vec::new();
    for (vars, means) in per_bin.iter().zip(&mean_bin) {
        if vars.len() < opts.min_patches_per_bin {
            continue;
        }
        let mut sorted = vars.clone();
        sorted.sort_by(|a, b| a.total_cmp(b));
        let median = sorted[sorted.len() / 2];
        let (mut sm, mut sv, mut k) = (0.0, 0.0, 0usize);
        for (v, m) in vars.iter().zip(means) {
            if *v <= opts.reject_factor * median {
                sm += m;
                sv += v;
                k += 1;
            }
        }
        if k >= opts.min_patches_per_bin {
            points.push((sm / k as f64, sv / k as f64, k));
        }
    }
    if points.len() < MIN_BINS {
        return Err(IspError::TooFewPatches {
            found: points.len(),
            needed: MIN_BINS,
        });
    }
    let mut params = fit_line(&points);
    // One robust refit: drop bins more than 3 robust sigmas off the line.
    let mut res: Vec<f64> = points
        .iter()
        .map(|(m, v, _)| (v - params.a * m - params.b).abs())
        .collect();
    res.sort_by(|a, b| a.total_cmp(b));
    let mad = res[res.len() / 2] * 1.4826;
    if mad > 0.0 {
        let kept: Vec<(f64, f64, usize)> = points
            .iter()
            .copied()
            .filter(|(m, v, _)| (v - params.a * m - params.b).abs() <= 3.0 * mad)
            .collect();
        if kept.len() >= MIN_BINS {
            params = fit_line(&kept);
            points = kept;
        }
    }
    Ok(NoiseEstimate { params, bins: points })
}

/// Weighted least squares `v = a·m + b`, weights = patch counts.
fn fit_line(points: &[(f64, f64, usize)]) -> NoiseParams {
    let (mut sw, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(m, v, k) in points {
        let w = k as f64;
        sw += w;
        sx += w * m;
        sy += w * v;
        sxx += w * m * m;
        sxy += w * m * v;
    }
    let den = sw * sxx - sx * sx;
    if den.abs() < f64::EPSILON {
        return NoiseParams { a: 0.0, b: sy / sw };
    }
    let a = (sw * sxy - sx * sy) / den;
    let b = (sy - a * sx) / sw;
    NoiseParams { a, b }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Image<f32> {
        Image::from_fn(w, h, |x, y| {
            0.1 + 0.8 * (x as f32 / w as f32) * 0.5 + 0.4 * (y as f32 / h as f32)
        })
    }

    #[test]
    fn zero_noise_is_identity() {
        let orig = ramp(37, 70);
        let mut img = orig.clone();
        add_noise(&mut img, NoiseParams::ZERO, 3).unwrap();
        assert_eq!(img, orig);
    }

    #[test]
    fn seeded_noise_repeats_and_seeds_differ() {
        let mut a = ramp(40, 80);
        let mut b = a.clone();
        let mut c = a.clone();
        add_noise(&mut a, NoiseLevel::High.params(), 11).unwrap();
        add_noise(&mut b, NoiseLevel::High.params(), 11).unwrap();
        add_noise(&mut c, NoiseLevel::High.params(), 12).unwrap();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn parallel_equals_serial() {
        let mut a = ramp(53, 211);
        let mut b = a.clone();
        add_noise(&mut a, NoiseLevel::Medium.params(), 5).unwrap();
        add_noise_serial(&mut b, NoiseLevel::Medium.params(), 5);
        assert_eq!(a, b);
    }

    #[test]
    fn variance_follows_a_y_plus_b() {
        // flat y = 0.4, 256x256 samples: sample variance within 3% of a*0.4 + b
        for level in NoiseLevel::ALL {
            let p = level.params();
            let mut img = Image::<f32>::filled(256, 256, 0.4);
            add_noise(&mut img, p, 99).unwrap();
            let n = img.as_slice().len() as f64;
            let mean = img.as_slice().iter().map(|&v| v as f64).sum::<f64>() / n;
            let var = img
                .as_slice()
                .iter()
                .map(|&v| (v as f64 - mean).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            let want = p.variance(0.4);
            assert!((var / want - 1.0).abs() < 0.03, "{level:?}: {var} vs {want}");
            assert!((mean - 0.4).abs() < 4.0 * (want / n).sqrt());
        }
    }

    #[test]
    fn rejects_negative_params() {
        let mut img = Image::<f32>::filled(4, 4, 0.5);
        assert!(matches!(
            add_noise(&mut img, NoiseParams { a: -1.0, b: 0.0 }, 0),
            Err(IspError::Param { name: "noise.a", .. })
        ));
        assert!("loud".parse::<NoiseLevel>().is_err());
        assert_eq!("HIGH".parse::<NoiseLevel>().unwrap(), NoiseLevel::High);
    }

    #[test]
    fn raw_frames_zero_noise_identity_and_metadata_kept() {
        use crate::raw::{Cfa, Levels};
        let px: Vec<u8> = (0..64).map(|i| 20 + i as u8 * 3).collect();
        let f = RawFrame::from_u8(8, 8, px, Cfa::Bggr, Levels::uniform(16, 250))
            .unwrap()
            .with_wb_gains([1.5, 1.0, 2.0]);
        assert_eq!(add_noise_to_raw(&f, NoiseParams::ZERO, 1).unwrap(), f);
        let n = add_noise_to_raw(&f, NoiseLevel::High.params(), 1).unwrap();
        assert_ne!(n.to_u16_vec(), f.to_u16_vec());
        assert_eq!(
            (n.cfa(), n.bit_depth(), *n.levels(), n.wb_gains),
            (f.cfa(), 8, *f.levels(), f.wb_gains)
        );
        assert!(matches!(n.pixels(), crate::raw::RawPixels::U8(_)));
        assert!(n.to_u16_vec().iter().all(|&v| v <= 250));
    }

    #[test]
    fn fit_line_recovers_exact_line() {
        let pts: Vec<(f64, f64, usize)> = (0..5)
            .map(|i| (i as f64 * 0.2, 0.01 * i as f64 * 0.2 + 0.001, 10))
            .collect();
        let p = fit_line(&pts);
        assert!((p.a - 0.01).abs() < 1e-12 && (p.b - 0.001).abs() < 1e-12);
    }
}
