//! Gradient magnitude similarity (GMS) and its deviation (GMSD).
//!
//! Two functions with two different jobs:
//!
//! * [`gms_map`] / [`gmsd`] compare two **gradient magnitude maps** that were already computed
//!   (the paper's eqs. 21–23): this is how the paper scores the mosaic gradient against the grey
//!   image gradient (Table III, Fig. 9). Magnitudes are expected on [0, 1] and the stabilising
//!   constant defaults to the paper's `c = 0.0026` ([`PAPER_C`]).
//! * [`gmsd_xue2014`] is the image-quality index of Xue et al. 2014 between two **images**, exactly
//!   as their reference MATLAB code computes it (2x2 average then downsample by 2, Prewitt/3
//!   gradients, `T = 170` on 0–255 luminance). It is used for the demosaicing table (Table IV).
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::metrics::{gms_stats, gmsd, PAPER_C};
//! let g = Image::<f32>::from_fn(8, 8, |x, y| (x + y) as f32 / 14.0);
//! assert_eq!(gmsd(g.view(), g.view(), PAPER_C).unwrap(), 0.0);
//! let half = g.map(|v| v * 0.5);
//! let s = gms_stats(g.view(), half.view(), PAPER_C).unwrap();
//! assert!(s.gmsm < 1.0 && s.gmsd > 0.0);
//! ```
//!
//! ## Math (paper eqs. 21–23, after Xue et al. 2014)
//! ```text
//! GMS(i) = (2 m_r(i) m_d(i) + c) / (m_r(i)² + m_d(i)² + c)        (21)
//! GMSM   = (1/N) Σ_i GMS(i)                                         (22)
//! GMSD   = sqrt( (1/N) Σ_i (GMS(i) − GMSM)² )                       (23)
//! ```
//! GMS is 1 where the magnitudes agree and falls towards 0 where they differ; GMSD (the population
//! standard deviation of the map) is 0 for identical maps and grows with *non-uniform* disagreement.
//! A uniform scale change of all magnitudes gives a low GMSD, by design.
//!
//! ## Xue et al. 2014 reference implementation ([`gmsd_xue2014`])
//! ```text
//! Y   = luminance on 0..255 (the caller converts RGB with BT.601 weights, as GMSD.m does)
//! Y'  = conv2(Y, ones(2)/4, 'same') sampled at (0, 2, 4, …)²  → the mean of each 2x2 block
//! g   = sqrt( conv2(Y', dx, 'same')² + conv2(Y', dxᵀ, 'same')² ),  dx = [1 0 −1; 1 0 −1; 1 0 −1]/3
//! GMS = (2 g_r g_d + T) / (g_r² + g_d² + T),  T = 170
//! score = std2(GMS)
//! ```
//! `conv2(…, 'same')` pads with zeros, so the outermost ring of `g` sees the zero border exactly as in
//! MATLAB (and an odd width/height averages its last column/row with zero). MATLAB's `std2` divides by
//! `N − 1`; we follow the reference code there (the difference from the population deviation is a
//! factor `sqrt(N/(N−1))`, 1.000005 for a 768x512 input).
//!
//! ## Deviations
//! None from the formulas. The paper does not state the standard deviation convention for eq. 23;
//! we use the population form written in the equation.
//!
//! ## References
//! W. Xue, L. Zhang, X. Mou, A. C. Bovik, "Gradient Magnitude Similarity Deviation: A Highly
//! Efficient Perceptual Image Quality Index", IEEE TIP 23(2), 2014, and its `GMSD.m`.
//! Zhou, Zhang, Gao, Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern Images", eqs. 21–23.

use super::{positive, same_size, MetricsError, Result};
use crate::image::{Image, ImageView};
use rayon::prelude::*;

/// The paper's stabilising constant for magnitudes on [0, 1] (eq. 21): 170 / 255² ≈ 0.0026.
pub const PAPER_C: f64 = 0.0026;

/// Xue et al.'s constant `T` for luminance on 0..255.
pub(crate) const XUE_T: f64 = 170.0;

/// Rows per rayon task when computing the GMS map.
const STRIP_ROWS: usize = 32;

/// Mean and deviation of a GMS map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GmsStats {
    /// Gradient magnitude similarity mean (eq. 22), 1 for identical maps.
    pub gmsm: f64,
    /// Gradient magnitude similarity deviation (eq. 23), 0 for identical maps.
    pub gmsd: f64,
}

#[inline]
fn gms(a: f64, b: f64, c: f64) -> f64 {
    (2.0 * a * b + c) / (a * a + b * b + c)
}

fn gms_rows(a: &ImageView<'_, f32>, b: &ImageView<'_, f32>, c: f64, y0: usize, out: &mut [f32]) {
    let w = a.width();
    for (k, row) in out.chunks_mut(w).enumerate() {
        let (ra, rb) = (a.row(y0 + k), b.row(y0 + k));
        for x in 0..w {
            row[x] = gms(f64::from(ra[x]), f64::from(rb[x]), c) as f32;
        }
    }
}

fn gms_map_impl(
    a: ImageView<'_, f32>,
    b: ImageView<'_, f32>,
    c: f64,
    dst: &mut Image<f32>,
    parallel: bool,
) -> Result<()> {
    let (w, h) = same_size(&a, &b)?;
    positive("c", c)?;
    dst.reshape(w, h);
    if parallel {
        dst.as_mut_slice()
            .par_chunks_mut(w * STRIP_ROWS)
            .enumerate()
            .for_each(|(i, strip)| gms_rows(&a, &b, c, i * STRIP_ROWS, strip));
    } else {
        gms_rows(&a, &b, c, 0, dst.as_mut_slice());
    }
    Ok(())
}

/// GMS map (eq. 21) of a reference magnitude map `m_r` and a distorted one `m_d` into `dst`
/// (resized to the input size). Parallel over row strips.
pub fn gms_map_into(
    m_r: ImageView<'_, f32>,
    m_d: ImageView<'_, f32>,
    c: f64,
    dst: &mut Image<f32>,
) -> Result<()> {
    gms_map_impl(m_r, m_d, c, dst, true)
}

/// Allocating form of [`gms_map_into`].
pub fn gms_map(m_r: ImageView<'_, f32>, m_d: ImageView<'_, f32>, c: f64) -> Result<Image<f32>> {
    let mut dst = Image::new(0, 0);
    gms_map_into(m_r, m_d, c, &mut dst)?;
    Ok(dst)
}

/// Mean and population standard deviation of any map, accumulated in `f64` (two passes).
fn mean_std(values: impl Iterator<Item = f64> + Clone, n: usize, ddof: usize) -> (f64, f64) {
    let mean = values.clone().sum::<f64>() / n as f64;
    let ss: f64 = values.map(|v| (v - mean) * (v - mean)).sum();
    let denom = n.saturating_sub(ddof).max(1) as f64;
    (mean, (ss / denom).sqrt())
}

/// GMSM and GMSD (eqs. 22–23) of two gradient magnitude maps, with the GMS values kept in `f64`.
pub fn gms_stats(m_r: ImageView<'_, f32>, m_d: ImageView<'_, f32>, c: f64) -> Result<GmsStats> {
    let (w, h) = same_size(&m_r, &m_d)?;
    positive("c", c)?;
    let it = (0..h).flat_map(|y| {
        let (ra, rb) = (m_r.row(y), m_d.row(y));
        (0..w).map(move |x| gms(f64::from(ra[x]), f64::from(rb[x]), c))
    });
    let (gmsm, gmsd) = mean_std(it, w * h, 0);
    Ok(GmsStats { gmsm, gmsd })
}

/// GMSD (eq. 23) of two gradient magnitude maps; 0 for identical maps.
pub fn gmsd(m_r: ImageView<'_, f32>, m_d: ImageView<'_, f32>, c: f64) -> Result<f64> {
    Ok(gms_stats(m_r, m_d, c)?.gmsd)
}

/// `conv2(y, ones(2)/4, 'same')` sampled every second pixel from 0: the mean of each 2x2 block,
/// with zeros past the right/bottom edge (MATLAB's zero padding).
fn average_downsample2(y: &ImageView<'_, f32>) -> Image<f64> {
    let (w, h) = (y.width(), y.height());
    let (ow, oh) = (w.div_ceil(2), h.div_ceil(2));
    let at = |x: usize, yy: usize| -> f64 {
        if x < w && yy < h {
            f64::from(y.get(x, yy))
        } else {
            0.0
        }
    };
    Image::from_fn(ow, oh, |x, yy| {
        let (sx, sy) = (2 * x, 2 * yy);
        (at(sx, sy) + at(sx + 1, sy) + at(sx, sy + 1) + at(sx + 1, sy + 1)) / 4.0
    })
}

/// Prewitt/3 gradient magnitude with zero padding (`conv2(…, 'same')`).
fn prewitt_magnitude(y: &Image<f64>) -> Image<f64> {
    let (w, h) = (y.width() as isize, y.height() as isize);
    let at = |x: isize, yy: isize| -> f64 {
        if x >= 0 && yy >= 0 && x < w && yy < h {
            y.get(x as usize, yy as usize)
        } else {
            0.0
        }
    };
    Image::from_fn(y.width(), y.height(), |x, yy| {
        let (x, yy) = (x as isize, yy as isize);
        let mut gx = 0.0;
        let mut gy = 0.0;
        for d in -1..=1 {
            gx += at(x + 1, yy + d) - at(x - 1, yy + d);
            gy += at(x + d, yy + 1) - at(x + d, yy - 1);
        }
        ((gx / 3.0).powi(2) + (gy / 3.0).powi(2)).sqrt()
    })
}

/// The GMSD image-quality index of Xue et al. 2014 between a reference and a distorted
/// **luminance** image on 0..255 (see the module docs for the exact steps). 0 for identical images.
///
/// Both images must have the same size, at least 2x2.
pub fn gmsd_xue2014(reference: ImageView<'_, f32>, distorted: ImageView<'_, f32>) -> Result<f64> {
    let (w, h) = same_size(&reference, &distorted)?;
    if w < 2 || h < 2 {
        return Err(MetricsError::TooSmall {
            width: w,
            height: h,
            window: 2,
        });
    }
    let gr = prewitt_magnitude(&average_downsample2(&reference));
    let gd = prewitt_magnitude(&average_downsample2(&distorted));
    let n = gr.as_slice().len();
    let it = gr
        .as_slice()
        .iter()
        .zip(gd.as_slice())
        .map(|(&a, &b)| gms(a, b, XUE_T));
    // MATLAB std2 = std(a(:)), normalised by N − 1.
    Ok(mean_std(it, n, 1).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Image<f32> {
        Image::from_fn(w, h, |x, y| ((x * 13 + y * 7) % 17) as f32 / 16.0)
    }

    #[test]
    fn identical_maps_give_zero() {
        let g = ramp(40, 30);
        let s = gms_stats(g.view(), g.view(), PAPER_C).unwrap();
        assert_eq!(s.gmsm, 1.0);
        assert_eq!(s.gmsd, 0.0);
        let m = gms_map(g.view(), g.view(), PAPER_C).unwrap();
        assert!(m.as_slice().iter().all(|&v| v == 1.0));
    }

    #[test]
    fn hand_computed_gms() {
        // m_r = 1, m_d = 0: GMS = c / (1 + c).  m_r = m_d: GMS = 1.
        let a = Image::from_vec(2, 1, vec![1.0f32, 0.5]).unwrap();
        let b = Image::from_vec(2, 1, vec![0.0f32, 0.5]).unwrap();
        let c = 0.25;
        let m = gms_map(a.view(), b.view(), c).unwrap();
        assert!((m.get(0, 0) - 0.2).abs() < 1e-7);
        assert_eq!(m.get(1, 0), 1.0);
        let s = gms_stats(a.view(), b.view(), c).unwrap();
        assert!((s.gmsm - 0.6).abs() < 1e-12);
        assert!((s.gmsd - 0.4).abs() < 1e-12); // population std of {0.2, 1.0}
    }

    #[test]
    fn gms_is_symmetric_and_bounded() {
        let a = ramp(20, 10);
        let b = Image::from_fn(20, 10, |x, y| ((x * 3 + y * 11) % 7) as f32 / 6.0);
        let ab = gms_map(a.view(), b.view(), PAPER_C).unwrap();
        let ba = gms_map(b.view(), a.view(), PAPER_C).unwrap();
        assert_eq!(ab, ba);
        assert!(ab.as_slice().iter().all(|&v| v > 0.0 && v <= 1.0));
    }

    #[test]
    fn parallel_equals_serial() {
        let a = ramp(77, 101);
        let b = Image::from_fn(77, 101, |x, y| ((x * 5 + y) % 9) as f32 / 8.0);
        let mut p = Image::new(0, 0);
        let mut s = Image::new(0, 0);
        gms_map_impl(a.view(), b.view(), PAPER_C, &mut p, true).unwrap();
        gms_map_impl(a.view(), b.view(), PAPER_C, &mut s, false).unwrap();
        assert_eq!(p, s);
    }

    #[test]
    fn bad_inputs() {
        let a = ramp(4, 4);
        let b = ramp(4, 5);
        assert!(matches!(
            gmsd(a.view(), b.view(), PAPER_C),
            Err(MetricsError::SizeMismatch { .. })
        ));
        assert!(matches!(
            gmsd(a.view(), a.view(), -1.0),
            Err(MetricsError::InvalidParameter { name: "c", .. })
        ));
        let t = Image::<f32>::new(1, 5);
        assert!(matches!(
            gmsd_xue2014(t.view(), t.view()),
            Err(MetricsError::TooSmall { .. })
        ));
    }

    #[test]
    fn xue_identical_is_zero_and_distortion_is_positive() {
        let a = Image::from_fn(64, 48, |x, y| (((x / 4 + y / 3) % 5) * 50) as f32);
        assert_eq!(gmsd_xue2014(a.view(), a.view()).unwrap(), 0.0);
        let b = a.map(|v| (v + 30.0).min(255.0) * 0.7);
        assert!(gmsd_xue2014(a.view(), b.view()).unwrap() > 0.0);
    }

    #[test]
    fn xue_hand_computed_steps() {
        // A 4x4 image: averaging 2x2 blocks gives [[1, 2], [3, 4]] (sums 4, 8, 12, 16 / 4).
        let a = Image::from_vec(
            4,
            4,
            vec![
                1.0f32, 1.0, 2.0, 2.0, //
                1.0, 1.0, 2.0, 2.0, //
                3.0, 3.0, 4.0, 4.0, //
                3.0, 3.0, 4.0, 4.0,
            ],
        )
        .unwrap();
        let avg = average_downsample2(&a.view());
        assert_eq!(avg.as_slice(), &[1.0, 2.0, 3.0, 4.0]);
        // Prewitt/3 with zero padding at (0,0) of [[1,2],[3,4]]:
        // gx = (right column − left column)/3 = ((2 + 4) − 0)/3 = 2, gy = ((3 + 4) − 0)/3 = 7/3.
        let g = prewitt_magnitude(&avg);
        assert!((g.get(0, 0) - (4.0f64 + 49.0 / 9.0).sqrt()).abs() < 1e-12);
        // Odd width: the last column averages with zero padding.
        let o = Image::from_vec(3, 2, vec![4.0f32, 4.0, 8.0, 4.0, 4.0, 8.0]).unwrap();
        assert_eq!(average_downsample2(&o.view()).as_slice(), &[4.0, 4.0]);
    }
}
