//! Peak memory of refusing hostile files: each is refused before its pixels are read, so the
//! process's peak resident set grows by far less than the file claims. One test in its own binary,
//! so that no other test's allocations move the peak (Linux: `VmHWM` from `/proc/self/status`,
//! reset through `/proc/self/clear_refs`).

use std::path::Path;

use mosaicd::capture::{CaptureError, McapSource, McapSourceOptions, RecordPastEnd, Source};
use mosaicd::raw::{load_camera_raw, load_headerless, Container, Endian, RawFormat};
use mosaicd::raw::{Cfa, Levels, RawError};

/// Peak resident set size so far, KiB.
fn peak_kib() -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = s.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// Peak growth (MiB) while `f` runs, after resetting the peak to the current resident set.
fn peak_growth_mib<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
    let before = peak_kib();
    let out = f();
    let after = peak_kib();
    assert!(reset || after >= before);
    (out, after.saturating_sub(before) / 1024)
}

/// A sparse file of `len` bytes (no disk blocks; reading it would still allocate `len`).
fn sparse(path: &Path, len: u64) {
    std::fs::File::create(path).unwrap().set_len(len).unwrap();
}

#[test]
fn hostile_files_are_refused_without_reading_them() {
    let dir = tempfile::tempdir().unwrap();
    // The review's case: a 1 GiB file with a 2x2 sidecar cost 1.06 GB before its size was
    // compared. Now the size is compared from `stat`.
    let big = dir.path().join("big.raw");
    sparse(&big, 1 << 30);
    let fmt = RawFormat::new(
        2,
        2,
        8,
        Cfa::Rggb,
        Container::U8,
        Endian::Little,
        Levels::uniform(0, 255),
    );
    let (r, grew) = peak_growth_mib(|| load_headerless(&big, &fmt));
    assert!(
        matches!(r, Err(RawError::SizeMismatch { actual, .. }) if actual == 1 << 30),
        "{r:?}"
    );
    assert!(grew < 64, "headerless: peak grew {grew} MiB");
    // A camera raw file larger than any frame within the limit can be, refused from `stat`.
    let nef = dir.path().join("big.nef");
    sparse(&nef, 1 << 30);
    let (r, grew) = peak_growth_mib(|| load_camera_raw(&nef));
    assert!(matches!(r, Err(RawError::FileTooLarge { .. })), "{r:?}");
    assert!(grew < 64, "camera raw: peak grew {grew} MiB");
    // docs/fuzzing.md, finding 5: the mcap reader zero-fills a buffer of the length a record
    // declares. The committed seed is 33 bytes: the magic and a Schema record declaring
    // 100,000,000 bytes, of which 16 are there (within the record-length limit, about 192 MiB).
    // Before the guard bounded records by the file, this cost a peak of about 95 MiB more; now the
    // replay stops before the record's header, reported as a truncation naming it.
    let seed = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/mcap_source/record-past-end.mcap");
    let (r, grew) = peak_growth_mib(|| {
        let mut src = McapSource::open(&seed, McapSourceOptions::default()).unwrap();
        src.next_frame()
    });
    assert!(grew < 16, "mcap record past the end: peak grew {grew} MiB");
    match r {
        Err(CaptureError::Truncated {
            frames: 0,
            source: mcap::McapError::Io(io),
            ..
        }) => {
            let p = io.get_ref().and_then(|e| e.downcast_ref::<RecordPastEnd>());
            assert_eq!(
                p,
                Some(&RecordPastEnd {
                    record: 8,
                    opcode: 0x03,
                    len: 100_000_000,
                    left: 16,
                    file_len: 33
                })
            );
        }
        other => panic!("{other:?}"),
    }
}
