//! Histograms of oriented gradients (Dalal & Triggs 2005) with OpenCV's `HOGDescriptor` layout,
//! computed once per image into a grid of normalised blocks that every window reads.
//!
//! # Overview
//!
//! A [`HogSpec`] (built from [`HogOptions`], defaults = `cv2.HOGDescriptor()`: 64x128 window, 8x8
//! cells, 16x16 blocks, block stride 8, 9 unsigned bins, Gaussian block window σ = 4, L2-Hys clip
//! 0.2, sqrt gamma) turns an image ([`HogInput`]: grey u8 / u16 / f32, RGB u8, or a Bayer mosaic)
//! into a [`BlockGrid`]: every 16x16 block at every multiple of 8 pixels, normalised. A window's
//! 3780-value descriptor (OpenCV order) is read from the grid with [`BlockGrid::window_descriptor`];
//! the detector scores windows straight from the grid without building descriptors.
//!
//! ```
//! use mosaicd::features::hog::{block_grid_from_input, HogInput, HogOptions, HogSpec};
//! use mosaicd::image::Image;
//! let spec = HogSpec::new(&HogOptions::default()).unwrap();
//! let img = Image::<u8>::from_fn(64, 128, |x, y| ((x * 7 + y * 3) % 256) as u8);
//! let grid = block_grid_from_input(&spec, &HogInput::GreyU8(img.view())).unwrap();
//! let d = grid.window_descriptor(&spec, 0, 0).unwrap();
//! assert_eq!(d.len(), spec.descriptor_len());
//! assert_eq!(d.len(), 3780);
//! ```
//!
//! Levels of an approximate feature pyramid come from another level's orientation votes pooled
//! into micro-cells ([`micro_grid_from_gamma_planes`], [`blocks_from_micro_grid`]; the math and
//! how it differs from Dollár et al. and from our previous cell resampling are in `approx.rs`'s
//! module docs; [`ApproxLevel`]).
//!
//! # The math (as OpenCV `hog.cpp` computes it)
//!
//! 1. **Gamma**: every sample `v` (in 8-bit units, u16 inputs scaled by 255/max) becomes `√v`
//!    when `gamma_correction` is on (OpenCV's default).
//! 2. **Gradients** `dx = I(x+1) − I(x−1)`, `dy = I(y+1) − I(y−1)` with `BORDER_REFLECT_101`
//!    (so the outermost pixels have zero gradient across the border). Colour: per pixel the channel
//!    with the largest `dx²+dy²` wins, ties resolved like OpenCV (B over G over R). Mosaic
//!    ([`MosaicTaps`]): by default taps of the centre's own colour two pixels away, `dx =
//!    (I(x+2) − I(x−2)) / 2` (halved to the grey scale), so every difference is between
//!    same-colour pixels and no demosaicing is needed; reflect-101 keeps the colour phase.
//!    [`MosaicTaps::Paper`] is the paper's operator instead: the grey `[-1, 0, 1]` applied to the
//!    mosaic as it is, whose taps `x−1` and `x+1` also share a colour (at green pixels `dx` and
//!    `dy` then come from red and blue). It is finer (a two-pixel instead of a four-pixel
//!    derivative): on clean input it suits weights trained on grey gradients much better, under
//!    the paper's noise it is worse (docs/detection.md, "The mosaic derivative").
//! 3. **Orientation**: `θ = atan2(dy, dx)` with OpenCV's `fastAtan2` polynomial (≈0.01° accurate),
//!    unsigned: `a = θ·nbins/π − ½`, bin `⌊a⌋ mod nbins` gets `|g|(1−f)`, the next bin `|g|f`.
//! 4. **Block histograms**: a pixel at block position (i, j) votes with weight
//!    `exp(−((i−8)²+(j−8)²)/(2σ²))` times the bilinear weight of the cell centres of the *block*
//!    (cell coordinate `(j+½)/8 − ½`, votes leaving the block are dropped). Because that weight is
//!    separable, we compute once per 8x8 image cell 16 weighted 9-bin histograms (4 x-profiles x 4
//!    y-profiles: block-cell index x cell-in-block offset) and assemble every block from its four
//!    cells by additions only — each pixel is visited once per image, not once per block or window.
//! 5. **L2-Hys**: `v ← v / (‖v‖₂ + 0.1·36)`, clip at 0.2, `v ← v / (‖v‖₂ + 10⁻³)` (OpenCV's
//!    `normalizeBlockHistogram` epsilons).
//! 6. **Layout**: within a block, cells column-major ((0,0),(0,1),(1,0),(1,1)); within a window,
//!    blocks column-major (x outer, y inner), 105 blocks x 36 = 3780 values.
//!
//! # Deviations
//!
//! - Floating-point summation order differs from OpenCV (cells first, then blocks) and the Gaussian
//!   is evaluated as `g(i)·g(j)` instead of `exp` of the sum: differences are ≈1e-6, tested ≤ 1e-4.
//! - Cell size is fixed at 8 with 2x2-cell blocks and a block stride of one cell (OpenCV's default
//!   and what the shared block grid needs); window size and bin count are free.
//! - Mosaic input is our addition (Zhou, Zhang, Gao & Lou, "Gradient-based Feature Extraction From
//!   Raw Bayer Pattern Images").
//!
//! # References
//!
//! N. Dalal, B. Triggs, "Histograms of Oriented Gradients for Human Detection", CVPR 2005.
//! OpenCV `modules/objdetect/src/hog.cpp` (`computeGradient`, `HOGCache::init`,
//! `normalizeBlockHistogram`), `modules/core/src/mathfuncs_core.simd.hpp` (`fastAtan32f`).
//!
//! # Layout
//!
//! This file is the facade: it re-exports what callers use. The stages live in private
//! submodules, the per-row kernels (portable and per instruction set) below them. Imports only
//! point down the table (stages → `kernels` → `gradient` → `types` → `spec`, `error`):
//!
//! | module | holds |
//! |---|---|
//! | `grid` | the entry points from an input ([`block_grid`], [`block_grid_from_input`], …) and stage timing |
//! | `approx` | micro-cells and approximated pyramid levels ([`ApproxLevel`], [`approx_block_rows`]) (the method, the taps, the sweep) |
//! | `blocks` | [`BlockGrid`], the bands of cell rows → block rows |
//! | `cells` | [`CellGrid`], the parallel strips of cell rows |
//! | `input` | [`HogInput`], [`GammaPlanes`], gamma correction of whole planes |
//! | `kernels` | the choice of kernel per [`crate::kernels::isa`] and the dispatch (`kernels/mod.rs`); the AVX2, AVX-512 and NEON builds (`kernels/{avx2,avx512,neon}.rs`) and the half-float rows (`kernels/f16.rs`), the only files here with intrinsics; the portable kernels, the oracles (`kernels/portable.rs`: cell histograms, block assembly and [`normalize_l2hys`], micro rows, the approximated levels' fill) |
//! | `gradient` | derivatives, [`fast_atan2_deg`], orientation binning of a pixel row |
//! | `types` | [`Exec`], the planes, scratch, cell layout, [`MicroGrid`] and taps the stages and kernels share; half floats in software |
//! | `spec` | [`HogOptions`], [`MosaicTaps`], [`HogSpec`] (validated geometry and weight profiles) |
//! | `error` | [`HogError`] |
//! | [`MosaicTone`] | raw → mosaic in a model's tone (re-exported from `crate::raw`, its home) |

/// Cell side in pixels (OpenCV `cellSize` default; fixed here).
pub const CELL_SIZE: usize = 8;
/// Cells per block side (OpenCV `blockSize` 16 = 2 cells; fixed here).
pub const BLOCK_CELLS: usize = 2;
// Block assembly sums the 2x2 cells of a block explicitly.
const _: () = assert!(BLOCK_CELLS == 2);
/// Block side in pixels.
pub const BLOCK_SIZE: usize = CELL_SIZE * BLOCK_CELLS;
/// Block stride in pixels (one cell, OpenCV default; fixed here).
pub const BLOCK_STRIDE: usize = CELL_SIZE;
/// OpenCV's default orientation bin count.
pub const DEFAULT_NBINS: usize = 9;
/// OpenCV's default L2-Hys clipping threshold.
pub const DEFAULT_L2HYS_THRESHOLD: f32 = 0.2;
/// First-normalisation epsilon per histogram element (`normalizeBlockHistogram`: `sz*0.1f`).
const L2HYS_EPS_PER_ELEMENT: f32 = 0.1;
/// Second-normalisation epsilon (`normalizeBlockHistogram`: `1e-3f`).
const L2HYS_EPS2: f32 = 1e-3;
/// Samples are brought to 8-bit units before gamma so OpenCV-trained weights apply.
const UNIT_RANGE: f32 = 255.0;
/// Number of weight profiles per axis: block-cell index (2) x cell position in block (2).
const PROFILES: usize = BLOCK_CELLS * BLOCK_CELLS;
/// Cell rows per parallel strip.
const STRIP_CELL_ROWS: usize = 2;

mod approx;
mod blocks;
mod cells;
mod error;
mod gradient;
mod grid;
mod input;
mod kernels;
mod spec;
mod types;

pub use crate::raw::tone::{
    mosaic_from_raw, mosaic_from_raw_into, mosaic_from_raw_toned, mosaic_from_raw_toned_into,
    mosaic_from_raw_with, MosaicTone, ToneTables,
};
pub use approx::{
    approx_block_rows, block_and_micro_grids_from_gamma_planes, block_grid_dims, blocks_from_micro_grid,
    micro_grid_from_gamma_planes, ApproxLevel, MicroGrid, SweepBuffers, MICRO_CELL,
};
pub use blocks::{block_grid_from_gamma_planes, blocks_from_cells, BlockGrid, BAND_BLOCK_ROWS};
pub use cells::{cell_grid, cell_grid_from_gamma_planes, CellGrid};
pub use error::HogError;
pub use gradient::fast_atan2_deg;
pub use grid::{
    block_grid, block_grid_from_input, block_grid_stage_times, descriptor_from_window, HogTimings,
};
pub use input::{gamma_in_place, gamma_plane_into, GammaPlanes, HogInput};
pub use kernels::portable::normalize_l2hys;
pub use spec::{HogOptions, HogSpec, MosaicTaps, MAX_NBINS, MAX_WINDOW_SIDE};
pub use types::Exec;

#[cfg(test)]
mod tests;
