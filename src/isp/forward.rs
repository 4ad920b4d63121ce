//! A minimal forward ISP: raw Bayer frame → sRGB `u8` image.
//!
//! Steps (the reverse of [`super::reverse`], so that a round trip can be measured):
//!
//! 1. **Black level**: `y = (v − black) / (white − black)` per tile position (the frame's levels).
//! 2. **White balance**: multiply each CFA site by its channel's gain (the profile's gains unless
//!    [`ForwardIspOptions::wb_gains`] overrides them), then clip at 1 (highlight clipping, as
//!    Infinite-ISP does: otherwise a blown sky turns magenta). Values below 0 are kept.
//! 3. **Demosaic** with the chosen [`DemosaicMethod`].
//! 4. **Colour matrix**: `rgb_lin = M · cam_wb` (profile's camera → linear sRGB matrix).
//! 5. **Gamma**: clip to `[0, 1]`, sRGB transfer function (IEC 61966-2-1), round to `u8`.
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::isp::{raw_from_srgb, srgb_from_raw, CameraProfile, DemosaicMethod, ForwardIspOptions, ReverseIspOptions};
//! let rgb = Image::<[u8; 3]>::filled(16, 16, [200, 120, 40]);
//! let p = CameraProfile::default();
//! let mut o = ReverseIspOptions::for_profile(&p);
//! o.bit_depth = 14;
//! let raw = raw_from_srgb(rgb.view(), &p, &o).unwrap();
//! let back = srgb_from_raw(&raw, &p, &ForwardIspOptions { method: DemosaicMethod::Malvar, wb_gains: None }).unwrap();
//! // a flat colour survives the round trip to within one code value
//! for (a, b) in back.get(8, 8).iter().zip([200u8, 120, 40]) {
//!     assert!((*a as i32 - b as i32).abs() <= 1);
//! }
//! ```
//!
//! ## Deviations
//! No denoising, lens shading, tone mapping or sharpening: this ISP exists to measure the cost
//! and the losses of the conventional path, not to make pretty pictures. Values are clipped at 1
//! after white balance and to `[0, 1]` after the colour matrix.

use rayon::prelude::*;

use super::demosaic::{demosaic_into, DemosaicMethod};
use super::noise::linear_from_raw;
use super::profile::CameraProfile;
use super::IspError;
use crate::image::Image;
use crate::raw::{Colour, RawFrame};
use crate::srgb::srgb_from_linear;

/// Rows per parallel strip.
const STRIP_ROWS: usize = 32;

/// Options of [`srgb_from_raw`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardIspOptions {
    /// Demosaicing method.
    pub method: DemosaicMethod,
    /// White-balance gains (R, G, B) overriding the profile's (e.g. a frame's own `wb_gains`).
    pub wb_gains: Option<[f64; 3]>,
}

impl Default for ForwardIspOptions {
    /// Malvar–He–Cutler demosaicing, the profile's gains.
    fn default() -> Self {
        Self {
            method: DemosaicMethod::Malvar,
            wb_gains: None,
        }
    }
}

/// Linear sRGB (steps 1–4, unclipped) of a raw frame.
pub(crate) fn linear_rgb_from_raw(
    frame: &RawFrame,
    profile: &CameraProfile,
    opts: &ForwardIspOptions,
) -> Result<Image<[f32; 3]>, IspError> {
    profile.validate()?;
    let gains = opts.wb_gains.unwrap_or(profile.wb_gains);
    for g in gains {
        if !g.is_finite() || g <= 0.0 {
            return Err(IspError::Param {
                name: "wb_gains",
                value: g,
                why: "white-balance gains must be finite and > 0",
            });
        }
    }
    let cfa = frame.cfa();
    let w = frame.width();
    let mut mosaic = linear_from_raw(frame);
    mosaic
        .as_mut_slice()
        .par_chunks_mut(w * STRIP_ROWS)
        .enumerate()
        .for_each(|(s, rows)| {
            for (i, v) in rows.iter_mut().enumerate() {
                let (x, y) = (i % w, s * STRIP_ROWS + i / w);
                let g = match cfa.colour_at(x, y) {
                    Colour::Red => gains[0],
                    Colour::Green => gains[1],
                    Colour::Blue => gains[2],
                };
                // highlight clip: a site saturated before white balance stays at 1 after it,
                // so blown highlights come out white instead of tinted by the gains
                *v = (*v * g as f32).min(1.0);
            }
        });
    let mut rgb = Image::new(w, frame.height());
    demosaic_into(mosaic.view(), cfa, opts.method, &mut rgb)?;
    let m = profile.ccm.map(|r| r.map(|v| v as f32));
    rgb.as_mut_slice()
        .par_chunks_mut(w * STRIP_ROWS)
        .for_each(|rows| {
            for p in rows.iter_mut() {
                let c = *p;
                *p = [0, 1, 2].map(|r| m[r][0] * c[0] + m[r][1] * c[1] + m[r][2] * c[2]);
            }
        });
    Ok(rgb)
}

/// Encode linear sRGB as `u8`: clip to `[0, 1]`, sRGB transfer function, round.
pub(crate) fn srgb_u8_from_linear(rgb: &Image<[f32; 3]>) -> Image<[u8; 3]> {
    rgb.map(|p| p.map(|c| (srgb_from_linear(c.clamp(0.0, 1.0)) * 255.0).round() as u8))
}

/// Raw frame → sRGB `u8` through black level, white balance, demosaicing, colour matrix, gamma.
pub fn srgb_from_raw(
    frame: &RawFrame,
    profile: &CameraProfile,
    opts: &ForwardIspOptions,
) -> Result<Image<[u8; 3]>, IspError> {
    Ok(srgb_u8_from_linear(&linear_rgb_from_raw(frame, profile, opts)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::{Cfa, Levels};

    fn identity_profile() -> CameraProfile {
        CameraProfile {
            name: "id".into(),
            black_level: 0,
            white_level: 1023,
            bit_depth: 10,
            wb_gains: [2.0, 1.0, 4.0],
            ccm: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            cfa: Cfa::Rggb,
        }
    }

    #[test]
    fn hand_computed_flat_frame() {
        // black 100, white 1100: R sites 350 -> y 0.25 * gain 2 = 0.5; G sites 600 -> 0.5;
        // B sites 225 -> 0.125 * 4 = 0.5  => linear 0.5 grey -> sRGB 0.7354 -> 188
        let mut px = vec![0u16; 16];
        for y in 0..4 {
            for x in 0..4 {
                px[y * 4 + x] = match Cfa::Bggr.colour_at(x, y) {
                    Colour::Red => 350,
                    Colour::Green => 600,
                    Colour::Blue => 225,
                };
            }
        }
        let f = RawFrame::from_u16(4, 4, px, Cfa::Bggr, 12, Levels::uniform(100, 1100)).unwrap();
        for method in DemosaicMethod::all() {
            let out = srgb_from_raw(
                &f,
                &identity_profile(),
                &ForwardIspOptions {
                    method,
                    wb_gains: None,
                },
            )
            .unwrap();
            assert!(
                out.as_slice().iter().all(|p| *p == [188, 188, 188]),
                "{method}: {:?}",
                out.get(0, 0)
            );
        }
        // gains overridden to 1: R = 0.25 -> sRGB 0.5371 -> 137
        let o = ForwardIspOptions {
            method: DemosaicMethod::Bilinear,
            wb_gains: Some([1.0, 1.0, 1.0]),
        };
        assert_eq!(
            srgb_from_raw(&f, &identity_profile(), &o).unwrap().get(1, 1)[0],
            137
        );
    }

    #[test]
    fn saturated_sites_stay_white_after_white_balance() {
        // every site at the white level; gains 2 / 1 / 4 would tint it without the highlight clip
        let f = RawFrame::from_u16(6, 6, vec![1023; 36], Cfa::Grbg, 10, Levels::uniform(64, 1023)).unwrap();
        let out = srgb_from_raw(&f, &identity_profile(), &ForwardIspOptions::default()).unwrap();
        assert!(out.as_slice().iter().all(|p| *p == [255, 255, 255]));
        let lin = linear_rgb_from_raw(&f, &identity_profile(), &ForwardIspOptions::default()).unwrap();
        assert!(lin.as_slice().iter().all(|p| *p == [1.0; 3]));
    }

    #[test]
    fn ccm_is_applied_after_demosaic() {
        let f = RawFrame::from_u8(4, 4, vec![255; 16], Cfa::Rggb, Levels::uniform(0, 255)).unwrap();
        let mut p = identity_profile();
        p.wb_gains = [1.0; 3];
        // swap R and B
        p.ccm = [[0.0, 0.0, 0.5], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
        let lin = linear_rgb_from_raw(&f, &p, &ForwardIspOptions::default()).unwrap();
        assert_eq!(lin.get(2, 2), [0.5, 1.0, 1.0]);
    }
}
