//! Per-instruction-set kernels of the detector's SVM stage ([`super::score`]): every intrinsic of
//! that module lives here, one file per ISA, with the scalar pieces the kernels share with it (the
//! 8-bit quantiser, the window-sum row loops), so that nothing here imports from above. The
//! bilinear resize of the detectors' pyramids has its own kernels, [`crate::resize`].
//!
//! The algorithm files choose a kernel from [`crate::kernels::isa`] (and, inside a path, the
//! sub-features of [`crate::kernels::features`]), check every length a kernel relies on once
//! per call, and keep the scalar reference each kernel is tested against. The kernels here only
//! compute; their `# Safety` sections name the CPU features and the lengths their callers check.
//!
//! | kernel | scalar (oracle) | AVX2 (+FMA) | AVX-512 | NEON |
//! |---|---|---|---|---|
//! | f32 block products | `mul_add` chain | 8 lanes, 12-position tiles | 16 lanes, 21-position tiles | 2×4 lanes, `fmla` by lane, 12-position tiles |
//! | 8-bit block products | i32 arithmetic | `vpmaddubsw` + `vpmaddwd`, or `vpdpbusd` ymm (AVX-VNNI) | `vpdpbusd` zmm (AVX-512 VNNI) | `sdot` (dotprod), else `smull`/`sadalp` |
//! | 8-bit quantiser | `round(180·v)` | 8 lanes | 16 lanes + gathers | 4 lanes |
//! | SVM window sums | plain loops | the loops compiled for AVX2 | (AVX2's) | plain loops |

use std::ops::AddAssign;

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;
#[cfg(target_arch = "aarch64")]
pub(crate) mod neon;

/// Block positions (columns of the weight matrix) per register tile of the AVX2 and NEON
/// kernels: AVX2 keeps 12 accumulators + 1 block vector + 1 broadcast in its 16 ymm registers;
/// NEON 2 × 12 accumulators + 2 block vectors + 3 weight vectors in its 32.
pub(crate) const TILE_K_NARROW: usize = 12;
/// Block positions per register tile of the AVX-512 kernels (21 accumulators of 32 zmm;
/// 105 = 5·21).
pub(crate) const TILE_K_AVX512: usize = 21;

// The scalar pieces the per-ISA files share with the algorithm file (score.rs uses them too):
// kept here, below both, so the kernel files import nothing from above.

/// Scale of block values on the 8-bit path: `q = round(180·v)`. L2-Hys values lie in [0, 1] with
/// `‖v‖₂ ≤ 1`, so two values of a block quantise to a sum of at most 255: the bound that keeps
/// AVX2's saturating `vpmaddubsw` exact (`255·127 ≤ 32 767`; see `detect/kernels/avx2.rs`).
pub const BLOCK_QUANT_SCALE: f32 = 180.0;
/// Adding then subtracting 2^23 rounds a non-negative f32 below 2^23 to an integer, ties to even
/// (the default rounding mode, as `cvtps2dq`): plain arithmetic that vectorises, where
/// [`f32::round`] is a libm call on baseline x86-64.
const ROUND_MAGIC: f32 = 8_388_608.0;

/// One block value on the 8-bit path: `round(180·v)` clamped to `0..=180` (ties to even; NaN → 0).
#[inline]
pub fn quantise_block_value(v: f32) -> u8 {
    let x = (v * BLOCK_QUANT_SCALE).clamp(0.0, BLOCK_QUANT_SCALE);
    ((x + ROUND_MAGIC) - ROUND_MAGIC) as u8
}

/// `row[x] += pr[(by·bw + bx)·nbxp + bx + x]` for `bx = 0..bw` in that order and every `x`: the
/// block products of block row `by` of the windows of one window row (positions numbered row by
/// row, `crate::detect::score::ScoreWeights`; the same order for every element, so f32 sums have
/// the same bits whichever instruction set compiles it).
#[inline(always)]
pub(crate) fn add_window_row<T: Copy + AddAssign>(
    row: &mut [T],
    pr: &[T],
    by: usize,
    bw: usize,
    nbxp: usize,
) {
    for bx in 0..bw {
        let src = &pr[(by * bw + bx) * nbxp + bx..][..row.len()];
        for (v, &p) in row.iter_mut().zip(src) {
            *v += p;
        }
    }
}
