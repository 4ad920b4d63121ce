//! Decoding image files (PNG, JPEG, ...) into [`Image`]s: the one RGB decoder.
//!
//! [`load_rgb8`] reads any image the `image` crate decodes and converts it to 8-bit RGB the way
//! that crate does (grey replicated into three channels, alpha dropped, 16-bit channels scaled to
//! 8 bits); [`rgb8_from_buffer`] is that last step for an image already decoded.

use std::path::{Path, PathBuf};

use crate::image::Image;

/// An image file that does not open or decode.
#[derive(Debug, thiserror::Error)]
#[error("cannot decode {path}: {source}")]
pub struct DecodeError {
    /// File.
    pub path: PathBuf,
    /// The decoder's error.
    #[source]
    pub source: image::ImageError,
}

/// A decoded 8-bit RGB buffer as an [`Image`] (row-major, no padding).
pub fn rgb8_from_buffer(rgb: &image::RgbImage) -> Image<[u8; 3]> {
    let (w, h) = (rgb.width() as usize, rgb.height() as usize);
    Image::from_vec(w, h, rgb.pixels().map(|p| p.0).collect()).expect("size from the decoder")
}

/// Decode the image file at `path` as 8-bit RGB (any colour type the decoder reads), within the
/// process's frame-size limit ([`crate::raw::FrameLimits::process`]): a file whose header claims
/// more pixels than the limit is refused before its pixels are decoded.
pub fn load_rgb8(path: &Path) -> Result<Image<[u8; 3]>, DecodeError> {
    let err = |source| DecodeError {
        path: path.to_path_buf(),
        source,
    };
    let limits = crate::raw::FrameLimits::process();
    let mut reader = image::ImageReader::open(path).map_err(|e| err(image::ImageError::IoError(e)))?;
    reader.limits(limits.image_limits());
    let decoder = reader.into_decoder().map_err(err)?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    if limits.check(w as u64, h as u64).is_err() {
        return Err(err(image::ImageError::Limits(
            image::error::LimitError::from_kind(image::error::LimitErrorKind::DimensionError),
        )));
    }
    let img = image::DynamicImage::from_decoder(decoder).map_err(err)?;
    Ok(rgb8_from_buffer(&img.to_rgb8()))
}
