//! The rawloader path of `load_camera_raw` on a synthetic DNG written by this test (the shared
//! data has no camera raw that rawloader 0.37 supports: see docs/raw.md). Checks the crop
//! (`ActiveArea` → rawloader `crops`) with re-phasing, black/white levels, bit depth from the white
//! level, and white-balance gains from `AsShotNeutral` normalised to G = 1.

use mosaicd::raw::{load_camera_raw, rawloader_ifd_visits, MAX_TIFF_IFD_VISITS};
use mosaicd::raw::{load_input, Cfa, InputOptions, Levels};

/// One IFD entry: tag, TIFF type, count, little-endian value bytes.
struct Entry(u16, u16, u32, Vec<u8>);

fn shorts(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn longs(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn rationals(v: &[(u32, u32)]) -> Vec<u8> {
    v.iter()
        .flat_map(|(a, b)| [a.to_le_bytes(), b.to_le_bytes()].concat())
        .collect()
}

/// A minimal uncompressed 16-bit little-endian DNG with one IFD.
#[allow(clippy::too_many_arguments)] // one argument per DNG tag under test
fn dng(
    w: u32,
    h: u32,
    px: &[u16],
    cfa: [u8; 4],
    black: u16,
    white: u16,
    active: [u32; 4],
    neutral: [(u32, u32); 3],
) -> Vec<u8> {
    const BYTE: u16 = 1;
    const ASCII: u16 = 2;
    const SHORT: u16 = 3;
    const LONG: u16 = 4;
    const RATIONAL: u16 = 5;
    let mut entries = vec![
        Entry(254, LONG, 1, longs(&[0])),
        Entry(256, LONG, 1, longs(&[w])),
        Entry(257, LONG, 1, longs(&[h])),
        Entry(258, SHORT, 1, shorts(&[16])),
        Entry(259, SHORT, 1, shorts(&[1])),
        Entry(262, SHORT, 1, shorts(&[32803])),
        Entry(271, ASCII, 6, b"Synth\0".to_vec()),
        Entry(272, ASCII, 7, b"Mosaic\0".to_vec()),
        Entry(273, LONG, 1, vec![]), // strip offset, filled below
        Entry(277, SHORT, 1, shorts(&[1])),
        Entry(278, LONG, 1, longs(&[h])),
        Entry(279, LONG, 1, longs(&[w * h * 2])),
        Entry(33421, SHORT, 2, shorts(&[2, 2])),
        Entry(33422, BYTE, 4, cfa.to_vec()),
        Entry(50706, BYTE, 4, vec![1, 4, 0, 0]),
        Entry(50714, SHORT, 1, shorts(&[black])),
        Entry(50717, SHORT, 1, shorts(&[white])),
        Entry(50728, RATIONAL, 3, rationals(&neutral)),
        Entry(50829, LONG, 4, longs(&active)),
    ];
    let n_entries = entries.len() as u32;
    let ifd_len = 2 + 12 * n_entries + 4;
    // Layout: header (8) | IFD | out-of-line values | pixels.
    let mut extra = Vec::new();
    let extra_start = 8 + ifd_len;
    let mut offsets = Vec::new();
    for e in &entries {
        if e.3.len() > 4 {
            offsets.push(Some(extra_start + extra.len() as u32));
            extra.extend_from_slice(&e.3);
            if extra.len() % 2 == 1 {
                extra.push(0);
            }
        } else {
            offsets.push(None);
        }
    }
    let strip = extra_start + extra.len() as u32;
    entries[8].3 = longs(&[strip]);
    let mut out = b"II*\0".to_vec();
    out.extend_from_slice(&8u32.to_le_bytes());
    out.extend_from_slice(&(n_entries as u16).to_le_bytes());
    for (e, off) in entries.iter().zip(&offsets) {
        out.extend_from_slice(&e.0.to_le_bytes());
        out.extend_from_slice(&e.1.to_le_bytes());
        out.extend_from_slice(&e.2.to_le_bytes());
        match off {
            Some(o) => out.extend_from_slice(&o.to_le_bytes()),
            None => {
                let mut v = e.3.clone();
                v.resize(4, 0);
                out.extend_from_slice(&v);
            }
        }
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    assert_eq!(out.len() as u32, extra_start);
    out.extend_from_slice(&extra);
    out.extend_from_slice(&shorts(px));
    out
}

/// The 10x8 test DNG: GRBG (CFAPattern 1 0 / 2 1), ActiveArea top 1, left 1, bottom 7, right 9,
/// black 64, white 4000, AsShotNeutral 1/2, 1, 1/4. Returns the width, the pixels and the file.
fn synthetic() -> (usize, Vec<u16>, Vec<u8>) {
    let (w, h) = (10usize, 8usize);
    let px: Vec<u16> = (0..w * h).map(|i| 64 + (i as u16 * 37) % 3900).collect();
    let bytes = dng(
        w as u32,
        h as u32,
        &px,
        [1, 0, 2, 1],
        64,
        4000,
        [1, 1, 7, 9],
        [(1, 2), (1, 1), (1, 4)],
    );
    (w, px, bytes)
}

#[test]
fn synthetic_dng_crop_levels_and_gains() {
    let (w, px, bytes) = synthetic();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("synth.dng");
    std::fs::write(&p, &bytes).unwrap();
    // One IFD for rawloader to walk: well within the pre-check's limit.
    assert_eq!(rawloader_ifd_visits(&bytes, MAX_TIFF_IFD_VISITS), 1);
    let f = load_camera_raw(&p).unwrap();
    // Cropped at (1, 1): 8x6, GRBG re-phased to GBRG.
    assert_eq!((f.width(), f.height()), (8, 6));
    assert_eq!(f.cfa(), Cfa::Grbg.shifted(1, 1));
    assert_eq!(f.cfa(), Cfa::Gbrg);
    for y in 0..6 {
        for x in 0..8 {
            assert_eq!(f.value(x, y), px[(y + 1) * w + x + 1], "({x}, {y})");
        }
    }
    assert_eq!(*f.levels(), Levels::uniform(64, 4000));
    assert_eq!(f.bit_depth(), 12);
    let g = f.wb_gains.expect("gains from AsShotNeutral");
    assert!(
        (g[0] - 2.0).abs() < 1e-6 && g[1] == 1.0 && (g[2] - 4.0).abs() < 1e-6,
        "{g:?}"
    );
    // The dispatcher picks rawloader for .dng.
    let l = load_input(&p, &InputOptions::default()).unwrap();
    assert_eq!(l.frame.to_u16_vec(), f.to_u16_vec());
    // Truncated: refused with the file named, no panic escapes.
    let t = dir.path().join("truncated.dng");
    std::fs::write(&t, &bytes[..bytes.len() / 2]).unwrap();
    let e = load_camera_raw(&t);
    assert!(e.is_err(), "truncated DNG must not load");
}

/// rawloader turns a panic of its decoders into an error, but the default panic hook printed
/// "panicked at ..." on stderr first. A truncated DNG panics inside rawloader: the command refuses
/// the file with rawloader's error and nothing on stderr says "panicked".
#[test]
fn rawloader_caught_panics_stay_off_stderr() {
    let (_, _, bytes) = synthetic();
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("truncated.dng");
    std::fs::write(&t, &bytes[..bytes.len() / 2]).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .arg("gradients")
        .arg(&t)
        .arg("--out")
        .arg(dir.path().join("g"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("truncated.dng") && err.contains("rawloader"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}
