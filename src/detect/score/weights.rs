//! The model's weights laid out for the block-row products: [`ScoreWeights`] (f32) and [`ScoreWeightsI8`] (the 8-bit path's quantised weights), and the errors of the scoring setup ([`super`] for the math).

use crate::detect::kernels::{quantise_block_value, BLOCK_QUANT_SCALE, TILE_K_AVX512, TILE_K_NARROW};
use crate::features::hog::HogSpec;

/// The model re-laid out for the GEMM: `wt[i·nkp + k]` = weight of value `i` of block position `k`,
/// zero-padded to `nkp` positions (whole tiles for every kernel, plus one: see `gemm_sizes`).
/// Positions are numbered row by row, `k = by·bw + bx` (OpenCV's descriptor runs column by
/// column, `bx·bh + by`), so the positions one block row needs form one range (`Stream::push`).
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreWeights {
    pub(super) wt: Vec<f32>,
    pub(super) bias: f32,
    /// Block length (36).
    pub(super) bl: usize,
    /// Blocks per window (7, 15).
    pub(super) bw: usize,
    pub(super) bh: usize,
    /// Block positions per window (105) and its padded count.
    pub(super) nk: usize,
    pub(super) nkp: usize,
}

/// The position in OpenCV's descriptor order (`bx·bh + by`) of our block position `k = by·bw + bx`.
pub(super) fn descriptor_position(k: usize, bw: usize, bh: usize) -> usize {
    (k % bw) * bh + k / bw
}

/// `n` rounded up to a multiple of `m`, `None` on overflow.
pub(super) fn round_up(n: usize, m: usize) -> Option<usize> {
    n.div_ceil(m).checked_mul(m)
}

/// The weight matrix of a window of `bw x bh` blocks of `bl` values: block positions `nk`, their
/// count padded to whole tiles of every kernel plus one more tile, `nkp` (a kernel's last tile may
/// run past the positions it was asked for; its results are not stored, and a range of positions
/// `[k0, k1)` then still reads inside the matrix: `k0 + round_up(k1 − k0) ≤ nk + tile ≤ nkp`), and
/// the matrix length `bl·nkp`, in checked arithmetic.
pub(super) fn gemm_sizes(bw: usize, bh: usize, bl: usize) -> Result<(usize, usize, usize), ScoreError> {
    let refuse = || ScoreError::Geometry {
        blocks_x: bw,
        blocks_y: bh,
        block_len: bl,
    };
    let nk = bw.checked_mul(bh).ok_or_else(refuse)?;
    let nkp = round_up(nk, TILE_K_NARROW)
        .zip(round_up(nk, TILE_K_AVX512))
        .and_then(|(a, b)| a.max(b).checked_add(TILE_K_NARROW.max(TILE_K_AVX512)))
        .ok_or_else(refuse)?;
    let len = bl.checked_mul(nkp).ok_or_else(refuse)?;
    Ok((nk, nkp, len))
}

impl ScoreWeights {
    /// From a weight vector in OpenCV descriptor order (`spec.descriptor_len()` values; a shorter
    /// vector is zero-extended, a longer one cut) and the bias.
    ///
    /// The geometry comes from the model file: sizes whose products overflow, or whose weight
    /// matrix cannot be allocated, are refused ([`ScoreError::Geometry`]) before anything is
    /// indexed.
    pub fn new(spec: &HogSpec, weights: &[f32], bias: f32) -> Result<Self, ScoreError> {
        let (bw, bh) = spec.blocks_per_window();
        let bl = spec.block_len();
        let (nk, nkp, len) = gemm_sizes(bw, bh, bl)?;
        let mut wt = Vec::new();
        wt.try_reserve_exact(len).map_err(|_| ScoreError::Geometry {
            blocks_x: bw,
            blocks_y: bh,
            block_len: bl,
        })?;
        wt.resize(len, 0.0f32);
        for k in 0..nk {
            let m = descriptor_position(k, bw, bh);
            for i in 0..bl {
                // m·bl + i < nk·bl ≤ nkp·bl = len: no overflow.
                wt[i * nkp + k] = weights.get(m * bl + i).copied().unwrap_or(0.0);
            }
        }
        Ok(Self {
            wt,
            bias,
            bl,
            bw,
            bh,
            nk,
            nkp,
        })
    }
}

/// Errors of the scoring setup.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ScoreError {
    /// A precision setting that is not `f32`, `i8` or `auto`.
    #[error("unknown SVM precision {0:?}: allowed f32, i8, auto")]
    UnknownPrecision(String),
    /// A descriptor too long for exact i32 window sums on the 8-bit path.
    #[error("the 8-bit SVM path takes descriptors of at most {max} values (exact i32 sums), not {len}")]
    DescriptorTooLong {
        /// The model's descriptor length.
        len: usize,
        /// [`ScoreWeightsI8::MAX_DESCRIPTOR_LEN`].
        max: usize,
    },
    /// A window geometry whose weight matrix overflows `usize` or cannot be allocated.
    #[error("window geometry of {blocks_x}x{blocks_y} blocks of {block_len} values is too large for the SVM weights")]
    Geometry {
        /// Blocks per window across.
        blocks_x: usize,
        /// Blocks per window down.
        blocks_y: usize,
        /// Values per block.
        block_len: usize,
    },
}

/// Largest quantised weight magnitude: `q = round(w·s)`, `s = 127 / max|w|`.
pub(crate) const WEIGHT_QUANT_MAX: f32 = 127.0;

/// The model quantised for the 8-bit path ([`ScorePrecision::I8`](super::ScorePrecision::I8)): `wq[g·nkp + k]` packs the i8
/// weights of values `4g..4g+4` of block position `k` into one dword (little-endian, zero past
/// the block length), the layout `vpdpbusd` and `vpmaddubsw` broadcast, and `corr` the
/// per-position constant of the NEON kernels.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoreWeightsI8 {
    pub(super) wq: Vec<u32>,
    /// `corr[k] = 128·Σ_i q_w[i][k]`: what shifting the block values by −128 takes off a product.
    pub(super) corr: Vec<i32>,
    pub(super) bias: f32,
    /// `s = 127 / max|w|` (1 for an all-zero model).
    pub(super) weight_scale: f32,
    /// `1 / (180·s)`: one unit of an i32 window sum in score units.
    pub(super) unit: f32,
    /// Worst-case |score − exact score| (see [`Self::error_bound`]).
    pub(super) error_bound: f32,
    /// Block length (36) and its dwords (`⌈bl/4⌉`).
    pub(super) bl: usize,
    pub(super) ng: usize,
    pub(super) bw: usize,
    pub(super) bh: usize,
    pub(super) nk: usize,
    pub(super) nkp: usize,
}

impl ScoreWeightsI8 {
    /// Longest descriptor whose window sums cannot overflow i32: `180 · 127 · n ≤ 2^31 − 1`
    /// (93 940; OpenCV's people detector has 3 780).
    pub const MAX_DESCRIPTOR_LEN: usize = i32::MAX as usize / (BLOCK_QUANT_SCALE as usize * 127);

    /// Quantise `w` (once per model): `q = round(w·s)`, `s = 127 / max|w|`; the bias stays f32.
    pub fn new(w: &ScoreWeights) -> Result<Self, ScoreError> {
        let (bl, nk, nkp) = (w.bl, w.nk, w.nkp);
        // nk·bl ≤ nkp·bl = w.wt.len(): no overflow.
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
        let q = |i: usize, k: usize| {
            if i < bl {
                (weight(i, k) as f64 * s).round().clamp(-127.0, 127.0) as i8
            } else {
                0
            }
        };
        let (mut wq, mut corr) = (vec![0u32; ng * nkp], vec![0i32; nkp]);
        for k in 0..nk {
            for g in 0..ng {
                let b: [u8; 4] = std::array::from_fn(|t| q(4 * g + t, k) as u8);
                wq[g * nkp + k] = u32::from_le_bytes(b);
            }
            corr[k] = 128 * (0..bl).map(|i| q(i, k) as i32).sum::<i32>();
        }
        // |Δ| ≤ Σ|w|·½/180 (values) + Σv·½/s (weights) + n·¼/(180·s) (both), with Σv ≤ nk·√bl
        // for blocks of L2 norm ≤ 1.
        let abs_sum: f64 = all().map(|v| v.abs() as f64).sum();
        let sum_v = nk as f64 * (bl as f64).sqrt();
        let qb = BLOCK_QUANT_SCALE as f64;
        let bound = abs_sum * 0.5 / qb + sum_v * 0.5 / s + (nk * bl) as f64 * 0.25 / (qb * s);
        Ok(Self {
            wq,
            corr,
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
    /// blocks of L2 norm ≤ 1 with values in [0, 1] (L2-Hys): `Σ|w|·½/180 + nk·√bl·½/s +
    /// n·¼/(180·s)` (the f32 conversion of the sum adds ≤ 1e-5 for realistic sums).
    pub fn error_bound(&self) -> f32 {
        self.error_bound
    }

    /// The quantised weight of value `i` of block position `k`.
    pub(super) fn weight(&self, i: usize, k: usize) -> i8 {
        self.wq[(i / 4) * self.nkp + k].to_le_bytes()[i % 4] as i8
    }

    /// An exact i32 window sum to a score: `bias + sum·(1/(180·s))`, the same in every kernel.
    #[inline]
    pub(super) fn score_from_sum(&self, sum: i32) -> f32 {
        self.bias + sum as f32 * self.unit
    }

    /// The 8-bit score of one window descriptor in OpenCV order (`spec.descriptor_len()` values):
    /// the same bits as [`window_scores_i8`](super::window_scores_i8) gives the window these blocks come from.
    pub fn score_descriptor(&self, d: &[f32]) -> f32 {
        let mut sum = 0i32;
        for k in 0..self.nk {
            let m = descriptor_position(k, self.bw, self.bh);
            for i in 0..self.bl {
                let v = d.get(m * self.bl + i).copied().unwrap_or(0.0);
                sum += quantise_block_value(v) as i32 * self.weight(i, k) as i32;
            }
        }
        self.score_from_sum(sum)
    }
}
