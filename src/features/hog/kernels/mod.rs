//! The HOG kernels per instruction-set path: which build of each hot loop runs for the process's
//! [`Isa`] ([`crate::kernels::isa`]), and the dispatch to it.
//!
//! [`portable`] (with the gradient rows of `gradient`) holds the portable kernels, written once as
//! `#[inline(always)]` bodies: they are the oracles, and they are also compiled per ISA by the
//! wrappers in [`avx2`], [`avx512`] and [`neon`] (LLVM vectorises their gradient, magnitude and
//! angle passes). The register kernels in those files are written with intrinsics for the loops
//! the compiler cannot vectorise (the scatter of orientation votes into histograms, the L2-Hys
//! reduction chains); [`f16`] holds the half-float row conversions.
//!
//! The stages (`input`, `cells`, `blocks`, `approx`, `grid`) call down into this dispatch; the
//! files here import only the shared types (`types`), the spec, `gradient` and each other
//! downwards (`portable` and the ISA files read `f16`; nothing here imports this file):
//!
//! | kernel | scalar | AVX2 + FMA | AVX-512 | NEON |
//! |---|---|---|---|---|
//! | cell histograms (+ micro-cells in the same pass) | portable | registers, one-hot votes by `vpermps` | registers, masked one-hot votes | registers, one-hot votes by `tbl` |
//! | block rows (assembly + L2-Hys) | portable | 8 blocks per reduction chain | as AVX2 | portable |
//! | gamma, gradient rows, micro rows | portable | portable, compiled for the ISA | portable, compiled for the ISA | portable |
//! | approximated cell rows (`fill`) | portable | registers | registers | registers |
//! | half floats | software | F16C | F16C | `fcvtn` / `fcvtl` |
//!
//! Every kernel equals its portable oracle bit for bit: each lane of a register kernel performs
//! the same fused multiply-adds (or adds), in the same order, as the scalar code performs on that
//! value, and lanes the scalar code does not touch only ever add `+0` to sums that are `≥ +0`.
//! The register cell and fill kernels need ≤ [`REGISTER_MAX_BINS`] bins and the profiles' fixed
//! zeros (`types::profiles_have_fixed_zeros`); other specs take the portable kernel compiled for
//! the same ISA.
//!
//! Dispatch checks what it relies on, once per call: a kernel of a path this CPU cannot run, or a
//! register kernel for a spec it does not fit, runs the portable code instead (so an `unsafe` call
//! is reached only with the CPU features its `# Safety` section names).

use super::gradient::gradient_pass;
use super::types::{
    cell_len, profiles_have_fixed_zeros, CellScratch, FillScratch, MicroGrid, Planes, Taps, REGISTER_MAX_BINS,
};
use super::{HogSpec, CELL_SIZE};
use crate::kernels::Isa;
use portable::micro_rows as micro_rows_portable;
use portable::{block_row as block_row_portable, cells_strip, fill_cell_row, gamma_in_place_generic};

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;
pub(crate) mod f16;
#[cfg(target_arch = "aarch64")]
pub(crate) mod neon;
pub(crate) mod portable;

/// Whether the register kernels fit `spec`.
fn registers_fit(spec: &HogSpec) -> bool {
    spec.nbins() <= REGISTER_MAX_BINS && profiles_have_fixed_zeros(&spec.profile)
}

/// Which build of the cell-histogram kernel runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CellKernel {
    /// The portable kernel (`portable::cells_strip`) for the baseline target: the oracle.
    Scalar,
    /// The portable kernel compiled for AVX2 + FMA (the AVX2 and AVX-512 paths' kernel for specs
    /// the register kernels do not fit).
    Avx2Portable,
    /// AVX2 + FMA: per-cell histograms in 256-bit registers ([`avx2`]).
    Avx2,
    /// AVX-512F/BW/VL: per-cell histograms in 512-bit registers ([`avx512`]).
    Avx512,
    /// NEON: per-cell histograms in 128-bit registers (`neon`).
    Neon,
}

impl CellKernel {
    /// The kernel of path `isa` for `spec`.
    pub(crate) fn for_isa(isa: Isa, spec: &HogSpec) -> Self {
        let regs = registers_fit(spec);
        match isa {
            Isa::Avx512 if regs && Isa::Avx512.is_available() => Self::Avx512,
            Isa::Avx2 | Isa::Avx512 if regs && Isa::Avx2.is_available() => Self::Avx2,
            Isa::Avx2 | Isa::Avx512 if Isa::Avx2.is_available() => Self::Avx2Portable,
            Isa::Neon if regs && Isa::Neon.is_available() => Self::Neon,
            _ => Self::Scalar,
        }
    }

    /// The kernel of the process's path ([`crate::kernels::isa`]).
    pub(crate) fn detect(spec: &HogSpec) -> Self {
        Self::for_isa(crate::kernels::isa(), spec)
    }

    /// Every kernel this CPU runs for `spec` (the scalar oracle first): what equality tests loop
    /// over.
    #[cfg(test)]
    pub(crate) fn available(spec: &HogSpec) -> Vec<Self> {
        let mut v: Vec<Self> = Isa::available()
            .into_iter()
            .map(|i| Self::for_isa(i, spec))
            .collect();
        if Isa::Avx2.is_available() {
            v.push(Self::Avx2Portable);
        }
        v.sort_by_key(|k| *k as u8);
        v.dedup();
        v
    }

    /// Whether this kernel can run here for `spec`: the check every dispatch makes before an
    /// `unsafe` call.
    fn runs(self, spec: &HogSpec) -> bool {
        match self {
            Self::Scalar => true,
            Self::Avx2Portable => Isa::Avx2.is_available(),
            Self::Avx2 => Isa::Avx2.is_available() && registers_fit(spec),
            Self::Avx512 => Isa::Avx512.is_available() && registers_fit(spec),
            Self::Neon => Isa::Neon.is_available() && registers_fit(spec),
        }
    }

    /// Whether [`Self::cells_micro_row`] pools micro-cells in the cell pass with this kernel.
    pub(crate) fn pools_micro_cells(self) -> bool {
        matches!(self, Self::Avx2 | Self::Avx512 | Self::Neon)
    }

    /// The cell rows from `cy0` on (as many as `chunk` holds; `chunk` is whole cell rows of
    /// `p.width / 8` cells).
    pub(crate) fn cells_strip(
        self,
        spec: &HogSpec,
        p: &Planes,
        cy0: usize,
        chunk: &mut [f32],
        cs: &mut CellScratch,
    ) {
        if !self.runs(spec) {
            return cells_strip(spec, p, cy0, chunk, cs);
        }
        match self {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX2 and FMA on this CPU.
            Self::Avx2Portable => unsafe { avx2::cells_strip_portable(spec, p, cy0, chunk, cs) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX2, FMA and F16C, ≤ 16 bins and the fixed zeros.
            Self::Avx2 => unsafe { avx2::cells_strip(spec, p, cy0, chunk, cs) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX-512F/BW/VL, AVX2 and FMA, ≤ 16 bins and the fixed zeros.
            Self::Avx512 => unsafe { avx512::cells_strip(spec, p, cy0, chunk, cs) },
            #[cfg(target_arch = "aarch64")]
            // SAFETY: `runs` checked NEON, ≤ 16 bins and the fixed zeros.
            Self::Neon => unsafe { neon::cells_strip(spec, p, cy0, chunk, cs) },
            _ => cells_strip(spec, p, cy0, chunk, cs),
        }
    }

    /// One cell row `cy` (`row`: `p.width / 8` cells) and its 4 rows of 2x2-pixel micro-cells
    /// (`micro`: `4 · (p.width / 2) · nbins` half floats), from one gradient pass: the bits of
    /// [`Self::cells_strip`] and of `portable::micro_rows` at micro-cell size 2. `false` (nothing
    /// written) when this kernel does not pool micro-cells or the buffers have other sizes.
    pub(crate) fn cells_micro_row(
        self,
        spec: &HogSpec,
        p: &Planes,
        cy: usize,
        row: &mut [f32],
        cs: &mut CellScratch,
        micro: &mut [u16],
    ) -> bool {
        let nb = spec.nbins();
        let sizes_ok = row.len() == p.width / CELL_SIZE * cell_len(nb)
            && micro.len() == CELL_SIZE / 2 * (p.width / 2) * nb
            && cs.bins.len() >= CELL_SIZE * (p.width / 2 * 2)
            && cs.wts.len() >= CELL_SIZE * (p.width / 2 * 2);
        debug_assert!(
            sizes_ok,
            "cell row {} / micro rows {} for width {}",
            row.len(),
            micro.len(),
            p.width
        );
        if !(sizes_ok && self.pools_micro_cells() && self.runs(spec)) {
            return false;
        }
        match self {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX2, FMA and F16C, ≤ 16 bins and the fixed zeros; the
            // buffer sizes were checked above.
            Self::Avx2 => unsafe { avx2::cells_micro_row(spec, p, cy, row, cs, micro) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above for AVX-512F/BW/VL.
            Self::Avx512 => unsafe { avx512::cells_micro_row(spec, p, cy, row, cs, micro) },
            #[cfg(target_arch = "aarch64")]
            // SAFETY: as above for NEON.
            Self::Neon => unsafe { neon::cells_micro_row(spec, p, cy, row, cs, micro) },
            _ => return false,
        }
        true
    }

    /// The gradient pass of [`super::block_grid_stage_times`], built as this kernel builds
    /// `gradient::gradient_row`.
    pub(crate) fn gradient_pass(self, spec: &HogSpec, p: &Planes, nb: usize) {
        if !self.runs(spec) {
            return gradient_pass(p, nb);
        }
        match self {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX2 and FMA.
            Self::Avx2 | Self::Avx2Portable => unsafe { avx2::gradient_pass(p, nb) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX-512F, AVX2 and FMA.
            Self::Avx512 => unsafe { avx512::gradient_pass(p, nb) },
            _ => gradient_pass(p, nb),
        }
    }
}

/// One block row (`portable::block_row`) with the `isa` build: the batched AVX2 kernel on the x86 paths
/// (AVX-512 adds nothing to its 8-block chains), the portable one elsewhere.
pub(crate) fn block_row(isa: Isa, spec: &HogSpec, ncx: usize, top: &[f32], bottom: &[f32], row: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    if matches!(isa, Isa::Avx2 | Isa::Avx512) && Isa::Avx2.is_available() {
        // SAFETY: AVX2 and FMA checked on this CPU just above.
        return unsafe { avx2::block_row(spec, ncx, top, bottom, row) };
    }
    let _ = isa;
    block_row_portable(spec, ncx, top, bottom, row)
}

/// HOG's gamma on one row with the `isa` build (`portable::gamma_in_place_generic`, vectorised).
pub(crate) fn gamma_in_place(isa: Isa, row: &mut [f32], gamma: bool) {
    #[cfg(target_arch = "x86_64")]
    if matches!(isa, Isa::Avx2 | Isa::Avx512) && Isa::Avx2.is_available() {
        // SAFETY: AVX2 and FMA checked on this CPU just above.
        return unsafe { avx2::gamma_in_place(row, gamma) };
    }
    let _ = isa;
    gamma_in_place_generic(row, gamma)
}

/// Micro-cell rows (`portable::micro_rows`) with the `isa` build.
pub(crate) fn micro_rows(isa: Isa, p: &Planes, nb: usize, size: usize, my0: usize, chunk: &mut [u16]) {
    #[cfg(target_arch = "x86_64")]
    if matches!(isa, Isa::Avx2 | Isa::Avx512) && Isa::Avx2.is_available() {
        // SAFETY: AVX2, FMA and F16C checked on this CPU just above.
        return unsafe { avx2::micro_rows(p, nb, size, my0, chunk) };
    }
    micro_rows_portable(isa, p, nb, size, my0, chunk)
}

/// Bound of [`FillKernel::ScalarUnfused`]'s values relative to the oracle's: each value is a chain
/// of at most 4 + 8 multiply-adds of non-negative terms per micro row of a cell (an x-profile sum,
/// then a y-profile sum), and each unfused step adds at most one rounding (2⁻²⁴) of a partial sum
/// not larger than the value; 2⁻¹⁶ leaves room for 256 steps.
#[cfg(test)]
pub(crate) const UNFUSED_FILL_REL: f32 = 1.0 / 65536.0;

/// Which build of the approximated levels' cell-row fill (`portable::fill_cell_row`) runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FillKernel {
    /// The portable fill, software half floats: the oracle (fused multiply-adds).
    Scalar,
    /// The portable fill with a multiply, then an add, instead of each fused multiply-add: what
    /// the scalar path runs on x86-64, whose baseline build has no FMA (there `f32::mul_add` is a
    /// library call, and the fill was slower than the exact pyramid). Within a relative 2⁻¹⁶ of
    /// the oracle (`UNFUSED_FILL_REL`; every term is non-negative), not the same bits.
    ScalarUnfused,
    /// The portable fill compiled for AVX2 + FMA with F16C conversions (more than 16 bins).
    Avx2Portable,
    /// AVX2 + FMA + F16C, one cell at a time in registers ([`avx2`]).
    Avx2,
    /// AVX-512F/BW/VL + F16C, one cell at a time in registers ([`avx512`]).
    Avx512,
    /// NEON, one cell at a time in registers (`neon`).
    Neon,
}

impl FillKernel {
    /// The fill of path `isa` for `nb` bins.
    pub(crate) fn for_isa(isa: Isa, nb: usize) -> Self {
        let regs = nb <= REGISTER_MAX_BINS;
        match isa {
            Isa::Avx512 if regs && Isa::Avx512.is_available() => Self::Avx512,
            Isa::Avx2 | Isa::Avx512 if regs && Isa::Avx2.is_available() => Self::Avx2,
            Isa::Avx2 | Isa::Avx512 if Isa::Avx2.is_available() => Self::Avx2Portable,
            Isa::Neon if regs && Isa::Neon.is_available() => Self::Neon,
            _ if cfg!(target_arch = "x86_64") => Self::ScalarUnfused,
            _ => Self::Scalar,
        }
    }

    /// Every fill this CPU runs for `nb` bins (the scalar oracle first).
    #[cfg(test)]
    pub(crate) fn available(nb: usize) -> Vec<Self> {
        let mut v: Vec<Self> = Isa::available()
            .into_iter()
            .map(|i| Self::for_isa(i, nb))
            .collect();
        if Isa::Avx2.is_available() {
            v.push(Self::Avx2Portable);
        }
        v.sort_by_key(|k| *k as u8);
        v.dedup();
        v
    }

    /// Whether this fill can run here for `nb` bins.
    fn runs(self, nb: usize) -> bool {
        match self {
            Self::Scalar | Self::ScalarUnfused => true,
            Self::Avx2Portable => Isa::Avx2.is_available(),
            Self::Avx2 => Isa::Avx2.is_available() && nb <= REGISTER_MAX_BINS,
            Self::Avx512 => Isa::Avx512.is_available() && nb <= REGISTER_MAX_BINS,
            Self::Neon => Isa::Neon.is_available() && nb <= REGISTER_MAX_BINS,
        }
    }

    /// Cell row `cy` of the level `taps` describes, from `micro` (the same bits with every
    /// kernel). `row` holds `taps.ncx` cells.
    pub(crate) fn fill(
        self,
        micro: &MicroGrid,
        taps: &Taps,
        cy: usize,
        row: &mut [f32],
        s: &mut FillScratch,
    ) {
        let nb = micro.nbins;
        // The taps must be those of this grid (their micro-cell indices are in its range).
        let fits = taps.fits(micro) && cy < taps.rows.len();
        debug_assert!(fits, "taps of another micro grid");
        if !(fits && self.runs(nb)) {
            return fill_cell_row::<true>(Isa::Scalar, micro, taps, cy, row, s);
        }
        match self {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX2, FMA and F16C.
            Self::Avx2Portable => unsafe { avx2::fill_cell_row_portable(micro, taps, cy, row, s) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX2, FMA and F16C and ≤ 16 bins; `fits` the taps.
            Self::Avx2 => unsafe { avx2::fill_cell_row(micro, taps, cy, row) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `runs` checked AVX-512F/BW/VL, F16C, AVX2 and FMA and ≤ 16 bins; `fits`
            // the taps.
            Self::Avx512 => unsafe { avx512::fill_cell_row(micro, taps, cy, row) },
            #[cfg(target_arch = "aarch64")]
            // SAFETY: `runs` checked NEON and ≤ 16 bins; `fits` the taps.
            Self::Neon => unsafe { neon::fill_cell_row(micro, taps, cy, row) },
            Self::ScalarUnfused => fill_cell_row::<false>(Isa::Scalar, micro, taps, cy, row, s),
            _ => fill_cell_row::<true>(Isa::Scalar, micro, taps, cy, row, s),
        }
    }
}
