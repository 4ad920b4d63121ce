//! Raw Bayer frames: the [`Cfa`] pattern type, [`RawFrame`], levels and normalisation, loaders.
//!
//! Data assumptions everywhere in mosaicd: pixel values are **linear** sensor values (no gamma, no
//! white balance, no colour matrix applied), stored LSB-aligned in a `u8` or `u16` container with a
//! known bit depth, a black level per 2x2 tile position and a white (saturation) level, and a 2x2
//! pattern phase given physically (RGGB = red at (0, 0)).
//!
//! The files are private behind this facade (what other crates use is re-exported here), except
//! [`kodak_radc`], a self-contained decoder whose names (`identify`, `decode`, `WHITE`, …) only read
//! well in its own namespace.

pub(crate) mod cfa;
pub(crate) mod frame;
pub mod kodak_radc;
pub(crate) mod levels;
pub(crate) mod limits;
pub(crate) mod load;
pub(crate) mod sample;
pub(crate) mod tone;

use std::path::PathBuf;

pub use cfa::{Cfa, CfaChannel, Colour, ParseCfaError};
pub use frame::{FrameMeta, Levels, RawFrame, RawPixels, RawView};
pub use levels::{
    f32_from_raw, grey_world_gains, normalise_into, u16_from_raw, Compression, Gains, NormaliseOptions,
    NormaliseSpec, ParseOptionError,
};
pub use limits::{FrameLimits, FrameTooLarge, DEFAULT_MAX_PIXELS};
pub use load::{
    camera_raw_from_bytes, decode_image, frame_from_bytes, load_camera_raw, load_headerless, load_input,
    load_input_bytes, load_png_mosaic, pgm_from_bytes, rawloader_ifd_visits, Container, Endian, InputOptions,
    LoadedInput, MosaicFormat, RawFormat, MAX_TIFF_IFD_VISITS,
};
pub use sample::{frame_from_rgb8, mosaic_from_rgb};
pub use tone::{MosaicTone, ToneTables};

/// Errors from building, cropping, normalising and loading raw frames.
#[derive(Debug, thiserror::Error)]
pub enum RawError {
    /// Width or height is zero.
    #[error("empty frame: {width}x{height}")]
    EmptyFrame {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// Row stride smaller than the width.
    #[error("row stride {stride} is smaller than width {width}")]
    Stride {
        /// Stride in pixels.
        stride: usize,
        /// Width in pixels.
        width: usize,
    },
    /// Bit depth does not fit the container.
    #[error("bit depth {bit_depth} is not valid for a {container_bits}-bit container (u8: 8, u16: 8..=16)")]
    BitDepth {
        /// Requested bit depth.
        bit_depth: u8,
        /// Container bits.
        container_bits: u8,
    },
    /// Black/white levels are inconsistent.
    #[error("levels black {black:?} / white {white} are invalid: need black < white <= {max}")]
    Levels {
        /// Black levels.
        black: [u16; 4],
        /// White level.
        white: u16,
        /// Largest value of the bit depth.
        max: u16,
    },
    /// The pixel buffer is too small.
    #[error("pixel buffer holds {len} pixels, {width}x{height} with stride {stride} needs {needed}")]
    BufferSize {
        /// Pixels present.
        len: usize,
        /// Pixels needed.
        needed: usize,
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Stride.
        stride: usize,
    },
    /// A crop rectangle outside the frame.
    #[error("crop {w}x{h} at ({x}, {y}) does not fit in {width}x{height}")]
    Crop {
        /// Crop x.
        x: usize,
        /// Crop y.
        y: usize,
        /// Crop width.
        w: usize,
        /// Crop height.
        h: usize,
        /// Frame width.
        width: usize,
        /// Frame height.
        height: usize,
    },
    /// File could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// A headerless file's size does not match the format description.
    #[error("{path}: file is {actual} bytes but {width}x{height} at {bytes_per_pixel} byte(s)/pixel with stride {stride_bytes} bytes needs {expected}")]
    SizeMismatch {
        /// File.
        path: PathBuf,
        /// Bytes expected.
        expected: u64,
        /// Bytes present.
        actual: u64,
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Bytes per pixel.
        bytes_per_pixel: usize,
        /// Row stride in bytes.
        stride_bytes: usize,
    },
    /// A frame larger than the frame-size limit ([`FrameLimits`]), refused before its pixels are read.
    #[error("{path}: {limit}")]
    TooLarge {
        /// File.
        path: PathBuf,
        /// The size claimed and the limit.
        limit: FrameTooLarge,
    },
    /// A file larger than any frame within the frame-size limit can be, refused before it is read.
    #[error("{path}: file is {size} bytes, more than the {max} bytes {what} within the frame-size limit can take (config key limits.max_frame_pixels)")]
    FileTooLarge {
        /// File.
        path: PathBuf,
        /// Its size in bytes.
        size: u64,
        /// Largest size accepted.
        max: u64,
        /// What kind of file ("a camera raw file", ...).
        what: &'static str,
    },
    /// A camera raw file whose directories (TIFF IFDs, or Canon CIFF heaps) point at each other
    /// so that rawloader's walk of them would build more directories than the limit (an
    /// exponential walk: a hostile or corrupt file), refused before rawloader reads it.
    #[error("{path}: its TIFF/CIFF directories would make the raw decoder visit at least {visits} of them, more than the limit of {limit} (sub-directory pointers that loop back: a corrupt or hostile file)")]
    TiffWalk {
        /// File.
        path: PathBuf,
        /// Directory visits counted when the walk stopped (a lower bound).
        visits: u64,
        /// The limit, [`load::MAX_TIFF_IFD_VISITS`].
        limit: u64,
    },
    /// A Minolta MRW whose header or block length wraps the raw decoder's 32-bit offset
    /// arithmetic (in release builds rawloader would loop forever on it), refused before
    /// rawloader reads it (`mrw_length_wrap`).
    #[error("{path}: Minolta MRW length {len:#010x} at byte {offset} wraps the raw decoder's 32-bit offsets (a corrupt or hostile file)")]
    MrwLength {
        /// File.
        path: PathBuf,
        /// Byte offset of the length field.
        offset: usize,
        /// The length it holds.
        len: u32,
    },
    /// A Sony SRF whose declared image exceeds the frame-size limit or does not fit in the file
    /// (rawloader would reserve its bytes before reading any: a failed reservation aborts the
    /// process), refused before rawloader reads it (`sony_srf_size`).
    #[error("{path}: Sony SRF declares a {width}x{height} image, whose 16-bit samples from byte {data_offset} need the file to hold {needed} bytes: it holds {file_len}, and the frame-size limit is {max_pixels} pixels and {max_side} a side (a corrupt or hostile file)")]
    SrfSize {
        /// File.
        path: PathBuf,
        /// Declared width.
        width: u64,
        /// Declared height.
        height: u64,
        /// Where the samples start, `SRF_DATA_OFFSET`.
        data_offset: u64,
        /// `data_offset + width * height * 2` (saturating).
        needed: u64,
        /// The file's size.
        file_len: u64,
        /// The frame-size limit's pixels.
        max_pixels: u64,
        /// The frame-size limit's side.
        max_side: u64,
    },
    /// A value in a file exceeds the declared bit depth.
    #[error("{path}: pixel value {value} at ({x}, {y}) exceeds the declared {bit_depth}-bit range")]
    ValueOutOfRange {
        /// File.
        path: PathBuf,
        /// Value.
        value: u32,
        /// x.
        x: usize,
        /// y.
        y: usize,
        /// Declared depth.
        bit_depth: u8,
    },
    /// The file format is not one we can read, or the file is not what its name says.
    #[error("{path}: {what}")]
    Format {
        /// File.
        path: PathBuf,
        /// What is wrong (a fixed description plus the offending values).
        what: String,
    },
    /// Gains from the file were asked for but the frame has none.
    #[error("white-balance gains from the file were requested but {origin:?} has none (use fixed, grey-world or auto gains)")]
    NoFileGains {
        /// The frame's source.
        origin: String,
    },
    /// Invalid normalisation parameters.
    #[error("invalid normalisation parameter {name} = {value}: {why}")]
    Param {
        /// Parameter name.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Allowed range.
        why: &'static str,
    },
}
