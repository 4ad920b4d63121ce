//! Reading a whole file whose size is checked first, for every loader of files other people made
//! (raw frames, `.npy` arrays, model files): `stat`, refuse a file above the bound, then read at
//! most the bound (a file that grows between the two is refused the same way). Callers turn
//! [`ReadAtMostError`] into their own error type.

use std::io::Read;
use std::path::Path;

/// Why [`read_at_most`] read nothing.
#[derive(Debug)]
pub(crate) enum ReadAtMostError {
    /// Opening, `stat` or reading failed.
    Io(std::io::Error),
    /// The file holds `size` bytes (at least), more than the bound.
    TooLarge {
        /// Bytes found (the `stat` size, or what was read of a file that grew).
        size: u64,
    },
}

/// The bytes of the file at `path` if it holds at most `max` bytes.
pub(crate) fn read_at_most(path: &Path, max: u64) -> Result<Vec<u8>, ReadAtMostError> {
    let file = std::fs::File::open(path).map_err(ReadAtMostError::Io)?;
    let size = file.metadata().map_err(ReadAtMostError::Io)?.len();
    if size > max {
        return Err(ReadAtMostError::TooLarge { size });
    }
    let mut bytes = Vec::with_capacity(size as usize);
    file.take(max.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(ReadAtMostError::Io)?;
    if bytes.len() as u64 > max {
        return Err(ReadAtMostError::TooLarge {
            size: bytes.len() as u64,
        });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_above_the_bound_and_reads_up_to_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f");
        std::fs::write(&p, [7u8; 10]).unwrap();
        assert_eq!(read_at_most(&p, 10).unwrap(), vec![7u8; 10]);
        assert!(matches!(
            read_at_most(&p, 9),
            Err(ReadAtMostError::TooLarge { size: 10 })
        ));
        assert!(matches!(
            read_at_most(&dir.path().join("missing"), 10),
            Err(ReadAtMostError::Io(_))
        ));
    }
}
