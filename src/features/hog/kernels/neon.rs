//! The NEON builds of the HOG kernels (aarch64: Jetson Orin, Raspberry Pi 5, RK3588): the cell
//! histograms with micro-cells pooled in the same pass, and the approximated levels' fill, with
//! each cell's histograms accumulated in 128-bit registers (`R` = ⌈nbins / 4⌉ registers per
//! histogram), and the half-float conversions by `fcvtn` / `fcvtl`. The gradient, gamma and block
//! passes are the portable kernels, which LLVM vectorises for NEON (every aarch64 CPU has it).
//!
//! The register kernels mirror the AVX2 ones ([`super`] for the scheme): a pixel's two votes
//! become the one-hot vector `w0·e(b0) + w1·e(b1)`, here by a byte table lookup (`tbl`) of
//! `[w0, w1, +0, +0]` whose out-of-range indices give zero bytes; each lane then sees the fused
//! multiply-adds (`fmla`) of the scalar code in its order, so the results are the same bits.
//!
//! Every function here needs NEON; its callers in `kernels` check it first.

use std::arch::aarch64::*;
use std::arch::asm;

use super::super::approx::{self, MicroGrid, Taps, LEFT_PROFILES, RIGHT_PROFILES};
use super::super::cells::{cell_len, cell_slot, live_profiles};
use super::super::gradient::{gradient_row, CellScratch};
use super::super::input::Planes;
use super::super::{HogSpec, CELL_SIZE, PROFILES};

/// Four half floats (bits) to `f32`, exactly (`fcvtl`).
#[target_feature(enable = "neon")]
fn f32x4_from_f16(h: uint16x4_t) -> float32x4_t {
    let r: float32x4_t;
    // SAFETY: `fcvtl` reads and writes registers only.
    unsafe {
        asm!("fcvtl {0:v}.4s, {1:v}.4h", out(vreg) r, in(vreg) h, options(pure, nomem, nostack, preserves_flags))
    };
    r
}

/// Four `f32` to half-float bits, rounded to nearest even (`fcvtn`, the rounding mode Linux
/// leaves in FPCR), as `approx::f16_bits`.
#[target_feature(enable = "neon")]
fn f16x4_from_f32(v: float32x4_t) -> uint16x4_t {
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
        *o = approx::f16_bits(v);
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
        *o = approx::f32_from_f16(h);
    }
}

/// The first `dst.len()` (≤ 4·R) lanes of `v` into `dst`.
#[target_feature(enable = "neon")]
fn store_lanes<const R: usize>(v: &[float32x4_t; R], dst: &mut [f32]) {
    let mut t = [[0.0f32; 4]; R];
    for (r, x) in v.iter().enumerate() {
        // SAFETY: `t[r]` holds 4 floats.
        unsafe { vst1q_f32(t[r].as_mut_ptr(), *x) };
    }
    dst.copy_from_slice(&t.as_flattened()[..dst.len()]);
}

/// The one-hot vote byte tables: `tbl` of `[w0, w1, +0, +0]` (as bytes) with `idx[b0][r]` puts
/// `w0` in bin `b0`, `w1` in bin `(b0 + 1) mod nb` and zero bytes (index 255) elsewhere, for the
/// bins `4r .. 4r + 4` of register `r`.
#[target_feature(enable = "neon")]
fn vote_tables<const R: usize>(nb: usize) -> [[uint8x16_t; R]; 16] {
    let mut t = [[[255u8; 16]; R]; 16];
    for (b0, regs) in t.iter_mut().enumerate().take(nb) {
        let b1 = (b0 + 1) % nb;
        for (r, bytes) in regs.iter_mut().enumerate() {
            for l in 0..4 {
                let bin = 4 * r + l;
                let src = if bin == b0 {
                    Some(0u8)
                } else if bin == b1 {
                    Some(4)
                } else {
                    None
                };
                if let Some(s) = src {
                    for k in 0..4 {
                        bytes[4 * l + k] = s + k as u8;
                    }
                }
            }
        }
    }
    // SAFETY: every `bytes` array holds 16 bytes.
    t.map(|regs| regs.map(|bytes| unsafe { vld1q_u8(bytes.as_ptr()) }))
}

/// A pixel's two votes `w` as the one-hot vector `w0·e(b0) + w1·e(b1)`, by the byte tables
/// `t` of its bin `b0` ([`vote_tables`]).
#[target_feature(enable = "neon")]
#[inline]
fn vote<const R: usize>(t: &[uint8x16_t; R], [w0, w1]: [f32; 2]) -> [float32x4_t; R] {
    let pair = [w0, w1, 0.0, 0.0];
    // SAFETY: `pair` holds 4 floats.
    let s = vreinterpretq_u8_f32(unsafe { vld1q_f32(pair.as_ptr()) });
    let mut v = [vdupq_n_f32(0.0); R];
    for (x, idx) in v.iter_mut().zip(t) {
        *x = vreinterpretq_f32_u8(vqtbl1q_u8(s, *idx));
    }
    v
}

/// The `R` registers of the half floats `at .. at + 4R` of `data`, as `f32` (halves past its end
/// read as +0).
#[target_feature(enable = "neon")]
#[inline]
fn load_halves<const R: usize>(data: &[u16], at: usize) -> [float32x4_t; R] {
    let mut out = [vdupq_n_f32(0.0); R];
    for (r, o) in out.iter_mut().enumerate() {
        let a = at + 4 * r;
        let h = if a + 4 <= data.len() {
            // SAFETY: 4 half floats at `a` are inside `data`.
            unsafe { vld1_u16(data[a..a + 4].as_ptr()) }
        } else {
            let mut t = [0u16; 4];
            let n = data.len().saturating_sub(a).min(4);
            t[..n].copy_from_slice(&data[a..a + n]);
            // SAFETY: `t` holds 4 half floats.
            unsafe { vld1_u16(t.as_ptr()) }
        };
        *o = f32x4_from_f16(h);
    }
    out
}

/// The cell rows from `cy0` on (as many as `chunk` holds) with each cell's votes in registers.
///
/// # Safety
/// The CPU must support NEON; `spec` has ≤ 16 bins and its profiles have the fixed zeros
/// (`cells::profiles_have_fixed_zeros`).
#[target_feature(enable = "neon")]
pub(crate) unsafe fn cells_strip(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
) {
    // SAFETY: this function's contract; R registers hold 4R ≥ nbins bins.
    unsafe {
        match spec.nbins().div_ceil(4) {
            0 | 1 => cells_body::<false, 1>(spec, p, cy0, chunk, cs, &mut []),
            2 => cells_body::<false, 2>(spec, p, cy0, chunk, cs, &mut []),
            3 => cells_body::<false, 3>(spec, p, cy0, chunk, cs, &mut []),
            _ => cells_body::<false, 4>(spec, p, cy0, chunk, cs, &mut []),
        }
    }
}

/// [`cells_strip`] for one cell row `cy` that also pools its 4 rows of 2x2-pixel micro-cells into
/// `micro` from the same votes (the bits of `approx::micro_rows`).
///
/// # Safety
/// As [`cells_strip`]; `chunk` is one cell row and `micro` holds its 4 micro rows; the scratch
/// rows hold `8 · 2·(p.width / 2)` pixels.
#[target_feature(enable = "neon")]
pub(crate) unsafe fn cells_micro_row(
    spec: &HogSpec,
    p: &Planes,
    cy: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    // SAFETY: this function's contract; R registers hold 4R ≥ nbins bins.
    unsafe {
        match spec.nbins().div_ceil(4) {
            0 | 1 => cells_body::<true, 1>(spec, p, cy, chunk, cs, micro),
            2 => cells_body::<true, 2>(spec, p, cy, chunk, cs, micro),
            3 => cells_body::<true, 3>(spec, p, cy, chunk, cs, micro),
            _ => cells_body::<true, 4>(spec, p, cy, chunk, cs, micro),
        }
    }
}

/// The body of [`cells_strip`] and [`cells_micro_row`] with `R` 4-lane registers per histogram
/// (the AVX2 body's scheme: row accumulators per pixel row, then the cell's histograms one
/// x-profile at a time).
///
/// # Safety
/// As [`cells_micro_row`] when `MICRO`, else as [`cells_strip`]; `nb ≤ 4R`.
#[target_feature(enable = "neon")]
unsafe fn cells_body<const MICRO: bool, const R: usize>(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    let nb = spec.nbins();
    debug_assert!(nb <= 4 * R);
    let ncx = p.width / CELL_SIZE;
    let cl = cell_len(nb);
    let nmx = p.width / 2;
    const PER_CELL: usize = CELL_SIZE / 2;
    const HALF: usize = CELL_SIZE / 2;
    let stride = if MICRO { nmx * 2 } else { ncx * CELL_SIZE };
    let CellScratch { bins, wts, sc } = cs;
    let prof = spec.profile;
    let tables = vote_tables::<R>(nb);
    let zero = vdupq_n_f32(0.0);
    // Row accumulators of a cell's 8 pixel rows, [row][x-profile][register], and the vote vectors
    // of its pixels (MICRO only), [row][column][register]: every value is written per cell.
    let mut rows = [[[zero; R]; PROFILES]; CELL_SIZE];
    let mut votes = [[[zero; R]; CELL_SIZE]; CELL_SIZE];
    for (k, cell_row) in chunk.chunks_mut(ncx * cl).enumerate() {
        let cy = cy0 + k;
        for i in 0..CELL_SIZE {
            let r = i * stride..(i + 1) * stride;
            gradient_row(p, cy * CELL_SIZE + i, nb, sc, &mut bins[r.clone()], &mut wts[r]);
        }
        for (cx, cell) in cell_row.chunks_exact_mut(cl).enumerate() {
            for (i, row_acc) in rows.iter_mut().enumerate() {
                let o = i * stride + cx * CELL_SIZE;
                let (b, w) = (&bins[o..o + CELL_SIZE], &wts[o..o + CELL_SIZE]);
                let mut acc = [[zero; R]; PROFILES];
                for j in 0..HALF {
                    let v = vote(&tables[b[j][0] as usize], w[j]);
                    for px in live_profiles(0) {
                        for r in 0..R {
                            acc[px][r] = vfmaq_n_f32(acc[px][r], v[r], prof[px][j]);
                        }
                    }
                    if MICRO {
                        votes[i][j] = v;
                    }
                }
                for j in HALF..CELL_SIZE {
                    let v = vote(&tables[b[j][0] as usize], w[j]);
                    for px in live_profiles(HALF) {
                        for r in 0..R {
                            acc[px][r] = vfmaq_n_f32(acc[px][r], v[r], prof[px][j]);
                        }
                    }
                    if MICRO {
                        votes[i][j] = v;
                    }
                }
                *row_acc = acc;
            }
            for px in 0..PROFILES {
                let mut c = [[zero; R]; PROFILES];
                for i in 0..HALF {
                    let a = &rows[i][px];
                    for py in live_profiles(0) {
                        for r in 0..R {
                            c[py][r] = vfmaq_n_f32(c[py][r], a[r], prof[py][i]);
                        }
                    }
                }
                for i in HALF..CELL_SIZE {
                    let a = &rows[i][px];
                    for py in live_profiles(HALF) {
                        for r in 0..R {
                            c[py][r] = vfmaq_n_f32(c[py][r], a[r], prof[py][i]);
                        }
                    }
                }
                for (py, h) in c.iter().enumerate() {
                    store_lanes(h, &mut cell[cell_slot(py, px) * nb..][..nb]);
                }
            }
            if MICRO {
                for a in 0..PER_CELL {
                    let mrow = &mut micro[a * nmx * nb..][..nmx * nb];
                    for c in 0..PER_CELL {
                        let mut m = [zero; R];
                        for (y, x) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                            let v = &votes[2 * a + y][2 * c + x];
                            for r in 0..R {
                                m[r] = vaddq_f32(m[r], v[r]);
                            }
                        }
                        let mut h = [[0u16; 4]; R];
                        for r in 0..R {
                            // SAFETY: `h[r]` holds 4 half floats.
                            unsafe { vst1_u16(h[r].as_mut_ptr(), f16x4_from_f32(m[r])) };
                        }
                        mrow[(cx * PER_CELL + c) * nb..][..nb].copy_from_slice(&h.as_flattened()[..nb]);
                    }
                }
            }
        }
        if MICRO && ncx * PER_CELL < nmx {
            approx::micro_margin(bins, wts, stride, nb, ncx * PER_CELL, micro);
        }
    }
}

/// An approximated level's cell row `cy` one cell at a time (the AVX2 fill's scheme with 4-lane
/// registers; the same bits as `approx::fill_cell_row`).
///
/// # Safety
/// The CPU must support NEON; `micro` has ≤ 16 bins and `taps` are its taps (`Taps::fits`).
#[target_feature(enable = "neon")]
pub(crate) unsafe fn fill_cell_row(micro: &MicroGrid, taps: &Taps, cy: usize, row: &mut [f32]) {
    // SAFETY: this function's contract; R registers hold 4R ≥ nbins bins.
    unsafe {
        match micro.nbins.div_ceil(4) {
            0 | 1 => fill_body::<1>(micro, taps, cy, row),
            2 => fill_body::<2>(micro, taps, cy, row),
            3 => fill_body::<3>(micro, taps, cy, row),
            _ => fill_body::<4>(micro, taps, cy, row),
        }
    }
}

/// The body of [`fill_cell_row`] with `R` registers per histogram.
///
/// # Safety
/// As [`fill_cell_row`]; `nb ≤ 4R`.
#[target_feature(enable = "neon")]
unsafe fn fill_body<const R: usize>(micro: &MicroGrid, taps: &Taps, cy: usize, row: &mut [f32]) {
    let nb = micro.nbins;
    debug_assert!(nb <= 4 * R);
    let cl = cell_len(nb);
    let (lo, hi) = taps.rows[cy];
    let stride = micro.nmx * nb;
    let data = &micro.data[..];
    let zero = vdupq_n_f32(0.0);
    let wys: Vec<(usize, [f32; PROFILES])> = (lo..hi)
        .filter_map(|my| taps.yt[my].map(|ty| (my, ty.w.map(|w| w * taps.gain))))
        .collect();
    for (cx, cell) in row.chunks_exact_mut(cl).enumerate().take(taps.ncx) {
        let (clo, chi) = taps.cols[cx];
        let mut t = [[zero; R]; PROFILES * PROFILES];
        for (i, &(my, wy)) in wys.iter().enumerate() {
            let mut acc = [[zero; R]; PROFILES];
            match taps.split[cx] {
                // Left of `mid` x-profile 2 is exactly 0 and right of it x-profile 1 is.
                Some(mid) => {
                    for mx in clo..mid {
                        let (w, v) = (&taps.xw[mx], load_halves::<R>(data, my * stride + mx * nb));
                        for p in LEFT_PROFILES {
                            for r in 0..R {
                                acc[p][r] = vfmaq_n_f32(acc[p][r], v[r], w[p]);
                            }
                        }
                    }
                    for mx in mid..chi {
                        let (w, v) = (&taps.xw[mx], load_halves::<R>(data, my * stride + mx * nb));
                        for p in RIGHT_PROFILES {
                            for r in 0..R {
                                acc[p][r] = vfmaq_n_f32(acc[p][r], v[r], w[p]);
                            }
                        }
                    }
                }
                None => {
                    for mx in clo..chi {
                        let (w, v) = (&taps.xw[mx], load_halves::<R>(data, my * stride + mx * nb));
                        for p in 0..PROFILES {
                            for r in 0..R {
                                acc[p][r] = vfmaq_n_f32(acc[p][r], v[r], w[p]);
                            }
                        }
                    }
                }
            }
            for (py, &w) in wy.iter().enumerate() {
                let tr = &mut t[py * PROFILES..][..PROFILES];
                if i == 0 {
                    for (d, a) in tr.iter_mut().zip(&acc) {
                        for r in 0..R {
                            d[r] = vmulq_n_f32(a[r], w);
                        }
                    }
                } else if w != 0.0 {
                    for (d, a) in tr.iter_mut().zip(&acc) {
                        for r in 0..R {
                            d[r] = vfmaq_n_f32(d[r], a[r], w);
                        }
                    }
                }
            }
        }
        for py in 0..PROFILES {
            for px in 0..PROFILES {
                store_lanes(&t[py * PROFILES + px], &mut cell[cell_slot(py, px) * nb..][..nb]);
            }
        }
    }
}
