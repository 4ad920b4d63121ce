//! Loaders: headerless raw, 8/16-bit grey PNG and PGM mosaics, camera raw (via `rawloader`),
//! 8-bit RGB images (resampled to a mosaic), and a dispatcher [`load_input`].
//!
//! Every loader returns a [`RawError`] that names the file and the problem; none panics and none
//! returns a silently wrong frame:
//! - a headerless file whose size does not match `height * stride` is [`RawError::SizeMismatch`];
//! - a value above the declared bit depth is [`RawError::ValueOutOfRange`] (this is what a wrong
//!   endianness or a wrong bit depth looks like);
//! - a PNG that is neither 1-channel (mosaic) nor 8-bit RGB(A) is [`RawError::Format`].
//!
//! ```
//! use mosaicd::raw::load::{frame_from_bytes, Container, Endian, RawFormat};
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
//! data, non-2x2 patterns (X-Trans) and linear (demosaiced) DNGs.
//!
//! Grey PNGs written by [`write_png16`] describe themselves (pattern, bit depth, levels) in a
//! `tEXt` chunk, so [`load_input`] needs no flags for them; flags override the description.
//!
//! References: Netpbm PGM specification (16-bit samples are big-endian); PNG specification
//! (16-bit samples are big-endian, the `png`/`image` crates return native values).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::kodak_radc;
use super::sample::frame_from_rgb8;
use super::{Cfa, FrameMeta, Levels, RawError, RawFrame, RawPixels};
use crate::image::Image;

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

/// Description of a headerless raw file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawFormat {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Significant bits (8 for `U8`, 8..=16 for `U16`).
    pub bit_depth: u8,
    /// Pattern at (0, 0).
    pub cfa: Cfa,
    /// Sample container.
    pub container: Container,
    /// Byte order (ignored for `U8`).
    pub endian: Endian,
    /// Row stride in bytes; `None` means `width * bytes per pixel` (no padding).
    pub stride_bytes: Option<usize>,
    /// Black and white levels.
    pub levels: Levels,
}

impl RawFormat {
    /// A format without row padding.
    pub fn new(
        width: usize,
        height: usize,
        bit_depth: u8,
        cfa: Cfa,
        container: Container,
        endian: Endian,
        levels: Levels,
    ) -> Self {
        Self {
            width,
            height,
            bit_depth,
            cfa,
            container,
            endian,
            stride_bytes: None,
            levels,
        }
    }

    /// Row stride in bytes.
    pub fn stride(&self) -> usize {
        self.stride_bytes
            .unwrap_or(self.width.saturating_mul(self.container.bytes()))
    }

    /// Exact file size this format describes (`height * stride`).
    pub fn expected_len(&self) -> u64 {
        // Saturating: an absurd size is a size no file has, never a wrapped small one.
        (self.height as u64).saturating_mul(self.stride() as u64)
    }
}

fn io_err(path: &Path, source: std::io::Error) -> RawError {
    RawError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn format_err(path: &Path, what: String) -> RawError {
    RawError::Format {
        path: path.to_path_buf(),
        what,
    }
}

fn meta_for(origin: &Path) -> FrameMeta {
    FrameMeta {
        source: Arc::from(origin.display().to_string()),
        ..FrameMeta::default()
    }
}

/// Check every pixel against the bit depth; the first offender is the error.
fn check_range(data: &[u16], width: usize, bit_depth: u8, origin: &Path) -> Result<(), RawError> {
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

/// Build a frame from the bytes of a headerless file. `origin` names the source in errors and in
/// the frame's metadata.
pub fn frame_from_bytes(bytes: &[u8], fmt: &RawFormat, origin: &Path) -> Result<RawFrame, RawError> {
    let (w, h) = (fmt.width, fmt.height);
    if w == 0 || h == 0 {
        return Err(RawError::EmptyFrame { width: w, height: h });
    }
    let bpp = fmt.container.bytes();
    let row_bytes = w
        .checked_mul(bpp)
        .ok_or_else(|| format_err(origin, format!("width {w} is too large")))?;
    let stride = fmt.stride();
    if stride < row_bytes {
        return Err(RawError::Stride {
            stride: stride / bpp,
            width: w,
        });
    }
    if !stride.is_multiple_of(bpp) {
        return Err(format_err(
            origin,
            format!("stride {stride} bytes is not a multiple of the {bpp}-byte sample size"),
        ));
    }
    let expected = fmt.expected_len();
    if bytes.len() as u64 != expected {
        return Err(RawError::SizeMismatch {
            path: origin.to_path_buf(),
            expected,
            actual: bytes.len() as u64,
            width: w,
            height: h,
            bytes_per_pixel: bpp,
            stride_bytes: stride,
        });
    }
    let pixels = match fmt.container {
        Container::U8 => {
            if fmt.bit_depth != 8 {
                return Err(RawError::BitDepth {
                    bit_depth: fmt.bit_depth,
                    container_bits: 8,
                });
            }
            let mut out = Vec::with_capacity(w * h);
            for row in bytes.chunks_exact(stride) {
                out.extend_from_slice(&row[..row_bytes]);
            }
            RawPixels::U8(out)
        }
        Container::U16 => {
            if !(8..=16).contains(&fmt.bit_depth) {
                return Err(RawError::BitDepth {
                    bit_depth: fmt.bit_depth,
                    container_bits: 16,
                });
            }
            let mut out = Vec::with_capacity(w * h);
            for row in bytes.chunks_exact(stride) {
                let px = row[..row_bytes].chunks_exact(2);
                match fmt.endian {
                    Endian::Little => out.extend(px.map(|b| u16::from_le_bytes([b[0], b[1]]))),
                    Endian::Big => out.extend(px.map(|b| u16::from_be_bytes([b[0], b[1]]))),
                }
            }
            check_range(&out, w, fmt.bit_depth, origin)?;
            RawPixels::U16(out)
        }
    };
    let f = RawFrame::new(w, h, w, pixels, fmt.cfa, fmt.bit_depth, fmt.levels)?;
    Ok(f.with_meta(meta_for(origin)))
}

/// Load a headerless raw file.
pub fn load_headerless(path: &Path, fmt: &RawFormat) -> Result<RawFrame, RawError> {
    let bytes = std::fs::read(path).map_err(|e| io_err(path, e))?;
    frame_from_bytes(&bytes, fmt, path)
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

fn bits_for(max: u32) -> u8 {
    (32 - max.leading_zeros()).max(8) as u8
}

fn mosaic_frame(
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

/// Load a 1-channel 8- or 16-bit PNG as a mosaic.
pub fn load_png_mosaic(path: &Path, fmt: &MosaicFormat) -> Result<RawFrame, RawError> {
    let img = image::open(path).map_err(|e| format_err(path, format!("cannot decode PNG: {e}")))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    match img {
        image::DynamicImage::ImageLuma8(g) => mosaic_frame(w, h, RawPixels::U8(g.into_raw()), 8, fmt, path),
        image::DynamicImage::ImageLuma16(g) => {
            mosaic_frame(w, h, RawPixels::U16(g.into_raw()), 16, fmt, path)
        }
        other => Err(format_err(
            path,
            format!(
                "a mosaic PNG must be 1-channel 8- or 16-bit grey, this one is {:?}",
                other.color()
            ),
        )),
    }
}

/// Parse a binary PGM (`P5`) from bytes: width, height, maxval, samples (big-endian when
/// maxval > 255, as the Netpbm specification says).
pub fn pgm_from_bytes(bytes: &[u8], origin: &Path) -> Result<(usize, usize, u16, RawPixels), RawError> {
    let bad = |what: &str| format_err(origin, format!("not a binary PGM (P5): {what}"));
    if bytes.len() < 2 || &bytes[..2] != b"P5" {
        return Err(bad("magic number is not P5"));
    }
    let mut pos = 2;
    let mut fields = [0usize; 3];
    for f in fields.iter_mut() {
        // Skip whitespace and comments.
        loop {
            match bytes.get(pos) {
                Some(c) if c.is_ascii_whitespace() => pos += 1,
                Some(b'#') => {
                    while bytes.get(pos).is_some_and(|&c| c != b'\n') {
                        pos += 1;
                    }
                }
                Some(_) => break,
                None => return Err(bad("header ends early")),
            }
        }
        let start = pos;
        while bytes.get(pos).is_some_and(|c| c.is_ascii_digit()) {
            pos += 1;
        }
        if start == pos {
            return Err(bad("expected a decimal number in the header"));
        }
        *f = std::str::from_utf8(&bytes[start..pos])
            .ok()
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| bad("number too large in the header"))?;
    }
    // Exactly one whitespace byte separates the header from the samples.
    if !bytes.get(pos).is_some_and(|c| c.is_ascii_whitespace()) {
        return Err(bad("no whitespace after maxval"));
    }
    pos += 1;
    let [w, h, maxval] = fields;
    if maxval == 0 || maxval > 65535 {
        return Err(format_err(
            origin,
            format!("PGM maxval {maxval} is outside 1..=65535"),
        ));
    }
    if w == 0 || h == 0 {
        return Err(RawError::EmptyFrame { width: w, height: h });
    }
    let bpp = if maxval > 255 { 2 } else { 1 };
    let data = &bytes[pos..];
    let expected = (w as u64) * (h as u64) * bpp as u64;
    if (data.len() as u64) < expected {
        return Err(RawError::SizeMismatch {
            path: origin.to_path_buf(),
            expected: expected + pos as u64,
            actual: bytes.len() as u64,
            width: w,
            height: h,
            bytes_per_pixel: bpp,
            stride_bytes: w * bpp,
        });
    }
    let data = &data[..expected as usize];
    let pixels = if bpp == 1 {
        RawPixels::U8(data.to_vec())
    } else {
        RawPixels::U16(
            data.chunks_exact(2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
                .collect(),
        )
    };
    // Samples above maxval violate the format.
    let over = match &pixels {
        RawPixels::U8(v) => v
            .iter()
            .position(|&s| s as usize > maxval)
            .map(|i| (i, v[i] as u32)),
        RawPixels::U16(v) => v
            .iter()
            .position(|&s| s as usize > maxval)
            .map(|i| (i, v[i] as u32)),
    };
    if let Some((i, value)) = over {
        return Err(RawError::ValueOutOfRange {
            path: origin.to_path_buf(),
            value,
            x: i % w,
            y: i / w,
            bit_depth: bits_for(maxval as u32),
        });
    }
    Ok((w, h, maxval as u16, pixels))
}

/// Load a binary PGM (`P5`) mosaic. Without an explicit bit depth, the bit depth is the number of
/// bits of maxval (at least 8).
pub fn load_pgm_mosaic(path: &Path, fmt: &MosaicFormat) -> Result<RawFrame, RawError> {
    let bytes = std::fs::read(path).map_err(|e| io_err(path, e))?;
    let (w, h, maxval, pixels) = pgm_from_bytes(&bytes, path)?;
    mosaic_frame(w, h, pixels, bits_for(maxval as u32), fmt, path)
}

/// Keyword of the PNG `tEXt` chunk in which [`write_png16`] records the pattern, bit depth and
/// levels, so that our own mosaic PNGs load without flags.
pub const PNG_TEXT_KEY: &str = "mosaicd-mosaic";

/// What a mosaic PNG written by [`write_png16`] says about itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PngMosaicMeta {
    /// Pattern at (0, 0).
    pub cfa: Cfa,
    /// Significant bits.
    pub bit_depth: u8,
    /// Levels.
    pub levels: Levels,
}

impl PngMosaicMeta {
    /// The text stored in the chunk: `cfa=RGGB bit_depth=14 black=600,600,600,600 white=15520`.
    pub fn to_text(&self) -> String {
        let b = self.levels.black;
        format!(
            "cfa={} bit_depth={} black={},{},{},{} white={}",
            self.cfa, self.bit_depth, b[0], b[1], b[2], b[3], self.levels.white
        )
    }

    /// Parse [`PngMosaicMeta::to_text`]'s format; every field is required.
    pub fn parse(text: &str) -> Option<Self> {
        let (mut cfa, mut bits, mut black, mut white) = (None, None, None, None);
        for field in text.split_whitespace() {
            let (k, v) = field.split_once('=')?;
            match k {
                "cfa" => cfa = v.parse::<Cfa>().ok(),
                "bit_depth" => bits = v.parse::<u8>().ok(),
                "black" => {
                    let b: Vec<u16> = v.split(',').map(|t| t.parse().ok()).collect::<Option<_>>()?;
                    black = <[u16; 4]>::try_from(b).ok();
                }
                "white" => white = v.parse::<u16>().ok(),
                _ => return None,
            }
        }
        Some(Self {
            cfa: cfa?,
            bit_depth: bits?,
            levels: Levels {
                black: black?,
                white: white?,
            },
        })
    }
}

/// Write a frame as a 16-bit grey PNG: values as stored (not scaled), with the pattern, bit depth
/// and levels in a `tEXt` chunk ([`PNG_TEXT_KEY`]) that [`load_input`] reads.
pub fn write_png16(frame: &RawFrame, path: &Path) -> Result<(), RawError> {
    let (w, h) = (frame.width(), frame.height());
    let (Ok(w32), Ok(h32)) = (u32::try_from(w), u32::try_from(h)) else {
        return Err(format_err(path, format!("frame {w}x{h} too large for PNG")));
    };
    let meta = PngMosaicMeta {
        cfa: frame.cfa(),
        bit_depth: frame.bit_depth(),
        levels: *frame.levels(),
    };
    let png_err = |e: png::EncodingError| match e {
        png::EncodingError::IoError(io) => io_err(path, io),
        other => format_err(path, format!("cannot write PNG: {other}")),
    };
    let file = std::fs::File::create(path).map_err(|e| io_err(path, e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w32, h32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Sixteen);
    enc.add_text_chunk(PNG_TEXT_KEY.to_string(), meta.to_text())
        .map_err(png_err)?;
    let mut writer = enc.write_header().map_err(png_err)?;
    let bytes: Vec<u8> = frame.to_u16_vec().iter().flat_map(|v| v.to_be_bytes()).collect();
    writer.write_image_data(&bytes).map_err(png_err)?;
    writer.finish().map_err(png_err)
}

/// Write a frame as a binary PGM (`P5`) with maxval `2^bit_depth - 1` (big-endian 16-bit samples
/// when the bit depth exceeds 8).
pub fn write_pgm(frame: &RawFrame, path: &Path) -> Result<(), RawError> {
    let maxval = frame.max_value();
    let mut out = format!("P5\n{} {}\n{}\n", frame.width(), frame.height(), maxval).into_bytes();
    for v in frame.to_u16_vec() {
        if maxval > 255 {
            out.extend_from_slice(&v.to_be_bytes());
        } else {
            out.push(v as u8);
        }
    }
    std::fs::write(path, out).map_err(|e| io_err(path, e))
}

/// Load an 8-bit RGB (or RGBA, alpha dropped) PNG or JPEG.
pub fn load_rgb8(path: &Path) -> Result<Image<[u8; 3]>, RawError> {
    let img = image::open(path).map_err(|e| match e {
        image::ImageError::IoError(io) => io_err(path, io),
        other => format_err(path, format!("cannot decode image: {other}")),
    })?;
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

/// Map rawloader's 2x2 pattern name to ours.
fn cfa_from_rawloader(name: &str, origin: &Path) -> Result<Cfa, RawError> {
    name.parse::<Cfa>().map_err(|_| {
        format_err(
            origin,
            format!("CFA pattern {name:?} is not one of the 2x2 Bayer patterns RGGB, BGGR, GRBG, GBRG"),
        )
    })
}

/// Load a camera raw file: a Kodak DC40/DC50 KDC (identified by its TIFF make and model, see
/// [`super::kodak_radc`]) through our RADC decoder, anything else through `rawloader`.
pub fn load_camera_raw(path: &Path) -> Result<RawFrame, RawError> {
    let bytes = std::fs::read(path).map_err(|e| io_err(path, e))?;
    if let Some(info) = kodak_radc::identify(&bytes) {
        return load_kodak_radc(path, &bytes, &info);
    }
    let raw = rawloader::decode(&mut std::io::Cursor::new(&bytes)).map_err(|e| {
        let e = e.to_string();
        let first = e.lines().next().unwrap_or_default().trim().to_string();
        if first.contains("find a decoder") {
            // rawloader's own text goes on to ask for samples on its web site: not for our users.
            format_err(
                path,
                format!(
                    "not a supported input: no camera raw decoder knows this file (rawloader: {first}), \
                     and its extension is none of png, pgm, jpg, jpeg, bmp (images), raw, bin \
                     (headerless, with --width/--height or a sidecar)"
                ),
            )
        } else {
            // Only the first line: the rest of rawloader's messages asks for samples on its site.
            format_err(path, format!("rawloader: {first}"))
        }
    })?;
    let data = match raw.data {
        rawloader::RawImageData::Integer(ref d) => d,
        rawloader::RawImageData::Float(_) => {
            return Err(format_err(
                path,
                "floating-point raw data is not supported".into(),
            ))
        }
    };
    if raw.cpp != 1 {
        return Err(format_err(
            path,
            format!("{} components per pixel: not a Bayer mosaic", raw.cpp),
        ));
    }
    if raw.cfa.width != 2 || raw.cfa.height != 2 {
        return Err(format_err(
            path,
            format!(
                "CFA pattern {:?} is {}x{}, only 2x2 Bayer patterns are supported",
                raw.cfa.name, raw.cfa.width, raw.cfa.height
            ),
        ));
    }
    let full_cfa = cfa_from_rawloader(&raw.cfa.name, path)?;
    let (w, h) = (raw.width, raw.height);
    if data.len() < w * h {
        return Err(format_err(
            path,
            format!("rawloader returned {} samples for {w}x{h}", data.len()),
        ));
    }
    // Black levels are given per colour (R, G, B, E); ours are per tile position.
    let mut black = [0u16; 4];
    for (i, b) in black.iter_mut().enumerate() {
        let (x, y) = (i & 1, i >> 1);
        *b = raw.blacklevels[raw.cfa.color_at(y, x).min(3)];
    }
    let white = *raw.whitelevels.iter().max().unwrap_or(&0);
    let max_value = data.iter().copied().max().unwrap_or(0);
    let bit_depth = bits_for(white.max(max_value) as u32);
    let levels = Levels { black, white };
    let full = RawFrame::new(w, h, w, RawPixels::U16(data.clone()), full_cfa, bit_depth, levels)?;
    let [top, right, bottom, left] = raw.crops;
    let cw = w.saturating_sub(left + right);
    let ch = h.saturating_sub(top + bottom);
    let mut frame = if (top, right, bottom, left) == (0, 0, 0, 0) {
        full
    } else {
        full.crop(left, top, cw, ch)?
    };
    let g = raw.wb_coeffs[1];
    let gains = [raw.wb_coeffs[0] / g, 1.0, raw.wb_coeffs[2] / g];
    if gains.iter().all(|v| v.is_finite() && *v > 0.0) {
        frame.wb_gains = Some(gains);
    }
    frame.meta = meta_for(path);
    Ok(frame)
}

/// A Kodak DC40/DC50 RADC file: 768x512 GRBG, linear 14-bit values, black 0, white 16383, no
/// white-balance gains in the file.
fn load_kodak_radc(path: &Path, bytes: &[u8], info: &kodak_radc::RadcInfo) -> Result<RawFrame, RawError> {
    let px = kodak_radc::decode(bytes, info).map_err(|e| {
        format_err(
            path,
            format!("{} {} (Kodak RADC): {e}", info.make, info.model_name),
        )
    })?;
    let levels = Levels::uniform(kodak_radc::BLACK, kodak_radc::WHITE);
    let frame = RawFrame::new(
        info.width,
        info.height,
        info.width,
        RawPixels::U16(px),
        kodak_radc::CFA,
        kodak_radc::BIT_DEPTH,
        levels,
    )?;
    Ok(frame.with_meta(meta_for(path)))
}

/// How [`load_input`] should read a file. Fields that do not apply to a file type are ignored.
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

/// What [`load_input`] read: the mosaic, and the RGB image it was resampled from when the input
/// was an RGB image.
#[derive(Debug, Clone)]
pub struct LoadedInput {
    /// The mosaic.
    pub frame: RawFrame,
    /// The RGB image the mosaic was sampled from (RGB inputs only).
    pub rgb: Option<Image<[u8; 3]>>,
}

fn ext_of(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default()
}

fn need_cfa(opts: &InputOptions, path: &Path, kind: &str) -> Result<Cfa, RawError> {
    opts.cfa.ok_or_else(|| {
        format_err(
            path,
            format!("{kind} needs its CFA pattern (--cfa RGGB|BGGR|GRBG|GBRG)"),
        )
    })
}

fn levels_from(opts: &InputOptions, bit_depth: u8) -> Option<Levels> {
    if opts.black.is_none() && opts.white.is_none() {
        return None;
    }
    let max = ((1u32 << bit_depth.min(16)) - 1) as u16;
    Some(Levels {
        black: opts.black.unwrap_or([0; 4]),
        white: opts.white.unwrap_or(max),
    })
}

/// The headerless format described by `opts` for the file at `path`.
pub fn headerless_format(path: &Path, opts: &InputOptions) -> Result<RawFormat, RawError> {
    let (Some(width), Some(height)) = (opts.width, opts.height) else {
        return Err(format_err(
            path,
            "a headerless raw file needs --width and --height (and --bit-depth, --cfa)".into(),
        ));
    };
    let cfa = need_cfa(opts, path, "a headerless raw file")?;
    let (bit_depth, container) = match (opts.bit_depth, opts.container) {
        (Some(b), Some(c)) => (b, c),
        (Some(b), None) => (b, if b <= 8 { Container::U8 } else { Container::U16 }),
        (None, Some(Container::U8)) => (8, Container::U8),
        (None, _) => {
            return Err(format_err(
                path,
                "a headerless raw file needs --bit-depth (8..=16)".into(),
            ))
        }
    };
    let max = ((1u32 << bit_depth.min(16)) - 1) as u16;
    Ok(RawFormat {
        width,
        height,
        bit_depth,
        cfa,
        container,
        endian: opts.endian,
        stride_bytes: opts.stride_bytes,
        levels: levels_from(opts, bit_depth).unwrap_or(Levels::uniform(0, max)),
    })
}

/// Read a PNG's header without decoding the pixels: whether it is 1-channel grey, and our
/// [`PNG_TEXT_KEY`] description when it has one (a malformed description is an error).
fn png_header(path: &Path) -> Result<(bool, Option<PngMosaicMeta>), RawError> {
    let file = std::fs::File::open(path).map_err(|e| io_err(path, e))?;
    let decoder = png::Decoder::new(std::io::BufReader::new(file));
    let reader = decoder
        .read_info()
        .map_err(|e| format_err(path, format!("cannot read PNG header: {e}")))?;
    let info = reader.info();
    let grey = matches!(info.color_type, png::ColorType::Grayscale);
    let meta =
        match info
            .uncompressed_latin1_text
            .iter()
            .find(|t| t.keyword == PNG_TEXT_KEY)
        {
            None => None,
            Some(t) => Some(PngMosaicMeta::parse(&t.text).ok_or_else(|| {
                format_err(path, format!("malformed {PNG_TEXT_KEY} text chunk {:?}", t.text))
            })?),
        };
    Ok((grey, meta))
}

/// Read the mosaic description [`write_png16`] stores in a PNG, if any.
pub fn png_mosaic_meta(path: &Path) -> Result<Option<PngMosaicMeta>, RawError> {
    Ok(png_header(path)?.1)
}

/// Load any supported input, choosing the loader by options, extension and content:
///
/// - width and height given, or extension `raw`/`bin` → headerless ([`load_headerless`]);
/// - `.pgm` → PGM mosaic; `.png` 1-channel → PNG mosaic (pattern from `opts.cfa`, required);
/// - `.png` RGB(A) 8-bit, `.jpg`/`.jpeg`, `.bmp` → RGB image resampled into `opts.cfa` (default
///   RGGB), keeping the RGB image (a grey BMP decodes to equal R, G and B);
/// - anything else → camera raw through rawloader.
pub fn load_input(path: &Path, opts: &InputOptions) -> Result<LoadedInput, RawError> {
    let ext = ext_of(path);
    let headerless = (opts.width.is_some() || opts.height.is_some()) || ext == "raw" || ext == "bin";
    if headerless {
        let fmt = headerless_format(path, opts)?;
        return Ok(LoadedInput {
            frame: load_headerless(path, &fmt)?,
            rgb: None,
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
        "pgm" => Ok(LoadedInput {
            frame: load_pgm_mosaic(path, &mosaic_fmt("a PGM mosaic")?)?,
            rgb: None,
        }),
        "png" => match png_header(path)? {
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
                Ok(LoadedInput {
                    frame: load_png_mosaic(path, &fmt)?,
                    rgb: None,
                })
            }
            (false, _) => rgb_input(path, opts),
        },
        // BMP: the decoder expands 8-bit (palette) files to RGB, so a grey BMP (the USC sets)
        // samples into a mosaic of its own grey values, whatever the pattern.
        "jpg" | "jpeg" | "bmp" => rgb_input(path, opts),
        _ => Ok(LoadedInput {
            frame: load_camera_raw(path)?,
            rgb: None,
        }),
    }
}

fn rgb_input(path: &Path, opts: &InputOptions) -> Result<LoadedInput, RawError> {
    let rgb = load_rgb8(path)?;
    let mut frame = frame_from_rgb8(&rgb, opts.cfa.unwrap_or(Cfa::Rggb))?;
    frame.meta = meta_for(path);
    Ok(LoadedInput {
        frame,
        rgb: Some(rgb),
    })
}

/// A path for error messages when there is no file.
pub fn memory_origin() -> PathBuf {
    PathBuf::from("<memory>")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dimensions from a sidecar that would wrap `width * bytes` or `height * stride` past the
    /// size checks (release builds do not trap overflow) are refused, not turned into a frame.
    #[test]
    fn absurd_dimensions_cannot_wrap_past_the_size_checks() {
        let levels = Levels::uniform(0, 4095);
        let mut fmt = RawFormat::new(
            (1usize << 63) + 2,
            2,
            12,
            Cfa::Rggb,
            Container::U16,
            Endian::Little,
            levels,
        );
        fmt.stride_bytes = Some(4);
        let e = frame_from_bytes(&[0; 8], &fmt, Path::new("huge.raw")).unwrap_err();
        assert!(e.to_string().contains("too large"), "{e}");
        let mut tall = RawFormat::new(
            2,
            usize::MAX / 2,
            12,
            Cfa::Rggb,
            Container::U16,
            Endian::Little,
            levels,
        );
        tall.stride_bytes = Some(8);
        assert_eq!(tall.expected_len(), u64::MAX);
        assert!(matches!(
            frame_from_bytes(&[0; 8], &tall, Path::new("tall.raw")),
            Err(RawError::SizeMismatch { .. })
        ));
        // The frame type itself: stride * (height - 1) + width must not wrap either.
        let e = RawFrame::new(
            2,
            usize::MAX / 2,
            4,
            RawPixels::U16(vec![0; 8]),
            Cfa::Rggb,
            12,
            levels,
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                RawError::BufferSize {
                    needed: usize::MAX,
                    ..
                }
            ),
            "{e:?}"
        );
    }

    fn fmt16(w: usize, h: usize, endian: Endian) -> RawFormat {
        RawFormat::new(
            w,
            h,
            12,
            Cfa::Rggb,
            Container::U16,
            endian,
            Levels::uniform(64, 4095),
        )
    }

    fn origin() -> PathBuf {
        memory_origin()
    }

    #[test]
    fn little_and_big_endian() {
        let vals = [0u16, 1, 0x0abc, 4095, 256, 17];
        let le: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let be: Vec<u8> = vals.iter().flat_map(|v| v.to_be_bytes()).collect();
        let f = frame_from_bytes(&le, &fmt16(3, 2, Endian::Little), &origin()).unwrap();
        assert_eq!(f.to_u16_vec(), vals);
        let f = frame_from_bytes(&be, &fmt16(3, 2, Endian::Big), &origin()).unwrap();
        assert_eq!(f.to_u16_vec(), vals);
        assert_eq!(f.bit_depth(), 12);
        assert_eq!(f.levels().black, [64; 4]);
        // Wrong endianness: 1 reads as 0x0100 (still fits), 0x0abc as 0xbc0a > 4095.
        let err = frame_from_bytes(&le, &fmt16(3, 2, Endian::Big), &origin()).unwrap_err();
        match err {
            RawError::ValueOutOfRange {
                value,
                x,
                y,
                bit_depth,
                ..
            } => {
                assert_eq!((x, y, bit_depth), (2, 0, 12));
                assert_eq!(value, 0xbc0a);
            }
            e => panic!("unexpected {e}"),
        }
    }

    #[test]
    fn stride_padding_is_dropped() {
        // 2x2 u8 with stride 3; 2x2 u16 with stride 6 bytes.
        let b8 = [1u8, 2, 0xee, 3, 4, 0xee];
        let mut f8 = RawFormat::new(
            2,
            2,
            8,
            Cfa::Bggr,
            Container::U8,
            Endian::Little,
            Levels::uniform(0, 255),
        );
        f8.stride_bytes = Some(3);
        let f = frame_from_bytes(&b8, &f8, &origin()).unwrap();
        assert_eq!(f.to_u16_vec(), vec![1, 2, 3, 4]);
        assert_eq!(f.stride(), 2);
        let b16 = [1u8, 0, 2, 0, 0xff, 0xff, 3, 0, 4, 0, 0xff, 0xff];
        let mut f16 = fmt16(2, 2, Endian::Little);
        f16.stride_bytes = Some(6);
        let f = frame_from_bytes(&b16, &f16, &origin()).unwrap();
        assert_eq!(f.to_u16_vec(), vec![1, 2, 3, 4]);
        // Stride smaller than a row.
        f16.stride_bytes = Some(2);
        assert!(matches!(
            frame_from_bytes(&b16[..4], &f16, &origin()),
            Err(RawError::Stride { .. })
        ));
        // Odd stride for u16.
        f16.stride_bytes = Some(5);
        assert!(matches!(
            frame_from_bytes(&b16[..10], &f16, &origin()),
            Err(RawError::Format { .. })
        ));
    }

    /// Round trip with a pinned seed: random sizes, depths, endians and padding.
    #[test]
    fn random_headerless_round_trips() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261122);
        for _ in 0..200 {
            let (w, h) = (rng.random_range(1..20usize), rng.random_range(1..12usize));
            let container = if rng.random_bool(0.5) {
                Container::U8
            } else {
                Container::U16
            };
            let bits: u8 = if container == Container::U8 {
                8
            } else {
                rng.random_range(8..=16)
            };
            let endian = if rng.random_bool(0.5) {
                Endian::Little
            } else {
                Endian::Big
            };
            let bpp = container.bytes();
            let pad = rng.random_range(0..3usize) * bpp;
            let max = ((1u32 << bits) - 1) as u16;
            let vals: Vec<u16> = (0..w * h).map(|_| rng.random_range(0..=max)).collect();
            let mut bytes = Vec::new();
            for row in vals.chunks(w) {
                for &v in row {
                    match (container, endian) {
                        (Container::U8, _) => bytes.push(v as u8),
                        (Container::U16, Endian::Little) => bytes.extend_from_slice(&v.to_le_bytes()),
                        (Container::U16, Endian::Big) => bytes.extend_from_slice(&v.to_be_bytes()),
                    }
                }
                bytes.extend(std::iter::repeat_n(0xAAu8, pad));
            }
            let cfa = Cfa::ALL[rng.random_range(0..4usize)];
            let mut fmt = RawFormat::new(w, h, bits, cfa, container, endian, Levels::uniform(0, max));
            fmt.stride_bytes = Some(w * bpp + pad);
            let f = frame_from_bytes(&bytes, &fmt, &origin()).unwrap();
            assert_eq!(f.to_u16_vec(), vals);
            assert_eq!((f.width(), f.height(), f.cfa(), f.bit_depth()), (w, h, cfa, bits));
            // One byte short is always a size mismatch.
            assert!(matches!(
                frame_from_bytes(&bytes[..bytes.len() - 1], &fmt, &origin()),
                Err(RawError::SizeMismatch { .. })
            ));
        }
    }

    #[test]
    fn truncated_and_oversized_are_size_mismatch() {
        let bytes = vec![0u8; 3 * 2 * 2];
        for len in [0, 11, 13] {
            let mut b = bytes.clone();
            b.resize(len, 0);
            match frame_from_bytes(&b, &fmt16(3, 2, Endian::Little), &origin()) {
                Err(RawError::SizeMismatch { expected, actual, .. }) => {
                    assert_eq!((expected, actual), (12, len as u64));
                }
                other => panic!("len {len}: {other:?}"),
            }
        }
    }

    #[test]
    fn zero_size_and_bad_depth_are_errors() {
        assert!(matches!(
            frame_from_bytes(&[], &fmt16(0, 2, Endian::Little), &origin()),
            Err(RawError::EmptyFrame { .. })
        ));
        let mut f = fmt16(1, 1, Endian::Little);
        f.bit_depth = 17;
        assert!(matches!(
            frame_from_bytes(&[0, 0], &f, &origin()),
            Err(RawError::BitDepth { .. })
        ));
        let f = RawFormat::new(
            1,
            1,
            10,
            Cfa::Rggb,
            Container::U8,
            Endian::Little,
            Levels::uniform(0, 255),
        );
        assert!(matches!(
            frame_from_bytes(&[0], &f, &origin()),
            Err(RawError::BitDepth { .. })
        ));
        // Levels that do not fit the bit depth.
        let f = RawFormat::new(
            1,
            1,
            10,
            Cfa::Rggb,
            Container::U16,
            Endian::Little,
            Levels::uniform(0, 4095),
        );
        assert!(matches!(
            frame_from_bytes(&[0, 0], &f, &origin()),
            Err(RawError::Levels { .. })
        ));
    }

    #[test]
    fn pgm_round_trip_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        let f = RawFrame::from_u16(
            3,
            2,
            vec![0, 1, 1023, 512, 7, 1000],
            Cfa::Grbg,
            10,
            Levels::uniform(25, 1023),
        )
        .unwrap();
        let p = dir.path().join("m.pgm");
        write_pgm(&f, &p).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert!(bytes.starts_with(b"P5\n3 2\n1023\n"));
        // Big-endian samples: 1023 = 0x03ff at pixel 2.
        assert_eq!(&bytes[12 + 4..12 + 6], &[0x03, 0xff]);
        let fmt = MosaicFormat {
            cfa: Cfa::Grbg,
            bit_depth: None,
            black: [25; 4],
            white: Some(1023),
        };
        let g = load_pgm_mosaic(&p, &fmt).unwrap();
        assert_eq!(g.to_u16_vec(), f.to_u16_vec());
        assert_eq!(g.bit_depth(), 10);
        // Comments in the header, 8-bit.
        let (w, h, maxval, px) = pgm_from_bytes(b"P5 # c\n2 1\n# x\n255\n\x01\x02", &origin()).unwrap();
        assert_eq!((w, h, maxval), (2, 1, 255));
        assert_eq!(px, RawPixels::U8(vec![1, 2]));
        // Truncated, wrong magic, sample above maxval.
        assert!(matches!(
            pgm_from_bytes(b"P5\n2 2\n255\n\x01\x02\x03", &origin()),
            Err(RawError::SizeMismatch { .. })
        ));
        assert!(matches!(
            pgm_from_bytes(b"P2\n1 1\n255\n1", &origin()),
            Err(RawError::Format { .. })
        ));
        assert!(matches!(
            pgm_from_bytes(b"P5\n1 1\n100\n\xff", &origin()),
            Err(RawError::ValueOutOfRange { value: 255, .. })
        ));
        assert!(matches!(
            pgm_from_bytes(b"P5\n1 1\n70000\n\x00\x00", &origin()),
            Err(RawError::Format { .. })
        ));
    }

    #[test]
    fn png16_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let f = RawFrame::from_u16(
            2,
            3,
            vec![0, 1, 16383, 600, 9000, 5],
            Cfa::Gbrg,
            14,
            Levels::uniform(600, 15520),
        )
        .unwrap();
        let p = dir.path().join("m.png");
        write_png16(&f, &p).unwrap();
        let fmt = MosaicFormat {
            cfa: Cfa::Gbrg,
            bit_depth: Some(14),
            black: [600; 4],
            white: Some(15520),
        };
        let g = load_png_mosaic(&p, &fmt).unwrap();
        assert_eq!(g.to_u16_vec(), f.to_u16_vec());
        assert_eq!((g.width(), g.height(), g.cfa()), (2, 3, Cfa::Gbrg));
        // Impossible bit depths are errors, not panics.
        for bits in [0u8, 7, 17, 40] {
            let bad = MosaicFormat {
                bit_depth: Some(bits),
                white: None,
                ..fmt
            };
            assert!(
                matches!(load_png_mosaic(&p, &bad), Err(RawError::BitDepth { .. })),
                "{bits}"
            );
        }
        // Declaring too few bits is caught.
        let small = MosaicFormat {
            bit_depth: Some(10),
            white: None,
            ..fmt
        };
        assert!(matches!(
            load_png_mosaic(&p, &small),
            Err(RawError::ValueOutOfRange { .. })
        ));
        // Through the dispatcher, our own PNG describes itself: no flags needed.
        assert_eq!(
            png_mosaic_meta(&p).unwrap(),
            Some(PngMosaicMeta {
                cfa: Cfa::Gbrg,
                bit_depth: 14,
                levels: Levels::uniform(600, 15520)
            })
        );
        let l = load_input(&p, &InputOptions::default()).unwrap();
        assert_eq!(l.frame.to_u16_vec(), f.to_u16_vec());
        assert_eq!((l.frame.cfa(), l.frame.bit_depth()), (Cfa::Gbrg, 14));
        assert_eq!(*l.frame.levels(), Levels::uniform(600, 15520));
        // Flags override the description.
        let l = load_input(
            &p,
            &InputOptions {
                cfa: Some(Cfa::Rggb),
                white: Some(16000),
                ..InputOptions::default()
            },
        )
        .unwrap();
        assert_eq!(l.frame.cfa(), Cfa::Rggb);
        assert_eq!(*l.frame.levels(), Levels::uniform(600, 16000));
        // A grey PNG without the description needs its pattern.
        let plain = dir.path().join("plain.png");
        image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(2, 1, vec![1, 2])
            .unwrap()
            .save(&plain)
            .unwrap();
        assert!(matches!(
            load_input(&plain, &InputOptions::default()),
            Err(RawError::Format { .. })
        ));
        let opts = InputOptions {
            cfa: Some(Cfa::Gbrg),
            bit_depth: Some(14),
            black: Some([600; 4]),
            white: Some(15520),
            ..InputOptions::default()
        };
        let l = load_input(&p, &opts).unwrap();
        assert!(l.rgb.is_none());
        assert_eq!(l.frame.to_u16_vec(), f.to_u16_vec());
        assert_eq!(*l.frame.levels(), Levels::uniform(600, 15520));
    }

    #[test]
    fn png_description_round_trips_and_rejects_garbage() {
        let m = PngMosaicMeta {
            cfa: Cfa::Bggr,
            bit_depth: 12,
            levels: Levels {
                black: [1, 2, 3, 4],
                white: 4000,
            },
        };
        assert_eq!(m.to_text(), "cfa=BGGR bit_depth=12 black=1,2,3,4 white=4000");
        assert_eq!(PngMosaicMeta::parse(&m.to_text()), Some(m));
        for bad in [
            "",
            "cfa=BGGR bit_depth=12 black=1,2,3 white=4000",
            "cfa=XYZW bit_depth=12 black=1,2,3,4 white=4000",
            "cfa=BGGR bit_depth=12 black=1,2,3,4",
            "cfa=BGGR bit_depth=12 black=1,2,3,4 white=4000 extra=1",
        ] {
            assert_eq!(PngMosaicMeta::parse(bad), None, "{bad:?}");
        }
    }

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

    #[test]
    fn camera_raw_garbage_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.nef");
        std::fs::write(&p, b"not a raw file at all").unwrap();
        assert!(matches!(load_camera_raw(&p), Err(RawError::Format { .. })));
    }
}
