//! Cell histograms (step 4 of the math in the parent module): for every 8x8 image cell, 16
//! weighted orientation histograms (4 y-profiles x 4 x-profiles), from which blocks are sums.
//! [`cells_strip`] is the portable kernel and the oracle of the instruction-set builds in
//! `kernels`.

use rayon::prelude::*;

use super::blocks::sized;
use super::gradient::{gradient_row, CellScratch};
use super::input::{planes_from_input, planes_of, Planes};
use super::kernels::CellKernel;
use super::{
    Exec, GammaPlanes, HogError, HogInput, HogSpec, BLOCK_CELLS, CELL_SIZE, PROFILES, STRIP_CELL_ROWS,
};

/// Values per cell: PROFILES (y) x PROFILES (x) x nbins.
pub(super) fn cell_len(nbins: usize) -> usize {
    PROFILES * PROFILES * nbins
}

/// Per-cell weighted histograms of one image at one scale: for each 8x8 cell, 4 y-profiles x 4
/// x-profiles x nbins values (see the module docs). Blocks are sums of four cells' entries.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CellGrid {
    pub(super) ncx: usize,
    pub(super) ncy: usize,
    pub(super) cell_len: usize,
    pub(super) data: Vec<f32>,
}

impl CellGrid {
    /// An empty grid.
    pub fn empty() -> Self {
        Self {
            ncx: 0,
            ncy: 0,
            cell_len: 0,
            data: Vec::new(),
        }
    }
    /// Cells across.
    pub fn cells_x(&self) -> usize {
        self.ncx
    }
    /// Cells down.
    pub fn cells_y(&self) -> usize {
        self.ncy
    }
}

/// Compute the cell grid of `input` (the expensive, per-pixel part of HOG).
pub fn cell_grid(spec: &HogSpec, input: &HogInput, exec: Exec, dst: &mut CellGrid) -> Result<(), HogError> {
    let planes = planes_from_input(spec, input)?;
    cells_from_planes(spec, &planes.view(), exec, dst);
    Ok(())
}

/// [`cell_grid`] of planes that are already gamma-corrected (the detector fuses gamma into its
/// pyramid resize): the same grid, bit for bit, as [`cell_grid`] of the linear input. `dst`'s
/// buffer is reused.
pub fn cell_grid_from_gamma_planes(
    spec: &HogSpec,
    planes: &GammaPlanes,
    exec: Exec,
    dst: &mut CellGrid,
) -> Result<(), HogError> {
    cells_from_planes(spec, &planes_of(spec, planes)?, exec, dst);
    Ok(())
}

/// The cell grid of `p` with the process's cell kernel.
pub(super) fn cells_from_planes(spec: &HogSpec, p: &Planes, exec: Exec, out: &mut CellGrid) {
    cells_from_planes_with(spec, p, exec, CellKernel::detect(spec), out)
}

/// [`cells_from_planes`] with a chosen cell kernel.
pub(super) fn cells_from_planes_with(
    spec: &HogSpec,
    p: &Planes,
    exec: Exec,
    kernel: CellKernel,
    out: &mut CellGrid,
) {
    let nb = spec.nbins();
    let ncx = p.width / CELL_SIZE;
    let ncy = p.height / CELL_SIZE;
    let cl = cell_len(nb);
    out.ncx = ncx;
    out.ncy = ncy;
    out.cell_len = cl;
    sized(&mut out.data, ncx * ncy * cl);
    let cells = &mut out.data;
    let strip = STRIP_CELL_ROWS * ncx * cl;
    let work = |(s, chunk): (usize, &mut [f32])| {
        let mut cs = CellScratch::new(p.width);
        kernel.cells_strip(spec, p, s * STRIP_CELL_ROWS, chunk, &mut cs)
    };
    match exec {
        Exec::Parallel => cells.par_chunks_mut(strip.max(1)).enumerate().for_each(work),
        Exec::Serial => cells.chunks_mut(strip.max(1)).enumerate().for_each(work),
    }
}

/// The profiles that can be non-zero at pixel offset `k` of a cell: a pixel in the left (upper)
/// half of a cell never votes for the far block cell when its cell is the first of the block
/// (profile 2), nor in the right half for the near block cell when its cell is the second
/// (profile 1). [`HogSpec::new`] never writes those entries; [`profiles_have_fixed_zeros`] checks.
#[inline(always)]
pub(super) const fn live_profiles(k: usize) -> [usize; 3] {
    if k < CELL_SIZE / 2 {
        [0, 1, 3]
    } else {
        [0, 2, 3]
    }
}

/// Position (in histograms of `nbins`) of the (y-profile `py`, x-profile `px`) histogram within a
/// cell. Profile `p` = block cell · 2 + offset of the image cell in the block, and a cell is stored
/// grouped by its offset (sy, sx), then by block cell in block order (column-major, as the
/// descriptor): the 4·nbins values a block takes from the cell at (sy, sx) are one contiguous run.
#[inline(always)]
pub(super) const fn cell_slot(py: usize, px: usize) -> usize {
    let (bcy, sy) = (py / BLOCK_CELLS, py % BLOCK_CELLS);
    let (bcx, sx) = (px / BLOCK_CELLS, px % BLOCK_CELLS);
    (sy * BLOCK_CELLS + sx) * BLOCK_CELLS * BLOCK_CELLS + bcx * BLOCK_CELLS + bcy
}

/// Whether every profile entry outside [`live_profiles`] is exactly zero (true for every spec
/// [`HogSpec::new`] builds; the register cell kernels rely on it). Live entries may be zero too:
/// adding `0·v` to a non-negative sum leaves its bits unchanged, as skipping it does.
pub(super) fn profiles_have_fixed_zeros(profile: &[[f32; CELL_SIZE]; PROFILES]) -> bool {
    (0..CELL_SIZE).all(|k| (0..PROFILES).all(|p| live_profiles(k).contains(&p) || profile[p][k] == 0.0))
}

/// Cell histograms of strip `s` (STRIP_CELL_ROWS cell rows) into `chunk`. Votes are accumulated
/// with [`f32::mul_add`] (one rounding, as the FMA kernels): native on AArch64 and in the AVX2 + FMA
/// build, a slow library call only on x86 CPUs without FMA.
#[inline(always)]
pub(super) fn cells_strip(spec: &HogSpec, p: &Planes, cy0: usize, chunk: &mut [f32], cs: &mut CellScratch) {
    let nb = spec.nbins();
    let ncx = p.width / CELL_SIZE;
    let cl = cell_len(nb);
    // Non-zero x-profiles per pixel column of a cell (3 of 4 for the default geometry).
    let mut nonzero = [[(0usize, 0.0f32); PROFILES]; CELL_SIZE];
    let mut nnz = [0usize; CELL_SIZE];
    for j in 0..CELL_SIZE {
        for px in 0..PROFILES {
            if spec.profile[px][j] != 0.0 {
                nonzero[j][nnz[j]] = (px, spec.profile[px][j]);
                nnz[j] += 1;
            }
        }
    }
    let bins = &mut cs.bins[..ncx * CELL_SIZE];
    let wts = &mut cs.wts[..ncx * CELL_SIZE];
    let mut rowacc = vec![0.0f32; PROFILES * nb];
    chunk.fill(0.0);
    for (k, cell_row) in chunk.chunks_mut(ncx * cl).enumerate() {
        let cy = cy0 + k;
        for i in 0..CELL_SIZE {
            gradient_row(p, cy * CELL_SIZE + i, nb, &mut cs.sc, bins, wts);
            for (cx, cell) in cell_row.chunks_mut(cl).enumerate() {
                rowacc.iter_mut().for_each(|v| *v = 0.0);
                let x0 = cx * CELL_SIZE;
                let cols = bins[x0..x0 + CELL_SIZE].iter().zip(&wts[x0..x0 + CELL_SIZE]);
                for (j, (&[b0, b1], &[w0, w1])) in cols.enumerate() {
                    for &(px, pw) in &nonzero[j][..nnz[j]] {
                        let acc = &mut rowacc[px * nb..(px + 1) * nb];
                        acc[b0 as usize] = pw.mul_add(w0, acc[b0 as usize]);
                        acc[b1 as usize] = pw.mul_add(w1, acc[b1 as usize]);
                    }
                }
                for py in 0..PROFILES {
                    let wy = spec.profile[py][i];
                    if wy == 0.0 {
                        continue;
                    }
                    for (px, acc) in rowacc.chunks_exact(nb).enumerate() {
                        let dst = &mut cell[cell_slot(py, px) * nb..][..nb];
                        for (d, &r) in dst.iter_mut().zip(acc) {
                            *d = wy.mul_add(r, *d);
                        }
                    }
                }
            }
        }
    }
}
