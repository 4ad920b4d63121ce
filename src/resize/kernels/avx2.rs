//! AVX2 (+FMA) rows of the bilinear resize: the horizontal pass picks each group's taps by
//! `vpermps`; the vertical pass is the scalar loop compiled for AVX2.

use std::arch::x86_64::*;

/// The pyramid's horizontal pass ([`super::horizontal_row`]) on 8 outputs at a time: when every
/// tap of a group lies in the 16 values from its first tap `p[x]` (the resize's taps are
/// nondecreasing: a group's taps fit when the resize shrinks by about 2 or less, for a plane and
/// for a mosaic's interleaved planes alike), they are picked from there by two `vpermps` and a blend; any
/// other group (taps spread wider, or too close to the end of `a`) is computed by the scalar
/// pass. The same operations in the same order (no fused multiply-add), so the same bits.
///
/// # Safety
/// The CPU must have AVX2 and FMA; `p`, `q`, `f` hold at least `out.len()` values. The loads from
/// `a` are checked here (`p[x] + 16 ≤ a.len()`); the scalar pass indexes with bounds checks.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn horizontal(a: &[f32], p: &[u32], q: &[u32], f: &[f32], out: &mut [f32]) {
    let n = out.len();
    let seven = _mm256_set1_epi32(7);
    let wide = _mm256_set1_epi32(!15);
    let mut x = 0;
    while x + 8 <= n {
        let base = p[x] as usize;
        // SAFETY: x + 8 ≤ n ≤ the taps' lengths.
        let (ip, iq) = unsafe {
            let b = _mm256_set1_epi32(base as i32);
            (
                _mm256_sub_epi32(_mm256_loadu_si256(p.as_ptr().add(x).cast()), b),
                _mm256_sub_epi32(_mm256_loadu_si256(q.as_ptr().add(x).cast()), b),
            )
        };
        // every offset from the first tap in 0..16 (a negative one has high bits set)
        let near = _mm256_testz_si256(_mm256_or_si256(ip, iq), wide) == 1;
        if near && base + 16 <= a.len() {
            // SAFETY: x + 8 ≤ n ≤ out.len(), f.len(); base + 16 ≤ a.len().
            unsafe {
                let lo = _mm256_loadu_ps(a.as_ptr().add(base));
                let hi = _mm256_loadu_ps(a.as_ptr().add(base + 8));
                let pick = |i: __m256i| {
                    let upper = _mm256_castsi256_ps(_mm256_cmpgt_epi32(i, seven));
                    _mm256_blendv_ps(
                        _mm256_permutevar8x32_ps(lo, i),
                        _mm256_permutevar8x32_ps(hi, i),
                        upper,
                    )
                };
                let (ap, aq) = (pick(ip), pick(iq));
                let fx = _mm256_loadu_ps(f.as_ptr().add(x));
                let o = _mm256_add_ps(ap, _mm256_mul_ps(_mm256_sub_ps(aq, ap), fx));
                _mm256_storeu_ps(out.as_mut_ptr().add(x), o);
            }
        } else {
            super::horizontal_row(a, p, q, f, &mut out[..x + 8], x);
        }
        x += 8;
    }
    super::horizontal_row(a, p, q, f, out, x);
}

/// The pyramid's vertical pass and factor ([`super::vertical_row`]) compiled for AVX2 + FMA (8
/// lanes wide; Rust never contracts the multiply and add into an FMA, so the same bits).
///
/// # Safety
/// The CPU must have AVX2 and FMA.
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn vertical(r0: &[f32], r1: &[f32], fy: f32, k: f32, out: &mut [f32]) {
    super::vertical_row(r0, r1, fy, k, out)
}
