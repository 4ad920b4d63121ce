//! The conventional ISP path we compare against: demosaicing, grey conversion, reverse ISP, noise.
//!
//! The files are private behind this facade; what other crates use is re-exported here.
//!
//! - `profile.rs`: [`CameraProfile`] (black/white level, bit depth, white-balance gains, colour
//!   matrix, pattern) loaded from `config/cameras/*.toml`.
//! - `reverse.rs`: sRGB → raw Bayer frame ([`raw_from_srgb`], Buckler et al. 2017 style), used to
//!   make raw versions of RGB data sets (INRIA crops, Kodak) and recordings from RGB images.
//! - `noise.rs`: the paper's heteroscedastic noise (eq. 24) with its three presets, and an
//!   estimator of the noise parameters from a raw frame.
//! - `demosaic.rs` ([`rgb_from_mosaic`]): nearest, bilinear, bicubic, Malvar–He–Cutler and
//!   Hamilton–Adams demosaicing; `grey.rs`: RGB → grey.
//! - `forward.rs` ([`srgb_from_raw`]): a minimal forward ISP (black level, white balance, demosaic,
//!   colour matrix, sRGB gamma) so that a reverse → forward round trip can be measured.
//!
//! All of them report errors through [`IspError`].

pub(crate) mod demosaic;
pub(crate) mod forward;
pub(crate) mod grey;
pub(crate) mod noise;
pub(crate) mod profile;
pub(crate) mod quantise;
pub(crate) mod reverse;

use std::path::PathBuf;

pub use demosaic::{
    rgb_from_mosaic, rgb_from_mosaic_bilinear, rgb_from_mosaic_u8, DemosaicMethod, ParseDemosaicMethodError,
};
pub use forward::{srgb_from_raw, ForwardIspOptions};
pub use grey::{grey_f32, grey_from_rgb_f32, grey_from_rgb_u8};
pub use noise::{
    add_noise, add_noise_to_raw, estimate_noise, linear_from_raw, NoiseEstimate, NoiseEstimateOptions,
    NoiseLevel, NoiseParams,
};
pub use profile::CameraProfile;
pub use reverse::{raw_from_linear_mosaic, raw_from_srgb, ReverseIspOptions};

/// Errors of the ISP area (profiles, reverse/forward ISP, noise, demosaicing).
#[derive(Debug, thiserror::Error)]
pub enum IspError {
    /// A camera profile file could not be read.
    #[error("cannot read camera profile {path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// A camera profile file is not valid TOML or misses keys.
    #[error("camera profile {path}: {source}")]
    ProfileSyntax {
        /// File (or `<string>`).
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// A camera profile or option value is out of range.
    #[error("invalid {name} = {value}: {why}")]
    Param {
        /// Key name (e.g. `wb_gains[0]`, `bit_depth`).
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Allowed range.
        why: &'static str,
    },
    /// The colour matrix cannot be inverted.
    #[error("colour matrix is singular (determinant {det:e}); the reverse ISP needs its inverse")]
    SingularCcm {
        /// Determinant.
        det: f64,
    },
    /// An unknown CFA pattern name in a profile.
    #[error("camera profile {path}: {source}")]
    Cfa {
        /// File (or `<string>`).
        path: PathBuf,
        /// Cause.
        #[source]
        source: crate::raw::ParseCfaError,
    },
    /// An empty image.
    #[error("empty image {width}x{height}")]
    Empty {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// Source and destination sizes differ.
    #[error("size mismatch: source {src_w}x{src_h}, destination {dst_w}x{dst_h}")]
    SizeMismatch {
        /// Source width.
        src_w: usize,
        /// Source height.
        src_h: usize,
        /// Destination width.
        dst_w: usize,
        /// Destination height.
        dst_h: usize,
    },
    /// Too few usable patches to estimate noise.
    #[error("noise estimation found only {found} usable patch bins (need at least {needed}); the frame is too small, too textured or too clipped")]
    TooFewPatches {
        /// Bins found.
        found: usize,
        /// Bins needed.
        needed: usize,
    },
    /// Building the output frame failed.
    #[error(transparent)]
    Raw(#[from] crate::raw::RawError),
}

/// Reflect an index into `0..n` without repeating the edge sample (`scipy.ndimage` mode
/// `'mirror'`: `-1 → 1`, `n → n - 2`). Mirroring by an even or odd offset keeps the parity of the
/// offset, so a mirrored neighbour has the same CFA colour as the missing one.
#[inline]
pub(crate) fn mirror(i: isize, n: usize) -> usize {
    let n = n as isize;
    if n == 1 {
        return 0;
    }
    let period = 2 * (n - 1);
    let mut j = i.rem_euclid(period);
    if j >= n {
        j = period - j;
    }
    j as usize
}

#[cfg(test)]
mod tests {
    use super::mirror;

    #[test]
    fn mirror_matches_scipy_mirror_mode() {
        // scipy.ndimage 'mirror' on n = 4: ... 2 1 | 0 1 2 3 | 2 1 0 ...
        let got: Vec<usize> = (-3..7).map(|i| mirror(i, 4)).collect();
        assert_eq!(got, vec![3, 2, 1, 0, 1, 2, 3, 2, 1, 0]);
        assert_eq!(mirror(-5, 1), 0);
        for i in -10isize..10 {
            assert_eq!((mirror(i, 6) as isize - i).rem_euclid(2), 0, "parity kept");
        }
    }
}
