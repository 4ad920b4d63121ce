//! HOG options and the validated spec: window geometry, bins, the block window's weight profiles.

use super::{
    HogError, BLOCK_CELLS, BLOCK_SIZE, BLOCK_STRIDE, CELL_SIZE, DEFAULT_L2HYS_THRESHOLD, DEFAULT_NBINS,
    PROFILES,
};

/// Largest window side [`HogSpec::new`] accepts, in pixels (eight times the height of OpenCV's 64x128
/// pedestrian window). Windows come from model files, which come from users: every size the
/// detector computes from a window (descriptor length, blocks per window, weight tables) stays
/// small below it (≤ 127² blocks of ≤ 4·255 values).
pub const MAX_WINDOW_SIDE: usize = 1024;
/// Most orientation bins [`HogSpec::new`] accepts (bins are stored as bytes).
pub const MAX_NBINS: usize = 255;

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
    pub(super) opts: HogOptions,
    pub(super) sigma: f32,
    /// `profile[p][k]`, p = block_cell*2 + cell_offset, k = pixel offset in the 8-pixel cell.
    pub(super) profile: [[f32; CELL_SIZE]; PROFILES],
    /// [`Self::descriptor_len`], computed with checked arithmetic when the spec was built.
    descriptor_len: usize,
}

impl HogSpec {
    /// Validate options.
    pub fn new(opts: &HogOptions) -> Result<Self, HogError> {
        let (w, h) = (opts.win_width, opts.win_height);
        // Bounded first: every size below is computed from these.
        if w > MAX_WINDOW_SIDE || h > MAX_WINDOW_SIDE {
            return Err(HogError::WindowTooLarge {
                width: w,
                height: h,
                max: MAX_WINDOW_SIDE,
            });
        }
        if w < BLOCK_SIZE || h < BLOCK_SIZE || w % CELL_SIZE != 0 || h % CELL_SIZE != 0 {
            return Err(HogError::BadWindow {
                width: w,
                height: h,
                cell: CELL_SIZE,
                block: BLOCK_SIZE,
            });
        }
        if !(2..=MAX_NBINS).contains(&opts.nbins) {
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
        // Within the maxima above this cannot overflow (≤ 127² · 4 · 255 values); checked anyway,
        // so that a change of the maxima cannot bring back a wrapped length.
        let blocks = |side: usize| (side - BLOCK_SIZE) / BLOCK_STRIDE + 1;
        let descriptor_len = blocks(w)
            .checked_mul(blocks(h))
            .and_then(|n| n.checked_mul(BLOCK_CELLS * BLOCK_CELLS))
            .and_then(|n| n.checked_mul(opts.nbins))
            .ok_or(HogError::WindowTooLarge {
                width: w,
                height: h,
                max: MAX_WINDOW_SIDE,
            })?;
        Ok(Self {
            opts: *opts,
            sigma,
            profile,
            descriptor_len,
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
        self.descriptor_len
    }
}
