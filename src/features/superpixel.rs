//! Super-pixel scale space: Gaussian blur, octave steps and plane splitting that keep a Bayer
//! mosaic intact (the resize is the crate's one, [`crate::resize`]).
//!
//! # Overview
//!
//! Blurring or resizing a mosaic as if it were a grey image mixes colours: the result is no longer
//! a valid mosaic. The paper (§III-B, Figs. 7 and 11) groups each 2x2 tile into a **super-pixel**
//! and processes the four colour planes — R, G1 (= `Gr`), G2 (= `Gb`) and B, each a
//! half-resolution image — separately, then re-interleaves them. The result is again a mosaic of
//! the same pattern, so mosaic gradients, HOG and SIFT can run on every level of the pyramid.
//!
//! ```
//! use mosaicd::features::superpixel::{blur_mosaic, GaussianKernel};
//! use mosaicd::resize::resize_mosaic;
//! use mosaicd::image::Image;
//! // A flat RGGB mosaic: R = 0.8, G = 0.5, B = 0.2.
//! let m = Image::from_fn(16, 12, |x, y| match (x & 1, y & 1) {
//!     (0, 0) => 0.8f32,
//!     (1, 1) => 0.2,
//!     _ => 0.5,
//! });
//! let mut blurred = Image::new(0, 0);
//! blur_mosaic(m.view(), &GaussianKernel::from_ksize(3).unwrap(), &mut blurred).unwrap();
//! assert!((blurred.get(0, 0) - 0.8).abs() < 1e-6); // colours do not mix
//! let mut half = Image::new(0, 0);
//! resize_mosaic(m.view(), 8, 6, &mut half).unwrap();
//! assert!((half.get(1, 1) - 0.2).abs() < 1e-6); // still RGGB
//! ```
//!
//! # The math
//!
//! For a mosaic `M` of size W x H (both even) and tile position `p = (px, py) ∈ {0,1}²`, the plane
//! `P_p(i, j) = M(2i + px, 2j + py)` has size W/2 x H/2. An operator `T` (blur, resize) acts on
//! each plane, `P'_p = T(P_p)`, and the output mosaic is `M'(2i + px, 2j + py) = P'_p(i, j)`.
//!
//! * **Gaussian blur** uses the separable kernel `g(k) ∝ exp(−(k − (a−1)/2)² / 2σ²)`, `k = 0..a`.
//!   Given a kernel size `a`, `σ = 0.3((a − 1)·0.5 − 1) + 0.8` (paper eq. 26, OpenCV's
//!   `getGaussianKernel` rule); given σ, `a = round(8σ + 1) | 1` (OpenCV's rule for float images).
//!   **σ is in plane (super-pixel) units**: one plane pixel spans two mosaic pixels, so a blur of
//!   σ_m mosaic pixels is a plane blur of σ_m / 2.
//! * **Resize** ([`crate::resize::resize_mosaic`]) is bilinear with half-pixel centres,
//!   `x_src = (x_dst + ½)·(W_src / W_dst) − ½`, clamped at the borders: `cv2.resize(...,
//!   INTER_LINEAR)` on float data, to a few ulps.
//! * **Borders** use reflect-101 (`dcb|abcd|cba`), OpenCV's default, applied per plane: the mirror
//!   never crosses colours.
//!
//! # Where we differ
//!
//! * From OpenCV: [`GaussianKernel::from_ksize`] always uses the σ formula (paper eq. 26). OpenCV
//!   4.x's `GaussianBlur(ksize, sigma=0)` uses fixed tables in 1/256 steps for sizes 1 to 9 (3 →
//!   `[¼, ½, ¼]`, binomial up to 7, a quantised σ = 1.7 Gaussian for 9);
//!   [`GaussianKernel::from_ksize_opencv`] reproduces that when parity is wanted.
//! * Resizing planes independently keeps each plane's own sampling grid: after resizing by a factor
//!   `s`, the half-super-pixel offset between, say, R and B is still one output pixel, which maps to
//!   `s` input pixels rather than one. The paper accepts this; it is at most a fraction of a pixel
//!   at the scale steps used for detection (1.05) and exactly right for factor 2.
//! * Mosaics with an odd width or height are refused ([`SuperPixelError::OddSize`]): crop to even
//!   size first (an even-offset crop keeps the pattern).
//!
//! # References
//!
//! W. Zhou, L. Zhang, S. Gao, X. Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern
//! Images", §III-B. OpenCV `imgproc/src/smooth.dispatch.cpp` (`getGaussianKernel`).

use rayon::prelude::*;

use crate::image::{Image, ImageView};

/// Rows per rayon task in the separable filters.
const ROWS_PER_TASK: usize = 16;

/// Largest kernel size we accept (σ ≈ 50 plane pixels); larger is almost certainly a unit error.
const MAX_KSIZE: usize = 401;

/// OpenCV 4.x's fixed kernels for sizes 1, 3, 5, 7 and 9 when σ ≤ 0, in 1/256 units
/// (`getGaussianKernelBitExact`: binomial for 3–7, a quantised σ = 1.7 Gaussian for 9).
const SMALL_GAUSSIAN_TAB_256: [&[f32]; 5] = [
    &[256.0],
    &[64.0, 128.0, 64.0],
    &[16.0, 64.0, 96.0, 64.0, 16.0],
    &[8.0, 28.0, 56.0, 72.0, 56.0, 28.0, 8.0],
    &[4.0, 13.0, 30.0, 51.0, 60.0, 51.0, 30.0, 13.0, 4.0],
];

/// Errors from super-pixel operations.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SuperPixelError {
    /// A mosaic operation got an odd width or height.
    #[error("mosaic is {width}x{height}: super-pixel operations need even width and height (crop at an even offset first)")]
    OddSize {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// The image (or requested output) is too small for the operation.
    #[error("{what}: {width}x{height} is smaller than the minimum {min_width}x{min_height}")]
    TooSmall {
        /// What was too small.
        what: &'static str,
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Minimum width.
        min_width: usize,
        /// Minimum height.
        min_height: usize,
    },
    /// A Gaussian kernel parameter is out of range.
    #[error("invalid Gaussian kernel: size {ksize}, sigma {sigma} (size must be odd and 1..={MAX_KSIZE}, sigma positive and finite)")]
    Kernel {
        /// Kernel size.
        ksize: usize,
        /// Sigma.
        sigma: f64,
    },
    /// The four planes do not have the same size.
    #[error("planes differ in size: {sizes:?}")]
    PlaneSizes {
        /// Sizes of the planes.
        sizes: [(usize, usize); 4],
    },
}

/// σ of a Gaussian of kernel size `a` (paper eq. 26): `0.3((a − 1)·0.5 − 1) + 0.8`.
pub fn sigma_from_ksize(a: usize) -> f64 {
    0.3 * ((a as f64 - 1.0) * 0.5 - 1.0) + 0.8
}

/// A normalised, symmetric 1-D Gaussian kernel.
#[derive(Debug, Clone, PartialEq)]
pub struct GaussianKernel {
    sigma: f64,
    taps: Vec<f32>,
}

impl GaussianKernel {
    fn from_parts(ksize: usize, sigma: f64) -> Result<Self, SuperPixelError> {
        if ksize.is_multiple_of(2) || ksize > MAX_KSIZE || !(sigma.is_finite() && sigma > 0.0) {
            return Err(SuperPixelError::Kernel { ksize, sigma });
        }
        let c = (ksize as f64 - 1.0) * 0.5;
        let scale2 = -0.5 / (sigma * sigma);
        let raw: Vec<f64> = (0..ksize)
            .map(|i| (scale2 * (i as f64 - c).powi(2)).exp())
            .collect();
        let sum: f64 = raw.iter().sum();
        Ok(Self {
            sigma,
            taps: raw.iter().map(|v| (v / sum) as f32).collect(),
        })
    }

    /// Kernel of size `a` (odd) with σ from [`sigma_from_ksize`] (paper eq. 26).
    pub fn from_ksize(a: usize) -> Result<Self, SuperPixelError> {
        if a == 1 {
            return Ok(Self {
                sigma: sigma_from_ksize(1).max(f64::MIN_POSITIVE),
                taps: vec![1.0],
            });
        }
        Self::from_parts(a, sigma_from_ksize(a))
    }

    /// Exactly OpenCV 4.x's `getGaussianKernel(a, 0, CV_32F)`: fixed tables in 1/256 steps for
    /// sizes 1..=9, the σ formula above that.
    pub fn from_ksize_opencv(a: usize) -> Result<Self, SuperPixelError> {
        if a % 2 == 1 && a <= 9 {
            return Ok(Self {
                sigma: sigma_from_ksize(a),
                taps: SMALL_GAUSSIAN_TAB_256[a >> 1].iter().map(|v| v / 256.0).collect(),
            });
        }
        Self::from_ksize(a)
    }

    /// Kernel for standard deviation `sigma` with OpenCV's size rule for float images,
    /// `round(8σ + 1) | 1`.
    pub fn from_sigma(sigma: f64) -> Result<Self, SuperPixelError> {
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(SuperPixelError::Kernel { ksize: 0, sigma });
        }
        let ksize = ((sigma * 4.0 * 2.0 + 1.0).round() as usize) | 1;
        Self::from_parts(ksize, sigma)
    }

    /// Kernel of explicit size and σ (OpenCV `getGaussianKernel(ksize, sigma)` with σ > 0).
    pub fn with_size(ksize: usize, sigma: f64) -> Result<Self, SuperPixelError> {
        Self::from_parts(ksize, sigma)
    }

    /// Standard deviation.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// The taps, summing to 1.
    pub fn taps(&self) -> &[f32] {
        &self.taps
    }

    /// Half width: taps reach `radius` pixels either side.
    pub fn radius(&self) -> usize {
        self.taps.len() / 2
    }
}

/// Reflect-101 index: `dcb|abcd|cba`. Works for any offset, however far outside.
#[inline]
fn reflect101(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let n = n as isize;
    let period = 2 * (n - 1);
    let mut m = i.rem_euclid(period);
    if m >= n {
        m = period - m;
    }
    m as usize
}

fn check_nonempty(what: &'static str, w: usize, h: usize) -> Result<(), SuperPixelError> {
    if w == 0 || h == 0 {
        return Err(SuperPixelError::TooSmall {
            what,
            width: w,
            height: h,
            min_width: 1,
            min_height: 1,
        });
    }
    Ok(())
}

/// Gaussian blur of one plane, reflect-101 borders — `cv2.GaussianBlur` on float data.
///
/// `dst` is reshaped to the size of `src`.
pub fn gaussian_blur(
    src: ImageView<f32>,
    k: &GaussianKernel,
    dst: &mut Image<f32>,
) -> Result<(), SuperPixelError> {
    gaussian_blur_impl(src, k, dst, true)
}

fn gaussian_blur_impl(
    src: ImageView<f32>,
    k: &GaussianKernel,
    dst: &mut Image<f32>,
    parallel: bool,
) -> Result<(), SuperPixelError> {
    let (w, h) = (src.width(), src.height());
    check_nonempty("gaussian_blur input", w, h)?;
    let taps = k.taps();
    let r = k.radius() as isize;
    // Horizontal pass into a temporary, then vertical pass into dst.
    let mut tmp = Image::<f32>::new(w, h);
    let hpass = |y: usize, out: &mut [f32]| {
        let row = src.row(y);
        for (x, o) in out.iter_mut().enumerate() {
            let mut acc = 0.0f32;
            let xi = x as isize;
            if xi >= r && xi + r < w as isize {
                let s = &row[(xi - r) as usize..(xi + r + 1) as usize];
                for (t, v) in taps.iter().zip(s) {
                    acc += t * v;
                }
            } else {
                for (j, t) in taps.iter().enumerate() {
                    acc += t * row[reflect101(xi + j as isize - r, w)];
                }
            }
            *o = acc;
        }
    };
    if parallel {
        tmp.as_mut_slice()
            .par_chunks_mut(w * ROWS_PER_TASK)
            .enumerate()
            .for_each(|(ci, chunk)| {
                for (ri, out) in chunk.chunks_mut(w).enumerate() {
                    hpass(ci * ROWS_PER_TASK + ri, out);
                }
            });
    } else {
        for (y, out) in tmp.as_mut_slice().chunks_mut(w).enumerate() {
            hpass(y, out);
        }
    }
    dst.reshape(w, h);
    let tmpv = tmp.view();
    let vpass = |y: usize, out: &mut [f32]| {
        out.fill(0.0);
        for (j, t) in taps.iter().enumerate() {
            let sy = reflect101(y as isize + j as isize - r, h);
            for (o, v) in out.iter_mut().zip(tmpv.row(sy)) {
                *o += t * v;
            }
        }
    };
    if parallel {
        dst.as_mut_slice()
            .par_chunks_mut(w * ROWS_PER_TASK)
            .enumerate()
            .for_each(|(ci, chunk)| {
                for (ri, out) in chunk.chunks_mut(w).enumerate() {
                    vpass(ci * ROWS_PER_TASK + ri, out);
                }
            });
    } else {
        for (y, out) in dst.as_mut_slice().chunks_mut(w).enumerate() {
            vpass(y, out);
        }
    }
    Ok(())
}

/// Keep every other pixel of every other row (SIFT's octave step, OpenCV `INTER_NEAREST` to half
/// size). Output is `floor(w/2) x floor(h/2)`.
pub fn downsample2(src: ImageView<f32>, dst: &mut Image<f32>) -> Result<(), SuperPixelError> {
    let (w, h) = (src.width() / 2, src.height() / 2);
    check_nonempty("downsample2 output", w, h)?;
    dst.reshape(w, h);
    for y in 0..h {
        let s = src.row(2 * y);
        for (x, o) in dst.row_mut(y).iter_mut().enumerate() {
            *o = s[2 * x];
        }
    }
    Ok(())
}

fn check_mosaic(w: usize, h: usize) -> Result<(), SuperPixelError> {
    if w % 2 == 1 || h % 2 == 1 {
        return Err(SuperPixelError::OddSize { width: w, height: h });
    }
    if w < 2 || h < 2 {
        return Err(SuperPixelError::TooSmall {
            what: "mosaic",
            width: w,
            height: h,
            min_width: 2,
            min_height: 2,
        });
    }
    Ok(())
}

/// Split a mosaic into its four half-resolution planes, ordered by tile position
/// (0,0), (1,0), (0,1), (1,1). Use [`crate::raw::Cfa::tile`] to name them (R, Gr, Gb, B).
pub fn planes_from_mosaic<T: Copy + Default>(src: ImageView<T>) -> Result<[Image<T>; 4], SuperPixelError> {
    let (w, h) = (src.width(), src.height());
    check_mosaic(w, h)?;
    let (pw, ph) = (w / 2, h / 2);
    let mut planes: [Image<T>; 4] = std::array::from_fn(|_| Image::new(pw, ph));
    for j in 0..ph {
        let r0 = src.row(2 * j);
        let r1 = src.row(2 * j + 1);
        let [p0, p1, p2, p3] = &mut planes;
        let (o0, o1, o2, o3) = (p0.row_mut(j), p1.row_mut(j), p2.row_mut(j), p3.row_mut(j));
        for i in 0..pw {
            o0[i] = r0[2 * i];
            o1[i] = r0[2 * i + 1];
            o2[i] = r1[2 * i];
            o3[i] = r1[2 * i + 1];
        }
    }
    Ok(planes)
}

/// Interleave four equally sized planes (tile order (0,0), (1,0), (0,1), (1,1)) into a mosaic.
pub fn mosaic_from_planes<T: Copy + Default>(planes: &[Image<T>; 4]) -> Result<Image<T>, SuperPixelError> {
    let mut out = Image::new(0, 0);
    mosaic_from_planes_into(planes, &mut out)?;
    Ok(out)
}

/// [`mosaic_from_planes`] into an existing buffer (reshaped as needed).
pub fn mosaic_from_planes_into<T: Copy + Default>(
    planes: &[Image<T>; 4],
    dst: &mut Image<T>,
) -> Result<(), SuperPixelError> {
    let sizes = [
        planes[0].dimensions(),
        planes[1].dimensions(),
        planes[2].dimensions(),
        planes[3].dimensions(),
    ];
    if sizes.iter().any(|s| *s != sizes[0]) {
        return Err(SuperPixelError::PlaneSizes { sizes });
    }
    let (pw, ph) = sizes[0];
    check_nonempty("planes", pw, ph)?;
    dst.reshape(2 * pw, 2 * ph);
    for j in 0..ph {
        let (a, b, c, d) = (
            planes[0].row(j),
            planes[1].row(j),
            planes[2].row(j),
            planes[3].row(j),
        );
        {
            let r0 = dst.row_mut(2 * j);
            for i in 0..pw {
                r0[2 * i] = a[i];
                r0[2 * i + 1] = b[i];
            }
        }
        let r1 = dst.row_mut(2 * j + 1);
        for i in 0..pw {
            r1[2 * i] = c[i];
            r1[2 * i + 1] = d[i];
        }
    }
    Ok(())
}

/// Gaussian blur of a mosaic on the super-pixel grid: each plane is blurred by `k` (σ in plane
/// units), so the output is a mosaic of the same pattern.
pub fn blur_mosaic(
    src: ImageView<f32>,
    k: &GaussianKernel,
    dst: &mut Image<f32>,
) -> Result<(), SuperPixelError> {
    let planes = planes_from_mosaic(src)?;
    let mut out: [Image<f32>; 4] = std::array::from_fn(|_| Image::new(0, 0));
    // The four planes in parallel; each blur is itself parallel over rows.
    out.par_iter_mut()
        .zip(planes.par_iter())
        .try_for_each(|(o, p)| gaussian_blur(p.view(), k, o))?;
    mosaic_from_planes_into(&out, dst)
}

/// Keep every other super-pixel (the SIFT octave step on a mosaic). Output is
/// `2·floor(w/4) x 2·floor(h/4)`, a mosaic of the same pattern.
pub fn downsample2_mosaic(src: ImageView<f32>, dst: &mut Image<f32>) -> Result<(), SuperPixelError> {
    let (w, h) = (src.width(), src.height());
    check_mosaic(w, h)?;
    let (pw, ph) = (w / 4, h / 4);
    if pw == 0 || ph == 0 {
        return Err(SuperPixelError::TooSmall {
            what: "downsample2_mosaic input",
            width: w,
            height: h,
            min_width: 4,
            min_height: 4,
        });
    }
    dst.reshape(2 * pw, 2 * ph);
    for j in 0..ph {
        for dy in 0..2 {
            let s = src.row(4 * j + dy);
            let o = dst.row_mut(2 * j + dy);
            for i in 0..pw {
                o[2 * i] = s[4 * i];
                o[2 * i + 1] = s[4 * i + 1];
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random(w: usize, h: usize, seed: u64) -> Image<f32> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        Image::from_fn(w, h, |_, _| rng.random::<f32>())
    }

    #[test]
    fn sigma_formula_matches_paper() {
        assert!((sigma_from_ksize(3) - 0.8).abs() < 1e-12);
        assert!((sigma_from_ksize(5) - 1.1).abs() < 1e-12);
        assert!((sigma_from_ksize(9) - 1.7).abs() < 1e-12);
    }

    #[test]
    fn kernels_are_normalised_and_symmetric() {
        for k in [
            GaussianKernel::from_ksize(3).unwrap(),
            GaussianKernel::from_ksize(9).unwrap(),
            GaussianKernel::from_sigma(1.6).unwrap(),
            GaussianKernel::from_ksize_opencv(5).unwrap(),
        ] {
            let s: f32 = k.taps().iter().sum();
            assert!((s - 1.0).abs() < 1e-6);
            let t = k.taps();
            for i in 0..t.len() {
                assert_eq!(t[i], t[t.len() - 1 - i]);
            }
        }
        assert_eq!(GaussianKernel::from_sigma(1.6).unwrap().taps().len(), 15); // round(13.8) | 1
        assert_eq!(
            GaussianKernel::from_ksize_opencv(3).unwrap().taps(),
            &[0.25, 0.5, 0.25]
        );
        assert!(GaussianKernel::from_ksize(4).is_err());
        assert!(GaussianKernel::from_sigma(-1.0).is_err());
        assert!(GaussianKernel::from_sigma(f64::NAN).is_err());
    }

    #[test]
    fn reflect101_matches_opencv_convention() {
        // n = 4: ... c b | a b c d | c b a ...
        let idx: Vec<usize> = (-3..7).map(|i| reflect101(i, 4)).collect();
        assert_eq!(idx, vec![3, 2, 1, 0, 1, 2, 3, 2, 1, 0]);
        assert_eq!(reflect101(-5, 1), 0);
    }

    #[test]
    fn blur_hand_computed() {
        // 1-D impulse in a 5x1 image with kernel [1/4, 1/2, 1/4].
        let img = Image::from_vec(5, 1, vec![0.0, 0.0, 4.0, 0.0, 0.0]).unwrap();
        let k = GaussianKernel::from_ksize_opencv(3).unwrap();
        let mut out = Image::new(0, 0);
        gaussian_blur(img.view(), &k, &mut out).unwrap();
        assert_eq!(out.as_slice(), &[0.0, 1.0, 2.0, 1.0, 0.0]);
        // Reflect-101 at the border: [4, 0, 0] -> x0 = (0*? ) = 1/4*0(ref x1) + 1/2*4 + 1/4*0 = 2
        let img = Image::from_vec(3, 1, vec![4.0, 0.0, 0.0]).unwrap();
        gaussian_blur(img.view(), &k, &mut out).unwrap();
        assert_eq!(out.as_slice(), &[2.0, 1.0, 0.0]);
    }

    #[test]
    fn flat_mosaic_stays_flat_per_colour() {
        let m = Image::from_fn(20, 14, |x, y| [0.9f32, 0.5, 0.4, 0.1][(y & 1) * 2 + (x & 1)]);
        let mut out = Image::new(0, 0);
        blur_mosaic(m.view(), &GaussianKernel::from_ksize(5).unwrap(), &mut out).unwrap();
        for y in 0..14 {
            for x in 0..20 {
                assert!((out.get(x, y) - m.get(x, y)).abs() < 1e-6);
            }
        }
        crate::resize::resize_mosaic(m.view(), 30, 10, &mut out).unwrap();
        assert_eq!(out.dimensions(), (30, 10));
        for y in 0..10 {
            for x in 0..30 {
                assert!((out.get(x, y) - m.get(x & 1, y & 1)).abs() < 1e-6);
            }
        }
        downsample2_mosaic(m.view(), &mut out).unwrap();
        assert_eq!(out.dimensions(), (10, 6));
        for y in 0..6 {
            for x in 0..10 {
                assert_eq!(out.get(x, y), m.get(x & 1, y & 1));
            }
        }
    }

    #[test]
    fn planes_round_trip() {
        let m = random(12, 8, 1);
        let p = planes_from_mosaic(m.view()).unwrap();
        assert_eq!(p[3].get(2, 1), m.get(5, 3));
        assert_eq!(mosaic_from_planes(&p).unwrap(), m);
    }

    #[test]
    fn mosaic_blur_equals_plane_blur() {
        let m = random(32, 24, 2);
        let k = GaussianKernel::from_sigma(1.3).unwrap();
        let mut out = Image::new(0, 0);
        blur_mosaic(m.view(), &k, &mut out).unwrap();
        let p = planes_from_mosaic(m.view()).unwrap();
        let mut b = Image::new(0, 0);
        gaussian_blur(p[2].view(), &k, &mut b).unwrap();
        let po = planes_from_mosaic(out.view()).unwrap();
        assert_eq!(po[2], b);
    }

    #[test]
    fn refuses_odd_and_tiny() {
        let m = random(7, 8, 3);
        let mut out = Image::new(0, 0);
        assert!(matches!(
            blur_mosaic(m.view(), &GaussianKernel::from_ksize(3).unwrap(), &mut out),
            Err(SuperPixelError::OddSize { .. })
        ));
        let m = random(2, 2, 3);
        assert!(matches!(
            downsample2_mosaic(m.view(), &mut out),
            Err(SuperPixelError::TooSmall { .. })
        ));
        let empty = Image::<f32>::new(0, 0);
        assert!(gaussian_blur(empty.view(), &GaussianKernel::from_ksize(3).unwrap(), &mut out).is_err());
    }

    #[test]
    fn parallel_equals_serial() {
        let m = random(101, 67, 4);
        let k = GaussianKernel::from_sigma(2.0).unwrap();
        let (mut a, mut b) = (Image::new(0, 0), Image::new(0, 0));
        gaussian_blur_impl(m.view(), &k, &mut a, true).unwrap();
        gaussian_blur_impl(m.view(), &k, &mut b, false).unwrap();
        assert_eq!(a, b);
    }
}
