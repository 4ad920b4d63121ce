//! RGB → mosaic resampling: the paper's "resampled Bayer version" of an RGB image.
//!
//! Zhou et al. build Bayer versions of RGB test sets (Kodak, INRIA) by keeping, at each pixel, only
//! the channel the colour filter array would have measured there. [`mosaic_from_rgb`] does exactly
//! that for any of the four patterns, and [`frame_from_rgb8`] wraps the result of an 8-bit image
//! in a [`RawFrame`] (bit depth 8, levels 0/255, no gains).
//!
//! ```
//! use mosaicd::image::Image;
//! use mosaicd::raw::{mosaic_from_rgb, Cfa};
//! let rgb = Image::from_fn(2, 2, |x, y| [10 + x as u8, 20 + y as u8, 30u8]);
//! let m = mosaic_from_rgb(&rgb.view(), Cfa::Rggb);
//! // R at (0,0), G at (1,0) and (0,1), B at (1,1)
//! assert_eq!(m.as_slice(), &[10, 20, 21, 30]);
//! ```
//!
//! Math: `mosaic(x, y) = rgb(x, y)[c(x, y)]` with `c` the colour (R = 0, G = 1, B = 2) of the CFA
//! at (x, y). Both greens (Gr, Gb) take the G channel. No filtering, no interpolation: this is a
//! sampling, not a simulation of a sensor (no noise, no black level, no linearisation; the reverse
//! ISP in `isp/` does that).
//!
//! Reference: Zhou, Zhang, Gao, Lou, "Gradient-based Feature Extraction From Raw Bayer Pattern
//! Images", §IV (resampled Kodak and INRIA).

use super::{Cfa, Colour, Levels, RawError, RawFrame};
use crate::image::{Image, ImageView};

fn colour_index(c: Colour) -> usize {
    match c {
        Colour::Red => 0,
        Colour::Green => 1,
        Colour::Blue => 2,
    }
}

/// Sample `rgb` through the colour filter array `cfa` into `dst`.
///
/// `dst` is reshaped to the size of `rgb`. Never fails; the `Result` keeps the STYLE form.
pub(crate) fn mosaic_from_rgb_into<T: Copy + Default>(
    rgb: &ImageView<'_, [T; 3]>,
    cfa: Cfa,
    dst: &mut Image<T>,
) -> Result<(), RawError> {
    let (w, h) = (rgb.width(), rgb.height());
    dst.reshape(w, h);
    for y in 0..h {
        // The colour index at even and odd x on this row.
        let c0 = colour_index(cfa.colour_at(0, y));
        let c1 = colour_index(cfa.colour_at(1, y));
        let src = rgb.row(y);
        let out = dst.row_mut(y);
        for (x, (o, p)) in out.iter_mut().zip(src).enumerate() {
            *o = if x & 1 == 0 { p[c0] } else { p[c1] };
        }
    }
    Ok(())
}

/// Allocating form of `mosaic_from_rgb_into`.
pub fn mosaic_from_rgb<T: Copy + Default>(rgb: &ImageView<'_, [T; 3]>, cfa: Cfa) -> Image<T> {
    let mut dst = Image::new(rgb.width(), rgb.height());
    // Infallible by construction.
    let _ = mosaic_from_rgb_into(rgb, cfa, &mut dst);
    dst
}

/// An 8-bit [`RawFrame`] (levels 0/255) resampled from an 8-bit RGB image.
///
/// Fails only on an empty image.
pub fn frame_from_rgb8(rgb: &Image<[u8; 3]>, cfa: Cfa) -> Result<RawFrame, RawError> {
    let m = mosaic_from_rgb(&rgb.view(), cfa);
    let (w, h) = m.dimensions();
    RawFrame::from_u8(w, h, m.into_vec(), cfa, Levels::uniform(0, 255))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::CfaChannel;

    #[test]
    fn takes_the_cfa_channel_for_all_patterns() {
        let rgb = Image::from_fn(5, 3, |x, y| {
            let base = (10 * (y * 5 + x)) as u16;
            [base, base + 1, base + 2]
        });
        for cfa in Cfa::ALL {
            let m = mosaic_from_rgb(&rgb.view(), cfa);
            assert_eq!(m.dimensions(), (5, 3));
            for y in 0..3 {
                for x in 0..5 {
                    let base = (10 * (y * 5 + x)) as u16;
                    let want = match cfa.channel_at(x, y) {
                        CfaChannel::R => base,
                        CfaChannel::Gr | CfaChannel::Gb => base + 1,
                        CfaChannel::B => base + 2,
                    };
                    assert_eq!(m.get(x, y), want, "{cfa} at ({x}, {y})");
                }
            }
        }
    }

    #[test]
    fn hand_computed_bggr_and_frame() {
        let rgb = Image::from_vec(2, 2, vec![[1u8, 2, 3], [4, 5, 6], [7, 8, 9], [10, 11, 12]]).unwrap();
        // BGGR: B G / G R
        let m = mosaic_from_rgb(&rgb.view(), Cfa::Bggr);
        assert_eq!(m.as_slice(), &[3, 5, 8, 10]);
        let f = frame_from_rgb8(&rgb, Cfa::Gbrg).unwrap();
        // GBRG: G B / R G
        assert_eq!(f.to_u16_vec(), vec![2, 6, 7, 11]);
        assert_eq!(f.cfa(), Cfa::Gbrg);
        assert_eq!(f.bit_depth(), 8);
        assert_eq!(*f.levels(), Levels::uniform(0, 255));
    }

    #[test]
    fn empty_rgb_is_an_error() {
        let rgb: Image<[u8; 3]> = Image::new(0, 4);
        assert!(matches!(
            frame_from_rgb8(&rgb, Cfa::Rggb),
            Err(RawError::EmptyFrame { .. })
        ));
    }
}
