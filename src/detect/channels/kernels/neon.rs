//! NEON channel kernels (see [`super`]): 4 pixels per step, the scalar oracle for the tail.

use std::arch::aarch64::*;

use super::scalar::Edges;

/// [`super::grad_row`] on 4 pixels at a time.
///
/// # Safety
/// `mid.len() > mag.len()`, `up.len()`, `dn.len() ≥ mag.len() = bin.len()` (NEON is part of
/// every aarch64 target).
#[target_feature(enable = "neon")]
pub(super) unsafe fn grad_row(
    up: &[f32],
    mid: &[f32],
    dn: &[f32],
    edges: &Edges,
    mag: &mut [f32],
    bin: &mut [u8],
) {
    let n = mag.len();
    let half = vdupq_n_f32(0.5);
    let zero = vdupq_n_f32(0.0);
    let sign = vdupq_n_u32(0x8000_0000);
    let six = vdupq_n_u32(6);
    let mut x = 1;
    while x + 4 <= n {
        // SAFETY: x + 4 ≤ n < mid.len(), so mid[x − 1 .. x + 5] and up/dn[x .. x + 4] are in
        // bounds, as are mag/bin[x .. x + 4].
        unsafe {
            let l = vld1q_f32(mid.as_ptr().add(x - 1));
            let r = vld1q_f32(mid.as_ptr().add(x + 1));
            let u = vld1q_f32(up.as_ptr().add(x));
            let d = vld1q_f32(dn.as_ptr().add(x));
            let gx = vmulq_f32(vsubq_f32(r, l), half);
            let gy = vmulq_f32(vsubq_f32(d, u), half);
            let m2 = vaddq_f32(vmulq_f32(gx, gx), vmulq_f32(gy, gy));
            vst1q_f32(mag.as_mut_ptr().add(x), vsqrtq_f32(m2));
            let neg = vorrq_u32(
                vcltq_f32(gy, zero),
                vandq_u32(vceqq_f32(gy, zero), vcltq_f32(gx, zero)),
            );
            let flip = vandq_u32(neg, sign);
            let fx = vreinterpretq_f32_u32(veorq_u32(vreinterpretq_u32_f32(gx), flip));
            let fy = vreinterpretq_f32_u32(veorq_u32(vreinterpretq_u32_f32(gy), flip));
            let mut c = vdupq_n_u32(0);
            for &(ec, es) in edges {
                let t = vsubq_f32(vmulq_f32(fy, vdupq_n_f32(ec)), vmulq_f32(fx, vdupq_n_f32(es)));
                c = vsubq_u32(c, vcgeq_f32(t, zero)); // all ones = −1
            }
            c = vbicq_u32(c, vceqq_u32(c, six));
            let b: [u32; 4] = std::mem::transmute(c);
            for (k, v) in b.iter().enumerate() {
                *bin.get_unchecked_mut(x + k) = *v as u8;
            }
        }
        x += 4;
    }
    super::scalar::grad_row_scalar(up, mid, dn, edges, x, mag, bin);
}

/// [`super::normalise`] on 4 values at a time.
///
/// # Safety
/// The three slices have one length (NEON is part of every aarch64 target).
#[target_feature(enable = "neon")]
pub(super) unsafe fn normalise(m: &[f32], n: &[f32], c: f32, out: &mut [f32]) {
    let len = out.len();
    let cv = vdupq_n_f32(c);
    let mut x = 0;
    while x + 4 <= len {
        // SAFETY: x + 4 ≤ len, the length of all three slices.
        unsafe {
            let v = vdivq_f32(
                vld1q_f32(m.as_ptr().add(x)),
                vaddq_f32(vld1q_f32(n.as_ptr().add(x)), cv),
            );
            vst1q_f32(out.as_mut_ptr().add(x), v);
        }
        x += 4;
    }
    super::scalar::normalise_scalar(m, n, c, out, x);
}
