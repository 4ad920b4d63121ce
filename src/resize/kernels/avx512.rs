//! AVX-512 rows of the bilinear resize: the horizontal pass picks each output's taps by
//! `vpermt2ps` from the registers a [`Perm16`] names.

use std::arch::x86_64::*;

use super::{horizontal_row, Perm16};

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
/// (`base + 32·pairs ≤ a.len()`, offsets < `32·pairs`): [`crate::resize`] builds them
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
