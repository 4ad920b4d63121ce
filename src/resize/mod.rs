//! The crate's one bilinear resize, like `cv2.resize(INTER_LINEAR)`: grey/colour planes, a
//! CFA-preserving mosaic resize (each of the four 2x2 super-pixel planes resized on its own, then
//! re-interleaved: the paper's super-pixel scale space), and several planes stored one after
//! another. Each may apply a row operation to every output row while it is in cache. Every
//! resize of the crate runs it: the HOG detector's pyramid levels ([`resize_then`], with HOG's
//! gamma or 8-bit rounding as the row operation), the ACF channel pyramid's exact levels
//! ([`resize_bilinear`], [`resize_mosaic`]) and its approximated levels
//! ([`resize_planes_scaled`]: the ten channel planes, each multiplied by its channel's power-law
//! factor in the row pass, [`mod@crate::detect::channels::pyramid`]), SIFT's x2 upsampling of
//! the input (`keypoints_double`), the training windows and the paper's experiments in `eval`.
//!
//! ```
//! use mosaicd::resize::{resize_bilinear, resize_mosaic};
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
//! then vertical linear interpolation in f32. The vertical pass also multiplies by a factor,
//! `(r0 + (r1 − r0)·fy)·k` with each operation rounded on its own: `k` is the plane's factor in
//! [`resize_planes_scaled`] and 1 elsewhere (a product by one is exact: the interpolation's bits).
//!
//! One resize has one set of taps (`taps` per axis), computed once and shared by its parallel
//! tasks (strips of 16 output rows of one plane; whole planes of a several-plane resize). Each
//! task keeps the horizontally resampled source rows it still needs (two per tile phase) and
//! interpolates each output row between two of them. Per kernel path (`resize::kernels`): the
//! horizontal pass picks each group's taps from a few consecutive source values by register
//! permutes where they fit (AVX2 `vpermps`, AVX-512 `vpermt2ps`, NEON `tbl`) and computes the
//! others one at a time; every path does the scalar pass's operations in its order (no fused
//! multiply-add), so every path gives the same bits.
//!
//! The mosaic resize follows the super-pixel scale space of the paper: a mosaic of size W x H is four
//! planes of W/2 x H/2 (one per tile position); each plane is resized to new_w/2 x new_h/2 and the
//! planes are interleaved again, so the result is a valid mosaic of the same pattern.
//!
//! # Deviations
//! OpenCV resizes 8-bit images in 11-bit fixed point; we resize f32, so pyramid levels other than
//! the first differ from OpenCV's by up to ±0.5 grey level. On float data OpenCV computes
//! `a·(1 − f) + b·f`, we compute `a + (b − a)·f` (one multiply, the SIMD passes' form): the two
//! agree within a few ulps (a test holds them within 1e-3 on values up to 175, the parity test
//! against `cv2.resize` in `tests/superpixel_parity.rs` within its tolerance), not bit for bit.

use rayon::prelude::*;

mod kernels;

use crate::image::{Image, ImageView};
use crate::kernels::Isa;
use kernels::{horizontal_row, prefetch_row, vertical_row, Perm16};

/// Output rows per parallel strip.
const STRIP_ROWS: usize = 16;

/// Errors of the resize.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ResizeError {
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
    /// Planes stored one after another whose buffers do not hold one plane per factor.
    #[error(
        "{planes} planes of {src_w}x{src_h} -> {dst_w}x{dst_h} need {} source and {} destination \
         values, got {src_len} and {dst_len}", planes * src_w * src_h, planes * dst_w * dst_h
    )]
    Planes {
        /// Planes (factors).
        planes: usize,
        /// Values in the source buffer.
        src_len: usize,
        /// Source plane width.
        src_w: usize,
        /// Source plane height.
        src_h: usize,
        /// Values in the destination buffer.
        dst_len: usize,
        /// Destination plane width.
        dst_w: usize,
        /// Destination plane height.
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

/// Column taps of a whole output row, one array per field (the SIMD passes load 8 or 16 of each
/// at once): output `x` is `a[p[x]] + (a[q[x]] − a[p[x]])·f[x]`.
#[derive(Debug, Clone, Default)]
struct ColumnTaps {
    p: Vec<u32>,
    q: Vec<u32>,
    f: Vec<f32>,
}

/// The column taps of a plane interleaved with `step` (1 = plain image, 2 = mosaic: output column
/// `x` samples plane `x % 2` at plane column `x / 2`).
fn column_taps(sw: usize, dw: usize, step: usize) -> ColumnTaps {
    let tx = taps(sw, dw);
    let n = dw * step;
    let mut t = ColumnTaps {
        p: Vec::with_capacity(n),
        q: Vec::with_capacity(n),
        f: Vec::with_capacity(n),
    };
    for x in 0..n {
        let (ox, dx) = (x % step, x / step);
        let (ix, fx) = tx[dx];
        let ix1 = (ix + 1).min(sw - 1);
        t.p.push((ox + ix * step) as u32);
        t.q.push((ox + ix1 * step) as u32);
        t.f.push(fx);
    }
    t
}

/// One resize (planes of `sw x sh` to `dw x dh`, interleaved with `step`) on kernel path `isa`:
/// its taps, computed once and shared by every run of output rows.
struct Plan {
    step: usize,
    sh: usize,
    dh: usize,
    tc: ColumnTaps,
    ty: Vec<(usize, f32)>,
    perms: PermTaps,
    isa: Isa,
}

impl Plan {
    /// The plan of a resize whose source rows hold `row_len` values.
    fn new(
        step: usize,
        (sw, sh): (usize, usize),
        (dw, dh): (usize, usize),
        row_len: usize,
        isa: Isa,
    ) -> Self {
        let tc = column_taps(sw, dw, step);
        let perms = PermTaps::new(isa, &tc, row_len);
        Self {
            step,
            sh,
            dh,
            tc,
            ty: taps(sh, dh),
            perms,
            isa,
        }
    }

    /// Output values per row.
    fn width(&self) -> usize {
        self.tc.p.len()
    }

    /// Output rows `y0, y0 + 1, …` into `rows` (whole rows), each from two source rows of the
    /// same tile phase (`src_row(r)` is source row `r`) and multiplied by `k`, then `row_op` on
    /// each while it is in cache. Per pixel the arithmetic is `r0 = a[p] + (a[q] − a[p])·fx`, `r1`
    /// likewise from the lower row, `(r0 + (r1 − r0)·fy)·k` (`k = 1`: the interpolation's bits).
    fn run<'a>(
        &self,
        src_row: impl Fn(usize) -> &'a [f32],
        y0: usize,
        rows: &mut [f32],
        k: f32,
        row_op: &RowOp,
    ) {
        let (step, sh, w, isa) = (self.step, self.sh, self.width(), self.isa);
        // Horizontally resampled source rows, two per tile phase: consecutive output rows of a
        // phase usually share a source row (scale < 2), so each is resampled once.
        let mut cache: Vec<[(usize, Vec<f32>); 2]> = (0..step)
            .map(|_| [(usize::MAX, vec![0.0f32; w]), (usize::MAX, vec![0.0f32; w])])
            .collect();
        for (i, row) in rows.chunks_mut(w).enumerate() {
            let y = y0 + i;
            let (oy, dy) = (y % step, y / step);
            let (iy, fy) = self.ty[dy];
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
                    horizontal(src_row(r), &self.tc, &self.perms, &mut slot.1, isa);
                    slot.0 = r;
                }
            }
            // Ask for the next output row's new source row now: its loads (a full-resolution
            // row, usually not in cache) then overlap the vertical pass and the row op.
            let yn = y + 1;
            if yn < self.dh * step {
                let (on, dn) = (yn % step, yn / step);
                let iyn = self.ty[dn].0;
                let next = [on + iyn * step, on + (iyn + 1).min(sh - 1) * step];
                let held = [cache[on][0].0, cache[on][1].0];
                if let Some(&r) = next.iter().find(|r| !held.contains(r)) {
                    prefetch_row(src_row(r));
                }
            }
            let slots = &cache[oy];
            let (sa, sb) = if slots[0].0 == ra {
                (&slots[0], &slots[1])
            } else {
                (&slots[1], &slots[0])
            };
            vertical(&sa.1, &sb.1, fy, k, row, isa);
            row_op(row);
        }
    }
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
    fn new(isa: Isa, tc: &ColumnTaps, row_len: usize) -> Self {
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
fn perm_taps(tc: &ColumnTaps, row_len: usize) -> Vec<Option<Perm16>> {
    (0..tc.p.len())
        .step_by(16)
        .map(|k| {
            let e = (k + 16).min(tc.p.len());
            let (p, q, f) = (&tc.p[k..e], &tc.q[k..e], &tc.f[k..e]);
            let lo = p.iter().zip(q).map(|(&a, &b)| a.min(b)).min()?;
            let top = p.iter().zip(q).map(|(&a, &b)| a.max(b)).max()?;
            let pairs = (top - lo) / 32 + 1;
            let span = 32 * pairs as usize;
            if p.len() < 16 || pairs > MAX_PAIRS || span > row_len {
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
            for k in 0..16 {
                (pm.p[k], pm.q[k], pm.fx[k]) = (p[k] - base, q[k] - base, f[k]);
            }
            Some(pm)
        })
        .collect()
}

/// `out[x] = a[p[x]] + (a[q[x]] − a[p[x]])·f[x]` for the column taps `tc` on kernel path `isa`
/// (every path gives the same bits; AVX2 and NEON pick a group's taps from a few consecutive
/// values by register permutes where they fit, AVX-512 permutes with `perms` where it has them).
///
/// # Panics
/// If `tc` has fewer taps than `out` values, or `perms` was built for other taps or longer rows.
fn horizontal(a: &[f32], tc: &ColumnTaps, perms: &PermTaps, out: &mut [f32], isa: Isa) {
    let n = out.len();
    assert!(
        tc.p.len() >= n && tc.q.len() >= n && tc.f.len() >= n,
        "horizontal pass: {n} outputs, {} / {} / {} taps",
        tc.p.len(),
        tc.q.len(),
        tc.f.len()
    );
    let (p, q, f) = (&tc.p[..], &tc.q[..], &tc.f[..]);
    #[cfg(not(target_arch = "x86_64"))]
    let _ = perms;
    match isa {
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 if !perms.perms.is_empty() && isa.is_available() => {
            // The bounds every Perm16 relies on: built for these taps and rows of row_len
            // values, and a holds them.
            assert!(
                perms.row_len <= a.len() && perms.perms.len() == n.div_ceil(16),
                "permute taps built for rows of {} values and {} outputs, row has {}, {n} outputs",
                perms.row_len,
                16 * perms.perms.len(),
                a.len()
            );
            // SAFETY: the path is available (AVX-512F, AVX2, FMA); perm_taps made each Perm16 with
            // base + 32·pairs ≤ row_len ≤ a.len() and offsets < 32·pairs; one per 16 outputs
            // (checked above), p/q/f hold n values.
            unsafe { kernels::avx512::horizontal(a, (p, q, f), &perms.perms, out) }
        }
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the path is available: AVX2 and FMA (the AVX-512 path includes both); p/q/f
        // hold n values (checked above); the kernel checks its loads from a.
        Isa::Avx2 | Isa::Avx512 if isa.is_available() => unsafe {
            kernels::avx2::horizontal(a, p, q, f, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 CPU; p/q/f hold n values (checked above); the
        // kernel checks its loads from a.
        Isa::Neon => unsafe { kernels::neon::horizontal(a, p, q, f, out) },
        _ => horizontal_row(a, p, q, f, out, 0),
    }
}

/// `out[x] = (r0[x] + (r1[x] − r0[x])·fy)·k` on kernel path `isa` (the same bits on every path).
fn vertical(r0: &[f32], r1: &[f32], fy: f32, k: f32, out: &mut [f32], isa: Isa) {
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the path is available: AVX2 and FMA. The kernel indexes with bounds checks.
        Isa::Avx2 | Isa::Avx512 if isa.is_available() => unsafe {
            kernels::avx2::vertical(r0, r1, fy, k, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 CPU; the kernel stays within the shortest slice.
        Isa::Neon => unsafe { kernels::neon::vertical(r0, r1, fy, k, out) },
        _ => vertical_row(r0, r1, fy, k, out),
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
) -> Result<(), ResizeError> {
    resize_then(src, new_w, new_h, false, dst, &|_| {})
}

/// CFA-preserving resize of a mosaic to `new_w x new_h` (both even).
pub fn resize_mosaic(
    src: ImageView<'_, f32>,
    new_w: usize,
    new_h: usize,
    dst: &mut Image<f32>,
) -> Result<(), ResizeError> {
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
) -> Result<(), ResizeError> {
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
) -> Result<(), ResizeError> {
    let (w, h) = (src.width(), src.height());
    let step = if mosaic { 2 } else { 1 };
    let (src_w, src_h, dst_w, dst_h) = (w, h, new_w, new_h);
    if w < step || h < step || new_w < step || new_h < step {
        return Err(ResizeError::Empty {
            src_w,
            src_h,
            dst_w,
            dst_h,
        });
    }
    if mosaic && w % 2 + h % 2 + new_w % 2 + new_h % 2 != 0 {
        return Err(ResizeError::OddSize {
            src_w,
            src_h,
            dst_w,
            dst_h,
        });
    }
    dst.reshape(new_w, new_h);
    let plan = Plan::new(step, (w / step, h / step), (new_w / step, new_h / step), w, isa);
    // Strips of output rows in parallel: one plane has too few for a task per plane.
    dst.as_mut_slice()
        .par_chunks_mut(new_w * STRIP_ROWS)
        .enumerate()
        .for_each(|(s, strip)| plan.run(|r| src.row(r), s * STRIP_ROWS, strip, 1.0, row_op));
    Ok(())
}

/// Bilinear resize ([`resize_bilinear`]'s taps and arithmetic) of the planes of `src_w x src_h`
/// values stored one after another in `src` into the planes of `new_w x new_h` values of `dst`
/// (as many), every output value of plane `c` multiplied by `factors[c]` (the ACF pyramid's
/// per-channel power law, [`mod@crate::detect::channels::pyramid`]). The factor is applied to each
/// output row in the vertical pass, a rounding of its own after the interpolation's: the bits of
/// [`resize_bilinear`] followed by a multiplication (a factor of 1 changes nothing). The planes
/// share one set of taps and run in parallel, each plane's rows in order.
///
/// ```
/// use mosaicd::resize::resize_planes_scaled;
/// // two 4x2 planes halved to 2x1, the second multiplied by 10
/// let src = [0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0, 8.0, 8.0, 4.0, 4.0, 8.0, 8.0];
/// let mut dst = [0.0; 4];
/// resize_planes_scaled(&src, 4, 2, 2, 1, &mut dst, &[1.0, 10.0]).unwrap();
/// assert_eq!(dst, [0.5, 2.5, 40.0, 80.0]);
/// ```
pub fn resize_planes_scaled(
    src: &[f32],
    src_w: usize,
    src_h: usize,
    new_w: usize,
    new_h: usize,
    dst: &mut [f32],
    factors: &[f32],
) -> Result<(), ResizeError> {
    let isa = crate::kernels::isa();
    resize_planes_scaled_with(src, (src_w, src_h), (new_w, new_h), dst, factors, isa)
}

/// [`resize_planes_scaled`] (source planes `src_w x src_h`, output planes `new_w x new_h`) on
/// kernel path `isa` (every path gives the same bits).
pub(crate) fn resize_planes_scaled_with(
    src: &[f32],
    (src_w, src_h): (usize, usize),
    (new_w, new_h): (usize, usize),
    dst: &mut [f32],
    factors: &[f32],
    isa: Isa,
) -> Result<(), ResizeError> {
    let (n_src, n_dst) = (src_w * src_h, new_w * new_h);
    if n_src == 0 || n_dst == 0 {
        return Err(ResizeError::Empty {
            src_w,
            src_h,
            dst_w: new_w,
            dst_h: new_h,
        });
    }
    let planes = factors.len();
    if src.len() != planes * n_src || dst.len() != planes * n_dst {
        return Err(ResizeError::Planes {
            planes,
            src_len: src.len(),
            src_w,
            src_h,
            dst_len: dst.len(),
            dst_w: new_w,
            dst_h: new_h,
        });
    }
    let plan = Plan::new(1, (src_w, src_h), (new_w, new_h), src_w, isa);
    dst.par_chunks_mut(n_dst)
        .zip(src.par_chunks(n_src))
        .zip(factors)
        .for_each(|((out, plane), &k)| plan.run(|r| &plane[r * src_w..][..src_w], 0, out, k, &|_| {}));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// OpenCV's float `INTER_LINEAR` as written in `cv2.resize` (the test oracle: a bilinear
    /// resize in the form `a·(1 − f) + b·f`, taps from f64 source positions): our
    /// `a + (b − a)·f` rounds differently, so the two agree to a few ulps, not bit for bit.
    fn opencv_form(src: ImageView<'_, f32>, new_w: usize, new_h: usize) -> Image<f32> {
        let taps = |src_n: usize, dst_n: usize| -> Vec<(usize, usize, f32)> {
            let scale = src_n as f64 / dst_n as f64;
            (0..dst_n)
                .map(|d| {
                    let f = ((d as f64 + 0.5) * scale - 0.5) as f32;
                    let mut s = f.floor() as isize;
                    let mut a = f - s as f32;
                    if s < 0 {
                        s = 0;
                        a = 0.0;
                    }
                    if s as usize >= src_n - 1 {
                        s = src_n as isize - 1;
                        a = 0.0;
                    }
                    let s = s as usize;
                    (s, (s + 1).min(src_n - 1), a)
                })
                .collect()
        };
        let (xt, yt) = (taps(src.width(), new_w), taps(src.height(), new_h));
        Image::from_fn(new_w, new_h, |x, y| {
            let ((x0, x1, a), (y0, y1, b)) = (xt[x], yt[y]);
            let h = |r: usize| src.get(x0, r) * (1.0 - a) + src.get(x1, r) * a;
            h(y0) * (1.0 - b) + h(y1) * b
        })
    }

    /// [`opencv_form`] on each of a mosaic's four planes, interleaved again.
    fn opencv_form_mosaic(src: &Image<f32>, new_w: usize, new_h: usize) -> Image<f32> {
        let (pw, ph) = (src.width() / 2, src.height() / 2);
        let planes: Vec<Image<f32>> = [(0, 0), (1, 0), (0, 1), (1, 1)]
            .iter()
            .map(|&(ox, oy)| {
                let p = Image::<f32>::from_fn(pw, ph, |x, y| src.get(2 * x + ox, 2 * y + oy));
                opencv_form(p.view(), new_w / 2, new_h / 2)
            })
            .collect();
        Image::from_fn(new_w, new_h, |x, y| {
            planes[(x & 1) + 2 * (y & 1)].get(x / 2, y / 2)
        })
    }

    #[test]
    fn resizes_agree_with_opencv_s_float_form() {
        // The one resize computes `a + (b − a)·f` (one multiply: the SIMD passes' form); OpenCV's
        // float resize `a·(1 − f) + b·f`. Values up to 175: agreement within 1e-3 absolute
        // (a few ulps), for grey planes and mosaics alike, shrinking and enlarging.
        let src = Image::<f32>::from_fn(146, 98, |x, y| ((x * 37 + y * 91 + x * y) % 251) as f32 * 0.7);
        let worst = |a: &Image<f32>, b: &Image<f32>| {
            assert_eq!(a.dimensions(), b.dimensions());
            a.as_slice()
                .iter()
                .zip(b.as_slice())
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f32::max)
        };
        for (w, h) in [(146, 98), (120, 80), (62, 44), (200, 130), (10, 6), (292, 196)] {
            let mut ours = Image::new(0, 0);
            resize_bilinear(src.view(), w, h, &mut ours).unwrap();
            let d = worst(&ours, &opencv_form(src.view(), w, h));
            assert!(d <= 1e-3, "grey {w}x{h}: {d}");
            resize_mosaic(src.view(), w, h, &mut ours).unwrap();
            let d = worst(&ours, &opencv_form_mosaic(&src, w, h));
            assert!(d <= 1e-3, "mosaic {w}x{h}: {d}");
        }
        // and they do differ somewhere (the test would not notice a change of form otherwise)
        let mut ours = Image::new(0, 0);
        resize_bilinear(src.view(), 120, 80, &mut ours).unwrap();
        assert_ne!(ours, opencv_form(src.view(), 120, 80));
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
    fn doubling_interpolates_quarters() {
        // 2 -> 4: s = (d + 0.5)/2 - 0.5 = -0.25 (clamped), 0.25, 0.75, 1.25 (clamped).
        let src = Image::from_vec(2, 1, vec![0.0f32, 4.0]).unwrap();
        let mut d = Image::new(0, 0);
        resize_bilinear(src.view(), 4, 1, &mut d).unwrap();
        assert_eq!(d.as_slice(), &[0.0, 1.0, 3.0, 4.0]);
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

    /// The scalar horizontal pass over a whole row.
    fn h_row(a: &[f32], tc: &ColumnTaps, out: &mut [f32]) {
        horizontal_row(a, &tc.p, &tc.q, &tc.f, out, 0);
    }

    #[test]
    fn kernel_paths_row_passes_equal_the_scalar_ones_bit_for_bit() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        // Planes and mosaics shrunk by up to 2.2x (AVX2 groups of 8 spanning more than 16 values
        // and NEON groups of 4 spanning more than 8 fall back to the scalar pass) and enlarged,
        // every path's whole vectors and tails.
        for (sw, dw, step) in [
            (480usize, 440usize, 1usize),
            (480, 339, 1),
            (480, 240, 1),
            (480, 218, 1),
            (240, 311, 1),
            (50, 37, 1),
            (33, 31, 1),
            (9, 8, 1),
            (5, 7, 1),
            (1, 3, 1),
            (240, 200, 2),
            (240, 120, 2),
            (240, 109, 2),
            (120, 155, 2),
        ] {
            let a: Vec<f32> = (0..sw * step).map(|_| rng.random_range(-2.0..2.0)).collect();
            let b: Vec<f32> = (0..dw * step).map(|_| rng.random_range(-2.0..2.0)).collect();
            let mut tc = column_taps(sw, dw, step);
            if dw > 20 {
                // taps out of order (not a resize's): still the scalar pass's values
                tc.p.swap(3, 17);
                tc.q.swap(9, 2);
            }
            let none = PermTaps::default();
            let (mut h, mut v) = (vec![f32::NAN; dw * step], vec![f32::NAN; dw * step]);
            h_row(&a, &tc, &mut h);
            vertical_row(&h, &b, 0.37, 1.08, &mut v);
            for isa in Isa::available() {
                let (mut h2, mut v2) = (vec![f32::NAN; dw * step], vec![f32::NAN; dw * step]);
                horizontal(&a, &tc, &none, &mut h2, isa);
                vertical(&h2, &b, 0.37, 1.08, &mut v2, isa);
                assert_eq!(bits(&h2), bits(&h), "{isa} horizontal {sw} -> {dw}, step {step}");
                assert_eq!(bits(&v2), bits(&v), "{isa} vertical {dw}, step {step}");
            }
        }
    }

    #[test]
    fn several_planes_resize_as_one_each_then_the_factor_bit_for_bit() {
        // The ACF pyramid's resampling: ten planes, each resized as resize_bilinear does, then
        // multiplied by its factor (one rounding after the resize's), on every kernel path.
        let (sw, sh) = (121, 67);
        let src: Vec<f32> = (0..10 * sw * sh)
            .map(|i| ((i * 37 + i / 13) % 251) as f32 * 0.013 + 0.001)
            .collect();
        let k: Vec<f32> = (0..10)
            .map(|c| 0.8f32.powf(-0.11 * c as f32) + c as f32 * 0.01)
            .collect();
        for (w, h) in [(110, 61), (85, 47), (60, 33), (144, 80), (121, 67), (1, 1)] {
            let mut want = vec![0.0f32; 10 * w * h];
            for (c, out) in want.chunks_mut(w * h).enumerate() {
                let plane = Image::from_vec(sw, sh, src[c * sw * sh..][..sw * sh].to_vec()).unwrap();
                let mut d = Image::new(0, 0);
                resize_bilinear(plane.view(), w, h, &mut d).unwrap();
                for (o, &v) in out.iter_mut().zip(d.as_slice()) {
                    *o = v * k[c];
                }
            }
            for isa in Isa::available() {
                let mut got = vec![f32::NAN; 10 * w * h];
                resize_planes_scaled_with(&src, (sw, sh), (w, h), &mut got, &k, isa).unwrap();
                assert_eq!(bits(&got), bits(&want), "{isa} {w}x{h}");
            }
        }
    }

    #[test]
    fn planes_that_do_not_fit_their_buffers_are_refused() {
        let src = vec![0.0f32; 2 * 6 * 4];
        let mut dst = vec![0.0f32; 2 * 3 * 2];
        let k = [1.0, 2.0];
        assert!(resize_planes_scaled(&src, 6, 4, 3, 2, &mut dst, &k).is_ok());
        assert!(matches!(
            resize_planes_scaled(&src[1..], 6, 4, 3, 2, &mut dst, &k),
            Err(ResizeError::Planes { src_len: 47, .. })
        ));
        assert!(matches!(
            resize_planes_scaled(&src, 6, 4, 3, 2, &mut dst[1..], &k),
            Err(ResizeError::Planes { dst_len: 11, .. })
        ));
        assert!(matches!(
            resize_planes_scaled(&src, 6, 4, 3, 2, &mut dst, &k[..1]),
            Err(ResizeError::Planes { planes: 1, .. })
        ));
        assert!(matches!(
            resize_planes_scaled(&src, 6, 4, 0, 2, &mut dst, &k),
            Err(ResizeError::Empty { dst_w: 0, .. })
        ));
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
                h_row(src.row(y % step + iy * step), &tc, &mut rows.0);
                h_row(src.row(y % step + iy1 * step), &tc, &mut rows.1);
                vertical_row(&rows.0, &rows.1, fy, 1.0, out);
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
            h_row(&a, &tc, &mut want);
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
        // Taps of a 400-value row (they end at 399), permutes built for rows of 410 values.
        let tc = column_taps(400, 300, 1);
        let pt = PermTaps {
            row_len: 410,
            perms: perm_taps(&tc, 410),
        };
        let r = std::panic::catch_unwind(|| {
            let mut out = vec![0.0; 300];
            horizontal(&[0.0; 400], &tc, &pt, &mut out, Isa::Avx512);
        });
        // Only the AVX-512 path reads through the permute taps; without AVX-512 the pass falls
        // back to checked indexing, which this row satisfies.
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
            Err(ResizeError::OddSize { .. })
        ));
    }
}
