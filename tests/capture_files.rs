//! File source: directories and lists of raw files with TOML sidecars, played as a stream;
//! real sensor files from ../shared/data.

use std::path::PathBuf;
use std::sync::Arc;

use mosaicd::capture::{CaptureError, Clock, FakeClock, Source, SourceKind};
use mosaicd::capture::{FileSource, FileSourceOptions};
use mosaicd::raw::Cfa;

fn write_u16le(path: &std::path::Path, v: &[u16]) {
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn directory_with_sidecars_plays_in_name_order_with_timestamps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_u16le(&d.join("b.raw"), &[1, 2, 3, 4]);
    write_u16le(&d.join("a.raw"), &[100, 200, 300, 4000]);
    std::fs::write(
        d.join(mosaicd::capture::DIR_SIDECAR),
        "width = 2\nheight = 2\nbit_depth = 12\ncfa = \"GBRG\"\nblack = [10, 11, 12, 13]\nwhite = 4095\n",
    )
    .unwrap();
    // Per-file sidecar wins over the directory one.
    write_u16le(&d.join("c.raw"), &[7; 8]);
    std::fs::write(
        d.join("c.raw.toml"),
        "width = 4\nheight = 2\nbit_depth = 10\ncfa = \"RGGB\"\n",
    )
    .unwrap();
    std::fs::write(d.join("notes.txt"), "not a frame").unwrap();
    let clock = Arc::new(FakeClock::new(0));
    let opts = FileSourceOptions {
        fps: 10.0,
        pace: true,
        clock: clock.clone(),
        ..Default::default()
    };
    let mut src = FileSource::open(&[d.to_path_buf()], opts).unwrap();
    assert_eq!(src.kind(), SourceKind::Replay);
    assert_eq!(src.files().len(), 3);
    let a = src.next_frame().unwrap().unwrap();
    assert_eq!(a.to_u16_vec(), vec![100, 200, 300, 4000]);
    assert_eq!(
        (a.cfa(), a.bit_depth(), a.levels().black),
        (Cfa::Gbrg, 12, [10, 11, 12, 13])
    );
    assert_eq!((a.meta.sequence, a.meta.timestamp_ns), (0, 0));
    assert!(a.meta.source.ends_with("a.raw"));
    let b = src.next_frame().unwrap().unwrap();
    assert_eq!((b.meta.sequence, b.meta.timestamp_ns), (1, 100_000_000));
    let c = src.next_frame().unwrap().unwrap();
    assert_eq!((c.width(), c.cfa(), c.bit_depth()), (4, Cfa::Rggb, 10));
    assert_eq!(c.meta.timestamp_ns, 200_000_000);
    // Paced on the fake clock: waited until 200 ms.
    assert_eq!(clock.now_ns(), 200_000_000);
    assert!(src.next_frame().unwrap().is_none());
    assert!(src.is_finished());
}

#[test]
fn bad_files_and_sidecars_are_clear_errors_and_the_stream_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_u16le(&d.join("a.raw"), &[1, 2, 3]); // too short for 2x2
    write_u16le(&d.join("b.raw"), &[1, 2, 3, 4]);
    std::fs::write(
        d.join("mosaicd-raw.toml"),
        "width = 2\nheight = 2\nbit_depth = 12\ncfa = \"RGGB\"\n",
    )
    .unwrap();
    let mut src =
        FileSource::open(&[d.join("a.raw"), d.join("b.raw")], FileSourceOptions::default()).unwrap();
    let e = src.next_frame().unwrap_err();
    assert!(matches!(e, CaptureError::Raw(_)), "{e}");
    assert!(e.to_string().contains("a.raw"), "{e}");
    assert_eq!(src.next_frame().unwrap().unwrap().to_u16_vec(), vec![1, 2, 3, 4]);

    std::fs::write(
        d.join("mosaicd-raw.toml"),
        "width = 2\nheight = 2\nbit_depth = 12\ncfa = \"RGBG\"\n",
    )
    .unwrap();
    let mut src = FileSource::open(&[d.join("b.raw")], FileSourceOptions::default()).unwrap();
    let e = src.next_frame().unwrap_err();
    assert!(e.to_string().contains("cfa = RGBG"), "{e}");
    std::fs::write(d.join("mosaicd-raw.toml"), "width = 2\nheight = 2\nbits = 12\n").unwrap();
    let mut src = FileSource::open(&[d.join("b.raw")], FileSourceOptions::default()).unwrap();
    let e = src.next_frame().unwrap_err();
    assert!(matches!(e, CaptureError::Sidecar { .. }), "{e}");

    let e = FileSource::open(&[d.join("missing.raw")], FileSourceOptions::default()).unwrap_err();
    assert!(e.to_string().contains("missing.raw"), "{e}");
    let empty = tempfile::tempdir().unwrap();
    let e = FileSource::open(&[empty.path().to_path_buf()], FileSourceOptions::default()).unwrap_err();
    assert!(e.to_string().contains("at least one frame file"), "{e}");
}

/// Looped: a bad file among good ones is reported on every pass and the loop goes on; a loop
/// whose every file fails reports each once, then stops with an error that says so, instead of
/// repeating the same errors forever.
#[test]
fn a_loop_stops_only_when_a_whole_pass_delivers_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_u16le(&d.join("a.raw"), &[1, 2, 3]); // too short for 2x2
    write_u16le(&d.join("b.raw"), &[1, 2, 3, 4]);
    write_u16le(&d.join("c.raw"), &[1; 5]); // too long
    std::fs::write(
        d.join("mosaicd-raw.toml"),
        "width = 2\nheight = 2\nbit_depth = 12\ncfa = \"RGGB\"\n",
    )
    .unwrap();
    let looped = || FileSourceOptions {
        looped: true,
        ..Default::default()
    };
    let mut src = FileSource::open(&[d.join("a.raw"), d.join("b.raw")], looped()).unwrap();
    for _ in 0..3 {
        assert!(matches!(src.next_frame(), Err(CaptureError::Raw(_))));
        assert!(src.next_frame().unwrap().is_some());
    }
    assert!(!src.is_finished());

    let mut src = FileSource::open(&[d.join("a.raw"), d.join("c.raw")], looped()).unwrap();
    assert!(matches!(src.next_frame(), Err(CaptureError::Raw(_))));
    assert!(matches!(src.next_frame(), Err(CaptureError::Raw(_))));
    let e = src.next_frame().unwrap_err();
    assert!(
        matches!(e, CaptureError::NothingPlayable { files: 2, .. }),
        "{e:?}"
    );
    assert!(e.to_string().contains("none of its 2 file(s)"), "{e}");
    assert!(src.is_finished());
    assert!(src.next_frame().unwrap().is_none());
}

/// Real sensor files: the Nikon 14-bit RGGB frame and its re-phased GBRG copy, through one
/// sidecar each, looped.
#[test]
fn real_nikon_frames_play_looped() {
    let rggb = mosaicd::data::require("raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw");
    let gbrg = mosaicd::data::require("raw/nikon_dsc1339_isp/DSC_1339_768x512_gbrg.raw");
    let dir = tempfile::tempdir().unwrap();
    let side = |cfa: &str| {
        let p = dir.path().join(format!("{cfa}.toml"));
        std::fs::write(
            &p,
            format!(
                "width = 768\nheight = 512\nbit_depth = 14\ncfa = \"{cfa}\"\nblack = 600\nwhite = 15520\n"
            ),
        )
        .unwrap();
        p
    };
    let opts = FileSourceOptions {
        sidecar: Some(side("RGGB")),
        looped: true,
        ..Default::default()
    };
    let mut src = FileSource::open(&[rggb], opts).unwrap();
    let f0 = src.next_frame().unwrap().unwrap();
    let f1 = src.next_frame().unwrap().unwrap();
    assert_eq!(
        (f0.width(), f0.height(), f0.bit_depth(), f0.cfa()),
        (768, 512, 14, Cfa::Rggb)
    );
    assert_eq!(f0.levels().white, 15520);
    assert_eq!(f0.to_u16_vec(), f1.to_u16_vec());
    assert_eq!(f1.meta.sequence, 1);
    assert!(!src.is_finished());
    let opts = FileSourceOptions {
        sidecar: Some(side("GBRG")),
        ..Default::default()
    };
    let g = FileSource::open(&[gbrg], opts)
        .unwrap()
        .next_frame()
        .unwrap()
        .unwrap();
    assert_eq!(g.cfa(), Cfa::Gbrg);
    // The author's GBRG copy is the RGGB frame re-phased by one row: same pixels shifted.
    assert_eq!((g.width(), g.height()), (768, 512));
}

#[test]
fn real_infinite_isp_outdoor_frame_loads_8bit_grbg() {
    let p: PathBuf = mosaicd::data::require("raw/infinite_isp_8bit/Outdoor1_2592x1536_8bit_GRBG.raw");
    let dir = tempfile::tempdir().unwrap();
    let s = dir.path().join("side.toml");
    std::fs::write(
        &s,
        "width = 2592\nheight = 1536\nbit_depth = 8\ncfa = \"GRBG\"\nblack = 12\nwhite = 255\n",
    )
    .unwrap();
    let opts = FileSourceOptions {
        sidecar: Some(s),
        ..Default::default()
    };
    let f = FileSource::open(&[p], opts)
        .unwrap()
        .next_frame()
        .unwrap()
        .unwrap();
    assert_eq!(
        (f.width(), f.height(), f.cfa(), f.bit_depth()),
        (2592, 1536, Cfa::Grbg, 8)
    );
    assert!(matches!(f.pixels(), mosaicd::raw::RawPixels::U8(_)));
}
