//! AVX2 channel kernels (see [`super`]): 8 pixels per step, the scalar oracle for the tail.

use std::arch::x86_64::*;

use super::scalar::Edges;

/// [`super::grad_row`] on 8 pixels at a time.
///
/// # Safety
/// The CPU has AVX2; `mid.len() > mag.len()`, `up.len()`, `dn.len() ≥ mag.len() = bin.len()`.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn grad_row(
    up: &[f32],
    mid: &[f32],
    dn: &[f32],
    edges: &Edges,
    mag: &mut [f32],
    bin: &mut [u8],
) {
    let n = mag.len();
    let half = _mm256_set1_ps(0.5);
    let zero = _mm256_setzero_ps();
    let sign = _mm256_set1_ps(-0.0);
    let six = _mm256_set1_epi32(6);
    // byte 0 of each 32-bit lane, per 128-bit half
    let pick = _mm256_setr_epi8(
        0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1,
        -1, -1, -1, -1, -1,
    );
    let ec: [__m256; 6] = std::array::from_fn(|k| _mm256_set1_ps(edges[k].0));
    let es: [__m256; 6] = std::array::from_fn(|k| _mm256_set1_ps(edges[k].1));
    let mut x = 1;
    while x + 8 <= n {
        // SAFETY: x + 8 ≤ n < mid.len(), so mid[x − 1 .. x + 9] and up/dn[x .. x + 8] are in
        // bounds, as are mag/bin[x .. x + 8].
        unsafe {
            let l = _mm256_loadu_ps(mid.as_ptr().add(x - 1));
            let r = _mm256_loadu_ps(mid.as_ptr().add(x + 1));
            let u = _mm256_loadu_ps(up.as_ptr().add(x));
            let d = _mm256_loadu_ps(dn.as_ptr().add(x));
            let gx = _mm256_mul_ps(_mm256_sub_ps(r, l), half);
            let gy = _mm256_mul_ps(_mm256_sub_ps(d, u), half);
            let m2 = _mm256_add_ps(_mm256_mul_ps(gx, gx), _mm256_mul_ps(gy, gy));
            _mm256_storeu_ps(mag.as_mut_ptr().add(x), _mm256_sqrt_ps(m2));
            // fold into the upper half-plane: gy < 0, or gy = 0 and gx < 0
            let neg = _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_LT_OQ>(gy, zero),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_EQ_OQ>(gy, zero),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(gx, zero),
                ),
            );
            let flip = _mm256_and_ps(neg, sign);
            let (fx, fy) = (_mm256_xor_ps(gx, flip), _mm256_xor_ps(gy, flip));
            let mut c = _mm256_setzero_si256();
            for k in 0..6 {
                let t = _mm256_sub_ps(_mm256_mul_ps(fy, ec[k]), _mm256_mul_ps(fx, es[k]));
                c = _mm256_sub_epi32(c, _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(t, zero)));
            }
            c = _mm256_andnot_si256(_mm256_cmpeq_epi32(c, six), c);
            let p = _mm256_shuffle_epi8(c, pick);
            let v = _mm_unpacklo_epi32(_mm256_castsi256_si128(p), _mm256_extracti128_si256::<1>(p));
            _mm_storel_epi64(bin.as_mut_ptr().add(x).cast(), v);
        }
        x += 8;
    }
    super::scalar::grad_row_scalar(up, mid, dn, edges, x, mag, bin);
}

/// [`super::normalise`] on 8 values at a time.
///
/// # Safety
/// The CPU has AVX2; the three slices have one length.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn normalise(m: &[f32], n: &[f32], c: f32, out: &mut [f32]) {
    let len = out.len();
    let cv = _mm256_set1_ps(c);
    let mut x = 0;
    while x + 8 <= len {
        // SAFETY: x + 8 ≤ len, the length of all three slices.
        unsafe {
            let v = _mm256_div_ps(
                _mm256_loadu_ps(m.as_ptr().add(x)),
                _mm256_add_ps(_mm256_loadu_ps(n.as_ptr().add(x)), cv),
            );
            _mm256_storeu_ps(out.as_mut_ptr().add(x), v);
        }
        x += 8;
    }
    super::scalar::normalise_scalar(m, n, c, out, x);
}

/// [`super::taps_sum`] on 8 values at a time.
///
/// # Safety
/// The CPU has AVX2; every source holds at least `out.len()` values.
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn taps_sum(out: &mut [f32], srcs: &[&[f32]], taps: &[f32]) {
    let len = out.len();
    let mut x = 0;
    while x + 8 <= len {
        let mut acc = _mm256_setzero_ps();
        for (src, &t) in srcs.iter().zip(taps) {
            // SAFETY: x + 8 ≤ len ≤ src.len(). A product then a sum, never fused: the oracle's
            // rounding.
            acc = _mm256_add_ps(
                acc,
                _mm256_mul_ps(_mm256_set1_ps(t), unsafe { _mm256_loadu_ps(src.as_ptr().add(x)) }),
            );
        }
        // SAFETY: x + 8 ≤ len.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr().add(x), acc) };
        x += 8;
    }
    super::scalar::taps_sum_scalar(out, srcs, taps, x);
}

/// The 4x8 transposition of [`aggregate`]: from four vectors of 8 consecutive pixels (two blocks
/// each), the vectors of pixel `j = 0..4` of the 8 blocks, lanes in block order
/// `0, 2, 4, 6, 1, 3, 5, 7`.
#[inline]
#[target_feature(enable = "avx2,fma")]
fn transpose4x8(a: __m256, b: __m256, c: __m256, d: __m256) -> [__m256; 4] {
    let t0 = _mm256_unpacklo_ps(a, b);
    let t1 = _mm256_unpackhi_ps(a, b);
    let t2 = _mm256_unpacklo_ps(c, d);
    let t3 = _mm256_unpackhi_ps(c, d);
    [
        _mm256_shuffle_ps::<0x44>(t0, t2),
        _mm256_shuffle_ps::<0xEE>(t0, t2),
        _mm256_shuffle_ps::<0x44>(t1, t3),
        _mm256_shuffle_ps::<0xEE>(t1, t3),
    ]
}

/// [`super::aggregate`] on 8 blocks (32 pixels of each of the 4 rows) at a time: the pixels are
/// transposed so that each lane is one block, then added in the oracle's order (rows, then
/// pixels left to right); an orientation sum adds `+0.0` for the pixels of other bins, which
/// leaves it unchanged (the sums are never `−0.0`).
///
/// # Safety
/// The CPU has AVX2; the lengths checked by [`super::aggregate`].
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn aggregate(v: &[f32], bins: &[u8], gw: usize, inv: f32, out: &mut [f32], ostride: usize) {
    use super::scalar::BLOCK;
    let cw = gw / BLOCK;
    let invv = _mm256_set1_ps(inv);
    // lane i of a transposed vector holds block [0, 2, 4, 6, 1, 3, 5, 7][i]; this puts them back
    let unperm = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
    let ob: [__m256i; 6] = std::array::from_fn(|o| _mm256_set1_epi32(o as i32));
    let mut bx = 0;
    while bx + 8 <= cw {
        let mut acc = [_mm256_setzero_ps(); 7];
        for r in 0..BLOCK {
            let p = r * gw + bx * BLOCK;
            // SAFETY: p + 32 ≤ r·gw + cw·4 = (r + 1)·gw ≤ 4·gw ≤ v.len(), bins.len().
            let (vals, bs) = unsafe {
                let vals = transpose4x8(
                    _mm256_loadu_ps(v.as_ptr().add(p)),
                    _mm256_loadu_ps(v.as_ptr().add(p + 8)),
                    _mm256_loadu_ps(v.as_ptr().add(p + 16)),
                    _mm256_loadu_ps(v.as_ptr().add(p + 24)),
                );
                let b = |q: usize| {
                    _mm256_castsi256_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(
                        bins.as_ptr().add(p + 8 * q).cast(),
                    )))
                };
                (vals, transpose4x8(b(0), b(1), b(2), b(3)))
            };
            for (d, b) in vals.iter().zip(bs) {
                acc[0] = _mm256_add_ps(acc[0], *d);
                let b = _mm256_castps_si256(b);
                for o in 0..6 {
                    let m = _mm256_castsi256_ps(_mm256_cmpeq_epi32(b, ob[o]));
                    acc[1 + o] = _mm256_add_ps(acc[1 + o], _mm256_and_ps(m, *d));
                }
            }
        }
        for (k, a) in acc.iter().enumerate() {
            let r = _mm256_permutevar8x32_ps(_mm256_mul_ps(*a, invv), unperm);
            // SAFETY: k·ostride + bx + 8 ≤ 6·ostride + cw ≤ out.len() (checked by the caller).
            unsafe { _mm256_storeu_ps(out.as_mut_ptr().add(k * ostride + bx), r) };
        }
        bx += 8;
    }
    super::scalar::aggregate_scalar(v, bins, gw, inv, out, ostride, bx);
}

/// [`super::luv_row`] on 8 values at a time (`Y^⅓` lane by lane through `f32::cbrt`, the
/// oracle's function); the arithmetic of `luv_from_rgb` in its order.
///
/// # Safety
/// The CPU has AVX2; the six slices have the same length (checked by [`super::luv_row`]).
#[target_feature(enable = "avx2,fma")]
pub(super) unsafe fn luv_row(rgb: [&[f32]; 3], luv: [&mut [f32]; 3]) {
    use super::scalar::{
        LUV_A, LUV_MAXI, LUV_MB, LUV_MG, LUV_MINU, LUV_MINV, LUV_MR, LUV_UN, LUV_VN, LUV_Y0,
    };
    let [r, g, b] = rgb;
    let [l, u, v] = luv;
    let n = l.len();
    let k = |c: f32| _mm256_set1_ps(c);
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY: i + 8 ≤ n, the length of every slice.
        let (rv, gv, bv) = unsafe {
            (
                _mm256_loadu_ps(r.as_ptr().add(i)),
                _mm256_loadu_ps(g.as_ptr().add(i)),
                _mm256_loadu_ps(b.as_ptr().add(i)),
            )
        };
        let dot = |m: usize| {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(k(LUV_MR[m]), rv), _mm256_mul_ps(k(LUV_MG[m]), gv)),
                _mm256_mul_ps(k(LUV_MB[m]), bv),
            )
        };
        let (x, y, z) = (dot(0), dot(1), dot(2));
        let above = _mm256_cmp_ps::<_CMP_GT_OQ>(y, k(LUV_Y0));
        let lanes = _mm256_movemask_ps(above);
        let mut ys = [0.0f32; 8];
        // SAFETY: 8 values into an array of 8.
        unsafe { _mm256_storeu_ps(ys.as_mut_ptr(), y) };
        let mut cb = [0.0f32; 8];
        for (j, (c, y)) in cb.iter_mut().zip(ys).enumerate() {
            if lanes >> j & 1 != 0 {
                *c = y.cbrt();
            }
        }
        // SAFETY: 8 values from an array of 8.
        let cb = unsafe { _mm256_loadu_ps(cb.as_ptr()) };
        let lc = _mm256_sub_ps(_mm256_mul_ps(k(116.0), cb), k(16.0));
        let lv = _mm256_mul_ps(
            _mm256_blendv_ps(_mm256_mul_ps(y, k(LUV_A)), lc, above),
            k(LUV_MAXI),
        );
        let den = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_add_ps(x, _mm256_mul_ps(k(15.0), y)),
                _mm256_mul_ps(k(3.0), z),
            ),
            k(1e-35),
        );
        let d = _mm256_div_ps(k(1.0), den);
        let uv = _mm256_sub_ps(
            _mm256_mul_ps(
                lv,
                _mm256_sub_ps(_mm256_mul_ps(_mm256_mul_ps(k(52.0), x), d), k(13.0 * LUV_UN)),
            ),
            k(LUV_MINU),
        );
        let vv = _mm256_sub_ps(
            _mm256_mul_ps(
                lv,
                _mm256_sub_ps(_mm256_mul_ps(_mm256_mul_ps(k(117.0), y), d), k(13.0 * LUV_VN)),
            ),
            k(LUV_MINV),
        );
        // SAFETY: i + 8 ≤ n.
        unsafe {
            _mm256_storeu_ps(l.as_mut_ptr().add(i), lv);
            _mm256_storeu_ps(u.as_mut_ptr().add(i), uv);
            _mm256_storeu_ps(v.as_mut_ptr().add(i), vv);
        }
        i += 8;
    }
    super::scalar::luv_row_scalar([r, g, b], [l, u, v], i);
}
