//! Approximate HOG block grids of other scales from one exactly computed level: the
//! feature-pyramid approximation of Dollár, Appel, Belongie & Perona (2014), done on
//! orientation channels *before* they are spatially pooled.
//!
//! # Method
//!
//! An exact level `L` (`W x H` pixels, gamma-corrected) is pooled once into a [`MicroGrid`]:
//! `m x m`-pixel micro-cells (the detector uses `m` = [`MICRO_CELL`] = 2), each holding the sum
//! of its pixels' orientation votes per bin (the same two interpolated votes `|g|(1−f)`, `|g|f` as the
//! exact cells, no spatial weight). For a level `L'` of `W' x H'` pixels, `r_x = W'/W`,
//! `r_y = H'/H`, a micro-cell whose centre is the pixel coordinate `(u, v)` of `L` stands at
//! `(u', v') = ((u+½)·r_x − ½, (v+½)·r_y − ½)` in `L'` (the half-pixel convention of the pyramid's
//! bilinear resize, so `L'` pixel centres and the mapped micro-cells agree). It then votes into the
//! cell of `L'` that contains `(u', v')` exactly as a pixel at that point would: with the cell's
//! 4 x-profiles and 4 y-profiles (OpenCV's Gaussian block window times the bilinear weight of the
//! block's cell centres, see the parent module) evaluated at the *continuous* offset in the cell,
//! times a gain `√(r_x r_y)`. Blocks are assembled from those cells and L2-Hys-normalised as for
//! an exact level.
//!
//! The gain: gradient magnitudes summed over an area measure the length of the edges in it (a
//! `[−1, 0, 1]` step response integrates to the same value at any scale), and lengths shrink by
//! `r` from `L` to `L'`, so an `L'` cell holds about `r` times what the micro-cells mapped into it
//! hold. L2-Hys removes any global factor but for its first epsilon (`0.1·36` added to the block
//! norm), so the gain only matters for faint blocks.
//!
//! # Where we differ
//!
//! - Dollár et al. resample per-pixel channels and pool them afterwards at the coarse scale with
//!   a box filter, and correct magnitudes with a fitted power law `r^−λ`. We keep OpenCV's pooling
//!   (Gaussian-windowed, bilinear over cell centres) by evaluating its weights at the mapped
//!   micro-cell positions, and use the edge-length gain `r` (no fitted λ; on USC, gain `1`
//!   instead of `r` gave the same AP within noise, 0.646 vs 0.643 at `--approx 14`).
//! - Levels are only approximated downwards (from the finer exact level): approximating a level
//!   from the next *coarser* exact level gave larger window-score errors at every distance but
//!   the last two levels of a group of 14.
//! - Micro-cells are placed at their centre: a vote's position inside its micro-cell is lost
//!   (at `m` = 2, ≤ ½ pixel), which is why `m` = 4 loses more than `m` = 2.
//! - Gradients (and their orientations) are those of `L`, not of the coarser `L'`: texture finer
//!   than `L'` resolves keeps its votes. That is the approximation's residual error.
//! - The previous approximation (until commit 07aa828) resampled the *pooled* 8x8 cells
//!   bilinearly, which mixes neighbouring cells' Gaussian-weighted histograms and lost ≈ 6 AP
//!   points on USC at any spacing of exact levels; this one is within ≈ 0.5 (docs/detection.md).
//! - Micro-cells are **stored as IEEE half floats** (summed in `f32` per micro row, then rounded
//!   to nearest even, [`f16_bits`]; read back exactly). Every approximated level reads the whole
//!   micro grid of its exact level, and that read is what the stage waits on: padding micro-cells
//!   to 16 floats made it slower, half floats made it 12–22 % faster (docs/detection.md). Votes are
//!   below ≈ 130 (gamma-corrected 8-bit units, 4 pixels), so the relative error is ≤ 2⁻¹¹; on the
//!   1080p bench frame window scores moved by at most 5.4e-4 (mean 7.9e-5), no box changed, and
//!   USC AP is the same at all seven pyramid phases we measure. The exact pyramid is untouched.
//! - At `r = 1` and `m = 1` this is the exact grid up to summation order and half-float rounding
//!   (tested).
//! - The register fills (AVX-512, AVX2 and NEON builds in `kernels`) build a level one **cell at
//!   a time** (on AVX-512 its 16 profile histograms stay in 16 registers while the micro rows and
//!   micro-cells landing in it are added; AVX2 and NEON, with too few registers for them, make
//!   the cell in two register passes, x sums per micro row and then y sums per y-profile, with
//!   the bins past the last whole register held as the 4 x-profiles in one register's lanes),
//!   skipping the x-profile that is exactly zero on each half of a cell. On AVX2 the two-pass
//!   fill took the approximated levels of a 1080p frame from ≈ 230 to ≈ 80 ms of CPU (one
//!   thread, a loaded machine; the same bits). The portable fill goes a
//!   micro row at a time through row buffers. All make the same fused multiply-adds
//!   ([`f32::mul_add`]; FMA instructions where the CPU has them) in the same order, so the same
//!   bits (tested), but one: the **x86-64 scalar path** runs the portable fill with a multiply,
//!   then an add. Its baseline build has no FMA, so `mul_add` is a library call there (`fmaf`,
//!   40 % of a frame's CPU), and with it `approx_levels = 14` was slower than the exact pyramid
//!   (5.8–5.9 s against 5.4 s per 1080p frame); unfused it takes 3.1–3.3 s. Its cells are within
//!   a relative 2⁻¹⁶ of the fused oracle (tested); on USC (`--upsample 2`, `--approx 14 --svm
//!   i8`) it gave the same 794 boxes as the AVX2 path, scores within 1.5e-3 (mean 2.6e-6). The register fill took the approximated levels from ≈ 50 to ≈ 32 ms of CPU per
//!   1080p frame and fused multiply-adds (instead of a multiply, then an add) to ≈ 27; those
//!   moved window scores by ≤ 2.9e-6 (docs/detection.md).
//! - The detector does not build the approximated levels one after another: it sweeps the micro
//!   grid once for several levels ([`approx_block_rows`]), filling each level's cell rows as soon
//!   as the micro rows they need are read, and scores each block row as it is made, so neither
//!   the micro grid (9.3 MB at 1080p, read once per level before) nor a level's block grid goes
//!   through memory per level. Same bits as [`blocks_from_micro_grid`] (tested).

use rayon::prelude::*;

use super::blocks::{block_grid_shape, blocks_in_bands, blocks_in_bands_with, blocks_of};
use super::input::planes_of;
use super::kernels::{self, CellKernel, FillKernel};
pub use super::types::MicroGrid;
use super::types::{cell_len, AxisTap, CellScratch, FillScratch, Taps, LEFT_PROFILES, RIGHT_PROFILES};
use super::{
    BlockGrid, Exec, GammaPlanes, HogError, HogSpec, BAND_BLOCK_ROWS, BLOCK_CELLS, CELL_SIZE, PROFILES,
};
use crate::kernels::Isa;

/// Micro-cell side the detector uses, in pixels. Dollár et al. shrink channels by 4; on USC
/// (docs/detection.md) 4 costs ≈ 1 AP point more than 2 at `--approx 14` for ≈ 20 % less time,
/// 1 gains nothing over 2.
pub const MICRO_CELL: usize = 2;
/// Micro-cell rows per parallel task.
const MICRO_ROWS_PER_TASK: usize = 4;

/// Pool gamma-corrected planes into `size x size`-pixel micro-cells (`size` in 1..=8): the same
/// gradients and orientation votes as the exact cells, summed per micro-cell and bin. `dst`'s
/// buffer is reused. Errors as [`super::cell_grid_from_gamma_planes`], plus
/// [`HogError::BadMicroCell`].
pub fn micro_grid_from_gamma_planes(
    spec: &HogSpec,
    planes: &GammaPlanes,
    size: usize,
    exec: Exec,
    dst: &mut MicroGrid,
) -> Result<(), HogError> {
    micro_grid_with(crate::kernels::isa(), spec, planes, size, exec, dst)
}

/// [`micro_grid_from_gamma_planes`] with the `isa` build of the kernels.
pub(super) fn micro_grid_with(
    isa: Isa,
    spec: &HogSpec,
    planes: &GammaPlanes,
    size: usize,
    exec: Exec,
    dst: &mut MicroGrid,
) -> Result<(), HogError> {
    if !(1..=CELL_SIZE).contains(&size) {
        return Err(HogError::BadMicroCell(size));
    }
    let p = planes_of(spec, planes)?;
    let nb = spec.nbins();
    dst.reshape(&p, size, nb);
    let row_len = dst.nmx * nb;
    if row_len == 0 {
        return Ok(());
    }
    let work = |(t, chunk): (usize, &mut [u16])| {
        kernels::micro_rows(isa, &p, nb, size, t * MICRO_ROWS_PER_TASK, chunk)
    };
    let task = MICRO_ROWS_PER_TASK * row_len;
    match exec {
        Exec::Parallel => dst.data.par_chunks_mut(task).enumerate().for_each(work),
        Exec::Serial => dst.data.chunks_mut(task).enumerate().for_each(work),
    }
    Ok(())
}

/// [`super::block_grid_from_gamma_planes`] and [`micro_grid_from_gamma_planes`] of the same
/// planes at once, with the same results bit for bit. With a register cell kernel (AVX2,
/// AVX-512 or NEON; `kernels`) and `size` 2, the micro-cells are pooled inside the cell pass from
/// the votes it computes anyway, instead of a second pass that computes every gradient again;
/// otherwise (the scalar path, more than 16 bins, other sizes) this runs the two functions one
/// after the other. Errors as theirs.
pub fn block_and_micro_grids_from_gamma_planes(
    spec: &HogSpec,
    planes: &GammaPlanes,
    size: usize,
    exec: Exec,
    blocks: &mut BlockGrid,
    micro: &mut MicroGrid,
) -> Result<(), HogError> {
    block_and_micro_grids_with(crate::kernels::isa(), spec, planes, size, exec, blocks, micro)
}

/// [`block_and_micro_grids_from_gamma_planes`] with the `isa` build of the kernels.
pub(super) fn block_and_micro_grids_with(
    isa: Isa,
    spec: &HogSpec,
    planes: &GammaPlanes,
    size: usize,
    exec: Exec,
    blocks: &mut BlockGrid,
    micro: &mut MicroGrid,
) -> Result<(), HogError> {
    let kernel = CellKernel::for_isa(isa, spec);
    let p = planes_of(spec, planes)?;
    let (ncx, ncy) = (p.width / CELL_SIZE, p.height / CELL_SIZE);
    if size != 2 || !kernel.pools_micro_cells() || ncx < BLOCK_CELLS || ncy < BLOCK_CELLS {
        blocks_in_bands(spec, &p, exec, kernel, isa, blocks);
        return micro_grid_with(isa, spec, planes, size, exec, micro);
    }
    let nb = spec.nbins();
    micro.reshape(&p, size, nb);
    // Micro rows per cell row, and the length of one micro row.
    let per_cell = CELL_SIZE / size;
    let row_len = micro.nmx * nb;
    // Band b fills cell rows 16b ..= 16b + 16; it pools the micro rows of the first 16 (the
    // last band: of all it fills), so every micro row is written once.
    let nbands = (ncy - 1).div_ceil(BAND_BLOCK_ROWS);
    let (mut rest, tail) = micro.data.split_at_mut(ncy * per_cell * row_len);
    let mut slots = Vec::with_capacity(nbands);
    for b in 0..nbands {
        let rows = if b + 1 == nbands {
            ncy - b * BAND_BLOCK_ROWS
        } else {
            BAND_BLOCK_ROWS
        };
        let (own, r) = rest.split_at_mut(rows * per_cell * row_len);
        slots.push(std::sync::Mutex::new(Some(own)));
        rest = r;
    }
    let scratch = |b: usize| {
        let own = slots[b]
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take()
            .expect("each band takes its own micro rows once");
        (CellScratch::new(p.width), own, b * BAND_BLOCK_ROWS)
    };
    let fill = |cy: usize, row: &mut [f32], s: &mut (CellScratch, &mut [u16], usize)| {
        let (cs, own, first) = s;
        let at = (cy - *first) * per_cell * row_len;
        if at < own.len() {
            let m = &mut own[at..][..per_cell * row_len];
            let pooled = kernel.cells_micro_row(spec, &p, cy, row, cs, m);
            debug_assert!(pooled, "{kernel:?} pools micro-cells");
            if !pooled {
                // Not reached (the kernel pools and the sizes are the ones it checks); kept so
                // that every micro row is written whatever the kernel.
                kernel.cells_strip(spec, &p, cy, row, cs);
                kernels::micro_rows(isa, &p, nb, size, cy * per_cell, m);
            }
        } else {
            kernel.cells_strip(spec, &p, cy, row, cs)
        }
    };
    blocks_in_bands_with(spec, ncx, ncy, BAND_BLOCK_ROWS, exec, isa, blocks, scratch, fill);
    // Micro rows below the last whole cell row.
    kernels::micro_rows(isa, &p, nb, size, ncy * per_cell, tail);
    Ok(())
}

/// Profile `p` (block cell · 2 + offset of the image cell in the block) at the continuous pixel
/// offset `k ∈ [−½, 8−½)` in the cell: OpenCV's Gaussian window times the bilinear (tent) weight
/// of the block cell's centre, zero outside the block. At integer `k` it is [`HogSpec`]'s
/// discrete profile.
fn profile_at(spec: &HogSpec, p: usize, k: f32) -> f32 {
    let (bc, off) = (p / BLOCK_CELLS, p % BLOCK_CELLS);
    let j = (off * CELL_SIZE) as f32 + k;
    let sigma = spec.win_sigma();
    let scale = 1.0 / (sigma * sigma * 2.0);
    let d = j - (BLOCK_CELLS * CELL_SIZE) as f32 * 0.5;
    let g = (-(d * d) * scale).exp();
    let cell = (j + 0.5) / CELL_SIZE as f32 - 0.5;
    g * (1.0 - (cell - bc as f32).abs()).max(0.0)
}

/// Taps of `n` micro-cells of `size` pixels along one axis into `cells` cells of a level `ratio`
/// times as large; `None` for micro-cells that land outside the cells.
fn axis_taps(spec: &HogSpec, n: usize, size: usize, ratio: f64, cells: usize) -> Vec<Option<AxisTap>> {
    (0..n)
        .map(|i| {
            let centre = (i * size) as f64 + (size as f64 - 1.0) * 0.5;
            let u = (centre + 0.5) * ratio - 0.5;
            let c = ((u + 0.5) / CELL_SIZE as f64).floor();
            if c < 0.0 || c >= cells as f64 {
                return None;
            }
            let k = (u - c * CELL_SIZE as f64) as f32;
            Some(AxisTap {
                cell: c as usize,
                w: std::array::from_fn(|p| profile_at(spec, p, k)),
            })
        })
        .collect()
}

/// The normalised block grid of a `width x height` level approximated from `micro` (pooled from
/// another level of the same image), with cell values times `gain` (see the module docs; the
/// detector passes `√(r_x r_y)`). Bands of block rows run in parallel as in
/// [`super::block_grid_from_gamma_planes`]; the result does not depend on the thread count.
/// `dst`'s buffer is reused.
pub fn blocks_from_micro_grid(
    spec: &HogSpec,
    micro: &MicroGrid,
    width: usize,
    height: usize,
    gain: f32,
    exec: Exec,
    dst: &mut BlockGrid,
) {
    let isa = crate::kernels::isa();
    let fill = FillKernel::for_isa(isa, spec.nbins());
    blocks_from_micro_grid_with(isa, fill, spec, micro, width, height, gain, exec, dst)
}

/// [`blocks_from_micro_grid`] with the `isa` build of the kernels and the `fill` build of the
/// cell-row fill (the path's own is [`FillKernel::for_isa`]; tests pass the oracle).
#[allow(clippy::too_many_arguments)]
pub(super) fn blocks_from_micro_grid_with(
    isa: Isa,
    kernel: FillKernel,
    spec: &HogSpec,
    micro: &MicroGrid,
    width: usize,
    height: usize,
    gain: f32,
    exec: Exec,
    dst: &mut BlockGrid,
) {
    let (ncx, ncy) = (width / CELL_SIZE, height / CELL_SIZE);
    let nb = spec.nbins();
    if micro.nmx == 0 || micro.nmy == 0 || ncx == 0 || ncy == 0 {
        block_grid_shape(spec, 0, 0, dst);
        return;
    }
    // A grid pooled with another bin count has no blocks of this spec (checked, not assumed:
    // the fill kernels size their loads and stores by the grid's bins).
    debug_assert_eq!(micro.nbins, nb);
    if micro.nbins != nb {
        block_grid_shape(spec, 0, 0, dst);
        return;
    }
    let taps = Taps::new(spec, micro, width, height, gain);
    let scratch = |_| FillScratch::new();
    let fill = |cy: usize, row: &mut [f32], s: &mut FillScratch| kernel.fill(micro, &taps, cy, row, s);
    // Serially, one band: each cell row is filled once (bands share a cell row with the next,
    // which in parallel is the price of independence; a cell row is the same bits either way).
    let band_rows = match exec {
        Exec::Parallel => BAND_BLOCK_ROWS,
        Exec::Serial => ncy,
    };
    blocks_in_bands_with(spec, ncx, ncy, band_rows, exec, isa, dst, scratch, fill);
}

/// One level of [`approx_block_rows`]: the arguments `width`, `height` and `gain` of
/// [`blocks_from_micro_grid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ApproxLevel {
    /// Level width in pixels.
    pub width: usize,
    /// Level height in pixels.
    pub height: usize,
    /// Cell gain (the detector passes `√(r_x r_y)`).
    pub gain: f32,
}

/// Blocks across and down of a `width x height` level (what [`BlockGrid::blocks_x`] and
/// [`BlockGrid::blocks_y`] of its grid are).
pub fn block_grid_dims(width: usize, height: usize) -> (usize, usize) {
    (blocks_of(width / CELL_SIZE), blocks_of(height / CELL_SIZE))
}

/// Micro rows per step of [`approx_block_rows`]' sweep (16 pixel rows of the exact level: at
/// 1080p, 8 micro rows of half floats are 138 KB, which stay in L2 while every level reads them).
const SWEEP_MICRO_ROWS: usize = 8;

/// One level's state in [`approx_block_rows`].
struct Sweep {
    taps: Taps,
    ncx: usize,
    ncy: usize,
    /// The next cell row to fill (the one above it is in the ring).
    next: usize,
    /// Two cell rows: cell row `cy` in slot `cy % 2`.
    ring: Vec<f32>,
    /// The block row handed to the visitor.
    row: Vec<f32>,
    scratch: FillScratch,
}

/// The block rows of `levels`, each approximated from `micro` exactly as
/// [`blocks_from_micro_grid`] computes its grid (the same bits), handed to `visit(level, by,
/// row)`: for each level its rows `by = 0, 1, …` in order (levels interleaved), `row` holding
/// the level's [`block_grid_dims`] `.0` blocks. No block grid is made, so a caller can consume
/// (score) each row while it is in cache.
///
/// The levels go down the micro grid together: each step fills, for every level, the cell rows
/// whose micro rows all lie in the first 8·k rows (16·k pixel rows of the exact level). A micro row is then read
/// by all the levels while it is in cache, instead of the whole grid (9.3 MB at 1080p) once per
/// level from memory; a cell row is filled once (no bands). Serial, on the calling thread: a
/// caller splits its levels between threads (the results do not depend on the split).
pub fn approx_block_rows(
    spec: &HogSpec,
    micro: &MicroGrid,
    levels: &[ApproxLevel],
    bufs: &mut SweepBuffers,
    visit: impl FnMut(usize, usize, &[f32]),
) {
    approx_block_rows_with(crate::kernels::isa(), spec, micro, levels, bufs, visit)
}

/// The cell-row rings and block rows of [`approx_block_rows`], kept from call to call by a caller
/// that sweeps every frame (their contents do not matter: every value is written before it is
/// read).
#[derive(Debug, Default)]
pub struct SweepBuffers {
    rings: Vec<Vec<f32>>,
    rows: Vec<Vec<f32>>,
}

impl SweepBuffers {
    /// Buffer `j` of `v` with `n` values (grown with zeros if shorter; its values are stale).
    fn take(v: &mut Vec<Vec<f32>>, j: usize, n: usize) -> Vec<f32> {
        if v.len() <= j {
            v.resize_with(j + 1, Vec::new);
        }
        let mut b = std::mem::take(&mut v[j]);
        b.resize(n, 0.0);
        b
    }
}

/// [`approx_block_rows`] with the `isa` build of the kernels.
pub(super) fn approx_block_rows_with(
    isa: Isa,
    spec: &HogSpec,
    micro: &MicroGrid,
    levels: &[ApproxLevel],
    bufs: &mut SweepBuffers,
    mut visit: impl FnMut(usize, usize, &[f32]),
) {
    let nb = spec.nbins();
    // As `blocks_from_micro_grid_with`: an empty grid or one pooled with another bin count has
    // no blocks of this spec.
    debug_assert_eq!(micro.nbins, nb);
    if micro.nmx == 0 || micro.nmy == 0 || micro.nbins != nb {
        return;
    }
    let kernel = FillKernel::for_isa(isa, nb);
    let cl = cell_len(nb);
    let bl = spec.block_len();
    let mut sweeps: Vec<Option<Sweep>> = levels
        .iter()
        .enumerate()
        .map(|(j, lv)| {
            let (ncx, ncy) = (lv.width / CELL_SIZE, lv.height / CELL_SIZE);
            let (nbx, _) = block_grid_dims(lv.width, lv.height);
            if ncx < BLOCK_CELLS || ncy < BLOCK_CELLS || bl == 0 {
                return None;
            }
            let mut sw = Sweep {
                taps: Taps::new(spec, micro, lv.width, lv.height, lv.gain),
                ncx,
                ncy,
                next: 1,
                ring: SweepBuffers::take(&mut bufs.rings, j, 2 * ncx * cl),
                row: SweepBuffers::take(&mut bufs.rows, j, nbx * bl),
                scratch: FillScratch::new(),
            };
            kernel.fill(micro, &sw.taps, 0, &mut sw.ring[..ncx * cl], &mut sw.scratch);
            Some(sw)
        })
        .collect();
    let mut end = 0usize;
    loop {
        end = end.saturating_add(SWEEP_MICRO_ROWS);
        let last = end >= micro.nmy;
        if last {
            // Cell rows below the last micro row (no taps: all +0) come with the last step.
            end = usize::MAX;
        }
        for (j, sw) in sweeps.iter_mut().enumerate() {
            let Some(sw) = sw else { continue };
            while sw.next < sw.ncy && sw.taps.rows[sw.next].1 <= end {
                let cy = sw.next;
                let (a, b) = sw.ring.split_at_mut(sw.ncx * cl);
                let (top, bottom) = if cy % 2 == 1 { (a, b) } else { (b, a) };
                kernel.fill(micro, &sw.taps, cy, bottom, &mut sw.scratch);
                kernels::block_row(isa, spec, sw.ncx, top, bottom, &mut sw.row);
                visit(j, cy - 1, &sw.row);
                sw.next += 1;
            }
        }
        if last {
            break;
        }
    }
    for (j, sw) in sweeps.into_iter().enumerate() {
        if let Some(sw) = sw {
            (bufs.rings[j], bufs.rows[j]) = (sw.ring, sw.row);
        }
    }
}

/// The micro rows (or columns) `[lo, hi)` landing in each of `ncy` cell rows (columns)
/// (contiguous, since the mapping is monotonic).
fn row_ranges(yt: &[Option<AxisTap>], ncy: usize) -> Vec<(usize, usize)> {
    let mut rows = vec![(0usize, 0usize); ncy];
    for (my, t) in yt.iter().enumerate() {
        if let Some(t) = t {
            let r = &mut rows[t.cell];
            if r.1 == r.0 {
                *r = (my, my + 1);
            } else {
                r.1 = my + 1;
            }
        }
    }
    rows
}

impl Taps {
    /// The taps of the `width x height` level approximated from `micro`, cell values times `gain`.
    fn new(spec: &HogSpec, micro: &MicroGrid, width: usize, height: usize, gain: f32) -> Self {
        let (ncx, ncy) = (width / CELL_SIZE, height / CELL_SIZE);
        let rx = width as f64 / micro.width as f64;
        let ry = height as f64 / micro.height as f64;
        let xt = axis_taps(spec, micro.nmx, micro.size, rx, ncx);
        let yt = axis_taps(spec, micro.nmy, micro.size, ry, ncy);
        let rows = row_ranges(&yt, ncy);
        let cols = row_ranges(&xt, ncx);
        let xw: Vec<[f32; PROFILES]> = xt.iter().map(|t| t.map_or([0.0; PROFILES], |t| t.w)).collect();
        // The profile each half of a cell leaves out (2 on the left, 1 on the right).
        let off = |live: [usize; 3]| (0..PROFILES).find(|p| !live.contains(p)).expect("3 of 4 live");
        let (off_left, off_right) = (off(LEFT_PROFILES), off(RIGHT_PROFILES));
        let split = cols
            .iter()
            .map(|&(lo, hi)| {
                let mid = (lo..hi).find(|&mx| xw[mx][off_left] != 0.0).unwrap_or(hi);
                let ok = (lo..mid).all(|mx| xw[mx][off_left] == 0.0)
                    && (mid..hi).all(|mx| xw[mx][off_right] == 0.0);
                ok.then_some(mid)
            })
            .collect();
        Self {
            xt,
            yt,
            rows,
            cols,
            xw,
            split,
            ncx,
            gain,
            shape: (micro.nmx, micro.nmy, micro.nbins),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::hog::types::{f16_bits, f32_from_f16};
    use crate::features::hog::{blocks_from_cells, cell_grid_from_gamma_planes, CellGrid, HogOptions};

    #[test]
    fn the_x86_scalar_path_runs_the_unfused_fill() {
        // On x86-64 the baseline build has no FMA: there the fused fill's `mul_add` is a library
        // call, and with it the approximated pyramid was slower than the exact one (the x86
        // scalar path runs the unfused fill instead). Every other fill is fused.
        for nbins in [9, 18, 40] {
            let k = FillKernel::for_isa(Isa::Scalar, nbins);
            assert_eq!(
                k == FillKernel::ScalarUnfused,
                cfg!(target_arch = "x86_64"),
                "{nbins}"
            );
            for isa in [Isa::Avx2, Isa::Avx512, Isa::Neon] {
                if isa.is_available() {
                    assert_ne!(
                        FillKernel::for_isa(isa, nbins),
                        FillKernel::ScalarUnfused,
                        "{isa}"
                    );
                }
            }
        }
    }
    use crate::image::Image;

    fn spec() -> HogSpec {
        HogSpec::new(&HogOptions::default()).unwrap()
    }

    fn plane(w: usize, h: usize) -> Image<f32> {
        Image::from_fn(w, h, |x, y| {
            let v = ((x * 7 + y * 3 + (x * y) / 5) % 97) as f32 + 40.0 * ((x as f32) * 0.05).sin();
            v.max(0.0).sqrt()
        })
    }

    /// The micro-cells of the grey plane `img`.
    fn micro(img: &Image<f32>, size: usize, exec: Exec) -> MicroGrid {
        let mut m = MicroGrid::empty();
        micro_grid_from_gamma_planes(&spec(), &GammaPlanes::Grey(img.view()), size, exec, &mut m).unwrap();
        m
    }

    #[test]
    fn continuous_profiles_match_the_discrete_ones() {
        let s = spec();
        for p in 0..PROFILES {
            for k in 0..CELL_SIZE {
                assert!(
                    (profile_at(&s, p, k as f32) - s.profile[p][k]).abs() < 1e-7,
                    "p {p} k {k}"
                );
            }
        }
    }

    #[test]
    fn unit_micro_cells_at_ratio_one_give_the_exact_blocks() {
        let s = spec();
        let img = plane(83, 150);
        let gp = GammaPlanes::Grey(img.view());
        let mut cells = CellGrid::empty();
        cell_grid_from_gamma_planes(&s, &gp, Exec::Serial, &mut cells).unwrap();
        let mut exact = BlockGrid::empty();
        blocks_from_cells(&s, &cells, Exec::Serial, &mut exact);
        let m = micro(&img, 1, Exec::Parallel);
        let mut got = BlockGrid::empty();
        blocks_from_micro_grid(&s, &m, 83, 150, 1.0, Exec::Parallel, &mut got);
        assert_eq!(
            (got.blocks_x(), got.blocks_y()),
            (exact.blocks_x(), exact.blocks_y())
        );
        let worst = got
            .data
            .iter()
            .zip(&exact.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(worst < 1e-4, "{worst}");
    }

    #[test]
    fn coarser_micro_cells_stay_close_to_exact_at_ratio_one() {
        let s = spec();
        let img = plane(96, 160);
        let gp = GammaPlanes::Grey(img.view());
        let mut exact = BlockGrid::empty();
        crate::features::hog::block_grid_from_gamma_planes(&s, &gp, Exec::Serial, &mut exact).unwrap();
        let m = micro(&img, 2, Exec::Serial);
        let mut got = BlockGrid::empty();
        blocks_from_micro_grid(&s, &m, 96, 160, 1.0, Exec::Serial, &mut got);
        let bl = s.block_len();
        let mut cos = 0.0;
        let n = got.data.len() / bl;
        for (a, b) in got.data.chunks(bl).zip(exact.data.chunks(bl)) {
            let dot: f32 = a.iter().zip(b).map(|(x, y)| x * y).sum();
            let na: f32 = a.iter().map(|x| x * x).sum::<f32>().sqrt();
            let nb: f32 = b.iter().map(|x| x * x).sum::<f32>().sqrt();
            cos += dot / (na * nb).max(1e-12);
        }
        assert!(cos / n as f32 > 0.97, "{}", cos / n as f32);
    }

    #[test]
    fn approximation_does_not_depend_on_threads() {
        let s = spec();
        let img = plane(200, 260);
        let (a, b) = (
            micro(&img, MICRO_CELL, Exec::Parallel),
            micro(&img, MICRO_CELL, Exec::Serial),
        );
        assert_eq!(a, b);
        let (mut ga, mut gb) = (BlockGrid::empty(), BlockGrid::empty());
        blocks_from_micro_grid(&s, &a, 131, 171, 0.7, Exec::Parallel, &mut ga);
        blocks_from_micro_grid(&s, &a, 131, 171, 0.7, Exec::Serial, &mut gb);
        assert_eq!(ga, gb);
        assert_eq!((ga.blocks_x(), ga.blocks_y()), (131 / 8 - 1, 171 / 8 - 1));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let mut gc = BlockGrid::empty();
        pool.install(|| blocks_from_micro_grid(&s, &a, 131, 171, 0.7, Exec::Parallel, &mut gc));
        assert_eq!(ga, gc);
    }

    #[test]
    fn kernel_paths_swept_block_rows_equal_each_level_s_grid() {
        // Levels interleaved in one sweep (sizes from 0.95 to a level without blocks) give, row
        // by row and in order, the grids each level gets alone, on every path.
        let s = spec();
        let img = plane(200, 260);
        let m = micro(&img, MICRO_CELL, Exec::Serial);
        let levels: Vec<ApproxLevel> = [
            (190, 247, 0.95),
            (131, 171, 0.7),
            (100, 130, 0.5),
            (41, 60, 0.3),
            (12, 9, 0.1),
        ]
        .iter()
        .map(|&(width, height, gain)| ApproxLevel { width, height, gain })
        .collect();
        for isa in Isa::available() {
            let mut rows: Vec<Vec<f32>> = vec![Vec::new(); levels.len()];
            let mut next = vec![0usize; levels.len()];
            approx_block_rows_with(
                isa,
                &s,
                &m,
                &levels,
                &mut SweepBuffers::default(),
                |j, by, row| {
                    assert_eq!(by, next[j], "level {j}: rows in order");
                    next[j] += 1;
                    rows[j].extend_from_slice(row);
                },
            );
            for (j, lv) in levels.iter().enumerate() {
                let mut g = BlockGrid::empty();
                blocks_from_micro_grid_with(
                    isa,
                    FillKernel::for_isa(isa, s.nbins()),
                    &s,
                    &m,
                    lv.width,
                    lv.height,
                    lv.gain,
                    Exec::Parallel,
                    &mut g,
                );
                assert_eq!(block_grid_dims(lv.width, lv.height), (g.blocks_x(), g.blocks_y()));
                assert_eq!(next[j], g.blocks_y(), "{isa} level {j}");
                let same = rows[j].len() == g.data.len()
                    && rows[j]
                        .iter()
                        .zip(&g.data)
                        .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same, "{isa} level {j}");
            }
            assert!(next[0] > 16 && next[4] == 0);
        }
    }

    /// A spec with `nbins` bins.
    fn spec_nb(nbins: usize) -> HogSpec {
        HogSpec::new(&HogOptions {
            nbins,
            ..Default::default()
        })
        .unwrap()
    }

    #[test]
    fn kernel_paths_fill_gives_the_oracle_bits_or_the_unfused_bound() {
        // Integer-exact comparison: every fill makes the same fused multiply-adds in the same
        // order. AVX2 holds 4 bins in tail lanes only, 8 and 16 in one and two full registers,
        // 9 and 12 in one register and tail lanes (NEON: one to four registers); 18 is more
        // than the register fills hold (the portable fill of the path).
        let img = plane(150, 170);
        for nbins in [9, 4, 8, 12, 16, 18] {
            let s = spec_nb(nbins);
            let mut m = MicroGrid::empty();
            micro_grid_with(
                Isa::Scalar,
                &s,
                &GammaPlanes::Grey(img.view()),
                2,
                Exec::Serial,
                &mut m,
            )
            .unwrap();
            for (w, h) in [(150, 170), (119, 133), (80, 128)] {
                let (ncx, ncy) = (w / CELL_SIZE, h / CELL_SIZE);
                let taps = Taps::new(&s, &m, w, h, 0.8);
                assert!(taps.fits(&m));
                let run = |k: FillKernel| {
                    let mut sc = FillScratch::new();
                    let mut out = vec![f32::NAN; ncx * cell_len(nbins) * ncy];
                    for (cy, row) in out.chunks_mut(ncx * cell_len(nbins)).enumerate() {
                        k.fill(&m, &taps, cy, row, &mut sc);
                    }
                    out
                };
                let want = run(FillKernel::Scalar);
                assert!(want.iter().all(|v| v.is_finite()));
                // Every fill of this CPU but the unfused one gives the oracle's bits.
                for k in FillKernel::available(nbins) {
                    if k == FillKernel::ScalarUnfused {
                        continue;
                    }
                    let got = run(k);
                    assert!(
                        want.iter().zip(&got).all(|(a, b)| a.to_bits() == b.to_bits()),
                        "{k:?} {nbins} bins {w}x{h}"
                    );
                }
                // The unfused fill (what the x86-64 scalar path runs; tested on every CPU):
                // two roundings per step instead of one, so close, not the same bits, and it
                // does differ (the bound is not met by two identical fills only).
                let unfused = run(FillKernel::ScalarUnfused);
                let rel = kernels::UNFUSED_FILL_REL;
                assert!(
                    want.iter()
                        .zip(&unfused)
                        .all(|(a, b)| (a - b).abs() <= rel * a.abs()),
                    "{nbins} bins {w}x{h}"
                );
                assert!(
                    want.iter().zip(&unfused).any(|(a, b)| a != b),
                    "{nbins} bins {w}x{h}"
                );
            }
        }
    }

    #[test]
    fn kernel_paths_approximated_levels_equal_the_scalar_ones() {
        let img = plane(200, 260);
        for nbins in [9, 4] {
            let s = spec_nb(nbins);
            let gp = GammaPlanes::Grey(img.view());
            let mut m = MicroGrid::empty();
            micro_grid_with(Isa::Scalar, &s, &gp, 2, Exec::Serial, &mut m).unwrap();
            let mut want = BlockGrid::empty();
            let oracle = FillKernel::Scalar;
            blocks_from_micro_grid_with(
                Isa::Scalar,
                oracle,
                &s,
                &m,
                131,
                171,
                0.7,
                Exec::Serial,
                &mut want,
            );
            for isa in Isa::available() {
                let mut mi = MicroGrid::empty();
                micro_grid_with(isa, &s, &gp, 2, Exec::Parallel, &mut mi).unwrap();
                assert_eq!(mi, m, "{isa} {nbins} bins");
                let mut got = BlockGrid::empty();
                let fill = FillKernel::for_isa(isa, nbins);
                blocks_from_micro_grid_with(isa, fill, &s, &m, 131, 171, 0.7, Exec::Parallel, &mut got);
                assert_eq!((got.nbx, got.nby), (want.nbx, want.nby));
                if fill == FillKernel::ScalarUnfused {
                    // Cells within `UNFUSED_FILL_REL` of the oracle's; after L2-Hys (values
                    // below 1, a clip at 0.2) the blocks within 1e-5.
                    let worst = got
                        .data
                        .iter()
                        .zip(&want.data)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f32::max);
                    assert!(worst <= 1e-5, "{isa} {nbins} bins: {worst}");
                    continue;
                }
                assert!(
                    got.data
                        .iter()
                        .zip(&want.data)
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{isa} {nbins} bins"
                );
            }
        }
    }

    #[test]
    fn kernel_paths_fused_cells_and_micro_cells_equal_the_two_scalar_passes() {
        // Sizes with and without a right / bottom margin past the last whole cell, several
        // bands, odd widths; grey, mosaic and colour planes; 1 and 2 workers; one and two AVX2
        // registers per histogram (4 and 9 bins) and more than the register kernels hold (18).
        for (w, h, nbins) in [
            (160, 144, 9),
            (173, 299, 9),
            (66, 530, 9),
            (174, 298, 4),
            (301, 133, 9),
            (71, 128, 16),
            (90, 140, 18),
        ] {
            let s = spec_nb(nbins);
            let a = plane(w, h);
            let b = Image::from_fn(w, h, |x, y| a.get(w - 1 - x, y) * 0.7);
            let c = Image::from_fn(w, h, |x, y| a.get(x, h - 1 - y) + 1.0);
            let mut all = vec![
                GammaPlanes::Grey(a.view()),
                GammaPlanes::Colour([a.view(), b.view(), c.view()]),
            ];
            if w % 2 == 0 && h % 2 == 0 {
                all.push(GammaPlanes::Mosaic(a.view()));
            }
            for planes in all {
                let (mut want_b, mut want_m) = (BlockGrid::empty(), MicroGrid::empty());
                let p = planes_of(&s, &planes).unwrap();
                blocks_in_bands(&s, &p, Exec::Serial, CellKernel::Scalar, Isa::Scalar, &mut want_b);
                micro_grid_with(Isa::Scalar, &s, &planes, 2, Exec::Serial, &mut want_m).unwrap();
                for isa in Isa::available() {
                    for exec in [Exec::Serial, Exec::Parallel] {
                        let (mut got_b, mut got_m) = (BlockGrid::empty(), MicroGrid::empty());
                        // Stale contents in reused buffers must not leak through.
                        got_m.data = vec![0x7bff; 5];
                        block_and_micro_grids_with(isa, &s, &planes, 2, exec, &mut got_b, &mut got_m)
                            .unwrap();
                        assert_eq!(got_m, want_m, "{isa} {w}x{h} {exec:?}");
                        assert_eq!(got_b.blocks_x(), want_b.blocks_x());
                        assert_eq!(got_b.blocks_y(), want_b.blocks_y());
                        for by in 0..want_b.blocks_y() {
                            let (g, e) = (got_b.block_row(by), want_b.block_row(by));
                            assert!(
                                g.iter().zip(e).all(|(x, y)| x.to_bits() == y.to_bits()),
                                "{isa} {w}x{h} {nbins} bins row {by}"
                            );
                        }
                    }
                }
                // The public entry point runs the process's path.
                let (mut pb, mut pm) = (BlockGrid::empty(), MicroGrid::empty());
                block_and_micro_grids_from_gamma_planes(&s, &planes, 2, Exec::Parallel, &mut pb, &mut pm)
                    .unwrap();
                assert_eq!((pb, pm), (want_b, want_m));
            }
        }
    }

    #[test]
    fn every_cell_run_splits_where_the_profiles_say() {
        // The AVX-512 fill skips x-profile 2 left of a cell's split and 1 right of it; the
        // split must exist for the detector's profiles at every ratio it uses (else that fill
        // falls back to all four products, still correct but slower).
        let s = spec();
        let m = micro(&plane(400, 300), 2, Exec::Serial);
        for k in 0..14 {
            let r = 1.05f64.powi(-k);
            let (w, h) = ((400.0 * r).round() as usize, (300.0 * r).round() as usize);
            let taps = Taps::new(&s, &m, w, h, 1.0);
            assert_eq!(taps.split.len(), w / CELL_SIZE);
            for (cx, (sp, &(lo, hi))) in taps.split.iter().zip(&taps.cols).enumerate() {
                let mid = sp.unwrap_or_else(|| panic!("ratio {r}: cell {cx} has no split"));
                assert!(lo < hi && (lo..=hi).contains(&mid), "ratio {r}: cell {cx}");
            }
        }
    }

    #[test]
    fn kernel_paths_micro_rows_give_the_same_bits() {
        let s = spec();
        let img = plane(150, 170);
        let gp = GammaPlanes::Grey(img.view());
        let p = planes_of(&s, &gp).unwrap();
        let run = |isa: Isa| {
            let mut out = vec![0x7e00u16; (150 / 2) * 9 * 5];
            kernels::micro_rows(isa, &p, 9, 2, 7, &mut out);
            out
        };
        let want = run(Isa::Scalar);
        assert!(want.iter().all(|&v| f32_from_f16(v).is_finite()));
        assert_eq!(want, micro(&img, 2, Exec::Serial).data[7 * 75 * 9..12 * 75 * 9]);
        for isa in Isa::available() {
            assert_eq!(want, run(isa), "{isa}");
        }
    }

    #[test]
    fn kernel_paths_half_floats_round_trip_and_match_the_hardware() {
        // Every half float converts to f32 and back unchanged (NaNs stay NaNs).
        for h in 0..=u16::MAX {
            let f = f32_from_f16(h);
            if f.is_nan() {
                assert!(f32_from_f16(f16_bits(f)).is_nan());
            } else {
                assert_eq!(f16_bits(f), h, "{h:#06x} = {f}");
            }
        }
        // Rounding: ties to even, overflow, subnormals, underflow.
        assert_eq!(f16_bits(1.0 + 2f32.powi(-11)), 0x3c00); // tie, even stays
        assert_eq!(f16_bits(1.0 + 3.0 * 2f32.powi(-11)), 0x3c02); // tie, odd rounds up
        assert_eq!(f16_bits(65520.0), 0x7c00); // rounds past the largest finite to infinity
        assert_eq!(f16_bits(65519.0), 0x7bff);
        assert_eq!(f16_bits(2f32.powi(-25)), 0); // tie between 0 and the smallest subnormal
        assert_eq!(f16_bits(2f32.powi(-25) * 1.5), 1);
        assert_eq!(f16_bits(-0.0), 0x8000);
        // The software conversion equals F16C's on values of every magnitude.
        let mut vals: Vec<f32> = (0..200_000u32)
            .map(|i| f32::from_bits(i.wrapping_mul(2_654_435_761) >> 1))
            .filter(|v| v.is_finite())
            .collect();
        vals.extend((0..4096).map(|i| i as f32 * 0.013 + 0.5));
        let all: Vec<u16> = (0..=u16::MAX).collect();
        for isa in Isa::available() {
            let mut hw = vec![0u16; vals.len()];
            kernels::f16::to_f16_row(isa, &vals, &mut hw);
            for (v, h) in vals.iter().zip(&hw) {
                assert_eq!(f16_bits(*v), *h, "{isa} {v:e}");
            }
            let mut back = vec![0.0f32; all.len()];
            kernels::f16::from_f16_row(isa, &all, &mut back);
            for (&h, f) in all.iter().zip(&back) {
                assert_eq!(f.to_bits(), f32_from_f16(h).to_bits(), "{isa} {h:#06x}");
            }
        }
    }

    #[test]
    fn bad_inputs_are_errors() {
        let s = spec();
        let img = plane(64, 128);
        let gp = GammaPlanes::Grey(img.view());
        let mut m = MicroGrid::empty();
        for size in [0, 9] {
            assert_eq!(
                micro_grid_from_gamma_planes(&s, &gp, size, Exec::Serial, &mut m),
                Err(HogError::BadMicroCell(size))
            );
        }
        let small = plane(60, 128);
        assert!(matches!(
            micro_grid_from_gamma_planes(&s, &GammaPlanes::Grey(small.view()), 4, Exec::Serial, &mut m),
            Err(HogError::ImageTooSmall { .. })
        ));
        let odd = plane(65, 128);
        assert!(matches!(
            micro_grid_from_gamma_planes(&s, &GammaPlanes::Mosaic(odd.view()), 4, Exec::Serial, &mut m),
            Err(HogError::OddMosaic { .. })
        ));
        // An empty micro grid gives an empty block grid.
        let mut g = BlockGrid::empty();
        blocks_from_micro_grid(&s, &MicroGrid::empty(), 64, 128, 1.0, Exec::Serial, &mut g);
        assert_eq!((g.blocks_x(), g.blocks_y()), (0, 0));
    }
}
