//! What the per-format loaders share, below all of them: the error constructors, the bounded
//! file read, the frame metadata, the range check, the 1-channel [`MosaicFormat`] and the
//! [`InputOptions`] that [`super::load_input`] and the headerless and RGB loaders read (with the
//! headerless [`Container`] and [`Endian`] they name). The facade `raw/load/mod.rs` re-exports
//! the public items; nothing here imports a loader.

use std::path::Path;
use std::sync::Arc;

use crate::image::Image;
use crate::raw::{Cfa, FrameMeta, FrameTooLarge, Levels, RawError, RawFrame, RawPixels};

/// Pixel container of a headerless file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Container {
    /// One byte per pixel (bit depth 8).
    U8,
    /// Two bytes per pixel (bit depth 8..=16, LSB-aligned).
    U16,
}

impl Container {
    /// Bytes per pixel.
    pub fn bytes(self) -> usize {
        match self {
            Container::U8 => 1,
            Container::U16 => 2,
        }
    }
}

/// Byte order of 16-bit samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Endian {
    /// Least significant byte first (most sensors and dumps).
    #[default]
    Little,
    /// Most significant byte first (PGM, PNG, some cameras).
    Big,
}

pub(super) fn io_err(path: &Path, source: std::io::Error) -> RawError {
    RawError::Io {
        path: path.to_path_buf(),
        source,
    }
}

pub(super) fn format_err(path: &Path, what: String) -> RawError {
    RawError::Format {
        path: path.to_path_buf(),
        what,
    }
}

pub(super) fn too_large(path: &Path, limit: FrameTooLarge) -> RawError {
    RawError::TooLarge {
        path: path.to_path_buf(),
        limit,
    }
}

/// Read a whole file whose size is checked first: `stat`, refuse a file above `max` bytes
/// ([`RawError::FileTooLarge`], naming `what`), then read at most `max` bytes (a file that grows
/// between the two is refused the same way).
pub(super) fn read_at_most(path: &Path, max: u64, what: &'static str) -> Result<Vec<u8>, RawError> {
    use crate::bounded_read::ReadAtMostError;
    crate::bounded_read::read_at_most(path, max).map_err(|e| match e {
        ReadAtMostError::Io(e) => io_err(path, e),
        ReadAtMostError::TooLarge { size } => RawError::FileTooLarge {
            path: path.to_path_buf(),
            size,
            max,
            what,
        },
    })
}

pub(super) fn meta_for(origin: &Path) -> FrameMeta {
    FrameMeta {
        source: Arc::from(origin.display().to_string()),
        ..FrameMeta::default()
    }
}

/// Check every pixel against the bit depth; the first offender is the error.
pub(super) fn check_range(data: &[u16], width: usize, bit_depth: u8, origin: &Path) -> Result<(), RawError> {
    let max = ((1u32 << bit_depth) - 1) as u16;
    if let Some(i) = data.iter().position(|&v| v > max) {
        return Err(RawError::ValueOutOfRange {
            path: origin.to_path_buf(),
            value: data[i] as u32,
            x: i % width,
            y: i / width,
            bit_depth,
        });
    }
    Ok(())
}

/// How to interpret a 1-channel image file (PNG or PGM) as a mosaic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MosaicFormat {
    /// Pattern at (0, 0).
    pub cfa: Cfa,
    /// Significant bits; `None` means the file's sample depth (8 or 16, or PGM's maxval bits).
    pub bit_depth: Option<u8>,
    /// Black level per tile position.
    pub black: [u16; 4],
    /// White level; `None` means `2^bit_depth - 1`.
    pub white: Option<u16>,
}

pub(super) fn bits_for(max: u32) -> u8 {
    (32 - max.leading_zeros()).max(8) as u8
}

pub(super) fn mosaic_frame(
    width: usize,
    height: usize,
    pixels: RawPixels,
    file_bits: u8,
    fmt: &MosaicFormat,
    origin: &Path,
) -> Result<RawFrame, RawError> {
    let bit_depth = fmt.bit_depth.unwrap_or(file_bits);
    if !(8..=16).contains(&bit_depth) {
        return Err(RawError::BitDepth {
            bit_depth,
            container_bits: 16,
        });
    }
    let pixels = match pixels {
        RawPixels::U8(v) if bit_depth > 8 => RawPixels::U16(v.into_iter().map(u16::from).collect()),
        RawPixels::U16(v) => {
            check_range(&v, width, bit_depth, origin)?;
            RawPixels::U16(v)
        }
        p => p,
    };
    let max = ((1u32 << bit_depth.min(16)) - 1) as u16;
    let levels = Levels {
        black: fmt.black,
        white: fmt.white.unwrap_or(max),
    };
    let f = RawFrame::new(width, height, width, pixels, fmt.cfa, bit_depth, levels)?;
    Ok(f.with_meta(meta_for(origin)))
}

/// How [`load_input`](super::load_input) should read a file. Fields that do not apply to a file
/// type are ignored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct InputOptions {
    /// Width of a headerless file (giving width and height selects the headerless loader).
    pub width: Option<usize>,
    /// Height of a headerless file.
    pub height: Option<usize>,
    /// Bit depth of a headerless file or mosaic PNG/PGM.
    pub bit_depth: Option<u8>,
    /// Pattern of a headerless file or mosaic PNG/PGM (required for those), and the pattern RGB
    /// images are resampled into (default RGGB).
    pub cfa: Option<Cfa>,
    /// Black level (per tile position; one value for all is `[b; 4]`). Default 0.
    pub black: Option<[u16; 4]>,
    /// White level. Default `2^bit_depth - 1`.
    pub white: Option<u16>,
    /// Byte order of a 16-bit headerless file.
    pub endian: Endian,
    /// Row stride of a headerless file, in bytes.
    pub stride_bytes: Option<usize>,
    /// Container of a headerless file; default from the bit depth (8 → u8, more → u16).
    pub container: Option<Container>,
}

/// What [`load_input`](super::load_input) read: the mosaic, and the RGB image it was resampled
/// from when the input was an RGB image.
#[derive(Debug, Clone)]
pub struct LoadedInput {
    /// The mosaic.
    pub frame: RawFrame,
    /// The RGB image the mosaic was sampled from (RGB inputs only).
    pub rgb: Option<Image<[u8; 3]>>,
}

pub(super) fn need_cfa(opts: &InputOptions, path: &Path, kind: &str) -> Result<Cfa, RawError> {
    opts.cfa.ok_or_else(|| {
        format_err(
            path,
            format!("{kind} needs its CFA pattern (--cfa RGGB|BGGR|GRBG|GBRG)"),
        )
    })
}

pub(super) fn levels_from(opts: &InputOptions, bit_depth: u8) -> Option<Levels> {
    if opts.black.is_none() && opts.white.is_none() {
        return None;
    }
    let max = ((1u32 << bit_depth.min(16)) - 1) as u16;
    Some(Levels {
        black: opts.black.unwrap_or([0; 4]),
        white: opts.white.unwrap_or(max),
    })
}
