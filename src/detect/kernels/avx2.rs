//! AVX2 (+FMA) kernels of the SVM stage, and the 256-bit VNNI variants of the
//! 8-bit products (AVX-VNNI, VEX-encoded; and its EVEX twin of AVX-512 VNNI + VL, used by the
//! tests to run the same code on CPUs that have only the latter).
//!
//! # The 8-bit products without VNNI: `vpmaddubsw`, exact because blocks are L2-normalised
//! `vpmaddubsw` adds two u8·i8 products in a *saturating* i16. Block values are quantised as
//! `q = round(180·v)` ([`super::BLOCK_QUANT_SCALE`]) and weights as `|q_w| ≤ 127`.
//! Every block the detector scores is L2-Hys normalised (`‖v‖₂ ≤ 1`), so two values of one block
//! satisfy `v_a + v_b ≤ √2` and `q_a + q_b ≤ 180·√2 + 1 < 256`: a pair sums to at most
//! `255·127 = 32 385 ≤ 32 767` and never saturates (the bound holds up to `‖v‖₂ ≤ 1.01`). The
//! i16 pair sums are then widened and added by `vpmaddwd` against ones (two pairs per i32 lane)
//! and `vpaddd`: per block position 9 broadcasts + 9 `vpmaddubsw` + 9 `vpmaddwd` + 9 `vpaddd`,
//! against 18 + 18 + 18 for the u16-pair `vpmaddwd` kernel this replaced and 36 FMAs + 36
//! broadcasts in f32 (docs/detection.md, "8-bit SVM"). Blocks that are not normalised (only
//! the unit tests make them) may saturate: the scalar reference, VNNI and NEON kernels stay
//! exact for any bytes.

use std::arch::x86_64::*;

use super::quantise_block_value;
use super::TILE_K_NARROW;

/// f32 block products `out[k·nbxp + x] = Σ_{i<bl} bt[i·nbxp + x] · wt[i·nkp + k]` (fused, `i`
/// ascending from 0: the scalar reference's bits) for `k < nk` and every column `x < nbxp`.
///
/// # Safety
/// The CPU must have AVX2 and FMA. `nbxp` is a multiple of 8, `bt.len() ≥ bl·nbxp`,
/// `wt.len() ≥ bl·nkp`, `nkp ≥ ⌈nk/12⌉·12`, `out.len() ≥ nk·nbxp`.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn products_f32(
    bt: &[f32],
    wt: &[f32],
    bl: usize,
    nk: usize,
    nkp: usize,
    nbxp: usize,
    out: &mut [f32],
) {
    const L: usize = 8;
    for x in (0..nbxp).step_by(L) {
        for k0 in (0..nk).step_by(TILE_K_NARROW) {
            let mut acc = [_mm256_setzero_ps(); TILE_K_NARROW];
            for i in 0..bl {
                // SAFETY: x + 8 ≤ nbxp and i < bl, so the 8 floats are inside bt (bl·nbxp);
                // k0 + 12 ≤ nkp, so the broadcasts read inside wt (bl·nkp).
                let b = unsafe { _mm256_loadu_ps(bt.as_ptr().add(i * nbxp + x)) };
                let wr = unsafe { wt.as_ptr().add(i * nkp + k0) };
                for (j, a) in acc.iter_mut().enumerate() {
                    let wv = unsafe { _mm256_broadcast_ss(&*wr.add(j)) };
                    *a = _mm256_fmadd_ps(b, wv, *a);
                }
            }
            for (j, a) in acc.iter().enumerate().filter(|(j, _)| k0 + j < nk) {
                // SAFETY: k0 + j < nk and x + 8 ≤ nbxp: inside out (nk·nbxp).
                unsafe { _mm256_storeu_ps(out.as_mut_ptr().add((k0 + j) * nbxp + x), *a) };
            }
        }
    }
}

/// The body of every 256-bit dword-pair product kernel: per dword group `g`,
/// `acc[j] = $op(acc[j], btq[g][x..x+8], broadcast(wq[g][k0+j]))`, stored for `k0 + j < nk`.
macro_rules! dword_products {
    ($(#[$doc:meta])* $name:ident, $features:literal, $op:ident) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// The CPU must have the features enabled on this function. `nbxp` is a multiple of 8,
        /// `btq.len() ≥ ng·nbxp`, `wq.len() ≥ ng·nkp`, `nkp ≥ ⌈nk/12⌉·12`,
        /// `out.len() ≥ nk·nbxp`.
        #[target_feature(enable = $features)]
        pub(crate) unsafe fn $name(
            btq: &[u32],
            wq: &[u32],
            ng: usize,
            nk: usize,
            nkp: usize,
            nbxp: usize,
            out: &mut [i32],
        ) {
            const L: usize = 8;
            for x in (0..nbxp).step_by(L) {
                for k0 in (0..nk).step_by(TILE_K_NARROW) {
                    let mut acc = [_mm256_setzero_si256(); TILE_K_NARROW];
                    for g in 0..ng {
                        // SAFETY: x + 8 ≤ nbxp and g < ng: inside btq (ng·nbxp); k0 + 12 ≤ nkp:
                        // inside wq (ng·nkp).
                        let b = unsafe { _mm256_loadu_si256(btq.as_ptr().add(g * nbxp + x).cast()) };
                        let wr = unsafe { wq.as_ptr().add(g * nkp + k0) };
                        for (j, a) in acc.iter_mut().enumerate() {
                            let wv = _mm256_set1_epi32(unsafe { *wr.add(j) } as i32);
                            *a = $op(*a, b, wv);
                        }
                    }
                    for (j, a) in acc.iter().enumerate().filter(|(j, _)| k0 + j < nk) {
                        // SAFETY: k0 + j < nk and x + 8 ≤ nbxp: inside out (nk·nbxp).
                        unsafe { _mm256_storeu_si256(out.as_mut_ptr().add((k0 + j) * nbxp + x).cast(), *a) };
                    }
                }
            }
        }
    };
}

/// `a + vpmaddwd(vpmaddubsw(b, w), 1)`: four u8·i8 products per i32 lane, exact while each
/// pair's sum fits an i16 (L2-normalised blocks: see the module docs).
#[target_feature(enable = "avx2")]
#[inline]
fn maddubs_acc(a: __m256i, b: __m256i, w: __m256i) -> __m256i {
    let pairs = _mm256_maddubs_epi16(b, w);
    _mm256_add_epi32(a, _mm256_madd_epi16(pairs, _mm256_set1_epi16(1)))
}

/// `vpdpbusd` (VEX, AVX-VNNI): four u8·i8 products per i32 lane, exact.
#[target_feature(enable = "avx2,avxvnni")]
#[inline]
fn dpbusd_vex(a: __m256i, b: __m256i, w: __m256i) -> __m256i {
    _mm256_dpbusd_avx_epi32(a, b, w)
}

/// `vpdpbusd` (EVEX, AVX-512 VNNI + VL) on ymm: the same operation as [`dpbusd_vex`].
#[cfg(test)]
#[target_feature(enable = "avx2,avx512vnni,avx512vl")]
#[inline]
fn dpbusd_evex(a: __m256i, b: __m256i, w: __m256i) -> __m256i {
    _mm256_dpbusd_epi32(a, b, w)
}

dword_products!(
    /// 8-bit products on AVX2 without VNNI over the byte layout (`btq` dword `g` of a block holds
    /// values `4g..4g+4` as u8, `wq` the four i8 weights): `vpmaddubsw` + `vpmaddwd` + `vpaddd`
    /// per dword and block position. Exact for L2-normalised blocks (module docs).
    products_bytes_maddubs,
    "avx2",
    maddubs_acc
);

dword_products!(
    /// 8-bit products with AVX-VNNI over the byte layout (`btq` dword `g` of a block holds values
    /// `4g..4g+4` as u8, `wq` the four i8 weights): one `vpdpbusd` per dword and block position.
    products_bytes_avxvnni,
    "avx2,avxvnni",
    dpbusd_vex
);

dword_products!(
    /// [`products_bytes_avxvnni`] with the EVEX encoding (AVX-512 VNNI + VL): the same kernel
    /// body, runnable on this generation of test machines.
    #[cfg(test)]
    products_bytes_vnni256,
    "avx2,avx512vnni,avx512vl",
    dpbusd_evex
);

/// `q[i] = quantise_block_value(row[i])` for `i < n`, 8 at a time (`vcvtps2dq` rounds to nearest
/// even like the scalar quantiser; `max(m, 0)` returns 0 for NaN as its clamp-then-cast does).
///
/// # Safety
/// The CPU must have AVX2; `row.len() ≥ n` and `q.len() ≥ n`.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn quantise_values(row: &[f32], n: usize, q: &mut [u8]) {
    const L: usize = 8;
    let scale = _mm256_set1_ps(super::BLOCK_QUANT_SCALE);
    let zero = _mm256_setzero_ps();
    let whole = n / L * L;
    for i in (0..whole).step_by(L) {
        // SAFETY: i + 8 ≤ n ≤ row.len(), and the 8-byte store ends at i + 8 ≤ n ≤ q.len().
        let v = unsafe { _mm256_loadu_ps(row.as_ptr().add(i)) };
        let m = _mm256_min_ps(_mm256_max_ps(_mm256_mul_ps(v, scale), zero), scale);
        let d = _mm256_cvtps_epi32(m);
        let w = _mm_packus_epi32(_mm256_castsi256_si128(d), _mm256_extracti128_si256::<1>(d));
        let b = _mm_packus_epi16(w, w);
        unsafe { _mm_storel_epi64(q.as_mut_ptr().add(i).cast(), b) };
    }
    for (d, &v) in q[whole..n].iter_mut().zip(&row[whole..n]) {
        *d = quantise_block_value(v);
    }
}

/// The SVM's window sums ([`super::add_window_row`]) compiled for AVX2, on
/// f32 products (the same additions in the same order: the same bits).
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn add_window_row_f32(row: &mut [f32], pr: &[f32], by: usize, bw: usize, nbxp: usize) {
    super::add_window_row(row, pr, by, bw, nbxp)
}

/// [`add_window_row_f32`] on the 8-bit path's exact i32 products.
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn add_window_row_i32(row: &mut [i32], pr: &[i32], by: usize, bw: usize, nbxp: usize) {
    super::add_window_row(row, pr, by, bw, nbxp)
}
