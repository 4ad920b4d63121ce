//! The errors of the HOG stage.

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
    /// A window side above [`MAX_WINDOW_SIDE`](super::MAX_WINDOW_SIDE) (model files come from
    /// users: their geometry is bounded before any size is computed from it).
    #[error("HOG window {width}x{height} exceeds the largest supported side, {max} pixels")]
    WindowTooLarge {
        /// Requested width.
        width: usize,
        /// Requested height.
        height: usize,
        /// [`MAX_WINDOW_SIDE`](super::MAX_WINDOW_SIDE).
        max: usize,
    },
    /// Bin count outside 2..=[`MAX_NBINS`](super::MAX_NBINS).
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
    /// A micro-cell side outside 1..=8
    /// ([`micro_grid_from_gamma_planes`](super::micro_grid_from_gamma_planes)).
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
