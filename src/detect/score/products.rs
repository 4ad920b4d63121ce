//! The block-row products per kernel: the f32 and 8-bit kernel choice for a path ([`I8Kernel`]), the transposes and quantisation of a block row, the length checks every kernel relies on, and the scalar references (the intrinsics are in `detect/kernels/`).

use std::ops::Range;

use super::weights::{round_up, ScoreWeights, ScoreWeightsI8};
use crate::detect::kernels::{quantise_block_value, TILE_K_AVX512, TILE_K_NARROW};
use crate::kernels::{features, Isa};

/// Block columns are zero-padded to a multiple of this (the widest kernel's vector).
pub(super) const PAD_COLUMNS: usize = 16;

/// The f32 block-product kernel of a path: every path has one ([`Isa::Scalar`] is the reference,
/// [`f32::mul_add`] chains); a path this CPU cannot run falls back to it.
pub(super) fn f32_kernel(isa: Isa) -> Isa {
    if isa.is_available() {
        isa
    } else {
        Isa::Scalar
    }
}

/// The 8-bit block-product kernels (each with the quantiser of its instruction set).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum I8Kernel {
    /// Plain i32 arithmetic: the reference.
    Scalar,
    /// AVX2 `vpmaddubsw` + `vpmaddwd` (no VNNI).
    Avx2Maddubs,
    /// AVX-VNNI `vpdpbusd` on ymm.
    AvxVnni,
    /// AVX-512 VNNI `vpdpbusd` on zmm.
    Avx512Vnni,
    /// The AVX-VNNI kernel's body with the EVEX encoding (AVX-512 VNNI + VL): tests only.
    #[cfg(test)]
    Vnni256,
    /// NEON `smull`/`sadalp`.
    NeonSmull,
    /// NEON `sdot` (dot-product extension).
    NeonSdot,
}

impl I8Kernel {
    /// The fastest 8-bit kernel of kernel path `isa` on this CPU (its sub-features from
    /// [`features`]); the scalar one for a path this CPU cannot run.
    pub(crate) fn for_isa(isa: Isa) -> Self {
        let f = features();
        if !isa.is_available() {
            return Self::Scalar;
        }
        match isa {
            Isa::Scalar => Self::Scalar,
            Isa::Avx512 if f.avx512vnni => Self::Avx512Vnni,
            Isa::Avx2 | Isa::Avx512 if f.avxvnni => Self::AvxVnni,
            Isa::Avx2 | Isa::Avx512 => Self::Avx2Maddubs,
            Isa::Neon if f.dotprod => Self::NeonSdot,
            Isa::Neon => Self::NeonSmull,
        }
    }

    /// Every 8-bit kernel path `isa` can run on this CPU (for the equality tests).
    #[cfg(test)]
    pub(super) fn all_for(isa: Isa) -> Vec<Self> {
        let all = [
            Self::Scalar,
            Self::Avx2Maddubs,
            Self::AvxVnni,
            Self::Avx512Vnni,
            Self::Vnni256,
            Self::NeonSmull,
            Self::NeonSdot,
        ];
        all.into_iter()
            .filter(|k| k.isa() == isa && k.is_runnable())
            .collect()
    }

    /// The kernel path this kernel belongs to (its quantiser's instruction set).
    #[cfg(test)]
    pub(super) fn isa(self) -> Isa {
        match self {
            Self::Scalar => Isa::Scalar,
            Self::Avx2Maddubs | Self::AvxVnni => Isa::Avx2,
            Self::Avx512Vnni | Self::Vnni256 => Isa::Avx512,
            Self::NeonSmull | Self::NeonSdot => Isa::Neon,
        }
    }

    /// This kernel if this CPU runs it, else the scalar reference.
    pub(super) fn or_scalar(self) -> Self {
        if self.is_runnable() {
            self
        } else {
            Self::Scalar
        }
    }

    /// Whether this CPU has every feature the kernel uses.
    pub(super) fn is_runnable(self) -> bool {
        let f = features();
        match self {
            Self::Scalar => true,
            Self::Avx2Maddubs => Isa::Avx2.is_available(),
            Self::AvxVnni => Isa::Avx2.is_available() && f.avxvnni,
            Self::Avx512Vnni => Isa::Avx512.is_available() && f.avx512vnni,
            #[cfg(test)]
            Self::Vnni256 => Isa::Avx512.is_available() && f.avx512vnni,
            Self::NeonSmull => Isa::Neon.is_available(),
            Self::NeonSdot => Isa::Neon.is_available() && f.dotprod,
        }
    }

    /// Whether this kernel was measured faster than the f32 kernel of its path (docs/detection.md,
    /// "8-bit SVM"; the rule of [`ScorePrecision::auto_for`]).
    pub(super) fn faster_than_f32(self) -> bool {
        match self {
            Self::Scalar => cfg!(target_arch = "x86_64"),
            Self::Avx2Maddubs | Self::AvxVnni | Self::Avx512Vnni => true,
            #[cfg(test)]
            Self::Vnni256 => true,
            Self::NeonSmull | Self::NeonSdot => false,
        }
    }

    /// Column multiple the kernel steps by (a divisor of [`PAD_COLUMNS`]).
    pub(super) fn lanes(self) -> usize {
        match self {
            Self::Scalar => 1,
            Self::NeonSmull => 4,
            Self::Avx512Vnni => 16,
            _ => 8,
        }
    }

    /// Block positions per tile (the kernel reads weights up to the tile's end).
    pub(super) fn tile(self) -> usize {
        match self {
            Self::Scalar => 1,
            Self::Avx512Vnni => TILE_K_AVX512,
            _ => TILE_K_NARROW,
        }
    }
}

/// `bt[i·nbxp + x] = row[x·bl + i]` for `x < nbx` (the padding columns stay zero).
pub(super) fn transpose_row(row: &[f32], bl: usize, nbx: usize, nbxp: usize, bt: &mut [f32]) {
    for (x, blk) in row.chunks_exact(bl).take(nbx).enumerate() {
        for (i, &v) in blk.iter().enumerate() {
            bt[i * nbxp + x] = v;
        }
    }
}

/// The lengths every product kernel relies on, checked once per call (the kernels' `# Safety`
/// sections, for the slices [`position_slices`] hands them): `nbxp` whole vectors, `nbx ≤ nbxp`,
/// the transposed row `nd·nbxp`, the weights `nd` rows of `nkp` with the positions `ks` and the
/// rest of their last tile inside a row (`ks.start + round_up(ks.len(), tile) ≤ nkp`), the
/// products `ks.end·nbxp`.
#[allow(clippy::too_many_arguments)]
pub(super) fn check_product_bounds(
    nbx: usize,
    nbxp: usize,
    nd: usize,
    bt_len: usize,
    ks: &Range<usize>,
    nkp: usize,
    w_len: usize,
    tile: usize,
    out_len: usize,
) {
    let fits = |a: usize, b: usize, len: usize| a.checked_mul(b).is_some_and(|n| n <= len);
    assert!(
        nbxp.is_multiple_of(PAD_COLUMNS)
            && nbx <= nbxp
            && ks.start <= ks.end
            && fits(nd, nbxp, bt_len)
            && fits(nd, nkp, w_len)
            && round_up(ks.len(), tile)
                .and_then(|t| t.checked_add(ks.start))
                .is_some_and(|t| t <= nkp)
            && fits(ks.end, nbxp, out_len),
        "block products out of bounds: {nbx}/{nbxp} columns, {nd} rows ({bt_len}), positions {ks:?} of {nkp} \
         (tile {tile}, weights {w_len}), products {out_len}"
    );
}

/// The weights (`nd` rows of `nkp`, `w`) and products (`out`) seen from position `ks.start`: a
/// kernel asked for `ks.len()` positions then computes exactly the positions `ks`.
pub(super) fn position_slices<'a, W, T>(
    w: &'a [W],
    out: &'a mut [T],
    ks: &Range<usize>,
    nbxp: usize,
) -> (&'a [W], &'a mut [T]) {
    (&w[ks.start..], &mut out[ks.start * nbxp..])
}

/// `out[k·nbxp + x] = Σ_i bt[i·nbxp + x] · wt[i·nkp + k]` for `k ∈ ks`, `x < nbx` (SIMD kernels also
/// fill padding columns), fused multiply-adds in order `i = 0..bl` from 0.
pub(super) fn block_products(
    w: &ScoreWeights,
    bt: &[f32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    kernel: Isa,
    out: &mut [f32],
) {
    let tile = match kernel {
        Isa::Avx512 => TILE_K_AVX512,
        _ => TILE_K_NARROW,
    };
    check_product_bounds(nbx, nbxp, w.bl, bt.len(), &ks, w.nkp, w.wt.len(), tile, out.len());
    let (bl, nk, nkp) = (w.bl, ks.len(), w.nkp);
    if nk == 0 {
        return;
    }
    let (wt, out) = position_slices(&w.wt, out, &ks, nbxp);
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `kernel` is a path this CPU runs (`f32_kernel`): AVX2 and FMA; lengths checked
        // above. Measured: see docs/detection.md "Speed" (SVM stage).
        Isa::Avx2 => unsafe { crate::detect::kernels::avx2::products_f32(bt, wt, bl, nk, nkp, nbxp, out) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, with AVX-512F.
        Isa::Avx512 => unsafe {
            crate::detect::kernels::avx512::products_f32(bt, wt, bl, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 CPU; lengths checked above.
        Isa::Neon => unsafe { crate::detect::kernels::neon::products_f32(bt, wt, bl, nk, nkp, nbxp, out) },
        _ => block_products_scalar(w, bt, nbx, nbxp, ks, out),
    }
}

/// The scalar reference (`out` seen from position `ks.start`).
pub(super) fn block_products_scalar(
    w: &ScoreWeights,
    bt: &[f32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    out: &mut [f32],
) {
    for (j, k) in ks.enumerate() {
        for x in 0..nbx {
            let mut acc = 0.0f32;
            for i in 0..w.bl {
                acc = bt[i * nbxp + x].mul_add(w.wt[i * w.nkp + k], acc);
            }
            out[j * nbxp + x] = acc;
        }
    }
}

/// Quantise block row `row` (`nbx` blocks of `bl` values) on the 8-bit path: `q[x·4ng + i]` =
/// [`quantise_block_value`] of value `i` of block `x` (zero for `bl ≤ i < 4ng`), then the dword
/// transpose: `btq[g·nbxp + x]` = bytes `4g..4g+4` of block `x`; padding columns stay zero.
/// For blocks of a multiple of 4 values (every HOG block) the kernel's instruction set
/// quantises; the bytes are the scalar ones.
pub(super) fn quantise_row(
    row: &[f32],
    bl: usize,
    nbx: usize,
    nbxp: usize,
    kernel: I8Kernel,
    q: &mut [u8],
    btq: &mut [u32],
) {
    let ng = bl.div_ceil(4);
    let n = nbx * 4 * ng;
    // The bounds the SIMD quantisers rely on, once per call.
    assert!(
        row.len() >= nbx * bl
            && q.len() >= n
            && btq.len() >= ng * nbxp
            && nbxp.is_multiple_of(PAD_COLUMNS)
            && nbx <= nbxp,
        "quantise_row out of bounds: {nbx}/{nbxp} blocks of {bl}, row {}, q {}, btq {}",
        row.len(),
        q.len(),
        btq.len()
    );
    if bl == 4 * ng {
        match kernel {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the kernel is runnable (`scores_i8_kernel`), so the CPU has AVX-512F and
            // BW; lengths checked above with bl = 4·ng.
            I8Kernel::Avx512Vnni => {
                return unsafe {
                    crate::detect::kernels::avx512::quantise_row_bytes(row, ng, nbx, nbxp, q, btq)
                };
            }
            #[cfg(target_arch = "x86_64")]
            // SAFETY: these kernels run only with AVX2 (`is_runnable`); n ≤ row.len(), q.len().
            I8Kernel::Avx2Maddubs | I8Kernel::AvxVnni => unsafe {
                crate::detect::kernels::avx2::quantise_values(row, n, q)
            },
            #[cfg(all(test, target_arch = "x86_64"))]
            // SAFETY: as above.
            I8Kernel::Vnni256 => unsafe { crate::detect::kernels::avx2::quantise_values(row, n, q) },
            #[cfg(target_arch = "aarch64")]
            // SAFETY: NEON is part of every aarch64 CPU; n ≤ row.len(), q.len().
            I8Kernel::NeonSmull | I8Kernel::NeonSdot => unsafe {
                crate::detect::kernels::neon::quantise_values(row, n, q)
            },
            _ => {
                for (d, &v) in q[..n].iter_mut().zip(&row[..n]) {
                    *d = quantise_block_value(v);
                }
            }
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

/// `out[k·nbxp + x] = Σ_i q_b[i][x] · q_w[i][k]` for `k ∈ ks`, `x < nbx` (SIMD kernels also fill
/// padding columns), exact in i32.
pub(super) fn quant_products(
    w: &ScoreWeightsI8,
    btq: &[u32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    kernel: I8Kernel,
    out: &mut [i32],
) {
    let nd = w.ng;
    check_product_bounds(
        nbx,
        nbxp,
        nd,
        btq.len(),
        &ks,
        w.nkp,
        w.wq.len(),
        kernel.tile(),
        out.len(),
    );
    debug_assert!(PAD_COLUMNS.is_multiple_of(kernel.lanes()));
    let (nk, nkp) = (ks.len(), w.nkp);
    if nk == 0 {
        return;
    }
    #[cfg(target_arch = "aarch64")]
    // corr holds nkp values, so ks.start.. holds the positions the kernel reads (checked above).
    let corr = &w.corr[ks.start..];
    let (wq, out) = position_slices(&w.wq, out, &ks, nbxp);
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the kernel is runnable (`scores_i8_kernel`): AVX-512F, BW and VNNI; lengths
        // checked above. Measured: see docs/detection.md "8-bit SVM".
        I8Kernel::Avx512Vnni => unsafe {
            crate::detect::kernels::avx512::products_bytes_vnni(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: runnable: AVX2 and AVX-VNNI; lengths checked above.
        I8Kernel::AvxVnni => unsafe {
            crate::detect::kernels::avx2::products_bytes_avxvnni(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(all(test, target_arch = "x86_64"))]
        // SAFETY: runnable: AVX2, AVX-512 VNNI (and VL, part of the AVX-512 path); lengths checked.
        I8Kernel::Vnni256 => unsafe {
            crate::detect::kernels::avx2::products_bytes_vnni256(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: runnable: AVX2; lengths checked above. Exact for the L2-normalised blocks of
        // every BlockGrid (the kernel's module docs).
        I8Kernel::Avx2Maddubs => unsafe {
            crate::detect::kernels::avx2::products_bytes_maddubs(btq, wq, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: runnable: the dot-product extension; lengths checked above, corr holds nkp ≥ nk.
        I8Kernel::NeonSdot => unsafe {
            crate::detect::kernels::neon::products_bytes_sdot(btq, wq, corr, nd, nk, nkp, nbxp, out)
        },
        #[cfg(target_arch = "aarch64")]
        // SAFETY: NEON is part of every aarch64 CPU; lengths checked above, corr holds nkp ≥ nk.
        I8Kernel::NeonSmull => unsafe {
            crate::detect::kernels::neon::products_bytes_smull(btq, wq, corr, nd, nk, nkp, nbxp, out)
        },
        _ => quant_products_scalar(w, btq, nbx, nbxp, ks, out),
    }
}

/// The scalar reference of the 8-bit path: plain i32 arithmetic over the byte layout (`out` seen
/// from position `ks.start`).
pub(super) fn quant_products_scalar(
    w: &ScoreWeightsI8,
    btq: &[u32],
    nbx: usize,
    nbxp: usize,
    ks: Range<usize>,
    out: &mut [i32],
) {
    for (j, k) in ks.enumerate() {
        for x in 0..nbx {
            let mut acc = 0i32;
            for g in 0..w.ng {
                let b = btq[g * nbxp + x].to_le_bytes();
                let q = w.wq[g * w.nkp + k].to_le_bytes();
                for t in 0..4 {
                    acc += b[t] as i32 * q[t] as i8 as i32;
                }
            }
            out[j * nbxp + x] = acc;
        }
    }
}
