//! The sRGB transfer function (IEC 61966-2-1), both directions, on values in `[0, 1]`:
//!
//! ```text
//! encode:  srgb(v) = 12.92 v                     (v ≤ 0.0031308)
//!                  = 1.055 v^(1/2.4) − 0.055     (otherwise)
//! decode:  lin(c)  = c / 12.92                   (c ≤ 0.04045)
//!                  = ((c + 0.055) / 1.055)^2.4   (otherwise)
//! ```
//!
//! A leaf: the forward and reverse ISP and the detector's `srgb` mosaic tone
//! ([`crate::raw::tone`]) all use these two functions.

/// sRGB transfer function: linear segment threshold on the encoded value.
const SRGB_ENC_THRESHOLD: f32 = 0.040_45;
/// sRGB transfer function: linear segment threshold on the linear value.
const SRGB_LIN_THRESHOLD: f32 = 0.003_130_8;
/// Slope of the linear segment.
const SRGB_SLOPE: f32 = 12.92;
/// Offset of the power segment.
const SRGB_ALPHA: f32 = 0.055;
/// Exponent of the power segment.
const SRGB_GAMMA: f32 = 2.4;

/// Inverse sRGB transfer function: encoded `c ∈ [0, 1]` → linear.
#[inline]
pub(crate) fn linear_from_srgb(c: f32) -> f32 {
    if c <= SRGB_ENC_THRESHOLD {
        c / SRGB_SLOPE
    } else {
        ((c + SRGB_ALPHA) / (1.0 + SRGB_ALPHA)).powf(SRGB_GAMMA)
    }
}

/// sRGB transfer function: linear `v ∈ [0, 1]` → encoded.
#[inline]
pub(crate) fn srgb_from_linear(v: f32) -> f32 {
    if v <= SRGB_LIN_THRESHOLD {
        v * SRGB_SLOPE
    } else {
        (1.0 + SRGB_ALPHA) * v.powf(1.0 / SRGB_GAMMA) - SRGB_ALPHA
    }
}
