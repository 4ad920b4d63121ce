//! Hostile inputs from the review of issue 24, each refused with a clear error instead of a panic,
//! a wrapped size, an allocation of gigabytes or a late report: a crafted model, a zstd chunk and
//! a frame header claiming a 16000x15625 frame, a 16000x15000 PNG, a damaged MCAP summary, an empty
//! recording, records that overrun an uncompressed MCAP chunk, and rawloader's caught panics. (Peak memory is measured in `hostile_memory.rs`.)

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use mosaicd::capture::{CaptureError, Damage, McapSource, McapSourceOptions, RecordPastEnd, Source};
use mosaicd::raw::{load_input, InputOptions};
use mosaicd::raw::{Cfa, FrameMeta, Levels, RawError, RawFrame};
use mosaicd::record::{Compression, McapRecorder, RecorderOptions};
use mosaicd::wire::schema::{
    encode_raw_frame, RAW_FRAME_ENCODING, RAW_FRAME_SCHEMA, RAW_FRAME_SCHEMA_ENCODING,
};

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");

/// A finished recording of `n` small frames.
fn small_recording(path: &Path, n: u64) {
    small_recording_with(path, n, RecorderOptions::default());
}

/// A finished recording of `n` small frames, written with `opts`.
fn small_recording_with(path: &Path, n: u64, opts: RecorderOptions) {
    let mut rec = McapRecorder::create(path, opts).unwrap();
    for i in 0..n {
        let f = RawFrame::from_u8(4, 4, vec![i as u8; 16], Cfa::Rggb, Levels::uniform(0, 255))
            .unwrap()
            .with_meta(FrameMeta {
                sequence: i,
                timestamp_ns: 1000 * i,
                ..Default::default()
            });
        rec.write_frame(&f).unwrap();
    }
    rec.finish().unwrap();
}

/// Offsets of the top-level records of an MCAP file (after the magic), with their opcodes.
fn records(bytes: &[u8]) -> Vec<(usize, u8)> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() - 8 {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        out.push((at, bytes[at]));
        at += 9 + len;
    }
    out
}

/// The bomb of the review, in the form that needs no 250 MB to build: a zstd chunk whose header
/// claims the 250,000,000+ uncompressed bytes of one 16000x15625 8-bit frame. The reader must
/// refuse it from the header (the record-length limit the frame-size limit sets), before it
/// decompresses or allocates anything; with the old 256 MiB limit it was accepted.
#[test]
fn a_chunk_claiming_a_250_mb_frame_is_refused_before_decompression() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bomb.mcap");
    small_recording(&path, 2);
    let mut bytes = std::fs::read(&path).unwrap();
    let (chunk, _) = *records(&bytes)
        .iter()
        .find(|(_, op)| *op == 0x06)
        .expect("a chunk");
    // opcode, length, message start and end time, then uncompressed_size.
    let at = chunk + 1 + 8 + 16;
    bytes[at..at + 8].copy_from_slice(&(16_000u64 * 15_625 + 400).to_le_bytes());
    std::fs::write(&path, &bytes).unwrap();
    let mut src = McapSource::open(&path, McapSourceOptions::default()).unwrap();
    match src.next_frame() {
        Err(CaptureError::Corrupt {
            source: Damage::Mcap(mcap::McapError::ChunkTooLarge(n)),
            ..
        }) => assert_eq!(n, 16_000 * 15_625 + 400),
        other => panic!("expected ChunkTooLarge, got {other:?}"),
    }
}

/// Replay `path`: frames delivered, then the error.
fn replay(path: &Path) -> (u64, Option<CaptureError>) {
    let mut src = McapSource::open(path, McapSourceOptions::default()).unwrap();
    let mut n = 0;
    loop {
        match src.next_frame() {
            Ok(Some(_)) => n += 1,
            Ok(None) => return (n, None),
            Err(e) => return (n, Some(e)),
        }
    }
}

/// The fuzzer's MCAP: an uncompressed chunk of 1 byte of records, holding a 9-byte record. mcap
/// 0.26 subtracts the record's size from what is left without a check: "attempt to subtract with
/// overflow" with overflow checks on (debug builds, the fuzzer), a misleading truncation error
/// without. A guard under the reader (`capture::mcap_guard`) stops it first, in both builds.
/// The fuzzer's chunk also declares 1,828 bytes where the file holds 106 after its header, which
/// the guard now stops first (finding 5: a truncation); with its length set to what the file holds,
/// the same chunk reaches the overrun check.
#[test]
fn records_that_overrun_an_uncompressed_chunk_are_a_clear_error_not_an_overflow() {
    let seed =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/mcap_source/chunk-records-overrun.mcap");
    let (n, e) = replay(&seed);
    assert_eq!(n, 0);
    match &e {
        Some(CaptureError::Truncated {
            frames: 0,
            source: mcap::McapError::Io(io),
            ..
        }) => assert_eq!(
            io.get_ref().and_then(|e| e.downcast_ref::<RecordPastEnd>()),
            Some(&RecordPastEnd {
                record: 38,
                opcode: 0x06,
                len: 1828,
                left: 106,
                file_len: 153
            })
        ),
        e => panic!("want a RecordPastEnd, got {e:?}"),
    }
    let mut fitted = std::fs::read(&seed).unwrap();
    fitted[39..47].copy_from_slice(&106u64.to_le_bytes());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fitted.mcap");
    std::fs::write(&path, &fitted).unwrap();
    let (n, e) = replay(&path);
    assert_eq!(n, 0);
    let e = e.unwrap();
    match &e {
        CaptureError::Corrupt {
            frames: 0,
            source: Damage::ChunkOverrun(o),
            ..
        } => assert_eq!(
            (o.chunk, o.records_len, o.record, o.need, o.left),
            (38, 1, 87, 9, 1)
        ),
        e => panic!("want a ChunkOverrun, got {e:?}"),
    }
    assert!(
        e.to_string()
            .contains("chunk at byte 38 holds 1 bytes of records"),
        "{e}"
    );

    // Recordings of every compression replay in full through the guard.
    for compression in [Compression::None, Compression::Zstd, Compression::Lz4] {
        let path = dir.path().join(format!("{compression:?}.mcap"));
        let opts = RecorderOptions {
            compression,
            ..RecorderOptions::default()
        };
        small_recording_with(&path, 5, opts);
        let (n, e) = replay(&path);
        assert_eq!((n, e.map(|e| e.to_string())), (5, None), "{compression:?}");
    }
    // An uncompressed recording cut after its first chunk, then a chunk whose one record (39
    // bytes) claims more than the 20 bytes of records the chunk declares: the first chunk's
    // frames, then the overrun.
    let good = std::fs::read(dir.path().join("None.mcap")).unwrap();
    let (chunk, _) = *records(&good)
        .iter()
        .find(|(_, op)| *op == 0x06)
        .expect("a chunk");
    let len = u64::from_le_bytes(good[chunk + 1..chunk + 9].try_into().unwrap()) as usize;
    let end = chunk + 9 + len;
    let mut body = vec![0u8; 28]; // start and end time, uncompressed size and CRC
    body.extend(0u32.to_le_bytes()); // no compression
    body.extend(20u64.to_le_bytes()); // records_len
    body.push(0x05);
    body.extend(30u64.to_le_bytes());
    body.extend([0u8; 30]);
    let mut bad = good[..end].to_vec();
    bad.push(0x06);
    bad.extend((body.len() as u64).to_le_bytes());
    bad.extend(body);
    let path = dir.path().join("bad.mcap");
    std::fs::write(&path, &bad).unwrap();
    let (n, e) = replay(&path);
    assert!(n >= 1, "{n}");
    match e {
        Some(CaptureError::Corrupt {
            frames,
            source: Damage::ChunkOverrun(o),
            ..
        }) => {
            assert_eq!(frames, n);
            let end = end as u64;
            assert_eq!((o.chunk, o.record, o.need, o.left), (end, end + 49, 39, 20));
        }
        e => panic!("want a ChunkOverrun, got {e:?}"),
    }
}

/// A frame message whose header claims 16000x15625 is refused from its header, before its pixels
/// are looked at (here they are absent: the old decoder reported a short message instead).
#[test]
fn a_frame_header_beyond_the_limit_is_refused_from_the_header() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge_header.mcap");
    let f = RawFrame::from_u8(2, 2, vec![1; 4], Cfa::Rggb, Levels::uniform(0, 255)).unwrap();
    let mut msg = Vec::new();
    encode_raw_frame(&f, &mut msg);
    let hlen = u32::from_le_bytes(msg[4..8].try_into().unwrap()) as usize;
    let header = String::from_utf8(msg[8..8 + hlen].to_vec()).unwrap();
    let header = header
        .replace("\"width\":2", "\"width\":16000")
        .replace("\"height\":2", "\"height\":15625");
    let mut crafted = b"MRF1".to_vec();
    crafted.extend_from_slice(&(header.len() as u32).to_le_bytes());
    crafted.extend_from_slice(header.as_bytes());
    crafted.extend_from_slice(&[1, 1, 1, 1]);
    let mut w = mcap::Writer::new(std::io::BufWriter::new(std::fs::File::create(&path).unwrap())).unwrap();
    let schema = w
        .add_schema(RAW_FRAME_SCHEMA, RAW_FRAME_SCHEMA_ENCODING, b"")
        .unwrap();
    let ch = w
        .add_channel(schema, "/cam/raw", RAW_FRAME_ENCODING, &BTreeMap::new())
        .unwrap();
    let head = mcap::records::MessageHeader {
        channel_id: ch,
        sequence: 0,
        log_time: 0,
        publish_time: 0,
    };
    w.write_to_known_channel(&head, &crafted).unwrap();
    w.finish().unwrap();
    drop(w);
    let mut src = McapSource::open(&path, McapSourceOptions::default()).unwrap();
    match src.next_frame() {
        Err(CaptureError::Raw(RawError::TooLarge { limit, .. })) => {
            assert_eq!((limit.width, limit.height), (16_000, 15_625))
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
}

/// A flipped byte in the summary section (here in the statistics' message count, which parses
/// fine) is found when the recording is opened, not after every frame was replayed.
#[test]
fn a_damaged_summary_is_refused_at_open() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.mcap");
    small_recording(&path, 3);
    let good = std::fs::read(&path).unwrap();
    let (stats, _) = *records(&good)
        .iter()
        .find(|(_, op)| *op == 0x0B)
        .expect("a statistics record");
    let mut bad = good.clone();
    bad[stats + 9] ^= 0x01;
    std::fs::write(&path, &bad).unwrap();
    match McapSource::open(&path, McapSourceOptions::default()) {
        Err(CaptureError::Corrupt {
            source: Damage::Mcap(mcap::McapError::BadSummaryCrc { .. }),
            ..
        }) => {}
        other => panic!("expected BadSummaryCrc at open, got {other:?}"),
    }
    assert!(mosaicd::wire::RecordingInfo::read(&path).is_err());
    // The intact file opens and replays.
    std::fs::write(&path, &good).unwrap();
    let mut src = McapSource::open(&path, McapSourceOptions::default()).unwrap();
    let mut n = 0;
    while src.next_frame().unwrap().is_some() {
        n += 1;
    }
    assert_eq!(n, 3);
}

/// The smallest valid 8-bit grey PNG header claiming `w`x`h`, with an IDAT that decodes to nothing:
/// only a check of the header's size can refuse it as too large (a decoder would fail later, and
/// differently).
fn png_claiming(w: u32, h: u32) -> Vec<u8> {
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut c = kind.to_vec();
        c.extend_from_slice(data);
        out.extend_from_slice(&c);
        out.extend_from_slice(&crc32fast::hash(&c).to_be_bytes());
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    );
    chunk(&mut out, b"IEND", &[]);
    out
}

#[test]
fn images_beyond_the_frame_size_limit_are_refused_from_their_header() {
    let dir = tempfile::tempdir().unwrap();
    let grey = dir.path().join("bomb.png");
    std::fs::write(&grey, png_claiming(16_000, 15_000)).unwrap();
    let opts = InputOptions {
        cfa: Some(Cfa::Rggb),
        ..InputOptions::default()
    };
    match load_input(&grey, &opts) {
        Err(RawError::TooLarge { path, limit }) => {
            assert_eq!(path, grey);
            assert_eq!((limit.width, limit.height), (16_000, 15_000));
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
    // The same through the RGB decoder every command uses (a .bmp or .jpg name would too).
    assert!(matches!(
        mosaicd::raw::decode_image(&grey),
        Err(RawError::TooLarge { .. })
    ));
    // A PGM header claiming an overflowing size is refused, not multiplied.
    let pgm = dir.path().join("bomb.pgm");
    std::fs::write(&pgm, b"P5\n18446744073709551615 2\n255\n\x00").unwrap();
    assert!(matches!(load_input(&pgm, &opts), Err(RawError::TooLarge { .. })));
    // The commands refuse it with the file named, exit status 1 (not a crash).
    let out = Command::new(BIN)
        .args(["gradients"])
        .arg(&grey)
        .args(["--cfa", "RGGB"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("frame-size limit") && err.contains("bomb.png"),
        "{err}"
    );
}

/// The crafted model of the review: 32x6148914691236517216, 2 bins, 8 weights. `mosaicd detect`
/// panicked (exit 101) in the scorer; now it refuses the model, naming the field (exit 1).
#[test]
fn detect_refuses_a_model_with_absurd_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("crafted.json");
    std::fs::write(
        &model,
        serde_json::json!({
            "format": "mosaicd-hog-svm", "version": 1, "win_width": 32,
            "win_height": 6148914691236517216u64, "cell_size": 8, "block_size": 16,
            "block_stride": 8, "nbins": 2, "gamma_correction": true, "l2hys_threshold": 0.2,
            "domain": "mosaic", "bias": 0.0, "weights": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        })
        .to_string(),
    )
    .unwrap();
    let raw = dir.path().join("f.raw");
    std::fs::write(&raw, vec![0u8; 64 * 128]).unwrap();
    let out = Command::new(BIN)
        .arg("detect")
        .arg(&raw)
        .args([
            "--width",
            "64",
            "--height",
            "128",
            "--bit-depth",
            "8",
            "--cfa",
            "RGGB",
        ])
        .arg("--model")
        .arg(&model)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("win_height") && !err.contains("panicked"), "{err}");
}

/// `mosaicd record` with nothing recordable (every input skipped) exits non-zero.
#[test]
fn record_fails_when_nothing_was_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("x.nef");
    std::fs::write(&bad, b"not a raw file at all").unwrap();
    let out_file = dir.path().join("out.mcap");
    let out = Command::new(BIN)
        .arg("record")
        .arg(&bad)
        .arg("-o")
        .arg(&out_file)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("nothing was recorded"), "{err}");
    // One good input among bad ones still succeeds.
    let good: PathBuf = dir.path().join("a.raw");
    std::fs::write(&good, [1u8, 2, 3, 4]).unwrap();
    std::fs::write(
        dir.path().join("a.raw.toml"),
        "width = 2\nheight = 2\nbit_depth = 8\ncfa = \"RGGB\"\n",
    )
    .unwrap();
    let out = Command::new(BIN)
        .arg("record")
        .arg(&good)
        .arg(&bad)
        .arg("-o")
        .arg(&out_file)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

/// `mosaicd bench detect --raw` reads the file through the headerless loader: a truncated file or
/// samples above the file's depth are refused with the file named, and depths that leave the
/// file fewer than 8 bits are refused before any read.
#[test]
fn bench_detect_refuses_a_bad_raw_file_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let bench = |file: &Path, extra: &[&str]| {
        let out = Command::new(BIN)
            .args([
                "bench",
                "detect",
                "--no-peer",
                "--frames",
                "1",
                "--width",
                "64",
                "--height",
                "128",
            ])
            .arg("--raw")
            .arg(file)
            .args(extra)
            .output()
            .unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let short = dir.path().join("short.raw");
    std::fs::write(&short, vec![0u8; 64 * 128 * 2 - 2]).unwrap();
    let err = bench(&short, &[]);
    assert!(err.contains("short.raw"), "{err}");
    // 10-bit file (12-bit bench, shift 2) holding a 12-bit value
    let hot = dir.path().join("hot.raw");
    let mut bytes = vec![0u8; 64 * 128 * 2];
    bytes[..2].copy_from_slice(&4000u16.to_le_bytes());
    std::fs::write(&hot, &bytes).unwrap();
    let err = bench(&hot, &[]);
    assert!(err.contains("hot.raw"), "{err}");
    let err = bench(&hot, &["--bit-depth", "9", "--shift", "2"]);
    assert!(err.contains("must be at least 8"), "{err}");
}

/// What a load gave, comparable across entry points: the frame's geometry, format and samples
/// (and whether an RGB image came with it), or the error's text.
fn outcome(r: Result<(RawFrame, bool), RawError>) -> String {
    match r {
        Ok((f, rgb)) => format!(
            "{}x{} {:?} {} bits {:?} rgb {rgb} {:?} {:?}",
            f.width(),
            f.height(),
            f.cfa(),
            f.bit_depth(),
            f.levels(),
            f.wb_gains,
            f.to_u16_vec()
        ),
        Err(e) => format!("error: {e}"),
    }
}

/// The committed fuzz seeds of one target, sorted.
fn fuzz_seeds(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/seeds")
        .join(target);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no seeds in {}", dir.display());
    v
}

/// The fuzz targets feed bytes from memory to the loaders' in-memory entry points; the file
/// entry points are a `stat` and a bounded read in front of the same parsers. On every committed
/// seed (valid files, and the hostile ones of the findings), both give the same frame or the
/// same error.
#[test]
fn fuzz_seeds_load_the_same_from_memory_and_from_their_file() {
    use mosaicd::raw::{camera_raw_from_bytes, load_camera_raw, load_input_bytes};
    let opts = InputOptions {
        cfa: Some(Cfa::Rggb),
        ..InputOptions::default()
    };
    let (mut frames, mut errors) = (0, 0);
    let mut count = |a: &str| {
        if a.starts_with("error") {
            errors += 1
        } else {
            frames += 1
        }
    };
    for p in fuzz_seeds("pgm_png") {
        let bytes = std::fs::read(&p).unwrap();
        let file = outcome(load_input(&p, &opts).map(|l| (l.frame, l.rgb.is_some())));
        let memory = outcome(load_input_bytes(&bytes, &p, &opts).map(|l| (l.frame, l.rgb.is_some())));
        assert_eq!(file, memory, "{}", p.display());
        count(&file);
    }
    for p in fuzz_seeds("camera_raw") {
        let bytes = std::fs::read(&p).unwrap();
        let file = outcome(load_camera_raw(&p).map(|f| (f, false)));
        let memory = outcome(camera_raw_from_bytes(&bytes, &p).map(|f| (f, false)));
        assert_eq!(file, memory, "{}", p.display());
        count(&file);
    }
    for p in fuzz_seeds("mcap_source") {
        let bytes = std::fs::read(&p).unwrap();
        let drain = |src: Result<McapSource, CaptureError>| -> String {
            let mut src = match src {
                Ok(s) => s,
                Err(e) => return format!("error: {e}"),
            };
            let mut out = String::new();
            loop {
                match src.next_frame() {
                    Ok(Some(f)) => out += &format!("{} {:?}; ", f.meta.timestamp_ns, f.to_u16_vec()),
                    Ok(None) => return out,
                    Err(e) => return format!("{out}error: {e}"),
                }
            }
        };
        let file = drain(McapSource::open(&p, McapSourceOptions::default()));
        let memory = drain(McapSource::from_bytes(bytes, &p, McapSourceOptions::default()));
        assert_eq!(file, memory, "{}", p.display());
        count(&file);
    }
    // Both kinds of outcome were compared.
    assert!(frames >= 5 && errors >= 5, "{frames} frames, {errors} errors");
}

/// A looped replay from memory starts again from the same bytes, as one from a file reopens it.
#[test]
fn a_looped_replay_from_memory_starts_again() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.mcap");
    small_recording(&path, 3);
    let opts = McapSourceOptions {
        looped: true,
        ..McapSourceOptions::default()
    };
    let bytes = std::fs::read(&path).unwrap();
    let mut src = McapSource::from_bytes(bytes, "memory.mcap", opts).unwrap();
    let values: Vec<u16> = (0..7)
        .map(|_| src.next_frame().unwrap().unwrap().value(0, 0))
        .collect();
    assert_eq!(values, vec![0, 1, 2, 0, 1, 2, 0]);
    assert_eq!(src.describe(), "mcap:memory.mcap");
}

/// The fuzzer's 79-byte MCAP (10^7-run campaign, docs/fuzzing.md finding 6): an Attachment record
/// whose body is shorter than its header, which mcap 0.26 slices without a check. The panic
/// killed the source thread, and `mosaicd replay` then waited until a signal. Now the replay ends
/// with a corruption error naming the record.
#[test]
fn an_attachment_shorter_than_its_header_is_a_clear_error_not_a_panic() {
    let seed =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/mcap_source/attachment-short-body.mcap");
    let (frames, err) = replay(&seed);
    assert_eq!(frames, 0);
    match err {
        Some(CaptureError::Corrupt {
            source: Damage::ReaderPanic { message },
            ..
        }) => assert!(
            message.contains("range") || message.contains("index"),
            "{message}"
        ),
        other => panic!("{other:?}"),
    }
    let out = Command::new(BIN)
        .args(["replay", seed.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("malformed record"), "{stderr}");
}
