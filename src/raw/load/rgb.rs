//! 8-bit RGB images (PNG, JPEG, BMP), resampled into a mosaic by [`crate::raw::sample`].

use std::path::Path;

use super::common::{format_err, io_err, meta_for, too_large, InputOptions, LoadedInput};
use crate::image::Image;
use crate::raw::sample::frame_from_rgb8;
use crate::raw::{Cfa, FrameLimits, RawError};

/// Decode a PNG, JPEG or BMP file (format from the extension, as `image::open`) within the
/// frame-size limit: the header's width and height are checked against
/// [`FrameLimits::process`] before any pixel is decoded, and the decoder's own allocations are
/// capped ([`FrameLimits::image_limits`]). Every image decode in mosaicd goes through here or
/// through `decode_image_bytes`.
pub fn decode_image(path: &Path) -> Result<image::DynamicImage, RawError> {
    let reader = image::ImageReader::open(path).map_err(|e| io_err(path, e))?;
    decode_within_limits(reader, path)
}

/// [`decode_image`] for an image already in memory: the format is the one `origin`'s extension
/// names (as for a file), the same limits apply, and `origin` names the source in errors.
pub(crate) fn decode_image_bytes(bytes: &[u8], origin: &Path) -> Result<image::DynamicImage, RawError> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
    if let Ok(format) = image::ImageFormat::from_path(origin) {
        reader.set_format(format);
    }
    decode_within_limits(reader, origin)
}

/// The decode of [`decode_image`] and [`decode_image_bytes`]: limits first, then the header's
/// size, then the pixels.
fn decode_within_limits<R: std::io::BufRead + std::io::Seek>(
    mut reader: image::ImageReader<R>,
    origin: &Path,
) -> Result<image::DynamicImage, RawError> {
    let limits = FrameLimits::process();
    let decode_err = |e: image::ImageError| match e {
        image::ImageError::IoError(io) => io_err(origin, io),
        other => format_err(origin, format!("cannot decode image: {other}")),
    };
    reader.limits(limits.image_limits());
    let decoder = reader.into_decoder().map_err(decode_err)?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    limits
        .check(w as u64, h as u64)
        .map_err(|l| too_large(origin, l))?;
    image::DynamicImage::from_decoder(decoder).map_err(decode_err)
}

/// Load an 8-bit RGB (or RGBA, alpha dropped) PNG, JPEG or BMP.
pub(crate) fn load_rgb8(path: &Path) -> Result<Image<[u8; 3]>, RawError> {
    rgb8_from_image(decode_image(path)?, path)
}

/// An 8-bit RGB (or RGBA, alpha dropped) decoded image as an [`Image`]; any other colour type is
/// an error naming `origin`.
fn rgb8_from_image(img: image::DynamicImage, origin: &Path) -> Result<Image<[u8; 3]>, RawError> {
    let rgb = match img {
        image::DynamicImage::ImageRgb8(i) => i,
        image::DynamicImage::ImageRgba8(i) => image::DynamicImage::ImageRgba8(i).to_rgb8(),
        other => {
            return Err(format_err(
                origin,
                format!("expected an 8-bit RGB image, found {:?}", other.color()),
            ))
        }
    };
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    let px: Vec<[u8; 3]> = rgb.pixels().map(|p| p.0).collect();
    Image::from_vec(w, h, px).map_err(|e| format_err(origin, format!("{e}")))
}

/// A decoded colour image resampled into the mosaic of `opts.cfa` (default RGGB), keeping the RGB
/// image.
pub(super) fn rgb_input(
    img: image::DynamicImage,
    opts: &InputOptions,
    origin: &Path,
) -> Result<LoadedInput, RawError> {
    let rgb = rgb8_from_image(img, origin)?;
    let mut frame = frame_from_rgb8(&rgb, opts.cfa.unwrap_or(Cfa::Rggb))?;
    frame.meta = meta_for(origin);
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
