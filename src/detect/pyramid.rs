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
//! the first differ from OpenCV's by up to ±0.5 grey level. The float resizes compute what
//! `features::superpixel::{resize_bilinear, resize_mosaic}` compute (a test holds them within
//! 1e-3 grey levels); the detector keeps its own for the strips that fuse a row operation into
//! the resize and for its reused buffers.

use rayon::prelude::*;

use super::kernels::{horizontal_row, prefetch_row, vertical_row, Perm16};
use crate::image::{Image, ImageView};
use crate::kernels::Isa;

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
pub(crate) fn taps(src: usize, dst: usize) -> Vec<(usize, f32)> {
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

/// Column taps of the whole output row: source columns `p`, `q` and weight `fx` of
/// `a[p] + (a[q] − a[p])·fx`, for a plane interleaved with `step` (1 = plain image, 2 = mosaic:
/// output column `x` samples plane `x % 2` at plane column `x / 2`).
fn column_taps(sw: usize, dw: usize, step: usize) -> Vec<(u32, u32, f32)> {
    let tx = taps(sw, dw);
    (0..dw * step)
        .map(|x| {
            let (ox, dx) = (x % step, x / step);
            let (ix, fx) = tx[dx];
            let ix1 = (ix + 1).min(sw - 1);
            ((ox + ix * step) as u32, (ox + ix1 * step) as u32, fx)
        })
        .collect()
}

/// Bilinear resize core for a plane (`step` 1) or the four interleaved planes of a mosaic
/// (`step` 2, each plane `sw x sh` → `dw x dh`): one pass over the output rows, each row from two
/// source rows of the same tile phase. Per pixel the arithmetic is
/// `r0 = a[p] + (a[q] − a[p])·fx`, `r1` likewise from the lower row, `r0 + (r1 − r0)·fy`.
#[allow(clippy::too_many_arguments)]
fn resize_planes(
    src: ImageView<'_, f32>,
    step: usize,
    sw: usize,
    sh: usize,
    dw: usize,
    dh: usize,
    dst: &mut [f32],
    row_op: &RowOp,
    isa: Isa,
) {
    let tc = column_taps(sw, dw, step);
    let ty = taps(sh, dh);
    let w = dw * step;
    let perms = PermTaps::new(isa, &tc, src.width());
    dst.par_chunks_mut(w * STRIP_ROWS)
        .enumerate()
        .for_each(|(s, chunk)| {
            // Horizontally resampled source rows, two per tile phase: consecutive output rows of a
            // phase usually share a source row (scale < 2), so each is resampled once.
            let mut cache: Vec<[(usize, Vec<f32>); 2]> = (0..step)
                .map(|_| [(usize::MAX, vec![0.0f32; w]), (usize::MAX, vec![0.0f32; w])])
                .collect();
            for (k, row) in chunk.chunks_mut(w).enumerate() {
                let y = s * STRIP_ROWS + k;
                let (oy, dy) = (y % step, y / step);
                let (iy, fy) = ty[dy];
                let iy1 = (iy + 1).min(sh - 1);
                let (ra, rb) = (oy + iy * step, oy + iy1 * step);
                let slots = &mut cache[oy];
                // Keep the slot that holds a needed row; refill the other(s).
                if slots[0].0 != ra && slots[0].0 != rb {
                    slots.swap(0, 1);
                }
                let (s0, s1) = slots.split_at_mut(1);
                let (sa, sb) = if s0[0].0 == rb {
                    (&mut s1[0], &mut s0[0])
                } else {
                    (&mut s0[0], &mut s1[0])
                };
                for (slot, r) in [(&mut *sa, ra), (&mut *sb, rb)] {
                    if slot.0 != r {
                        horizontal(src.row(r), &tc, &perms, &mut slot.1, isa);
                        slot.0 = r;
                    }
                }
                // Ask for the next output row's new source row now: its loads (a full-resolution
                // row, usually not in cache) then overlap the vertical pass and the row op.
                let yn = y + 1;
                if yn < dh * step {
                    let (on, dn) = (yn % step, yn / step);
                    let iyn = ty[dn].0;
                    let next = [on + iyn * step, on + (iyn + 1).min(sh - 1) * step];
                    let held = [cache[on][0].0, cache[on][1].0];
                    if let Some(&r) = next.iter().find(|r| !held.contains(r)) {
                        prefetch_row(src.row(r));
                    }
                }
                let slots = &cache[oy];
                let (sa, sb) = if slots[0].0 == ra {
                    (&slots[0], &slots[1])
                } else {
                    (&slots[1], &slots[0])
                };
                vertical(&sa.1, &sb.1, fy, row, isa);
                row_op(row);
            }
        });
}

/// Most 32-value source windows a [`Perm16`] may span (128 values: scale ≲ 3.9 for a mosaic,
/// ≲ 7.9 for a plane).
const MAX_PAIRS: u32 = 4;

/// The [`Perm16`]s of one resize and the source row length they were built for (the AVX-512
/// horizontal pass checks it against every row, once per call); empty off the AVX-512 path.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
#[derive(Debug, Clone, Default)]
struct PermTaps {
    row_len: usize,
    perms: Vec<Option<Perm16>>,
}

impl PermTaps {
    /// [`perm_taps`] on the AVX-512 path, nothing elsewhere.
    fn new(isa: Isa, tc: &[(u32, u32, f32)], row_len: usize) -> Self {
        match isa {
            Isa::Avx512 if isa.is_available() => Self {
                row_len,
                perms: perm_taps(tc, row_len),
            },
            _ => Self::default(),
        }
    }
}

/// [`Perm16`] of every 16 outputs of `tc` (source rows of `row_len` values), `None` where the taps
/// span more than `32·MAX_PAIRS` values, the row is shorter than the window, or the chunk is short.
fn perm_taps(tc: &[(u32, u32, f32)], row_len: usize) -> Vec<Option<Perm16>> {
    tc.chunks(16)
        .map(|c| {
            let lo = c.iter().map(|t| t.0.min(t.1)).min()?;
            let top = c.iter().map(|t| t.0.max(t.1)).max()?;
            let pairs = (top - lo) / 32 + 1;
            let span = 32 * pairs as usize;
            if c.len() < 16 || pairs > MAX_PAIRS || span > row_len {
                return None;
            }
            // Slide the window left where it would run past the row (top < row_len keeps every
            // tap inside it).
            let base = (lo as usize).min(row_len - span) as u32;
            let mut pm = Perm16 {
                base,
                pairs,
                p: [0; 16],
                q: [0; 16],
                fx: [0.0; 16],
            };
            for (k, t) in c.iter().enumerate() {
                (pm.p[k], pm.q[k], pm.fx[k]) = (t.0 - base, t.1 - base, t.2);
            }
            Some(pm)
        })
        .collect()
}

/// `out[x] = a[p] + (a[q] − a[p])·fx` for the column taps `(p, q, fx)` on kernel path `isa`
/// (every path gives the same bits; the AVX-512 one permutes with `perms` where it has them).
fn horizontal(a: &[f32], tc: &[(u32, u32, f32)], perms: &PermTaps, out: &mut [f32], isa: Isa) {
    #[cfg(not(target_arch = "x86_64"))]
    let _ = perms;
    match isa {
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 if !perms.perms.is_empty() && isa.is_available() => {
            // The bound every Perm16 relies on: built for rows of row_len values, a holds them.
            assert!(
                perms.row_len <= a.len(),
                "permute taps built for rows of {} values, row has {}",
                perms.row_len,
                a.len()
            );
            // SAFETY: the path is available (AVX-512F, AVX2, FMA); perm_taps made each Perm16 with
            // base + 32·pairs ≤ row_len ≤ a.len() and offsets < 32·pairs.
            unsafe { super::kernels::avx512::horizontal(a, tc, &perms.perms, out) }
        }
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the path is available: AVX2 and FMA (the AVX-512 path includes both). The
        // kernel indexes with bounds checks.
        Isa::Avx2 | Isa::Avx512 if isa.is_available() => unsafe {
            super::kernels::avx2::horizontal(a, tc, out)
        },
        // NEON has no gather: the taps are arbitrary columns, so the portable loop (whose
        // arithmetic the compiler already emits as NEON) is the NEON path.
        _ => horizontal_row(a, tc, out),
    }
}

/// `out[x] = r0[x] + (r1[x] − r0[x])·fy` on kernel path `isa` (the same bits on every path).
fn vertical(r0: &[f32], r1: &[f32], fy: f32, out: &mut [f32], isa: Isa) {
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the path is available: AVX2 and FMA. The kernel indexes with bounds checks.
        Isa::Avx2 | Isa::Avx512 if isa.is_available() => unsafe {
            super::kernels::avx2::vertical(r0, r1, fy, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 CPU; the kernel stays within the shortest slice.
        Isa::Neon => unsafe { super::kernels::neon::vertical(r0, r1, fy, out) },
        _ => vertical_row(r0, r1, fy, out),
    }
}

/// An operation applied in place to every output row while it is still in cache (e.g. HOG's gamma,
/// [`crate::features::hog::gamma_in_place`]).
pub type RowOp = dyn Fn(&mut [f32]) + Sync;

/// Bilinear resize of one f32 plane to `new_w x new_h` (cv2.resize INTER_LINEAR semantics).
pub fn resize_bilinear(
    src: ImageView<'_, f32>,
    new_w: usize,
    new_h: usize,
    dst: &mut Image<f32>,
) -> Result<(), PyramidError> {
    resize_then(src, new_w, new_h, false, dst, &|_| {})
}

/// CFA-preserving resize of a mosaic to `new_w x new_h` (both even).
pub fn resize_mosaic(
    src: ImageView<'_, f32>,
    new_w: usize,
    new_h: usize,
    dst: &mut Image<f32>,
) -> Result<(), PyramidError> {
    resize_then(src, new_w, new_h, true, dst, &|_| {})
}

/// [`resize_mosaic`] (`mosaic`) or [`resize_bilinear`], then `row_op` on every output row while
/// it is in cache; `dst`'s allocation is reused.
pub fn resize_then(
    src: ImageView<'_, f32>,
    new_w: usize,
    new_h: usize,
    mosaic: bool,
    dst: &mut Image<f32>,
    row_op: &RowOp,
) -> Result<(), PyramidError> {
    resize_then_with(src, new_w, new_h, mosaic, dst, row_op, crate::kernels::isa())
}

/// [`resize_then`] on kernel path `isa` (every path gives the same bits).
fn resize_then_with(
    src: ImageView<'_, f32>,
    new_w: usize,
    new_h: usize,
    mosaic: bool,
    dst: &mut Image<f32>,
    row_op: &RowOp,
    isa: Isa,
) -> Result<(), PyramidError> {
    let (w, h) = (src.width(), src.height());
    let step = if mosaic { 2 } else { 1 };
    let (src_w, src_h, dst_w, dst_h) = (w, h, new_w, new_h);
    if w < step || h < step || new_w < step || new_h < step {
        return Err(PyramidError::Empty {
            src_w,
            src_h,
            dst_w,
            dst_h,
        });
    }
    if mosaic && w % 2 + h % 2 + new_w % 2 + new_h % 2 != 0 {
        return Err(PyramidError::OddSize {
            src_w,
            src_h,
            dst_w,
            dst_h,
        });
    }
    dst.reshape(new_w, new_h);
    let (sw, sh, dw, dh) = (w / step, h / step, new_w / step, new_h / step);
    resize_planes(src, step, sw, sh, dw, dh, dst.as_mut_slice(), row_op, isa);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resizes_equal_the_super_pixel_module_s() {
        // The detector keeps its own resize (strips with a fused row operation, reused buffers);
        // it must stay what `features::superpixel` computes, for grey planes and mosaics alike.
        use crate::features::superpixel as sp;
        let src = Image::<f32>::from_fn(146, 98, |x, y| ((x * 37 + y * 91 + x * y) % 251) as f32 * 0.7);
        let worst = |a: &Image<f32>, b: &Image<f32>| {
            assert_eq!(a.dimensions(), b.dimensions());
            a.as_slice()
                .iter()
                .zip(b.as_slice())
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f32::max)
        };
        for (w, h) in [(146, 98), (120, 80), (62, 44), (200, 130), (10, 6)] {
            let (mut ours, mut theirs) = (Image::new(0, 0), Image::new(0, 0));
            resize_bilinear(src.view(), w, h, &mut ours).unwrap();
            sp::resize_bilinear(src.view(), w, h, &mut theirs).unwrap();
            let d = worst(&ours, &theirs);
            assert!(d <= 1e-3, "grey {w}x{h}: {d}");
            resize_mosaic(src.view(), w, h, &mut ours).unwrap();
            sp::resize_mosaic(src.view(), w, h, &mut theirs).unwrap();
            let d = worst(&ours, &theirs);
            assert!(d <= 1e-3, "mosaic {w}x{h}: {d}");
        }
    }

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
    fn mosaic_resize_equals_per_plane_bilinear_bit_for_bit() {
        let src = Image::<f32>::from_fn(46, 30, |x, y| ((x * 37 + y * 11 + x * y) % 97) as f32 * 0.7);
        let mut d = Image::new(0, 0);
        for (nw, nh) in [(40, 26), (20, 12), (46, 30), (60, 34)] {
            resize_mosaic(src.view(), nw, nh, &mut d).unwrap();
            for (ox, oy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let plane = Image::<f32>::from_fn(23, 15, |x, y| src.get(2 * x + ox, 2 * y + oy));
                let mut p = Image::new(0, 0);
                resize_bilinear(plane.view(), nw / 2, nh / 2, &mut p).unwrap();
                for y in 0..nh / 2 {
                    for x in 0..nw / 2 {
                        assert_eq!(d.get(2 * x + ox, 2 * y + oy).to_bits(), p.get(x, y).to_bits());
                    }
                }
            }
        }
    }

    #[test]
    fn kernel_paths_row_passes_equal_the_scalar_ones_bit_for_bit() {
        // 37 outputs: whole vectors of every path and a tail.
        let a: Vec<f32> = (0..50).map(|i| (i * 7 % 13) as f32 * 1.3).collect();
        let b: Vec<f32> = (0..37).map(|i| (i * 5 % 11) as f32 * 2.1).collect();
        let tc = column_taps(50, 37, 1);
        let none = PermTaps::default();
        let (mut h, mut v) = (vec![0.0; 37], vec![0.0; 37]);
        horizontal_row(&a, &tc, &mut h);
        vertical_row(&h, &b, 0.37, &mut v);
        for isa in Isa::available() {
            let (mut h2, mut v2) = (vec![0.0; 37], vec![0.0; 37]);
            horizontal(&a, &tc, &none, &mut h2, isa);
            vertical(&h2, &b, 0.37, &mut v2, isa);
            assert_eq!(bits(&h2), bits(&h), "{isa}");
            assert_eq!(bits(&v2), bits(&v), "{isa}");
        }
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn kernel_paths_resize_whole_images_bit_for_bit() {
        // Plain and mosaic resizes of a ramp with texture, every path against the scalar one.
        let src = Image::<f32>::from_fn(402, 230, |x, y| ((x * 37 + y * 91 + x * y) % 251) as f32 * 0.7);
        for (w, h, mosaic) in [
            (301, 173, false),
            (100, 57, false),
            (300, 172, true),
            (120, 70, true),
        ] {
            let step = if mosaic { 2 } else { 1 };
            let tc = column_taps(402 / step, w / step, step);
            let ty = taps(230 / step, h / step);
            let mut want = vec![0.0f32; w * h];
            let mut rows = (vec![0.0f32; w], vec![0.0f32; w]);
            for (y, out) in want.chunks_mut(w).enumerate() {
                let (iy, fy) = ty[y / step];
                let iy1 = (iy + 1).min(230 / step - 1);
                horizontal_row(src.row(y % step + iy * step), &tc, &mut rows.0);
                horizontal_row(src.row(y % step + iy1 * step), &tc, &mut rows.1);
                vertical_row(&rows.0, &rows.1, fy, out);
            }
            for isa in Isa::available() {
                let mut got = Image::new(0, 0);
                resize_then_with(src.view(), w, h, mosaic, &mut got, &|_| {}, isa).unwrap();
                assert_eq!(bits(got.as_slice()), bits(&want), "{isa} {w}x{h} mosaic {mosaic}");
            }
        }
    }

    #[test]
    fn kernel_paths_permute_horizontal_pass_equals_the_scalar_one_bit_for_bit() {
        let a: Vec<f32> = (0..400).map(|i| ((i * 37 % 101) as f32).sqrt() * 3.7).collect();
        // Plain and mosaic taps at scales 1.05 … 8.5 (one to four register pairs; above ≈3.9
        // for a mosaic and ≈7.9 for a plane the chunks fall back).
        let cases = [
            (400, 381, 1),
            (400, 296, 1),
            (400, 130, 1),
            (400, 57, 1),
            (400, 47, 1),
            (200, 190, 2),
            (200, 120, 2),
            (200, 80, 2),
            (200, 61, 2),
            (200, 52, 2),
            (200, 40, 2),
            (200, 23, 2),
        ];
        for (sw, dw, step) in cases {
            let tc = column_taps(sw, dw, step);
            let mut want = vec![0.0; dw * step];
            horizontal_row(&a, &tc, &mut want);
            let perms = perm_taps(&tc, a.len());
            if sw < dw * 3 {
                assert!(perms.iter().filter(|p| p.is_some()).count() > perms.len() / 2);
            }
            for isa in Isa::available() {
                let pt = PermTaps::new(isa, &tc, a.len());
                assert_eq!(pt.perms.is_empty(), isa != Isa::Avx512);
                let mut got = vec![0.0; dw * step];
                horizontal(&a, &tc, &pt, &mut got, isa);
                assert_eq!(bits(&got), bits(&want), "{isa} {sw} {dw} {step}");
            }
        }
    }

    #[test]
    fn a_row_shorter_than_the_permute_taps_is_refused() {
        // The AVX-512 pass's bound is a real check (a release build too), not a debug assertion.
        let tc = column_taps(400, 300, 1);
        let pt = PermTaps {
            row_len: 400,
            perms: perm_taps(&tc, 400),
        };
        let r = std::panic::catch_unwind(|| {
            let mut out = vec![0.0; 300];
            horizontal(&[0.0; 399], &tc, &pt, &mut out, Isa::Avx512);
        });
        // Only the AVX-512 path reads through the taps; others fall back to checked indexing,
        // which this row satisfies (its taps end at 399).
        assert_eq!(r.is_err(), Isa::Avx512.is_available());
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
