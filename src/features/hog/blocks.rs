//! Blocks (steps 5 and 6 of the math in the parent module): each 2x2-cell block is the sum of
//! its four cells' runs, then L2-Hys-normalised; a [`BlockGrid`] holds every block of an image.
//! The per-row kernel is `kernels::portable::block_row` (with [`normalize_l2hys`](super::normalize_l2hys), the oracle of
//! the batched builds in `kernels`); this file holds the grid and the bands that call it.

use rayon::prelude::*;

use super::cells::CellGrid;
use super::input::planes_of;
use super::kernels::{self, CellKernel};
use super::types::{cell_len, sized, CellScratch, Planes};
use super::{Exec, GammaPlanes, HogError, HogSpec, BLOCK_CELLS, CELL_SIZE};
use crate::kernels::Isa;

/// `[8bx, 8bx+16) x [8by, 8by+16)`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BlockGrid {
    pub(super) nbx: usize,
    pub(super) nby: usize,
    pub(super) block_len: usize,
    pub(super) data: Vec<f32>,
}

impl BlockGrid {
    /// An empty grid (reuse with [`block_grid`](super::block_grid)).
    pub fn empty() -> Self {
        Self {
            nbx: 0,
            nby: 0,
            block_len: 0,
            data: Vec::new(),
        }
    }
    /// Blocks across.
    pub fn blocks_x(&self) -> usize {
        self.nbx
    }
    /// Blocks down.
    pub fn blocks_y(&self) -> usize {
        self.nby
    }
    /// Values per block.
    pub fn block_len(&self) -> usize {
        self.block_len
    }
    /// The normalised block at (bx, by) (panics only on out-of-range indices, like slicing).
    #[inline]
    pub fn block(&self, bx: usize, by: usize) -> &[f32] {
        let o = (by * self.nbx + bx) * self.block_len;
        &self.data[o..o + self.block_len]
    }
    /// One row of blocks, contiguous.
    #[inline]
    pub fn block_row(&self, by: usize) -> &[f32] {
        let n = self.nbx * self.block_len;
        &self.data[by * n..(by + 1) * n]
    }
    /// Windows across and down at a stride of one cell.
    pub fn windows(&self, spec: &HogSpec) -> (usize, usize) {
        let (bw, bh) = spec.blocks_per_window();
        (
            (self.nbx + 1).saturating_sub(bw),
            (self.nby + 1).saturating_sub(bh),
        )
    }
    /// Write the descriptor of the window whose top-left block is (wx, wy) (pixel (8wx, 8wy)) in
    /// OpenCV order into `out`.
    pub fn window_descriptor_into(
        &self,
        spec: &HogSpec,
        wx: usize,
        wy: usize,
        out: &mut [f32],
    ) -> Result<(), HogError> {
        let (bw, bh) = spec.blocks_per_window();
        let (nwx, nwy) = self.windows(spec);
        if wx >= nwx || wy >= nwy {
            return Err(HogError::WindowOutside {
                bx: wx,
                by: wy,
                nbx: self.nbx,
                nby: self.nby,
            });
        }
        if out.len() != spec.descriptor_len() {
            return Err(HogError::BadOutput {
                expected: spec.descriptor_len(),
                actual: out.len(),
            });
        }
        let bl = self.block_len;
        for bx in 0..bw {
            for by in 0..bh {
                let o = (bx * bh + by) * bl;
                out[o..o + bl].copy_from_slice(self.block(wx + bx, wy + by));
            }
        }
        Ok(())
    }
    /// Allocating [`BlockGrid::window_descriptor_into`].
    pub fn window_descriptor(&self, spec: &HogSpec, wx: usize, wy: usize) -> Result<Vec<f32>, HogError> {
        let mut v = vec![0.0; spec.descriptor_len()];
        self.window_descriptor_into(spec, wx, wy, &mut v)?;
        Ok(v)
    }
}

/// The normalised block grid of gamma-corrected planes, bit for bit the grid that
/// [`cell_grid_from_gamma_planes`](super::cell_grid_from_gamma_planes) then [`blocks_from_cells`]
/// give, without a whole-image cell grid: bands of [`BAND_BLOCK_ROWS`] block rows run in parallel,
/// each computes its cell rows one at a time into a two-row ring (in cache) and assembles a block
/// row as soon as both of its cell rows are there. A band recomputes the cell row it shares with
/// the next band (≈6 % more cell work at 1080p), in exchange for no cell grid round trip through
/// memory (≈36 MB per 1080p level). `dst`'s buffer is reused.
pub fn block_grid_from_gamma_planes(
    spec: &HogSpec,
    planes: &GammaPlanes,
    exec: Exec,
    dst: &mut BlockGrid,
) -> Result<(), HogError> {
    let p = planes_of(spec, planes)?;
    blocks_in_bands(
        spec,
        &p,
        exec,
        CellKernel::detect(spec),
        crate::kernels::isa(),
        dst,
    );
    Ok(())
}

/// Block rows per band of [`block_grid_from_gamma_planes`].
pub const BAND_BLOCK_ROWS: usize = 16;

/// [`block_grid_from_gamma_planes`] with a chosen cell kernel and block-row path.
pub(super) fn blocks_in_bands(
    spec: &HogSpec,
    p: &Planes,
    exec: Exec,
    kernel: CellKernel,
    isa: Isa,
    dst: &mut BlockGrid,
) {
    let (ncx, ncy) = (p.width / CELL_SIZE, p.height / CELL_SIZE);
    let scratch = |_| CellScratch::new(p.width);
    let fill = |cy: usize, row: &mut [f32], cs: &mut CellScratch| kernel.cells_strip(spec, p, cy, row, cs);
    // Serially, one band: no cell row is computed twice.
    let band_rows = match exec {
        Exec::Parallel => BAND_BLOCK_ROWS,
        Exec::Serial => ncy,
    };
    blocks_in_bands_with(spec, ncx, ncy, band_rows, exec, isa, dst, scratch, fill);
}

/// The blocks of `ncx x ncy` cells in bands of `band_rows` (≥ 1) block rows: `fill(cy, row,
/// scratch)` writes cell row `cy` into `row`, each band keeps two cell rows in a ring. Band `b`
/// fills cell rows `band_rows·b ..= band_rows·(b + 1)` (the last band up to `ncy − 1`) with its
/// own `scratch(b)`. Block rows are assembled with the `isa` build of [`block_row`].
#[allow(clippy::too_many_arguments)]
pub(super) fn blocks_in_bands_with<S>(
    spec: &HogSpec,
    ncx: usize,
    ncy: usize,
    band_rows: usize,
    exec: Exec,
    isa: Isa,
    dst: &mut BlockGrid,
    scratch: impl Fn(usize) -> S + Sync,
    fill: impl Fn(usize, &mut [f32], &mut S) + Sync,
) {
    let row_len = ncx * cell_len(spec.nbins());
    let Some(row_size) = block_grid_shape(spec, ncx, ncy, dst) else {
        return;
    };
    let band_rows = band_rows.max(1);
    let band_work = |(b, band): (usize, &mut [f32])| {
        let by0 = b * band_rows;
        let mut cs = scratch(b);
        let mut ring = vec![0.0f32; 2 * row_len];
        fill(by0, &mut ring[..row_len], &mut cs);
        for (r, out) in band.chunks_mut(row_size).enumerate() {
            let (a, b) = ring.split_at_mut(row_len);
            let (top, bottom) = if r % 2 == 0 { (a, b) } else { (b, a) };
            fill(by0 + r + 1, bottom, &mut cs);
            kernels::block_row(isa, spec, ncx, top, bottom, out);
        }
    };
    let band = band_rows * row_size;
    match exec {
        Exec::Parallel => dst.data.par_chunks_mut(band).enumerate().for_each(band_work),
        Exec::Serial => dst.data.chunks_mut(band).enumerate().for_each(band_work),
    }
}

/// Assemble and L2-Hys-normalise every block from a cell grid.
pub fn blocks_from_cells(spec: &HogSpec, cg: &CellGrid, exec: Exec, dst: &mut BlockGrid) {
    block_rows_with(spec, cg, exec, crate::kernels::isa(), dst)
}

/// [`blocks_from_cells`] with the `isa` build of [`block_row`].
pub(super) fn block_rows_with(spec: &HogSpec, cg: &CellGrid, exec: Exec, isa: Isa, dst: &mut BlockGrid) {
    let (ncx, cl) = (cg.ncx, cg.cell_len);
    let Some(row_size) = block_grid_shape(spec, ncx, cg.ncy, dst) else {
        return;
    };
    let row_work = |(by, row): (usize, &mut [f32])| {
        let cell_row = |cy: usize| &cg.data[cy * ncx * cl..][..ncx * cl];
        kernels::block_row(isa, spec, ncx, cell_row(by), cell_row(by + 1), row)
    };
    match exec {
        Exec::Parallel => dst.data.par_chunks_mut(row_size).enumerate().for_each(row_work),
        Exec::Serial => dst.data.chunks_mut(row_size).enumerate().for_each(row_work),
    }
}

/// Blocks along a run of `cells` cells (a block is 2 cells, at a stride of one).
pub(super) fn blocks_of(cells: usize) -> usize {
    cells.saturating_sub(BLOCK_CELLS - 1)
}

/// Size `dst` for the blocks of `ncx x ncy` cells; the length of one block row, or `None` when
/// there are no blocks.
pub(super) fn block_grid_shape(spec: &HogSpec, ncx: usize, ncy: usize, dst: &mut BlockGrid) -> Option<usize> {
    let (nbx, nby) = (blocks_of(ncx), blocks_of(ncy));
    let bl = spec.block_len();
    dst.nbx = nbx;
    dst.nby = nby;
    dst.block_len = bl;
    sized(&mut dst.data, nbx * nby * bl);
    (bl > 0 && nbx > 0 && nby > 0).then_some(nbx * bl)
}
