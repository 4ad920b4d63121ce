//! AVX-512 tree scoring: 16 windows per group, lanes masked by `k` registers (see [`super`]).

use std::arch::x86_64::*;

use super::scalar::Tree2;

/// [`super::score_run`] on 16 windows at a time, the rest by the scalar oracle.
///
/// # Safety
/// The CPU has AVX-512 F; `data[base0 + i + t.off[k]]` is in bounds for every window `i` and
/// node.
#[target_feature(enable = "avx512f,avx2,fma")]
pub(super) unsafe fn score_run(
    trees: &[Tree2],
    reject: &[f32],
    data: &[f32],
    base0: usize,
    scores: &mut [f32],
    counts: &mut [u32],
) {
    let n = scores.len();
    let groups = n / 16;
    let one = _mm512_set1_epi32(1);
    for g in 0..groups {
        // SAFETY: the caller guarantees every window's reads are in bounds; lane j reads
        // window g·16 + j < n.
        let x = unsafe { data.as_ptr().add(base0 + g * 16) };
        // `h` runs on in every lane (one addition per tree: the only long dependency chain);
        // a lane's score is frozen in `score` at the tree that rejects it
        let mut h = _mm512_setzero_ps();
        let mut score = _mm512_setzero_ps();
        let mut cnt = _mm512_setzero_si512();
        let mut alive: __mmask16 = 0xffff;
        for (t, &r) in trees.iter().zip(reject) {
            // SAFETY: in bounds (above); unaligned loads.
            let (v0, v1, v2) = unsafe {
                (
                    _mm512_loadu_ps(x.add(t.off[0] as usize)),
                    _mm512_loadu_ps(x.add(t.off[1] as usize)),
                    _mm512_loadu_ps(x.add(t.off[2] as usize)),
                )
            };
            let m0 = _mm512_cmp_ps_mask::<_CMP_NLT_UQ>(v0, _mm512_set1_ps(t.thr[0]));
            let v = _mm512_mask_blend_ps(m0, v1, v2);
            let th = _mm512_mask_blend_ps(m0, _mm512_set1_ps(t.thr[1]), _mm512_set1_ps(t.thr[2]));
            let m1 = _mm512_cmp_ps_mask::<_CMP_NLT_UQ>(v, th);
            let lo = _mm512_mask_blend_ps(m1, _mm512_set1_ps(t.hs[0]), _mm512_set1_ps(t.hs[1]));
            let hi = _mm512_mask_blend_ps(m1, _mm512_set1_ps(t.hs[2]), _mm512_set1_ps(t.hs[3]));
            let leaf = _mm512_mask_blend_ps(m0, lo, hi);
            h = _mm512_add_ps(h, leaf);
            cnt = _mm512_mask_add_epi32(cnt, alive, cnt, one);
            // still alive: alive and not (h ≤ r); the others alive before were rejected here
            let still = _mm512_mask_cmp_ps_mask::<_CMP_NLE_UQ>(alive, h, _mm512_set1_ps(r));
            score = _mm512_mask_mov_ps(score, alive ^ still, h);
            alive = still;
            if alive == 0 {
                break;
            }
        }
        // lanes never rejected score the sum of every tree
        let h = _mm512_mask_mov_ps(score, alive, h);
        // SAFETY: g·16 + 16 ≤ n = scores.len() = counts.len().
        unsafe {
            _mm512_storeu_ps(scores.as_mut_ptr().add(g * 16), h);
            _mm512_storeu_si512(counts.as_mut_ptr().add(g * 16).cast(), cnt);
        }
    }
    let done = groups * 16;
    // SAFETY: AVX2 is part of the AVX-512 path (`Isa::is_available`); same bounds.
    unsafe {
        super::avx2::score_run(
            trees,
            reject,
            data,
            base0 + done,
            &mut scores[done..],
            &mut counts[done..],
        )
    };
}
