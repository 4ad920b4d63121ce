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

/// [`super::taps_sum`] on 4 values at a time.
///
/// # Safety
/// Every source holds at least `out.len()` values (NEON is part of every aarch64 target).
#[target_feature(enable = "neon")]
pub(super) unsafe fn taps_sum(out: &mut [f32], srcs: &[&[f32]], taps: &[f32]) {
    let len = out.len();
    let mut x = 0;
    while x + 4 <= len {
        let mut acc = vdupq_n_f32(0.0);
        for (src, &t) in srcs.iter().zip(taps) {
            // SAFETY: x + 4 ≤ len ≤ src.len(). A product then a sum, never fused: the oracle's
            // rounding.
            acc = vaddq_f32(
                acc,
                vmulq_f32(vdupq_n_f32(t), unsafe { vld1q_f32(src.as_ptr().add(x)) }),
            );
        }
        // SAFETY: x + 4 ≤ len.
        unsafe { vst1q_f32(out.as_mut_ptr().add(x), acc) };
        x += 4;
    }
    super::scalar::taps_sum_scalar(out, srcs, taps, x);
}

/// [`super::aggregate`] on 8 blocks (32 pixels of each of the 4 rows) at a time: `vld4` splits
/// the pixels so that each lane is one block, then they are added in the oracle's order (rows,
/// then pixels left to right); an orientation sum adds `+0.0` for the pixels of other bins,
/// which leaves it unchanged (the sums are never `−0.0`).
///
/// # Safety
/// The lengths checked by [`super::aggregate`] (NEON is part of every aarch64 target).
#[target_feature(enable = "neon")]
pub(super) unsafe fn aggregate(v: &[f32], bins: &[u8], gw: usize, inv: f32, out: &mut [f32], ostride: usize) {
    use super::scalar::BLOCK;
    let cw = gw / BLOCK;
    let invv = vdupq_n_f32(inv);
    let mut bx = 0;
    while bx + 8 <= cw {
        // two halves of 4 blocks
        let mut acc = [[vdupq_n_f32(0.0); 7]; 2];
        for r in 0..BLOCK {
            let p = r * gw + bx * BLOCK;
            // SAFETY: p + 32 ≤ r·gw + cw·4 = (r + 1)·gw ≤ 4·gw ≤ v.len(), bins.len().
            let (lo, hi, b) = unsafe {
                (
                    vld4q_f32(v.as_ptr().add(p)),
                    vld4q_f32(v.as_ptr().add(p + 16)),
                    vld4_u8(bins.as_ptr().add(p)),
                )
            };
            let vals = [[lo.0, lo.1, lo.2, lo.3], [hi.0, hi.1, hi.2, hi.3]];
            for (j, bj) in [b.0, b.1, b.2, b.3].into_iter().enumerate() {
                let w = vmovl_u8(bj);
                let bh = [vmovl_u16(vget_low_u16(w)), vmovl_high_u16(w)];
                for h in 0..2 {
                    let d = vals[h][j];
                    acc[h][0] = vaddq_f32(acc[h][0], d);
                    for o in 0..6 {
                        let m = vceqq_u32(bh[h], vdupq_n_u32(o as u32));
                        let dm = vreinterpretq_f32_u32(vandq_u32(m, vreinterpretq_u32_f32(d)));
                        acc[h][1 + o] = vaddq_f32(acc[h][1 + o], dm);
                    }
                }
            }
        }
        for (h, acc) in acc.iter().enumerate() {
            for (k, a) in acc.iter().enumerate() {
                // SAFETY: k·ostride + bx + 8 ≤ 6·ostride + cw ≤ out.len() (checked by the caller).
                unsafe {
                    vst1q_f32(
                        out.as_mut_ptr().add(k * ostride + bx + 4 * h),
                        vmulq_f32(*a, invv),
                    )
                };
            }
        }
        bx += 8;
    }
    super::scalar::aggregate_scalar(v, bins, gw, inv, out, ostride, bx);
}

/// [`super::luv_row`] on 4 values at a time (`Y^⅓` lane by lane through `f32::cbrt`, the
/// oracle's function); the arithmetic of `luv_from_rgb` in its order.
///
/// # Safety
/// The six slices have the same length (checked by [`super::luv_row`]; NEON is part of every
/// aarch64 target).
#[target_feature(enable = "neon")]
pub(super) unsafe fn luv_row(rgb: [&[f32]; 3], luv: [&mut [f32]; 3]) {
    use super::scalar::{
        LUV_A, LUV_MAXI, LUV_MB, LUV_MG, LUV_MINU, LUV_MINV, LUV_MR, LUV_UN, LUV_VN, LUV_Y0,
    };
    let [r, g, b] = rgb;
    let [l, u, v] = luv;
    let n = l.len();
    let k = |c: f32| vdupq_n_f32(c);
    let mut i = 0;
    while i + 4 <= n {
        // SAFETY: i + 4 ≤ n, the length of every slice.
        let (rv, gv, bv) = unsafe {
            (
                vld1q_f32(r.as_ptr().add(i)),
                vld1q_f32(g.as_ptr().add(i)),
                vld1q_f32(b.as_ptr().add(i)),
            )
        };
        let dot = |m: usize| {
            vaddq_f32(
                vaddq_f32(vmulq_f32(k(LUV_MR[m]), rv), vmulq_f32(k(LUV_MG[m]), gv)),
                vmulq_f32(k(LUV_MB[m]), bv),
            )
        };
        let (x, y, z) = (dot(0), dot(1), dot(2));
        let above = vcgtq_f32(y, k(LUV_Y0));
        let (mut ys, mut ab) = ([0.0f32; 4], [0u32; 4]);
        // SAFETY: 4 values into arrays of 4.
        unsafe {
            vst1q_f32(ys.as_mut_ptr(), y);
            vst1q_u32(ab.as_mut_ptr(), above);
        }
        let mut cb = [0.0f32; 4];
        for ((c, y), a) in cb.iter_mut().zip(ys).zip(ab) {
            if a != 0 {
                *c = y.cbrt();
            }
        }
        // SAFETY: 4 values from an array of 4.
        let cb = unsafe { vld1q_f32(cb.as_ptr()) };
        let lc = vsubq_f32(vmulq_f32(k(116.0), cb), k(16.0));
        let lv = vmulq_f32(vbslq_f32(above, lc, vmulq_f32(y, k(LUV_A))), k(LUV_MAXI));
        let den = vaddq_f32(
            vaddq_f32(vaddq_f32(x, vmulq_f32(k(15.0), y)), vmulq_f32(k(3.0), z)),
            k(1e-35),
        );
        let d = vdivq_f32(k(1.0), den);
        let uv = vsubq_f32(
            vmulq_f32(
                lv,
                vsubq_f32(vmulq_f32(vmulq_f32(k(52.0), x), d), k(13.0 * LUV_UN)),
            ),
            k(LUV_MINU),
        );
        let vv = vsubq_f32(
            vmulq_f32(
                lv,
                vsubq_f32(vmulq_f32(vmulq_f32(k(117.0), y), d), k(13.0 * LUV_VN)),
            ),
            k(LUV_MINV),
        );
        // SAFETY: i + 4 ≤ n.
        unsafe {
            vst1q_f32(l.as_mut_ptr().add(i), lv);
            vst1q_f32(u.as_mut_ptr().add(i), uv);
            vst1q_f32(v.as_mut_ptr().add(i), vv);
        }
        i += 4;
    }
    super::scalar::luv_row_scalar([r, g, b], [l, u, v], i);
}
