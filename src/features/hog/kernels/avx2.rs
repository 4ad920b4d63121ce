//! The AVX2 + FMA (+ F16C) builds of the HOG kernels: the path of the x86-64 edge CPUs (Intel
//! N100/N305, Atom x7000, AMD embedded), and of AVX-512 CPUs run with `MOSAICD_KERNELS=avx2`.
//!
//! - [`cells_strip`] / [`cells_micro_row`]: cell histograms with each cell's votes added in
//!   256-bit registers, and the 2x2-pixel micro-cells of the approximate pyramid pooled from the
//!   same votes (the port of the AVX-512 kernel's one-pass idea, see below).
//! - [`fill_cell_row`]: an approximated level's cell row, one cell at a time in registers.
//! - [`block_row`]: block assembly and L2-Hys, eight blocks per reduction chain.
//! - The portable kernels compiled for AVX2 + FMA: [`gamma_in_place`], [`gradient_pass`],
//!   [`micro_rows`], [`cells_strip_portable`], [`fill_cell_row_portable`].
//!
//! Every function here needs AVX2, FMA and F16C (what `Isa::Avx2` promises); its callers in
//! `kernels` check them first.

use std::arch::x86_64::*;

use super::super::gradient::{self, gradient_row};
use super::super::types::{
    cell_len, cell_slot, live_profiles, BlockParams, CellScratch, FillScratch, MicroGrid, Planes, Taps,
    LEFT_PROFILES, RIGHT_PROFILES,
};
use super::super::{HogSpec, BLOCK_CELLS, CELL_SIZE, DEFAULT_NBINS, L2HYS_EPS2, PROFILES};
use super::portable::{self, block_at, block_row as block_row_portable, gamma_in_place_generic};
use crate::kernels::Isa;

/// HOG's gamma (`portable::gamma_in_place_generic`) compiled for AVX2 (8 lanes, IEEE `vsqrtps`).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn gamma_in_place(row: &mut [f32], gamma: bool) {
    gamma_in_place_generic(row, gamma)
}

/// `gradient::gradient_pass` compiled for AVX2 + FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn gradient_pass(p: &Planes, nb: usize) {
    gradient::gradient_pass(p, nb)
}

/// The portable cell kernel (`portable::cells_strip`) compiled for AVX2 + FMA (vectorises the
/// magnitude / angle pass 8 lanes wide; the vote scatter stays scalar).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn cells_strip_portable(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
) {
    portable::cells_strip(spec, p, cy0, chunk, cs)
}

/// `portable::micro_rows` compiled for AVX2 + FMA, half floats by F16C.
///
/// # Safety
/// The CPU must support AVX2, FMA and F16C.
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn micro_rows(p: &Planes, nb: usize, size: usize, my0: usize, chunk: &mut [u16]) {
    portable::micro_rows(Isa::Avx2, p, nb, size, my0, chunk)
}

/// The portable fill (`portable::fill_cell_row`) compiled for AVX2 + FMA, half floats by F16C.
///
/// # Safety
/// The CPU must support AVX2, FMA and F16C.
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn fill_cell_row_portable(
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
) {
    portable::fill_cell_row::<true>(Isa::Avx2, micro, taps, cy, row, s)
}

/// The first `dst.len()` (≤ 8·R) lanes of `v` into `dst`.
#[target_feature(enable = "avx2,fma,f16c")]
fn store_lanes<const R: usize>(v: &[__m256; R], dst: &mut [f32]) {
    let mut t = [[0.0f32; 8]; R];
    for (r, x) in v.iter().enumerate() {
        // SAFETY: `t[r]` holds 8 floats.
        unsafe { _mm256_storeu_ps(t[r].as_mut_ptr(), *x) };
    }
    dst.copy_from_slice(&t.as_flattened()[..dst.len()]);
}

/// The one-hot vote permutations of [`cells_body`]: `idx[b0][r]` moves lane 0 of `[w0, w1, +0,
/// …]` to bin `b0`, lane 1 to bin `(b0 + 1) mod nb` and `+0` everywhere else, for the bins `8r ..
/// 8r + 8` of register `r`.
#[target_feature(enable = "avx2,fma,f16c")]
fn vote_permutations<const R: usize>(nb: usize) -> [[__m256i; R]; 16] {
    let mut t = [[[2i32; 8]; R]; 16];
    for (b0, regs) in t.iter_mut().enumerate().take(nb) {
        let b1 = (b0 + 1) % nb;
        for (r, lanes) in regs.iter_mut().enumerate() {
            for (l, x) in lanes.iter_mut().enumerate() {
                let bin = 8 * r + l;
                *x = if bin == b0 {
                    0
                } else if bin == b1 {
                    1
                } else {
                    2
                };
            }
        }
    }
    // SAFETY: every `lanes` array holds 8 i32 (32 bytes).
    t.map(|regs| regs.map(|lanes| unsafe { _mm256_loadu_si256(lanes.as_ptr() as *const __m256i) }))
}

/// A pixel's two votes `w` as the one-hot vector `w0·e(b0) + w1·e(b1)`, by the permutations `perm`
/// of its bin `b0` ([`vote_permutations`]). A function, not a closure, so that it is compiled
/// with the kernel's target features and inlined.
#[target_feature(enable = "avx2,fma,f16c")]
#[inline]
fn vote<const R: usize>(perm: &[__m256i; R], [w0, w1]: [f32; 2]) -> [__m256; R] {
    let s = _mm256_setr_ps(w0, w1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let mut v = [_mm256_setzero_ps(); R];
    for (x, p) in v.iter_mut().zip(perm) {
        *x = _mm256_permutevar8x32_ps(s, *p);
    }
    v
}

/// The cell rows from `cy0` on (as many as `chunk` holds) with each cell's votes in registers
/// ([`cells_body`]).
///
/// # Safety
/// The CPU must support AVX2, FMA and F16C; `spec` has ≤ 16 bins and its profiles have the fixed
/// zeros (`types::profiles_have_fixed_zeros`).
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn cells_strip(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
) {
    match spec.nbins() {
        DEFAULT_NBINS => cells_body::<false, 2, DEFAULT_NBINS>(spec, p, cy0, chunk, cs, &mut []),
        ..=8 => cells_body::<false, 1, 0>(spec, p, cy0, chunk, cs, &mut []),
        _ => cells_body::<false, 2, 0>(spec, p, cy0, chunk, cs, &mut []),
    }
}

/// [`cells_strip`] for one cell row `cy` that also pools the row's 2x2-pixel micro-cells (its 4
/// micro rows, `(p.width / 2) · nbins` half floats each, into `micro`) from the same votes: each
/// micro-cell is the sum of its 4 pixels' one-hot vote vectors in the pixel order of
/// `portable::micro_rows` (rows, then columns; other lanes add +0), rounded to half floats as it
/// does. Micro-cells right of the last whole cell are summed by a scalar loop in the same order.
///
/// # Safety
/// As [`cells_strip`]; `chunk` is one cell row and `micro` holds its 4 micro rows; the scratch
/// rows hold `8 · 2·(p.width / 2)` pixels.
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn cells_micro_row(
    spec: &HogSpec,
    p: &Planes,
    cy: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    match spec.nbins() {
        DEFAULT_NBINS => cells_body::<true, 2, DEFAULT_NBINS>(spec, p, cy, chunk, cs, micro),
        ..=8 => cells_body::<true, 1, 0>(spec, p, cy, chunk, cs, micro),
        _ => cells_body::<true, 2, 0>(spec, p, cy, chunk, cs, micro),
    }
}

/// The body of [`cells_strip`] and [`cells_micro_row`], with `R` 8-lane registers per histogram
/// (`nb ≤ 8R`).
///
/// Per cell and pixel row `i`, each pixel's two votes become the one-hot vector `w0·e(b0) +
/// w1·e(b1)`: `[w0, w1, +0, …]` permuted by `vpermps` with the indices of its bin `b0` (a table
/// of 16 x R registers built once per call; AVX-512 uses masked moves instead). It is added with
/// the pixel column's live x-profile weights into 4 row accumulators (`4R` registers). The 8 row
/// accumulators of a cell go to the stack, and the cell's 16 profile histograms are then made one
/// x-profile at a time (`4R` registers) by adding the 8 rows with their live y-profile weights:
/// 16 histograms of 2 registers do not fit in AVX2's 16, where AVX-512 keeps them all. Each lane
/// sees exactly the fused multiply-adds of the scalar scatter in `portable::cells_strip`, in its
/// order (row accumulators over pixel columns from `+0`, cell histograms over pixel rows from
/// `+0`; skipped terms are `0·v = +0`), so the same bits.
///
/// With `MICRO`, the vote vectors of the cell's 64 pixels are kept (stack) and summed per 2x2
/// micro-cell afterwards.
///
/// `NB` is the bin count as a constant (the detector's 9), or 0 to read it from `spec`: with a
/// constant, the histogram stores are fixed-length moves instead of calls to `memcpy`.
///
/// # Safety
/// As [`cells_micro_row`] when `MICRO`, else as [`cells_strip`]; `nb ≤ 8R`; `NB` is 0 or
/// `spec.nbins()`.
#[target_feature(enable = "avx2,fma,f16c")]
unsafe fn cells_body<const MICRO: bool, const R: usize, const NB: usize>(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    debug_assert!(NB == 0 || NB == spec.nbins());
    let nb = if NB > 0 { NB } else { spec.nbins() };
    debug_assert!(nb <= 8 * R && R <= 2);
    let ncx = p.width / CELL_SIZE;
    let cl = cell_len(nb);
    // Micro-cells across (2x2 pixels), per cell, and the pixel columns (the row stride of
    // `bins` / `wts`) the gradient rows must cover.
    let nmx = p.width / 2;
    const PER_CELL: usize = CELL_SIZE / 2;
    const HALF: usize = CELL_SIZE / 2;
    let stride = if MICRO { nmx * 2 } else { ncx * CELL_SIZE };
    let CellScratch { bins, wts, sc } = cs;
    let prof = spec.profile;
    let idx = vote_permutations::<R>(nb);
    // Profile weights as broadcast registers, [pixel offset][profile].
    let pw: [[__m256; PROFILES]; CELL_SIZE] =
        std::array::from_fn(|j| std::array::from_fn(|p| _mm256_set1_ps(prof[p][j])));
    let zero = _mm256_setzero_ps();
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
                // Left and right halves of the cell: the live x-profiles are constants.
                for j in 0..HALF {
                    let v = vote(&idx[b[j][0] as usize], w[j]);
                    for px in live_profiles(0) {
                        for r in 0..R {
                            acc[px][r] = _mm256_fmadd_ps(pw[j][px], v[r], acc[px][r]);
                        }
                    }
                    if MICRO {
                        votes[i][j] = v;
                    }
                }
                for j in HALF..CELL_SIZE {
                    let v = vote(&idx[b[j][0] as usize], w[j]);
                    for px in live_profiles(HALF) {
                        for r in 0..R {
                            acc[px][r] = _mm256_fmadd_ps(pw[j][px], v[r], acc[px][r]);
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
                            c[py][r] = _mm256_fmadd_ps(pw[i][py], a[r], c[py][r]);
                        }
                    }
                }
                for i in HALF..CELL_SIZE {
                    let a = &rows[i][px];
                    for py in live_profiles(HALF) {
                        for r in 0..R {
                            c[py][r] = _mm256_fmadd_ps(pw[i][py], a[r], c[py][r]);
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
                        // Pixel order: the upper row's two pixels, then the lower row's.
                        let mut m = [zero; R];
                        for (y, x) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                            let v = &votes[2 * a + y][2 * c + x];
                            for r in 0..R {
                                m[r] = _mm256_add_ps(m[r], v[r]);
                            }
                        }
                        let mut h = [[0u16; 8]; R];
                        for r in 0..R {
                            let x = _mm256_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(m[r]);
                            // SAFETY: `h[r]` holds 8 half floats (16 bytes).
                            unsafe { _mm_storeu_si128(h[r].as_mut_ptr() as *mut __m128i, x) };
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

/// An approximated level's cell row, one cell at a time (the register fill of the AVX2 path).
///
/// A cell's 16 profile histograms (4 y-profiles x 4 x-profiles, `nb` bins each) do not fit in
/// AVX2's sixteen registers (they take 32 for 9 bins, which is what the one-pass AVX-512 fill
/// keeps in 16 zmm), so the cell is built in two passes, both held in registers:
/// 1. **x pass**, per micro row landing in the cell: the row's micro-cells times their 4
///    x-profile weights, `FULL` registers of 8 bins per x-profile, and the `TAIL` bins past
///    `8·FULL` with the 4 x-profiles in the lanes of one xmm per bin (so the 9th bin of the
///    default geometry costs one 4-lane FMA per micro-cell instead of four 8-lane ones with
///    7 idle lanes). Kept per row in a small L1 buffer.
/// 2. **y pass**, per y-profile: the rows' x sums times the row's y weight, 4·`FULL` registers;
///    the tail bins with two y-profiles per ymm.
///
/// Each value gets the same fused multiply-adds in the same order as the portable fill
/// (`portable::fill_cell_row`): x sums over the micro columns left to right from +0, then the y
/// sum over the micro rows top to bottom, the first a multiply. So the same bits. Where the
/// portable fill skips a product whose weight is 0 (the x-profile that is zero on each half of a
/// cell, a y-profile that is zero for a row), the tail lanes add `0·v` = +0 to a sum ≥ +0
/// instead, which changes no bit (votes are finite and ≥ 0).
///
/// # Safety
/// The CPU must support AVX2, FMA and F16C; `micro` has ≤ 16 bins and `taps` are its taps
/// (`Taps::fits`).
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn fill_cell_row(micro: &MicroGrid, taps: &Taps, cy: usize, row: &mut [f32]) {
    macro_rules! by_bins {
        ($($nb:literal => ($f:literal, $t:literal)),* $(,)?) => {
            match micro.nbins {
                $($nb => fill_body::<$f, $t>(micro, taps, cy, row),)*
                nb => unreachable!("{nb} bins: more than the register fill holds"),
            }
        };
    }
    by_bins!(
        1 => (0, 1), 2 => (0, 2), 3 => (0, 3), 4 => (0, 4), 5 => (0, 5), 6 => (0, 6),
        7 => (0, 7), 8 => (1, 0), 9 => (1, 1), 10 => (1, 2), 11 => (1, 3), 12 => (1, 4),
        13 => (1, 5), 14 => (1, 6), 15 => (1, 7), 16 => (2, 0),
    )
}

/// One micro row's x sums in [`fill_body`]: `[x-profile][register]` for the bins `0 .. 8·FULL`,
/// and per tail bin the 4 x-profiles' sums in the lanes of an xmm.
#[derive(Clone, Copy)]
struct RowSums<const FULL: usize, const TAIL: usize> {
    full: [[__m256; FULL]; PROFILES],
    tail: [__m128; TAIL],
}

/// A micro row landing in the cell row being filled: its index, its y-profile weights (times the
/// gain) broadcast, the same as two-y-profile pairs for the tail (`[w0 x4, w1 x4]`,
/// `[w2 x4, w3 x4]`), and which weights are non-zero.
struct RowWeights {
    my: usize,
    wy: [__m256; PROFILES],
    pairs: [__m256; 2],
    live: [bool; PROFILES],
}

/// The body of [`fill_cell_row`] for `nb = 8·FULL + TAIL` bins.
///
/// # Safety
/// As [`fill_cell_row`]; `micro.nbins == 8·FULL + TAIL`, `TAIL < 8`.
#[target_feature(enable = "avx2,fma,f16c")]
unsafe fn fill_body<const FULL: usize, const TAIL: usize>(
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
) {
    let nb = micro.nbins;
    debug_assert_eq!(nb, 8 * FULL + TAIL);
    let cl = cell_len(nb);
    let (lo, hi) = taps.rows[cy];
    let stride = micro.nmx * nb;
    let data = &micro.data[..];
    let zero = _mm256_setzero_ps();
    let rows: Vec<RowWeights> = (lo..hi)
        .filter_map(|my| {
            taps.yt[my].map(|ty| {
                let w = ty.w.map(|w| w * taps.gain);
                let pair = |a: f32, b: f32| _mm256_setr_ps(a, a, a, a, b, b, b, b);
                RowWeights {
                    my,
                    wy: w.map(|w| _mm256_set1_ps(w)),
                    pairs: [pair(w[0], w[1]), pair(w[2], w[3])],
                    live: w.map(|w| w != 0.0),
                }
            })
        })
        .collect();
    let empty = RowSums::<FULL, TAIL> {
        full: [[zero; FULL]; PROFILES],
        tail: [_mm_setzero_ps(); TAIL],
    };
    let mut sums = vec![empty; rows.len()];
    for (cx, cell) in row.chunks_exact_mut(cl).enumerate().take(taps.ncx) {
        let (clo, chi) = taps.cols[cx];
        // 1. x pass, one micro row at a time, in registers (`$live` a literal list of
        //    x-profiles, so every index below is a constant).
        for (rw, s) in rows.iter().zip(sums.iter_mut()) {
            // The micro-cells `clo..chi` of this row, and their x-profile weights: every load
            // below is inside these two slices (a micro-cell is `nb = 8·FULL + TAIL` halves).
            let cells = &data[rw.my * stride + clo * nb..rw.my * stride + chi * nb];
            let xw = &taps.xw[clo..chi];
            let mut full = [[zero; FULL]; PROFILES];
            let mut tail = [_mm_setzero_ps(); TAIL];
            macro_rules! add {
                ($range:expr, [$($p:literal),*]) => {
                    for mx in $range {
                        let at = (mx - clo) * nb;
                        let w = &xw[mx - clo];
                        // SAFETY: `at + nb ≤ cells.len()` (mx < chi): the `FULL` 8-half loads
                        // end at `at + 8·FULL ≤ at + nb`.
                        let v: [__m256; FULL] = std::array::from_fn(|r| unsafe {
                            _mm256_cvtph_ps(_mm_loadu_si128(cells.as_ptr().add(at + 8 * r).cast()))
                        });
                        $(
                            let wv = _mm256_set1_ps(w[$p]);
                            for r in 0..FULL {
                                full[$p][r] = _mm256_fmadd_ps(wv, v[r], full[$p][r]);
                            }
                        )*
                        if TAIL > 0 {
                            // SAFETY: `w` holds the 4 x-profile weights (16 bytes).
                            let wx = unsafe { _mm_loadu_ps(w.as_ptr()) };
                            for (k, t) in tail.iter_mut().enumerate() {
                                // SAFETY: `at + 8·FULL + k < at + nb ≤ cells.len()`.
                                let h = unsafe { *cells.get_unchecked(at + 8 * FULL + k) };
                                let v = _mm_cvtph_ps(_mm_set1_epi16(h as i16));
                                *t = _mm_fmadd_ps(wx, v, *t);
                            }
                        }
                    }
                };
            }
            const _: () = assert!(
                matches!(LEFT_PROFILES, [0, 1, 3]) && matches!(RIGHT_PROFILES, [0, 2, 3]),
                "the literal profile lists below are LEFT_PROFILES and RIGHT_PROFILES"
            );
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
            for (i, (rw, s)) in rows.iter().zip(&sums).enumerate() {
                if i == 0 {
                    for (d, a) in t.iter_mut().zip(&s.full) {
                        for r in 0..FULL {
                            d[r] = _mm256_mul_ps(rw.wy[py], a[r]);
                        }
                    }
                } else if rw.live[py] {
                    for (d, a) in t.iter_mut().zip(&s.full) {
                        for r in 0..FULL {
                            d[r] = _mm256_fmadd_ps(rw.wy[py], a[r], d[r]);
                        }
                    }
                }
            }
            for (px, regs) in t.iter().enumerate() {
                let dst = &mut cell[cell_slot(py, px) * nb..][..8 * FULL];
                for (r, x) in regs.iter().enumerate() {
                    // SAFETY: `dst` holds `8·FULL` floats.
                    unsafe { _mm256_storeu_ps(dst[8 * r..].as_mut_ptr(), *x) };
                }
            }
        }
        for k in 0..TAIL {
            let mut t = [zero; 2];
            for (i, (rw, s)) in rows.iter().zip(&sums).enumerate() {
                let a = _mm256_set_m128(s.tail[k], s.tail[k]);
                for (d, w) in t.iter_mut().zip(&rw.pairs) {
                    *d = if i == 0 {
                        _mm256_mul_ps(*w, a)
                    } else {
                        _mm256_fmadd_ps(*w, a, *d)
                    };
                }
            }
            let mut lanes = [[0.0f32; 8]; 2];
            for (l, x) in lanes.iter_mut().zip(&t) {
                // SAFETY: `l` holds 8 floats.
                unsafe { _mm256_storeu_ps(l.as_mut_ptr(), *x) };
            }
            for (j, v) in lanes.as_flattened().iter().enumerate() {
                let (py, px) = (j / PROFILES, j % PROFILES);
                cell[cell_slot(py, px) * nb + 8 * FULL + k] = *v;
            }
        }
    }
}

/// Blocks per batch of [`block_row`].
const BLOCK_BATCH: usize = 8;

/// `portable::block_row` with AVX2, bit for bit: the blocks are taken in batches of [`BLOCK_BATCH`] so
/// that each of the two normalisations runs one horizontal reduction → square root → division
/// chain for eight blocks at once (in `portable::block_row` that latency-bound chain runs twice per block;
/// ≈2x less time per block on a 1080p row).
///
/// A batch is assembled as in `portable::block_row` (same four-run sum from `0.0`), and each block's 8
/// partial sums of squares (lane `i mod 8`, one ymm per block, added chunk after chunk as
/// `portable::sum_of_squares` does) are reduced across the batch by [`lane_sums`], which combines
/// the lanes of each block in the same order ((0+4)+(2+6))+((1+5)+(3+7)) with vertical adds.
/// The square root and division are then done for the eight blocks in one vector; IEEE `sqrt`
/// and `/` are correctly rounded, so each lane has the bits of the scalar ones. Products and sums
/// are separate multiplies and adds (no FMA), as in the scalar code (Rust never contracts them),
/// and `min(x, thresh)` returns `thresh` for a NaN `x` like [`f32::min`] (`thresh` is never NaN:
/// [`HogSpec::new`] checks it). The last `nbx mod 8` blocks go through [`block_at`].
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn block_row(spec: &HogSpec, ncx: usize, top: &[f32], bottom: &[f32], row: &mut [f32]) {
    let bp = BlockParams::new(spec);
    let (bl, cl) = (bp.bl, cell_len(bp.nb));
    let nbx = row.len() / bl;
    // Every run read below lies in cell bx or bx + 1 ≤ nbx < ncx of `top` or `bottom`: checked
    // once per call (other sizes take the portable kernel, which indexes with bounds checks).
    let fits = row.len() == nbx * bl && nbx < ncx && top.len() >= ncx * cl && bottom.len() >= ncx * cl;
    debug_assert!(
        fits,
        "block row {} of {ncx} cells ({} / {})",
        row.len(),
        top.len(),
        bottom.len()
    );
    if !fits {
        return block_row_portable(spec, ncx, top, bottom, row);
    }
    let batches = nbx / BLOCK_BATCH;
    for batch in 0..batches {
        let bx0 = batch * BLOCK_BATCH;
        let out = &mut row[bx0 * bl..][..BLOCK_BATCH * bl];
        // SAFETY: the CPU has AVX2 (this function's contract); `out` and the runs are in bounds
        // (checked above).
        unsafe {
            if bp.nb == DEFAULT_NBINS {
                // The detector's bins, with the chunk counts constant.
                let bp = BlockParams {
                    nb: DEFAULT_NBINS,
                    bl: BLOCK_CELLS * BLOCK_CELLS * DEFAULT_NBINS,
                    ..bp
                };
                block_batch(&bp, top, bottom, bx0, out)
            } else {
                block_batch(&bp, top, bottom, bx0, out)
            }
        }
    }
    for (bx, blk) in row.chunks_mut(bl).enumerate().skip(batches * BLOCK_BATCH) {
        block_at(&bp, top, bottom, bx, blk);
    }
}

/// The [`BLOCK_BATCH`] blocks from `bx0` into `out` ([`block_row`]).
///
/// # Safety
/// The CPU must support AVX2; `out` holds `BLOCK_BATCH·bl` values and `top` and `bottom` hold
/// cells `bx0 ..= bx0 + BLOCK_BATCH` (`cell_len(nb)` values each).
#[inline(always)]
unsafe fn block_batch(bp: &BlockParams, top: &[f32], bottom: &[f32], bx0: usize, out: &mut [f32]) {
    let BlockParams { nb, bl, eps1, thresh } = *bp;
    // bl = 4·nbins: whole ymm chunks, then half of one when nbins is odd.
    let (full, half) = (bl / 8, bl % 8 == 4);
    let cl = cell_len(nb);
    debug_assert!(out.len() == BLOCK_BATCH * bl);
    debug_assert!(top.len().min(bottom.len()) >= (bx0 + BLOCK_BATCH + 1) * cl);
    // The run of block cell (sy, sx) of block bx0 + j, as in `block_at`.
    let runs = |j: usize| {
        let c = (bx0 + j) * cl;
        // SAFETY: in bounds by the contract (`cell_slot(..)·nb + bl ≤ cl`).
        unsafe {
            [
                top.as_ptr().add(c + cell_slot(0, 0) * nb),
                top.as_ptr().add(c + cl + cell_slot(0, 1) * nb),
                bottom.as_ptr().add(c + cell_slot(1, 0) * nb),
                bottom.as_ptr().add(c + cl + cell_slot(1, 1) * nb),
            ]
        }
    };
    let o = out.as_mut_ptr();
    let zero = _mm256_setzero_ps();
    let mut acc = [zero; BLOCK_BATCH];
    for (j, a) in acc.iter_mut().enumerate() {
        let [h00, h01, h10, h11] = runs(j);
        // SAFETY: k + 8 ≤ bl (k + 4 = bl for the half chunk): every run and block has `bl` values.
        unsafe {
            let o = o.add(j * bl);
            for c in 0..full {
                let k = 8 * c;
                let v = _mm256_add_ps(zero, _mm256_loadu_ps(h00.add(k)));
                let v = _mm256_add_ps(v, _mm256_loadu_ps(h01.add(k)));
                let v = _mm256_add_ps(v, _mm256_loadu_ps(h10.add(k)));
                let v = _mm256_add_ps(v, _mm256_loadu_ps(h11.add(k)));
                _mm256_storeu_ps(o.add(k), v);
                *a = _mm256_add_ps(*a, _mm256_mul_ps(v, v));
            }
            if half {
                let k = 8 * full;
                let v = _mm_add_ps(_mm_setzero_ps(), _mm_loadu_ps(h00.add(k)));
                let v = _mm_add_ps(v, _mm_loadu_ps(h01.add(k)));
                let v = _mm_add_ps(v, _mm_loadu_ps(h10.add(k)));
                let v = _mm_add_ps(v, _mm_loadu_ps(h11.add(k)));
                _mm_storeu_ps(o.add(k), v);
                // Lanes 4..8 add +0, which leaves a sum of squares (never -0) unchanged.
                *a = _mm256_add_ps(*a, _mm256_zextps128_ps256(_mm_mul_ps(v, v)));
            }
        }
    }
    let one = _mm256_set1_ps(1.0);
    let scale = _mm256_div_ps(
        one,
        _mm256_add_ps(_mm256_sqrt_ps(lane_sums(&acc)), _mm256_set1_ps(eps1)),
    );
    let mut scales = [0.0f32; BLOCK_BATCH];
    // SAFETY: `scales` holds 8 values.
    unsafe { _mm256_storeu_ps(scales.as_mut_ptr(), scale) };
    let tv = _mm256_set1_ps(thresh);
    for (j, a) in acc.iter_mut().enumerate() {
        let s = _mm256_set1_ps(scales[j]);
        *a = zero;
        // SAFETY: inside block j of `out`, as above.
        unsafe {
            let o = o.add(j * bl);
            for c in 0..full {
                let k = 8 * c;
                let v = _mm256_min_ps(_mm256_mul_ps(_mm256_loadu_ps(o.add(k)), s), tv);
                _mm256_storeu_ps(o.add(k), v);
                *a = _mm256_add_ps(*a, _mm256_mul_ps(v, v));
            }
            if half {
                let k = 8 * full;
                let (s, tv) = (_mm256_castps256_ps128(s), _mm256_castps256_ps128(tv));
                let v = _mm_min_ps(_mm_mul_ps(_mm_loadu_ps(o.add(k)), s), tv);
                _mm_storeu_ps(o.add(k), v);
                *a = _mm256_add_ps(*a, _mm256_zextps128_ps256(_mm_mul_ps(v, v)));
            }
        }
    }
    let eps2 = _mm256_set1_ps(L2HYS_EPS2);
    let scale2 = _mm256_div_ps(one, _mm256_add_ps(_mm256_sqrt_ps(lane_sums(&acc)), eps2));
    // SAFETY: `scales` holds 8 values.
    unsafe { _mm256_storeu_ps(scales.as_mut_ptr(), scale2) };
    for (j, &sj) in scales.iter().enumerate() {
        let s = _mm256_set1_ps(sj);
        // SAFETY: inside block j of `out`, as above.
        unsafe {
            let o = o.add(j * bl);
            for c in 0..full {
                let k = 8 * c;
                _mm256_storeu_ps(o.add(k), _mm256_mul_ps(_mm256_loadu_ps(o.add(k)), s));
            }
            if half {
                let k = 8 * full;
                _mm_storeu_ps(
                    o.add(k),
                    _mm_mul_ps(_mm_loadu_ps(o.add(k)), _mm256_castps256_ps128(s)),
                );
            }
        }
    }
}

/// Lane `j` = the 8 partial sums of `acc[j]` combined as `portable::sum_of_squares` does,
/// ((0+4)+(2+6))+((1+5)+(3+7)), every add with the same operands in the same order.
#[target_feature(enable = "avx2,fma")]
fn lane_sums(acc: &[__m256; BLOCK_BATCH]) -> __m256 {
    // b(j) = [a0+a4, a1+a5, a2+a6, a3+a7] of block j; pairs (j, j+4) share a register.
    let b = |j: usize| {
        let lo = _mm256_permute2f128_ps::<0x20>(acc[j], acc[j + 4]);
        let hi = _mm256_permute2f128_ps::<0x31>(acc[j], acc[j + 4]);
        _mm256_add_ps(lo, hi)
    };
    let (b04, b15, b26, b37) = (b(0), b(1), b(2), b(3));
    // [c, d] = [b0+b2, b1+b3] of blocks (0, 1 | 4, 5) and (2, 3 | 6, 7).
    let cd = |x: __m256, y: __m256| {
        let p = _mm256_shuffle_ps::<0b01_00_01_00>(x, y);
        let q = _mm256_shuffle_ps::<0b11_10_11_10>(x, y);
        _mm256_add_ps(p, q)
    };
    let (cd0145, cd2367) = (cd(b04, b15), cd(b26, b37));
    let c = _mm256_shuffle_ps::<0b10_00_10_00>(cd0145, cd2367);
    let d = _mm256_shuffle_ps::<0b11_01_11_01>(cd0145, cd2367);
    _mm256_add_ps(c, d)
}
