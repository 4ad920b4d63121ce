//! V4L2 Bayer pixel formats: FourCC → (pattern, bit depth, packing), and unpacking a driver
//! buffer (with its `bytesperline` stride) into a [`RawFrame`]. Pure functions, no device.
//!
//! Supported (names are V4L2's and **physical**: `RGGB` = red at (0, 0), unlike OpenCV's
//! `COLOR_BayerBG2BGR` for the same sensor; the pattern names map straight to [`Cfa`]):
//!
//! | FourCCs (BGGR, GBRG, GRBG, RGGB) | bits | layout |
//! |---|---|---|
//! | `BA81`, `GBRG`, `GRBG`, `RGGB` | 8 | one byte per pixel |
//! | `BG10`, `GB10`, `BA10`, `RG10` | 10 | u16 little-endian, 6 high bits zero |
//! | `BG12`, `GB12`, `BA12`, `RG12` | 12 | u16 little-endian, 4 high bits zero |
//! | `BG14`, `GB14`, `GR14`, `RG14` | 14 | u16 little-endian, 2 high bits zero |
//! | `BYR2`, `GB16`, `GR16`, `RG16` | 16 | u16 little-endian |
//! | `pBAA`, `pGAA`, `pgAA`, `pRAA` | 10 | MIPI CSI-2 packed: 4 pixels in 5 bytes |
//! | `pBCC`, `pGCC`, `pgCC`, `pRCC` | 12 | MIPI CSI-2 packed: 2 pixels in 3 bytes |
//!
//! Packed layouts (kernel docs `pixfmt-srggb10p`, `pixfmt-srggb12p`): for 10-bit, bytes 0..4 of a
//! group hold the 8 high bits of pixels 0..3 and byte 4 holds their 2 low bits, pixel 0 in bits
//! 1..0, pixel 1 in bits 3..2, pixel 2 in 5..4, pixel 3 in 7..6. For 12-bit, bytes 0 and 1 hold
//! the high 8 bits of pixels 0 and 1 and byte 2 their low 4 bits, pixel 0 in bits 3..0, pixel 1
//! in bits 7..4. A row may end in a partial group, which still occupies a whole group of bytes
//! (we require `bytesperline ≥ ceil(width / 4) · 5`, resp. `ceil(width / 2) · 3`); the bytes after
//! the row's pixels up to `bytesperline` are padding and ignored.
//!
//! Unpacked 10/12/14-bit values must fit their bit depth (the spec says the high bits are zero);
//! a value that does not is reported, never silently masked.
//!
//! ```
//! use mosaicd::capture::{bayer_format, raw_frame_from_v4l2};
//! use mosaicd::raw::Cfa;
//! let fmt = bayer_format(*b"pRAA").unwrap();
//! assert_eq!((fmt.cfa, fmt.bit_depth), (Cfa::Rggb, 10));
//! // 4 pixels 0x3FF, 0x001, 0x200, 0x155 in 5 bytes.
//! let buf = [0xFF, 0x00, 0x80, 0x55, 0b01_00_01_11];
//! let f = raw_frame_from_v4l2(&fmt, &buf, 4, 1, 5, None).unwrap();
//! assert_eq!(f.to_u16_vec(), vec![0x3FF, 0x001, 0x200, 0x155]);
//! ```
//!
//! References: Linux kernel documentation, "V4L2_PIX_FMT_SRGGB10P", "V4L2_PIX_FMT_SRGGB12P",
//! "V4L2_PIX_FMT_SRGGB10 (…) 10-bit Bayer formats expanded to 16 bits", "V4L2_PIX_FMT_SRGGB8".

use rayon::prelude::*;

use crate::raw::{Cfa, FrameLimits, FrameTooLarge, Levels, RawError, RawFrame, RawPixels};

/// Rows per rayon task when unpacking.
pub(crate) const STRIP_ROWS: usize = 64;

/// How samples are stored in a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Packing {
    /// One byte per pixel.
    U8,
    /// Little-endian u16 per pixel, value LSB-aligned.
    U16Le,
    /// MIPI CSI-2 10-bit: 4 pixels in 5 bytes.
    Mipi10,
    /// MIPI CSI-2 12-bit: 2 pixels in 3 bytes.
    Mipi12,
}

/// A V4L2 Bayer format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BayerFormat {
    /// The FourCC.
    pub fourcc: [u8; 4],
    /// Physical pattern at (0, 0).
    pub cfa: Cfa,
    /// Significant bits.
    pub bit_depth: u8,
    /// Storage.
    pub packing: Packing,
}

/// Errors interpreting V4L2 formats and buffers.
#[derive(Debug, thiserror::Error)]
pub enum V4l2FormatError {
    /// Not a Bayer FourCC we know.
    #[error("FourCC {fourcc:?} is not a supported Bayer format (supported: {supported})")]
    UnknownFourcc {
        /// The FourCC as text.
        fourcc: String,
        /// The supported list.
        supported: String,
    },
    /// `bytesperline` too small for the width.
    #[error("{fourcc}: bytesperline {bytes_per_line} is smaller than the {min} bytes {width} pixels need")]
    Stride {
        /// Format.
        fourcc: String,
        /// Given stride.
        bytes_per_line: usize,
        /// Needed.
        min: usize,
        /// Width.
        width: usize,
    },
    /// The buffer is shorter than height rows.
    #[error("{fourcc}: buffer holds {len} bytes, {width}x{height} with bytesperline {bytes_per_line} needs {needed}")]
    BufferSize {
        /// Format.
        fourcc: String,
        /// Bytes present.
        len: usize,
        /// Bytes needed.
        needed: usize,
        /// Width.
        width: usize,
        /// Height.
        height: usize,
        /// Stride.
        bytes_per_line: usize,
    },
    /// An unpacked value exceeds the bit depth.
    #[error("{fourcc}: value {value} at ({x}, {y}) exceeds {bit_depth} bits (high bits must be zero)")]
    ValueOutOfRange {
        /// Format.
        fourcc: String,
        /// The value.
        value: u16,
        /// x.
        x: usize,
        /// y.
        y: usize,
        /// Bit depth.
        bit_depth: u8,
    },
    /// The result is not a valid frame (zero size, bad levels).
    #[error(transparent)]
    Frame(#[from] RawError),
    /// The driver's frame size exceeds the frame-size limit.
    #[error("{fourcc}: {limit}")]
    TooLarge {
        /// Format.
        fourcc: String,
        /// The size and the limit.
        limit: FrameTooLarge,
    },
}

/// Every supported FourCC, in the table's order.
pub const SUPPORTED: [[u8; 4]; 24] = [
    *b"BA81", *b"GBRG", *b"GRBG", *b"RGGB", // 8-bit
    *b"BG10", *b"GB10", *b"BA10", *b"RG10", // 10-bit unpacked
    *b"BG12", *b"GB12", *b"BA12", *b"RG12", // 12-bit unpacked
    *b"BG14", *b"GB14", *b"GR14", *b"RG14", // 14-bit unpacked
    *b"BYR2", *b"GB16", *b"GR16", *b"RG16", // 16-bit
    *b"pBAA", *b"pGAA", *b"pgAA", *b"pRAA", // 10-bit packed
];

/// 12-bit packed FourCCs (kept apart so [`SUPPORTED`] stays a readable table).
pub const SUPPORTED_PACKED12: [[u8; 4]; 4] = [*b"pBCC", *b"pGCC", *b"pgCC", *b"pRCC"];

/// A FourCC written as text (`"pRAA"`): its four bytes, or `None` unless it is exactly four
/// bytes long. The inverse of `fourcc_str` for printable codes.
pub fn parse_fourcc(s: &str) -> Option<[u8; 4]> {
    <[u8; 4]>::try_from(s.as_bytes()).ok()
}

/// FourCC as printable text.
pub(crate) fn fourcc_str(f: [u8; 4]) -> String {
    f.iter()
        .map(|&b| {
            if b.is_ascii_graphic() || b == b' ' {
                b as char
            } else {
                '?'
            }
        })
        .collect()
}

/// Look up a Bayer FourCC.
pub fn bayer_format(fourcc: [u8; 4]) -> Result<BayerFormat, V4l2FormatError> {
    use Cfa::*;
    use Packing::*;
    let (cfa, bit_depth, packing) = match &fourcc {
        b"BA81" => (Bggr, 8, U8),
        b"GBRG" => (Gbrg, 8, U8),
        b"GRBG" => (Grbg, 8, U8),
        b"RGGB" => (Rggb, 8, U8),
        b"BG10" => (Bggr, 10, U16Le),
        b"GB10" => (Gbrg, 10, U16Le),
        b"BA10" => (Grbg, 10, U16Le),
        b"RG10" => (Rggb, 10, U16Le),
        b"BG12" => (Bggr, 12, U16Le),
        b"GB12" => (Gbrg, 12, U16Le),
        b"BA12" => (Grbg, 12, U16Le),
        b"RG12" => (Rggb, 12, U16Le),
        b"BG14" => (Bggr, 14, U16Le),
        b"GB14" => (Gbrg, 14, U16Le),
        b"GR14" => (Grbg, 14, U16Le),
        b"RG14" => (Rggb, 14, U16Le),
        b"BYR2" => (Bggr, 16, U16Le),
        b"GB16" => (Gbrg, 16, U16Le),
        b"GR16" => (Grbg, 16, U16Le),
        b"RG16" => (Rggb, 16, U16Le),
        b"pBAA" => (Bggr, 10, Mipi10),
        b"pGAA" => (Gbrg, 10, Mipi10),
        b"pgAA" => (Grbg, 10, Mipi10),
        b"pRAA" => (Rggb, 10, Mipi10),
        b"pBCC" => (Bggr, 12, Mipi12),
        b"pGCC" => (Gbrg, 12, Mipi12),
        b"pgCC" => (Grbg, 12, Mipi12),
        b"pRCC" => (Rggb, 12, Mipi12),
        _ => {
            let supported: Vec<String> = SUPPORTED
                .iter()
                .chain(&SUPPORTED_PACKED12)
                .map(|f| fourcc_str(*f))
                .collect();
            return Err(V4l2FormatError::UnknownFourcc {
                fourcc: fourcc_str(fourcc),
                supported: supported.join(" "),
            });
        }
    };
    Ok(BayerFormat {
        fourcc,
        cfa,
        bit_depth,
        packing,
    })
}

impl BayerFormat {
    /// Smallest `bytesperline` for `width` pixels (saturating: a width whose row does not fit
    /// in `usize` needs `usize::MAX` bytes, which no buffer has).
    pub fn min_bytes_per_line(&self, width: usize) -> usize {
        match self.packing {
            Packing::U8 => width,
            Packing::U16Le => width.saturating_mul(2),
            Packing::Mipi10 => width.div_ceil(4).saturating_mul(5),
            Packing::Mipi12 => width.div_ceil(2).saturating_mul(3),
        }
    }

    /// Largest value of the bit depth.
    pub fn max_value(&self) -> u16 {
        ((1u32 << self.bit_depth) - 1) as u16
    }

    fn name(&self) -> String {
        fourcc_str(self.fourcc)
    }

    /// Check a buffer's geometry: the size against the frame-size limit, the stride against the
    /// width, the length against `bpl * (height - 1) + min` (all checked: the sizes come from the
    /// driver).
    fn check(&self, len: usize, width: usize, height: usize, bpl: usize) -> Result<(), V4l2FormatError> {
        FrameLimits::process()
            .check_usize(width, height)
            .map_err(|limit| V4l2FormatError::TooLarge {
                fourcc: self.name(),
                limit,
            })?;
        let min = self.min_bytes_per_line(width);
        if bpl < min {
            return Err(V4l2FormatError::Stride {
                fourcc: self.name(),
                bytes_per_line: bpl,
                min,
                width,
            });
        }
        let needed = match height {
            0 => 0,
            h => bpl
                .checked_mul(h - 1)
                .and_then(|n| n.checked_add(min))
                .unwrap_or(usize::MAX),
        };
        if len < needed {
            return Err(V4l2FormatError::BufferSize {
                fourcc: self.name(),
                len,
                needed,
                width,
                height,
                bytes_per_line: bpl,
            });
        }
        Ok(())
    }
}

/// Unpack one row of `width` pixels from `src` (at least `min_bytes_per_line` long) into `dst`.
/// Returns the first out-of-range (x, value) for unpacked formats.
fn unpack_row(fmt: &BayerFormat, src: &[u8], dst: &mut [u16]) -> Option<(usize, u16)> {
    match fmt.packing {
        Packing::U8 => {
            for (d, &s) in dst.iter_mut().zip(src) {
                *d = s as u16;
            }
            None
        }
        Packing::U16Le => {
            let max = fmt.max_value();
            let mut bad = None;
            for (x, (d, s)) in dst.iter_mut().zip(src.chunks_exact(2)).enumerate() {
                *d = u16::from_le_bytes([s[0], s[1]]);
                if *d > max && bad.is_none() {
                    bad = Some((x, *d));
                }
            }
            bad
        }
        Packing::Mipi10 => {
            for (g, out) in dst.chunks_mut(4).enumerate() {
                let b = &src[g * 5..g * 5 + 5];
                for (i, d) in out.iter_mut().enumerate() {
                    *d = (b[i] as u16) << 2 | ((b[4] >> (2 * i)) & 0x3) as u16;
                }
            }
            None
        }
        Packing::Mipi12 => {
            for (g, out) in dst.chunks_mut(2).enumerate() {
                let b = &src[g * 3..g * 3 + 3];
                for (i, d) in out.iter_mut().enumerate() {
                    *d = (b[i] as u16) << 4 | ((b[2] >> (4 * i)) & 0xF) as u16;
                }
            }
            None
        }
    }
}

/// Unpack a driver buffer into `dst` (`width * height` u16 values, row-major, contiguous).
/// Rows are unpacked in parallel strips of `STRIP_ROWS` on the current rayon pool.
pub fn unpack_into(
    fmt: &BayerFormat,
    buf: &[u8],
    width: usize,
    height: usize,
    bytes_per_line: usize,
    dst: &mut [u16],
) -> Result<(), V4l2FormatError> {
    fmt.check(buf.len(), width, height, bytes_per_line)?;
    // Within the frame-size limit (checked above) width * height cannot overflow.
    if dst.len() != width * height {
        return Err(V4l2FormatError::Frame(RawError::BufferSize {
            len: dst.len(),
            needed: width * height,
            width,
            height,
            stride: width,
        }));
    }
    if width == 0 || height == 0 {
        return Ok(());
    }
    let min = fmt.min_bytes_per_line(width);
    let bad = dst
        .par_chunks_mut(width * STRIP_ROWS)
        .enumerate()
        .filter_map(|(strip, rows)| {
            let mut first = None;
            for (r, out) in rows.chunks_mut(width).enumerate() {
                let y = strip * STRIP_ROWS + r;
                let src = &buf[y * bytes_per_line..y * bytes_per_line + min];
                if let Some((x, v)) = unpack_row(fmt, src, out) {
                    first.get_or_insert((x, y, v));
                }
            }
            first
        })
        .min_by_key(|&(x, y, _)| (y, x));
    if let Some((x, y, value)) = bad {
        return Err(V4l2FormatError::ValueOutOfRange {
            fourcc: fmt.name(),
            value,
            x,
            y,
            bit_depth: fmt.bit_depth,
        });
    }
    Ok(())
}

/// Serial reference of [`unpack_into`] (the test oracle for the parallel path; the `v4l2_unpack`
/// fuzz target compares the two).
pub fn unpack_into_serial(
    fmt: &BayerFormat,
    buf: &[u8],
    width: usize,
    height: usize,
    bytes_per_line: usize,
    dst: &mut [u16],
) -> Result<(), V4l2FormatError> {
    fmt.check(buf.len(), width, height, bytes_per_line)?;
    let min = fmt.min_bytes_per_line(width);
    for (y, out) in dst.chunks_mut(width.max(1)).take(height).enumerate() {
        if let Some((x, value)) = unpack_row(fmt, &buf[y * bytes_per_line..y * bytes_per_line + min], out) {
            return Err(V4l2FormatError::ValueOutOfRange {
                fourcc: fmt.name(),
                value,
                x,
                y,
                bit_depth: fmt.bit_depth,
            });
        }
    }
    Ok(())
}

/// Unpack a driver buffer into a new contiguous [`RawFrame`] (u8 container for 8-bit formats,
/// u16 otherwise). `levels` defaults to black 0 and white = the bit depth's maximum.
pub fn raw_frame_from_v4l2(
    fmt: &BayerFormat,
    buf: &[u8],
    width: usize,
    height: usize,
    bytes_per_line: usize,
    levels: Option<Levels>,
) -> Result<RawFrame, V4l2FormatError> {
    let levels = levels.unwrap_or(Levels::uniform(0, fmt.max_value()));
    // Geometry first (frame-size limit, checked sizes): nothing is allocated for a bad one.
    fmt.check(buf.len(), width, height, bytes_per_line)?;
    if fmt.packing == Packing::U8 {
        let mut px = Vec::with_capacity(width * height);
        for y in 0..height {
            px.extend_from_slice(&buf[y * bytes_per_line..y * bytes_per_line + width]);
        }
        return Ok(RawFrame::new(
            width,
            height,
            width,
            RawPixels::U8(px),
            fmt.cfa,
            8,
            levels,
        )?);
    }
    let mut px = vec![0u16; width * height];
    unpack_into(fmt, buf, width, height, bytes_per_line, &mut px)?;
    Ok(RawFrame::new(
        width,
        height,
        width,
        RawPixels::U16(px),
        fmt.cfa,
        fmt.bit_depth,
        levels,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_fourcc_maps_to_its_physical_pattern() {
        let want = [Cfa::Bggr, Cfa::Gbrg, Cfa::Grbg, Cfa::Rggb];
        let depths = [8, 10, 12, 14, 16, 10];
        for (row, chunk) in SUPPORTED.chunks(4).enumerate() {
            for (i, f) in chunk.iter().enumerate() {
                let fmt = bayer_format(*f).unwrap();
                assert_eq!(fmt.cfa, want[i], "{}", fourcc_str(*f));
                assert_eq!(fmt.bit_depth, depths[row], "{}", fourcc_str(*f));
            }
        }
        for (i, f) in SUPPORTED_PACKED12.iter().enumerate() {
            let fmt = bayer_format(*f).unwrap();
            assert_eq!(
                (fmt.cfa, fmt.bit_depth, fmt.packing),
                (want[i], 12, Packing::Mipi12)
            );
        }
        // Physical naming: RGGB is red at (0,0); OpenCV would call the same sensor BayerBG.
        assert_eq!(bayer_format(*b"RGGB").unwrap().cfa.opencv_code_name(), "BayerBG");
    }

    #[test]
    fn unknown_fourcc_is_a_clear_error() {
        let e = bayer_format(*b"YUYV").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("YUYV") && msg.contains("pRAA") && msg.contains("BA81"),
            "{msg}"
        );
        let e = bayer_format([0, 1, 2, 3]).unwrap_err();
        assert!(e.to_string().contains("????"));
    }

    /// Kernel doc example for SBGGR10P, row 0: B00 G01 B02 G03 high bytes, then
    /// G03low(7..6) B02low(5..4) G01low(3..2) B00low(1..0).
    #[test]
    fn mipi10_matches_kernel_layout_with_stride_padding_and_partial_group() {
        let fmt = bayer_format(*b"pBAA").unwrap();
        // Row 0: values 0x3FF, 0x000, 0x2AA, 0x155, then 0x001, 0x3FE (partial group of 2).
        // Row 1: 0x100 0x0FF 0x004 0x203 | 0x3FF 0x000.
        let row0 = [
            0xFF,
            0x00,
            0xAA,
            0x55,
            0b01_10_00_11, // 0x155 low 01, 0x2AA low 10, 0x000 low 00, 0x3FF low 11
            0x00,
            0xFF,
            0x00,
            0x00,
            0b00_00_10_01, // 0x001 -> hi 0x00 lo 01; 0x3FE -> hi 0xFF lo 10
        ];
        let row1 = [
            0x40,
            0x3F,
            0x01,
            0x80,
            0b11_00_11_00, // 0x100: 40/00, 0x0FF: 3F/11, 0x004: 01/00, 0x203: 80/11
            0xFF,
            0x00,
            0x00,
            0x00,
            0b00_00_00_11,
        ];
        let bpl = 12; // 10 bytes of pixels + 2 padding
        let mut buf = Vec::new();
        buf.extend_from_slice(&row0);
        buf.extend_from_slice(&[0xEE, 0xEE]);
        buf.extend_from_slice(&row1);
        let f = raw_frame_from_v4l2(&fmt, &buf, 6, 2, bpl, None).unwrap();
        assert_eq!(
            f.to_u16_vec(),
            vec![0x3FF, 0x000, 0x2AA, 0x155, 0x001, 0x3FE, 0x100, 0x0FF, 0x004, 0x203, 0x3FF, 0x000]
        );
        assert_eq!((f.cfa(), f.bit_depth(), f.levels().white), (Cfa::Bggr, 10, 1023));
    }

    /// Kernel doc example for SBGGR12P: B00high G01high, G01low(7..4) B00low(3..0).
    #[test]
    fn mipi12_matches_kernel_layout_with_odd_width() {
        let fmt = bayer_format(*b"pRCC").unwrap();
        // Width 3 (odd): groups (0xABC, 0x123), (0xFFF, pad).
        let bpl = 8; // 6 bytes + 2 padding
        let row = [0xAB, 0x12, 0x3C, 0xFF, 0x00, 0x0F, 0x77, 0x77];
        let row1 = [0x00, 0x80, 0x0F, 0x01, 0x00, 0x01];
        let mut buf = row.to_vec();
        buf.extend_from_slice(&row1);
        let f = raw_frame_from_v4l2(&fmt, &buf, 3, 2, bpl, None).unwrap();
        assert_eq!(f.to_u16_vec(), vec![0xABC, 0x123, 0xFFF, 0x00F, 0x800, 0x011]);
        assert_eq!(f.cfa(), Cfa::Rggb);
    }

    /// SRGGB10: "each sample stored in a 16-bit word, little-endian, 6 high bits zero".
    #[test]
    fn unpacked16_little_endian_with_stride_and_range_check() {
        let fmt = bayer_format(*b"BA10").unwrap();
        // Width 3, bpl 8 (2 bytes padding), 2 rows.
        let buf = [
            0xFF, 0x03, 0x01, 0x00, 0x00, 0x02, 0xAA, 0xAA, //
            0x34, 0x01, 0x00, 0x00, 0x10, 0x00,
        ];
        let f = raw_frame_from_v4l2(&fmt, &buf, 3, 2, 8, None).unwrap();
        assert_eq!(f.to_u16_vec(), vec![0x3FF, 0x001, 0x200, 0x134, 0, 0x10]);
        assert_eq!(f.cfa(), Cfa::Grbg);
        let mut bad = buf;
        bad[11] = 0x04; // pixel (1,1) = 0x0400 > 1023
        let e = raw_frame_from_v4l2(&fmt, &bad, 3, 2, 8, None).unwrap_err();
        assert!(
            matches!(
                e,
                V4l2FormatError::ValueOutOfRange {
                    value: 0x400,
                    x: 1,
                    y: 1,
                    ..
                }
            ),
            "{e}"
        );
        // 16-bit formats take the full range.
        let fmt = bayer_format(*b"BYR2").unwrap();
        let f = raw_frame_from_v4l2(&fmt, &[0xFF, 0xFF], 1, 1, 2, None).unwrap();
        assert_eq!(f.value(0, 0), 0xFFFF);
    }

    #[test]
    fn eight_bit_with_stride_keeps_u8_container() {
        let fmt = bayer_format(*b"GRBG").unwrap();
        let buf = [1, 2, 3, 0, 4, 5, 6];
        let f = raw_frame_from_v4l2(&fmt, &buf, 3, 2, 4, Some(Levels::uniform(1, 255))).unwrap();
        assert!(matches!(f.pixels(), RawPixels::U8(_)));
        assert_eq!(f.to_u16_vec(), vec![1, 2, 3, 4, 5, 6]);
        assert_eq!(f.levels().black, [1; 4]);
    }

    #[test]
    fn short_stride_and_short_buffer_are_errors() {
        let fmt = bayer_format(*b"pRAA").unwrap();
        let e = raw_frame_from_v4l2(&fmt, &[0; 100], 6, 2, 8, None).unwrap_err();
        assert!(matches!(e, V4l2FormatError::Stride { min: 10, .. }), "{e}");
        let e = raw_frame_from_v4l2(&fmt, &[0; 19], 6, 2, 10, None).unwrap_err();
        assert!(matches!(e, V4l2FormatError::BufferSize { needed: 20, .. }), "{e}");
        // The last row needs no padding.
        assert!(raw_frame_from_v4l2(&fmt, &[0; 22], 6, 2, 12, None).is_ok());
        let e = raw_frame_from_v4l2(&fmt, &[], 0, 0, 0, None).unwrap_err();
        assert!(matches!(e, V4l2FormatError::Frame(_)), "{e}");
    }

    /// Sizes from a driver that would overflow `bytesperline * (height - 1) + min` or
    /// `width * height` are errors, not wrapped lengths (or overflow panics).
    #[test]
    fn absurd_driver_sizes_are_errors_not_overflows() {
        let fmt = bayer_format(*b"pRAA").unwrap();
        let e = raw_frame_from_v4l2(&fmt, &[0; 64], 16, 4, usize::MAX / 2, None).unwrap_err();
        assert!(
            matches!(
                e,
                V4l2FormatError::BufferSize {
                    needed: usize::MAX,
                    ..
                }
            ),
            "{e}"
        );
        for (w, h) in [(usize::MAX / 2, 3), (20_000, 2), (8192, 8193)] {
            let e = raw_frame_from_v4l2(&fmt, &[0; 64], w, h, usize::MAX, None).unwrap_err();
            assert!(matches!(e, V4l2FormatError::TooLarge { .. }), "{w}x{h}: {e}");
            let mut dst = [0u16; 4];
            let e = unpack_into_serial(&fmt, &[0; 64], w, h, 8, &mut dst).unwrap_err();
            assert!(matches!(e, V4l2FormatError::TooLarge { .. }), "{w}x{h}: {e}");
        }
        assert_eq!(fmt.min_bytes_per_line(usize::MAX), usize::MAX);
    }

    #[test]
    fn parallel_equals_serial() {
        for f in [*b"RG12", *b"pgAA", *b"pGCC", *b"RG16"] {
            let fmt = bayer_format(f).unwrap();
            let (w, h) = (37, 200);
            let bpl = fmt.min_bytes_per_line(w) + 3;
            let mut state = 12345u32;
            let mut buf: Vec<u8> = (0..bpl * h)
                .map(|_| {
                    state = state.wrapping_mul(1664525).wrapping_add(1013904223);
                    (state >> 24) as u8
                })
                .collect();
            if fmt.packing == Packing::U16Le && fmt.bit_depth < 16 {
                let min = fmt.min_bytes_per_line(w);
                for y in 0..h {
                    for px in buf[y * bpl..y * bpl + min].chunks_exact_mut(2) {
                        px[1] &= (fmt.max_value() >> 8) as u8;
                    }
                }
            }
            let mut a = vec![0u16; w * h];
            let mut b = vec![0u16; w * h];
            unpack_into(&fmt, &buf, w, h, bpl, &mut a).unwrap();
            unpack_into_serial(&fmt, &buf, w, h, bpl, &mut b).unwrap();
            assert_eq!(a, b, "{}", fourcc_str(f));
        }
    }
}
