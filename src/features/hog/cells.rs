//! Cell histograms (step 4 of the math in the parent module): for every 8x8 image cell, 16
//! weighted orientation histograms (4 y-profiles x 4 x-profiles), from which blocks are sums.
//! The per-row kernel is `kernels::portable::cells_strip` (the oracle of the instruction-set
//! builds in `kernels`); this file holds the grid and the parallel strips that call it.

use rayon::prelude::*;

use super::input::{planes_from_input, planes_of};
use super::kernels::CellKernel;
use super::types::{cell_len, sized, CellScratch, Planes};
use super::{Exec, GammaPlanes, HogError, HogInput, HogSpec, CELL_SIZE, STRIP_CELL_ROWS};

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
