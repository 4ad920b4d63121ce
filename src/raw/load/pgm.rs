//! Binary PGM (`P5`) mosaics (Netpbm: 16-bit samples are big-endian).

use std::path::Path;

use super::common::{bits_for, format_err, mosaic_frame, read_at_most, too_large, MosaicFormat};
use crate::raw::{FrameLimits, RawError, RawFrame, RawPixels};

/// Room for a PGM's header and comments on top of its samples, bytes.
pub(super) const MAX_PGM_HEADER_BYTES: u64 = 1 << 20;

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
    FrameLimits::process()
        .check_usize(w, h)
        .map_err(|l| too_large(origin, l))?;
    let bpp: usize = if maxval > 255 { 2 } else { 1 };
    let data = &bytes[pos..];
    // Within the limit nothing below can overflow; checked all the same (the sizes come from the
    // file), so that a change of limit cannot make them wrap.
    let row = w.checked_mul(bpp);
    let expected = row.and_then(|r| r.checked_mul(h));
    let Some((row, expected)) = row.zip(expected) else {
        return Err(bad("width x height overflows"));
    };
    if data.len() < expected {
        return Err(RawError::SizeMismatch {
            path: origin.to_path_buf(),
            expected: (expected as u64).saturating_add(pos as u64),
            actual: bytes.len() as u64,
            width: w,
            height: h,
            bytes_per_pixel: bpp,
            stride_bytes: row,
        });
    }
    let data = &data[..expected];
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
///
/// The file is `stat`ed first: one larger than the largest frame within the frame-size limit
/// plus [`MAX_PGM_HEADER_BYTES`] is refused before it is read.
pub(crate) fn load_pgm_mosaic(path: &Path, fmt: &MosaicFormat) -> Result<RawFrame, RawError> {
    let max = FrameLimits::process()
        .max_sample_bytes()
        .saturating_add(MAX_PGM_HEADER_BYTES);
    let bytes = read_at_most(path, max, "a PGM")?;
    pgm_mosaic_from_bytes(&bytes, fmt, path)
}

/// A binary PGM (`P5`) mosaic from bytes already in memory: what [`load_pgm_mosaic`] does after
/// its read (it calls this). `origin` names the source in errors and in the frame's metadata.
pub(crate) fn pgm_mosaic_from_bytes(
    bytes: &[u8],
    fmt: &MosaicFormat,
    origin: &Path,
) -> Result<RawFrame, RawError> {
    let (w, h, maxval, pixels) = pgm_from_bytes(bytes, origin)?;
    mosaic_frame(w, h, pixels, bits_for(maxval as u32), fmt, origin)
}

/// Write a frame as a binary PGM (`P5`) with maxval `2^bit_depth - 1` (big-endian 16-bit samples
/// when the bit depth exceeds 8).
#[cfg(test)]
pub(super) fn write_pgm(frame: &RawFrame, path: &Path) -> Result<(), RawError> {
    let maxval = frame.max_value();
    let mut out = format!("P5\n{} {}\n{}\n", frame.width(), frame.height(), maxval).into_bytes();
    for v in frame.to_u16_vec() {
        if maxval > 255 {
            out.extend_from_slice(&v.to_be_bytes());
        } else {
            out.push(v as u8);
        }
    }
    std::fs::write(path, out).map_err(|e| super::common::io_err(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raw::load::memory_origin;
    use crate::raw::{Cfa, Levels};
    use std::path::PathBuf;

    fn origin() -> PathBuf {
        memory_origin()
    }

    /// The 33 fuzz crashes of the review ("attempt to multiply with overflow" in `w * h * bpp`):
    /// sizes whose product overflows, or that merely exceed the frame-size limit, are refused from
    /// the header.
    #[test]
    fn pgm_sizes_that_overflow_or_exceed_the_limit_are_refused() {
        for header in [
            &b"P5\n18446744073709551615 18446744073709551615\n65535\n\x00\x00"[..],
            b"P5\n4294967296 4294967296\n255\n\x00",
            b"P5\n9223372036854775807 3\n255\n\x00",
            b"P5\n16000 15000\n255\n\x00",
            b"P5\n16385 1\n255\n\x00",
        ] {
            match pgm_from_bytes(header, &origin()) {
                Err(RawError::TooLarge { .. }) => {}
                other => panic!("{:?}: {other:?}", String::from_utf8_lossy(header)),
            }
        }
        // A number that does not fit usize is a header error.
        assert!(matches!(
            pgm_from_bytes(b"P5\n99999999999999999999999 1\n255\n\x00", &origin()),
            Err(RawError::Format { .. })
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
}
