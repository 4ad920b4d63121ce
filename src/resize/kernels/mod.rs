//! Per-instruction-set rows of the bilinear resize ([`super`]): every intrinsic of the resize
//! lives here, one file per ISA, with the scalar row loops that are every path's reference and
//! the SIMD passes' tails. [`super`] chooses a path from [`crate::kernels::isa`], checks the lengths
//! once per call and keeps the tests; the kernels here only compute (their `# Safety` sections name
//! the CPU features and the lengths their callers check).
//!
//! | pass | scalar (oracle) | AVX2 | AVX-512 | NEON |
//! |---|---|---|---|---|
//! | horizontal | plain loop | 8 outputs from 16 loaded values (`vpermps`) | 16 outputs by `vpermt2ps` taps ([`Perm16`]) | 4 outputs from 8 loaded values (`tbl`) |
//! | vertical (and factor) | plain loop | the loop compiled for AVX2 | (AVX2's) | 4 lanes |
//!
//! No path fuses a multiply and an add, so every path gives the scalar loop's bits.

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;
#[cfg(target_arch = "aarch64")]
pub(crate) mod neon;

/// Prefetch every cache line of `row` into L2 (no effect on results; nothing on other targets).
pub(crate) fn prefetch_row(row: &[f32]) {
    #[cfg(target_arch = "x86_64")]
    for k in (0..row.len()).step_by(16) {
        // SAFETY: prefetching an address inside a live slice has no side effects (SSE, part of
        // the x86-64 baseline).
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T1 }>(row.as_ptr().add(k).cast())
        };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = row;
}

/// The column taps of 16 consecutive outputs whose sources all lie in the `32·pairs` values from
/// `base`: the AVX-512 horizontal pass loads those values (`2·pairs` registers) and picks each
/// output's two taps with `vpermt2ps`, one per pair of registers, keeping the pair that holds the
/// tap (no gathers).
// Read only by the AVX-512 pass: built (and tested) everywhere, used on x86-64.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
#[derive(Debug, Clone, Copy)]
pub(crate) struct Perm16 {
    /// First source value of the window.
    pub(crate) base: u32,
    /// Register pairs (of 32 values) the window spans.
    pub(crate) pairs: u32,
    /// Offsets of the left taps from `base` (< `32·pairs`).
    pub(crate) p: [u32; 16],
    /// Offsets of the right taps from `base`.
    pub(crate) q: [u32; 16],
    /// Weights of the right taps.
    pub(crate) fx: [f32; 16],
}

/// The scalar horizontal pass of the bilinear resize from output `from` on (the reference of every
/// path, and the SIMD passes' tails and fallbacks): `out[x] = a[p[x]] + (a[q[x]] − a[p[x]])·f[x]`.
#[inline(always)]
pub(crate) fn horizontal_row(a: &[f32], p: &[u32], q: &[u32], f: &[f32], out: &mut [f32], from: usize) {
    for x in from..out.len() {
        let (ap, aq) = (a[p[x] as usize], a[q[x] as usize]);
        out[x] = ap + (aq - ap) * f[x];
    }
}

/// The scalar vertical pass and a factor (the reference of every path):
/// `out[x] = (r0[x] + (r1[x] − r0[x])·fy)·k`, each operation rounded on its own (`k = 1` leaves
/// the interpolation's bits unchanged: a product by one is exact).
#[inline(always)]
pub(crate) fn vertical_row(r0: &[f32], r1: &[f32], fy: f32, k: f32, out: &mut [f32]) {
    for ((o, &v0), &v1) in out.iter_mut().zip(r0).zip(r1) {
        *o = (v0 + (v1 - v0) * fy) * k;
    }
}
