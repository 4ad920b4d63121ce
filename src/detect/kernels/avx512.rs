//! AVX-512 kernels of the SVM stage.

use std::arch::x86_64::*;

use super::BLOCK_QUANT_SCALE;
use super::TILE_K_AVX512;

/// f32 block products as [`super::avx2::products_f32`], 16 columns per vector and 21 block
/// positions per tile.
///
/// # Safety
/// The CPU must have AVX-512F. `nbxp` is a multiple of 16, `bt.len() ≥ bl·nbxp`,
/// `wt.len() ≥ bl·nkp`, `nkp ≥ ⌈nk/21⌉·21`, `out.len() ≥ nk·nbxp`.
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn products_f32(
    bt: &[f32],
    wt: &[f32],
    bl: usize,
    nk: usize,
    nkp: usize,
    nbxp: usize,
    out: &mut [f32],
) {
    const L: usize = 16;
    for x in (0..nbxp).step_by(L) {
        for k0 in (0..nk).step_by(TILE_K_AVX512) {
            let mut acc = [_mm512_setzero_ps(); TILE_K_AVX512];
            for i in 0..bl {
                // SAFETY: x + 16 ≤ nbxp and i < bl: inside bt; k0 + 21 ≤ nkp: inside wt.
                let b = unsafe { _mm512_loadu_ps(bt.as_ptr().add(i * nbxp + x)) };
                let wr = unsafe { wt.as_ptr().add(i * nkp + k0) };
                for (j, a) in acc.iter_mut().enumerate() {
                    let wv = _mm512_set1_ps(unsafe { *wr.add(j) });
                    *a = _mm512_fmadd_ps(b, wv, *a);
                }
            }
            for (j, a) in acc.iter().enumerate().filter(|(j, _)| k0 + j < nk) {
                // SAFETY: k0 + j < nk and x + 16 ≤ nbxp: inside out (nk·nbxp).
                unsafe { _mm512_storeu_ps(out.as_mut_ptr().add((k0 + j) * nbxp + x), *a) };
            }
        }
    }
}

/// 8-bit products over the byte layout with AVX-512 VNNI: per dword group `g`, one `vpdpbusd`
/// per block position adds the four u8·i8 products of 16 blocks at once.
///
/// # Safety
/// The CPU must have AVX-512F, BW and VNNI. `nbxp` is a multiple of 16, `btq.len() ≥ ng·nbxp`,
/// `wq.len() ≥ ng·nkp`, `nkp ≥ ⌈nk/21⌉·21`, `out.len() ≥ nk·nbxp`.
#[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
pub(crate) unsafe fn products_bytes_vnni(
    btq: &[u32],
    wq: &[u32],
    ng: usize,
    nk: usize,
    nkp: usize,
    nbxp: usize,
    out: &mut [i32],
) {
    const L: usize = 16;
    for x in (0..nbxp).step_by(L) {
        for k0 in (0..nk).step_by(TILE_K_AVX512) {
            let mut acc = [_mm512_setzero_si512(); TILE_K_AVX512];
            for g in 0..ng {
                // SAFETY: x + 16 ≤ nbxp and g < ng: inside btq (ng·nbxp); k0 + 21 ≤ nkp: inside wq.
                let b = unsafe { _mm512_loadu_si512(btq.as_ptr().add(g * nbxp + x).cast()) };
                let wr = unsafe { wq.as_ptr().add(g * nkp + k0) };
                for (j, a) in acc.iter_mut().enumerate() {
                    let wv = _mm512_set1_epi32(unsafe { *wr.add(j) } as i32);
                    *a = _mm512_dpbusd_epi32(*a, b, wv);
                }
            }
            for (j, a) in acc.iter().enumerate().filter(|(j, _)| k0 + j < nk) {
                // SAFETY: k0 + j < nk and x + 16 ≤ nbxp: inside out (nk·nbxp).
                unsafe { _mm512_storeu_si512(out.as_mut_ptr().add((k0 + j) * nbxp + x).cast(), *a) };
            }
        }
    }
}

/// The 8-bit quantiser and byte-layout transpose for blocks of `4·ng` values: `q[i]` =
/// `quantise_block_value(row[i])` 16 at a time (`vcvtps2dq` rounds to nearest even like the
/// scalar quantiser; `max(m, 0)` turns NaN into 0 as its clamp-then-cast does), then
/// `btq[g·nbxp + x]` = dword `g` of block `x` by 16-lane gathers (zeros in padding columns).
///
/// # Safety
/// The CPU must have AVX-512F and BW. With `n = nbx·4·ng`: `row.len() ≥ n`, `q.len() ≥ n`,
/// `nbx ≤ nbxp`, `nbxp` a multiple of 16, `btq.len() ≥ ng·nbxp`.
#[target_feature(enable = "avx512f,avx512bw")]
pub(crate) unsafe fn quantise_row_bytes(
    row: &[f32],
    ng: usize,
    nbx: usize,
    nbxp: usize,
    q: &mut [u8],
    btq: &mut [u32],
) {
    const L: usize = 16;
    let n = nbx * 4 * ng;
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
