//! The SIFT vocabulary every stage shares, below all of them: the user-facing [`SiftOptions`], the
//! validated [`SiftSpec`] they build, its [`SiftError`], and the [`Keypoint`] that detection
//! produces and the descriptor reads. The facade `features/sift/mod.rs` re-exports them.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Smallest accepted width or height, in input pixels.
pub const MIN_SIZE: usize = 16;

/// Errors from building a SIFT spec or running SIFT.
#[derive(Debug, Error)]
pub enum SiftError {
    /// The image is smaller than [`MIN_SIZE`] in some dimension.
    #[error("image {width}x{height} is too small for SIFT (needs at least {min}x{min})")]
    TooSmall {
        /// Image width.
        width: usize,
        /// Image height.
        height: usize,
        /// Minimum side.
        min: usize,
    },
    /// Mosaic SIFT needs whole 2x2 super-pixels.
    #[error("mosaic {width}x{height} has an odd size; mosaic SIFT needs even width and height")]
    OddSize {
        /// Image width.
        width: usize,
        /// Image height.
        height: usize,
    },
    /// A scale-space operation failed (sizes are checked first, so this signals a bug).
    #[error(transparent)]
    ScaleSpace(#[from] crate::features::superpixel::SuperPixelError),
    /// The x2 upsampling of the input failed (sizes are checked first, so this signals a bug).
    #[error(transparent)]
    Resize(#[from] crate::resize::ResizeError),
    /// An option is out of its range.
    #[error("SIFT option {name} = {value} is invalid (allowed: {allowed})")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Allowed range.
        allowed: &'static str,
    },
}

/// Which image SIFT runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Domain {
    /// A grey image (same-colour step 1; OpenCV SIFT).
    Grey,
    /// A Bayer mosaic (same-colour step 2; the paper's mosaic SIFT).
    Mosaic,
}

/// User-facing SIFT options (paper / OpenCV names and defaults); [`SiftOptions::build`] validates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SiftOptions {
    /// Grey image or Bayer mosaic.
    pub domain: Domain,
    /// Layers per octave (`nOctaveLayers`, 3).
    pub n_octave_layers: usize,
    /// Base blur of each octave, input pixels (`sigma`, 1.6).
    pub sigma: f64,
    /// Contrast threshold on [0, 1] data (`contrastThreshold`, 0.04; divided by the layers).
    pub contrast_threshold: f64,
    /// Ratio of principal curvatures above which edges are rejected (`edgeThreshold`, 10).
    pub edge_threshold: f64,
    /// Double the image (every colour plane for a mosaic) first (`firstOctave = -1`); default
    /// true for grey (OpenCV), false for the mosaic. False is 4x cheaper.
    pub double_image: bool,
    /// Value of full scale in the input (255 for u8 data, `2^bits - 1` for u16 data).
    pub max_value: f64,
    /// Mosaic only: `sigma` (and the assumed input blur) are in super-pixel (colour-plane)
    /// pixels, i.e. twice as large in mosaic pixels, so every colour plane is blurred exactly as
    /// grey SIFT blurs an image of the plane's size. Default true; false means mosaic pixels.
    pub sigma_in_super_pixels: bool,
    /// The octave step takes the mean of each 2x2 block of same-colour samples, centred between
    /// them, instead of every other sample (OpenCV). Centred octaves are symmetric under flips
    /// and quarter turns of an image whose sides are multiples of `2^octaves`; picking every other
    /// sample shifts the coarse grid by one sample under such a turn. Default false for grey
    /// (OpenCV parity), true for the mosaic.
    pub centred_octaves: bool,
}

impl SiftOptions {
    /// OpenCV `SIFT_create()` defaults on 8-bit grey data.
    pub fn grey() -> Self {
        Self {
            domain: Domain::Grey,
            n_octave_layers: 3,
            sigma: 1.6,
            contrast_threshold: 0.04,
            edge_threshold: 10.0,
            double_image: true,
            max_value: 255.0,
            sigma_in_super_pixels: true,
            centred_octaves: false,
        }
    }

    /// The paper's mosaic SIFT with the same parameters on 8-bit data: sigma in super-pixels,
    /// no doubling (the pyramid base is the mosaic itself: 4x cheaper than grey SIFT's doubled
    /// base; doubling the planes is available and measured in `docs/sift.md`).
    pub fn mosaic() -> Self {
        Self {
            domain: Domain::Mosaic,
            double_image: false,
            centred_octaves: true,
            ..Self::grey()
        }
    }

    /// Validate into a [`SiftSpec`].
    pub fn build(&self) -> Result<SiftSpec, SiftError> {
        let bad = |name, value: f64, allowed| Err(SiftError::InvalidOption { name, value, allowed });
        if !(1..=8).contains(&self.n_octave_layers) {
            return bad("n_octave_layers", self.n_octave_layers as f64, "1..=8");
        }
        if !(self.sigma.is_finite() && self.sigma > 0.5 && self.sigma <= 10.0) {
            return bad("sigma", self.sigma, "(0.5, 10]");
        }
        if !(self.contrast_threshold.is_finite()
            && self.contrast_threshold >= 0.0
            && self.contrast_threshold < 1.0)
        {
            return bad("contrast_threshold", self.contrast_threshold, "[0, 1)");
        }
        if !(self.edge_threshold.is_finite() && self.edge_threshold > 0.0) {
            return bad("edge_threshold", self.edge_threshold, "> 0");
        }
        if !(self.max_value.is_finite() && self.max_value > 0.0) {
            return bad("max_value", self.max_value, "> 0");
        }
        Ok(SiftSpec { o: *self })
    }
}

/// Validated SIFT parameters (build with [`SiftOptions::build`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SiftSpec {
    pub(super) o: SiftOptions,
}

impl SiftSpec {
    /// Length unit of `sigma` in pyramid-base pixels: 2 for a mosaic with super-pixel sigmas.
    pub(crate) fn unit(&self) -> f64 {
        if self.o.domain == Domain::Mosaic && self.o.sigma_in_super_pixels {
            2.0
        } else {
            1.0
        }
    }

    /// `sigma` in pyramid-base pixels.
    pub(crate) fn sigma_px(&self) -> f64 {
        self.o.sigma * self.unit()
    }

    /// The same spec with sigma measured in super-pixels (`true`) or mosaic pixels.
    pub fn with_sigma_in_super_pixels(mut self, on: bool) -> Self {
        self.o.sigma_in_super_pixels = on;
        self
    }

    /// Defaults for grey 8-bit data ([`SiftOptions::grey`]).
    pub fn grey() -> Self {
        SiftOptions::grey().build().expect("defaults are valid")
    }

    /// Defaults for an 8-bit mosaic ([`SiftOptions::mosaic`]).
    pub fn mosaic() -> Self {
        SiftOptions::mosaic().build().expect("defaults are valid")
    }

    /// The same spec for data whose full scale is `max_value` (validated as
    /// [`SiftOptions::build`] validates it).
    pub fn with_max_value(self, max_value: f64) -> Result<Self, SiftError> {
        SiftOptions { max_value, ..self.o }.build()
    }

    /// The same spec with image doubling switched on or off.
    pub fn with_double_image(mut self, double_image: bool) -> Self {
        self.o.double_image = double_image;
        self
    }

    /// The same spec with base blur `sigma` (in the spec's unit; see
    /// [`SiftOptions::sigma_in_super_pixels`]), validated as [`SiftOptions::build`] validates it.
    pub fn with_sigma(self, sigma: f64) -> Result<Self, SiftError> {
        SiftOptions { sigma, ..self.o }.build()
    }

    /// The same spec with centred octaves ([`SiftOptions::centred_octaves`]) on or off.
    pub fn with_centred_octaves(mut self, centred: bool) -> Self {
        self.o.centred_octaves = centred;
        self
    }

    /// Grey or mosaic.
    pub fn domain(&self) -> Domain {
        self.o.domain
    }

    /// Whether the image is doubled first.
    pub fn double_image(&self) -> bool {
        self.o.double_image
    }

    /// Full-scale value of the input.
    pub fn max_value(&self) -> f64 {
        self.o.max_value
    }

    /// Whether octaves are centred 2x2 means (see [`SiftOptions::centred_octaves`]).
    pub fn centred_octaves(&self) -> bool {
        self.o.centred_octaves
    }

    /// Same-colour sample distance: 1 for grey, 2 for a mosaic.
    pub(crate) fn step(&self) -> usize {
        match self.o.domain {
            Domain::Grey => 1,
            Domain::Mosaic => 2,
        }
    }
}

/// A keypoint, in input-image pixel coordinates (pixel centres at integers, as OpenCV).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Keypoint {
    /// Column.
    pub x: f32,
    /// Row.
    pub y: f32,
    /// Diameter of the meaningful neighbourhood (OpenCV `size` = 2 x sigma of the keypoint).
    pub size: f32,
    /// Orientation in degrees, [0, 360), OpenCV convention (counter-clockwise with y up).
    pub angle: f32,
    /// |DoG| at the refined extremum, on [0, 1] data.
    pub response: f32,
    /// Octave relative to the input (-1 for the doubled image).
    pub octave: i32,
    /// Layer inside the octave (1..=n_octave_layers).
    pub layer: u32,
}
