//! RGB → grey conversion (ITU-R BT.601 luma weights), matching OpenCV's `cv2.cvtColor(.., RGB2GRAY)`.
//!
//! The grey-image baseline of the paper (§III-A) converts a demosaiced RGB image to grey and then
//! applies the same gradient operators as on the mosaic. This module is that conversion.
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::isp::grey_from_rgb_u8;
//! let rgb = Image::from_fn(2, 1, |x, _| if x == 0 { [255u8, 0, 0] } else { [10u8, 10, 10] });
//! let grey = grey_from_rgb_u8(&rgb.view());
//! assert_eq!(grey.as_slice(), &[76, 10]); // 0.299 * 255 = 76.2; equal channels stay put
//! ```
//!
//! # Math
//!
//! `Y = 0.299 R + 0.587 G + 0.114 B`.
//!
//! * **u8**: OpenCV 4.x computes it in fixed point with 15 fractional bits,
//!   `Y = (9798 R + 19235 G + 3735 B + 2^14) >> 15`, the weights rounded so that they sum to exactly
//!   `2^15` (so R = G = B = v gives Y = v). We use the same integers, and a test checks it against
//!   all 2^24 RGB triples through the oracle generator (`tests/oracle/gen_gradients.py`).
//! * **f32**: `Y = 0.299 R + 0.587 G + 0.114 B` in f32, evaluated left to right. OpenCV's SIMD path may
//!   group the sums differently; results agree within 1 ulp of the operands' scale.
//!
//! # Deviations
//!
//! None intended for u8 (bit-exact). For f32 the summation order may differ from OpenCV's by rounding.
//!
//! # References
//!
//! ITU-R BT.601; OpenCV `modules/imgproc/src/color_rgb.simd.hpp` (`RGB2Gray<uchar>`).

use rayon::prelude::*;
use thiserror::Error;

use crate::image::{Image, ImageView, ImageViewMut};

/// Fixed-point shift of OpenCV's 8-bit RGB→grey (`gray_shift`).
pub(crate) const GREY_SHIFT: u32 = 15;
/// Red weight 0.299 in Q15 (OpenCV's `RY15`).
pub(crate) const R_Q15: u32 = 9798;
/// Green weight 0.587 in Q15 (OpenCV's `GY15`).
pub(crate) const G_Q15: u32 = 19235;
/// Blue weight 0.114 in Q15 (OpenCV's `BY15`). The three sum to exactly `1 << 15`.
pub(crate) const B_Q15: u32 = 3735;
/// BT.601 red weight.
pub(crate) const R_WEIGHT: f32 = 0.299;
/// BT.601 green weight.
pub(crate) const G_WEIGHT: f32 = 0.587;
/// BT.601 blue weight.
pub(crate) const B_WEIGHT: f32 = 0.114;

/// Rows per rayon task.
const STRIP_ROWS: usize = 32;

/// Errors from grey conversion.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub(crate) enum GreyError {
    /// Source and destination sizes differ.
    #[error("grey conversion: source is {src_w}x{src_h} but destination is {dst_w}x{dst_h}")]
    SizeMismatch {
        /// Source width.
        src_w: usize,
        /// Source height.
        src_h: usize,
        /// Destination width.
        dst_w: usize,
        /// Destination height.
        dst_h: usize,
    },
}

/// One pixel, 8-bit, exactly as OpenCV.
#[inline]
pub(crate) fn grey_u8(p: [u8; 3]) -> u8 {
    let [r, g, b] = p;
    ((r as u32 * R_Q15 + g as u32 * G_Q15 + b as u32 * B_Q15 + (1 << (GREY_SHIFT - 1))) >> GREY_SHIFT) as u8
}

/// One pixel, float.
#[inline]
pub fn grey_f32(p: [f32; 3]) -> f32 {
    p[0] * R_WEIGHT + p[1] * G_WEIGHT + p[2] * B_WEIGHT
}

/// Pixel types [`grey_from_rgb`] accepts: `[u8; 3]` → `u8` and `[f32; 3]` → `f32`.
pub(crate) trait GreyPixel: Copy + Send + Sync {
    /// The grey pixel type.
    type Grey: Copy + Default + Send + Sync;
    /// Convert one pixel.
    fn grey(self) -> Self::Grey;
}

impl GreyPixel for [u8; 3] {
    type Grey = u8;
    #[inline]
    fn grey(self) -> u8 {
        grey_u8(self)
    }
}

impl GreyPixel for [f32; 3] {
    type Grey = f32;
    #[inline]
    fn grey(self) -> f32 {
        grey_f32(self)
    }
}

/// Convert `src` (R, G, B order) to grey into `dst`, in parallel over row strips.
pub(crate) fn grey_from_rgb<P: GreyPixel>(
    src: &ImageView<'_, P>,
    dst: &mut ImageViewMut<'_, P::Grey>,
) -> Result<(), GreyError> {
    if src.width() != dst.width() || src.height() != dst.height() {
        return Err(GreyError::SizeMismatch {
            src_w: src.width(),
            src_h: src.height(),
            dst_w: dst.width(),
            dst_h: dst.height(),
        });
    }
    let (w, h, stride) = (dst.width(), dst.height(), dst.stride());
    if w == 0 || h == 0 {
        return Ok(());
    }
    let data = dst.as_mut_slice();
    data.par_chunks_mut(stride * STRIP_ROWS)
        .enumerate()
        .for_each(|(strip, chunk)| {
            let y0 = strip * STRIP_ROWS;
            for (i, y) in (y0..(y0 + STRIP_ROWS).min(h)).enumerate() {
                let out = &mut chunk[i * stride..i * stride + w];
                for (o, &p) in out.iter_mut().zip(src.row(y)) {
                    *o = p.grey();
                }
            }
        });
    Ok(())
}

/// Allocating wrapper of `grey_from_rgb` for 8-bit RGB.
pub fn grey_from_rgb_u8(src: &ImageView<'_, [u8; 3]>) -> Image<u8> {
    let mut out = Image::new(src.width(), src.height());
    grey_from_rgb(src, &mut out.view_mut()).expect("sizes match by construction");
    out
}

/// Allocating wrapper of `grey_from_rgb` for float RGB.
pub fn grey_from_rgb_f32(src: &ImageView<'_, [f32; 3]>) -> Image<f32> {
    let mut out = Image::new(src.width(), src.height());
    grey_from_rgb(src, &mut out.view_mut()).expect("sizes match by construction");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one() {
        assert_eq!(R_Q15 + G_Q15 + B_Q15, 1 << GREY_SHIFT);
        assert!((R_WEIGHT + G_WEIGHT + B_WEIGHT - 1.0).abs() < 1e-6);
    }

    #[test]
    fn hand_computed_u8() {
        // 9798*255 + 16384 = 2514874; >> 15 = 76 (2514874 / 32768 = 76.7; 0.299*255 = 76.2)
        assert_eq!(grey_u8([255, 0, 0]), 76);
        // 19235*255 = 4904925 + 16384 = 4921309 >> 15 = 150 (0.587*255 = 149.7)
        assert_eq!(grey_u8([0, 255, 0]), 150);
        // 3735*255 = 952425 + 16384 = 968809 >> 15 = 29 (0.114*255 = 29.07)
        assert_eq!(grey_u8([0, 0, 255]), 29);
        assert_eq!(grey_u8([255, 255, 255]), 255);
        for v in 0..=255u8 {
            assert_eq!(grey_u8([v, v, v]), v, "equal channels must be unchanged");
        }
    }

    #[test]
    fn hand_computed_f32() {
        assert!((grey_f32([1.0, 0.0, 0.0]) - 0.299).abs() < 1e-7);
        assert!((grey_f32([0.5, 0.5, 0.5]) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn parallel_equals_serial_and_strided() {
        let img = Image::from_fn(37, 70, |x, y| [(x * 7) as u8, (y * 3) as u8, (x * y) as u8]);
        let par = grey_from_rgb_u8(&img.view());
        for y in 0..70 {
            for x in 0..37 {
                assert_eq!(par.get(x, y), grey_u8(img.get(x, y)));
            }
        }
        // Strided destination.
        let mut buf = vec![0u8; 40 * 70];
        let mut dst = ImageViewMut::new(&mut buf, 37, 70, 40).unwrap();
        grey_from_rgb(&img.view(), &mut dst).unwrap();
        assert_eq!(buf[40 * 5 + 3], par.get(3, 5));
        let mut small = Image::<u8>::new(3, 3);
        assert!(matches!(
            grey_from_rgb(&img.view(), &mut small.view_mut()),
            Err(GreyError::SizeMismatch { .. })
        ));
    }
}
