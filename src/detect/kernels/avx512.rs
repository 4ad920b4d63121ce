//! AVX-512 kernels of the SVM stage and the pyramid.

use std::arch::x86_64::*;

use super::BLOCK_QUANT_SCALE;
use super::TILE_K_AVX512;
use super::{horizontal_row, Perm16};

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

/// The 16 source values at the offsets `idx` (< `32·pairs`) from `src`: one `vpermt2ps` per pair
/// of registers, each lane kept from the pair its offset falls in.
///
/// # Safety
/// The CPU must support AVX-512F and `src` must be readable for `32·pairs` values.
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn pick16(src: *const f32, pairs: u32, idx: __m512i) -> __m512 {
    // SAFETY: the caller guarantees 32·pairs readable values; vpermt2ps uses the low 5 index bits.
    unsafe {
        let mut v = _mm512_permutex2var_ps(_mm512_loadu_ps(src), idx, _mm512_loadu_ps(src.add(16)));
        for k in 1..pairs as usize {
            let t = _mm512_permutex2var_ps(
                _mm512_loadu_ps(src.add(32 * k)),
                idx,
                _mm512_loadu_ps(src.add(32 * k + 16)),
            );
            let m = _mm512_cmpge_epu32_mask(idx, _mm512_set1_epi32(32 * k as i32));
            v = _mm512_mask_blend_ps(m, v, t);
        }
        v
    }
}

/// The pyramid's horizontal pass with AVX-512 permutes for the outputs that have a [`Perm16`]
/// (same arithmetic, no fused operations: the same bits as [`horizontal_row`]), the scalar pass
/// for the others.
///
/// # Safety
/// The CPU must support AVX-512F; `perms` holds one entry per 16 outputs and `p`, `q`, `f` at
/// least `out.len()` values; every [`Perm16`] of `perms` must lie inside `a`
/// (`base + 32·pairs ≤ a.len()`, offsets < `32·pairs`): [`crate::detect::pyramid`] builds them
/// for rows of `a`'s length and checks that once per call.
#[target_feature(enable = "avx512f,avx2,fma")]
pub(crate) unsafe fn horizontal(
    a: &[f32],
    (p, q, f): (&[u32], &[u32], &[f32]),
    perms: &[Option<Perm16>],
    out: &mut [f32],
) {
    for (i, (o, pm)) in out.chunks_mut(16).zip(perms).enumerate() {
        match pm {
            Some(pm) if o.len() == 16 => {
                // SAFETY: the Perm16 lies inside a (the caller's contract); `o` holds 16.
                unsafe {
                    let src = a.as_ptr().add(pm.base as usize);
                    let vp = pick16(src, pm.pairs, _mm512_loadu_si512(pm.p.as_ptr().cast()));
                    let vq = pick16(src, pm.pairs, _mm512_loadu_si512(pm.q.as_ptr().cast()));
                    let fx = _mm512_loadu_ps(pm.fx.as_ptr());
                    let r = _mm512_add_ps(vp, _mm512_mul_ps(_mm512_sub_ps(vq, vp), fx));
                    _mm512_storeu_ps(o.as_mut_ptr(), r);
                }
            }
            _ => {
                let k = i * 16;
                horizontal_row(a, &p[k..], &q[k..], &f[k..], o, 0)
            }
        }
    }
}
