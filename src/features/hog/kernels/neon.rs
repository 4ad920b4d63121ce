//! The NEON builds of the HOG kernels (aarch64: Jetson Orin, Raspberry Pi 5, RK3588): the cell
//! histograms with micro-cells pooled in the same pass, and the approximated levels' fill, with
//! each cell's histograms accumulated in 128-bit registers (`R` = ⌈nbins / 4⌉ registers per
//! histogram), and the half-float conversions by `fcvtn` / `fcvtl`. The gradient, gamma and block
//! passes are the portable kernels, which LLVM vectorises for NEON (every aarch64 CPU has it).
//!
//! The register kernels mirror the AVX2 ones ([`super`] for the scheme): a pixel's two votes
//! become the one-hot vector `w0·e(b0) + w1·e(b1)`, here by a byte table lookup (`tbl`) of
//! `[w0, w1, +0, +0]` whose out-of-range indices give zero bytes; each lane then sees the fused
//! multiply-adds (`fmla`) of the scalar code in its order, so the results are the same bits.
//!
//! Every function here needs NEON; its callers in `kernels` check it first.

use std::arch::aarch64::*;

use super::super::gradient::gradient_row;
use super::super::types::{
    cell_len, cell_slot, live_profiles, CellScratch, MicroGrid, Planes, Taps, LEFT_PROFILES, RIGHT_PROFILES,
};
use super::super::{HogSpec, CELL_SIZE, PROFILES};
use super::f16::neon::{f16x4_from_f32, f32x4_from_f16};
use super::portable;

/// The first `dst.len()` (≤ 4·R) lanes of `v` into `dst`.
#[target_feature(enable = "neon")]
fn store_lanes<const R: usize>(v: &[float32x4_t; R], dst: &mut [f32]) {
    let mut t = [[0.0f32; 4]; R];
    for (r, x) in v.iter().enumerate() {
        // SAFETY: `t[r]` holds 4 floats.
        unsafe { vst1q_f32(t[r].as_mut_ptr(), *x) };
    }
    dst.copy_from_slice(&t.as_flattened()[..dst.len()]);
}

/// The one-hot vote byte tables: `tbl` of `[w0, w1, +0, +0]` (as bytes) with `idx[b0][r]` puts
/// `w0` in bin `b0`, `w1` in bin `(b0 + 1) mod nb` and zero bytes (index 255) elsewhere, for the
/// bins `4r .. 4r + 4` of register `r`.
#[target_feature(enable = "neon")]
fn vote_tables<const R: usize>(nb: usize) -> [[uint8x16_t; R]; 16] {
    let mut t = [[[255u8; 16]; R]; 16];
    for (b0, regs) in t.iter_mut().enumerate().take(nb) {
        let b1 = (b0 + 1) % nb;
        for (r, bytes) in regs.iter_mut().enumerate() {
            for l in 0..4 {
                let bin = 4 * r + l;
                let src = if bin == b0 {
                    Some(0u8)
                } else if bin == b1 {
                    Some(4)
                } else {
                    None
                };
                if let Some(s) = src {
                    for k in 0..4 {
                        bytes[4 * l + k] = s + k as u8;
                    }
                }
            }
        }
    }
    // SAFETY: every `bytes` array holds 16 bytes.
    t.map(|regs| regs.map(|bytes| unsafe { vld1q_u8(bytes.as_ptr()) }))
}

/// A pixel's two votes `w` as the one-hot vector `w0·e(b0) + w1·e(b1)`, by the byte tables
/// `t` of its bin `b0` ([`vote_tables`]).
#[target_feature(enable = "neon")]
#[inline]
fn vote<const R: usize>(t: &[uint8x16_t; R], [w0, w1]: [f32; 2]) -> [float32x4_t; R] {
    let pair = [w0, w1, 0.0, 0.0];
    // SAFETY: `pair` holds 4 floats.
    let s = vreinterpretq_u8_f32(unsafe { vld1q_f32(pair.as_ptr()) });
    let mut v = [vdupq_n_f32(0.0); R];
    for (x, idx) in v.iter_mut().zip(t) {
        *x = vreinterpretq_f32_u8(vqtbl1q_u8(s, *idx));
    }
    v
}

/// The cell rows from `cy0` on (as many as `chunk` holds) with each cell's votes in registers.
///
/// # Safety
/// The CPU must support NEON; `spec` has ≤ 16 bins and its profiles have the fixed zeros
/// (`types::profiles_have_fixed_zeros`).
#[target_feature(enable = "neon")]
pub(crate) unsafe fn cells_strip(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
) {
    // SAFETY: this function's contract; R registers hold 4R ≥ nbins bins.
    unsafe {
        match spec.nbins().div_ceil(4) {
            0 | 1 => cells_body::<false, 1>(spec, p, cy0, chunk, cs, &mut []),
            2 => cells_body::<false, 2>(spec, p, cy0, chunk, cs, &mut []),
            3 => cells_body::<false, 3>(spec, p, cy0, chunk, cs, &mut []),
            _ => cells_body::<false, 4>(spec, p, cy0, chunk, cs, &mut []),
        }
    }
}

/// [`cells_strip`] for one cell row `cy` that also pools its 4 rows of 2x2-pixel micro-cells into
/// `micro` from the same votes (the bits of `portable::micro_rows`).
///
/// # Safety
/// As [`cells_strip`]; `chunk` is one cell row and `micro` holds its 4 micro rows; the scratch
/// rows hold `8 · 2·(p.width / 2)` pixels.
#[target_feature(enable = "neon")]
pub(crate) unsafe fn cells_micro_row(
    spec: &HogSpec,
    p: &Planes,
    cy: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    // SAFETY: this function's contract; R registers hold 4R ≥ nbins bins.
    unsafe {
        match spec.nbins().div_ceil(4) {
            0 | 1 => cells_body::<true, 1>(spec, p, cy, chunk, cs, micro),
            2 => cells_body::<true, 2>(spec, p, cy, chunk, cs, micro),
            3 => cells_body::<true, 3>(spec, p, cy, chunk, cs, micro),
            _ => cells_body::<true, 4>(spec, p, cy, chunk, cs, micro),
        }
    }
}

/// The body of [`cells_strip`] and [`cells_micro_row`] with `R` 4-lane registers per histogram
/// (the AVX2 body's scheme: row accumulators per pixel row, then the cell's histograms one
/// x-profile at a time).
///
/// # Safety
/// As [`cells_micro_row`] when `MICRO`, else as [`cells_strip`]; `nb ≤ 4R`.
#[target_feature(enable = "neon")]
unsafe fn cells_body<const MICRO: bool, const R: usize>(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    let nb = spec.nbins();
    debug_assert!(nb <= 4 * R);
    let ncx = p.width / CELL_SIZE;
    let cl = cell_len(nb);
    let nmx = p.width / 2;
    const PER_CELL: usize = CELL_SIZE / 2;
    const HALF: usize = CELL_SIZE / 2;
    let stride = if MICRO { nmx * 2 } else { ncx * CELL_SIZE };
    let CellScratch { bins, wts, sc } = cs;
    let prof = spec.profile;
    let tables = vote_tables::<R>(nb);
    let zero = vdupq_n_f32(0.0);
    // Row accumulators of a cell's 8 pixel rows, [row][x-profile][register], and the vote vectors
    // of its pixels (MICRO only), [row][column][register]: every value is written per cell.
    let mut rows = [[[zero; R]; PROFILES]; CELL_SIZE];
    let mut votes = [[[zero; R]; CELL_SIZE]; CELL_SIZE];
    for (k, cell_row) in chunk.chunks_mut(ncx * cl).enumerate() {
        let cy = cy0 + k;
        for i in 0..CELL_SIZE {
            let r = i * stride..(i + 1) * stride;
            gradient_row(p, cy * CELL_SIZE + i, nb, sc, &mut bins[r.clone()], &mut wts[r]);
        }
        for (cx, cell) in cell_row.chunks_exact_mut(cl).enumerate() {
            for (i, row_acc) in rows.iter_mut().enumerate() {
                let o = i * stride + cx * CELL_SIZE;
                let (b, w) = (&bins[o..o + CELL_SIZE], &wts[o..o + CELL_SIZE]);
                let mut acc = [[zero; R]; PROFILES];
                for j in 0..HALF {
                    let v = vote(&tables[b[j][0] as usize], w[j]);
                    for px in live_profiles(0) {
                        for r in 0..R {
                            acc[px][r] = vfmaq_n_f32(acc[px][r], v[r], prof[px][j]);
                        }
                    }
                    if MICRO {
                        votes[i][j] = v;
                    }
                }
                for j in HALF..CELL_SIZE {
                    let v = vote(&tables[b[j][0] as usize], w[j]);
                    for px in live_profiles(HALF) {
                        for r in 0..R {
                            acc[px][r] = vfmaq_n_f32(acc[px][r], v[r], prof[px][j]);
                        }
                    }
                    if MICRO {
                        votes[i][j] = v;
                    }
                }
                *row_acc = acc;
            }
            for px in 0..PROFILES {
                let mut c = [[zero; R]; PROFILES];
                for i in 0..HALF {
                    let a = &rows[i][px];
                    for py in live_profiles(0) {
                        for r in 0..R {
                            c[py][r] = vfmaq_n_f32(c[py][r], a[r], prof[py][i]);
                        }
                    }
                }
                for i in HALF..CELL_SIZE {
                    let a = &rows[i][px];
                    for py in live_profiles(HALF) {
                        for r in 0..R {
                            c[py][r] = vfmaq_n_f32(c[py][r], a[r], prof[py][i]);
                        }
                    }
                }
                for (py, h) in c.iter().enumerate() {
                    store_lanes(h, &mut cell[cell_slot(py, px) * nb..][..nb]);
                }
            }
            if MICRO {
                for a in 0..PER_CELL {
                    let mrow = &mut micro[a * nmx * nb..][..nmx * nb];
                    for c in 0..PER_CELL {
                        let mut m = [zero; R];
                        for (y, x) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                            let v = &votes[2 * a + y][2 * c + x];
                            for r in 0..R {
                                m[r] = vaddq_f32(m[r], v[r]);
                            }
                        }
                        let mut h = [[0u16; 4]; R];
                        for r in 0..R {
                            // SAFETY: `h[r]` holds 4 half floats.
                            unsafe { vst1_u16(h[r].as_mut_ptr(), f16x4_from_f32(m[r])) };
                        }
                        mrow[(cx * PER_CELL + c) * nb..][..nb].copy_from_slice(&h.as_flattened()[..nb]);
                    }
                }
            }
        }
        if MICRO && ncx * PER_CELL < nmx {
            portable::micro_margin(bins, wts, stride, nb, ncx * PER_CELL, micro);
        }
    }
}

/// An approximated level's cell row `cy` one cell at a time, in two register passes (the AVX2
/// fill's scheme, `avx2::fill_cell_row`, with 4-lane registers): a cell's 16 profile histograms
/// would take 48 registers for 9 bins, more than NEON's 32.
/// 1. **x pass**, per micro row landing in the cell: `FULL = nb / 4` registers of bins per
///    x-profile, and each of the `TAIL = nb mod 4` last bins with the 4 x-profiles in the lanes of
///    one register (the 9th bin of the default geometry: one `fmla` per micro-cell instead of
///    four with 3 idle lanes each). Kept per row in a small buffer.
/// 2. **y pass**, per y-profile: the rows' x sums times the row's y weight.
///
/// The same fused multiply-adds in the same order as `portable::fill_cell_row`, so the same bits;
/// where the portable fill skips an x-profile whose weight is exactly 0, the tail lanes add
/// `0·v` = +0 to a sum ≥ +0, which changes no bit.
///
/// # Safety
/// The CPU must support NEON; `micro` has ≤ 16 bins and `taps` are its taps (`Taps::fits`).
#[target_feature(enable = "neon")]
pub(crate) unsafe fn fill_cell_row(micro: &MicroGrid, taps: &Taps, cy: usize, row: &mut [f32]) {
    macro_rules! by_bins {
        ($($nb:literal => ($f:literal, $t:literal)),* $(,)?) => {
            // SAFETY: this function's contract; `nb = 4·FULL + TAIL`.
            unsafe {
                match micro.nbins {
                    $($nb => fill_body::<$f, $t>(micro, taps, cy, row),)*
                    nb => unreachable!("{nb} bins: more than the register fill holds"),
                }
            }
        };
    }
    by_bins!(
        1 => (0, 1), 2 => (0, 2), 3 => (0, 3), 4 => (1, 0), 5 => (1, 1), 6 => (1, 2),
        7 => (1, 3), 8 => (2, 0), 9 => (2, 1), 10 => (2, 2), 11 => (2, 3), 12 => (3, 0),
        13 => (3, 1), 14 => (3, 2), 15 => (3, 3), 16 => (4, 0),
    )
}

/// One micro row's x sums in [`fill_body`]: `[x-profile][register]` for the bins `0 .. 4·FULL`,
/// and per tail bin the 4 x-profiles' sums in the lanes of one register.
#[derive(Clone, Copy)]
struct RowSums<const FULL: usize, const TAIL: usize> {
    full: [[float32x4_t; FULL]; PROFILES],
    tail: [float32x4_t; TAIL],
}

/// The body of [`fill_cell_row`] for `nb = 4·FULL + TAIL` bins.
///
/// # Safety
/// As [`fill_cell_row`]; `micro.nbins == 4·FULL + TAIL`, `TAIL < 4`.
#[target_feature(enable = "neon")]
unsafe fn fill_body<const FULL: usize, const TAIL: usize>(
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
) {
    let nb = micro.nbins;
    debug_assert_eq!(nb, 4 * FULL + TAIL);
    let cl = cell_len(nb);
    let (lo, hi) = taps.rows[cy];
    let stride = micro.nmx * nb;
    let data = &micro.data[..];
    let zero = vdupq_n_f32(0.0);
    let wys: Vec<(usize, [f32; PROFILES])> = (lo..hi)
        .filter_map(|my| taps.yt[my].map(|ty| (my, ty.w.map(|w| w * taps.gain))))
        .collect();
    let empty = RowSums::<FULL, TAIL> {
        full: [[zero; FULL]; PROFILES],
        tail: [zero; TAIL],
    };
    let mut sums = vec![empty; wys.len()];
    const _: () = assert!(
        matches!(LEFT_PROFILES, [0, 1, 3]) && matches!(RIGHT_PROFILES, [0, 2, 3]),
        "the literal profile lists below are LEFT_PROFILES and RIGHT_PROFILES"
    );
    for (cx, cell) in row.chunks_exact_mut(cl).enumerate().take(taps.ncx) {
        let (clo, chi) = taps.cols[cx];
        // 1. x pass, one micro row at a time, in registers.
        for (&(my, _), s) in wys.iter().zip(sums.iter_mut()) {
            // The micro-cells `clo..chi` of this row and their weights: every load below is
            // inside these two slices (a micro-cell is `nb = 4·FULL + TAIL` halves).
            let cells = &data[my * stride + clo * nb..my * stride + chi * nb];
            let xw = &taps.xw[clo..chi];
            let mut full = [[zero; FULL]; PROFILES];
            let mut tail = [zero; TAIL];
            macro_rules! add {
                ($range:expr, [$($p:literal),*]) => {
                    for mx in $range {
                        let at = (mx - clo) * nb;
                        let w = &xw[mx - clo];
                        // SAFETY: `at + nb ≤ cells.len()` (mx < chi): the `FULL` 4-half loads
                        // end at `at + 4·FULL ≤ at + nb`.
                        let v: [float32x4_t; FULL] = std::array::from_fn(|r| {
                            f32x4_from_f16(unsafe { vld1_u16(cells.as_ptr().add(at + 4 * r)) })
                        });
                        $(
                            for r in 0..FULL {
                                full[$p][r] = vfmaq_n_f32(full[$p][r], v[r], w[$p]);
                            }
                        )*
                        if TAIL > 0 {
                            // SAFETY: `w` holds the 4 x-profile weights.
                            let wx = unsafe { vld1q_f32(w.as_ptr()) };
                            for (k, t) in tail.iter_mut().enumerate() {
                                // SAFETY: `at + 4·FULL + k < at + nb ≤ cells.len()`.
                                let h = unsafe { *cells.get_unchecked(at + 4 * FULL + k) };
                                *t = vfmaq_f32(*t, wx, f32x4_from_f16(vdup_n_u16(h)));
                            }
                        }
                    }
                };
            }
            match taps.split[cx] {
                // Left of `mid` x-profile 2 is exactly 0 and right of it x-profile 1 is: adding
                // `0·v` (+0) to a sum ≥ +0 changes no bit, so those products are skipped.
                Some(mid) => {
                    add!(clo..mid, [0, 1, 3]);
                    add!(mid..chi, [0, 2, 3]);
                }
                None => add!(clo..chi, [0, 1, 2, 3]),
            }
            *s = RowSums { full, tail };
        }
        // 2. y pass, one y-profile at a time (a cell row without micro rows is all +0).
        for py in 0..PROFILES {
            let mut t = [[zero; FULL]; PROFILES];
            let mut tt = [zero; TAIL];
            for (i, (&(_, wy), s)) in wys.iter().zip(&sums).enumerate() {
                let w = wy[py];
                if i == 0 {
                    for (d, a) in t.iter_mut().zip(&s.full) {
                        for r in 0..FULL {
                            d[r] = vmulq_n_f32(a[r], w);
                        }
                    }
                    for (d, a) in tt.iter_mut().zip(&s.tail) {
                        *d = vmulq_n_f32(*a, w);
                    }
                } else if w != 0.0 {
                    for (d, a) in t.iter_mut().zip(&s.full) {
                        for r in 0..FULL {
                            d[r] = vfmaq_n_f32(d[r], a[r], w);
                        }
                    }
                    for (d, a) in tt.iter_mut().zip(&s.tail) {
                        *d = vfmaq_n_f32(*d, *a, w);
                    }
                }
            }
            for (px, regs) in t.iter().enumerate() {
                let dst = &mut cell[cell_slot(py, px) * nb..][..4 * FULL];
                for (r, x) in regs.iter().enumerate() {
                    // SAFETY: `dst` holds `4·FULL` floats.
                    unsafe { vst1q_f32(dst[4 * r..].as_mut_ptr(), *x) };
                }
            }
            for (k, x) in tt.iter().enumerate() {
                let mut lanes = [0.0f32; 4];
                // SAFETY: `lanes` holds 4 floats.
                unsafe { vst1q_f32(lanes.as_mut_ptr(), *x) };
                for (px, v) in lanes.iter().enumerate() {
                    cell[cell_slot(py, px) * nb + 4 * FULL + k] = *v;
                }
            }
        }
    }
}
