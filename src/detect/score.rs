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
//! # 8-bit path ([`ScorePrecision::I8`])
//!
//! An optional integer path for CPUs with AVX-512 VNNI (`vpdpbusd`: 16 lanes, each adding four
//! u8·i8 products to an i32). Block values `v ∈ [0, 1]` (L2-Hys) become bytes
//! `q_v = round(255·v)` ([`quantise_block_value`]: clamped to `0..=255`, ties to even), the weights
//! become `q_w = round(s·w)`, `s = 127 / max|w|`, once per model ([`ScoreWeightsI8`]; an all-zero
//! model keeps `s = 1` and scores its bias). Then
//!
//! `P_r[k][x] = Σ_i q_v(x, r)[i] · q_w[i][k]` and `S(wx, wy) = Σ_{by} Σ_{bx} P_{wy+by}[bx·bh+by][wx+bx]`
//!
//! are **exact** i32 sums (`|S| ≤ 255·127·3780 < 2^31`; descriptors longer than
//! [`ScoreWeightsI8::MAX_DESCRIPTOR_LEN`] are refused), and the score is
//! `s(wx, wy) = b + S · (1/(255·s))` in f32 (one multiply, one add, the same code after every
//! kernel; the bias stays f32).
//!
//! Layout: each block row is quantised to bytes and transposed as dwords, `btq[g·nbxp + x]` = the
//! bytes of values `4g..4g+4` of block `x` (9 dwords for 36 values; a block length that is not a
//! multiple of 4 is zero-padded), and the weights as dwords `wq[g·nkp + k]`. The VNNI kernel keeps
//! the f32 kernel's 21-accumulator tiles, `acc[j] = vpdpbusd(acc[j], btq[g][x..x+16],
//! broadcast(wq[g][k0+j]))`: a quarter of its instructions (9 instead of 36 per block position).
//!
//! **Determinism.** Integer addition is associative, so the scalar reference and the VNNI kernel,
//! any strip split and any thread count give the same bits (tested), whatever order the sums run
//! in. Without AVX-512 F/BW/VNNI the path runs the scalar kernel: the same bits, but slower than
//! the f32 path — choose f32 there.
//!
//! **Error.** With `q_v = 255·v + e_v` and `q_w = s·w + e_w`, `|e| ≤ ½`, a score differs from the
//! exact one by `Σ (v·e_w/s + w·e_v/255 + e_v·e_w/(255·s))`, so
//! `|Δ| ≤ Σ|w|·½/255 + Σv·½/s + n·¼/(255·s)` with `Σv ≤ nk·√bl` for blocks of L2 norm ≤ 1
//! ([`ScoreWeightsI8::error_bound`]: 1.53 for OpenCV's people detector, `s` = 294.7). The bound is
//! loose because the rounding errors have both signs and mostly cancel: measured with OpenCV's
//! weights on the 1080p bench frame (262 135 windows, scores −9…0) max |Δ| 0.038, p99 0.021, mean
//! 0.0065; on kodim01 max 0.032, mean 0.0066 (test).
//!
//! **Against OpenCV.** OpenCV has no 8-bit HOG scoring: the 8-bit scores are OpenCV's within the
//! error above, so windows within ≈0.04 of the hit threshold may flip. The OpenCV parity tests
//! and the golden detection hashes use the f32 path, which is unchanged.
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
//! // The 8-bit path: the same windows within the error bound.
//! use mosaicd::detect::score::{window_scores_i8, ScoreWeightsI8};
//! let sq = ScoreWeightsI8::new(&sw).unwrap();
//! let mut q = vec![0.0; 3 * 3];
//! window_scores_i8(&sq, &grid, Exec::Serial, &mut q);
//! assert!(q.iter().zip(&scores).all(|(a, b)| (a - b).abs() <= sq.error_bound()));
//! assert_eq!(q[1 * 3 + 2], sq.score_descriptor(&d));
//! ```

use std::ops::AddAssign;
use std::str::FromStr;

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

/// Arithmetic of the SVM stage ([`crate::detect::DetectorOptions::svm`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum ScorePrecision {
    /// f32 products (fused multiply-adds) and window sums: OpenCV's scores within ≈1e-6.
    #[default]
    F32,
    /// Block values as u8, weights as i8, exact i32 products (AVX-512 VNNI) and window sums; scores
    /// within [`ScoreWeightsI8::error_bound`] of the exact ones (module docs, "8-bit path").
    I8,
}

impl ScorePrecision {
    /// Every precision, in the order of [`Self::name`]'s list.
    pub const ALL: [Self; 2] = [Self::F32, Self::I8];

    /// The name used by the CLI (`--svm`) and the daemon config (`compute.svm`): `f32`, `i8`.
    pub fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::I8 => "i8",
        }
    }
}

impl std::fmt::Display for ScorePrecision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Errors of the scoring setup.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScoreError {
    /// A precision name that is not one of [`ScorePrecision::ALL`]'s.
    #[error("unknown SVM precision {0:?}: allowed f32, i8")]
    UnknownPrecision(String),
    /// A descriptor too long for exact i32 window sums on the 8-bit path.
    #[error("the 8-bit SVM path takes descriptors of at most {max} values (exact i32 sums), not {len}")]
    DescriptorTooLong {
        /// The model's descriptor length.
        len: usize,
        /// [`ScoreWeightsI8::MAX_DESCRIPTOR_LEN`].
        max: usize,
    },
}

impl FromStr for ScorePrecision {
    type Err = ScoreError;
    /// `f32` or `i8` (ASCII case ignored).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| ScoreError::UnknownPrecision(s.to_string()))
    }
}

/// Which block-product kernel runs (the instruction set; each [`ScorePrecision`] has its own
/// kernel for each).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProductKernel {
    /// Scalar: [`f32::mul_add`] chains, or plain i32 arithmetic (the references).
    Scalar,
    /// AVX2 + FMA, 8 blocks per vector (f32 only).
    Avx2,
    /// AVX-512F, 16 blocks per vector (f32); AVX-512 VNNI `vpdpbusd` (i8, with AVX-512F and BW).
    Avx512,
}

impl ProductKernel {
    /// The fastest f32 kernel this CPU runs.
    pub fn detect() -> Self {
        Self::detect_for(ScorePrecision::F32)
    }

    /// Every f32 kernel this CPU runs, slowest first (for tests that compare them).
    pub fn available() -> Vec<Self> {
        Self::available_for(ScorePrecision::F32)
    }

    /// The fastest kernel of precision `p` this CPU runs.
    pub fn detect_for(p: ScorePrecision) -> Self {
        *Self::available_for(p).last().unwrap_or(&Self::Scalar)
    }

    /// Every kernel of precision `p` this CPU runs, slowest first.
    pub fn available_for(p: ScorePrecision) -> Vec<Self> {
        #[allow(unused_mut)]
        let mut v = vec![Self::Scalar];
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            match p {
                ScorePrecision::F32 => {
                    if has!("avx2") && has!("fma") {
                        v.push(Self::Avx2);
                    }
                    if has!("avx512f") {
                        v.push(Self::Avx512);
                    }
                }
                ScorePrecision::I8 => {
                    if has!("avx512f") && has!("avx512bw") && has!("avx512vnni") {
                        v.push(Self::Avx512);
                    }
                }
            }
        }
        v
    }

    /// This kernel if the CPU runs it for `p`, else the scalar one.
    fn or_scalar(self, p: ScorePrecision) -> Self {
        if Self::available_for(p).contains(&self) {
            self
        } else {
            Self::Scalar
        }
    }
}

/// Scale of block values on the 8-bit path: `q = round(v·255)` (L2-Hys values lie in [0, 1]).
pub const BLOCK_QUANT_SCALE: f32 = 255.0;
/// Largest quantised weight magnitude: `q = round(w·s)`, `s = 127 / max|w|`.
pub const WEIGHT_QUANT_MAX: f32 = 127.0;
/// Adding then subtracting 2^23 rounds a non-negative f32 below 2^23 to an integer, ties to even
/// (the default rounding mode, as `cvtps2dq`): plain arithmetic that vectorises, where
/// [`f32::round`] is a libm call on baseline x86-64.
const ROUND_MAGIC: f32 = 8_388_608.0;

/// One block value on the 8-bit path: `round(v·255)` clamped to `0..=255` (ties to even; NaN → 0).
#[inline]
pub fn quantise_block_value(v: f32) -> u8 {
    let x = (v * BLOCK_QUANT_SCALE).clamp(0.0, BLOCK_QUANT_SCALE);
    ((x + ROUND_MAGIC) - ROUND_MAGIC) as u8
}

/// The model quantised for the 8-bit path ([`ScorePrecision::I8`]): `wq[g·nkp + k]` packs the i8
/// weights of values `4g..4g+4` of block position `k` into one dword (little-endian, zero past
/// the block length), the layout `vpdpbusd` broadcasts.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreWeightsI8 {
    wq: Vec<u32>,
    bias: f32,
    /// `s = 127 / max|w|` (1 for an all-zero model).
    weight_scale: f32,
    /// `1 / (255·s)`: one unit of an i32 window sum in score units.
    unit: f32,
    /// Worst-case |score − exact score| (see [`Self::error_bound`]).
    error_bound: f32,
    /// Block length (36) and its dwords (`⌈bl/4⌉`).
    bl: usize,
    ng: usize,
    bw: usize,
    bh: usize,
    nk: usize,
    nkp: usize,
}

impl ScoreWeightsI8 {
    /// Longest descriptor whose window sums cannot overflow i32: `255 · 127 · n ≤ 2^31 − 1`
    /// (66 311; OpenCV's people detector has 3 780).
    pub const MAX_DESCRIPTOR_LEN: usize = i32::MAX as usize / (255 * 127);

    /// Quantise `w` (once per model): `q = round(w·s)`, `s = 127 / max|w|`; the bias stays f32.
    pub fn new(w: &ScoreWeights) -> Result<Self, ScoreError> {
        let (bl, nk, nkp) = (w.bl, w.nk, w.nkp);
        if nk * bl > Self::MAX_DESCRIPTOR_LEN {
            return Err(ScoreError::DescriptorTooLong {
                len: nk * bl,
                max: Self::MAX_DESCRIPTOR_LEN,
            });
        }
        let ng = bl.div_ceil(4);
        let weight = |i: usize, k: usize| w.wt[i * nkp + k];
        let all = || (0..nk).flat_map(move |k| (0..bl).map(move |i| weight(i, k)));
        let max = all().fold(0.0f32, |m, v| m.max(v.abs()));
        // An all-zero model scores its bias: any scale gives zero weights.
        let s = if max > 0.0 {
            WEIGHT_QUANT_MAX as f64 / max as f64
        } else {
            1.0
        };
        let q = |v: f32| (v as f64 * s).round().clamp(-127.0, 127.0) as i8;
        let mut wq = vec![0u32; ng * nkp];
        for k in 0..nk {
            for g in 0..ng {
                let b: [u8; 4] = std::array::from_fn(|t| {
                    if 4 * g + t < bl {
                        q(weight(4 * g + t, k)) as u8
                    } else {
                        0
                    }
                });
                wq[g * nkp + k] = u32::from_le_bytes(b);
            }
        }
        // |Δ| ≤ Σ|w|·½/255 (values) + Σv·½/s (weights) + n·¼/(255·s) (both), with Σv ≤ nk·√bl
        // for blocks of L2 norm ≤ 1.
        let abs_sum: f64 = all().map(|v| v.abs() as f64).sum();
        let sum_v = nk as f64 * (bl as f64).sqrt();
        let qb = BLOCK_QUANT_SCALE as f64;
        let bound = abs_sum * 0.5 / qb + sum_v * 0.5 / s + (nk * bl) as f64 * 0.25 / (qb * s);
        Ok(Self {
            wq,
            bias: w.bias,
            weight_scale: s as f32,
            unit: (1.0 / (qb * s)) as f32,
            error_bound: bound as f32,
            bl,
            ng,
            bw: w.bw,
            bh: w.bh,
            nk,
            nkp,
        })
    }

    /// The weight scale `s = 127 / max|w|`.
    pub fn weight_scale(&self) -> f32 {
        self.weight_scale
    }

    /// Worst-case difference between an 8-bit score and the exact score of the same blocks, for
    /// blocks of L2 norm ≤ 1 with values in [0, 1] (L2-Hys): `Σ|w|·½/255 + nk·√bl·½/s +
    /// n·¼/(255·s)` (the f32 conversion of the sum adds ≤ 1e-5 for realistic sums).
    pub fn error_bound(&self) -> f32 {
        self.error_bound
    }

    /// The quantised weight of value `i` of block position `k`.
    fn weight(&self, i: usize, k: usize) -> i8 {
        self.wq[(i / 4) * self.nkp + k].to_le_bytes()[i % 4] as i8
    }

    /// An exact i32 window sum to a score: `bias + sum·(1/(255·s))`, the same in every kernel.
    #[inline]
    fn score_from_sum(&self, sum: i32) -> f32 {
        self.bias + sum as f32 * self.unit
    }

    /// The 8-bit score of one window descriptor in OpenCV order (`spec.descriptor_len()` values):
    /// the same bits as [`window_scores_i8`] gives the window these blocks come from.
    pub fn score_descriptor(&self, d: &[f32]) -> f32 {
        let mut sum = 0i32;
        for k in 0..self.nk {
            for i in 0..self.bl {
                let v = d.get(k * self.bl + i).copied().unwrap_or(0.0);
                sum += quantise_block_value(v) as i32 * self.weight(i, k) as i32;
            }
        }
        self.score_from_sum(sum)
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
    let kernel = kernel.or_scalar(ScorePrecision::F32);
    scores_by_strips(&F32Rows { w, kernel }, grid, exec, scores)
}

/// [`window_scores`] on the 8-bit path ([`ScorePrecision::I8`], see the module docs), with the
/// fastest kernel of this CPU for it (the scalar one without AVX-512 VNNI).
pub fn window_scores_i8(w: &ScoreWeightsI8, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
    window_scores_i8_with(
        w,
        grid,
        exec,
        ProductKernel::detect_for(ScorePrecision::I8),
        scores,
    )
}

/// [`window_scores_i8`] with a chosen kernel (one of `ProductKernel::available_for(I8)`; an
/// unavailable one falls back to the scalar kernel). Every kernel gives the same bits.
pub fn window_scores_i8_with(
    w: &ScoreWeightsI8,
    grid: &BlockGrid,
    exec: Exec,
    kernel: ProductKernel,
    scores: &mut [f32],
) {
    let kernel = kernel.or_scalar(ScorePrecision::I8);
    scores_by_strips(&I8Rows { w, kernel }, grid, exec, scores)
}

/// One precision's block-row products and final scores, for the strip driver [`scores_by_strips`].
trait RowProducts: Sync {
    /// Element of the products and window sums (f32, or exact i32).
    type Acc: Copy + Default + AddAssign + Send;
    /// Per-strip buffers of the transposed block row.
    type Scratch;
    /// Block length, blocks per window (x, y), block positions per window.
    fn dims(&self) -> (usize, usize, usize, usize);
    /// What a window sum starts from.
    fn start(&self) -> Self::Acc;
    /// Fresh (zeroed) buffers for a grid `nbxp` columns wide.
    fn scratch(&self, nbxp: usize) -> Self::Scratch;
    /// `out[k·nbxp + x]` = product of block `x < nbx` of `row` with the weights of position `k`.
    fn products(&self, row: &[f32], nbx: usize, nbxp: usize, s: &mut Self::Scratch, out: &mut [Self::Acc]);
    /// Window sums to scores.
    fn finish(&self, sums: &[Self::Acc], scores: &mut [f32]);
}

/// The f32 path: transposed block rows, f32 products, window sums from the bias.
struct F32Rows<'a> {
    w: &'a ScoreWeights,
    kernel: ProductKernel,
}

impl RowProducts for F32Rows<'_> {
    type Acc = f32;
    type Scratch = Vec<f32>;
    fn dims(&self) -> (usize, usize, usize, usize) {
        (self.w.bl, self.w.bw, self.w.bh, self.w.nk)
    }
    fn start(&self) -> f32 {
        self.w.bias
    }
    fn scratch(&self, nbxp: usize) -> Vec<f32> {
        vec![0.0; self.w.bl * nbxp]
    }
    fn products(&self, row: &[f32], nbx: usize, nbxp: usize, bt: &mut Vec<f32>, out: &mut [f32]) {
        transpose_row(row, self.w.bl, nbx, nbxp, bt);
        block_products(self.w, bt, nbx, nbxp, self.kernel, out);
    }
    fn finish(&self, sums: &[f32], scores: &mut [f32]) {
        scores.copy_from_slice(sums);
    }
}

/// The 8-bit path: quantised, dword-transposed block rows, exact i32 products and window sums.
struct I8Rows<'a> {
    w: &'a ScoreWeightsI8,
    kernel: ProductKernel,
}

impl RowProducts for I8Rows<'_> {
    type Acc = i32;
    /// The quantised row (`4·ng` bytes per block) and its dword transpose.
    type Scratch = (Vec<u8>, Vec<u32>);
    fn dims(&self) -> (usize, usize, usize, usize) {
        (self.w.bl, self.w.bw, self.w.bh, self.w.nk)
    }
    fn start(&self) -> i32 {
        0
    }
    fn scratch(&self, nbxp: usize) -> (Vec<u8>, Vec<u32>) {
        (vec![0; 4 * self.w.ng * nbxp], vec![0; self.w.ng * nbxp])
    }
    fn products(&self, row: &[f32], nbx: usize, nbxp: usize, s: &mut (Vec<u8>, Vec<u32>), out: &mut [i32]) {
        let (q, btq) = s;
        quantise_row(row, self.w.bl, nbx, nbxp, self.kernel, q, btq);
        quant_products(self.w, btq, nbx, nbxp, self.kernel, out);
    }
    fn finish(&self, sums: &[i32], scores: &mut [f32]) {
        for (s, &v) in scores.iter_mut().zip(sums) {
            *s = self.w.score_from_sum(v);
        }
    }
}

/// Window scores of `grid` with one precision's products (see [`window_scores_with`]).
fn scores_by_strips<R: RowProducts>(r: &R, grid: &BlockGrid, exec: Exec, scores: &mut [f32]) {
    let (bl, bw, bh, nk) = r.dims();
    let (nbx, nby) = (grid.blocks_x(), grid.blocks_y());
    if nbx < bw || nby < bh || grid.block_len() != bl {
        return;
    }
    let (nwx, nwy) = (nbx + 1 - bw, nby + 1 - bh);
    // Columns padded with zero blocks to whole vectors of the widest kernel.
    let nbxp = nbx.div_ceil(PAD_COLUMNS) * PAD_COLUMNS;
    // A strip of window rows walks the block rows it needs in ascending order, computes each row's
    // products once into a small buffer and adds them to the window rows they belong to. Parallel
    // strips recompute the bh − 1 block rows they share (≈10 % at 1080p) instead of holding every
    // row's products (13 MB at 1080p); serially the whole grid is one strip. A window's sum has
    // the same order in any split (block rows ascending, then block columns), so the same bits
    // (on the 8-bit path the sums are integers: any order gives the same bits).
    let strip_work = |(s, chunk): (usize, &mut [f32])| {
        let first = s * SCORE_STRIP_ROWS;
        let rows = chunk.len() / nwx;
        let mut scratch = r.scratch(nbxp);
        let mut pr = vec![R::Acc::default(); nk * nbxp];
        let mut sums = vec![r.start(); chunk.len()];
        for row_index in first..first + rows + bh - 1 {
            r.products(grid.block_row(row_index), nbx, nbxp, &mut scratch, &mut pr);
            // Window row wy = row_index − by gets block row `by` of its window from this block row.
            for by in 0..bh {
                let Some(wy) = row_index.checked_sub(by) else {
                    break;
                };
                if wy < first || wy >= first + rows {
                    continue;
                }
                let row = &mut sums[(wy - first) * nwx..][..nwx];
                for bx in 0..bw {
                    let src = &pr[(bx * bh + by) * nbxp + bx..][..nwx];
                    for (v, &p) in row.iter_mut().zip(src) {
                        *v += p;
                    }
                }
            }
        }
        r.finish(&sums, chunk);
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

/// Quantise block row `row` (`nbx` blocks of `bl` values) on the 8-bit path: `q[x·4ng + i]` =
/// [`quantise_block_value`] of value `i` of block `x` (zero for `bl ≤ i < 4ng`), then the dword
/// transpose `btq[g·nbxp + x]` = bytes `4g..4g+4` of block `x` (padding columns stay zero). With
/// the AVX-512 kernel (and `bl` a multiple of 4, as every HOG block) the same bytes come from
/// AVX-512 code.
fn quantise_row(
    row: &[f32],
    bl: usize,
    nbx: usize,
    nbxp: usize,
    kernel: ProductKernel,
    q: &mut [u8],
    btq: &mut [u32],
) {
    let ng = bl.div_ceil(4);
    debug_assert!(row.len() >= nbx * bl && q.len() >= nbx * 4 * ng && btq.len() >= ng * nbxp);
    debug_assert!(nbxp.is_multiple_of(PAD_COLUMNS) && nbx <= nbxp);
    #[cfg(target_arch = "x86_64")]
    if kernel == ProductKernel::Avx512 && bl == 4 * ng {
        // SAFETY: the AVX-512 kernel of the 8-bit path is only chosen when the CPU has AVX-512F
        // and BW (`ProductKernel::available_for(I8)`); lengths as asserted above.
        return unsafe { quantise_row_avx512(row, ng, nbx, nbxp, q, btq) };
    }
    let _ = kernel;
    if bl == 4 * ng {
        // Every block length of a HOG spec (4·nbins): one contiguous pass.
        for (d, &v) in q[..nbx * bl].iter_mut().zip(&row[..nbx * bl]) {
            *d = quantise_block_value(v);
        }
    } else {
        for (dst, blk) in q.chunks_exact_mut(4 * ng).zip(row.chunks_exact(bl)).take(nbx) {
            for (d, &v) in dst.iter_mut().zip(blk) {
                *d = quantise_block_value(v);
            }
            dst[bl..].fill(0);
        }
    }
    for (x, blk) in q.chunks_exact(4 * ng).take(nbx).enumerate() {
        for (g, b) in blk.chunks_exact(4).enumerate() {
            btq[g * nbxp + x] = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
    }
}

/// [`quantise_row`] for blocks of `4·ng` values with AVX-512: 16 values at a time
/// (`vcvtps2dq` rounds to nearest even like [`quantise_block_value`]; `max(m, 0)` turns NaN
/// into 0 as its clamp-then-cast does), then the dword transpose by 16-lane gathers.
///
/// # Safety
/// The CPU must support AVX-512F and BW; lengths as in [`quantise_row`] with `bl = 4·ng`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw")]
unsafe fn quantise_row_avx512(
    row: &[f32],
    ng: usize,
    nbx: usize,
    nbxp: usize,
    q: &mut [u8],
    btq: &mut [u32],
) {
    use std::arch::x86_64::*;
    const L: usize = 16;
    let n = nbx * 4 * ng;
    debug_assert!(row.len() >= n && q.len() >= n && btq.len() >= ng * nbxp);
    let scale = _mm512_set1_ps(BLOCK_QUANT_SCALE);
    let zero = _mm512_setzero_ps();
    for i in (0..n).step_by(L) {
        // The last chunk of a row may be partial (n is a multiple of 4, not of 16).
        let mask: __mmask16 = if i + L <= n { !0 } else { (1 << (n - i)) - 1 };
        // SAFETY: the mask keeps the load inside row[..n] and the store inside q[..n].
        let v = unsafe { _mm512_maskz_loadu_ps(mask, row.as_ptr().add(i)) };
        let m = _mm512_min_ps(_mm512_max_ps(_mm512_mul_ps(v, scale), zero), scale);
        let d = _mm512_cvtps_epi32(m);
        unsafe { _mm512_mask_cvtusepi32_storeu_epi8(q.as_mut_ptr().add(i).cast(), mask, d) };
    }
    let step = _mm512_set1_epi32(ng as i32);
    let lanes = _mm512_mullo_epi32(
        _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
        step,
    );
    for x in (0..nbx).step_by(L) {
        let mask: __mmask16 = if x + L <= nbx { !0 } else { (1 << (nbx - x)) - 1 };
        // SAFETY: lane j reads dword (x + j)·ng + g of q (inside q[..n] for x + j < nbx, masked
        // otherwise); the store of 16 dwords ends at g·nbxp + x + 16 ≤ ng·nbxp (x + 16 ≤ nbxp),
        // writing zeros in padding columns.
        let base = unsafe { q.as_ptr().add(x * 4 * ng) };
        for g in 0..ng {
            let idx = _mm512_add_epi32(lanes, _mm512_set1_epi32(g as i32));
            let v =
                unsafe { _mm512_mask_i32gather_epi32::<4>(_mm512_setzero_si512(), mask, idx, base.cast()) };
            unsafe { _mm512_storeu_si512(btq.as_mut_ptr().add(g * nbxp + x).cast(), v) };
        }
    }
}

/// `out[k·nbxp + x] = Σ_i q_b[i][x] · q_w[i][k]` for `k < nk`, `x < nbx` (the VNNI kernel also
/// fills padding columns), exact in i32.
fn quant_products(
    w: &ScoreWeightsI8,
    btq: &[u32],
    nbx: usize,
    nbxp: usize,
    kernel: ProductKernel,
    out: &mut [i32],
) {
    debug_assert!(nbxp.is_multiple_of(PAD_COLUMNS) && nbx <= nbxp);
    debug_assert!(btq.len() >= w.ng * nbxp && out.len() >= w.nk * nbxp && w.wq.len() >= w.ng * w.nkp);
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `kernel` is one of `ProductKernel::available_for(I8)` (checked by the caller), so
        // the CPU has AVX-512F, BW and VNNI; loads and stores stay within the lengths asserted
        // above. Measured: see docs/detection.md "8-bit SVM".
        ProductKernel::Avx512 => unsafe { quant_products_vnni(w, btq, nbxp, out) },
        _ => quant_products_scalar(w, btq, nbx, nbxp, out),
    }
}

/// The scalar reference of the 8-bit path: plain i32 arithmetic.
fn quant_products_scalar(w: &ScoreWeightsI8, btq: &[u32], nbx: usize, nbxp: usize, out: &mut [i32]) {
    for k in 0..w.nk {
        for x in 0..nbx {
            let mut acc = 0i32;
            for g in 0..w.ng {
                let b = btq[g * nbxp + x].to_le_bytes();
                let q = w.wq[g * w.nkp + k].to_le_bytes();
                for t in 0..4 {
                    acc += b[t] as i32 * q[t] as i8 as i32;
                }
            }
            out[k * nbxp + x] = acc;
        }
    }
}

/// AVX-512 VNNI products over all `nbxp` (a multiple of 16) columns: per dword group `g`, one
/// `vpdpbusd` per block position adds the four u8·i8 products of 16 blocks at once.
///
/// # Safety
/// The CPU must support AVX-512F, AVX-512BW and AVX-512 VNNI; lengths as in [`quant_products`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
unsafe fn quant_products_vnni(w: &ScoreWeightsI8, btq: &[u32], nbx: usize, out: &mut [i32]) {
    use std::arch::x86_64::*;
    const L: usize = 16;
    debug_assert!(nbx.is_multiple_of(L));
    let (ng, nk, nkp) = (w.ng, w.nk, w.nkp);
    debug_assert!(nk.div_ceil(TILE_K_AVX512) * TILE_K_AVX512 <= nkp);
    for x in (0..nbx).step_by(L) {
        for k0 in (0..nk).step_by(TILE_K_AVX512) {
            let mut acc = [_mm512_setzero_si512(); TILE_K_AVX512];
            for g in 0..ng {
                debug_assert!(g * nbx + x + L <= btq.len() && g * nkp + k0 + TILE_K_AVX512 <= w.wq.len());
                // SAFETY: x + 16 ≤ nbx and g < ng: inside btq (ng·nbx); k0 + TILE ≤ nkp: inside wq.
                let b = unsafe { _mm512_loadu_si512(btq.as_ptr().add(g * nbx + x).cast()) };
                let wr = unsafe { w.wq.as_ptr().add(g * nkp + k0) };
                for (j, a) in acc.iter_mut().enumerate() {
                    let wv = _mm512_set1_epi32(unsafe { *wr.add(j) } as i32);
                    *a = _mm512_dpbusd_epi32(*a, b, wv);
                }
            }
            for (j, a) in acc.iter().enumerate() {
                let k = k0 + j;
                if k < nk {
                    debug_assert!(k * nbx + x + L <= out.len());
                    // SAFETY: k < nk and x + 16 ≤ nbx, inside out (nk·nbx).
                    unsafe { _mm512_storeu_si512(out.as_mut_ptr().add(k * nbx + x).cast(), *a) };
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

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|v| v.to_bits()).collect()
    }

    #[test]
    fn every_i8_kernel_is_bit_identical_to_the_scalar_reference() {
        // 700 px high: two parallel strips; 300 px wide: 36 blocks padded to 48 columns.
        let (spec, grid, wts) = setup(300, 700);
        let sw = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &wts, 0.25)).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let mut want = vec![0.0f32; nwx * nwy];
        window_scores_i8_with(&sw, &grid, Exec::Serial, ProductKernel::Scalar, &mut want);
        assert!(want.iter().any(|&v| v != 0.25), "the weights must matter");
        let kernels = ProductKernel::available_for(ScorePrecision::I8);
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512vnni")
            && std::arch::is_x86_feature_detected!("avx512bw")
        {
            assert!(kernels.contains(&ProductKernel::Avx512));
        }
        for k in kernels {
            for exec in [Exec::Serial, Exec::Parallel] {
                let mut got = vec![0.0f32; nwx * nwy];
                window_scores_i8_with(&sw, &grid, exec, k, &mut got);
                assert_eq!(bits(&got), bits(&want), "{k:?} {exec:?}");
            }
        }
    }

    #[test]
    fn i8_scores_equal_the_quantised_descriptor_scores() {
        let (spec, grid, wts) = setup(100, 300);
        let sw = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &wts, -0.75)).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let mut got = vec![0.0f32; nwx * nwy];
        window_scores_i8(&sw, &grid, Exec::Parallel, &mut got);
        for wy in 0..nwy {
            for wx in 0..nwx {
                let d = grid.window_descriptor(&spec, wx, wy).unwrap();
                assert_eq!(
                    got[wy * nwx + wx].to_bits(),
                    sw.score_descriptor(&d).to_bits(),
                    "{wx},{wy}"
                );
            }
        }
    }

    #[test]
    fn i8_scores_stay_within_the_bound_of_f32_with_opencv_weights_on_kodak() {
        use crate::detect::model::{Domain, LinearModel};
        let model = LinearModel::load(
            &crate::data::require("opencv_hog/default_people_detector_64x128.npy"),
            Domain::Colour,
        )
        .unwrap();
        let spec = model.hog_spec("test").unwrap();
        let img = crate::raw::load::load_rgb8(&crate::data::require("kodak/kodim01.png")).unwrap();
        let mut grid = BlockGrid::empty();
        block_grid(&spec, &HogInput::Rgb8(img.view()), Exec::Parallel, &mut grid).unwrap();
        let sw = ScoreWeights::new(&spec, &model.weights, model.bias);
        let sq = ScoreWeightsI8::new(&sw).unwrap();
        let (nwx, nwy) = grid.windows(&spec);
        let (mut f, mut q) = (vec![0.0f32; nwx * nwy], vec![0.0f32; nwx * nwy]);
        window_scores(&sw, &grid, Exec::Parallel, &mut f);
        window_scores_i8(&sq, &grid, Exec::Parallel, &mut q);
        let d: Vec<f32> = f.iter().zip(&q).map(|(a, b)| (a - b).abs()).collect();
        let max = d.iter().fold(0.0f32, |m, &v| m.max(v));
        let mean = d.iter().sum::<f32>() / d.len() as f32;
        // The proven worst case (≈1.5 for these weights: loose, the sum of block values is bounded by 105·√36), plus the f32 path's own rounding.
        assert!(
            max <= sq.error_bound() + 1e-4,
            "max |Δ| {max} > bound {}",
            sq.error_bound()
        );
        // Measured: max 0.032, mean 0.0066 (rounding errors mostly cancel; the 1080p bench frame
        // gives 0.038 / 0.0065); a wrong scale or layout gives errors of the order of the scores.
        eprintln!("kodim01: {} windows, max |Δ| {max}, mean {mean}", d.len());
        assert!(max < 0.05 && mean < 0.01, "max {max} mean {mean}");
    }

    #[test]
    fn quantisation_edge_cases() {
        assert_eq!(quantise_block_value(0.0), 0);
        assert_eq!(quantise_block_value(1.0), 255);
        assert_eq!(quantise_block_value(-0.25), 0);
        assert_eq!(quantise_block_value(1.5), 255);
        assert_eq!(quantise_block_value(f32::NAN), 0);
        assert_eq!(quantise_block_value(1.0 / 255.0), 1);
        assert_eq!(quantise_block_value(0.4 / 255.0), 0);
        assert_eq!(quantise_block_value(0.6 / 255.0), 1);
        // 127.5 and 128.5: ties to even.
        assert_eq!(quantise_block_value(0.5), 128);
        assert_eq!(quantise_block_value(128.5 / 255.0), 128);
        let spec = HogSpec::new(&HogOptions::default()).unwrap();
        // All-zero weights: every window scores the bias.
        let zero = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &[], 1.5)).unwrap();
        assert_eq!(zero.weight_scale(), 1.0);
        let (_, grid, _) = setup(80, 144);
        let mut s = vec![0.0f32; 9];
        window_scores_i8(&zero, &grid, Exec::Serial, &mut s);
        assert_eq!(s, vec![1.5; 9]);
        // The largest weight maps to ±127 (s = 127 / (127/128) = 128), half steps round away
        // from zero.
        let mut w = vec![0.0f32; spec.descriptor_len()];
        (w[0], w[1], w[2], w[37]) = (-127.0 / 128.0, 0.25, -0.5 / 128.0, 1.5 / 128.0);
        let q = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &w, 0.0)).unwrap();
        assert_eq!(q.weight_scale(), 128.0);
        assert_eq!(
            [q.weight(0, 0), q.weight(1, 0), q.weight(2, 0), q.weight(1, 1)],
            [-127, 32, -1, 2]
        );
        // One block of ones against those weights: (−127 + 32 − 1)·255 / (255·128).
        let mut d = vec![0.0f32; spec.descriptor_len()];
        d[..36].fill(1.0);
        assert!((q.score_descriptor(&d) + 0.75).abs() < 1e-6);
    }

    #[test]
    fn every_quantiser_gives_the_scalar_bytes_at_the_edges() {
        // 21 blocks of 36 values (756: a partial last vector and a partial gather of 5 blocks),
        // with ties, out-of-range values and NaN.
        let special = [
            0.0,
            1.0,
            -0.0,
            -1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            0.5,
            128.5 / 255.0,
            1e-9,
        ];
        let row: Vec<f32> = (0..21 * 36)
            .map(|i| special.get(i % 97).copied().unwrap_or((i as f32 * 0.618).fract()))
            .collect();
        let run = |k| {
            let (mut q, mut btq) = (vec![0u8; 21 * 36], vec![1u32; 9 * 32]);
            quantise_row(&row, 36, 21, 32, k, &mut q, &mut btq);
            (q, btq)
        };
        let want = run(ProductKernel::Scalar);
        assert_eq!(want.0[..10], [0, 255, 0, 0, 255, 0, 255, 128, 128, 0]);
        for k in ProductKernel::available_for(ScorePrecision::I8) {
            let got = run(k);
            assert_eq!(got.0, want.0, "{k:?}");
            for g in 0..9 {
                assert_eq!(got.1[g * 32..][..21], want.1[g * 32..][..21], "{k:?} dword {g}");
            }
        }
    }

    #[test]
    fn block_lengths_off_a_multiple_of_four_are_zero_padded() {
        // Two blocks of 6 values → 2 dwords each; 16 padded columns.
        let row = [1.0, 0.0, 0.5, 1.0, 0.2, 0.4, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0];
        let (mut q, mut btq) = (vec![9u8; 2 * 8], vec![7u32; 2 * 16]);
        quantise_row(&row, 6, 2, 16, ProductKernel::Scalar, &mut q, &mut btq);
        assert_eq!(btq[0], u32::from_le_bytes([255, 0, 128, 255]));
        assert_eq!(btq[16], u32::from_le_bytes([51, 102, 0, 0]));
        assert_eq!(btq[1], u32::from_le_bytes([0, 255, 255, 0]));
        assert_eq!(btq[17], u32::from_le_bytes([255, 255, 0, 0]));
        assert_eq!(btq[2], 7, "columns past nbx are not written");
    }

    #[test]
    fn precisions_parse_by_name_and_long_descriptors_are_refused() {
        for p in ScorePrecision::ALL {
            assert_eq!(p.to_string().parse::<ScorePrecision>().unwrap(), p);
        }
        assert_eq!("I8".parse::<ScorePrecision>().unwrap(), ScorePrecision::I8);
        assert_eq!(ScorePrecision::default(), ScorePrecision::F32);
        let e = "f16".parse::<ScorePrecision>().unwrap_err().to_string();
        assert!(e.contains("f16") && e.contains("f32, i8"), "{e}");
        // 255 bins: 7·15 blocks of 1020 values overflow i32 window sums.
        let spec = HogSpec::new(&HogOptions {
            nbins: 255,
            ..HogOptions::default()
        })
        .unwrap();
        let e = ScoreWeightsI8::new(&ScoreWeights::new(&spec, &[1.0], 0.0)).unwrap_err();
        assert_eq!(
            e,
            ScoreError::DescriptorTooLong {
                len: 107_100,
                max: 66_311
            }
        );
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
