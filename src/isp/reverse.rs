//! Reverse ISP: an sRGB image → a raw Bayer frame, as a camera would have recorded it.
//!
//! The paper made raw versions of INRIA with the reverse pipeline of Buckler et al. (ICCV 2017).
//! We follow the same steps, undoing a simple forward ISP in reverse order:
//!
//! 1. **Inverse tone curve**: sRGB `u8` → linear with the inverse sRGB transfer function
//!    (IEC 61966-2-1): `c ≤ 0.04045 ? c/12.92 : ((c + 0.055)/1.055)^2.4`.
//! 2. **Inverse colour matrix**: `cam_wb = M⁻¹ · rgb_lin`, with `M` the profile's camera → sRGB matrix.
//! 3. **Inverse white balance**: `cam = cam_wb / gains` (per channel).
//! 4. **Mosaic**: keep at each pixel only the channel of the chosen CFA pattern.
//! 5. **Quantise**: optional noise `N(0, a·y + b)` on the linear `y` (paper eq. 24, see
//!    [`super::noise`]), then `v = round(black + y·(white − black))` clipped to `[0, white]` at the
//!    chosen bit depth (`u8` container for 8 bits, `u16` otherwise).
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::isp::{raw_from_srgb, CameraProfile, ReverseIspOptions};
//! use mosaicd::raw::Cfa;
//! let rgb = Image::<[u8; 3]>::filled(8, 6, [255, 255, 255]);
//! let profile = CameraProfile::default();
//! let mut opts = ReverseIspOptions::for_profile(&profile);
//! opts.cfa = Cfa::Rggb;
//! opts.bit_depth = 12;
//! let raw = raw_from_srgb(rgb.view(), &profile, &opts).unwrap();
//! assert_eq!((raw.width(), raw.height(), raw.bit_depth(), raw.cfa()), (8, 6, 12, Cfa::Rggb));
//! // white: green is at the white level, red/blue are divided by their white-balance gains
//! assert_eq!(raw.value(1, 0), raw.levels().white);
//! assert!(raw.value(0, 0) < raw.value(1, 0));
//! ```
//!
//! ## Deviations
//! - Buckler et al. also invert tone mapping and gamut mapping of a specific camera; we invert the
//!   plain sRGB curve only (the forward ISP in [`super::forward`] applies exactly that curve).
//! - Black and white levels of the profile are rescaled when a different bit depth is asked for
//!   ([`CameraProfile::levels_at`]).
//! - Out-of-gamut colours can give camera values below 0 or above 1; they are clipped at quantisation.
//!
//! ## References
//! - M. Buckler, S. Jayasuriya, A. Sampson, "Reconfiguring the Imaging Pipeline for Computer
//!   Vision", ICCV 2017.
//! - IEC 61966-2-1:1999 (sRGB).

use rayon::prelude::*;

use super::noise::{add_noise, NoiseParams};
use super::profile::CameraProfile;
use super::quantise::check_bit_depth;
/// Re-exported from `isp::quantise`, where it lives.
pub use super::quantise::raw_from_linear_mosaic;
use super::IspError;
use crate::image::{Image, ImageView};
use crate::raw::{Cfa, Colour, Levels, RawFrame};
/// Re-exported from [`crate::srgb`], where the transfer function lives.
pub(crate) use crate::srgb::linear_from_srgb;

/// Rows per parallel strip.
const STRIP_ROWS: usize = 32;

/// Linear value of each sRGB `u8` code.
pub(crate) fn srgb_u8_to_linear_lut() -> [f32; 256] {
    let mut lut = [0.0; 256];
    for (i, v) in lut.iter_mut().enumerate() {
        *v = linear_from_srgb(i as f32 / 255.0);
    }
    lut
}

/// Options of [`raw_from_srgb`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReverseIspOptions {
    /// Pattern of the output mosaic.
    pub cfa: Cfa,
    /// Bit depth of the output (8..=16); the profile's levels are rescaled to it.
    pub bit_depth: u8,
    /// Noise added on the linear signal before quantisation.
    pub noise: Option<NoiseParams>,
    /// Seed of the noise.
    pub seed: u64,
}

impl ReverseIspOptions {
    /// The profile's own pattern and bit depth, no noise, seed 0.
    pub fn for_profile(profile: &CameraProfile) -> Self {
        Self {
            cfa: profile.cfa,
            bit_depth: profile.bit_depth,
            noise: None,
            seed: 0,
        }
    }
}

impl Default for ReverseIspOptions {
    fn default() -> Self {
        Self::for_profile(&CameraProfile::default())
    }
}

/// The per-channel rows of `diag(1/gains) · M⁻¹`: camera value of channel c = row[c] · rgb_lin.
fn inverse_rows(profile: &CameraProfile) -> Result<[[f32; 3]; 3], IspError> {
    profile.validate()?;
    let inv = profile.ccm_inverse()?;
    let mut rows = [[0f32; 3]; 3];
    for c in 0..3 {
        for k in 0..3 {
            rows[c][k] = (inv[c][k] / profile.wb_gains[c]) as f32;
        }
    }
    Ok(rows)
}

/// Linear camera RGB (before white balance) of an sRGB image: steps 1–3, no mosaic.
#[cfg(test)]
pub(crate) fn camera_rgb_from_srgb(
    rgb: ImageView<'_, [u8; 3]>,
    profile: &CameraProfile,
) -> Result<Image<[f32; 3]>, IspError> {
    let rows = inverse_rows(profile)?;
    let lut = srgb_u8_to_linear_lut();
    Ok(Image::from_fn(rgb.width(), rgb.height(), |x, y| {
        let p = rgb.get(x, y);
        let l = [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]];
        let mut out = [0f32; 3];
        for c in 0..3 {
            out[c] = rows[c][0] * l[0] + rows[c][1] * l[1] + rows[c][2] * l[2];
        }
        out
    }))
}

fn colour_index(c: Colour) -> usize {
    match c {
        Colour::Red => 0,
        Colour::Green => 1,
        Colour::Blue => 2,
    }
}

/// The linear mosaic (steps 1–4) of an sRGB image, before noise and quantisation.
pub(crate) fn linear_mosaic_from_srgb(
    rgb: ImageView<'_, [u8; 3]>,
    profile: &CameraProfile,
    cfa: Cfa,
) -> Result<Image<f32>, IspError> {
    let (w, h) = (rgb.width(), rgb.height());
    if w == 0 || h == 0 {
        return Err(IspError::Empty { width: w, height: h });
    }
    let rows = inverse_rows(profile)?;
    let lut = srgb_u8_to_linear_lut();
    let mut mosaic = Image::<f32>::new(w, h);
    mosaic
        .as_mut_slice()
        .par_chunks_mut(w * STRIP_ROWS)
        .enumerate()
        .for_each(|(s, out)| {
            for (i, d) in out.iter_mut().enumerate() {
                let (x, y) = (i % w, s * STRIP_ROWS + i / w);
                let p = rgb.get(x, y);
                let r = &rows[colour_index(cfa.colour_at(x, y))];
                *d = r[0] * lut[p[0] as usize] + r[1] * lut[p[1] as usize] + r[2] * lut[p[2] as usize];
            }
        });
    Ok(mosaic)
}

/// sRGB `u8` image → raw Bayer frame through the profile's inverse ISP (see the module docs).
///
/// The frame carries the profile's white-balance gains (`wb_gains`) and levels rescaled to
/// `opts.bit_depth`.
pub fn raw_from_srgb(
    rgb: ImageView<'_, [u8; 3]>,
    profile: &CameraProfile,
    opts: &ReverseIspOptions,
) -> Result<RawFrame, IspError> {
    check_bit_depth(opts.bit_depth)?;
    if let Some(n) = opts.noise {
        n.validate()?;
    }
    let mut mosaic = linear_mosaic_from_srgb(rgb, profile, opts.cfa)?;
    if let Some(n) = opts.noise {
        add_noise(&mut mosaic, n, opts.seed)?;
    }
    let (black, white) = profile.levels_at(opts.bit_depth);
    let frame = raw_from_linear_mosaic(&mosaic, opts.cfa, opts.bit_depth, Levels::uniform(black, white))?;
    let g = profile.wb_gains;
    Ok(frame.with_wb_gains([g[0] as f32, g[1] as f32, g[2] as f32]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::isp::noise::NoiseLevel;
    use crate::raw::RawPixels;
    use crate::srgb::srgb_from_linear;

    #[test]
    fn srgb_curve_round_trips_and_matches_known_values() {
        // sRGB 0.5 encodes linear 0.21404 (IEC 61966-2-1)
        assert!((linear_from_srgb(0.5) - 0.214_041).abs() < 1e-5);
        assert_eq!(linear_from_srgb(0.0), 0.0);
        assert!((linear_from_srgb(1.0) - 1.0).abs() < 1e-6);
        for i in 0..=255 {
            let c = i as f32 / 255.0;
            assert!((srgb_from_linear(linear_from_srgb(c)) - c).abs() < 1e-5, "{i}");
        }
    }

    fn identity_profile() -> CameraProfile {
        CameraProfile {
            name: "identity".into(),
            black_level: 64,
            white_level: 1023,
            bit_depth: 10,
            wb_gains: [2.0, 1.0, 1.5],
            ccm: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            cfa: Cfa::Rggb,
        }
    }

    #[test]
    fn hand_computed_pixels_identity_matrix() {
        // white pixel, RGGB, 10-bit black 64 white 1023:
        // R = 1/2 -> 64 + 0.5*959 = 543.5 -> 544; G = 1 -> 1023; B = 1/1.5 -> 64 + 639.33 = 703
        let rgb = Image::<[u8; 3]>::filled(4, 4, [255, 255, 255]);
        let p = identity_profile();
        let raw = raw_from_srgb(rgb.view(), &p, &ReverseIspOptions::for_profile(&p)).unwrap();
        assert_eq!(raw.value(0, 0), 544);
        assert_eq!(raw.value(1, 0), 1023);
        assert_eq!(raw.value(0, 1), 1023);
        assert_eq!(raw.value(1, 1), 703);
        assert_eq!(raw.wb_gains, Some([2.0, 1.0, 1.5]));
        // black pixel -> black level everywhere
        let rgb = Image::<[u8; 3]>::filled(2, 2, [0, 0, 0]);
        let raw = raw_from_srgb(rgb.view(), &p, &ReverseIspOptions::for_profile(&p)).unwrap();
        assert_eq!(raw.to_u16_vec(), vec![64; 4]);
    }

    #[test]
    fn every_pattern_samples_the_right_channel() {
        // pure red sRGB: only R sites are above black
        let rgb = Image::<[u8; 3]>::filled(4, 4, [255, 0, 0]);
        let p = identity_profile();
        for cfa in Cfa::ALL {
            let mut o = ReverseIspOptions::for_profile(&p);
            o.cfa = cfa;
            let raw = raw_from_srgb(rgb.view(), &p, &o).unwrap();
            for y in 0..4 {
                for x in 0..4 {
                    let is_red = cfa.colour_at(x, y) == Colour::Red;
                    assert_eq!(raw.value(x, y) > 64, is_red, "{cfa} ({x},{y})");
                }
            }
        }
    }

    #[test]
    fn inverse_matrix_undoes_ccm() {
        let p = CameraProfile::default();
        let rgb = Image::from_fn(5, 3, |x, y| [(x * 50) as u8, (y * 100) as u8, 128]);
        let cam = camera_rgb_from_srgb(rgb.view(), &p).unwrap();
        let lut = srgb_u8_to_linear_lut();
        for y in 0..3 {
            for x in 0..5 {
                let c = cam.get(x, y);
                let s = rgb.get(x, y);
                for r in 0..3 {
                    let back: f64 = (0..3).map(|k| p.ccm[r][k] * c[k] as f64 * p.wb_gains[k]).sum();
                    assert!((back - lut[s[r] as usize] as f64).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn eight_bit_output_uses_u8_and_levels_rescale() {
        let rgb = Image::<[u8; 3]>::filled(4, 2, [128, 128, 128]);
        let p = CameraProfile::default();
        let mut o = ReverseIspOptions::for_profile(&p);
        o.bit_depth = 8;
        let raw = raw_from_srgb(rgb.view(), &p, &o).unwrap();
        assert!(matches!(raw.pixels(), RawPixels::U8(_)));
        // 50 * 255 / 1023 = 12.46 -> 12
        assert_eq!(raw.levels().black, [12; 4]);
        o.bit_depth = 17;
        assert!(matches!(
            raw_from_srgb(rgb.view(), &p, &o),
            Err(IspError::Param {
                name: "bit_depth",
                ..
            })
        ));
    }

    #[test]
    fn noise_is_seeded_and_zero_noise_is_noiseless() {
        let rgb = Image::from_fn(64, 64, |x, y| [(x * 3) as u8, (y * 3) as u8, 100]);
        let p = CameraProfile::default();
        let mut o = ReverseIspOptions::for_profile(&p);
        o.bit_depth = 14;
        let clean = raw_from_srgb(rgb.view(), &p, &o).unwrap();
        o.noise = Some(NoiseParams::ZERO);
        assert_eq!(raw_from_srgb(rgb.view(), &p, &o).unwrap(), clean);
        o.noise = Some(NoiseLevel::Medium.params());
        o.seed = 4;
        let n1 = raw_from_srgb(rgb.view(), &p, &o).unwrap();
        let n2 = raw_from_srgb(rgb.view(), &p, &o).unwrap();
        assert_eq!(n1, n2);
        assert_ne!(n1, clean);
    }
}
