//! NEON rows of the bilinear resize: the horizontal pass picks each group's taps by a byte table
//! lookup (`tbl`); the vertical pass runs 4 lanes.

use std::arch::aarch64::*;

/// The pyramid's horizontal pass ([`super::horizontal_row`]) on 4 outputs at a time: when every
/// tap of a group lies in the 8 values from its first tap, they are picked from there by a byte
/// table lookup (`tbl` over 32 bytes); any other group (taps spread wider, or too close to the
/// end of `a`) is computed by the scalar pass. Separate multiply and add: the same bits.
///
/// # Safety
/// `p`, `q`, `f` hold at least `out.len()` values (NEON is part of every aarch64 target). The
/// loads from `a` are checked here (`p[x] + 8 ≤ a.len()`); the scalar pass indexes with bounds
/// checks.
#[target_feature(enable = "neon")]
pub(crate) unsafe fn horizontal(a: &[f32], p: &[u32], q: &[u32], f: &[f32], out: &mut [f32]) {
    let n = out.len();
    // lane offset i → its four bytes 4i, 4i + 1, 4i + 2, 4i + 3 (i < 8: below 32)
    let spread = vdupq_n_u32(0x0404_0404);
    let bytes = vdupq_n_u32(0x0302_0100);
    let mut x = 0;
    while x + 4 <= n {
        let base = p[x] as usize;
        let b = vdupq_n_u32(base as u32);
        // SAFETY: x + 4 ≤ n ≤ the taps' lengths.
        let (ip, iq) = unsafe {
            (
                vsubq_u32(vld1q_u32(p.as_ptr().add(x)), b),
                vsubq_u32(vld1q_u32(q.as_ptr().add(x)), b),
            )
        };
        // every offset from the first tap in 0..8 (a tap below it wraps to a large offset)
        if vmaxvq_u32(vorrq_u32(ip, iq)) < 8 && base + 8 <= a.len() {
            // SAFETY: x + 4 ≤ n ≤ out.len(), f.len(); base + 8 ≤ a.len().
            unsafe {
                let table = uint8x16x2_t(
                    vreinterpretq_u8_f32(vld1q_f32(a.as_ptr().add(base))),
                    vreinterpretq_u8_f32(vld1q_f32(a.as_ptr().add(base + 4))),
                );
                let pick = |i: uint32x4_t| {
                    let idx = vreinterpretq_u8_u32(vaddq_u32(vmulq_u32(i, spread), bytes));
                    vreinterpretq_f32_u8(vqtbl2q_u8(table, idx))
                };
                let (ap, aq) = (pick(ip), pick(iq));
                let fx = vld1q_f32(f.as_ptr().add(x));
                vst1q_f32(
                    out.as_mut_ptr().add(x),
                    vaddq_f32(ap, vmulq_f32(vsubq_f32(aq, ap), fx)),
                );
            }
        } else {
            super::horizontal_row(a, p, q, f, &mut out[..x + 4], x);
        }
        x += 4;
    }
    super::horizontal_row(a, p, q, f, out, x);
}

/// The pyramid's vertical pass and factor `out[x] = (r0[x] + (r1[x] − r0[x])·fy)·k`
/// ([`super::vertical_row`]), 4 lanes (separate multiplies and add, as the scalar code: the same
/// bits).
///
/// # Safety
/// None beyond NEON, which every aarch64 CPU has (lengths are those of the shortest slice).
#[target_feature(enable = "neon")]
pub(crate) unsafe fn vertical(r0: &[f32], r1: &[f32], fy: f32, k: f32, out: &mut [f32]) {
    let n = out.len().min(r0.len()).min(r1.len());
    let whole = n / 4 * 4;
    let (f, kv) = (vdupq_n_f32(fy), vdupq_n_f32(k));
    for x in (0..whole).step_by(4) {
        // SAFETY: x + 4 ≤ n, the length of the shortest slice.
        unsafe {
            let v0 = vld1q_f32(r0.as_ptr().add(x));
            let v1 = vld1q_f32(r1.as_ptr().add(x));
            vst1q_f32(
                out.as_mut_ptr().add(x),
                vmulq_f32(vaddq_f32(v0, vmulq_f32(vsubq_f32(v1, v0), f)), kv),
            );
        }
    }
    super::vertical_row(&r0[whole..n], &r1[whole..n], fy, k, &mut out[whole..n]);
}
