//! A minimal reader and writer for NumPy `.npy` files (format versions 1–3, C order,
//! little-endian numeric types). Used for OpenCV's detector weights and for the oracle fixtures
//! that `tests/oracle/` generates.
//!
//! ```
//! let a = mosaicd::npy::NpyArray { shape: vec![2, 2], data: vec![1.0, 2.0, 3.0, 4.0] };
//! let bytes = a.to_f32_bytes();
//! let b = mosaicd::npy::NpyArray::parse(&bytes, "mem").unwrap();
//! assert_eq!(b.shape, vec![2, 2]);
//! assert_eq!(b.data, vec![1.0, 2.0, 3.0, 4.0]);
//! ```

use std::path::{Path, PathBuf};

/// Largest `.npy` file [`NpyArray::read`] reads (values are widened to 8 bytes each in memory).
pub const MAX_FILE_BYTES: u64 = 256 << 20;

/// Errors reading `.npy` files.
#[derive(Debug, thiserror::Error)]
pub enum NpyError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// File.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The file is larger than [`MAX_FILE_BYTES`].
    #[error("{path}: file is {size} bytes, more than the {max} bytes a .npy file may have here")]
    TooLarge {
        /// File.
        path: PathBuf,
        /// Its size.
        size: u64,
        /// Largest size accepted.
        max: u64,
    },
    /// The header is malformed or describes something unsupported.
    #[error("{origin}: not a supported .npy file: {what}")]
    Format {
        /// File or label.
        origin: String,
        /// What is wrong.
        what: String,
    },
    /// The data is shorter than the header says.
    #[error("{origin}: truncated: header promises {expected} bytes of data, file has {actual}")]
    Truncated {
        /// File or label.
        origin: String,
        /// Bytes expected.
        expected: usize,
        /// Bytes present.
        actual: usize,
    },
}

/// An n-dimensional array, values widened to `f64`, C order.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyArray {
    /// Dimensions.
    pub shape: Vec<usize>,
    /// Values in C (row-major) order.
    pub data: Vec<f64>,
}

impl NpyArray {
    /// Read a file of at most [`MAX_FILE_BYTES`] (checked with `stat` before reading).
    pub fn read(path: impl AsRef<Path>) -> Result<Self, NpyError> {
        use crate::bounded_read::{read_at_most, ReadAtMostError};
        let path = path.as_ref();
        let bytes = read_at_most(path, MAX_FILE_BYTES).map_err(|e| match e {
            ReadAtMostError::Io(source) => NpyError::Io {
                path: path.to_path_buf(),
                source,
            },
            ReadAtMostError::TooLarge { size } => NpyError::TooLarge {
                path: path.to_path_buf(),
                size,
                max: MAX_FILE_BYTES,
            },
        })?;
        Self::parse(&bytes, &path.display().to_string())
    }

    /// Parse bytes; `origin` names them in errors.
    pub fn parse(bytes: &[u8], origin: &str) -> Result<Self, NpyError> {
        let fmt = |what: String| NpyError::Format {
            origin: origin.to_string(),
            what,
        };
        if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
            return Err(fmt("missing \\x93NUMPY magic".into()));
        }
        let major = bytes[6];
        let (hlen, hstart): (usize, usize) = match major {
            1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
            2 | 3 => {
                if bytes.len() < 12 {
                    return Err(fmt("header length cut off".into()));
                }
                (
                    u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
                    12,
                )
            }
            v => return Err(fmt(format!("format version {v} not supported"))),
        };
        let hend = hstart.saturating_add(hlen);
        if bytes.len() < hend {
            return Err(fmt("header cut off".into()));
        }
        let header =
            std::str::from_utf8(&bytes[hstart..hend]).map_err(|_| fmt("header is not text".into()))?;
        let descr = dict_value(header, "descr").ok_or_else(|| fmt("no descr".into()))?;
        let descr = descr.trim().trim_matches(|c| c == '\'' || c == '"');
        let fortran = dict_value(header, "fortran_order").ok_or_else(|| fmt("no fortran_order".into()))?;
        if fortran.trim().starts_with("True") {
            return Err(fmt("Fortran order not supported".into()));
        }
        let shape_s = dict_value(header, "shape").ok_or_else(|| fmt("no shape".into()))?;
        let shape: Vec<usize> = shape_s
            .trim()
            .trim_start_matches('(')
            .trim_end_matches(')')
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|s| {
                s.parse::<usize>()
                    .map_err(|_| fmt(format!("bad shape {shape_s}")))
            })
            .collect::<Result<_, _>>()?;
        // The shape comes from the file: its product is computed checked, so that a shape such as
        // (2**62 + 3781,) with 4-byte values cannot wrap into a small size that passes the length
        // check below.
        let n = shape
            .iter()
            .try_fold(1usize, |n, &d| n.checked_mul(d))
            .ok_or_else(|| fmt(format!("shape {shape_s} has more elements than fit in memory")))?;
        let (size, conv): (usize, fn(&[u8]) -> f64) = match descr {
            "<f4" => (4, |b| f32::from_le_bytes(b.try_into().unwrap()) as f64),
            "<f8" => (8, |b| f64::from_le_bytes(b.try_into().unwrap())),
            "|u1" | "<u1" => (1, |b| b[0] as f64),
            "|i1" | "<i1" => (1, |b| b[0] as i8 as f64),
            "<u2" => (2, |b| u16::from_le_bytes(b.try_into().unwrap()) as f64),
            "<i2" => (2, |b| i16::from_le_bytes(b.try_into().unwrap()) as f64),
            "<u4" => (4, |b| u32::from_le_bytes(b.try_into().unwrap()) as f64),
            "<i4" => (4, |b| i32::from_le_bytes(b.try_into().unwrap()) as f64),
            "<i8" => (8, |b| i64::from_le_bytes(b.try_into().unwrap()) as f64),
            "<u8" => (8, |b| u64::from_le_bytes(b.try_into().unwrap()) as f64),
            "|b1" => (1, |b| b[0] as f64),
            d => return Err(fmt(format!("dtype {d} not supported"))),
        };
        let body = &bytes[hend..];
        let Some(len) = n.checked_mul(size) else {
            return Err(fmt(format!(
                "shape {shape_s} of {size}-byte values has more bytes than fit in memory"
            )));
        };
        if body.len() < len {
            return Err(NpyError::Truncated {
                origin: origin.to_string(),
                expected: len,
                actual: body.len(),
            });
        }
        let data = body[..len].chunks_exact(size).map(conv).collect();
        Ok(Self { shape, data })
    }

    /// Serialise as a version-1 `.npy` of little-endian `f32`.
    pub fn to_f32_bytes(&self) -> Vec<u8> {
        let shape = match self.shape.len() {
            1 => format!("({},)", self.shape[0]),
            _ => format!(
                "({})",
                self.shape
                    .iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape}, }}");
        // Pad so that data starts on a 64-byte boundary, header ends in '\n'.
        let total = 10 + header.len() + 1;
        header.push_str(&" ".repeat((64 - total % 64) % 64));
        header.push('\n');
        let mut out = Vec::with_capacity(10 + header.len() + self.data.len() * 4);
        out.extend_from_slice(b"\x93NUMPY\x01\x00");
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        for v in &self.data {
            out.extend_from_slice(&(*v as f32).to_le_bytes());
        }
        out
    }
}

/// Value text following `'key':` in a Python dict literal, up to the next top-level comma.
fn dict_value<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    let pat1 = format!("'{key}':");
    let pat2 = format!("\"{key}\":");
    let start = header
        .find(&pat1)
        .map(|i| i + pat1.len())
        .or_else(|| header.find(&pat2).map(|i| i + pat2.len()))?;
    let rest = &header[start..];
    let mut depth = 0i32;
    for (i, c) in rest.char_indices() {
        match c {
            '(' | '[' => depth += 1,
            ')' | ']' => depth -= 1,
            ',' | '}' if depth == 0 => return Some(&rest[..i]),
            _ => {}
        }
    }
    Some(rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_garbage_and_truncation() {
        assert!(matches!(
            NpyArray::parse(b"hello world", "x"),
            Err(NpyError::Format { .. })
        ));
        let a = NpyArray {
            shape: vec![3],
            data: vec![1.0, 2.0, 3.0],
        };
        let b = a.to_f32_bytes();
        assert!(matches!(
            NpyArray::parse(&b[..b.len() - 2], "x"),
            Err(NpyError::Truncated { .. })
        ));
        assert_eq!(NpyArray::parse(&b, "x").unwrap(), a);
    }

    /// A shape whose element count times the value size wraps (2^62 + 3781 four-byte values is
    /// 15124 bytes modulo 2^64) must be refused, not read as 3781 values.
    #[test]
    fn shapes_that_overflow_are_refused() {
        // (2^62 + 3781) * 4 bytes wraps to 3781 * 4 = 15124: before the check this read as a
        // valid 3781-element vector (OpenCV's detector length).
        let mut bytes = header_only(&format!("({},)", (1u64 << 62) + 3781));
        bytes.extend(std::iter::repeat_n(0u8, 3781 * 4));
        match NpyArray::parse(&bytes, "crafted") {
            Err(NpyError::Format { what, .. }) => assert!(what.contains("fit in memory"), "{what}"),
            other => panic!("{other:?}"),
        }
        // The element count alone overflowing.
        let e = NpyArray::parse(&header_only(&format!("({}, {})", 1u64 << 40, 1u64 << 40)), "x").unwrap_err();
        assert!(e.to_string().contains("fit in memory"), "{e}");
        // A sane shape in the same layout still reads.
        let mut ok = header_only("(3,)");
        ok.extend(1.5f32.to_le_bytes().repeat(3));
        assert_eq!(NpyArray::parse(&ok, "ok").unwrap().data, vec![1.5; 3]);
    }

    fn header_only(shape: &str) -> Vec<u8> {
        let header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape}, }}\n");
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        out
    }
}
