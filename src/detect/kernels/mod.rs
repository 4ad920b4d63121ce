//! Per-instruction-set kernels of the detector's SVM stage ([`super::score`]) and pyramid resize
//! ([`super::pyramid`]): every intrinsic of those two modules lives here, one file per ISA.
//!
//! The algorithm files choose a kernel from [`crate::kernels::isa`] (and, inside a path, the
//! sub-features of [`crate::kernels::features`]), check every length a kernel relies on once
//! per call, and keep the scalar reference each kernel is tested against. The kernels here only
//! compute; their `# Safety` sections name the CPU features and the lengths their callers check.
//!
//! | kernel | scalar (oracle) | AVX2 (+FMA) | AVX-512 | NEON |
//! |---|---|---|---|---|
//! | f32 block products | `mul_add` chain | 8 lanes, 12-position tiles | 16 lanes, 21-position tiles | 2×4 lanes, `fmla` by lane, 12-position tiles |
//! | 8-bit block products | i32 arithmetic | `vpmaddwd` on u16 pairs, or `vpdpbusd` ymm (AVX-VNNI) | `vpdpbusd` zmm (AVX-512 VNNI) | `sdot` (dotprod), else `smull`/`sadalp` |
//! | 8-bit quantiser | `round(255·v)` | 8 lanes | 16 lanes + gathers | 4 lanes |
//! | pyramid rows | plain loops | the loops compiled for AVX2 | `vpermt2ps` taps | vertical pass 4 lanes |

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

/// Prefetch every cache line of `row` into L2 (no effect on results; nothing on other targets).
pub(crate) fn prefetch_row(row: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    for k in (0..row.len()).step_by(16) {
        // SAFETY: prefetching an address inside a live slice has no side effects (SSE, part of
        // the x86-64 baseline).
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T1 }>(row.as_ptr().add(k).cast())
        };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = row;
}
