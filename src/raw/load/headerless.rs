//! Headerless raw files: [`RawFormat`] describes one (size, bit depth, pattern, container, byte
//! order, row stride, levels), [`frame_from_bytes`] turns bytes into a frame, [`load_headerless`]
//! reads a file.

use std::path::Path;

use super::common::{
    check_range, format_err, io_err, levels_from, meta_for, need_cfa, read_at_most, too_large, Container,
    Endian, InputOptions,
};
use crate::raw::{Cfa, FrameLimits, Levels, RawError, RawFrame, RawPixels};

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

/// The checked layout of `fmt`: (bytes per pixel, bytes of pixels in a row, stride in bytes).
/// Refuses empty frames, frames above the frame-size limit, strides shorter than a row or not a
/// whole number of samples, and a file size (`height * stride`) above twice the largest frame.
fn layout(fmt: &RawFormat, origin: &Path) -> Result<(usize, usize, usize), RawError> {
    let (w, h) = (fmt.width, fmt.height);
    if w == 0 || h == 0 {
        return Err(RawError::EmptyFrame { width: w, height: h });
    }
    let limits = FrameLimits::process();
    limits.check_usize(w, h).map_err(|l| too_large(origin, l))?;
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
    let max_file = limits.max_sample_bytes().saturating_mul(2);
    if fmt.expected_len() > max_file {
        return Err(format_err(
            origin,
            format!(
                "{h} rows of stride {stride} bytes make {} bytes, more than twice the largest frame \
                 within the frame-size limit ({max_file} bytes)",
                fmt.expected_len()
            ),
        ));
    }
    Ok((bpp, row_bytes, stride))
}

fn size_mismatch(fmt: &RawFormat, origin: &Path, actual: u64) -> RawError {
    RawError::SizeMismatch {
        path: origin.to_path_buf(),
        expected: fmt.expected_len(),
        actual,
        width: fmt.width,
        height: fmt.height,
        bytes_per_pixel: fmt.container.bytes(),
        stride_bytes: fmt.stride(),
    }
}

/// Build a frame from the bytes of a headerless file. `origin` names the source in errors and in
/// the frame's metadata.
pub fn frame_from_bytes(bytes: &[u8], fmt: &RawFormat, origin: &Path) -> Result<RawFrame, RawError> {
    let (w, h) = (fmt.width, fmt.height);
    let (_, row_bytes, stride) = layout(fmt, origin)?;
    if bytes.len() as u64 != fmt.expected_len() {
        return Err(size_mismatch(fmt, origin, bytes.len() as u64));
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
///
/// The format is checked and the file `stat`ed first: a file whose size is not `height * stride`
/// is [`RawError::SizeMismatch`] before any byte of it is read.
pub fn load_headerless(path: &Path, fmt: &RawFormat) -> Result<RawFrame, RawError> {
    layout(fmt, path)?;
    let size = std::fs::metadata(path).map_err(|e| io_err(path, e))?.len();
    if size != fmt.expected_len() {
        return Err(size_mismatch(fmt, path, size));
    }
    let bytes = read_at_most(path, fmt.expected_len(), "a headerless file of this format")?;
    frame_from_bytes(&bytes, fmt, path)
}

/// The headerless format described by `opts` for the file at `path`.
pub(crate) fn headerless_format(path: &Path, opts: &InputOptions) -> Result<RawFormat, RawError> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::load::memory_origin;
    use crate::raw::Cfa;
    use std::path::PathBuf;

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
        assert!(matches!(e, RawError::TooLarge { .. }), "{e}");
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
            Err(RawError::TooLarge { .. })
        ));
        // Within the frame-size limit, a stride that makes the file absurdly large is refused.
        let mut wide = RawFormat::new(2, 2, 12, Cfa::Rggb, Container::U16, Endian::Little, levels);
        wide.stride_bytes = Some(usize::MAX / 2 - 1);
        let e = frame_from_bytes(&[0; 8], &wide, Path::new("wide.raw")).unwrap_err();
        assert!(e.to_string().contains("twice the largest frame"), "{e}");
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
}
