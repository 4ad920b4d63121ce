//! Image-quality and detection metrics: GMS/GMSD, MSE/PSNR, SSIM/MSSIM, miss rate, AP.
//!
//! These are the measurements the paper (Zhou, Zhang, Gao, Lou) reports in Tables III–VI and
//! Fig. 9, plus the detection metrics used for the HOG experiments:
//!
//! | file | what |
//! |---|---|
//! | `gmsd.rs` | gradient magnitude similarity map and deviation between two gradient maps (paper eqs. 21–23: [`gms_stats`], [`gmsd`]), and the reference GMSD of Xue et al. 2014 between two images ([`gmsd_xue2014`]) |
//! | `psnr.rs` | mean squared error and peak signal-to-noise ratio with an explicit data range ([`mse`], [`psnr`]) |
//! | `ssim.rs` | SSIM map and mean SSIM (Wang et al. 2004), matching `skimage.metrics.structural_similarity` with Gaussian weights ([`ssim_map`], [`mssim`]) |
//! | `detection.rs` | miss rate vs false positives per window (DET curve: [`det_curve`]) and PASCAL average precision |
//! | `interval.rs` | a bootstrap confidence interval ([`Interval`]) |
//!
//! The files are private behind this facade: what other crates use is re-exported here; the rest
//! is `pub(crate)`, for the evaluation code and the trainer.
//!
//! All image metrics read [`ImageView`] values of `f32` (grey) or `[f32; 3]`
//! (RGB, via the [`Pixel`] trait) and accumulate in `f64`. The two images must have the same size;
//! a mismatch is a [`MetricsError`], never a panic.
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::metrics::{mssim, psnr, SsimOptions};
//! let a = Image::<f32>::from_fn(32, 32, |x, y| ((x * 7 + y * 3) % 11) as f32 / 10.0);
//! assert!(psnr(a.view(), a.view(), 1.0).unwrap().is_infinite());
//! let spec = SsimOptions::with_data_range(1.0).build().unwrap();
//! assert!((mssim(a.view(), a.view(), &spec).unwrap() - 1.0).abs() < 1e-12);
//! ```

pub(crate) mod detection;
pub(crate) mod gmsd;
pub(crate) mod interval;
pub(crate) mod psnr;
pub(crate) mod ssim;

pub use detection::{
    det_curve, miss_rate_at_fppw, pascal_ap, ApResult, DetPoint, ImageDetections, DALAL_FPPW,
};
pub use gmsd::{gms_map, gms_map_into, gms_stats, gmsd, gmsd_xue2014, GmsStats, PAPER_C};
pub use interval::Interval;
pub use psnr::{mse, psnr, psnr_from_mse};
pub use ssim::{mssim, mssim_per_channel, ssim_map, SsimOptions, SsimSpec};

use crate::image::ImageView;
use thiserror::Error;

/// Errors from the image and detection metrics.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MetricsError {
    /// The two images do not have the same size.
    #[error("image sizes differ: {a_width}x{a_height} vs {b_width}x{b_height}")]
    SizeMismatch {
        /// Width of the first image.
        a_width: usize,
        /// Height of the first image.
        a_height: usize,
        /// Width of the second image.
        b_width: usize,
        /// Height of the second image.
        b_height: usize,
    },
    /// An image has no pixels.
    #[error("image is empty ({width}x{height})")]
    Empty {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// The image is smaller than the metric's window.
    #[error("image {width}x{height} is smaller than the {window}x{window} window")]
    TooSmall {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Window side in pixels.
        window: usize,
    },
    /// A parameter is out of its valid range.
    #[error("parameter `{name}` = {value} is invalid: {reason}")]
    InvalidParameter {
        /// Parameter name.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// What is allowed.
        reason: &'static str,
    },
    /// Two input lists that must have the same length do not.
    #[error("`{what}` has {got} entries but {expected} were expected")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// Entries given.
        got: usize,
        /// Entries expected.
        expected: usize,
    },
    /// An input list that must not be empty is empty.
    #[error("`{what}` is empty")]
    NoSamples {
        /// Which input.
        what: &'static str,
    },
}

/// Result alias for the metrics.
pub type Result<T> = std::result::Result<T, MetricsError>;

/// A pixel whose channels the metrics can read as `f64`.
///
/// Implemented for grey (`f32`, `f64`, `u8`, `u16`) and RGB (`[f32; 3]`, `[u8; 3]`) pixels.
pub trait Pixel: Copy {
    /// Number of channels.
    const CHANNELS: usize;
    /// Channel `c` (`c < CHANNELS`) as `f64`.
    fn channel(&self, c: usize) -> f64;
}

macro_rules! scalar_pixel {
    ($($t:ty),*) => {$(
        impl Pixel for $t {
            const CHANNELS: usize = 1;
            #[inline]
            fn channel(&self, _c: usize) -> f64 {
                f64::from(*self)
            }
        }
    )*};
}
scalar_pixel!(f32, f64, u8, u16);

macro_rules! rgb_pixel {
    ($($t:ty),*) => {$(
        impl Pixel for [$t; 3] {
            const CHANNELS: usize = 3;
            #[inline]
            fn channel(&self, c: usize) -> f64 {
                f64::from(self[c])
            }
        }
    )*};
}
rgb_pixel!(f32, u8, u16);

/// Checks that two views have the same, non-zero size; returns `(width, height)`.
pub(crate) fn same_size<P: Copy, Q: Copy>(
    a: &ImageView<'_, P>,
    b: &ImageView<'_, Q>,
) -> Result<(usize, usize)> {
    if a.width() != b.width() || a.height() != b.height() {
        return Err(MetricsError::SizeMismatch {
            a_width: a.width(),
            a_height: a.height(),
            b_width: b.width(),
            b_height: b.height(),
        });
    }
    if a.width() == 0 || a.height() == 0 {
        return Err(MetricsError::Empty {
            width: a.width(),
            height: a.height(),
        });
    }
    Ok((a.width(), a.height()))
}

/// Checks that a parameter is finite and strictly positive.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(MetricsError::InvalidParameter {
            name,
            value,
            reason: "must be finite and > 0",
        })
    }
}
