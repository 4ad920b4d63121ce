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

/// Decode the image file at `path` as 8-bit RGB (any colour type the decoder reads).
pub fn load_rgb8(path: &Path) -> Result<Image<[u8; 3]>, DecodeError> {
    let img = image::open(path).map_err(|source| DecodeError {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(rgb8_from_buffer(&img.to_rgb8()))
}
