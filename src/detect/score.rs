//! Linear-SVM window scores of a HOG block grid, computed as a matrix product.
//!
//! # Method
//!
//! A window whose top-left block is `(wx, wy)` scores
//! `s(wx, wy) = b + Σ_{by<bh} Σ_{bx<bw} w_k · B(wx+bx, wy+by)`, `k = bx·bh + by` (OpenCV's block
//! order), where `B` is a normalised block (36 values) and `w_k` the model's weight slice for block
//! position `k`. Instead of one 36-long dot product per (window, block) pair with a horizontal sum
//! each time, every block row `r` of the grid is multiplied once by the `36 x 105` weight matrix:
//!
//! `P_r[k][x] = Σ_i B(x, r)[i] · W[i][k]` (a GEMM, `nbx x 36` times `36 x 105`),
//!
//! and a window score is a sum of 105 entries of `P`:
//! `s(wx, wy) = b + Σ_{by} Σ_{bx} P_{wy+by}[bx·bh+by][wx+bx]`. The second step is a plain
//! element-wise add of rows of `P` (vectorised over `wx`). The multiply count is the same as the
//! direct method (one product per block and block position) but it runs register-blocked, 8 (AVX2)
//! or 16 (AVX-512) blocks per vector, with no horizontal sums.
//!
//! # Exactness
//!
//! Every `P` entry is the same chain of fused multiply-adds over `i = 0..36` starting from 0 in
//! all kernels (the scalar reference uses [`f32::mul_add`]), and the window sums add in the fixed
//! order `by` then `bx` starting from the bias, so all dispatch paths give **bit-identical** scores,
//! for any thread count. Against the old per-window dot product (8 partial sums) scores differ only
//! by summation order (≈1e-6).
//!
//! ```
//! use mosaicd::detect::score::{window_scores, ScoreWeights};
//! use mosaicd::features::hog::{block_grid_from_input, HogInput, HogOptions, HogSpec, Exec};
//! use mosaicd::image::Image;
//! let spec = HogSpec::new(&HogOptions::default()).unwrap();
//! let img = Image::<u8>::from_fn(80, 144, |x, y| ((x * 7 + y * 3) % 256) as u8);
//! let grid = block_grid_from_input(&spec, &HogInput::GreyU8(img.view())).unwrap();
//! let w = vec![0.01f32; spec.descriptor_len()];
//! let sw = ScoreWeights::new(&spec, &w, -0.5);
//! let mut scores = vec![0.0; 3 * 3];
//! window_scores(&sw, &grid, Exec::Serial, &mut scores);
//! let d = grid.window_descriptor(&spec, 2, 1).unwrap();
//! let direct: f32 = d.iter().sum::<f32>() * 0.01 - 0.5;
//! assert!((scores[1 * 3 + 2] - direct).abs() < 1e-4);
//! ```

use rayon::prelude::*;

use crate::features::hog::{BlockGrid, Exec, HogSpec};

/// Window rows per parallel task (1080p level 0 has 120; each task recomputes 14 block rows).
const SCORE_STRIP_ROWS: usize = 64;
/// Block columns are zero-padded to a multiple of this (the widest kernel's vector).
const PAD_COLUMNS: usize = 16;
/// Block positions (columns of the weight matrix) per register tile of the AVX2 kernel: 12
/// accumulators + 1 block vector + 1 broadcast fit the 16 ymm registers.
const TILE_K_AVX2: usize = 12;
/// Block positions per register tile of the AVX-512 kernel (21 accumulators of 32 zmm; 105 = 5·21).
const TILE_K_AVX512: usize = 21;

/// The model re-laid out for the GEMM: `wt[i·nkp + k]` = weight of value `i` of block position `k`,
/// zero-padded to `nkp` positions (whole tiles for every kernel).
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreWeights {
    wt: Vec<f32>,
    bias: f32,
    /// Block length (36).
    bl: usize,
    /// Blocks per window (7, 15).
    bw: usize,
    bh: usize,
    /// Block positions per window (105) and its padded count.
    nk: usize,
    nkp: usize,
}

impl ScoreWeights {
    /// From a weight vector in OpenCV descriptor order (`spec.descriptor_len()` values; a shorter
    /// vector is zero-extended, a longer one cut) and the bias.
    pub fn new(spec: &HogSpec, weights: &[f32], bias: f32) -> Self {
        let (bw, bh) = spec.blocks_per_window();
        let bl = spec.block_len();
        let nk = bw * bh;
        // Every kernel's last tile may run past nk (its results are not stored) but stays in wt.
        let nkp = (nk.div_ceil(TILE_K_AVX2) * TILE_K_AVX2).max(nk.div_ceil(TILE_K_AVX512) * TILE_K_AVX512);
        let mut wt = vec![0.0f32; bl * nkp];
        for k in 0..nk {
            for i in 0..bl {
                wt[i * nkp + k] = weights.get(k * bl + i).copied().unwrap_or(0.0);
            }
        }
        Self {
            wt,
            bias,
            bl,
            bw,
            bh,
            nk,
            nkp,
        }
    }
}

/// Which block-product kernel runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProductKernel {
    /// Scalar [`f32::mul_add`] chains (the reference).
    Scalar,
    /// AVX2 + FMA, 8 blocks per vector.
    Avx2,
    /// AVX-512F, 16 blocks per vector.
    Avx512,
}

impl ProductKernel {
    /// The fastest kernel this CPU runs.
    pub fn detect() -> Self {
        *Self::available().last().unwrap_or(&Self::Scalar)
    }

    /// Every kernel this CPU runs, slowest first (for tests that compare them).
    pub fn available() -> Vec<Self> {
        #[allow(unused_mut)]
        let mut v = vec![Self::Scalar];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                v.push(Self::Avx2);
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                v.push(Self::Avx512);
            }
        }
        v
    }
}

/// Scores of every window of `grid` (row-major, `grid.windows()` wide) into `scores`, with the
/// fastest kernel of this CPU. `scores` must hold `nwx · nwy` values (extra values are untouched).
pub fn window_scores(w: &ScoreWeights, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
    window_scores_with(w, grid, exec, ProductKernel::detect(), scores)
}

/// [`window_scores`] with a chosen kernel (must be one of [`ProductKernel::available`]; an
/// unavailable one falls back to the scalar kernel).
pub fn window_scores_with(
    w: &ScoreWeights,
    grid: &BlockGrid,
    exec: Exec,
    kernel: ProductKernel,
    scores: &mut [f32],
) {
    let (nbx, nby) = (grid.blocks_x(), grid.blocks_y());
    if nbx < w.bw || nby < w.bh || grid.block_len() != w.bl {
        return;
    }
    let (nwx, nwy) = (nbx + 1 - w.bw, nby + 1 - w.bh);
    let kernel = if ProductKernel::available().contains(&kernel) {
        kernel
    } else {
        ProductKernel::Scalar
    };
    // Columns padded with zero blocks to whole vectors of the widest kernel.
    let nbxp = nbx.div_ceil(PAD_COLUMNS) * PAD_COLUMNS;
    // A strip of window rows walks the block rows it needs in ascending order, computes each row's
    // products once into a small buffer and adds them to the window rows they belong to. Parallel
    // strips recompute the bh − 1 block rows they share (≈10 % at 1080p) instead of holding every
    // row's products (13 MB at 1080p); serially the whole grid is one strip. A window's sum has
    // the same order in any split (block rows ascending, then block columns), so the same bits.
    let strip_work = |(s, chunk): (usize, &mut [f32])| {
        let first = s * SCORE_STRIP_ROWS;
        let rows = chunk.len() / nwx;
        let mut bt = vec![0.0f32; w.bl * nbxp];
        let mut pr = vec![0.0f32; w.nk * nbxp];
        chunk.fill(w.bias);
        for r in first..first + rows + w.bh - 1 {
            transpose_row(grid.block_row(r), w.bl, nbx, nbxp, &mut bt);
            block_products(w, &bt, nbx, nbxp, kernel, &mut pr);
            // Window row wy = r − by gets block row `by` of its window from this block row.
            for by in 0..w.bh {
                let Some(wy) = r.checked_sub(by) else { break };
                if wy < first || wy >= first + rows {
                    continue;
                }
                let row = &mut chunk[(wy - first) * nwx..][..nwx];
                for bx in 0..w.bw {
                    let src = &pr[(bx * w.bh + by) * nbxp + bx..][..nwx];
                    for (v, &p) in row.iter_mut().zip(src) {
                        *v += p;
                    }
                }
            }
        }
    };
    let scores = &mut scores[..nwx * nwy];
    match exec {
        Exec::Parallel => scores
            .par_chunks_mut(nwx * SCORE_STRIP_ROWS)
            .enumerate()
            .for_each(strip_work),
        // One strip: nothing to share, so no block row is computed twice.
        Exec::Serial => strip_work((0, scores)),
    }
}

/// `bt[i·nbxp + x] = row[x·bl + i]` for `x < nbx` (the padding columns stay zero).
fn transpose_row(row: &[f32], bl: usize, nbx: usize, nbxp: usize, bt: &mut [f32]) {
    for (x, blk) in row.chunks_exact(bl).take(nbx).enumerate() {
        for (i, &v) in blk.iter().enumerate() {
            bt[i * nbxp + x] = v;
        }
    }
}

/// `out[k·nbxp + x] = Σ_i bt[i·nbxp + x] · wt[i·nkp + k]` for `k < nk`, `x < nbx` (SIMD kernels also
/// fill padding columns), fused multiply-adds in order `i = 0..bl` from 0.
fn block_products(
    w: &ScoreWeights,
    bt: &[f32],
    nbx: usize,
    nbxp: usize,
    kernel: ProductKernel,
    out: &mut [f32],
) {
    debug_assert!(nbxp.is_multiple_of(PAD_COLUMNS) && nbx <= nbxp);
    debug_assert!(bt.len() >= w.bl * nbxp && out.len() >= w.nk * nbxp && w.wt.len() >= w.bl * w.nkp);
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `kernel` is one of `ProductKernel::available()` (checked by the caller), so the
        // CPU has AVX2 and FMA; the kernel's loads and stores stay within the lengths asserted above.
        // Measured: see docs/detection.md "Speed" (SVM stage).
        ProductKernel::Avx2 => unsafe { block_products_avx2(w, bt, nbxp, out) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, with AVX-512F detected.
        ProductKernel::Avx512 => unsafe { block_products_avx512(w, bt, nbxp, out) },
        _ => block_products_scalar(w, bt, nbx, nbxp, out),
    }
}

/// The scalar reference.
fn block_products_scalar(w: &ScoreWeights, bt: &[f32], nbx: usize, nbxp: usize, out: &mut [f32]) {
    for k in 0..w.nk {
        for x in 0..nbx {
            let mut acc = 0.0f32;
            for i in 0..w.bl {
                acc = bt[i * nbxp + x].mul_add(w.wt[i * w.nkp + k], acc);
            }
            out[k * nbxp + x] = acc;
        }
    }
}

/// AVX2 + FMA block products over all `nbxp` (a multiple of 8) columns.
///
/// # Safety
/// The CPU must support AVX2 and FMA; `bt`, `out` and `w.wt` must hold the lengths asserted in
/// [`block_products`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn block_products_avx2(w: &ScoreWeights, bt: &[f32], nbx: usize, out: &mut [f32]) {
    use std::arch::x86_64::*;
    const L: usize = 8;
    debug_assert!(nbx.is_multiple_of(L));
    let full = nbx;
    let (bl, nk, nkp) = (w.bl, w.nk, w.nkp);
    debug_assert!(nk.div_ceil(TILE_K_AVX2) * TILE_K_AVX2 <= nkp);
    for x in (0..full).step_by(L) {
        for k0 in (0..nk).step_by(TILE_K_AVX2) {
            let mut acc = [_mm256_setzero_ps(); TILE_K_AVX2];
            for i in 0..bl {
                debug_assert!(i * nbx + x + L <= bt.len() && i * nkp + k0 + TILE_K_AVX2 <= w.wt.len());
                // SAFETY: x + 8 ≤ nbx and i < bl, so the 8 loaded floats are inside bt (bl·nbx);
                // k0 + TILE ≤ nkp, so the broadcasts read inside wt (bl·nkp).
                let b = unsafe { _mm256_loadu_ps(bt.as_ptr().add(i * nbx + x)) };
                let wr = unsafe { w.wt.as_ptr().add(i * nkp + k0) };
                for (j, a) in acc.iter_mut().enumerate() {
                    let wv = unsafe { _mm256_broadcast_ss(&*wr.add(j)) };
                    *a = _mm256_fmadd_ps(b, wv, *a);
                }
            }
            for (j, a) in acc.iter().enumerate() {
                let k = k0 + j;
                if k < nk {
                    debug_assert!(k * nbx + x + L <= out.len());
                    // SAFETY: k < nk and x + 8 ≤ nbx, inside out (nk·nbx).
                    unsafe { _mm256_storeu_ps(out.as_mut_ptr().add(k * nbx + x), *a) };
                }
            }
        }
    }
}

/// AVX-512F block products over all `nbxp` (a multiple of 16) columns.
///
/// # Safety
/// The CPU must support AVX-512F; lengths as in [`block_products`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn block_products_avx512(w: &ScoreWeights, bt: &[f32], nbx: usize, out: &mut [f32]) {
    use std::arch::x86_64::*;
    const L: usize = 16;
    debug_assert!(nbx.is_multiple_of(L));
    let full = nbx;
    let (bl, nk, nkp) = (w.bl, w.nk, w.nkp);
    debug_assert!(nk.div_ceil(TILE_K_AVX512) * TILE_K_AVX512 <= nkp);
    for x in (0..full).step_by(L) {
        for k0 in (0..nk).step_by(TILE_K_AVX512) {
            let mut acc = [_mm512_setzero_ps(); TILE_K_AVX512];
            for i in 0..bl {
                debug_assert!(i * nbx + x + L <= bt.len() && i * nkp + k0 + TILE_K_AVX512 <= w.wt.len());
                // SAFETY: x + 16 ≤ nbx and i < bl: inside bt; k0 + TILE ≤ nkp: inside wt.
                let b = unsafe { _mm512_loadu_ps(bt.as_ptr().add(i * nbx + x)) };
                let wr = unsafe { w.wt.as_ptr().add(i * nkp + k0) };
                for (j, a) in acc.iter_mut().enumerate() {
                    let wv = _mm512_set1_ps(unsafe { *wr.add(j) });
                    *a = _mm512_fmadd_ps(b, wv, *a);
                }
            }
            for (j, a) in acc.iter().enumerate() {
                let k = k0 + j;
                if k < nk {
                    debug_assert!(k * nbx + x + L <= out.len());
                    // SAFETY: k < nk and x + 16 ≤ nbx, inside out (nk·nbx).
                    unsafe { _mm512_storeu_ps(out.as_mut_ptr().add(k * nbx + x), *a) };
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::hog::{block_grid, HogInput, HogOptions};
    use crate::image::Image;

    fn setup(w: usize, h: usize) -> (HogSpec, BlockGrid, Vec<f32>) {
        let spec = HogSpec::new(&HogOptions::default()).unwrap();
        let img = Image::<u8>::from_fn(w, h, |x, y| ((x * x + 7 * y * x + 3 * y) % 251) as u8);
        let mut grid = BlockGrid::empty();
        block_grid(&spec, &HogInput::GreyU8(img.view()), Exec::Serial, &mut grid).unwrap();
        let wts: Vec<f32> = (0..spec.descriptor_len() as u32)
            .map(|i| ((i.wrapping_mul(2654435761) >> 7) % 2001) as f32 / 1000.0 - 1.0)
            .collect();
        (spec, grid, wts)
    }

    #[test]
    fn every_kernel_is_bit_identical_to_the_scalar_reference() {
        // 300 px → 36 blocks across: padded to 48 columns for the SIMD kernels.
        let (spec, grid, wts) = setup(300, 277);
        let sw = ScoreWeights::new(&spec, &wts, 0.25);
        let (nwx, nwy) = grid.windows(&spec);
        let mut want = vec![0.0f32; nwx * nwy];
        window_scores_with(&sw, &grid, Exec::Serial, ProductKernel::Scalar, &mut want);
        let kernels = ProductKernel::available();
        assert!(kernels.contains(&ProductKernel::Scalar));
        for k in kernels {
            for exec in [Exec::Serial, Exec::Parallel] {
                let mut got = vec![0.0f32; nwx * nwy];
                window_scores_with(&sw, &grid, exec, k, &mut got);
                assert_eq!(
                    got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    want.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{k:?} {exec:?}"
                );
            }
        }
    }

    #[test]
    fn scores_equal_descriptor_dot_products() {
        // 700 px high → 72 window rows: two strips that share block rows.
        let (spec, grid, wts) = setup(100, 700);
        let sw = ScoreWeights::new(&spec, &wts, -0.75);
        let (nwx, nwy) = grid.windows(&spec);
        let mut got = vec![0.0f32; nwx * nwy];
        window_scores(&sw, &grid, Exec::Parallel, &mut got);
        for wy in 0..nwy {
            for wx in 0..nwx {
                let d = grid.window_descriptor(&spec, wx, wy).unwrap();
                let want = d
                    .iter()
                    .zip(&wts)
                    .map(|(&a, &b)| a as f64 * b as f64)
                    .sum::<f64>()
                    - 0.75;
                assert!((got[wy * nwx + wx] as f64 - want).abs() < 1e-4, "{wx},{wy}");
            }
        }
    }

    #[test]
    fn a_grid_smaller_than_a_window_leaves_scores_alone() {
        let spec = HogSpec::new(&HogOptions::default()).unwrap();
        let sw = ScoreWeights::new(&spec, &[], 1.0);
        let mut s = vec![7.0f32; 3];
        window_scores(&sw, &BlockGrid::empty(), Exec::Serial, &mut s);
        assert_eq!(s, vec![7.0; 3]);
    }
}
