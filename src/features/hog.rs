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
//! how it differs from Dollár et al. and from our previous cell resampling: [`approx`]).
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

use rayon::prelude::*;

use crate::image::{Image, ImageView};

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

/// Errors of the HOG stage.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum HogError {
    /// Window size is not a positive multiple of the cell or is smaller than a block.
    #[error("HOG window {width}x{height} must be a multiple of the {cell}-pixel cell and at least {block}x{block}")]
    BadWindow {
        /// Requested width.
        width: usize,
        /// Requested height.
        height: usize,
        /// Cell size.
        cell: usize,
        /// Block size.
        block: usize,
    },
    /// Bin count outside 2..=255.
    #[error("HOG nbins must be in 2..=255, got {0}")]
    BadBins(usize),
    /// Clip threshold outside (0, 1].
    #[error("L2-Hys threshold must be in (0, 1], got {0}")]
    BadThreshold(f32),
    /// Gaussian window sigma not positive/finite.
    #[error("HOG window sigma must be positive and finite, got {0}")]
    BadSigma(f32),
    /// The image has no pixels or is smaller than one window.
    #[error("image {width}x{height} is smaller than one {win_width}x{win_height} HOG window")]
    ImageTooSmall {
        /// Image width.
        width: usize,
        /// Image height.
        height: usize,
        /// Window width.
        win_width: usize,
        /// Window height.
        win_height: usize,
    },
    /// A mosaic with an odd side (the 2x2 pattern would be cut).
    #[error("mosaic size {width}x{height} must be even in both directions")]
    OddMosaic {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// A micro-cell side outside 1..=8 ([`micro_grid_from_gamma_planes`]).
    #[error("micro-cell size must be in 1..=8 pixels, got {0}")]
    BadMicroCell(usize),
    /// A u16 input with a zero maximum.
    #[error("u16 input maximum value must be positive, got {0}")]
    BadMaxValue(u16),
    /// Window position outside the block grid.
    #[error("window at block ({bx}, {by}) does not fit the {nbx}x{nby} block grid")]
    WindowOutside {
        /// Block column of the window's top-left.
        bx: usize,
        /// Block row.
        by: usize,
        /// Grid width in blocks.
        nbx: usize,
        /// Grid height in blocks.
        nby: usize,
    },
    /// Colour planes of different sizes.
    #[error("colour plane is {width}x{height}, the first plane is {want_width}x{want_height}")]
    PlaneSize {
        /// Plane width.
        width: usize,
        /// Plane height.
        height: usize,
        /// First plane width.
        want_width: usize,
        /// First plane height.
        want_height: usize,
    },
    /// Output buffer has the wrong length.
    #[error("output buffer holds {actual} values, {expected} needed")]
    BadOutput {
        /// Needed.
        expected: usize,
        /// Given.
        actual: usize,
    },
}

/// User-facing HOG options (OpenCV `HOGDescriptor` defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HogOptions {
    /// Detection window width in pixels (OpenCV `winSize.width`, 64).
    pub win_width: usize,
    /// Detection window height in pixels (128).
    pub win_height: usize,
    /// Unsigned orientation bins over 0..180° (9).
    pub nbins: usize,
    /// Gaussian block window σ in pixels; `None` = OpenCV's (16+16)/8 = 4.
    pub win_sigma: Option<f32>,
    /// L2-Hys clip (0.2).
    pub l2hys_threshold: f32,
    /// Square-root gamma on the input (OpenCV default `true`).
    pub gamma_correction: bool,
    /// Mosaic input only: the derivative's taps. [`MosaicTaps::SameSite`] (the default) is
    /// `(I(x+2) − I(x−2)) / 2`, taps of the centre pixel's own colour; [`MosaicTaps::Paper`] is the
    /// paper's central difference `I(x+1) − I(x−1)`, whose two taps share a colour filter.
    pub mosaic_taps: MosaicTaps,
}

/// Which same-colour pixels a mosaic's HOG derivative subtracts (see the module docs, step 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MosaicTaps {
    /// The paper's `[-1, 0, 1]` on the mosaic: `I(x+1) − I(x−1)`, `I(y+1) − I(y−1)`. The two
    /// taps are two pixels apart and always of one colour (not necessarily the centre's).
    Paper,
    /// `(I(x+2) − I(x−2)) / 2`: taps of the centre pixel's colour, four pixels apart, halved
    /// (the default; every shipped mosaic model uses it).
    #[default]
    SameSite,
}

impl MosaicTaps {
    /// The name in model files, configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::SameSite => "same-site",
        }
    }

    /// Distance from the centre to each tap.
    pub fn distance(self) -> usize {
        match self {
            Self::Paper => 1,
            Self::SameSite => 2,
        }
    }
}

impl std::str::FromStr for MosaicTaps {
    type Err = String;
    /// `paper` or `same-site` (the names of [`MosaicTaps::name`]).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        [Self::Paper, Self::SameSite]
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("'{s}' is not one of: paper, same-site"))
    }
}

impl Default for HogOptions {
    fn default() -> Self {
        Self {
            win_width: 64,
            win_height: 128,
            nbins: DEFAULT_NBINS,
            win_sigma: None,
            l2hys_threshold: DEFAULT_L2HYS_THRESHOLD,
            gamma_correction: true,
            mosaic_taps: MosaicTaps::SameSite,
        }
    }
}

/// Validated HOG parameters plus the precomputed block weight profiles.
#[derive(Debug, Clone, PartialEq)]
pub struct HogSpec {
    opts: HogOptions,
    sigma: f32,
    /// `profile[p][k]`, p = block_cell*2 + cell_offset, k = pixel offset in the 8-pixel cell.
    profile: [[f32; CELL_SIZE]; PROFILES],
}

impl HogSpec {
    /// Validate options.
    pub fn new(opts: &HogOptions) -> Result<Self, HogError> {
        let (w, h) = (opts.win_width, opts.win_height);
        if w < BLOCK_SIZE || h < BLOCK_SIZE || w % CELL_SIZE != 0 || h % CELL_SIZE != 0 {
            return Err(HogError::BadWindow {
                width: w,
                height: h,
                cell: CELL_SIZE,
                block: BLOCK_SIZE,
            });
        }
        if !(2..=255).contains(&opts.nbins) {
            return Err(HogError::BadBins(opts.nbins));
        }
        if !(opts.l2hys_threshold > 0.0 && opts.l2hys_threshold <= 1.0) {
            return Err(HogError::BadThreshold(opts.l2hys_threshold));
        }
        let sigma = opts.win_sigma.unwrap_or((BLOCK_SIZE + BLOCK_SIZE) as f32 / 8.0);
        if !(sigma.is_finite() && sigma > 0.0) {
            return Err(HogError::BadSigma(sigma));
        }
        let scale = 1.0 / (sigma * sigma * 2.0);
        let half = BLOCK_SIZE as f32 * 0.5;
        let mut profile = [[0.0f32; CELL_SIZE]; PROFILES];
        for j in 0..BLOCK_SIZE {
            let d = j as f32 - half;
            let g = (-(d * d) * scale).exp();
            let cell = (j as f32 + 0.5) / CELL_SIZE as f32 - 0.5;
            let c0 = cell.floor();
            let f = cell - c0;
            let c0 = c0 as i64;
            let (off, k) = (j / CELL_SIZE, j % CELL_SIZE);
            for (c, wt) in [(c0, 1.0 - f), (c0 + 1, f)] {
                if (0..BLOCK_CELLS as i64).contains(&c) {
                    profile[c as usize * BLOCK_CELLS + off][k] = g * wt;
                }
            }
        }
        Ok(Self {
            opts: *opts,
            sigma,
            profile,
        })
    }

    /// The options this spec was built from.
    pub fn options(&self) -> &HogOptions {
        &self.opts
    }
    /// Window width.
    pub fn win_width(&self) -> usize {
        self.opts.win_width
    }
    /// Window height.
    pub fn win_height(&self) -> usize {
        self.opts.win_height
    }
    /// Bins.
    pub fn nbins(&self) -> usize {
        self.opts.nbins
    }
    /// Gaussian σ actually used.
    pub fn win_sigma(&self) -> f32 {
        self.sigma
    }
    /// Values per block (cells per block x bins, 36 by default).
    pub fn block_len(&self) -> usize {
        BLOCK_CELLS * BLOCK_CELLS * self.opts.nbins
    }
    /// Blocks per window (x, y): (7, 15) by default.
    pub fn blocks_per_window(&self) -> (usize, usize) {
        (
            (self.opts.win_width - BLOCK_SIZE) / BLOCK_STRIDE + 1,
            (self.opts.win_height - BLOCK_SIZE) / BLOCK_STRIDE + 1,
        )
    }
    /// Descriptor length (3780 by default).
    pub fn descriptor_len(&self) -> usize {
        let (bx, by) = self.blocks_per_window();
        bx * by * self.block_len()
    }
}

/// What HOG is computed from.
#[derive(Debug, Clone, Copy)]
pub enum HogInput<'a> {
    /// 8-bit grey (exactly OpenCV's path).
    GreyU8(ImageView<'a, u8>),
    /// 16-bit grey, scaled by 255 / `max_value`.
    GreyU16 {
        /// Pixels.
        image: ImageView<'a, u16>,
        /// Value that maps to 255.
        max_value: u16,
    },
    /// Float grey in 8-bit units (0..=255).
    GreyF32(ImageView<'a, f32>),
    /// 8-bit RGB (R, G, B order); OpenCV's per-pixel max-magnitude channel.
    Rgb8(ImageView<'a, [u8; 3]>),
    /// Float colour planes (R, G, B) in 8-bit units; OpenCV's max-magnitude channel.
    ColourF32([ImageView<'a, f32>; 3]),
    /// A Bayer mosaic, black-subtracted and scaled to 0..=255 (see [`mosaic_from_raw`]); gradients
    /// use same-colour taps two pixels apart.
    Mosaic(ImageView<'a, f32>),
}

impl HogInput<'_> {
    /// (width, height).
    pub fn dimensions(&self) -> (usize, usize) {
        match self {
            HogInput::GreyU8(v) => (v.width(), v.height()),
            HogInput::GreyU16 { image, .. } => (image.width(), image.height()),
            HogInput::GreyF32(v) | HogInput::Mosaic(v) => (v.width(), v.height()),
            HogInput::Rgb8(v) => (v.width(), v.height()),
            HogInput::ColourF32(p) => (p[0].width(), p[0].height()),
        }
    }
}

/// OpenCV's `fastAtan32f` in degrees, [0, 360) (branch-free so it vectorises).
#[inline(always)]
pub fn fast_atan2_deg(y: f32, x: f32) -> f32 {
    // Polynomial constants of OpenCV mathfuncs_core (atan2_p1..p7), in degrees.
    const DEG: f32 = (180.0 / std::f64::consts::PI) as f32;
    const P1: f32 = 0.999_787_84_f32 * DEG;
    const P3: f32 = -0.325_808_4_f32 * DEG;
    const P5: f32 = 0.155_578_65_f32 * DEG;
    const P7: f32 = -0.044_326_555_f32 * DEG;
    const EPS: f32 = f64::EPSILON as f32;
    let (ax, ay) = (x.abs(), y.abs());
    // ax >= ay: c = ay/(ax+eps); else c = ax/(ay+eps) — both are min/(max+eps).
    let c = ax.min(ay) / (ax.max(ay) + EPS);
    let c2 = c * c;
    let p = (((P7 * c2 + P5) * c2 + P3) * c2 + P1) * c;
    let a = if ax >= ay { p } else { 90.0 - p };
    let a = if x < 0.0 { 180.0 - a } else { a };
    if y < 0.0 {
        360.0 - a
    } else {
        a
    }
}

/// Gamma-corrected planes in 8-bit units: one plane, or three (B, G, R order as OpenCV) for RGB.
struct Planes<'a> {
    width: usize,
    height: usize,
    planes: Vec<ImageView<'a, f32>>,
    /// Tap distance of the derivative: 1 for images, 2 for mosaics.
    tap: usize,
}

/// [`Planes`] that own their pixels.
struct OwnedPlanes {
    planes: Vec<Image<f32>>,
    tap: usize,
}

impl OwnedPlanes {
    fn view(&self) -> Planes<'_> {
        Planes {
            width: self.planes[0].width(),
            height: self.planes[0].height(),
            planes: self.planes.iter().map(|p| p.view()).collect(),
            tap: self.tap,
        }
    }
}

/// Gamma-corrected planes handed to [`cell_grid_from_gamma_planes`]: every sample is already
/// `√max(v, 0)` (`max(v, 0)` when the spec's `gamma_correction` is off), as [`gamma_in_place`]
/// leaves it.
#[derive(Debug, Clone, Copy)]
pub enum GammaPlanes<'a> {
    /// One grey plane.
    Grey(ImageView<'a, f32>),
    /// A Bayer mosaic (even size).
    Mosaic(ImageView<'a, f32>),
    /// Three colour planes in OpenCV's B, G, R order (ties resolve towards B).
    Colour([ImageView<'a, f32>; 3]),
}

/// `ImageTooSmall` unless a `w x h` image holds one window.
fn check_fits(spec: &HogSpec, w: usize, h: usize) -> Result<(), HogError> {
    if w < spec.win_width() || h < spec.win_height() {
        return Err(HogError::ImageTooSmall {
            width: w,
            height: h,
            win_width: spec.win_width(),
            win_height: spec.win_height(),
        });
    }
    Ok(())
}

fn planes_from_input(spec: &HogSpec, input: &HogInput) -> Result<OwnedPlanes, HogError> {
    let (w, h) = input.dimensions();
    check_fits(spec, w, h)?;
    let gamma = spec.opts.gamma_correction;
    let g = move |v: f32| if gamma { v.sqrt() } else { v };
    let mut tap = 1;
    let planes = match input {
        HogInput::GreyU8(v) => {
            let lut: Vec<f32> = (0..256).map(|i| g(i as f32)).collect();
            vec![plane_map(*v, |p| lut[p as usize])]
        }
        HogInput::GreyU16 { image, max_value } => {
            if *max_value == 0 {
                return Err(HogError::BadMaxValue(0));
            }
            let s = UNIT_RANGE / *max_value as f32;
            vec![plane_map(*image, |p| g(p as f32 * s))]
        }
        HogInput::GreyF32(v) => vec![gamma_plane(*v, gamma)],
        HogInput::Mosaic(v) => {
            if w % 2 != 0 || h % 2 != 0 {
                return Err(HogError::OddMosaic { width: w, height: h });
            }
            tap = spec.opts.mosaic_taps.distance();
            vec![gamma_plane(*v, gamma)]
        }
        HogInput::ColourF32(p) => {
            for q in &p[1..] {
                if (q.width(), q.height()) != (w, h) {
                    return Err(HogError::PlaneSize {
                        width: q.width(),
                        height: q.height(),
                        want_width: w,
                        want_height: h,
                    });
                }
            }
            (0..3).map(|c| plane_map(p[2 - c], |v| g(v.max(0.0)))).collect()
        }
        HogInput::Rgb8(v) => {
            let lut: Vec<f32> = (0..256).map(|i| g(i as f32)).collect();
            // OpenCV order B, G, R: ties resolve towards B.
            (0..3)
                .map(|c| plane_map(*v, |p: [u8; 3]| lut[p[2 - c] as usize]))
                .collect()
        }
    };
    Ok(OwnedPlanes { planes, tap })
}

fn gamma_plane(v: ImageView<'_, f32>, gamma: bool) -> Image<f32> {
    let mut out = Image::new(0, 0);
    gamma_plane_into(v, gamma, &mut out);
    out
}

/// `dst` = `√max(v, 0)` (or `max(v, 0)` without gamma) of a float plane, rows in parallel,
/// vectorised; `dst`'s allocation is reused.
pub fn gamma_plane_into(v: ImageView<'_, f32>, gamma: bool, dst: &mut Image<f32>) {
    let w = v.width();
    dst.reshape(w, v.height());
    dst.as_mut_slice()
        .par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            row.copy_from_slice(v.row(y));
            gamma_in_place(row, gamma)
        });
}

/// `v ← √max(v, 0)` (or `max(v, 0)` without gamma) for every sample of `row` — HOG's gamma
/// correction (AVX2 `vsqrtps` when available: IEEE square root, the same bits as scalar code).
pub fn gamma_in_place(row: &mut [f32], gamma: bool) {
    #[cfg(target_arch = "x86_64")]
    if have_avx2() {
        // SAFETY: AVX2 and FMA were detected on this CPU (`have_avx2`).
        unsafe { gamma_in_place_avx2(row, gamma) };
        return;
    }
    gamma_in_place_generic(row, gamma)
}

/// [`gamma_in_place_generic`] compiled for AVX2 (8 lanes; same bits as scalar).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn gamma_in_place_avx2(row: &mut [f32], gamma: bool) {
    gamma_in_place_generic(row, gamma)
}

#[inline(always)]
fn gamma_in_place_generic(row: &mut [f32], gamma: bool) {
    if gamma {
        for v in row.iter_mut() {
            *v = v.max(0.0).sqrt();
        }
    } else {
        for v in row.iter_mut() {
            *v = v.max(0.0);
        }
    }
}

fn plane_map<P: Copy + Sync>(v: ImageView<'_, P>, f: impl Fn(P) -> f32 + Sync) -> Image<f32> {
    let (w, h) = (v.width(), v.height());
    let mut out = Image::<f32>::new(w, h);
    out.as_mut_slice()
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, row)| {
            for (o, &p) in row.iter_mut().zip(v.row(y)) {
                *o = f(p);
            }
        });
    let _ = h;
    out
}

/// `BORDER_REFLECT_101` index (for `n > tap`).
#[inline]
fn reflect101(i: isize, n: usize) -> usize {
    let n = n as isize;
    let r = if i < 0 {
        -i
    } else if i >= n {
        2 * n - 2 - i
    } else {
        i
    };
    r.clamp(0, n - 1) as usize
}

/// Per-worker scratch of the cell kernels: the quantised gradients of one cell row (8 pixel rows)
/// and the rows [`gradient_row`] works in.
struct CellScratch {
    bins: Vec<[u8; 2]>,
    wts: Vec<[f32; 2]>,
    sc: RowScratch,
}

impl CellScratch {
    /// Room for 8 pixel rows of `width` pixels (the cell kernels use the first `ncx·8` of each row
    /// unless they also pool micro-cells, which reach the last even column).
    fn new(width: usize) -> Self {
        let n = width * CELL_SIZE;
        Self {
            bins: vec![[0; 2]; n],
            wts: vec![[0.0; 2]; n],
            sc: RowScratch::new(width),
        }
    }
}

/// Scratch rows for [`gradient_row`].
struct RowScratch {
    dx: Vec<f32>,
    dy: Vec<f32>,
    m: Vec<f32>,
}

impl RowScratch {
    fn new(w: usize) -> Self {
        Self {
            dx: vec![0.0; w],
            dy: vec![0.0; w],
            m: vec![0.0; w],
        }
    }
}

/// Derivatives of one plane's row `y` into `dx`, `dy` (reflect-101 at the borders).
#[inline(always)]
fn derivatives(
    plane: ImageView<'_, f32>,
    tap: usize,
    y: usize,
    ym: usize,
    yp: usize,
    dx: &mut [f32],
    dy: &mut [f32],
) {
    let w = plane.width();
    let r = plane.row(y);
    let (rm, rp) = (plane.row(ym), plane.row(yp));
    for ((d, a), b) in dy.iter_mut().zip(rp).zip(rm) {
        *d = a - b;
    }
    if w > 2 * tap {
        for ((d, a), b) in dx[tap..w - tap].iter_mut().zip(&r[2 * tap..]).zip(r) {
            *d = a - b;
        }
    }
    let t = tap as isize;
    for x in (0..tap.min(w)).chain(w.saturating_sub(tap).max(tap.min(w))..w) {
        dx[x] = r[reflect101(x as isize + t, w)] - r[reflect101(x as isize - t, w)];
    }
}

/// One row of quantised gradients: two bins and two weights per pixel (OpenCV `qangle`, `grad`).
#[inline(always)]
fn gradient_row(
    p: &Planes,
    y: usize,
    nbins: usize,
    sc: &mut RowScratch,
    bins: &mut [[u8; 2]],
    wts: &mut [[f32; 2]],
) {
    let w = p.width;
    let t = p.tap as isize;
    let ym = reflect101(y as isize - t, p.height);
    let yp = reflect101(y as isize + t, p.height);
    let n = bins.len().min(w);
    derivatives(p.planes[0], p.tap, y, ym, yp, &mut sc.dx, &mut sc.dy);
    if p.planes.len() > 1 {
        // OpenCV colour rule: a later plane (B, G, R order) wins only when strictly larger.
        for (d, (a, b)) in sc.m.iter_mut().zip(sc.dx.iter().zip(&sc.dy)) {
            *d = a * a + b * b;
        }
        let mut dx2 = vec![0.0f32; w];
        let mut dy2 = vec![0.0f32; w];
        for plane in &p.planes[1..] {
            derivatives(*plane, p.tap, y, ym, yp, &mut dx2, &mut dy2);
            for x in 0..w {
                let m = dx2[x] * dx2[x] + dy2[x] * dy2[x];
                if m > sc.m[x] {
                    sc.m[x] = m;
                    sc.dx[x] = dx2[x];
                    sc.dy[x] = dy2[x];
                }
            }
        }
    }
    if p.tap == 2 {
        // Same-colour taps are two pixels apart: halve to keep the [-1,0,1] scale.
        sc.dx.iter_mut().for_each(|v| *v *= 0.5);
        sc.dy.iter_mut().for_each(|v| *v *= 0.5);
    }
    let angle_scale = (nbins as f64 / std::f64::consts::PI) as f32;
    let to_rad = (std::f64::consts::PI / 180.0) as f32;
    let nb = nbins as i32;
    // Vectorisable pass: magnitude into dx, bin coordinate into dy.
    for (dx, dy) in sc.dx[..n].iter_mut().zip(&mut sc.dy[..n]) {
        let (gx, gy) = (*dx, *dy);
        *dx = (gx * gx + gy * gy).sqrt();
        *dy = fast_atan2_deg(gy, gx) * to_rad * angle_scale - 0.5;
    }
    for x in 0..n {
        let (mag, ang) = (sc.dx[x], sc.dy[x]);
        let hf = ang.floor();
        let frac = ang - hf;
        let mut h = hf as i32;
        if h < 0 {
            h += nb;
        } else if h >= nb {
            h -= nb;
        }
        let h = h.clamp(0, nb - 1);
        let h1 = if h + 1 < nb { h + 1 } else { 0 };
        bins[x] = [h as u8, h1 as u8];
        wts[x] = [mag * (1.0 - frac), mag * frac];
    }
}

/// Normalised HOG blocks of one image at one scale: block (bx, by) covers pixels
/// `[8bx, 8bx+16) x [8by, 8by+16)`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BlockGrid {
    nbx: usize,
    nby: usize,
    block_len: usize,
    data: Vec<f32>,
}

impl BlockGrid {
    /// An empty grid (reuse with [`block_grid`]).
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

/// How the block grid is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Exec {
    /// Rayon over strips of cell rows (the caller's pool).
    #[default]
    Parallel,
    /// One thread (the test oracle for `Parallel`).
    Serial,
}

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
/// - `cells`: the cell histograms ([`cell_grid_from_gamma_planes`], which computes the gradients
///   again) minus `gradients`;
/// - `blocks`: [`blocks_from_cells`] (assembly and L2-Hys).
///
/// The grid equals [`block_grid_from_gamma_planes`]'s bit for bit. The sum exceeds the fused
/// path's time (gradients run twice, and the cell grid goes through memory).
pub fn block_grid_stage_times(
    spec: &HogSpec,
    planes: &GammaPlanes,
    dst: &mut BlockGrid,
) -> Result<HogTimings, HogError> {
    let p = planes_of(spec, planes)?;
    let kernel = CellKernel::detect(spec);
    let t0 = std::time::Instant::now();
    gradient_pass_with(kernel, &p, spec.nbins());
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

/// [`gradient_pass`] built as the cell kernel `kernel` builds [`gradient_row`].
fn gradient_pass_with(kernel: CellKernel, p: &Planes, nb: usize) {
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `kernel` comes from `CellKernel::detect`, which saw AVX2 and FMA.
        CellKernel::Avx2 => unsafe { gradient_pass_avx2(p, nb) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, plus AVX-512F.
        CellKernel::Avx512 => unsafe { gradient_pass_avx512(p, nb) },
        _ => gradient_pass(p, nb),
    }
}

/// [`gradient_pass`] compiled for AVX2 + FMA.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn gradient_pass_avx2(p: &Planes, nb: usize) {
    gradient_pass(p, nb)
}

/// [`gradient_pass`] compiled for AVX-512F (as `cells_strip_avx512`).
///
/// # Safety
/// The CPU must support AVX-512F, AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn gradient_pass_avx512(p: &Planes, nb: usize) {
    gradient_pass(p, nb)
}

/// Gradients and orientation bins of every pixel row the cells use, as the cell stage computes
/// them (each row's results marked as read, so the pass is not optimised away).
#[inline(always)]
fn gradient_pass(p: &Planes, nb: usize) {
    let w8 = p.width / CELL_SIZE * CELL_SIZE;
    let mut sc = RowScratch::new(p.width);
    let mut bins = vec![[0u8; 2]; w8];
    let mut wts = vec![[0.0f32; 2]; w8];
    for y in 0..p.height / CELL_SIZE * CELL_SIZE {
        gradient_row(p, y, nb, &mut sc, &mut bins, &mut wts);
        // The row's results count as read, at no cost.
        std::hint::black_box((&bins, &wts));
    }
}

/// Allocating [`block_grid`] (parallel).
pub fn block_grid_from_input(spec: &HogSpec, input: &HogInput) -> Result<BlockGrid, HogError> {
    let mut g = BlockGrid::empty();
    block_grid(spec, input, Exec::Parallel, &mut g)?;
    Ok(g)
}

/// `$fast` (an AVX2 + FMA build) when `$avx2`, else `$generic`. Callers pass `$avx2` = true only
/// when AVX2 and FMA were detected ([`have_avx2`]).
macro_rules! avx2_or_generic {
    ($avx2:expr, $fast:expr, $generic:expr) => {{
        #[cfg(target_arch = "x86_64")]
        if $avx2 {
            // SAFETY: `$avx2` is true only when AVX2 and FMA were detected (`have_avx2`); the
            // calling closures are not compiled with them, the `#[target_feature]` function is.
            return unsafe { $fast };
        }
        let _ = $avx2;
        $generic
    }};
}

// After the macro: the submodule uses it.
pub mod approx;
pub use crate::raw::tone::{
    self, mosaic_from_raw, mosaic_from_raw_into, mosaic_from_raw_toned, mosaic_from_raw_toned_into,
    mosaic_from_raw_with, MosaicTone, ToneTables,
};
pub use approx::{
    block_and_micro_grids_from_gamma_planes, blocks_from_micro_grid, micro_grid_from_gamma_planes, MicroGrid,
    MICRO_CELL,
};

/// Values per cell: PROFILES (y) x PROFILES (x) x nbins.
fn cell_len(nbins: usize) -> usize {
    PROFILES * PROFILES * nbins
}

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

/// Per-cell weighted histograms of one image at one scale: for each 8x8 cell, 4 y-profiles x 4
/// x-profiles x nbins values (see the module docs). Blocks are sums of four cells' entries.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CellGrid {
    ncx: usize,
    ncy: usize,
    cell_len: usize,
    data: Vec<f32>,
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

/// The normalised block grid of gamma-corrected planes, bit for bit the grid that
/// [`cell_grid_from_gamma_planes`] then [`blocks_from_cells`] give, without a whole-image cell
/// grid: bands of [`BAND_BLOCK_ROWS`] block rows run in parallel, each computes its cell rows one
/// at a time into a two-row ring (in cache) and assembles a block row as soon as both of its cell
/// rows are there. A band recomputes the cell row it shares with the next band (≈6 % more cell
/// work at 1080p), in exchange for no cell grid round trip through memory (≈36 MB per 1080p level).
/// `dst`'s buffer is reused.
pub fn block_grid_from_gamma_planes(
    spec: &HogSpec,
    planes: &GammaPlanes,
    exec: Exec,
    dst: &mut BlockGrid,
) -> Result<(), HogError> {
    let p = planes_of(spec, planes)?;
    blocks_in_bands(spec, &p, exec, CellKernel::detect(spec), have_avx2(), dst);
    Ok(())
}

/// Block rows per band of [`block_grid_from_gamma_planes`].
pub const BAND_BLOCK_ROWS: usize = 16;

/// [`block_grid_from_gamma_planes`] with a chosen cell kernel and block-row build.
fn blocks_in_bands(
    spec: &HogSpec,
    p: &Planes,
    exec: Exec,
    kernel: CellKernel,
    avx2: bool,
    dst: &mut BlockGrid,
) {
    let (ncx, ncy) = (p.width / CELL_SIZE, p.height / CELL_SIZE);
    let scratch = |_| CellScratch::new(p.width);
    let fill =
        |cy: usize, row: &mut [f32], cs: &mut CellScratch| cells_strip_with(kernel, spec, p, cy, row, cs);
    blocks_in_bands_with(spec, ncx, ncy, exec, avx2, dst, scratch, fill);
}

/// The blocks of `ncx x ncy` cells in bands of [`BAND_BLOCK_ROWS`] block rows: `fill(cy, row,
/// scratch)` writes cell row `cy` into `row`, each band keeps two cell rows in a ring. Band `b`
/// fills cell rows `16b ..= 16b + 16` (the last band up to `ncy − 1`) with its own
/// `scratch(b)`.
#[allow(clippy::too_many_arguments)]
fn blocks_in_bands_with<S>(
    spec: &HogSpec,
    ncx: usize,
    ncy: usize,
    exec: Exec,
    avx2: bool,
    dst: &mut BlockGrid,
    scratch: impl Fn(usize) -> S + Sync,
    fill: impl Fn(usize, &mut [f32], &mut S) + Sync,
) {
    let row_len = ncx * cell_len(spec.nbins());
    let Some(row_size) = block_grid_shape(spec, ncx, ncy, dst) else {
        return;
    };
    let band_work = |(b, band): (usize, &mut [f32])| {
        let by0 = b * BAND_BLOCK_ROWS;
        let mut cs = scratch(b);
        let mut ring = vec![0.0f32; 2 * row_len];
        fill(by0, &mut ring[..row_len], &mut cs);
        for (r, out) in band.chunks_mut(row_size).enumerate() {
            let (a, b) = ring.split_at_mut(row_len);
            let (top, bottom) = if r % 2 == 0 { (a, b) } else { (b, a) };
            fill(by0 + r + 1, bottom, &mut cs);
            block_row_with(spec, ncx, top, bottom, avx2, out);
        }
    };
    let band = BAND_BLOCK_ROWS * row_size;
    match exec {
        Exec::Parallel => dst.data.par_chunks_mut(band).enumerate().for_each(band_work),
        Exec::Serial => dst.data.chunks_mut(band).enumerate().for_each(band_work),
    }
}

/// Validated [`Planes`] of gamma-corrected input.
fn planes_of<'a>(spec: &HogSpec, planes: &GammaPlanes<'a>) -> Result<Planes<'a>, HogError> {
    let (views, tap) = match planes {
        GammaPlanes::Grey(v) => (vec![*v], 1),
        GammaPlanes::Mosaic(v) => (vec![*v], spec.opts.mosaic_taps.distance()),
        GammaPlanes::Colour(p) => (p.to_vec(), 1),
    };
    let (w, h) = (views[0].width(), views[0].height());
    check_fits(spec, w, h)?;
    if matches!(planes, GammaPlanes::Mosaic(_)) && (w % 2 != 0 || h % 2 != 0) {
        return Err(HogError::OddMosaic { width: w, height: h });
    }
    if let Some(q) = views.iter().find(|q| (q.width(), q.height()) != (w, h)) {
        return Err(HogError::PlaneSize {
            width: q.width(),
            height: q.height(),
            want_width: w,
            want_height: h,
        });
    }
    Ok(Planes {
        width: w,
        height: h,
        planes: views,
        tap,
    })
}

/// Whether the AVX2 + FMA builds of the kernels can run on this CPU.
#[inline]
fn have_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

fn cells_from_planes(spec: &HogSpec, p: &Planes, exec: Exec, out: &mut CellGrid) {
    cells_from_planes_with(spec, p, exec, CellKernel::detect(spec), out)
}

fn cells_from_planes_with(spec: &HogSpec, p: &Planes, exec: Exec, kernel: CellKernel, out: &mut CellGrid) {
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
        cells_strip_with(kernel, spec, p, s * STRIP_CELL_ROWS, chunk, &mut cs)
    };
    match exec {
        Exec::Parallel => cells.par_chunks_mut(strip.max(1)).enumerate().for_each(work),
        Exec::Serial => cells.chunks_mut(strip.max(1)).enumerate().for_each(work),
    }
}

/// Which build of the cell-histogram kernel runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CellKernel {
    /// Portable code (the reference).
    Generic,
    /// The portable code compiled for AVX2 + FMA.
    Avx2,
    /// AVX-512F: per-cell histograms held in registers, one-hot bin vectors instead of scalar
    /// scatter (needs ≤ 16 bins).
    Avx512,
}

impl CellKernel {
    /// Every kernel this CPU runs for `spec`, slowest first.
    fn available(spec: &HogSpec) -> Vec<Self> {
        let nbins = spec.nbins();
        let fixed_zeros = profiles_have_fixed_zeros(&spec.profile);
        #[allow(unused_mut)]
        let mut v = vec![Self::Generic];
        #[cfg(target_arch = "x86_64")]
        {
            if have_avx2() {
                v.push(Self::Avx2);
                if std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512bw")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && nbins <= AVX512_MAX_BINS
                    && fixed_zeros
                {
                    v.push(Self::Avx512);
                }
            }
        }
        let _ = (nbins, fixed_zeros);
        v
    }
    fn detect(spec: &HogSpec) -> Self {
        *Self::available(spec).last().unwrap_or(&Self::Generic)
    }
}

/// Most bins the AVX-512 cell kernel holds in one 16-lane register.
const AVX512_MAX_BINS: usize = 16;

/// The cell rows from `cy0` on (as many as `chunk` holds) with `kernel`.
fn cells_strip_with(
    kernel: CellKernel,
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
) {
    match kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `kernel` comes from `CellKernel::available`, so AVX2 and FMA were detected. The
        // closure that calls this is not compiled with those features; the strip function is.
        CellKernel::Avx2 => unsafe { cells_strip_avx2(spec, p, cy0, chunk, cs) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, plus AVX-512F, nbins ≤ 16 and the profiles' fixed zeros checked by
        // `CellKernel::available`.
        CellKernel::Avx512 => unsafe { cells_strip_avx512(spec, p, cy0, chunk, cs) },
        _ => cells_strip(spec, p, cy0, chunk, cs),
    }
}

/// [`cells_strip`] with the per-cell accumulation in AVX-512 registers: for every cell, the 16
/// (y-profile, x-profile) histograms live in 16 zmm registers (bins in lanes) for its 8 pixel rows;
/// a pixel's two votes become the vector `w0·e(b0) + w1·e(b1)` (`e` = unit vectors), added with the
/// x-profile weights into 4 row accumulators, which are added with the y-profile weights into the
/// 16 cell accumulators (fused multiply-adds). Every lane sees exactly the fused multiply-adds, in
/// the same order, of the scalar scatter in [`cells_strip`] (other lanes add `w·0 = +0`), so the
/// result is bit-identical. Measured ≈1.4x less CPU for the cell stage than the AVX2 build of the
/// scalar scatter, which stalls on store-to-load forwarding.
///
/// # Safety
/// The CPU must support AVX-512F/BW/VL, AVX2 and FMA, `spec.nbins() ≤ 16`, and the profiles of
/// `spec` must be zero outside [`live_profiles`] ([`profiles_have_fixed_zeros`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
unsafe fn cells_strip_avx512(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
) {
    // SAFETY: this function's target features; no micro-cells requested.
    unsafe { cells_strip_avx512_body::<false>(spec, p, cy0, chunk, cs, &mut []) }
}

/// [`cells_strip_avx512`] for one cell row `cy` that also pools the row's 2x2-pixel micro-cells
/// (its 4 micro rows, `(p.width / 2) · nbins` half floats each, into `micro`) from the same
/// gradients: each micro-cell is the sum of its 4 pixels' one-hot vote vectors, in the pixel
/// order of [`approx::micro_grid_from_gamma_planes`] (rows, then columns; other lanes add +0),
/// rounded to half floats as it does — the same bits, without computing the gradients twice.
/// Micro-cells right of the last whole cell are summed by a scalar loop in the same order.
///
/// # Safety
/// As [`cells_strip_avx512`]; `chunk` is one cell row and `micro` holds its 4 micro rows.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
unsafe fn cells_micro_row_avx512(
    spec: &HogSpec,
    p: &Planes,
    cy: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    debug_assert_eq!(micro.len(), CELL_SIZE / 2 * (p.width / 2) * spec.nbins());
    // SAFETY: this function's target features; `micro` holds the row's micro rows.
    unsafe { cells_strip_avx512_body::<true>(spec, p, cy, chunk, cs, micro) }
}

/// The body of [`cells_strip_avx512`] and [`cells_micro_row_avx512`].
///
/// # Safety
/// As [`cells_micro_row_avx512`] when `MICRO`, else as [`cells_strip_avx512`].
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn cells_strip_avx512_body<const MICRO: bool>(
    spec: &HogSpec,
    p: &Planes,
    cy0: usize,
    chunk: &mut [f32],
    cs: &mut CellScratch,
    micro: &mut [u16],
) {
    use std::arch::x86_64::*;
    let nb = spec.nbins();
    debug_assert!(nb <= AVX512_MAX_BINS && PROFILES == 4);
    let ncx = p.width / CELL_SIZE;
    let cl = cell_len(nb);
    // Micro-cells across (2x2 pixels), per cell, and the pixel columns (the row stride of
    // `bins` / `wts`) the gradient rows must cover.
    let nmx = p.width / 2;
    const PER_CELL: usize = CELL_SIZE / 2;
    let stride = if MICRO { nmx * 2 } else { ncx * CELL_SIZE };
    let CellScratch { bins, wts, sc } = cs;
    let prof = spec.profile;
    let mask: __mmask16 = ((1u32 << nb) - 1) as __mmask16;
    for (k, cell_row) in chunk.chunks_mut(ncx * cl).enumerate() {
        let cy = cy0 + k;
        for i in 0..CELL_SIZE {
            let r = i * stride..(i + 1) * stride;
            gradient_row(p, cy * CELL_SIZE + i, nb, sc, &mut bins[r.clone()], &mut wts[r]);
        }
        for (cx, cell) in cell_row.chunks_exact_mut(cl).enumerate() {
            let mut cacc = [_mm512_setzero_ps(); PROFILES * PROFILES];
            // The micro-cells of the current pair of pixel rows (MICRO only).
            let mut macc = [_mm512_setzero_ps(); PER_CELL];
            // Fully unrolled over the 8 pixel rows and columns so that every accumulator index
            // is a constant (registers, no spills) and no weight is tested at run time.
            macro_rules! pixel_row {
                ($i:literal) => {{
                    let o = $i * stride + cx * CELL_SIZE;
                    let mut acc = [_mm512_setzero_ps(); PROFILES];
                    pixel_col!(o, acc, 0);
                    pixel_col!(o, acc, 1);
                    pixel_col!(o, acc, 2);
                    pixel_col!(o, acc, 3);
                    pixel_col!(o, acc, 4);
                    pixel_col!(o, acc, 5);
                    pixel_col!(o, acc, 6);
                    pixel_col!(o, acc, 7);
                    for py in live_profiles($i) {
                        let wv = _mm512_set1_ps(prof[py][$i]);
                        for px in 0..PROFILES {
                            let c = &mut cacc[py * PROFILES + px];
                            *c = _mm512_fmadd_ps(wv, acc[px], *c);
                        }
                    }
                    if MICRO && $i % 2 == 1 {
                        let row = &mut micro[($i / 2) * nmx * nb..][..nmx * nb];
                        for (c, m) in macc.iter_mut().enumerate() {
                            let h = _mm512_cvtps_ph::<_MM_FROUND_TO_NEAREST_INT>(*m);
                            debug_assert!((cx * PER_CELL + c + 1) * nb <= row.len());
                            // SAFETY: `nb` half floats of micro-cell PER_CELL·cx + c < nmx of this row.
                            unsafe {
                                _mm256_mask_storeu_epi16(
                                    row.as_mut_ptr().add((cx * PER_CELL + c) * nb) as *mut i16,
                                    mask,
                                    h,
                                )
                            };
                            *m = _mm512_setzero_ps();
                        }
                    }
                }};
            }
            macro_rules! pixel_col {
                ($o:expr, $acc:ident, $j:literal) => {{
                    let ([b0, b1], [w0, w1]) = (bins[$o + $j], wts[$o + $j]);
                    debug_assert!((b0 as usize) < nb && (b1 as usize) < nb);
                    // Lane b0 = w0, lane b1 = w1 (b0 ≠ b1), other lanes +0: the same bits as
                    // w0·e(b0) + w1·e(b1), since both weights are ≥ +0.
                    let v = _mm512_maskz_mov_ps(1 << b0, _mm512_set1_ps(w0));
                    let v = _mm512_mask_mov_ps(v, 1 << b1, _mm512_set1_ps(w1));
                    for px in live_profiles($j) {
                        $acc[px] = _mm512_fmadd_ps(_mm512_set1_ps(prof[px][$j]), v, $acc[px]);
                    }
                    if MICRO {
                        macc[$j / 2] = _mm512_add_ps(macc[$j / 2], v);
                    }
                }};
            }
            pixel_row!(0);
            pixel_row!(1);
            pixel_row!(2);
            pixel_row!(3);
            pixel_row!(4);
            pixel_row!(5);
            pixel_row!(6);
            pixel_row!(7);
            debug_assert!(cell.len() == PROFILES * PROFILES * nb);
            for (n, c) in cacc.iter().enumerate() {
                let slot = cell_slot(n / PROFILES, n % PROFILES);
                // SAFETY: the masked store writes lanes 0..nb at slot·nb, inside the cell (16·nb).
                unsafe { _mm512_mask_storeu_ps(cell.as_mut_ptr().add(slot * nb), mask, *c) };
            }
        }
        if MICRO && ncx * PER_CELL < nmx {
            // Micro-cells right of the last whole cell, summed in the same pixel order.
            let mut acc = vec![0.0f32; nb];
            for a in 0..PER_CELL {
                for mx in ncx * PER_CELL..nmx {
                    acc.fill(0.0);
                    for y in 2 * a..2 * a + 2 {
                        for x in 2 * mx..2 * mx + 2 {
                            let ([b0, b1], [w0, w1]) = (bins[y * stride + x], wts[y * stride + x]);
                            acc[b0 as usize] += w0;
                            acc[b1 as usize] += w1;
                        }
                    }
                    let out = &mut micro[(a * nmx + mx) * nb..][..nb];
                    for (o, &v) in out.iter_mut().zip(&acc) {
                        *o = approx::f16_bits(v);
                    }
                }
            }
        }
    }
}

/// The profiles that can be non-zero at pixel offset `k` of a cell: a pixel in the left (upper)
/// half of a cell never votes for the far block cell when its cell is the first of the block
/// (profile 2), nor in the right half for the near block cell when its cell is the second
/// (profile 1). [`HogSpec::new`] never writes those entries; [`profiles_have_fixed_zeros`] checks.
#[inline(always)]
const fn live_profiles(k: usize) -> [usize; 3] {
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
const fn cell_slot(py: usize, px: usize) -> usize {
    let (bcy, sy) = (py / BLOCK_CELLS, py % BLOCK_CELLS);
    let (bcx, sx) = (px / BLOCK_CELLS, px % BLOCK_CELLS);
    (sy * BLOCK_CELLS + sx) * BLOCK_CELLS * BLOCK_CELLS + bcx * BLOCK_CELLS + bcy
}

/// Whether every profile entry outside [`live_profiles`] is exactly zero (true for every spec
/// [`HogSpec::new`] builds; the AVX-512 cell kernel relies on it). Live entries may be zero too:
/// adding `0·v` to a non-negative sum leaves its bits unchanged, as skipping it does.
fn profiles_have_fixed_zeros(profile: &[[f32; CELL_SIZE]; PROFILES]) -> bool {
    (0..CELL_SIZE).all(|k| (0..PROFILES).all(|p| live_profiles(k).contains(&p) || profile[p][k] == 0.0))
}

/// [`cells_strip`] compiled for AVX2 + FMA (vectorises the magnitude/atan pass 8 lanes wide).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn cells_strip_avx2(spec: &HogSpec, p: &Planes, cy0: usize, chunk: &mut [f32], cs: &mut CellScratch) {
    cells_strip(spec, p, cy0, chunk, cs)
}

/// Cell histograms of strip `s` (STRIP_CELL_ROWS cell rows) into `chunk`. Votes are accumulated
/// with [`f32::mul_add`] (one rounding, as the FMA kernels): native on AArch64 and in the AVX2 + FMA
/// build, a slow library call only on x86 CPUs without FMA.
#[inline(always)]
fn cells_strip(spec: &HogSpec, p: &Planes, cy0: usize, chunk: &mut [f32], cs: &mut CellScratch) {
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

/// Assemble and L2-Hys-normalise every block from a cell grid.
pub fn blocks_from_cells(spec: &HogSpec, cg: &CellGrid, exec: Exec, dst: &mut BlockGrid) {
    block_rows_with(spec, cg, exec, have_avx2(), dst)
}

/// [`blocks_from_cells`], with the AVX2 + FMA build of the row function when `avx2` (which must
/// then be supported by the CPU).
fn block_rows_with(spec: &HogSpec, cg: &CellGrid, exec: Exec, avx2: bool, dst: &mut BlockGrid) {
    let (ncx, cl) = (cg.ncx, cg.cell_len);
    let Some(row_size) = block_grid_shape(spec, ncx, cg.ncy, dst) else {
        return;
    };
    let row_work = |(by, row): (usize, &mut [f32])| {
        let cell_row = |cy: usize| &cg.data[cy * ncx * cl..][..ncx * cl];
        block_row_with(spec, ncx, cell_row(by), cell_row(by + 1), avx2, row)
    };
    match exec {
        Exec::Parallel => dst.data.par_chunks_mut(row_size).enumerate().for_each(row_work),
        Exec::Serial => dst.data.chunks_mut(row_size).enumerate().for_each(row_work),
    }
}

/// Size `dst` for the blocks of `ncx x ncy` cells; the length of one block row, or `None` when
/// there are no blocks.
fn block_grid_shape(spec: &HogSpec, ncx: usize, ncy: usize, dst: &mut BlockGrid) -> Option<usize> {
    let nbx = ncx.saturating_sub(BLOCK_CELLS - 1);
    let nby = ncy.saturating_sub(BLOCK_CELLS - 1);
    let bl = spec.block_len();
    dst.nbx = nbx;
    dst.nby = nby;
    dst.block_len = bl;
    sized(&mut dst.data, nbx * nby * bl);
    (bl > 0 && nbx > 0 && nby > 0).then_some(nbx * bl)
}

/// [`block_row`], the AVX2 + FMA build when `avx2` (which must then be supported by the CPU).
fn block_row_with(spec: &HogSpec, ncx: usize, top: &[f32], bottom: &[f32], avx2: bool, row: &mut [f32]) {
    avx2_or_generic!(
        avx2,
        block_row_avx2(spec, ncx, top, bottom, row),
        block_row(spec, ncx, top, bottom, row)
    )
}

/// Blocks per batch of [`block_row_avx2`].
#[cfg(target_arch = "x86_64")]
const BLOCK_BATCH: usize = 8;

/// [`block_row`] with AVX2, bit for bit: the blocks are taken in batches of [`BLOCK_BATCH`] so
/// that each of the two normalisations runs one horizontal reduction → square root → division
/// chain for eight blocks at once (in [`block_row`] that latency-bound chain runs twice per block;
/// ≈2x less time per block on a 1080p row).
///
/// A batch is assembled as in [`block_row`] (same four-run sum from `0.0`), and each block's 8
/// partial sums of squares (lane `i mod 8`, one ymm per block, added chunk after chunk as
/// [`sum_of_squares`] does) are reduced across the batch by [`lane_sums_avx2`], which combines
/// the lanes of each block in the same order ((0+4)+(2+6))+((1+5)+(3+7)) with vertical adds.
/// The square root and division are then done for the eight blocks in one vector; IEEE `sqrt`
/// and `/` are correctly rounded, so each lane has the bits of the scalar ones. Products and sums
/// are separate multiplies and adds (no FMA), as in the scalar code (Rust never contracts them),
/// and `min(x, thresh)` returns `thresh` for a NaN `x` like [`f32::min`] (`thresh` is never NaN:
/// [`HogSpec::new`] checks it). The last `nbx mod 8` blocks go through [`block_at`].
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn block_row_avx2(spec: &HogSpec, ncx: usize, top: &[f32], bottom: &[f32], row: &mut [f32]) {
    let bp = BlockParams::new(spec);
    let (bl, cl) = (bp.bl, cell_len(bp.nb));
    let nbx = row.len() / bl;
    // Every run read below lies in cell bx or bx + 1 ≤ nbx < ncx of `top` or `bottom`.
    assert!(row.len() == nbx * bl && nbx < ncx && top.len() >= ncx * cl && bottom.len() >= ncx * cl);
    let batches = nbx / BLOCK_BATCH;
    for batch in 0..batches {
        let bx0 = batch * BLOCK_BATCH;
        let out = &mut row[bx0 * bl..][..BLOCK_BATCH * bl];
        // SAFETY: the CPU has AVX2 (this function's contract); `out` and the runs are in bounds
        // (assert above).
        unsafe {
            if bp.nb == DEFAULT_NBINS {
                // The detector's bins, with the chunk counts constant.
                let bp = BlockParams {
                    nb: DEFAULT_NBINS,
                    bl: BLOCK_CELLS * BLOCK_CELLS * DEFAULT_NBINS,
                    ..bp
                };
                block_batch_avx2(&bp, top, bottom, bx0, out)
            } else {
                block_batch_avx2(&bp, top, bottom, bx0, out)
            }
        }
    }
    for (bx, blk) in row.chunks_mut(bl).enumerate().skip(batches * BLOCK_BATCH) {
        block_at(&bp, top, bottom, bx, blk);
    }
}

/// The [`BLOCK_BATCH`] blocks from `bx0` into `out` ([`block_row_avx2`]).
///
/// # Safety
/// The CPU must support AVX2; `out` holds `BLOCK_BATCH·bl` values and `top` and `bottom` hold
/// cells `bx0 ..= bx0 + BLOCK_BATCH` (`cell_len(nb)` values each).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn block_batch_avx2(bp: &BlockParams, top: &[f32], bottom: &[f32], bx0: usize, out: &mut [f32]) {
    use std::arch::x86_64::*;
    let BlockParams { nb, bl, eps1, thresh } = *bp;
    // bl = 4·nbins: whole ymm chunks, then half of one when nbins is odd.
    let (full, half) = (bl / 8, bl % 8 == 4);
    let cl = cell_len(nb);
    debug_assert!(out.len() == BLOCK_BATCH * bl);
    debug_assert!(top.len().min(bottom.len()) >= (bx0 + BLOCK_BATCH + 1) * cl);
    // The run of block cell (sy, sx) of block bx0 + j, as in `block_at`.
    let runs = |j: usize| {
        let c = (bx0 + j) * cl;
        // SAFETY: in bounds by the contract (`cell_slot(..)·nb + bl ≤ cl`).
        unsafe {
            [
                top.as_ptr().add(c + cell_slot(0, 0) * nb),
                top.as_ptr().add(c + cl + cell_slot(0, 1) * nb),
                bottom.as_ptr().add(c + cell_slot(1, 0) * nb),
                bottom.as_ptr().add(c + cl + cell_slot(1, 1) * nb),
            ]
        }
    };
    let o = out.as_mut_ptr();
    let zero = _mm256_setzero_ps();
    let mut acc = [zero; BLOCK_BATCH];
    for (j, a) in acc.iter_mut().enumerate() {
        let [h00, h01, h10, h11] = runs(j);
        // SAFETY: k + 8 ≤ bl (k + 4 = bl for the half chunk): every run and block has `bl` values.
        unsafe {
            let o = o.add(j * bl);
            for c in 0..full {
                let k = 8 * c;
                let v = _mm256_add_ps(zero, _mm256_loadu_ps(h00.add(k)));
                let v = _mm256_add_ps(v, _mm256_loadu_ps(h01.add(k)));
                let v = _mm256_add_ps(v, _mm256_loadu_ps(h10.add(k)));
                let v = _mm256_add_ps(v, _mm256_loadu_ps(h11.add(k)));
                _mm256_storeu_ps(o.add(k), v);
                *a = _mm256_add_ps(*a, _mm256_mul_ps(v, v));
            }
            if half {
                let k = 8 * full;
                let v = _mm_add_ps(_mm_setzero_ps(), _mm_loadu_ps(h00.add(k)));
                let v = _mm_add_ps(v, _mm_loadu_ps(h01.add(k)));
                let v = _mm_add_ps(v, _mm_loadu_ps(h10.add(k)));
                let v = _mm_add_ps(v, _mm_loadu_ps(h11.add(k)));
                _mm_storeu_ps(o.add(k), v);
                // Lanes 4..8 add +0, which leaves a sum of squares (never -0) unchanged.
                *a = _mm256_add_ps(*a, _mm256_zextps128_ps256(_mm_mul_ps(v, v)));
            }
        }
    }
    let one = _mm256_set1_ps(1.0);
    let scale = _mm256_div_ps(
        one,
        _mm256_add_ps(_mm256_sqrt_ps(lane_sums_avx2(&acc)), _mm256_set1_ps(eps1)),
    );
    let mut scales = [0.0f32; BLOCK_BATCH];
    // SAFETY: `scales` holds 8 values.
    unsafe { _mm256_storeu_ps(scales.as_mut_ptr(), scale) };
    let tv = _mm256_set1_ps(thresh);
    for (j, a) in acc.iter_mut().enumerate() {
        let s = _mm256_set1_ps(scales[j]);
        *a = zero;
        // SAFETY: inside block j of `out`, as above.
        unsafe {
            let o = o.add(j * bl);
            for c in 0..full {
                let k = 8 * c;
                let v = _mm256_min_ps(_mm256_mul_ps(_mm256_loadu_ps(o.add(k)), s), tv);
                _mm256_storeu_ps(o.add(k), v);
                *a = _mm256_add_ps(*a, _mm256_mul_ps(v, v));
            }
            if half {
                let k = 8 * full;
                let (s, tv) = (_mm256_castps256_ps128(s), _mm256_castps256_ps128(tv));
                let v = _mm_min_ps(_mm_mul_ps(_mm_loadu_ps(o.add(k)), s), tv);
                _mm_storeu_ps(o.add(k), v);
                *a = _mm256_add_ps(*a, _mm256_zextps128_ps256(_mm_mul_ps(v, v)));
            }
        }
    }
    let eps2 = _mm256_set1_ps(L2HYS_EPS2);
    let scale2 = _mm256_div_ps(one, _mm256_add_ps(_mm256_sqrt_ps(lane_sums_avx2(&acc)), eps2));
    // SAFETY: `scales` holds 8 values.
    unsafe { _mm256_storeu_ps(scales.as_mut_ptr(), scale2) };
    for (j, &sj) in scales.iter().enumerate() {
        let s = _mm256_set1_ps(sj);
        // SAFETY: inside block j of `out`, as above.
        unsafe {
            let o = o.add(j * bl);
            for c in 0..full {
                let k = 8 * c;
                _mm256_storeu_ps(o.add(k), _mm256_mul_ps(_mm256_loadu_ps(o.add(k)), s));
            }
            if half {
                let k = 8 * full;
                _mm_storeu_ps(
                    o.add(k),
                    _mm_mul_ps(_mm_loadu_ps(o.add(k)), _mm256_castps256_ps128(s)),
                );
            }
        }
    }
}

/// Lane `j` = the 8 partial sums of `acc[j]` combined as [`sum_of_squares`] does,
/// ((0+4)+(2+6))+((1+5)+(3+7)), every add with the same operands in the same order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn lane_sums_avx2(acc: &[std::arch::x86_64::__m256; BLOCK_BATCH]) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    // b(j) = [a0+a4, a1+a5, a2+a6, a3+a7] of block j; pairs (j, j+4) share a register.
    let b = |j: usize| {
        let lo = _mm256_permute2f128_ps::<0x20>(acc[j], acc[j + 4]);
        let hi = _mm256_permute2f128_ps::<0x31>(acc[j], acc[j + 4]);
        _mm256_add_ps(lo, hi)
    };
    let (b04, b15, b26, b37) = (b(0), b(1), b(2), b(3));
    // [c, d] = [b0+b2, b1+b3] of blocks (0, 1 | 4, 5) and (2, 3 | 6, 7).
    let cd = |x: __m256, y: __m256| {
        let p = _mm256_shuffle_ps::<0b01_00_01_00>(x, y);
        let q = _mm256_shuffle_ps::<0b11_10_11_10>(x, y);
        _mm256_add_ps(p, q)
    };
    let (cd0145, cd2367) = (cd(b04, b15), cd(b26, b37));
    let c = _mm256_shuffle_ps::<0b10_00_10_00>(cd0145, cd2367);
    let d = _mm256_shuffle_ps::<0b11_01_11_01>(cd0145, cd2367);
    _mm256_add_ps(c, d)
}

/// One block row from its upper and lower cell rows (`ncx` cells each; every value is written).
/// The reference for [`block_row_avx2`].
#[inline(always)]
fn block_row(spec: &HogSpec, ncx: usize, top: &[f32], bottom: &[f32], row: &mut [f32]) {
    let bp = BlockParams::new(spec);
    debug_assert!(top.len() >= ncx * cell_len(bp.nb) && bottom.len() >= ncx * cell_len(bp.nb));
    for (bx, blk) in row.chunks_mut(bp.bl).enumerate() {
        block_at(&bp, top, bottom, bx, blk);
    }
}

/// What block assembly and normalisation take from a [`HogSpec`].
#[derive(Clone, Copy)]
struct BlockParams {
    /// Bins per histogram.
    nb: usize,
    /// Values per block (`4·nb`).
    bl: usize,
    /// First L2-Hys epsilon.
    eps1: f32,
    /// L2-Hys clipping threshold.
    thresh: f32,
}

impl BlockParams {
    #[inline(always)]
    fn new(spec: &HogSpec) -> Self {
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

/// Block `bx` of a block row (`blk`, `bl` values) from its upper and lower cell rows, then
/// [`normalize_l2hys`].
#[inline(always)]
fn block_at(bp: &BlockParams, top: &[f32], bottom: &[f32], bx: usize, blk: &mut [f32]) {
    let BlockParams { nb, bl, eps1, thresh } = *bp;
    let cl = cell_len(nb);
    // The cell at (sy, sx) in the block holds its whole contribution to the block, in block
    // order, as one run of `bl` values ([`cell_slot`]). The four runs are summed in (sy, sx)
    // order in registers from 0 (a read-modify-write of `blk` per source stalled on store
    // forwarding).
    let h = |sy: usize, sx: usize| {
        let cells = if sy == 0 { top } else { bottom };
        let c = &cells[(bx + sx) * cl..][..cl];
        &c[cell_slot(sy, sx) * nb..][..bl]
    };
    let (h00, h01, h10, h11) = (h(0, 0), h(0, 1), h(1, 0), h(1, 1));
    for (k, o) in blk.iter_mut().enumerate() {
        *o = (((0.0 + h00[k]) + h01[k]) + h10[k]) + h11[k];
    }
    normalize_l2hys(blk, eps1, thresh);
}

/// `buf` resized to `n` values with unspecified contents (the kernels overwrite every value): a
/// shrink keeps the allocation without a `memset` pass over tens of MB per pyramid level, a buffer
/// that must grow is allocated zeroed (`calloc`: fresh pages are already zero).
fn sized(buf: &mut Vec<f32>, n: usize) {
    if buf.capacity() < n {
        *buf = vec![0.0; n];
    } else if buf.len() >= n {
        buf.truncate(n);
    } else {
        buf.resize(n, 0.0);
    }
}

/// OpenCV `normalizeBlockHistogram`: L2, clip, L2 again. Squares are summed in 8 interleaved
/// partial sums (lane `i mod 8`) added pairwise at the end, so the loops vectorise; OpenCV sums in
/// 4 SIMD lanes, a sequential sum differs from both by ≈1e-7 relative.
#[inline(always)]
pub fn normalize_l2hys(h: &mut [f32], eps1: f32, thresh: f32) {
    let scale = 1.0 / (sum_of_squares(h).sqrt() + eps1);
    for v in h.iter_mut() {
        *v = (*v * scale).min(thresh);
    }
    let scale2 = 1.0 / (sum_of_squares(h).sqrt() + L2HYS_EPS2);
    for v in h.iter_mut() {
        *v *= scale2;
    }
}

/// `Σ v²` in 8 partial sums (lane `i mod 8`), combined as ((0+4)+(2+6))+((1+5)+(3+7)).
#[inline(always)]
fn sum_of_squares(h: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let chunks = h.chunks_exact(8);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..8 {
            acc[k] += c[k] * c[k];
        }
    }
    for (k, &v) in rest.iter().enumerate() {
        acc[k] += v * v;
    }
    let a: [f32; 4] = std::array::from_fn(|k| acc[k] + acc[k + 4]);
    (a[0] + a[2]) + (a[1] + a[3])
}

/// Descriptor of a whole image that is exactly one window (`cv2.HOGDescriptor().compute(img)`).
pub fn descriptor_from_window(spec: &HogSpec, input: &HogInput) -> Result<Vec<f32>, HogError> {
    let grid = block_grid_from_input(spec, input)?;
    grid.window_descriptor(spec, 0, 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> HogSpec {
        HogSpec::new(&HogOptions::default()).unwrap()
    }

    #[test]
    fn default_geometry_matches_opencv() {
        let s = spec();
        assert_eq!(s.blocks_per_window(), (7, 15));
        assert_eq!(s.block_len(), 36);
        assert_eq!(s.descriptor_len(), 3780);
        assert_eq!(s.win_sigma(), 4.0);
    }

    #[test]
    fn profiles_are_gaussian_times_bilinear() {
        let s = spec();
        // Pixel j = 0 of the block: cell coordinate -7/16, only cell 0, bilinear weight 9/16.
        let g0 = (-(64.0f32) / 32.0).exp();
        assert!((s.profile[0][0] - g0 * 9.0 / 16.0).abs() < 1e-7);
        assert_eq!(s.profile[2][0], 0.0); // block cell 1 gets nothing from j = 0
                                          // j = 8 (cell offset 1, k = 0): coordinate 9/16 → cell 0 weight 7/16, cell 1 weight 9/16.
        assert!((s.profile[1][0] - 7.0 / 16.0).abs() < 1e-7);
        assert!((s.profile[3][0] - 9.0 / 16.0).abs() < 1e-7);
    }

    #[test]
    fn bad_options_are_refused() {
        let o = HogOptions {
            win_width: 60,
            ..Default::default()
        };
        assert!(matches!(
            HogSpec::new(&o),
            Err(HogError::BadWindow { width: 60, .. })
        ));
        let o = HogOptions {
            nbins: 1,
            ..Default::default()
        };
        assert_eq!(HogSpec::new(&o), Err(HogError::BadBins(1)));
        let o = HogOptions {
            l2hys_threshold: 0.0,
            ..Default::default()
        };
        assert!(HogSpec::new(&o).is_err());
    }

    #[test]
    fn image_smaller_than_window_is_an_error() {
        let img = Image::<u8>::new(63, 128);
        let e = block_grid_from_input(&spec(), &HogInput::GreyU8(img.view())).unwrap_err();
        assert!(matches!(
            e,
            HogError::ImageTooSmall {
                width: 63,
                height: 128,
                ..
            }
        ));
        let img = Image::<u8>::new(0, 0);
        assert!(block_grid_from_input(&spec(), &HogInput::GreyU8(img.view())).is_err());
        let img = Image::<f32>::new(65, 128);
        assert_eq!(
            block_grid_from_input(&spec(), &HogInput::Mosaic(img.view())).unwrap_err(),
            HogError::OddMosaic {
                width: 65,
                height: 128
            }
        );
    }

    #[test]
    fn atan_matches_std_within_opencv_accuracy() {
        for k in 0..3600 {
            let t = k as f32 * 0.1f32.to_radians();
            let (y, x) = (t.sin() * 3.0, t.cos() * 3.0);
            let mut want = y.atan2(x).to_degrees();
            if want < 0.0 {
                want += 360.0;
            }
            let got = fast_atan2_deg(y, x);
            let d = (got - want).abs();
            assert!(d < 0.02 || (d - 360.0).abs() < 0.02, "{k}: {got} vs {want}");
        }
    }

    #[test]
    fn flat_image_gives_zero_descriptor() {
        let img = Image::<u8>::filled(64, 128, 77);
        let d = descriptor_from_window(&spec(), &HogInput::GreyU8(img.view())).unwrap();
        assert!(d.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn vertical_edge_votes_bin_for_zero_degrees() {
        // A step along x: gradient along +x, angle 0 → a = -0.5 → bins 8 and 0 equally.
        let img = Image::<u8>::from_fn(64, 128, |x, _| if x < 20 { 10 } else { 200 });
        let spec = spec();
        let grid = block_grid_from_input(&spec, &HogInput::GreyU8(img.view())).unwrap();
        let b = grid.block(1, 3); // pixels x 8..24 covers the edge at 19/20
        let mut energy = [0.0f32; 9];
        for c in 0..4 {
            for k in 0..9 {
                energy[k] += b[c * 9 + k];
            }
        }
        assert!(
            energy[0] > 0.1 && (energy[0] - energy[8]).abs() < 1e-5,
            "{energy:?}"
        );
        assert!(energy[1..8].iter().all(|&v| v == 0.0));
        // Normalised: L2 norm ≈ 1 (minus epsilon effects).
        let n: f32 = b.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!(n > 0.9 && n <= 1.0 + 1e-6, "{n}");
    }

    #[test]
    fn parallel_equals_serial() {
        let img = Image::<u8>::from_fn(301, 277, |x, y| ((x * x + 3 * y * x + y) % 251) as u8);
        let spec = spec();
        let inp = HogInput::GreyU8(img.view());
        let (mut a, mut b) = (BlockGrid::empty(), BlockGrid::empty());
        block_grid(&spec, &inp, Exec::Parallel, &mut a).unwrap();
        block_grid(&spec, &inp, Exec::Serial, &mut b).unwrap();
        assert_eq!(a, b);
        assert_eq!((a.blocks_x(), a.blocks_y()), (36, 33));
    }

    fn same_bits(a: &[f32], b: &[f32]) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    }

    #[test]
    fn every_kernel_build_is_bit_identical_to_the_generic_one() {
        let grey = Image::<u8>::from_fn(204, 150, |x, y| ((x * x + 3 * y * x + y) % 251) as u8);
        let mosaic = grey.map(|v| v as f32 * 0.93);
        let rgb = Image::<[u8; 3]>::from_fn(204, 150, |x, y| {
            [(x % 256) as u8, ((y * 3) % 256) as u8, ((x ^ y) % 256) as u8]
        });
        for nbins in [9, 4, 16, 18] {
            let spec = HogSpec::new(&HogOptions {
                nbins,
                ..Default::default()
            })
            .unwrap();
            for inp in [
                HogInput::GreyU8(grey.view()),
                HogInput::Mosaic(mosaic.view()),
                HogInput::Rgb8(rgb.view()),
            ] {
                let owned = planes_from_input(&spec, &inp).unwrap();
                let planes = owned.view();
                let mut want = CellGrid::empty();
                cells_from_planes_with(&spec, &planes, Exec::Serial, CellKernel::Generic, &mut want);
                let mut bw = BlockGrid::empty();
                block_rows_with(&spec, &want, Exec::Serial, false, &mut bw);
                for k in CellKernel::available(&spec) {
                    let mut got = CellGrid::empty();
                    cells_from_planes_with(&spec, &planes, Exec::Parallel, k, &mut got);
                    assert!(same_bits(&got.data, &want.data), "{k:?} nbins {nbins}");
                }
                let mut bg = BlockGrid::empty();
                block_rows_with(&spec, &want, Exec::Parallel, have_avx2(), &mut bg);
                assert!(same_bits(&bg.data, &bw.data));
                // Cells and blocks fused in bands (two bands here), every cell kernel.
                assert!(bw.nby > BAND_BLOCK_ROWS);
                for k in CellKernel::available(&spec) {
                    let mut bf = BlockGrid::empty();
                    blocks_in_bands(&spec, &planes, Exec::Parallel, k, have_avx2(), &mut bf);
                    assert_eq!((bf.nbx, bf.nby), (bw.nbx, bw.nby));
                    assert!(same_bits(&bf.data, &bw.data), "bands {k:?} nbins {nbins}");
                }
            }
        }
        // Gamma rows.
        let src: Vec<f32> = (0..77).map(|i| i as f32 * 3.3 - 20.0).collect();
        for gamma in [true, false] {
            let mut want = src.clone();
            gamma_in_place_generic(&mut want, gamma);
            let mut got = src.clone();
            gamma_in_place(&mut got, gamma);
            assert_eq!(got, want);
        }
    }

    #[test]
    fn batched_block_row_is_bit_identical_to_the_generic_one() {
        if !have_avx2() {
            return;
        }
        // xorshift32: cell values of every magnitude, with zeros, -0, all-zero blocks and values
        // whose squares overflow.
        let mut state = 0x9e37_79b9u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        for nbins in [9, 2, 3, 4, 16, 18] {
            for thresh in [DEFAULT_L2HYS_THRESHOLD, 1.0, 0.05] {
                let spec = HogSpec::new(&HogOptions {
                    nbins,
                    l2hys_threshold: thresh,
                    ..Default::default()
                })
                .unwrap();
                let cl = cell_len(nbins);
                for ncx in [2, 3, 8, 9, 10, 16, 17, 25, 40, 71] {
                    for kind in 0..6 {
                        let mut cell = |cx: usize| -> f32 {
                            let r = next();
                            let u = (r >> 8) as f32 / (1 << 24) as f32;
                            match (kind, r % 16) {
                                // Cells 3 and 4 zero: block 3 is all zeros.
                                (_, _) if (3..5).contains(&cx) && kind != 5 => 0.0,
                                (0, _) => u * 3.0,
                                (1, 0..=5) => 0.0,
                                (1, 6) => -0.0,
                                (1, _) => u * 1e-3,
                                (2, 0) => 1e20 * u,
                                (2, _) => u * 100.0,
                                (3, _) => f32::from_bits(r % 0x0100_0000), // subnormal to tiny
                                (4, 0..=7) => 0.0,
                                (4, _) => u * 1e18,
                                _ => u * 1e-2,
                            }
                        };
                        let mut cells = || -> Vec<f32> { (0..ncx * cl).map(|i| cell(i / cl)).collect() };
                        let (top, bottom) = (cells(), cells());
                        let n = (ncx - 1) * spec.block_len();
                        let (mut want, mut got) = (vec![f32::NAN; n], vec![f32::NAN; n]);
                        block_row_with(&spec, ncx, &top, &bottom, false, &mut want);
                        block_row_with(&spec, ncx, &top, &bottom, true, &mut got);
                        assert!(
                            same_bits(&got, &want),
                            "nbins {nbins} thresh {thresh} ncx {ncx} kind {kind}"
                        );
                        assert!(want.iter().all(|v| v.is_finite()));
                    }
                }
            }
        }
    }

    #[test]
    fn gamma_plane_entry_points_equal_the_linear_ones() {
        let spec = spec();
        let grey = Image::<u8>::from_fn(150, 290, |x, y| ((x * x + 3 * y * x + y) % 251) as u8);
        let mosaic = grey.map(|v| v as f32 * 0.93 - 2.0);
        let rgb = [0, 1, 2].map(|c| grey.map(|v| ((v as usize * (c + 2)) % 256) as f32));
        let g = |v: ImageView<'_, f32>| {
            let mut o = Image::new(0, 0);
            gamma_plane_into(v, true, &mut o);
            o
        };
        let gm = g(mosaic.view());
        let gc = [g(rgb[2].view()), g(rgb[1].view()), g(rgb[0].view())];
        for (lin, gam) in [
            (HogInput::Mosaic(mosaic.view()), GammaPlanes::Mosaic(gm.view())),
            (
                HogInput::ColourF32([rgb[0].view(), rgb[1].view(), rgb[2].view()]),
                GammaPlanes::Colour([gc[0].view(), gc[1].view(), gc[2].view()]),
            ),
        ] {
            let mut want = BlockGrid::empty();
            block_grid(&spec, &lin, Exec::Serial, &mut want).unwrap();
            let mut cells = CellGrid::empty();
            cell_grid_from_gamma_planes(&spec, &gam, Exec::Parallel, &mut cells).unwrap();
            let mut got = BlockGrid::empty();
            blocks_from_cells(&spec, &cells, Exec::Parallel, &mut got);
            assert_eq!(got, want);
            // A reused, larger buffer is resized, not appended to.
            let mut fused = want.clone();
            fused.data.extend([1.0; 100]);
            block_grid_from_gamma_planes(&spec, &gam, Exec::Parallel, &mut fused).unwrap();
            assert_eq!(fused, want);
            // The unfused, timed diagnostic gives the same grid and times each stage.
            let mut timed = BlockGrid::empty();
            let t = block_grid_stage_times(&spec, &gam, &mut timed).unwrap();
            assert_eq!(timed, want);
            assert!(t.gradients > std::time::Duration::ZERO && t.blocks > std::time::Duration::ZERO);
        }
        let small = Image::<f32>::new(60, 200);
        assert!(matches!(
            block_grid_from_gamma_planes(
                &spec,
                &GammaPlanes::Grey(small.view()),
                Exec::Serial,
                &mut BlockGrid::empty()
            ),
            Err(HogError::ImageTooSmall { .. })
        ));
    }

    #[test]
    fn window_descriptor_equals_descriptor_of_the_crop_interior() {
        // Blocks that do not touch the crop border see identical gradients, so their values agree.
        let img = Image::<u8>::from_fn(160, 200, |x, y| ((x * 13 + y * 7 + x * y / 5) % 256) as u8);
        let spec = spec();
        let grid = block_grid_from_input(&spec, &HogInput::GreyU8(img.view())).unwrap();
        let d = grid.window_descriptor(&spec, 3, 2).unwrap();
        let crop = img.view().crop(24, 16, 64, 128).unwrap().to_image();
        let d2 = descriptor_from_window(&spec, &HogInput::GreyU8(crop.view())).unwrap();
        // Block (bx=1, by=1) of the window is interior.
        let o = (15 + 1) * 36;
        for k in 0..36 {
            assert!((d[o + k] - d2[o + k]).abs() < 1e-6);
        }
    }

    #[test]
    fn mosaic_of_grey_scene_matches_half_resolution_trend() {
        // A flat-colour mosaic (each CFA site constant) has zero mosaic gradient: taps are same-colour.
        let img = Image::<f32>::from_fn(64, 128, |x, y| [10.0, 80.0, 120.0, 30.0][(y & 1) * 2 + (x & 1)]);
        let d = descriptor_from_window(&spec(), &HogInput::Mosaic(img.view())).unwrap();
        assert!(d.iter().all(|&v| v == 0.0));
        let paper = HogSpec::new(&HogOptions {
            mosaic_taps: MosaicTaps::Paper,
            ..Default::default()
        })
        .unwrap();
        let d = descriptor_from_window(&paper, &HogInput::Mosaic(img.view())).unwrap();
        assert!(d.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn mosaic_taps_paper_is_the_grey_operator_on_the_raw_mosaic_and_same_site_is_not() {
        // The paper's point: [-1, 0, 1] applied to the mosaic as if it were grey.
        let img = Image::<f32>::from_fn(96, 160, |x, y| {
            let c = [1.0, 0.6, 0.6, 0.3][(y & 1) * 2 + (x & 1)];
            c * (40.0 + ((x * 7 + y * 3) % 50) as f32 + (x as f32 / 9.0).sin() * 30.0)
        });
        let paper = HogSpec::new(&HogOptions {
            mosaic_taps: MosaicTaps::Paper,
            ..Default::default()
        })
        .unwrap();
        let mosaic = block_grid_from_input(&paper, &HogInput::Mosaic(img.view())).unwrap();
        let grey = block_grid_from_input(&paper, &HogInput::GreyF32(img.view())).unwrap();
        let d = mosaic.window_descriptor(&paper, 2, 3).unwrap();
        assert_eq!(d, grey.window_descriptor(&paper, 2, 3).unwrap());
        let same_site = spec();
        let s = block_grid_from_input(&same_site, &HogInput::Mosaic(img.view())).unwrap();
        let ds = s.window_descriptor(&same_site, 2, 3).unwrap();
        assert!(d.iter().zip(&ds).map(|(a, b)| (a - b).abs()).sum::<f32>() > 1.0);
        assert_eq!(MosaicTaps::default(), MosaicTaps::SameSite);
        assert_eq!(
            (MosaicTaps::Paper.distance(), MosaicTaps::SameSite.distance()),
            (1, 2)
        );
        for t in [MosaicTaps::Paper, MosaicTaps::SameSite] {
            assert_eq!(t.name().parse::<MosaicTaps>(), Ok(t));
            assert_eq!(serde_json::to_value(t).unwrap(), t.name());
        }
        assert!("Paper"
            .parse::<MosaicTaps>()
            .unwrap_err()
            .contains("paper, same-site"));
    }
}
