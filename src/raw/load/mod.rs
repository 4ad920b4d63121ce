//! Loaders: headerless raw, 8/16-bit grey PNG and PGM mosaics, camera raw (via `rawloader`),
//! 8-bit RGB images (resampled to a mosaic), and a dispatcher [`load_input`].
//!
//! Every loader returns a [`RawError`] that names the file and the problem; none panics and none
//! returns a silently wrong frame:
//! - a headerless file whose size does not match `height * stride` is [`RawError::SizeMismatch`];
//! - a value above the declared bit depth is [`RawError::ValueOutOfRange`] (this is what a wrong
//!   endianness or a wrong bit depth looks like);
//! - a PNG that is neither 1-channel (mosaic) nor 8-bit RGB(A) is [`RawError::Format`];
//! - a frame larger than the frame-size limit ([`crate::raw::limits`], config key
//!   `limits.max_frame_pixels`) is [`RawError::TooLarge`], found from the header (PNG, JPEG, BMP,
//!   PGM), the format description (headerless) or the file's size (camera raw:
//!   [`RawError::FileTooLarge`]) **before** the pixels are read or decoded. Every size from a file
//!   is computed with checked arithmetic; files are `stat`ed before they are read.
//!
//! One module per format: `headerless` ([`RawFormat`], which the sidecar of
//! [`crate::capture::files`] also parses into), `pgm`, `png` (mosaic PNGs), `rgb` (PNG, JPEG and
//! BMP colour images through [`decode_image`]) and `camera` (rawloader and Kodak RADC).
//!
//! ```
//! use mosaicd::raw::{frame_from_bytes, Container, Endian, RawFormat};
//! use mosaicd::raw::{Cfa, Levels};
//! // 2x2, 10-bit, little-endian u16: values 1, 2, 3, 1023
//! let bytes = [1u8, 0, 2, 0, 3, 0, 0xff, 0x03];
//! let fmt = RawFormat::new(2, 2, 10, Cfa::Grbg, Container::U16, Endian::Little, Levels::uniform(0, 1023));
//! let f = frame_from_bytes(&bytes, &fmt, "mem".as_ref()).unwrap();
//! assert_eq!(f.to_u16_vec(), vec![1, 2, 3, 1023]);
//! // The same bytes read big-endian exceed 10 bits: refused, not silently wrong.
//! let be = RawFormat { endian: Endian::Big, ..fmt };
//! assert!(frame_from_bytes(&bytes, &be, "mem".as_ref()).is_err());
//! ```
//!
//! Camera raw files are read once; a Kodak DC40/DC50 KDC (identified by its TIFF make and model,
//! not by its name) is decoded by [`super::kodak_radc`] (RADC compression, which rawloader 0.37
//! lacks) into a 768x512 GRBG frame, 14-bit, black 0, white 16383, no gains; a truncated or corrupt
//! one is refused naming the camera and the byte offset. Everything else goes through
//! `rawloader::decode`: its crop (`crops` = top, right, bottom,
//! left) is applied and the pattern re-phased, its black levels (given per colour, RGBE) are mapped
//! to our per-tile-position black levels, the bit depth is the smallest that holds the white level
//! (and every value), and `wb_coeffs` become gains normalised to G = 1 (absent when NaN or zero).
//! rawloader decodes on the global rayon pool; the daemon never calls it on its compute pool.
//! Refused with rawloader's or our message: cameras rawloader 0.37 does not know, floating-point
//! data, non-2x2 patterns (X-Trans) and linear (demosaiced) DNGs. Refused before rawloader sees
//! them: Sigma X3F ([`is_x3f`]), MRW lengths that wrap rawloader's arithmetic
//! ([`mrw_length_wrap`]), and directory structures (the file's TIFF, an MRW's, a Sony file's
//! private and SR2 IFDs, a Canon CIFF's heaps) whose walk would exceed [`MAX_TIFF_IFD_VISITS`]
//! directories ([`rawloader_ifd_visits`]).
//!
//! Grey PNGs written by [`write_png16`] describe themselves (pattern, bit depth, levels) in a
//! `tEXt` chunk, so [`load_input`] needs no flags for them; flags override the description.
//!
//! References: Netpbm PGM specification (16-bit samples are big-endian); PNG specification
//! (16-bit samples are big-endian, the `png`/`image` crates return native values).

use std::path::Path;

use super::RawError;

mod camera;
mod common;
mod headerless;
mod pgm;
mod png;
mod rgb;
mod tiff_walk;

pub use camera::{camera_raw_from_bytes, load_camera_raw};
pub use common::{Container, Endian, InputOptions, LoadedInput, MosaicFormat};
pub(crate) use headerless::headerless_format;
pub use headerless::{frame_from_bytes, load_headerless, RawFormat};
pub use pgm::pgm_from_bytes;
pub(crate) use pgm::{load_pgm_mosaic, pgm_mosaic_from_bytes};
pub use png::load_png_mosaic;
pub use rgb::decode_image;
pub(crate) use rgb::{decode_image_bytes, load_rgb8};
pub use tiff_walk::{rawloader_ifd_visits, MAX_TIFF_IFD_VISITS};

use common::need_cfa;
use png::{png_header, png_header_from, png_mosaic_from_image};
use rgb::rgb_input;

fn ext_of(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default()
}

/// Load any supported input, choosing the loader by options, extension and content:
///
/// - width and height given, or extension `raw`/`bin` → headerless ([`load_headerless`]);
/// - `.pgm` → PGM mosaic; `.png` 1-channel → PNG mosaic (pattern from `opts.cfa`, required);
/// - `.png` RGB(A) 8-bit, `.jpg`/`.jpeg`, `.bmp` → RGB image resampled into `opts.cfa` (default
///   RGGB), keeping the RGB image (a grey BMP decodes to equal R, G and B);
/// - anything else → camera raw through rawloader.
pub fn load_input(path: &Path, opts: &InputOptions) -> Result<LoadedInput, RawError> {
    load_from(Src::File(path), opts)
}

/// [`load_input`] for a file already in memory: `origin` stands for its path (its extension
/// chooses the loader, and it names the source in errors and in the frame's metadata); the same
/// parsers, checks and errors, without the file loaders' `stat` and read. The caller bounds the
/// bytes' length (the file loaders refuse a file larger than its format can need:
/// [`RawError::FileTooLarge`]).
pub fn load_input_bytes(bytes: &[u8], origin: &Path, opts: &InputOptions) -> Result<LoadedInput, RawError> {
    load_from(Src::Memory { bytes, origin }, opts)
}

/// Where [`load_from`] reads: a file (`stat`ed and bounded by each loader) or bytes in memory.
#[derive(Clone, Copy)]
enum Src<'a> {
    File(&'a Path),
    Memory { bytes: &'a [u8], origin: &'a Path },
}

impl Src<'_> {
    fn origin(&self) -> &Path {
        match *self {
            Src::File(p) => p,
            Src::Memory { origin, .. } => origin,
        }
    }

    fn decode_image(&self) -> Result<image::DynamicImage, RawError> {
        match *self {
            Src::File(p) => decode_image(p),
            Src::Memory { bytes, origin } => decode_image_bytes(bytes, origin),
        }
    }
}

/// The dispatch of [`load_input`] and [`load_input_bytes`].
fn load_from(src: Src<'_>, opts: &InputOptions) -> Result<LoadedInput, RawError> {
    let path = src.origin();
    let ext = ext_of(path);
    let mosaic = |frame| Ok(LoadedInput { frame, rgb: None });
    let headerless = (opts.width.is_some() || opts.height.is_some()) || ext == "raw" || ext == "bin";
    if headerless {
        let fmt = headerless_format(path, opts)?;
        return mosaic(match src {
            Src::File(p) => load_headerless(p, &fmt)?,
            Src::Memory { bytes, origin } => frame_from_bytes(bytes, &fmt, origin)?,
        });
    }
    let mosaic_fmt = |kind: &str| -> Result<MosaicFormat, RawError> {
        Ok(MosaicFormat {
            cfa: need_cfa(opts, path, kind)?,
            bit_depth: opts.bit_depth,
            black: opts.black.unwrap_or([0; 4]),
            white: opts.white,
        })
    };
    match ext.as_str() {
        "pgm" => {
            let fmt = mosaic_fmt("a PGM mosaic")?;
            mosaic(match src {
                Src::File(p) => load_pgm_mosaic(p, &fmt)?,
                Src::Memory { bytes, origin } => pgm_mosaic_from_bytes(bytes, &fmt, origin)?,
            })
        }
        "png" => {
            let header = match src {
                Src::File(p) => png_header(p)?,
                Src::Memory { bytes, origin } => png_header_from(std::io::Cursor::new(bytes), origin)?,
            };
            match header {
                (true, meta) => {
                    // Flags override what the file says about itself.
                    let fmt = match meta {
                        Some(m) => MosaicFormat {
                            cfa: opts.cfa.unwrap_or(m.cfa),
                            bit_depth: Some(opts.bit_depth.unwrap_or(m.bit_depth)),
                            black: opts.black.unwrap_or(m.levels.black),
                            white: Some(opts.white.unwrap_or(m.levels.white)),
                        },
                        None => mosaic_fmt("a grey PNG mosaic")?,
                    };
                    mosaic(png_mosaic_from_image(src.decode_image()?, &fmt, path)?)
                }
                (false, _) => rgb_input(src.decode_image()?, opts, path),
            }
        }
        // BMP: the decoder expands 8-bit (palette) files to RGB, so a grey BMP (the USC sets)
        // samples into a mosaic of its own grey values, whatever the pattern.
        "jpg" | "jpeg" | "bmp" => rgb_input(src.decode_image()?, opts, path),
        _ => mosaic(match src {
            Src::File(p) => load_camera_raw(p)?,
            Src::Memory { bytes, origin } => camera_raw_from_bytes(bytes, origin)?,
        }),
    }
}

/// A path for error messages when there is no file.
#[cfg(test)]
pub(crate) fn memory_origin() -> std::path::PathBuf {
    std::path::PathBuf::from("<memory>")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::Cfa;

    #[test]
    fn dispatcher_headerless_needs_its_format() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.raw");
        std::fs::write(&p, [1u8, 2, 3, 4]).unwrap();
        assert!(matches!(
            load_input(&p, &InputOptions::default()),
            Err(RawError::Format { .. })
        ));
        let opts = InputOptions {
            width: Some(2),
            height: Some(2),
            cfa: Some(Cfa::Rggb),
            container: Some(Container::U8),
            ..InputOptions::default()
        };
        let l = load_input(&p, &opts).unwrap();
        assert_eq!(l.frame.to_u16_vec(), vec![1, 2, 3, 4]);
        assert_eq!(l.frame.bit_depth(), 8);
        // u16 without a bit depth is refused.
        let opts = InputOptions {
            container: Some(Container::U16),
            width: Some(1),
            ..opts
        };
        assert!(matches!(load_input(&p, &opts), Err(RawError::Format { .. })));
        // Missing file names the file.
        let missing = dir.path().join("nope.raw");
        let opts = InputOptions {
            bit_depth: Some(8),
            ..opts
        };
        match load_input(&missing, &opts) {
            Err(RawError::Io { path, .. }) => assert_eq!(path, missing),
            other => panic!("{other:?}"),
        }
    }
}
