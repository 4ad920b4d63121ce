//! Row kernels of the SIFT pyramid and of the gradient layers, one body per kernel compiled for
//! every instruction-set path of the kernel layer ([`crate::kernels`]).
//!
//! Each kernel is written once as an `#[inline(always)]` body over fixed-size stack chunks, which
//! LLVM vectorises. The body is instantiated once per [`Isa`]: [`Isa::Scalar`] is the body built
//! for the baseline target (SSE2 on x86-64); [`Isa::Avx2`] and [`Isa::Avx512`] are copies inside
//! `#[target_feature]` functions chosen at run time; [`Isa::Neon`] is the aarch64 copy (NEON is
//! baseline there, so the body is already vectorised for it: 4-lane `fmul`/`fadd`/`fcm*` on
//! `v.4s` registers, checked in the cross build's assembly, docs/sift.md "Speed"). No path
//! enables fused multiply-add contraction (Rust never contracts `a * b + c`), so every path
//! performs the same IEEE operations in the same order: all paths are **bit-equal** to the
//! straightforward scalar loops kept in the tests (and to the reference `fast_atan2_deg`),
//! checked there for every path in [`Isa::available`]. The process's path is [`crate::kernels::isa`]
//! (override: `MOSAICD_KERNELS`). The kernels take slices and do not allocate.

use crate::kernels::Isa;

/// Pixels accumulated on the stack per step of the blur kernels (32 floats: four AVX2 or two
/// AVX-512 registers of accumulators, eight NEON registers).
const CHUNK: usize = 32;

/// Defines a dispatching function `$name(isa, args..)` over one `#[inline(always)]` body: the
/// baseline copy, AVX2 / AVX-512 copies compiled with those features on x86-64, and the aarch64
/// (NEON) copy. A path this CPU cannot run falls back to the baseline copy.
macro_rules! dispatch {
    ($(#[$m:meta])* $name:ident, $body:ident, ($($arg:ident: $ty:ty),*)) => {
        $(#[$m])*
        pub(crate) fn $name(isa: Isa, $($arg: $ty),*) {
            #[cfg(target_arch = "x86_64")]
            {
                /// # Safety
                /// The CPU must support AVX2.
                #[target_feature(enable = "avx2")]
                unsafe fn avx2($($arg: $ty),*) {
                    $body($($arg),*)
                }
                /// # Safety
                /// The CPU must support AVX2 and AVX-512 F/VL.
                #[target_feature(enable = "avx2,avx512f,avx512vl")]
                unsafe fn avx512($($arg: $ty),*) {
                    $body($($arg),*)
                }
                match isa {
                    Isa::Avx2 if Isa::Avx2.is_available() => {
                        debug_assert!(Isa::Avx2.is_available());
                        // SAFETY: AVX2 support was just checked. The body indexes slices with
                        // bounds checks, so the only precondition is the instruction set.
                        // Measured gain in docs/sift.md ("Speed").
                        return unsafe { avx2($($arg),*) };
                    }
                    Isa::Avx512 if Isa::Avx512.is_available() => {
                        debug_assert!(Isa::Avx512.is_available());
                        // SAFETY: AVX2 and AVX-512 F/VL support was just checked; the body is
                        // bounds-checked safe code.
                        return unsafe { avx512($($arg),*) };
                    }
                    _ => {}
                }
            }
            #[cfg(target_arch = "aarch64")]
            {
                /// The NEON copy: Advanced SIMD is part of the aarch64 baseline, so this is
                /// the body as LLVM vectorises it for 128-bit registers.
                fn neon($($arg: $ty),*) {
                    $body($($arg),*)
                }
                if isa == Isa::Neon {
                    return neon($($arg),*);
                }
            }
            let _ = isa;
            $body($($arg),*)
        }
    };
}

dispatch!(
    /// Horizontal pass of the symmetric blur on the interior `lo..hi` of one row:
    /// `out[x] = taps[r] row[x] + sum_k taps[r + k] (row[x - k step] + row[x + k step])`, the
    /// sum taken in order `k = 1..=r`. Needs `lo >= r step` and `hi + r step <= row.len()`.
    blur_row_interior,
    blur_row_interior_body,
    (row: &[f32], taps: &[f32], step: usize, lo: usize, hi: usize, out: &mut [f32])
);

dispatch!(
    /// Vertical pass of the symmetric blur for one output row:
    /// `out[x] = taps[r] center[x] + sum_k taps[r + k] (up[k - 1][x] + down[k - 1][x])`, the sum
    /// taken in order `k = 1..=r`. `up` and `down` hold the `r` rows above and below (already
    /// reflected at the border).
    blur_col,
    blur_col_body,
    (center: &[f32], up: &[&[f32]], down: &[&[f32]], taps: &[f32], out: &mut [f32])
);

dispatch!(
    /// [`blur_col`] that also writes the difference of Gaussians `dog[x] = out[x] - lower[x]`
    /// of the row while it is in registers (`lower` is the less blurred layer's row).
    #[allow(clippy::too_many_arguments)]
    blur_col_dog,
    blur_col_dog_body,
    (center: &[f32], up: &[&[f32]], down: &[&[f32]], taps: &[f32], lower: &[f32],
     out: &mut [f32], dog: &mut [f32])
);

dispatch!(
    /// Gradient magnitude and orientation of a list of gradients: `mag[i] = sqrt(dx² + dy²)`,
    /// `ori[i] = fast_atan2_deg(dy[i], dx[i])` (OpenCV's polynomial) (degrees in [0, 360)). All slices have the same
    /// length.
    polar,
    polar_body,
    (dx: &[f32], dy: &[f32], mag: &mut [f32], ori: &mut [f32])
);

dispatch!(
    /// Extremum pre-test of one DoG row: `flags[x] = 1` when `|cur[x]| > threshold` and
    /// `cur[x]` is at least (positive) or at most (negative) each of its same-row neighbours
    /// `cur[x ± k]`, `k = 1..=reach`, and `prev[x]`, `next[x]`; else 0. These are 2 reach + 2 of
    /// the extremum test's neighbours, so a pixel flagged 0 can never pass the full test. Only
    /// `x in reach..w - reach` is written.
    extremum_pretest,
    extremum_pretest_body,
    (prev: &[f32], cur: &[f32], next: &[f32], reach: usize, threshold: f32, flags: &mut [u8])
);

#[inline(always)]
fn chunk(s: &[f32], at: usize) -> &[f32; CHUNK] {
    s[at..at + CHUNK].try_into().expect("slice of CHUNK elements")
}

#[inline(always)]
fn blur_row_interior_body(row: &[f32], taps: &[f32], step: usize, lo: usize, hi: usize, out: &mut [f32]) {
    let r = taps.len() / 2;
    let c = taps[r];
    let mut x = lo;
    while x + CHUNK <= hi {
        let mut acc = [0.0f32; CHUNK];
        for (a, &v) in acc.iter_mut().zip(chunk(row, x)) {
            *a = c * v;
        }
        for (k, &t) in taps[r + 1..].iter().enumerate() {
            let d = (k + 1) * step;
            let (a, b) = (chunk(row, x - d), chunk(row, x + d));
            for ((o, &va), &vb) in acc.iter_mut().zip(a).zip(b) {
                *o += t * (va + vb);
            }
        }
        out[x..x + CHUNK].copy_from_slice(&acc);
        x += CHUNK;
    }
    for (x, o) in out.iter_mut().enumerate().take(hi).skip(x) {
        let mut acc = c * row[x];
        for (k, &t) in taps[r + 1..].iter().enumerate() {
            let d = (k + 1) * step;
            acc += t * (row[x - d] + row[x + d]);
        }
        *o = acc;
    }
}

#[inline(always)]
fn blur_col_body(center: &[f32], up: &[&[f32]], down: &[&[f32]], taps: &[f32], out: &mut [f32]) {
    blur_col_dog_body(center, up, down, taps, &[], out, &mut []);
}

/// The vertical pass; the difference to `lower` is written to `dog` unless `dog` is empty.
#[inline(always)]
fn blur_col_dog_body(
    center: &[f32],
    up: &[&[f32]],
    down: &[&[f32]],
    taps: &[f32],
    lower: &[f32],
    out: &mut [f32],
    dog: &mut [f32],
) {
    let with_dog = !dog.is_empty();
    let r = taps.len() / 2;
    let c = taps[r];
    let w = out.len();
    let mut x = 0;
    while x + CHUNK <= w {
        let mut acc = [0.0f32; CHUNK];
        for (a, &v) in acc.iter_mut().zip(chunk(center, x)) {
            *a = c * v;
        }
        for ((&t, ru), rd) in taps[r + 1..].iter().zip(up).zip(down) {
            let (a, b) = (chunk(ru, x), chunk(rd, x));
            for ((o, &va), &vb) in acc.iter_mut().zip(a).zip(b) {
                *o += t * (va + vb);
            }
        }
        out[x..x + CHUNK].copy_from_slice(&acc);
        if with_dog {
            let d: &mut [f32; CHUNK] = (&mut dog[x..x + CHUNK]).try_into().expect("CHUNK elements");
            for ((o, &b), &a) in d.iter_mut().zip(&acc).zip(chunk(lower, x)) {
                *o = b - a;
            }
        }
        x += CHUNK;
    }
    for x in x..w {
        let mut acc = c * center[x];
        for ((&t, ru), rd) in taps[r + 1..].iter().zip(up).zip(down) {
            acc += t * (ru[x] + rd[x]);
        }
        out[x] = acc;
        if with_dog {
            dog[x] = acc - lower[x];
        }
    }
}

/// The reference `fast_atan2_deg` without branches (selects only), so that it vectorises; bit-equal to it.
// `!(ax >= ay)` on purpose: it is the reference's else branch, NaN included.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn fast_atan2_deg_select(y: f32, x: f32) -> f32 {
    const P1: f32 = 57.283_627;
    const P3: f32 = -18.667_446;
    const P5: f32 = 8.914_001;
    const P7: f32 = -2.539_725;
    const EPS: f32 = f64::EPSILON as f32;
    let (ax, ay) = (x.abs(), y.abs());
    // The reference takes the first branch when `ax >= ay` (false for NaN as well).
    let swap = !(ax >= ay);
    let (num, den) = if swap { (ax, ay) } else { (ay, ax) };
    let c = num / (den + EPS);
    let c2 = c * c;
    let p = (((P7 * c2 + P5) * c2 + P3) * c2 + P1) * c;
    let a = if swap { 90.0 - p } else { p };
    let a = if x < 0.0 { 180.0 - a } else { a };
    if y < 0.0 {
        360.0 - a
    } else {
        a
    }
}

#[inline(always)]
fn polar_body(dx: &[f32], dy: &[f32], mag: &mut [f32], ori: &mut [f32]) {
    let n = dx.len();
    let (dy, mag, ori) = (&dy[..n], &mut mag[..n], &mut ori[..n]);
    for i in 0..n {
        let (gx, gy) = (dx[i], dy[i]);
        mag[i] = (gx * gx + gy * gy).sqrt();
        ori[i] = fast_atan2_deg_select(gy, gx);
    }
}

#[inline(always)]
fn extremum_pretest_body(
    prev: &[f32],
    cur: &[f32],
    next: &[f32],
    reach: usize,
    threshold: f32,
    flags: &mut [u8],
) {
    match reach {
        1 => extremum_pretest_fixed::<1>(prev, cur, next, threshold, flags),
        2 => extremum_pretest_fixed::<2>(prev, cur, next, threshold, flags),
        _ => extremum_pretest_any(prev, cur, next, reach, threshold, flags),
    }
}

/// The pre-test with the reach known at compile time: comparisons only (`!(v < u)` is the
/// reference's "not rejected by u", NaN included), so each lane is a few masks.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
#[inline(always)]
fn extremum_pretest_fixed<const R: usize>(
    prev: &[f32],
    cur: &[f32],
    next: &[f32],
    threshold: f32,
    flags: &mut [u8],
) {
    let w = cur.len();
    if w <= 2 * R {
        return;
    }
    let n = w - 2 * R;
    let (p, c, q, f) = (
        &prev[R..R + n],
        &cur[R..R + n],
        &next[R..R + n],
        &mut flags[R..R + n],
    );
    let (l1, r1) = (&cur[R - 1..R - 1 + n], &cur[R + 1..R + 1 + n]);
    let (l2, r2) = if R >= 2 {
        (&cur[R - 2..R - 2 + n], &cur[R + 2..R + 2 + n])
    } else {
        (l1, r1)
    };
    for i in 0..n {
        let v = c[i];
        let not_below = !(v < p[i]) & !(v < q[i]) & !(v < l1[i]) & !(v < r1[i]) & !(v < l2[i]) & !(v < r2[i]);
        let not_above = !(v > p[i]) & !(v > q[i]) & !(v > l1[i]) & !(v > r1[i]) & !(v > l2[i]) & !(v > r2[i]);
        let keep = (v.abs() > threshold) & (((v > 0.0) & not_below) | ((v < 0.0) & not_above));
        f[i] = u8::from(keep);
    }
}

/// The pre-test for any reach (not used by SIFT's steps 1 and 2, kept for completeness).
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn extremum_pretest_any(
    prev: &[f32],
    cur: &[f32],
    next: &[f32],
    reach: usize,
    threshold: f32,
    flags: &mut [u8],
) {
    let w = cur.len();
    for x in reach..w.saturating_sub(reach) {
        let v = cur[x];
        let nb = [prev[x], next[x]]
            .into_iter()
            .chain((1..=reach).flat_map(|k| [cur[x - k], cur[x + k]]));
        let keep = v.abs() > threshold
            && ((v > 0.0 && nb.clone().all(|u| !(v < u))) || (v < 0.0 && nb.clone().all(|u| !(v > u))));
        flags[x] = u8::from(keep);
    }
}

#[cfg(test)]
mod tests {
    use super::super::detect::fast_atan2_deg;
    use super::*;
    use rand::{Rng, SeedableRng};

    fn noise(n: usize, seed: u64) -> Vec<f32> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| rng.random_range(-300.0f32..300.0)).collect()
    }

    #[test]
    fn select_atan2_is_bit_equal_to_the_reference() {
        let v = noise(20_000, 1);
        let special = [0.0f32, -0.0, 1.0, -1.0, 1e-30, -1e-30, f32::NAN, f32::INFINITY];
        let pairs = v
            .chunks(2)
            .map(|p| (p[0], p[1]))
            .chain(special.iter().flat_map(|&a| special.iter().map(move |&b| (a, b))));
        for (y, x) in pairs {
            let (a, b) = (fast_atan2_deg(y, x), fast_atan2_deg_select(y, x));
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "{y} {x}: {a} {b}"
            );
        }
    }

    #[test]
    fn kernel_paths_are_bit_equal_to_the_scalar_loops() {
        let w = 203;
        let rows: Vec<Vec<f32>> = (0..25).map(|i| noise(w, 10 + i)).collect();
        for path in Isa::available() {
            for step in [1, 2, 3] {
                for ntaps in [1, 3, 11, 25] {
                    let taps: Vec<f32> = noise(ntaps, 99 + ntaps as u64).iter().map(|v| v.abs()).collect();
                    let r = ntaps / 2;
                    let (lo, hi) = (r * step, w - r * step);
                    // Horizontal pass against the per-pixel loop.
                    let mut out = vec![0.0f32; w];
                    blur_row_interior(path, &rows[0], &taps, step, lo, hi, &mut out);
                    for x in lo..hi {
                        let mut acc = taps[r] * rows[0][x];
                        for k in 1..=r {
                            acc += taps[r + k] * (rows[0][x - k * step] + rows[0][x + k * step]);
                        }
                        assert_eq!(acc.to_bits(), out[x].to_bits(), "{path:?} h {step} {ntaps} {x}");
                    }
                    // Vertical pass against the per-pixel loop.
                    let up: Vec<&[f32]> = (1..=r).map(|k| rows[k].as_slice()).collect();
                    let down: Vec<&[f32]> = (1..=r).map(|k| rows[12 + k].as_slice()).collect();
                    blur_col(path, &rows[0], &up, &down, &taps, &mut out);
                    for (x, &o) in out.iter().enumerate() {
                        let mut acc = taps[r] * rows[0][x];
                        for k in 1..=r {
                            acc += taps[r + k] * (up[k - 1][x] + down[k - 1][x]);
                        }
                        assert_eq!(acc.to_bits(), o.to_bits(), "{path:?} v {ntaps} {x}");
                    }
                    let mut dog = vec![0.0f32; w];
                    let mut out2 = vec![0.0f32; w];
                    blur_col_dog(path, &rows[0], &up, &down, &taps, &rows[3], &mut out2, &mut dog);
                    for x in 0..w {
                        assert_eq!(out[x].to_bits(), out2[x].to_bits(), "{path:?} v+dog {ntaps} {x}");
                        assert_eq!(
                            (out[x] - rows[3][x]).to_bits(),
                            dog[x].to_bits(),
                            "{path:?} dog {x}"
                        );
                    }
                }
                let mut flags = vec![9u8; w];
                extremum_pretest(path, &rows[4], &rows[5], &rows[6], step, 150.0, &mut flags);
                for x in step..w - step {
                    let v = rows[5][x];
                    let mut nb = vec![rows[4][x], rows[6][x]];
                    nb.extend((1..=step).flat_map(|k| [rows[5][x - k], rows[5][x + k]]));
                    let want = v.abs() > 150.0
                        && ((v > 0.0 && nb.iter().all(|&u| v >= u))
                            || (v < 0.0 && nb.iter().all(|&u| v <= u)));
                    assert_eq!(flags[x], u8::from(want), "{path:?} pretest {x}");
                }
                let (mut mag, mut ori) = (vec![0.0f32; w], vec![0.0f32; w]);
                polar(path, &rows[1], &rows[2], &mut mag, &mut ori);
                for x in 0..w {
                    let (dx, dy) = (rows[1][x], rows[2][x]);
                    assert_eq!((dx * dx + dy * dy).sqrt().to_bits(), mag[x].to_bits());
                    assert_eq!(fast_atan2_deg(dy, dx).to_bits(), ori[x].to_bits());
                }
            }
        }
    }
}
