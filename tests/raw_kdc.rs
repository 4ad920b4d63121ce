//! The Kodak DC40/DC50 RADC decoder (`src/raw/kodak_radc.rs`) on the shared
//! `raw/rawpy_kodak_dc50/RAW_KODAK_DC50.KDC`:
//! - parity with LibRaw through rawpy (fixtures from tests/oracle/gen_raw_kdc.py; run `make oracle`
//!   first): every pixel equal, same pattern, levels and size;
//! - robustness: truncations at many points and flipped bytes never panic; truncations inside the
//!   compressed data are errors naming the byte offset.

mod common;

use common::{oracle, oracle_dir};
use mosaicd::data::require;
use mosaicd::raw::kodak_radc::{self, KodakModel, RadcError};
use mosaicd::raw::load_camera_raw;
use mosaicd::raw::{load_input, Cfa, InputOptions, RawError};

const KDC: &str = "raw/rawpy_kodak_dc50/RAW_KODAK_DC50.KDC";

#[test]
fn dc50_equals_libraw_through_rawpy() {
    let p = require(KDC);
    let frame = load_camera_raw(&p).unwrap();
    let want = oracle("raw/kdc_dc50_raw.npy");
    assert_eq!(want.shape, vec![frame.height(), frame.width()]);
    let got = frame.to_u16_vec();
    let mismatches: Vec<(usize, usize, u16, f64)> = got
        .iter()
        .zip(&want.data)
        .enumerate()
        .filter(|(_, (&g, &w))| g as f64 != w)
        .map(|(i, (&g, &w))| (i % frame.width(), i / frame.width(), g, w))
        .collect();
    assert!(
        mismatches.is_empty(),
        "{} of {} pixels differ from LibRaw, first (x, y, ours, libraw): {:?}",
        mismatches.len(),
        got.len(),
        &mismatches[..mismatches.len().min(8)]
    );

    let meta_path = oracle_dir().join("raw/kdc_dc50.json");
    let text = std::fs::read_to_string(&meta_path)
        .unwrap_or_else(|e| panic!("{}: {e}: run `make oracle` first", meta_path.display()));
    let meta: serde_json::Value = serde_json::from_str(&text).unwrap();
    let cfa: Cfa = meta["pattern"].as_str().unwrap().parse().unwrap();
    assert_eq!(frame.cfa(), cfa);
    let black = meta["black_level_per_channel"].as_array().unwrap();
    assert!(
        black
            .iter()
            .all(|b| b.as_u64() == Some(frame.levels().black[0] as u64)),
        "{black:?}"
    );
    assert_eq!(meta["white_level"].as_u64(), Some(frame.levels().white as u64));
    assert_eq!(frame.max_value() as u64, meta["white_level"].as_u64().unwrap());
    assert_eq!(meta["width"].as_u64(), Some(frame.width() as u64));
    assert_eq!(meta["height"].as_u64(), Some(frame.height() as u64));
}

#[test]
fn dc50_is_identified_by_its_header() {
    let bytes = std::fs::read(require(KDC)).unwrap();
    let info = kodak_radc::identify(&bytes).expect("the DC50 file is identified");
    assert_eq!(info.model, KodakModel::Dc50);
    assert!(info.model_name.contains("DC50"), "{info:?}");
    assert!(info.make.contains("Kodak"), "{info:?}");
    assert_eq!((info.width, info.height), (768, 512));
    // dcraw's DC50 data offset is where the file's RADC-compressed strip starts.
    assert_eq!(info.data_offset, 19712);
    // The header, not the name, decides: the same bytes under another name load the same, and
    // the dispatcher (any unknown extension is camera raw) gets there too.
    let dir = tempfile::tempdir().unwrap();
    let other = dir.path().join("renamed.dat");
    std::fs::write(&other, &bytes).unwrap();
    let a = load_input(&other, &InputOptions::default()).unwrap().frame;
    let b = load_camera_raw(&require(KDC)).unwrap();
    assert_eq!(a.to_u16_vec(), b.to_u16_vec());
    assert_eq!((a.cfa(), a.bit_depth(), a.levels().white), (Cfa::Grbg, 14, 16383));
    assert!(a.wb_gains.is_none(), "the file carries no white balance");
}

/// Cutting the file anywhere never panics. A cut inside the compressed data is an error naming
/// a byte offset at or before the cut; a cut after the end of the stream (if the stream ends
/// before the file) may decode, and must then give exactly the full image.
#[test]
fn truncated_dc50_never_panics_and_names_the_offset() {
    let bytes = std::fs::read(require(KDC)).unwrap();
    let info = kodak_radc::identify(&bytes).unwrap();
    let full = kodak_radc::decode(&bytes, &info).unwrap();
    let data = bytes.len() - info.data_offset;
    let mut cuts: Vec<usize> = vec![0, 1, 4, 8, 64, 0x1b0, 0x200, 0x270, 0x300, 1000, 10_000];
    cuts.extend([0, 1, 2, 3, 100].iter().map(|d| info.data_offset + d));
    cuts.extend((1..20).map(|k| info.data_offset + data * k / 20));
    cuts.extend([bytes.len() - 64, bytes.len() - 2, bytes.len() - 1]);
    // Where the stream ends: the shortest prefix that decodes (decoding a prefix is monotone:
    // peeking past the end pads with zeros, consuming past it is an error).
    let (mut lo, mut hi) = (info.data_offset + 1, bytes.len());
    while lo < hi {
        let mid = (lo + hi) / 2;
        if kodak_radc::decode(&bytes[..mid], &info).is_ok() {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    let end = lo;
    eprintln!("RADC stream ends at byte {end} of {}", bytes.len());
    assert!(kodak_radc::decode(&bytes[..end - 1], &info).is_err());
    cuts.extend([end - 1, end]);
    let mut errors_in_data = 0;
    for &cut in &cuts {
        let head = &bytes[..cut];
        let Some(info) = kodak_radc::identify(head) else {
            assert!(cut < 0x270, "header cut at {cut} no longer identified");
            continue;
        };
        match kodak_radc::decode(head, &info) {
            Ok(px) => {
                assert!(cut >= end, "cut at {cut} before the stream end {end} decoded");
                assert_eq!(px, full, "cut at {cut} decoded to a different image");
            }
            Err(RadcError::Truncated { offset, len, .. }) => {
                assert!(cut < end, "cut at {cut} after the stream end {end} refused");
                assert_eq!(len, cut);
                assert!(
                    offset >= info.data_offset && offset <= cut,
                    "offset {offset}, cut {cut}"
                );
                errors_in_data += 1;
            }
            Err(RadcError::DataOffset { offset, len }) => {
                assert_eq!((offset, len), (info.data_offset, cut));
            }
            Err(e) => panic!("cut at {cut}: unexpected error {e}"),
        }
    }
    // Every cut up to 95 % of the data is inside the stream.
    assert!(errors_in_data >= 20, "only {errors_in_data} cuts were refused");

    // Through the loader: the error names the file, the camera and the offset.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cut.kdc");
    let cut = info.data_offset + data / 2;
    std::fs::write(&p, &bytes[..cut]).unwrap();
    match load_camera_raw(&p) {
        Err(RawError::Format { path, what }) => {
            assert_eq!(path, p);
            assert!(what.contains("DC50") && what.contains("offset"), "{what}");
        }
        other => panic!("expected a truncation error, got {other:?}"),
    }
}

/// Flipped bytes (header and data, deterministic positions) never panic; a flipped data byte
/// either errors or decodes to a well-formed frame of in-range values.
#[test]
fn flipped_bytes_never_panic() {
    let bytes = std::fs::read(require(KDC)).unwrap();
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut ok, mut err) = (0, 0);
    for i in 0..160 {
        let mut b = bytes.clone();
        // A third in the header, the rest in the compressed data.
        let pos = if i % 3 == 0 {
            (next() as usize) % 0x480
        } else {
            19712 + (next() as usize) % (bytes.len() - 19712)
        };
        b[pos] ^= 1 << (next() % 8);
        if i % 4 == 0 {
            b[pos] ^= 0xff;
        }
        let Some(info) = kodak_radc::identify(&b) else {
            continue;
        };
        match kodak_radc::decode(&b, &info) {
            Ok(px) => {
                assert_eq!(px.len(), info.width * info.height);
                assert!(px.iter().all(|&v| v <= kodak_radc::WHITE));
                ok += 1;
            }
            Err(_) => err += 1,
        }
    }
    // Starting the RADC decoder on the TIFF header instead of the data must not panic either.
    let _ = kodak_radc::decode_stream(&bytes, 0, 768, 512, false);
    let _ = kodak_radc::decode_stream(&bytes, 0, 768, 512, true);
    eprintln!("flipped bytes: {ok} decoded, {err} refused");
    assert!(ok + err > 100, "ok {ok}, err {err}");
}
