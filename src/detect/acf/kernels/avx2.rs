//! AVX2 tree scoring: 8 windows per group (see [`super`]).

use std::arch::x86_64::*;

use super::scalar::Tree2;

/// [`super::score_run`] on 8 windows at a time, the rest by the scalar oracle.
///
/// # Safety
/// The CPU has AVX2; `data[base0 + i + t.off[k]]` is in bounds for every window `i` and node.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn score_run(
    trees: &[Tree2],
    reject: &[f32],
    data: &[f32],
    base0: usize,
    scores: &mut [f32],
    counts: &mut [u32],
) {
    let n = scores.len();
    let groups = n / 8;
    for g in 0..groups {
        // SAFETY: the caller guarantees every window's reads are in bounds; lane j reads
        // window g·8 + j < n.
        let x = unsafe { data.as_ptr().add(base0 + g * 8) };
        // `h` runs on in every lane (one addition per tree: the only long dependency chain);
        // a lane's score is frozen in `score` at the tree that rejects it
        let mut h = _mm256_setzero_ps();
        let mut score = _mm256_setzero_ps();
        let mut cnt = _mm256_setzero_si256();
        let mut alive = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
        for (t, &r) in trees.iter().zip(reject) {
            // SAFETY: in bounds (above); unaligned loads.
            let (v0, v1, v2) = unsafe {
                (
                    _mm256_loadu_ps(x.add(t.off[0] as usize)),
                    _mm256_loadu_ps(x.add(t.off[1] as usize)),
                    _mm256_loadu_ps(x.add(t.off[2] as usize)),
                )
            };
            let m0 = _mm256_cmp_ps::<_CMP_NLT_UQ>(v0, _mm256_set1_ps(t.thr[0]));
            let v = _mm256_blendv_ps(v1, v2, m0);
            let th = _mm256_blendv_ps(_mm256_set1_ps(t.thr[1]), _mm256_set1_ps(t.thr[2]), m0);
            let m1 = _mm256_cmp_ps::<_CMP_NLT_UQ>(v, th);
            let lo = _mm256_blendv_ps(_mm256_set1_ps(t.hs[0]), _mm256_set1_ps(t.hs[1]), m1);
            let hi = _mm256_blendv_ps(_mm256_set1_ps(t.hs[2]), _mm256_set1_ps(t.hs[3]), m1);
            let leaf = _mm256_blendv_ps(lo, hi, m0);
            h = _mm256_add_ps(h, leaf);
            cnt = _mm256_sub_epi32(cnt, _mm256_castps_si256(alive));
            // rejected by this tree: alive and h ≤ r
            let dead = _mm256_and_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(h, _mm256_set1_ps(r)), alive);
            score = _mm256_blendv_ps(score, h, dead);
            alive = _mm256_andnot_ps(dead, alive);
            if _mm256_movemask_ps(alive) == 0 {
                break;
            }
        }
        // lanes never rejected score the sum of every tree
        let h = _mm256_blendv_ps(score, h, alive);
        // SAFETY: g·8 + 8 ≤ n = scores.len() = counts.len().
        unsafe {
            _mm256_storeu_ps(scores.as_mut_ptr().add(g * 8), h);
            _mm256_storeu_si256(counts.as_mut_ptr().add(g * 8).cast(), cnt);
        }
    }
    let done = groups * 8;
    super::scalar::score_run_scalar(
        trees,
        reject,
        data,
        base0 + done,
        &mut scores[done..],
        &mut counts[done..],
    );
}
