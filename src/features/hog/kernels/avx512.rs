//! The AVX-512 builds of the HOG kernels (F/BW/VL on top of AVX2 + FMA + F16C): per-cell
//! histograms held in 16 zmm registers with one-hot votes by masked moves, the register fill of
//! approximated levels, and the gradient pass compiled for AVX-512F. Block rows use the AVX2
//! kernel. Every function here needs the features its `# Safety` section names; its callers in
//! `kernels` check them first.

use std::arch::x86_64::*;

use super::super::gradient::{self, gradient_row};
use super::super::types::{
    cell_len, cell_slot, live_profiles, CellScratch, MicroGrid, Planes, Taps, LEFT_PROFILES,
    REGISTER_MAX_BINS, RIGHT_PROFILES,
};
use super::super::{HogSpec, CELL_SIZE, PROFILES};
use super::portable;

/// `gradient::gradient_pass` compiled for AVX-512F (as [`cells_strip`]).
///
/// # Safety
/// The CPU must support AVX-512F, AVX2 and FMA.
#[target_feature(enable = "avx512f,avx2,fma")]
pub(crate) unsafe fn gradient_pass(p: &Planes, nb: usize) {
    gradient::gradient_pass(p, nb)
}

/// `portable::cells_strip` with the per-cell accumulation in AVX-512 registers: for every cell, the 16
/// (y-profile, x-profile) histograms live in 16 zmm registers (bins in lanes) for its 8 pixel rows;
/// a pixel's two votes become the vector `w0·e(b0) + w1·e(b1)` (`e` = unit vectors), added with the
/// x-profile weights into 4 row accumulators, which are added with the y-profile weights into the
/// 16 cell accumulators (fused multiply-adds). Every lane sees exactly the fused multiply-adds, in
/// the same order, of the scalar scatter in `portable::cells_strip` (other lanes add `w·0 = +0`), so the
/// result is bit-identical. Measured ≈1.4x less CPU for the cell stage than the AVX2 build of the
/// scalar scatter, which stalls on store-to-load forwarding.
///
/// # Safety
/// The CPU must support AVX-512F/BW/VL, AVX2 and FMA, `spec.nbins() ≤ 16`, and the profiles of
/// `spec` must be zero outside `types::live_profiles` (`types::profiles_have_fixed_zeros`).
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
pub(crate) unsafe fn cells_strip(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
) {
    // SAFETY: this function's target features; no micro-cells requested.
    unsafe { cells_strip_body::<false>(spec, p, cy0, chunk, cs, &mut []) }
}

/// [`cells_strip`] for one cell row `cy` that also pools the row's 2x2-pixel micro-cells
/// (its 4 micro rows, `(p.width / 2) · nbins` half floats each, into `micro`) from the same
/// gradients: each micro-cell is the sum of its 4 pixels' one-hot vote vectors, in the pixel
/// order of `portable::micro_rows` (rows, then columns; other lanes add +0),
/// rounded to half floats as it does — the same bits, without computing the gradients twice.
/// Micro-cells right of the last whole cell are summed by a scalar loop in the same order.
///
/// # Safety
/// As [`cells_strip`]; `chunk` is one cell row and `micro` holds its 4 micro rows.
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
pub(crate) unsafe fn cells_micro_row(
    spec: &HogSpec,
    p: &Planes,
    cy: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    debug_assert_eq!(micro.len(), CELL_SIZE / 2 * (p.width / 2) * spec.nbins());
    // SAFETY: this function's target features; `micro` holds the row's micro rows.
    unsafe { cells_strip_body::<true>(spec, p, cy, chunk, cs, micro) }
}

/// The body of [`cells_strip`] and [`cells_micro_row`].
///
/// # Safety
/// As [`cells_micro_row`] when `MICRO`, else as [`cells_strip`].
#[inline(always)]
unsafe fn cells_strip_body<const MICRO: bool>(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    let nb = spec.nbins();
    debug_assert!(nb <= REGISTER_MAX_BINS && PROFILES == 4);
    let ncx = p.width / CELL_SIZE;
    let cl = cell_len(nb);
    // Micro-cells across (2x2 pixels), per cell, and the pixel columns (the row stride of
    // `bins` / `wts`) the gradient rows must cover.
    let nmx = p.width / 2;
    const PER_CELL: usize = CELL_SIZE / 2;
    let stride = if MICRO { nmx * 2 } else { ncx * CELL_SIZE };
    let CellScratch { bins, wts, sc } = cs;
    let prof = spec.profile;
    let mask: __mmask16 = ((1u32 << nb) - 1) as __mmask16;
    for (k, cell_row) in chunk.chunks_mut(ncx * cl).enumerate() {
        let cy = cy0 + k;
        for i in 0..CELL_SIZE {
            let r = i * stride..(i + 1) * stride;
            gradient_row(p, cy * CELL_SIZE + i, nb, sc, &mut bins[r.clone()], &mut wts[r]);
        }
        for (cx, cell) in cell_row.chunks_exact_mut(cl).enumerate() {
            let mut cacc = [_mm512_setzero_ps(); PROFILES * PROFILES];
            // The micro-cells of the current pair of pixel rows (MICRO only).
            let mut macc = [_mm512_setzero_ps(); PER_CELL];
            // Fully unrolled over the 8 pixel rows and columns so that every accumulator index
            // is a constant (registers, no spills) and no weight is tested at run time.
            macro_rules! pixel_row {
                ($i:literal) => {{
                    let o = $i * stride + cx * CELL_SIZE;
                    let mut acc = [_mm512_setzero_ps(); PROFILES];
                    pixel_col!(o, acc, 0);
                    pixel_col!(o, acc, 1);
                    pixel_col!(o, acc, 2);
                    pixel_col!(o, acc, 3);
                    pixel_col!(o, acc, 4);
                    pixel_col!(o, acc, 5);
                    pixel_col!(o, acc, 6);
                    pixel_col!(o, acc, 7);
                    for py in live_profiles($i) {
                        let wv = _mm512_set1_ps(prof[py][$i]);
                        for px in 0..PROFILES {
                            let c = &mut cacc[py * PROFILES + px];
                            *c = _mm512_fmadd_ps(wv, acc[px], *c);
                        }
                    }
                    if MICRO && $i % 2 == 1 {
                        let row = &mut micro[($i / 2) * nmx * nb..][..nmx * nb];
                        for (c, m) in macc.iter_mut().enumerate() {
                            let h = _mm512_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(*m);
                            debug_assert!((cx * PER_CELL + c + 1) * nb <= row.len());
                            // SAFETY: `nb` half floats of micro-cell PER_CELL·cx + c < nmx of this row.
                            unsafe {
                                _mm256_mask_storeu_epi16(
                                    row.as_mut_ptr().add((cx * PER_CELL + c) * nb) as *mut i16,
                                    mask,
                                    h,
                                )
                            };
                            *m = _mm512_setzero_ps();
                        }
                    }
                }};
            }
            macro_rules! pixel_col {
                ($o:expr, $acc:ident, $j:literal) => {{
                    let ([b0, b1], [w0, w1]) = (bins[$o + $j], wts[$o + $j]);
                    debug_assert!((b0 as usize) < nb && (b1 as usize) < nb);
                    // Lane b0 = w0, lane b1 = w1 (b0 ≠ b1), other lanes +0: the same bits as
                    // w0·e(b0) + w1·e(b1), since both weights are ≥ +0.
                    let v = _mm512_maskz_mov_ps(1 << b0, _mm512_set1_ps(w0));
                    let v = _mm512_mask_mov_ps(v, 1 << b1, _mm512_set1_ps(w1));
                    for px in live_profiles($j) {
                        $acc[px] = _mm512_fmadd_ps(_mm512_set1_ps(prof[px][$j]), v, $acc[px]);
                    }
                    if MICRO {
                        macc[$j / 2] = _mm512_add_ps(macc[$j / 2], v);
                    }
                }};
            }
            pixel_row!(0);
            pixel_row!(1);
            pixel_row!(2);
            pixel_row!(3);
            pixel_row!(4);
            pixel_row!(5);
            pixel_row!(6);
            pixel_row!(7);
            debug_assert!(cell.len() == PROFILES * PROFILES * nb);
            for (n, c) in cacc.iter().enumerate() {
                let slot = cell_slot(n / PROFILES, n % PROFILES);
                // SAFETY: the masked store writes lanes 0..nb at slot·nb, inside the cell (16·nb).
                unsafe { _mm512_mask_storeu_ps(cell.as_mut_ptr().add(slot * nb), mask, *c) };
            }
        }
        if MICRO && ncx * PER_CELL < nmx {
            portable::micro_margin(bins, wts, stride, nb, ncx * PER_CELL, micro);
        }
    }
}

/// `portable::fill_cell_row` one cell at a time, everything in registers: for each micro row landing in
/// cell row `cy` (in order), the cell's run of micro-cells is summed into four 16-lane registers
/// (one per x-profile, bins in lanes), and those are added with the row's four y-profile weights
/// (times the gain) into the cell's 16 profile histograms, which stay in registers until the cell
/// is stored into its slots. The same fused multiply-adds in the same order as
/// `portable::fill_cell_row` (every value is a chain over micro rows, each term a chain
/// over micro-cells from `+0`), so the same bits; but no `[y-profile][cell][x-profile][bin]` row
/// buffer goes through L2 per micro row, and no permutation pass follows.
///
/// # Safety
/// The CPU must support AVX-512F/BW/VL and F16C; `micro` has ≤ 16 bins and `taps` are its taps
/// (`Taps::fits`).
#[target_feature(enable = "avx512f,avx512bw,avx512vl,f16c,avx2,fma")]
pub(crate) unsafe fn fill_cell_row(micro: &MicroGrid, taps: &Taps, cy: usize, row: &mut [f32]) {
    let nb = micro.nbins;
    debug_assert!(nb <= REGISTER_MAX_BINS);
    let mask = ((1u32 << nb) - 1) as __mmask16;
    let cl = cell_len(nb);
    let (lo, hi) = taps.rows[cy];
    let stride = micro.nmx * nb;
    // The y-profile weights (times the gain) of the rows landing in this cell row, as the
    // portable fill computes them.
    let wys: Vec<(usize, [f32; PROFILES])> = (lo..hi)
        .filter_map(|my| taps.yt[my].map(|ty| (my, ty.w.map(|w| w * taps.gain))))
        .collect();
    for (cx, cell) in row.chunks_exact_mut(cl).enumerate().take(taps.ncx) {
        let (clo, chi) = taps.cols[cx];
        let mut t = [_mm512_setzero_ps(); PROFILES * PROFILES];
        for (i, (my, wy)) in wys.iter().enumerate() {
            let mut acc = [_mm512_setzero_ps(); PROFILES];
            let src = &micro.data[my * stride..][..stride];
            // SAFETY (both closures): `nb` half floats of micro-cell `mx` (< nmx) of this row.
            let load = |mx: usize| unsafe {
                _mm512_cvtph_ps(_mm256_maskz_loadu_epi16(
                    mask,
                    src.as_ptr().add(mx * nb) as *const i16,
                ))
            };
            match taps.split[cx] {
                // Left of `mid` x-profile 2 is exactly 0 and right of it x-profile 1 is: adding
                // `0·v` (+0) to a sum ≥ +0 changes no bit, so those products are skipped.
                Some(mid) => {
                    for mx in clo..mid {
                        let (w, vv) = (&taps.xw[mx], load(mx));
                        for p in LEFT_PROFILES {
                            acc[p] = _mm512_fmadd_ps(_mm512_set1_ps(w[p]), vv, acc[p]);
                        }
                    }
                    for mx in mid..chi {
                        let (w, vv) = (&taps.xw[mx], load(mx));
                        for p in RIGHT_PROFILES {
                            acc[p] = _mm512_fmadd_ps(_mm512_set1_ps(w[p]), vv, acc[p]);
                        }
                    }
                }
                None => {
                    for mx in clo..chi {
                        let (w, vv) = (&taps.xw[mx], load(mx));
                        for (a, &w) in acc.iter_mut().zip(w) {
                            *a = _mm512_fmadd_ps(_mm512_set1_ps(w), vv, *a);
                        }
                    }
                }
            }
            for (py, &w) in wy.iter().enumerate() {
                let wv = _mm512_set1_ps(w);
                let tr = &mut t[py * PROFILES..][..PROFILES];
                if i == 0 {
                    for (d, a) in tr.iter_mut().zip(&acc) {
                        *d = _mm512_mul_ps(wv, *a);
                    }
                } else if w != 0.0 {
                    for (d, a) in tr.iter_mut().zip(&acc) {
                        *d = _mm512_fmadd_ps(wv, *a, *d);
                    }
                }
            }
        }
        for py in 0..PROFILES {
            for px in 0..PROFILES {
                // SAFETY: `nb` lanes at the slot's offset, inside the cell's `cl` values.
                unsafe {
                    _mm512_mask_storeu_ps(
                        cell.as_mut_ptr().add(cell_slot(py, px) * nb),
                        mask,
                        t[py * PROFILES + px],
                    )
                };
            }
        }
    }
}
