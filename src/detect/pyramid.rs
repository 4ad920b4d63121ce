//! Image pyramids for the sliding-window detector: bilinear resize like `cv2.resize(INTER_LINEAR)`
//! for grey/colour planes, and a CFA-preserving mosaic resize (each of the four 2x2 super-pixel
//! planes resized on its own, then re-interleaved).
//!
//! ```
//! use mosaicd::detect::pyramid::{resize_bilinear, resize_mosaic};
//! use mosaicd::image::Image;
//! let src = Image::<f32>::from_fn(8, 6, |x, y| (x + 10 * y) as f32);
//! let mut dst = Image::new(0, 0);
//! resize_bilinear(src.view(), 4, 3, &mut dst).unwrap();
//! assert_eq!(dst.dimensions(), (4, 3));
//! resize_mosaic(src.view(), 4, 2, &mut dst).unwrap();
//! assert_eq!(dst.dimensions(), (4, 2));
//! ```
//!
//! # Math
//! Output pixel `d` samples the source at `s = (d + ½)·(W_src/W_dst) − ½` (half-pixel centres), with
//! OpenCV's border rule: `s < 0` → first pixel, `s ≥ W_src − 1` → last pixel. Separable: horizontal
//! then vertical linear interpolation in f32.
//!
//! The mosaic resize follows the super-pixel scale space of the paper: a mosaic of size W x H is four
//! planes of W/2 x H/2 (one per tile position); each plane is resized to new_w/2 x new_h/2 and the
//! planes are interleaved again, so the result is a valid mosaic of the same pattern.
//!
//! # Deviations
//! OpenCV resizes 8-bit images in 11-bit fixed point; we resize f32, so pyramid levels other than
//! the first differ from OpenCV's by up to ±0.5 grey level. This module is a stand-in with the same
//! semantics as `features::superpixel::{resize_bilinear, resize_mosaic}` (written by the lead); the
//! detector can switch to those once they are on main.

use rayon::prelude::*;

use crate::image::{Image, ImageView};

/// Output rows per parallel strip.
const STRIP_ROWS: usize = 16;

/// Errors of the pyramid stage.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PyramidError {
    /// Empty source or destination.
    #[error("cannot resize {src_w}x{src_h} to {dst_w}x{dst_h}: empty image")]
    Empty {
        /// Source width.
        src_w: usize,
        /// Source height.
        src_h: usize,
        /// Destination width.
        dst_w: usize,
        /// Destination height.
        dst_h: usize,
    },
    /// A mosaic size that is odd.
    #[error("mosaic sizes must be even: {src_w}x{src_h} -> {dst_w}x{dst_h}")]
    OddSize {
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

/// Source index and weight of the right/lower neighbour for each output coordinate.
fn taps(src: usize, dst: usize) -> Vec<(usize, f32)> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|d| {
            let s = ((d as f64 + 0.5) * scale - 0.5) as f32;
            let mut i = s.floor() as isize;
            let mut f = s - i as f32;
            if i < 0 {
                i = 0;
                f = 0.0;
            }
            if i as usize >= src - 1 {
                i = src as isize - 1;
                f = 0.0;
            }
            (i as usize, f)
        })
        .collect()
}

/// Strided bilinear resize core: reads `src` pixels at `(x0 + sx·step, y0 + sy·step)` and writes
/// `dst` pixels at `(ox + dx·step, oy + dy·step)` for a plane of `sw x sh` → `dw x dh`.
#[allow(clippy::too_many_arguments)]
fn resize_plane(
    src: ImageView<'_, f32>,
    step: usize,
    off: (usize, usize),
    sw: usize,
    sh: usize,
    dw: usize,
    dh: usize,
    dst: &mut [f32],
    dst_stride: usize,
) {
    let tx = taps(sw, dw);
    let ty = taps(sh, dh);
    let (ox, oy) = off;
    let rows_per_strip = STRIP_ROWS * step;
    dst.par_chunks_mut(dst_stride * rows_per_strip)
        .enumerate()
        .for_each(|(s, chunk)| {
            let mut r0 = vec![0.0f32; dw];
            let mut r1 = vec![0.0f32; dw];
            let first = s * STRIP_ROWS;
            for dy in first..(first + STRIP_ROWS).min(dh) {
                let (iy, fy) = ty[dy];
                let iy1 = (iy + 1).min(sh - 1);
                let a = src.row(oy + iy * step);
                let b = src.row(oy + iy1 * step);
                for (dx, &(ix, fx)) in tx.iter().enumerate() {
                    let ix1 = (ix + 1).min(sw - 1);
                    let (p, q) = (ox + ix * step, ox + ix1 * step);
                    r0[dx] = a[p] + (a[q] - a[p]) * fx;
                    r1[dx] = b[p] + (b[q] - b[p]) * fx;
                }
                let row = &mut chunk[((dy - first) * step + oy) * dst_stride..];
                for dx in 0..dw {
                    row[ox + dx * step] = r0[dx] + (r1[dx] - r0[dx]) * fy;
                }
            }
        });
}

/// Bilinear resize of one f32 plane to `new_w x new_h` (cv2.resize INTER_LINEAR semantics).
pub fn resize_bilinear(
    src: ImageView<'_, f32>,
    new_w: usize,
    new_h: usize,
    dst: &mut Image<f32>,
) -> Result<(), PyramidError> {
    let (w, h) = (src.width(), src.height());
    if w == 0 || h == 0 || new_w == 0 || new_h == 0 {
        return Err(PyramidError::Empty {
            src_w: w,
            src_h: h,
            dst_w: new_w,
            dst_h: new_h,
        });
    }
    dst.reshape(new_w, new_h);
    resize_plane(src, 1, (0, 0), w, h, new_w, new_h, dst.as_mut_slice(), new_w);
    Ok(())
}

/// CFA-preserving resize of a mosaic to `new_w x new_h` (both even).
pub fn resize_mosaic(
    src: ImageView<'_, f32>,
    new_w: usize,
    new_h: usize,
    dst: &mut Image<f32>,
) -> Result<(), PyramidError> {
    let (w, h) = (src.width(), src.height());
    let e = (w, h, new_w, new_h);
    if w < 2 || h < 2 || new_w < 2 || new_h < 2 {
        return Err(PyramidError::Empty {
            src_w: e.0,
            src_h: e.1,
            dst_w: e.2,
            dst_h: e.3,
        });
    }
    if w % 2 + h % 2 + new_w % 2 + new_h % 2 != 0 {
        return Err(PyramidError::OddSize {
            src_w: e.0,
            src_h: e.1,
            dst_w: e.2,
            dst_h: e.3,
        });
    }
    dst.reshape(new_w, new_h);
    // Each tile position is a plane; planes write disjoint pixels but share rows, so run them one
    // after the other (each is parallel inside).
    for oy in 0..2 {
        for ox in 0..2 {
            resize_plane(
                src,
                2,
                (ox, oy),
                w / 2,
                h / 2,
                new_w / 2,
                new_h / 2,
                dst.as_mut_slice(),
                new_w,
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_size_is_a_copy() {
        let src = Image::<f32>::from_fn(9, 7, |x, y| (x * 3 + y * 11) as f32);
        let mut d = Image::new(0, 0);
        resize_bilinear(src.view(), 9, 7, &mut d).unwrap();
        assert_eq!(d, src);
    }

    #[test]
    fn halving_averages_pairs() {
        // s = (d + 0.5) * 2 - 0.5 = 2d + 0.5 → mean of pixels 2d and 2d+1.
        let src = Image::<f32>::from_fn(8, 2, |x, _| (x * x) as f32);
        let mut d = Image::new(0, 0);
        resize_bilinear(src.view(), 4, 1, &mut d).unwrap();
        for x in 0..4 {
            let want = ((2 * x) * (2 * x) + (2 * x + 1) * (2 * x + 1)) as f32 / 2.0;
            assert_eq!(d.get(x, 0), want);
        }
    }

    #[test]
    fn mosaic_resize_keeps_the_pattern() {
        let src = Image::<f32>::from_fn(40, 20, |x, y| [1.0, 2.0, 3.0, 4.0][(y & 1) * 2 + (x & 1)]);
        let mut d = Image::new(0, 0);
        resize_mosaic(src.view(), 26, 14, &mut d).unwrap();
        for y in 0..14 {
            for x in 0..26 {
                assert_eq!(d.get(x, y), [1.0, 2.0, 3.0, 4.0][(y & 1) * 2 + (x & 1)]);
            }
        }
        assert!(matches!(
            resize_mosaic(src.view(), 25, 14, &mut d),
            Err(PyramidError::OddSize { .. })
        ));
    }
}
