//! NEON tree scoring: 4 windows per group, lanes selected by `bsl` (see [`super`]).

use std::arch::aarch64::*;

use super::scalar::Tree2;

/// [`super::score_run`] on 4 windows at a time, the rest by the scalar oracle.
///
/// # Safety
/// `data[base0 + i + t.off[k]]` is in bounds for every window `i` and node (NEON is part of
/// every aarch64 target).
#[target_feature(enable = "neon")]
pub(super) unsafe fn score_run(
    trees: &[Tree2],
    reject: &[f32],
    data: &[f32],
    base0: usize,
    scores: &mut [f32],
    counts: &mut [u32],
) {
    let n = scores.len();
    let groups = n / 4;
    for g in 0..groups {
        // SAFETY: the caller guarantees every window's reads are in bounds; lane j reads
        // window g·4 + j < n.
        let x = unsafe { data.as_ptr().add(base0 + g * 4) };
        // `h` runs on in every lane (one addition per tree: the only long dependency chain);
        // a lane's score is frozen in `score` at the tree that rejects it
        let mut h = vdupq_n_f32(0.0);
        let mut score = vdupq_n_f32(0.0);
        let mut cnt = vdupq_n_u32(0);
        let mut alive = vdupq_n_u32(u32::MAX);
        for (t, &r) in trees.iter().zip(reject) {
            // SAFETY: in bounds (above).
            let (v0, v1, v2) = unsafe {
                (
                    vld1q_f32(x.add(t.off[0] as usize)),
                    vld1q_f32(x.add(t.off[1] as usize)),
                    vld1q_f32(x.add(t.off[2] as usize)),
                )
            };
            // right: !(x < thr), true for NaN as in the oracle
            let m0 = vmvnq_u32(vcltq_f32(v0, vdupq_n_f32(t.thr[0])));
            let v = vbslq_f32(m0, v2, v1);
            let th = vbslq_f32(m0, vdupq_n_f32(t.thr[2]), vdupq_n_f32(t.thr[1]));
            let m1 = vmvnq_u32(vcltq_f32(v, th));
            let lo = vbslq_f32(m1, vdupq_n_f32(t.hs[1]), vdupq_n_f32(t.hs[0]));
            let hi = vbslq_f32(m1, vdupq_n_f32(t.hs[3]), vdupq_n_f32(t.hs[2]));
            let leaf = vbslq_f32(m0, hi, lo);
            h = vaddq_f32(h, leaf);
            cnt = vsubq_u32(cnt, alive); // alive lanes are all ones: −(−1) = +1
                                         // rejected by this tree: alive and h ≤ r
            let dead = vandq_u32(vcleq_f32(h, vdupq_n_f32(r)), alive);
            score = vbslq_f32(dead, h, score);
            alive = vbicq_u32(alive, dead);
            if vmaxvq_u32(alive) == 0 {
                break;
            }
        }
        // lanes never rejected score the sum of every tree
        let h = vbslq_f32(alive, h, score);
        // SAFETY: g·4 + 4 ≤ n = scores.len() = counts.len().
        unsafe {
            vst1q_f32(scores.as_mut_ptr().add(g * 4), h);
            vst1q_u32(counts.as_mut_ptr().add(g * 4), cnt);
        }
    }
    let done = groups * 4;
    super::scalar::score_run_scalar(
        trees,
        reject,
        data,
        base0 + done,
        &mut scores[done..],
        &mut counts[done..],
    );
}
