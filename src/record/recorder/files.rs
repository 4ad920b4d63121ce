//! Recording files: the numbered names of a rotating recording, the files already there, and the wall-clock metadata record.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::clock::WallClock;
use crate::wire::RecordError;

/// Name of the metadata record that ties a live recording's `CLOCK_MONOTONIC` times to the wall
/// clock. Keys: `timestamps` (`CLOCK_MONOTONIC`: what log times, publish times and the frames'
/// timestamps count), `realtime_minus_monotonic_ns` (add it to any of them for ns since the Unix
/// epoch, UTC), `realtime_ns` and `monotonic_ns` (the reading it comes from, taken when the file was
/// opened) and `realtime_utc` (the same instant, RFC 3339).
pub const WALL_CLOCK_METADATA: &str = "mosaicd.clock";

/// The [`WALL_CLOCK_METADATA`] record of a reading.
pub(crate) fn wall_clock_metadata(w: &WallClock) -> mcap::records::Metadata {
    let metadata = BTreeMap::from([
        ("timestamps".to_string(), "CLOCK_MONOTONIC".to_string()),
        (
            "realtime_minus_monotonic_ns".to_string(),
            w.offset_ns().to_string(),
        ),
        ("realtime_ns".to_string(), w.realtime_ns.to_string()),
        ("monotonic_ns".to_string(), w.monotonic_ns.to_string()),
        ("realtime_utc".to_string(), rfc3339_utc(w.realtime_ns)),
    ]);
    mcap::records::Metadata {
        name: WALL_CLOCK_METADATA.to_string(),
        metadata,
    }
}

/// `ns` since the Unix epoch as RFC 3339 UTC with nanoseconds (`2026-11-27T06:50:00.000000000Z`),
/// by the days-to-civil conversion of the proleptic Gregorian calendar (H. Hinnant, "chrono-
/// Compatible Low-Level Date Algorithms").
pub(super) fn rfc3339_utc(ns: u64) -> String {
    let (secs, nanos) = (ns / 1_000_000_000, ns % 1_000_000_000);
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1_460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{nanos:09}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// `base`'s file name with a file number: `stem-NNNN.ext` (the rotation naming).
pub(super) fn numbered_path(base: &Path, n: u32) -> PathBuf {
    let (stem, ext) = stem_ext(base);
    base.with_file_name(format!("{stem}-{n:04}.{ext}"))
}

pub(super) fn stem_ext(base: &Path) -> (String, String) {
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = base
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mcap".into());
    (stem, ext)
}

/// The numbered files of `base` in its directory (`stem-` + four to six digits + `.ext`, so a dated
/// `stem-20240101.ext` is not taken for one), lowest number first.
pub(super) fn numbered_files(base: &Path) -> Result<Vec<(u32, PathBuf)>, RecordError> {
    let (stem, ext) = stem_ext(base);
    let dir = base
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let entries = std::fs::read_dir(dir).map_err(|source| RecordError::Create {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut v: Vec<(u32, PathBuf)> = entries
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            let digits = name
                .strip_prefix(&stem)?
                .strip_prefix('-')?
                .strip_suffix(&ext)?
                .strip_suffix('.')?;
            if !(4..=6).contains(&digits.len()) || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            Some((digits.parse().ok()?, base.with_file_name(&name)))
        })
        .collect();
    v.sort();
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339_of_known_instants() {
        assert_eq!(rfc3339_utc(0), "1970-01-01T00:00:00.000000000Z");
        // 2000-02-29 (a leap day of a century leap year) 12:34:56.789
        assert_eq!(
            rfc3339_utc(951_827_696_789_000_000),
            "2000-02-29T12:34:56.789000000Z"
        );
        assert_eq!(
            rfc3339_utc(1_795_737_600_000_000_001),
            "2026-11-27T00:00:00.000000001Z"
        );
    }
}
