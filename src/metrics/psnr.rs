//! Mean squared error and peak signal-to-noise ratio.
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::metrics::{mse, psnr};
//! let a = Image::<f32>::filled(4, 4, 100.0);
//! let b = Image::<f32>::filled(4, 4, 110.0);
//! assert_eq!(mse(a.view(), b.view()).unwrap(), 100.0);
//! // 10 log10(255² / 100) = 28.13 dB
//! assert!((psnr(a.view(), b.view(), 255.0).unwrap() - 28.1308).abs() < 1e-4);
//! ```
//!
//! ## Math
//! `MSE = (1/N) Σ (a_i − b_i)²` over every pixel and channel (N = pixels × channels), and
//! `PSNR = 10 log10(R² / MSE)` where `R` is the **data range** given by the caller (255 for 8-bit
//! images, 1 for images on [0, 1], `2^bits − 1` for raw). The range is explicit because guessing it
//! from the pixel type (as scikit-image does for integer types) gives the wrong answer for `f32`
//! images and for raw values in a 16-bit container.
//!
//! ## Identical images
//! When `MSE = 0` the PSNR is `+∞` (`f64::INFINITY`), which is what scikit-image returns too
//! (it divides by zero with numpy semantics). Callers averaging PSNR over a data set should treat
//! infinite values explicitly (the eval tables report how many were infinite and average the rest).
//!
//! ## Parity
//! Equals `skimage.metrics.mean_squared_error` and `skimage.metrics.peak_signal_noise_ratio(...,
//! data_range=R)` (tests/metrics_parity.rs, fixtures by tests/oracle/gen_metrics.py).
//!
//! ## References
//! Any image-processing text; scikit-image `skimage/metrics/simple_metrics.py`.

use super::{positive, same_size, Pixel, Result};
use crate::image::ImageView;

/// Mean squared error over every pixel and channel, accumulated in `f64`.
pub fn mse<P: Pixel>(a: ImageView<'_, P>, b: ImageView<'_, P>) -> Result<f64> {
    let (w, h) = same_size(&a, &b)?;
    let mut sum = 0.0f64;
    for y in 0..h {
        let (ra, rb) = (a.row(y), b.row(y));
        for x in 0..w {
            for c in 0..P::CHANNELS {
                let d = ra[x].channel(c) - rb[x].channel(c);
                sum += d * d;
            }
        }
    }
    Ok(sum / (w * h * P::CHANNELS) as f64)
}

/// PSNR in dB from an MSE and a data range: `10 log10(R² / mse)`; `+∞` when `mse == 0`.
pub fn psnr_from_mse(mse: f64, data_range: f64) -> Result<f64> {
    let r = positive("data_range", data_range)?;
    if mse.is_nan() || mse < 0.0 {
        return Err(super::MetricsError::InvalidParameter {
            name: "mse",
            value: mse,
            reason: "must be >= 0",
        });
    }
    if mse == 0.0 {
        return Ok(f64::INFINITY);
    }
    Ok(10.0 * (r * r / mse).log10())
}

/// Peak signal-to-noise ratio in dB with an explicit data range `R`; `+∞` for identical images.
pub fn psnr<P: Pixel>(a: ImageView<'_, P>, b: ImageView<'_, P>, data_range: f64) -> Result<f64> {
    positive("data_range", data_range)?;
    psnr_from_mse(mse(a, b)?, data_range)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use crate::metrics::MetricsError;

    #[test]
    fn hand_computed_mse() {
        let a = Image::from_vec(2, 2, vec![0.0f32, 1.0, 2.0, 3.0]).unwrap();
        let b = Image::from_vec(2, 2, vec![1.0f32, 1.0, 0.0, 3.0]).unwrap();
        // (1 + 0 + 4 + 0) / 4
        assert_eq!(mse(a.view(), b.view()).unwrap(), 1.25);
        let p = psnr(a.view(), b.view(), 4.0).unwrap();
        assert!((p - 10.0 * (16.0f64 / 1.25).log10()).abs() < 1e-12);
    }

    #[test]
    fn rgb_counts_every_channel() {
        let a = Image::<[f32; 3]>::filled(3, 1, [0.0, 0.0, 0.0]);
        let b = Image::<[f32; 3]>::filled(3, 1, [3.0, 0.0, 0.0]);
        assert_eq!(mse(a.view(), b.view()).unwrap(), 3.0);
    }

    #[test]
    fn identical_is_infinite() {
        let a = Image::<u8>::from_fn(5, 3, |x, y| (x * y) as u8);
        assert_eq!(psnr(a.view(), a.view(), 255.0).unwrap(), f64::INFINITY);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let a = Image::<f32>::new(2, 2);
        let b = Image::<f32>::new(3, 2);
        assert!(matches!(
            mse(a.view(), b.view()),
            Err(MetricsError::SizeMismatch { .. })
        ));
        assert!(matches!(
            psnr(a.view(), a.view(), 0.0),
            Err(MetricsError::InvalidParameter {
                name: "data_range",
                ..
            })
        ));
        let e = Image::<f32>::new(0, 0);
        assert!(matches!(mse(e.view(), e.view()), Err(MetricsError::Empty { .. })));
    }

    #[test]
    fn psnr_decreases_with_error() {
        let a = Image::<f32>::filled(4, 4, 0.5);
        let b1 = Image::<f32>::filled(4, 4, 0.51);
        let b2 = Image::<f32>::filled(4, 4, 0.6);
        let p1 = psnr(a.view(), b1.view(), 1.0).unwrap();
        let p2 = psnr(a.view(), b2.view(), 1.0).unwrap();
        assert!(p1 > p2 && (p1 - 40.0).abs() < 1e-3 && (p2 - 20.0).abs() < 1e-3);
    }
}
