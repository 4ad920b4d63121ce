//! The portable HOG kernels: the per-row loops of gamma, cell histograms (step 4 of the math in
//! [`crate::features::hog`]), block assembly and L2-Hys (steps 5 and 6), micro rows and the
//! approximated levels' fill ([`crate::features::hog::approx`] for their math), written once as
//! `#[inline(always)]` bodies. They are the oracles of the register kernels in the sibling files,
//! and those files also compile them per instruction set (LLVM vectorises their arithmetic
//! passes). The stages (`cells`, `blocks`, `approx`, `input`) reach them only through the dispatch
//! in [`super`]. The gradient rows they all read are in `gradient`.

use super::super::gradient::gradient_row;
use super::super::types::{
    cell_len, cell_slot, f16_bits, AxisTap, BlockParams, CellScratch, FillScratch, MicroGrid, Planes,
    RowScratch, Taps,
};
use super::super::{HogSpec, CELL_SIZE, L2HYS_EPS2, PROFILES};
use super::f16::{from_f16_row, to_f16_row};
use crate::kernels::Isa;

/// [`gamma_in_place`](crate::features::hog::gamma_in_place)'s portable body (the oracle; the kernel paths compile it per ISA).
#[inline(always)]
pub(crate) fn gamma_in_place_generic(row: &mut [f32], gamma: bool) {
    if gamma {
        for v in row.iter_mut() {
            *v = v.max(0.0).sqrt();
        }
    } else {
        for v in row.iter_mut() {
            *v = v.max(0.0);
        }
    }
}

/// Cell histograms of strip `s` (STRIP_CELL_ROWS cell rows) into `chunk`. Votes are accumulated
/// with [`f32::mul_add`] (one rounding, as the FMA kernels): native on AArch64 and in the AVX2 + FMA
/// build, a slow library call only on x86 CPUs without FMA.
#[inline(always)]
pub(crate) fn cells_strip(spec: &HogSpec, p: &Planes, cy0: usize, chunk: &mut [f32], cs: &mut CellScratch) {
    let nb = spec.nbins();
    let ncx = p.width / CELL_SIZE;
    let cl = cell_len(nb);
    // Non-zero x-profiles per pixel column of a cell (3 of 4 for the default geometry).
    let mut nonzero = [[(0usize, 0.0f32); PROFILES]; CELL_SIZE];
    let mut nnz = [0usize; CELL_SIZE];
    for j in 0..CELL_SIZE {
        for px in 0..PROFILES {
            if spec.profile[px][j] != 0.0 {
                nonzero[j][nnz[j]] = (px, spec.profile[px][j]);
                nnz[j] += 1;
            }
        }
    }
    let bins = &mut cs.bins[..ncx * CELL_SIZE];
    let wts = &mut cs.wts[..ncx * CELL_SIZE];
    let mut rowacc = vec![0.0f32; PROFILES * nb];
    chunk.fill(0.0);
    for (k, cell_row) in chunk.chunks_mut(ncx * cl).enumerate() {
        let cy = cy0 + k;
        for i in 0..CELL_SIZE {
            gradient_row(p, cy * CELL_SIZE + i, nb, &mut cs.sc, bins, wts);
            for (cx, cell) in cell_row.chunks_mut(cl).enumerate() {
                rowacc.iter_mut().for_each(|v| *v = 0.0);
                let x0 = cx * CELL_SIZE;
                let cols = bins[x0..x0 + CELL_SIZE].iter().zip(&wts[x0..x0 + CELL_SIZE]);
                for (j, (&[b0, b1], &[w0, w1])) in cols.enumerate() {
                    for &(px, pw) in &nonzero[j][..nnz[j]] {
                        let acc = &mut rowacc[px * nb..(px + 1) * nb];
                        acc[b0 as usize] = pw.mul_add(w0, acc[b0 as usize]);
                        acc[b1 as usize] = pw.mul_add(w1, acc[b1 as usize]);
                    }
                }
                for py in 0..PROFILES {
                    let wy = spec.profile[py][i];
                    if wy == 0.0 {
                        continue;
                    }
                    for (px, acc) in rowacc.chunks_exact(nb).enumerate() {
                        let dst = &mut cell[cell_slot(py, px) * nb..][..nb];
                        for (d, &r) in dst.iter_mut().zip(acc) {
                            *d = wy.mul_add(r, *d);
                        }
                    }
                }
            }
        }
    }
}

/// One block row from its upper and lower cell rows (`ncx` cells each; every value is written).
/// The portable kernel, and the oracle of the batched builds in `kernels`.
#[inline(always)]
pub(crate) fn block_row(spec: &HogSpec, ncx: usize, top: &[f32], bottom: &[f32], row: &mut [f32]) {
    let bp = BlockParams::new(spec);
    debug_assert!(top.len() >= ncx * cell_len(bp.nb) && bottom.len() >= ncx * cell_len(bp.nb));
    for (bx, blk) in row.chunks_mut(bp.bl).enumerate() {
        block_at(&bp, top, bottom, bx, blk);
    }
}

/// Block `bx` of a block row (`blk`, `bl` values) from its upper and lower cell rows, then
/// [`normalize_l2hys`].
#[inline(always)]
pub(crate) fn block_at(bp: &BlockParams, top: &[f32], bottom: &[f32], bx: usize, blk: &mut [f32]) {
    let BlockParams { nb, bl, eps1, thresh } = *bp;
    let cl = cell_len(nb);
    // The cell at (sy, sx) in the block holds its whole contribution to the block, in block
    // order, as one run of `bl` values ([`cell_slot`]). The four runs are summed in (sy, sx)
    // order in registers from 0 (a read-modify-write of `blk` per source stalled on store
    // forwarding).
    let h = |sy: usize, sx: usize| {
        let cells = if sy == 0 { top } else { bottom };
        let c = &cells[(bx + sx) * cl..][..cl];
        &c[cell_slot(sy, sx) * nb..][..bl]
    };
    let (h00, h01, h10, h11) = (h(0, 0), h(0, 1), h(1, 0), h(1, 1));
    for (k, o) in blk.iter_mut().enumerate() {
        *o = (((0.0 + h00[k]) + h01[k]) + h10[k]) + h11[k];
    }
    normalize_l2hys(blk, eps1, thresh);
}

/// OpenCV `normalizeBlockHistogram`: L2, clip, L2 again. Squares are summed in 8 interleaved
/// partial sums (lane `i mod 8`) added pairwise at the end, so the loops vectorise; OpenCV sums in
/// 4 SIMD lanes, a sequential sum differs from both by ≈1e-7 relative.
#[inline(always)]
pub fn normalize_l2hys(h: &mut [f32], eps1: f32, thresh: f32) {
    let scale = 1.0 / (sum_of_squares(h).sqrt() + eps1);
    for v in h.iter_mut() {
        *v = (*v * scale).min(thresh);
    }
    let scale2 = 1.0 / (sum_of_squares(h).sqrt() + L2HYS_EPS2);
    for v in h.iter_mut() {
        *v *= scale2;
    }
}

/// `Σ v²` in 8 partial sums (lane `i mod 8`), combined as ((0+4)+(2+6))+((1+5)+(3+7)).
#[inline(always)]
pub(crate) fn sum_of_squares(h: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let chunks = h.chunks_exact(8);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..8 {
            acc[k] += c[k] * c[k];
        }
    }
    for (k, &v) in rest.iter().enumerate() {
        acc[k] += v * v;
    }
    let a: [f32; 4] = std::array::from_fn(|k| acc[k] + acc[k + 4]);
    (a[0] + a[2]) + (a[1] + a[3])
}

/// Micro rows from `my0` on (as many as `chunk` holds, every value written): each row summed
/// in `f32`, then stored as half floats (converted with the `isa` build). The portable kernel,
/// compiled per ISA by `kernels`.
#[inline(always)]
pub(crate) fn micro_rows(isa: Isa, p: &Planes, nb: usize, size: usize, my0: usize, chunk: &mut [u16]) {
    let nmx = p.width / size;
    let used = nmx * size;
    let mut sc = RowScratch::new(p.width);
    let mut bins = vec![[0u8; 2]; used];
    let mut wts = vec![[0.0f32; 2]; used];
    let mut row = vec![0.0f32; nmx * nb];
    for (k, out) in chunk.chunks_mut(nmx * nb).enumerate() {
        let my = my0 + k;
        row.fill(0.0);
        for y in my * size..(my + 1) * size {
            gradient_row(p, y, nb, &mut sc, &mut bins, &mut wts);
            for (cell, (b, w)) in row
                .chunks_exact_mut(nb)
                .zip(bins.chunks_exact(size).zip(wts.chunks_exact(size)))
            {
                for (&[b0, b1], &[w0, w1]) in b.iter().zip(w) {
                    cell[b0 as usize] += w0;
                    cell[b1 as usize] += w1;
                }
            }
        }
        to_f16_row(isa, &row, out);
    }
}

/// The 2x2-pixel micro-cells `mx0..` of a cell row's 4 micro rows (`micro`, `nmx` micro-cells
/// each) from its 8 pixel rows of votes (`bins`, `wts`, `stride` pixels apart), summed in the pixel
/// order of [`micro_rows`]: the register cell kernels' margin right of the last whole cell.
pub(crate) fn micro_margin(
    bins: &[[u8; 2]],
    wts: &[[f32; 2]],
    stride: usize,
    nb: usize,
    mx0: usize,
    micro: &mut [u16],
) {
    let per_cell = CELL_SIZE / 2;
    let nmx = micro.len() / (per_cell * nb).max(1);
    let mut acc = vec![0.0f32; nb];
    for a in 0..per_cell {
        for mx in mx0..nmx {
            acc.fill(0.0);
            for y in 2 * a..2 * a + 2 {
                for x in 2 * mx..2 * mx + 2 {
                    let ([b0, b1], [w0, w1]) = (bins[y * stride + x], wts[y * stride + x]);
                    acc[b0 as usize] += w0;
                    acc[b1 as usize] += w1;
                }
            }
            let out = &mut micro[(a * nmx + mx) * nb..][..nb];
            for (o, &v) in out.iter_mut().zip(&acc) {
                *o = f16_bits(v);
            }
        }
    }
}

/// `a·b + c`: one fused multiply-add (one rounding, [`f32::mul_add`]) when `FUSED`, else a
/// multiply, then an add (two roundings). The fill's oracle and every register fill are fused;
/// the unfused build is what the x86-64 baseline runs, where `mul_add` is a library call
/// (`FillKernel::ScalarUnfused`).
#[inline(always)]
fn madd<const FUSED: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FUSED {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// Horizontal pass of one micro row (`src`) into `h` (`[cell][x-profile][bin]`, every value
/// written): the row is converted to `f32` once into `v` ([`from_f16_row`]), then every
/// micro-cell adds its histogram times its four x-profile weights to its cell (fused
/// multiply-adds).
#[inline(always)]
fn hpass<const FUSED: bool>(
    isa: Isa,
    nb: usize,
    xt: &[Option<AxisTap>],
    src: &[u16],
    h: &mut [f32],
    v: &mut Vec<f32>,
) {
    let hl = PROFILES * nb;
    h.fill(0.0);
    v.resize(src.len(), 0.0);
    from_f16_row(isa, src, v);
    for (tx, mc) in xt.iter().zip(v.chunks_exact(nb)) {
        let Some(tx) = tx else { continue };
        let hc = &mut h[tx.cell * hl..][..hl];
        // All four x-profiles (zero weights add +0).
        for (hp, &wx) in hc.chunks_exact_mut(nb).zip(&tx.w) {
            for (d, &s) in hp.iter_mut().zip(mc) {
                *d = madd::<FUSED>(wx, s, *d);
            }
        }
    }
}

/// Cell row `cy` of the approximated level (cell layout of [`CellGrid`](crate::features::hog::CellGrid), every value
/// written; half floats converted with the `isa` build): each micro row landing in it is pooled
/// horizontally into (cell, x-profile) histograms, which are added with the row's y-profile
/// weights (times the gain) into a `[y-profile][cell][x-profile][bin]` buffer — one contiguous
/// multiply-add per y-profile — and that buffer is finally permuted into the cells' slots. The
/// portable kernel and the oracle of the register fills in `kernels`.
#[inline(always)]
pub(crate) fn fill_cell_row<const FUSED: bool>(
    isa: Isa,
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
) {
    // A literal bin count lets the compiler unroll and vectorise the default geometry.
    if micro.nbins == 9 {
        fill_cell_row_nb::<FUSED>(isa, 9, micro, taps, cy, row, s)
    } else {
        fill_cell_row_nb::<FUSED>(isa, micro.nbins, micro, taps, cy, row, s)
    }
}

/// [`fill_cell_row`] for `nb` = `micro.nbins` bins.
#[inline(always)]
fn fill_cell_row_nb<const FUSED: bool>(
    isa: Isa,
    nb: usize,
    micro: &MicroGrid,
    taps: &Taps,
    cy: usize,
    row: &mut [f32],
    s: &mut FillScratch,
) {
    let hl = PROFILES * nb;
    let plane = taps.ncx * hl;
    let FillScratch { h, t, v } = s;
    h.resize(taps.ncx * hl, 0.0);
    t.resize(PROFILES * plane, 0.0);
    let (lo, hi) = taps.rows[cy];
    let mut first = true;
    for (my, ty) in taps.yt.iter().enumerate().take(hi).skip(lo) {
        let Some(ty) = ty else { continue };
        hpass::<FUSED>(
            isa,
            nb,
            &taps.xt,
            &micro.data[my * micro.nmx * nb..][..micro.nmx * nb],
            h,
            v,
        );
        for (py, &wy) in ty.w.iter().enumerate() {
            let wy = wy * taps.gain;
            let tp = &mut t[py * plane..][..plane];
            if first {
                // `wy·s` is `0 + wy·s` to the bit (both ≥ +0): no zeroing pass.
                for (d, &s) in tp.iter_mut().zip(h.iter()) {
                    *d = wy * s;
                }
            } else if wy != 0.0 {
                for (d, &s) in tp.iter_mut().zip(h.iter()) {
                    *d = madd::<FUSED>(wy, s, *d);
                }
            }
        }
        first = false;
    }
    if first {
        t.fill(0.0);
    }
    let cl = cell_len(nb);
    for (cx, cell) in row.chunks_exact_mut(cl).enumerate() {
        for py in 0..PROFILES {
            for px in 0..PROFILES {
                let src = &t[py * plane + cx * hl + px * nb..][..nb];
                let dst = &mut cell[cell_slot(py, px) * nb..][..nb];
                for (d, &v) in dst.iter_mut().zip(src) {
                    *d = v;
                }
            }
        }
    }
}
