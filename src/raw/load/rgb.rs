//! 8-bit RGB images (PNG, JPEG, BMP), resampled into a mosaic by [`crate::raw::sample`].

use std::path::Path;

use super::common::{format_err, io_err, meta_for, too_large, InputOptions, LoadedInput};
use crate::image::Image;
use crate::raw::sample::frame_from_rgb8;
use crate::raw::{Cfa, FrameLimits, RawError};

/// Decode a PNG, JPEG or BMP file (format from the extension, as `image::open`) within the
/// frame-size limit: the header's width and height are checked against
/// [`FrameLimits::process`] before any pixel is decoded, and the decoder's own allocations are
/// capped ([`FrameLimits::image_limits`]). Every image decode in mosaicd goes through here.
pub fn decode_image(path: &Path) -> Result<image::DynamicImage, RawError> {
    let limits = FrameLimits::process();
    let decode_err = |e: image::ImageError| match e {
        image::ImageError::IoError(io) => io_err(path, io),
        other => format_err(path, format!("cannot decode image: {other}")),
    };
    let mut reader = image::ImageReader::open(path).map_err(|e| io_err(path, e))?;
    reader.limits(limits.image_limits());
    let decoder = reader.into_decoder().map_err(decode_err)?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    limits.check(w as u64, h as u64).map_err(|l| too_large(path, l))?;
    image::DynamicImage::from_decoder(decoder).map_err(decode_err)
}

/// Load an 8-bit RGB (or RGBA, alpha dropped) PNG, JPEG or BMP.
pub fn load_rgb8(path: &Path) -> Result<Image<[u8; 3]>, RawError> {
    let img = decode_image(path)?;
    let rgb = match img {
        image::DynamicImage::ImageRgb8(i) => i,
        image::DynamicImage::ImageRgba8(i) => image::DynamicImage::ImageRgba8(i).to_rgb8(),
        other => {
            return Err(format_err(
                path,
                format!("expected an 8-bit RGB image, found {:?}", other.color()),
            ))
        }
    };
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    let px: Vec<[u8; 3]> = rgb.pixels().map(|p| p.0).collect();
    Image::from_vec(w, h, px).map_err(|e| format_err(path, format!("{e}")))
}

pub(super) fn rgb_input(path: &Path, opts: &InputOptions) -> Result<LoadedInput, RawError> {
    let rgb = load_rgb8(path)?;
    let mut frame = frame_from_rgb8(&rgb, opts.cfa.unwrap_or(Cfa::Rggb))?;
    frame.meta = meta_for(path);
    Ok(LoadedInput {
        frame,
        rgb: Some(rgb),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::load::load_input;

    #[test]
    fn rgb_png_dispatches_to_resampling() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.png");
        let img = image::RgbImage::from_fn(4, 2, |x, y| image::Rgb([x as u8, 10 + y as u8, 100]));
        img.save(&p).unwrap();
        let l = load_input(
            &p,
            &InputOptions {
                cfa: Some(Cfa::Grbg),
                ..InputOptions::default()
            },
        )
        .unwrap();
        let rgb = l.rgb.expect("rgb kept");
        assert_eq!(rgb.get(3, 1), [3, 11, 100]);
        assert_eq!(l.frame.cfa(), Cfa::Grbg);
        // GRBG row 0: G R G R; row 1: B G B G
        assert_eq!(l.frame.to_u16_vec(), vec![10, 1, 10, 3, 100, 11, 100, 11]);
        // JPEG: lossy, so only the shape and the kept RGB are checked; grey JPEG is refused.
        let j = dir.path().join("c.jpg");
        img.save(&j).unwrap();
        let l = load_input(&j, &InputOptions::default()).unwrap();
        assert_eq!(
            (l.frame.width(), l.frame.height(), l.frame.cfa()),
            (4, 2, Cfa::Rggb)
        );
        let rgb = l.rgb.expect("rgb kept");
        assert_eq!(l.frame.value(0, 0), rgb.get(0, 0)[0] as u16);
        let g = dir.path().join("g.jpg");
        image::GrayImage::from_pixel(4, 2, image::Luma([9]))
            .save(&g)
            .unwrap();
        assert!(matches!(
            load_input(&g, &InputOptions::default()),
            Err(RawError::Format { .. })
        ));
    }
}
