//! The types the HOG stages and kernels share, below both: the execution mode, gamma-corrected
//! planes, the kernels' scratch, the cell layout, the micro grid and the taps of an approximated
//! level, and half floats in software. Nothing here computes a feature; the math is in the parent
//! module and in [`approx`](super::approx).

use super::{HogSpec, BLOCK_CELLS, CELL_SIZE, L2HYS_EPS_PER_ELEMENT, PROFILES};
use crate::image::ImageView;

/// How the block grid is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Exec {
    /// Rayon over strips of cell rows (the caller's pool).
    #[default]
    Parallel,
    /// One thread (the test oracle for `Parallel`).
    Serial,
}

/// Gamma-corrected planes in 8-bit units: one plane, or three (B, G, R order as OpenCV) for RGB.
pub(super) struct Planes<'a> {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) planes: Vec<ImageView<'a, f32>>,
    /// Tap distance of the derivative: 1 for images, 2 for mosaics.
    pub(super) tap: usize,
}

/// Per-worker scratch of the cell kernels: the quantised gradients of one cell row (8 pixel rows)
/// and the rows [`gradient_row`](super::gradient::gradient_row) works in.
pub(super) struct CellScratch {
    pub(super) bins: Vec<[u8; 2]>,
    pub(super) wts: Vec<[f32; 2]>,
    pub(super) sc: RowScratch,
}

impl CellScratch {
    /// Room for 8 pixel rows of `width` pixels (the cell kernels use the first `ncx·8` of each row
    /// unless they also pool micro-cells, which reach the last even column).
    pub(super) fn new(width: usize) -> Self {
        let n = width * CELL_SIZE;
        Self {
            bins: vec![[0; 2]; n],
            wts: vec![[0.0; 2]; n],
            sc: RowScratch::new(width),
        }
    }
}

/// Scratch rows for [`gradient_row`](super::gradient::gradient_row).
pub(super) struct RowScratch {
    pub(super) dx: Vec<f32>,
    pub(super) dy: Vec<f32>,
    pub(super) m: Vec<f32>,
}

impl RowScratch {
    pub(super) fn new(w: usize) -> Self {
        Self {
            dx: vec![0.0; w],
            dy: vec![0.0; w],
            m: vec![0.0; w],
        }
    }
}

/// Values per cell: PROFILES (y) x PROFILES (x) x nbins.
pub(super) fn cell_len(nbins: usize) -> usize {
    PROFILES * PROFILES * nbins
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

/// `buf` resized to `n` values with unspecified contents (the kernels overwrite every value): a
/// shrink keeps the allocation without a `memset` pass over tens of MB per pyramid level, a buffer
/// that must grow is allocated zeroed (`calloc`: fresh pages are already zero).
pub(super) fn sized(buf: &mut Vec<f32>, n: usize) {
    if buf.capacity() < n {
        *buf = vec![0.0; n];
    } else if buf.len() >= n {
        buf.truncate(n);
    } else {
        buf.resize(n, 0.0);
    }
}

/// What block assembly and normalisation take from a [`HogSpec`].
#[derive(Clone, Copy)]
pub(super) struct BlockParams {
    /// Bins per histogram.
    pub(super) nb: usize,
    /// Values per block (`4·nb`).
    pub(super) bl: usize,
    /// First L2-Hys epsilon.
    pub(super) eps1: f32,
    /// L2-Hys clipping threshold.
    pub(super) thresh: f32,
}

impl BlockParams {
    #[inline(always)]
    pub(super) fn new(spec: &HogSpec) -> Self {
        let (nb, bl) = (spec.nbins(), spec.block_len());
        debug_assert!(bl == BLOCK_CELLS * BLOCK_CELLS * nb);
        Self {
            nb,
            bl,
            eps1: bl as f32 * L2HYS_EPS_PER_ELEMENT,
            thresh: spec.opts.l2hys_threshold,
        }
    }
}

/// Orientation histograms of `m x m`-pixel micro-cells of one level (no spatial weights): the
/// source of [`blocks_from_micro_grid`](super::blocks_from_micro_grid). Pixels beyond the last whole micro-cell are left out.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MicroGrid {
    pub(super) nmx: usize,
    pub(super) nmy: usize,
    pub(super) size: usize,
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) nbins: usize,
    /// Votes as IEEE half-precision bits ([`f16_bits`]), `[my][mx][bin]`.
    pub(super) data: Vec<u16>,
}

impl MicroGrid {
    /// Shape for `size`-pixel micro-cells of `p` (buffer reused, contents stale).
    pub(super) fn reshape(&mut self, p: &Planes, size: usize, nb: usize) {
        let (nmx, nmy) = (p.width / size, p.height / size);
        *self = MicroGrid {
            nmx,
            nmy,
            size,
            width: p.width,
            height: p.height,
            nbins: nb,
            data: std::mem::take(&mut self.data),
        };
        self.data.resize(nmx * nmy * nb, 0);
    }

    /// An empty grid (fill with [`micro_grid_from_gamma_planes`](super::micro_grid_from_gamma_planes)).
    pub fn empty() -> Self {
        Self::default()
    }
    /// Micro-cells across.
    pub fn cells_x(&self) -> usize {
        self.nmx
    }
    /// Micro-cells down.
    pub fn cells_y(&self) -> usize {
        self.nmy
    }
    /// Micro-cell side in pixels.
    pub fn cell_size(&self) -> usize {
        self.size
    }
    /// Width of the level the grid was pooled from, in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height of that level.
    pub fn height(&self) -> usize {
        self.height
    }
    /// The `nbins` votes of micro-cell (mx, my) (stored as half floats, returned exactly).
    pub fn cell(&self, mx: usize, my: usize) -> Vec<f32> {
        self.data[(my * self.nmx + mx) * self.nbins..][..self.nbins]
            .iter()
            .map(|&h| f32_from_f16(h))
            .collect()
    }
}

/// Where one micro-cell row or column lands in the target level: its cell and the weights of the
/// 4 profiles at its continuous offset in that cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct AxisTap {
    pub(super) cell: usize,
    pub(super) w: [f32; PROFILES],
}

/// The taps of one approximated level.
pub(super) struct Taps {
    pub(super) xt: Vec<Option<AxisTap>>,
    pub(super) yt: Vec<Option<AxisTap>>,
    /// Micro rows `[lo, hi)` landing in each cell row.
    pub(super) rows: Vec<(usize, usize)>,
    /// Micro columns `[lo, hi)` landing in each cell column.
    pub(super) cols: Vec<(usize, usize)>,
    /// The x-profile weights of each micro column (zeros where it has no tap).
    pub(super) xw: Vec<[f32; PROFILES]>,
    /// Per cell column, the micro column `mid` such that only [`LEFT_PROFILES`] can be non-zero
    /// on `[lo, mid)` and only [`RIGHT_PROFILES`] on `[mid, hi)` (always so for [`HogSpec`]'s
    /// profiles: the tent of a block's second cell starts at a cell's centre); `None` if not.
    pub(super) split: Vec<Option<usize>>,
    pub(super) ncx: usize,
    pub(super) gain: f32,
    /// The shape of the micro grid the taps were made for: micro-cells across and down, bins.
    pub(super) shape: (usize, usize, usize),
}

impl Taps {
    /// Whether these are taps of `micro` (every micro row and column they name is in it, and its
    /// buffer holds all its micro-cells): the check the fill kernels' loads rely on.
    pub(super) fn fits(&self, micro: &MicroGrid) -> bool {
        let (nmx, nmy, nb) = self.shape;
        (micro.nmx, micro.nmy, micro.nbins) == self.shape
            && micro.data.len() == nmx * nmy * nb
            && self.yt.len() == nmy
            && self.xt.len() == nmx
            && self.xw.len() == nmx
            && self.cols.len() == self.ncx
            && self.split.len() == self.ncx
    }
}

/// The x-profiles that can be non-zero in the left / right half of a cell ([`live_profiles`] of
/// the exact cell kernel): the register fill multiplies only these.
pub(super) const LEFT_PROFILES: [usize; 3] = live_profiles(0);
pub(super) const RIGHT_PROFILES: [usize; 3] = live_profiles(CELL_SIZE / 2);

/// Per-band buffers of the portable fill (`kernels::portable::fill_cell_row`).
pub(super) struct FillScratch {
    /// One micro row pooled horizontally: `[cell][x-profile][bin]`.
    pub(super) h: Vec<f32>,
    /// The cell row being built: `[y-profile][cell][x-profile][bin]`.
    pub(super) t: Vec<f32>,
    /// The micro row being pooled, as `f32` (kernels that cannot read half floats directly).
    pub(super) v: Vec<f32>,
}

impl FillScratch {
    /// Empty buffers; the portable fill sizes them on first use (the register fills need none).
    pub(super) fn new() -> Self {
        Self {
            h: Vec::new(),
            t: Vec::new(),
            v: Vec::new(),
        }
    }
}

/// IEEE 754 half-precision bits of `x`, rounded to nearest, ties to even (overflow to infinity,
/// underflow through the subnormals to zero; a NaN stays a quiet NaN).
pub(super) fn f16_bits(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let exp = ((b >> 23) & 0xff) as i32;
    let man = b & 0x7f_ffff;
    if exp == 0xff {
        return sign | 0x7c00 | if man != 0 { 0x200 | (man >> 13) as u16 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    let round = |r: u32, rem: u32, half: u32| r + u32::from(rem > half || (rem == half && r & 1 == 1));
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        let m = man | 0x80_0000;
        let shift = (14 - e) as u32;
        let r = round(m >> shift, m & ((1 << shift) - 1), 1 << (shift - 1));
        return sign | r as u16;
    }
    // A carry out of the mantissa moves into the exponent, which is the correct result (up to
    // infinity).
    let r = round(((e as u32) << 10) | (man >> 13), man & 0x1fff, 0x1000);
    sign | r as u16
}

/// The `f32` value of half-precision bits `h` (exact; a NaN keeps its payload and comes back
/// quiet).
pub(super) fn f32_from_f16(h: u16) -> f32 {
    let sign = u32::from(h & 0x8000) << 16;
    let exp = u32::from((h >> 10) & 0x1f);
    let man = u32::from(h & 0x3ff);
    let bits = match (exp, man) {
        (0, 0) => sign,
        (0, _) => {
            // Subnormal: normalise (2^-14 has f32 exponent 113).
            let shift = man.leading_zeros() - 21;
            sign | ((113 - shift) << 23) | (((man << shift) & 0x3ff) << 13)
        }
        (0x1f, 0) => sign | 0x7f80_0000,
        // A NaN comes back quiet, as F16C converts it.
        (0x1f, _) => sign | 0x7fc0_0000 | (man << 13),
        _ => sign | ((exp + 112) << 23) | (man << 13),
    };
    f32::from_bits(bits)
}

/// Most bins the register cell and fill kernels hold (one 16-lane AVX-512 register; two AVX2 or
/// four NEON registers per histogram).
pub(crate) const REGISTER_MAX_BINS: usize = 16;
