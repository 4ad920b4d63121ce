//! Rows of half floats (the approximate pyramid's micro-cells, stored as IEEE binary16): the
//! conversions with the `isa` instructions (F16C `vcvtps2ph` / `vcvtph2ps`, NEON `fcvtn` /
//! `fcvtl`) or in software ([`f16_bits`], [`f32_from_f16`], the oracles), and the dispatch to them.

use super::super::types::{f16_bits, f32_from_f16};
use crate::kernels::Isa;

/// `out[i] = f16_bits(src[i])` (round to nearest even) for `min(len)` values, with the `isa`
/// conversion instructions (F16C `vcvtps2ph`, NEON `fcvtn`) or in software.
pub(crate) fn to_f16_row(isa: Isa, src: &[f32], out: &mut [u16]) {
    #[cfg(target_arch = "x86_64")]
    if matches!(isa, Isa::Avx2 | Isa::Avx512) && Isa::Avx2.is_available() {
        // SAFETY: F16C (part of the AVX2 path) checked on this CPU just above.
        return unsafe { f16c::to_f16_row(src, out) };
    }
    #[cfg(target_arch = "aarch64")]
    if isa == Isa::Neon && Isa::Neon.is_available() {
        // SAFETY: NEON checked on this CPU just above.
        return unsafe { neon::to_f16_row(src, out) };
    }
    let _ = isa;
    for (o, &v) in out.iter_mut().zip(src) {
        *o = f16_bits(v);
    }
}

/// `out[i] = f32_from_f16(src[i])` (exact) for `min(len)` values, with the `isa` conversion
/// instructions (F16C `vcvtph2ps`, NEON `fcvtl`) or in software.
pub(crate) fn from_f16_row(isa: Isa, src: &[u16], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if matches!(isa, Isa::Avx2 | Isa::Avx512) && Isa::Avx2.is_available() {
        // SAFETY: F16C (part of the AVX2 path) checked on this CPU just above.
        return unsafe { f16c::from_f16_row(src, out) };
    }
    #[cfg(target_arch = "aarch64")]
    if isa == Isa::Neon && Isa::Neon.is_available() {
        // SAFETY: NEON checked on this CPU just above.
        return unsafe { neon::from_f16_row(src, out) };
    }
    let _ = isa;
    for (o, &h) in out.iter_mut().zip(src) {
        *o = f32_from_f16(h);
    }
}

/// The F16C builds (part of the AVX2 path).
#[cfg(target_arch = "x86_64")]
mod f16c {
    use std::arch::x86_64::*;

    use crate::features::hog::types::{f16_bits, f32_from_f16};

    /// `out[i] = f16_bits(src[i])` with `vcvtps2ph` (round to nearest even, as [`f16_bits`]),
    /// 8 values at a time.
    ///
    /// # Safety
    /// The CPU must support F16C and AVX.
    #[target_feature(enable = "avx2,f16c")]
    pub(crate) unsafe fn to_f16_row(src: &[f32], out: &mut [u16]) {
        let n = src.len().min(out.len());
        let (src, out) = (&src[..n], &mut out[..n]);
        let mut s8 = src.chunks_exact(8);
        let mut o8 = out.chunks_exact_mut(8);
        for (s, o) in (&mut s8).zip(&mut o8) {
            // SAFETY: `s` and `o` hold 8 values each (16 and 32 bytes).
            unsafe {
                let h = _mm256_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(_mm256_loadu_ps(s.as_ptr()));
                _mm_storeu_si128(o.as_mut_ptr() as *mut __m128i, h);
            }
        }
        for (o, &v) in o8.into_remainder().iter_mut().zip(s8.remainder()) {
            *o = f16_bits(v);
        }
    }

    /// `out[i] = f32_from_f16(src[i])` with `vcvtph2ps` (exact), 8 values at a time.
    ///
    /// # Safety
    /// The CPU must support F16C and AVX.
    #[target_feature(enable = "avx2,f16c")]
    pub(crate) unsafe fn from_f16_row(src: &[u16], out: &mut [f32]) {
        let n = src.len().min(out.len());
        let (src, out) = (&src[..n], &mut out[..n]);
        let mut s8 = src.chunks_exact(8);
        let mut o8 = out.chunks_exact_mut(8);
        for (s, o) in (&mut s8).zip(&mut o8) {
            // SAFETY: `s` and `o` hold 8 values each.
            unsafe {
                let h = _mm_loadu_si128(s.as_ptr() as *const __m128i);
                _mm256_storeu_ps(o.as_mut_ptr(), _mm256_cvtph_ps(h));
            }
        }
        for (o, &h) in o8.into_remainder().iter_mut().zip(s8.remainder()) {
            *o = f32_from_f16(h);
        }
    }
}

/// The NEON builds (`fcvtn` / `fcvtl`; the lane helpers are also the NEON fill's).
#[cfg(target_arch = "aarch64")]
pub(crate) mod neon {
    use std::arch::aarch64::*;
    use std::arch::asm;

    use crate::features::hog::types::{f16_bits, f32_from_f16};

    /// Four half floats (bits) to `f32`, exactly (`fcvtl`).
    #[inline]
    #[target_feature(enable = "neon")]
    pub(crate) fn f32x4_from_f16(h: uint16x4_t) -> float32x4_t {
        let r: float32x4_t;
        // SAFETY: `fcvtl` reads and writes registers only.
        unsafe {
            asm!("fcvtl {0:v}.4s, {1:v}.4h", out(vreg) r, in(vreg) h, options(pure, nomem, nostack, preserves_flags))
        };
        r
    }

    /// Four `f32` to half-float bits, rounded to nearest even (`fcvtn`, the rounding mode Linux
    /// leaves in FPCR), as [`f16_bits`].
    #[inline]
    #[target_feature(enable = "neon")]
    pub(crate) fn f16x4_from_f32(v: float32x4_t) -> uint16x4_t {
        let r: uint16x4_t;
        // SAFETY: `fcvtn` reads and writes registers only.
        unsafe {
            asm!("fcvtn {0:v}.4h, {1:v}.4s", out(vreg) r, in(vreg) v, options(pure, nomem, nostack, preserves_flags))
        };
        r
    }

    /// `out[i] = f16_bits(src[i])` with `fcvtn`, 4 values at a time.
    ///
    /// # Safety
    /// The CPU must support NEON.
    #[target_feature(enable = "neon")]
    pub(crate) unsafe fn to_f16_row(src: &[f32], out: &mut [u16]) {
        let n = src.len().min(out.len());
        let (src, out) = (&src[..n], &mut out[..n]);
        let mut s4 = src.chunks_exact(4);
        let mut o4 = out.chunks_exact_mut(4);
        for (s, o) in (&mut s4).zip(&mut o4) {
            // SAFETY: `s` and `o` hold 4 values each.
            unsafe { vst1_u16(o.as_mut_ptr(), f16x4_from_f32(vld1q_f32(s.as_ptr()))) };
        }
        for (o, &v) in o4.into_remainder().iter_mut().zip(s4.remainder()) {
            *o = f16_bits(v);
        }
    }

    /// `out[i] = f32_from_f16(src[i])` with `fcvtl` (exact), 4 values at a time.
    ///
    /// # Safety
    /// The CPU must support NEON.
    #[target_feature(enable = "neon")]
    pub(crate) unsafe fn from_f16_row(src: &[u16], out: &mut [f32]) {
        let n = src.len().min(out.len());
        let (src, out) = (&src[..n], &mut out[..n]);
        let mut s4 = src.chunks_exact(4);
        let mut o4 = out.chunks_exact_mut(4);
        for (s, o) in (&mut s4).zip(&mut o4) {
            // SAFETY: `s` and `o` hold 4 values each.
            unsafe { vst1q_f32(o.as_mut_ptr(), f32x4_from_f16(vld1_u16(s.as_ptr()))) };
        }
        for (o, &h) in o4.into_remainder().iter_mut().zip(s4.remainder()) {
            *o = f32_from_f16(h);
        }
    }
}
