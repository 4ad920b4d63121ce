//! NEON (aarch64 Advanced SIMD) kernels of the SVM stage.
//!
//! # The 8-bit products
//! NEON has no u8·i8 dot product below Armv8.6 (`usdot`, FEAT_I8MM), so the block values are
//! shifted into i8 on load, `v − 128` (an `eor` with 0x80), and the shift is added back per block
//! position: `Σ_i v_i·w_i = Σ_i (v_i − 128)·w_i + 128·Σ_i w_i`, the last term a per-position
//! constant `corr[k]` computed once per model. Every product is exact: `|(v − 128)·w| ≤ 128·127`
//! fits i16 (`smull`), and the sums stay far inside i32.
//! - With the dot-product extension (`features().dotprod`: Cortex-A55/A76 and later, Jetson
//!   Orin), `sdot` by element adds four i8·i8 products per i32 lane. Its intrinsic `vdotq_s32`
//!   is still unstable in Rust 1.95 (`stdarch_neon_dotprod`), so the instruction is written as
//!   inline assembly.
//! - Without it, `smull`/`smull2` multiply eight i8 pairs into i16 and `sadalp` adds neighbouring
//!   pairs into i32 lanes; a final `addp` folds the two lanes of each block.

use std::arch::aarch64::*;
use std::arch::asm;

use super::quantise_block_value;
use super::TILE_K_NARROW;

/// f32 block products `out[k·nbxp + x] = Σ_{i<bl} bt[i·nbxp + x] · wt[i·nkp + k]` (`fmla` by lane:
/// fused, `i` ascending from 0, the scalar reference's bits), 8 columns and 12 block positions
/// per tile.
///
/// # Safety
/// `nbxp` is a multiple of 8, `bt.len() ≥ bl·nbxp`, `wt.len() ≥ bl·nkp`,
/// `nkp ≥ ⌈nk/12⌉·12`, `out.len() ≥ nk·nbxp`.
#[target_feature(enable = "neon")]
pub(crate) unsafe fn products_f32(
    bt: &[f32],
    wt: &[f32],
    bl: usize,
    nk: usize,
    nkp: usize,
    nbxp: usize,
    out: &mut [f32],
) {
    for x in (0..nbxp).step_by(8) {
        for k0 in (0..nk).step_by(TILE_K_NARROW) {
            let mut acc = [[vdupq_n_f32(0.0); 2]; TILE_K_NARROW];
            for i in 0..bl {
                // SAFETY: x + 8 ≤ nbxp and i < bl: inside bt (bl·nbxp); k0 + 12 ≤ nkp: the three
                // weight vectors are inside wt (bl·nkp).
                let (b0, b1, wr) = unsafe {
                    let p = bt.as_ptr().add(i * nbxp + x);
                    (vld1q_f32(p), vld1q_f32(p.add(4)), wt.as_ptr().add(i * nkp + k0))
                };
                for (t, a) in acc.chunks_exact_mut(4).enumerate() {
                    let w = unsafe { vld1q_f32(wr.add(4 * t)) };
                    a[0] = [
                        vfmaq_laneq_f32::<0>(a[0][0], b0, w),
                        vfmaq_laneq_f32::<0>(a[0][1], b1, w),
                    ];
                    a[1] = [
                        vfmaq_laneq_f32::<1>(a[1][0], b0, w),
                        vfmaq_laneq_f32::<1>(a[1][1], b1, w),
                    ];
                    a[2] = [
                        vfmaq_laneq_f32::<2>(a[2][0], b0, w),
                        vfmaq_laneq_f32::<2>(a[2][1], b1, w),
                    ];
                    a[3] = [
                        vfmaq_laneq_f32::<3>(a[3][0], b0, w),
                        vfmaq_laneq_f32::<3>(a[3][1], b1, w),
                    ];
                }
            }
            for (j, a) in acc.iter().enumerate().filter(|(j, _)| k0 + j < nk) {
                // SAFETY: k0 + j < nk and x + 8 ≤ nbxp: inside out (nk·nbxp).
                unsafe {
                    let p = out.as_mut_ptr().add((k0 + j) * nbxp + x);
                    vst1q_f32(p, a[0]);
                    vst1q_f32(p.add(4), a[1]);
                }
            }
        }
    }
}

/// `acc + sdot(b, w.4b[L])`: four i8·i8 products of each block with the weights of dword lane `L`.
#[target_feature(enable = "neon,dotprod")]
#[inline]
fn sdot_lane<const L: i32>(acc: int32x4_t, b: int8x16_t, w: int8x16_t) -> int32x4_t {
    let mut a = acc;
    // SAFETY: `sdot` (FEAT_DotProd, enabled on this function) reads two vector registers and
    // updates a third; no memory, no flags.
    unsafe {
        asm!(
            "sdot {a:v}.4s, {b:v}.16b, {w:v}.4b[{l}]",
            a = inout(vreg) a,
            b = in(vreg) b,
            w = in(vreg) w,
            l = const L,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    a
}

/// 8-bit products over the byte layout with `sdot` (module docs): `out[k·nbxp + x]` =
/// `Σ_g sdot(btq[g][x] ^ 0x80, wq[g][k]) + corr[k]`, 8 columns and 12 positions per tile.
///
/// # Safety
/// The CPU must have the dot-product extension. `nbxp` is a multiple of 8,
/// `btq.len() ≥ ng·nbxp`, `wq.len() ≥ ng·nkp`, `nkp ≥ ⌈nk/12⌉·12`, `corr.len() ≥ nk`,
/// `out.len() ≥ nk·nbxp`.
#[target_feature(enable = "neon,dotprod")]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn products_bytes_sdot(
    btq: &[u32],
    wq: &[u32],
    corr: &[i32],
    ng: usize,
    nk: usize,
    nkp: usize,
    nbxp: usize,
    out: &mut [i32],
) {
    let flip = vdupq_n_u8(0x80);
    for x in (0..nbxp).step_by(8) {
        for k0 in (0..nk).step_by(TILE_K_NARROW) {
            let mut acc = [[vdupq_n_s32(0); 2]; TILE_K_NARROW];
            for g in 0..ng {
                // SAFETY: x + 8 ≤ nbxp and g < ng: the 8 dwords are inside btq (ng·nbxp);
                // k0 + 12 ≤ nkp: the three weight vectors are inside wq (ng·nkp).
                let (b0, b1, wr) = unsafe {
                    let p = btq.as_ptr().add(g * nbxp + x).cast::<u8>();
                    (
                        vreinterpretq_s8_u8(veorq_u8(vld1q_u8(p), flip)),
                        vreinterpretq_s8_u8(veorq_u8(vld1q_u8(p.add(16)), flip)),
                        wq.as_ptr().add(g * nkp + k0),
                    )
                };
                for (t, a) in acc.chunks_exact_mut(4).enumerate() {
                    let w = vreinterpretq_s8_u32(unsafe { vld1q_u32(wr.add(4 * t)) });
                    a[0] = [sdot_lane::<0>(a[0][0], b0, w), sdot_lane::<0>(a[0][1], b1, w)];
                    a[1] = [sdot_lane::<1>(a[1][0], b0, w), sdot_lane::<1>(a[1][1], b1, w)];
                    a[2] = [sdot_lane::<2>(a[2][0], b0, w), sdot_lane::<2>(a[2][1], b1, w)];
                    a[3] = [sdot_lane::<3>(a[3][0], b0, w), sdot_lane::<3>(a[3][1], b1, w)];
                }
            }
            for (j, a) in acc.iter().enumerate().filter(|(j, _)| k0 + j < nk) {
                let c = vdupq_n_s32(corr[k0 + j]);
                // SAFETY: k0 + j < nk and x + 8 ≤ nbxp: inside out (nk·nbxp).
                unsafe {
                    let p = out.as_mut_ptr().add((k0 + j) * nbxp + x);
                    vst1q_s32(p, vaddq_s32(a[0], c));
                    vst1q_s32(p.add(4), vaddq_s32(a[1], c));
                }
            }
        }
    }
}

/// 8-bit products over the byte layout without the dot product (module docs): `smull`/`smull2`
/// and `sadalp` per dword group and block position, then `addp`; 4 columns and 12 positions per
/// tile.
///
/// # Safety
/// As [`products_bytes_sdot`], on any aarch64 CPU; `nbxp` a multiple of 4.
#[target_feature(enable = "neon")]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn products_bytes_smull(
    btq: &[u32],
    wq: &[u32],
    corr: &[i32],
    ng: usize,
    nk: usize,
    nkp: usize,
    nbxp: usize,
    out: &mut [i32],
) {
    let flip = vdupq_n_u8(0x80);
    for x in (0..nbxp).step_by(4) {
        for k0 in (0..nk).step_by(TILE_K_NARROW) {
            // acc[j] = [blocks x, x+1 (two lanes each), blocks x+2, x+3].
            let mut acc = [[vdupq_n_s32(0); 2]; TILE_K_NARROW];
            for g in 0..ng {
                // SAFETY: x + 4 ≤ nbxp and g < ng: the 4 dwords are inside btq (ng·nbxp);
                // k0 + 12 ≤ nkp: inside wq (ng·nkp).
                let (b, wr) = unsafe {
                    let p = btq.as_ptr().add(g * nbxp + x).cast::<u8>();
                    (
                        vreinterpretq_s8_u8(veorq_u8(vld1q_u8(p), flip)),
                        wq.as_ptr().add(g * nkp + k0),
                    )
                };
                let bl = vget_low_s8(b);
                for (j, a) in acc.iter_mut().enumerate() {
                    let w = vreinterpretq_s8_u32(vdupq_n_u32(unsafe { *wr.add(j) }));
                    a[0] = vpadalq_s16(a[0], vmull_s8(bl, vget_low_s8(w)));
                    a[1] = vpadalq_s16(a[1], vmull_high_s8(b, w));
                }
            }
            for (j, a) in acc.iter().enumerate().filter(|(j, _)| k0 + j < nk) {
                let s = vaddq_s32(vpaddq_s32(a[0], a[1]), vdupq_n_s32(corr[k0 + j]));
                // SAFETY: k0 + j < nk and x + 4 ≤ nbxp: inside out (nk·nbxp).
                unsafe { vst1q_s32(out.as_mut_ptr().add((k0 + j) * nbxp + x), s) };
            }
        }
    }
}

/// `q[i] = quantise_block_value(row[i])` for `i < n`, 4 at a time: `fmaxnm` with 0 turns NaN into
/// 0 as the scalar clamp-then-cast does, `fcvtnu` rounds to nearest even like it.
///
/// # Safety
/// `row.len() ≥ n` and `q.len() ≥ n`.
#[target_feature(enable = "neon")]
pub(crate) unsafe fn quantise_values(row: &[f32], n: usize, q: &mut [u8]) {
    let scale = vdupq_n_f32(super::BLOCK_QUANT_SCALE);
    let zero = vdupq_n_f32(0.0);
    let whole = n / 8 * 8;
    for i in (0..whole).step_by(8) {
        // SAFETY: i + 8 ≤ n ≤ row.len(), and the 8-byte store ends at i + 8 ≤ n ≤ q.len().
        unsafe {
            let p = row.as_ptr().add(i);
            let m0 = vminq_f32(vmaxnmq_f32(vmulq_f32(vld1q_f32(p), scale), zero), scale);
            let m1 = vminq_f32(vmaxnmq_f32(vmulq_f32(vld1q_f32(p.add(4)), scale), zero), scale);
            let h = vcombine_u16(vmovn_u32(vcvtnq_u32_f32(m0)), vmovn_u32(vcvtnq_u32_f32(m1)));
            vst1_u8(q.as_mut_ptr().add(i), vmovn_u16(h));
        }
    }
    for (d, &v) in q[whole..n].iter_mut().zip(&row[whole..n]) {
        *d = quantise_block_value(v);
    }
}
