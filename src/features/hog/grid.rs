//! The entry points from an input: gamma, cells and blocks in one call, their timing, and the
//! descriptor of a single window.

use super::cells::{cells_from_planes, cells_from_planes_with, CellGrid};
use super::input::{planes_from_input, planes_of};
use super::kernels::CellKernel;
use super::types::{Exec, Planes};
use super::{blocks_from_cells, BlockGrid, GammaPlanes, HogError, HogInput, HogSpec};

/// Wall time of the HOG stages of one [`block_grid`] call.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HogTimings {
    /// Input conversion and gamma.
    pub gamma: std::time::Duration,
    /// Gradients and orientation binning on their own. Zero where they are fused into
    /// [`Self::cells`] (every production path); only [`block_grid_stage_times`] measures them apart.
    pub gradients: std::time::Duration,
    /// Weighted cell histograms; in the production paths this includes the gradients and
    /// orientation binning (fused, one pass).
    pub cells: std::time::Duration,
    /// Block assembly from cells and L2-Hys normalisation.
    pub blocks: std::time::Duration,
}

impl std::ops::AddAssign for HogTimings {
    fn add_assign(&mut self, o: Self) {
        self.gamma += o.gamma;
        self.gradients += o.gradients;
        self.cells += o.cells;
        self.blocks += o.blocks;
    }
}

/// Compute the normalised block grid of `input` into `dst` (buffers reused); returns stage times.
pub fn block_grid(
    spec: &HogSpec,
    input: &HogInput,
    exec: Exec,
    dst: &mut BlockGrid,
) -> Result<HogTimings, HogError> {
    let t0 = std::time::Instant::now();
    let planes = planes_from_input(spec, input)?;
    let gamma = t0.elapsed();
    let (cells, blocks) = block_grid_from_planes(spec, &planes.view(), exec, dst);
    Ok(HogTimings {
        gamma,
        cells,
        blocks,
        ..Default::default()
    })
}

/// The normalised block grid of gamma-corrected planes, computed on the calling thread with the
/// stages **unfused and timed one by one** — a diagnostic for `mosaicd bench detect`, which
/// reports per-stage times the fused production path cannot give:
/// - `gradients`: one gradient and orientation-binning pass over every pixel row the cells use
///   (the same code and kernel build as the cell stage, results discarded);
/// - `cells`: the cell histograms
///   ([`cell_grid_from_gamma_planes`](super::cell_grid_from_gamma_planes), which computes the
///   gradients again) minus `gradients`;
/// - `blocks`: [`blocks_from_cells`] (assembly and L2-Hys).
///
/// The grid equals [`block_grid_from_gamma_planes`](super::block_grid_from_gamma_planes)'s bit for
/// bit. The sum exceeds the fused path's time (gradients run twice, and the cell grid goes through
/// memory).
pub fn block_grid_stage_times(
    spec: &HogSpec,
    planes: &GammaPlanes,
    dst: &mut BlockGrid,
) -> Result<HogTimings, HogError> {
    let p = planes_of(spec, planes)?;
    let kernel = CellKernel::detect(spec);
    let t0 = std::time::Instant::now();
    kernel.gradient_pass(spec, &p, spec.nbins());
    let gradients = t0.elapsed();
    let t1 = std::time::Instant::now();
    let mut cells = CellGrid::empty();
    cells_from_planes_with(spec, &p, Exec::Serial, kernel, &mut cells);
    let with_gradients = t1.elapsed();
    let t2 = std::time::Instant::now();
    blocks_from_cells(spec, &cells, Exec::Serial, dst);
    Ok(HogTimings {
        gamma: std::time::Duration::ZERO,
        gradients,
        cells: with_gradients.saturating_sub(gradients),
        blocks: t2.elapsed(),
    })
}

/// Allocating [`block_grid`] (parallel).
pub fn block_grid_from_input(spec: &HogSpec, input: &HogInput) -> Result<BlockGrid, HogError> {
    let mut g = BlockGrid::empty();
    block_grid(spec, input, Exec::Parallel, &mut g)?;
    Ok(g)
}

/// Cells then blocks of `p`, each stage timed.
fn block_grid_from_planes(
    spec: &HogSpec,
    p: &Planes,
    exec: Exec,
    dst: &mut BlockGrid,
) -> (std::time::Duration, std::time::Duration) {
    let t0 = std::time::Instant::now();
    let mut cells = CellGrid::empty();
    cells_from_planes(spec, p, exec, &mut cells);
    let t_cells = t0.elapsed();
    let t1 = std::time::Instant::now();
    blocks_from_cells(spec, &cells, exec, dst);
    (t_cells, t1.elapsed())
}

/// Descriptor of a whole image that is exactly one window (`cv2.HOGDescriptor().compute(img)`).
pub fn descriptor_from_window(spec: &HogSpec, input: &HogInput) -> Result<Vec<f32>, HogError> {
    let grid = block_grid_from_input(spec, input)?;
    grid.window_descriptor(spec, 0, 0)
}
