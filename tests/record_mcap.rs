//! Recording and replaying mosaicd MCAP files: round trip, determinism, truncation, corruption,
//! write errors (disk full), rotation, flush cadence, Foxglove schema compatibility.

use std::io::{Seek, SeekFrom, Write};
use std::path::Path;
use std::sync::Arc;

use mosaicd::capture::{CaptureError, Clock, FakeClock, McapSource, McapSourceOptions, Pacing, Source};
use mosaicd::detect::Detection;
use mosaicd::features::sift::Keypoint;
use mosaicd::raw::{Cfa, FrameMeta, Levels, RawFrame};
use mosaicd::record::{FlushPolicy, McapRecorder, RecordError, RecorderOptions, RotatePolicy};
use mosaicd::wire::{read_annotations, read_detections, read_stats, RecordingInfo};

const FRAME_NS: u64 = 33_333_333;

/// A deterministic synthetic 12-bit frame (a pattern that differs per frame).
fn frame(i: u64, w: usize, h: usize) -> RawFrame {
    let px: Vec<u16> = (0..w * h)
        .map(|k| (((k as u64 * 2654435761 + i * 97) >> 7) % 4096) as u16)
        .collect();
    RawFrame::from_u16(
        w,
        h,
        px,
        Cfa::Gbrg,
        12,
        Levels {
            black: [240, 256, 256, 250],
            white: 4095,
        },
    )
    .unwrap()
    .with_wb_gains([1.9, 1.0, 1.6])
    .with_meta(FrameMeta {
        sequence: i,
        sensor_sequence: Some(1000 + i),
        timestamp_ns: 5_000_000_000 + i * FRAME_NS,
        source: Arc::from("synthetic"),
    })
}

fn det(i: u64) -> Vec<Detection> {
    (0..(i % 3))
        .map(|k| Detection {
            x: 4.0 * k as f32,
            y: 2.0 + i as f32,
            width: 16.0,
            height: 32.0,
            score: 0.5 + k as f32,
        })
        .collect()
}

/// `i % 4` keypoints (none on every fourth frame).
fn kps(i: u64) -> Vec<Keypoint> {
    (0..(i % 4))
        .map(|k| Keypoint {
            x: 10.0 + k as f32,
            y: 6.0 + i as f32,
            size: 6.4,
            angle: 90.0,
            response: 0.02,
            octave: 0,
            layer: 1,
        })
        .collect()
}

/// One descriptor per keypoint of [`kps`], each byte a function of frame, keypoint and position.
fn descs(i: u64) -> Vec<[u8; 128]> {
    (0..(i % 4))
        .map(|k| std::array::from_fn(|j| (i as usize * 31 + k as usize * 7 + j) as u8))
        .collect()
}

fn record(path: &Path, n: u64, opts: RecorderOptions) -> mosaicd::record::RecordingSummary {
    let keypoints = opts.keypoints;
    let mut rec = McapRecorder::create(path, opts).unwrap();
    for i in 0..n {
        let f = frame(i, 64, 48);
        rec.write_frame(&f).unwrap();
        rec.write_detections(i, f.meta.timestamp_ns, 64, 48, &det(i))
            .unwrap();
        if keypoints {
            rec.write_keypoints(f.meta.timestamp_ns, &kps(i)).unwrap();
            // Descriptors on odd frames only, to see both forms of the message.
            let d = descs(i);
            rec.write_sift(
                i,
                f.meta.timestamp_ns,
                64,
                48,
                &kps(i),
                (i % 2 == 1).then_some(&d[..]),
            )
            .unwrap();
        }
        if i % 5 == 4 {
            rec.write_stats(f.meta.timestamp_ns, &serde_json::json!({"frames": i + 1}))
                .unwrap();
        }
    }
    rec.finish().unwrap()
}

fn replay_all(path: &Path) -> (Vec<RawFrame>, Option<CaptureError>) {
    let mut src = match McapSource::open(path, McapSourceOptions::default()) {
        Ok(s) => s,
        Err(e) => return (Vec::new(), Some(e)),
    };
    let mut out = Vec::new();
    loop {
        match src.next_frame() {
            Ok(Some(f)) => out.push(f),
            Ok(None) => return (out, None),
            Err(e) => {
                assert!(src.is_finished());
                assert!(src.next_frame().unwrap().is_none());
                return (out, Some(e));
            }
        }
    }
}

#[test]
fn round_trip_is_lossless_with_metadata_and_summary() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mcap");
    let s = record(&path, 12, RecorderOptions::default());
    assert_eq!((s.frames, s.detections, s.stats), (12, 12, 2));
    let (frames, err) = replay_all(&path);
    assert!(err.is_none(), "{err:?}");
    assert_eq!(frames.len(), 12);
    for (i, f) in frames.iter().enumerate() {
        let want = frame(i as u64, 64, 48);
        assert_eq!(f, &want, "frame {i}");
    }
    let info = RecordingInfo::read(&path).unwrap();
    assert_eq!(info.count("/camera/raw"), 12);
    assert_eq!(info.count("/camera/preview"), 12);
    assert_eq!(info.count("/camera/annotations"), 12);
    assert_eq!(info.count("/camera/detections"), 12);
    assert_eq!(info.count("/camera/stats"), 2);
    assert_eq!(info.start_ns, 5_000_000_000);
    assert_eq!(info.end_ns, 5_000_000_000 + 11 * FRAME_NS);
    assert!(info.chunks >= 1);
    let raw = &info.channels["/camera/raw"];
    assert_eq!(
        (raw.schema.as_str(), raw.message_encoding.as_str()),
        ("mosaicd.RawFrame", "mosaicd.rawframe.v1")
    );
    for t in [
        "/camera/preview",
        "/camera/annotations",
        "/camera/detections",
        "/camera/stats",
    ] {
        assert_eq!(info.channels[t].schema_encoding, "jsonschema");
        assert_eq!(info.channels[t].message_encoding, "json");
    }
    assert_eq!(info.channels["/camera/preview"].schema, "foxglove.RawImage");
    assert_eq!(
        info.channels["/camera/annotations"].schema,
        "foxglove.ImageAnnotations"
    );

    let dets = read_detections(&path, "camera").unwrap();
    assert_eq!(dets.len(), 12);
    for (i, d) in dets.iter().enumerate() {
        assert_eq!(d.sequence, i as u64);
        assert_eq!(d.detections, det(i as u64));
        assert_eq!((d.frame_width, d.frame_height), (64, 48));
    }
    let ann = read_annotations(&path, "camera").unwrap();
    assert_eq!(ann.len(), 12);
    // Frame 2 has 2 boxes; preview decimation 2 halves the coordinates.
    assert_eq!(ann[2].message.points.len(), 2);
    assert_eq!(ann[2].message.points[1].points[0].x, 2.0);
    assert_eq!(ann[2].message.texts[1].text, "1.50");
    assert_eq!(read_stats(&path, "camera").unwrap()[1].message["frames"], 10);
}

#[test]
fn same_inputs_give_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.mcap"), dir.path().join("b.mcap"));
    record(&a, 9, RecorderOptions::default());
    record(&b, 9, RecorderOptions::default());
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

/// Every truncation point yields the frames of the complete chunks (in order, intact), then a
/// clear error; never a panic, never a damaged frame.
#[test]
fn truncated_recording_yields_complete_frames_then_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("full.mcap");
    let opts = RecorderOptions {
        flush: FlushPolicy {
            every_frames: Some(1),
            every_ns: None,
        },
        ..Default::default()
    };
    record(&path, 10, opts);
    let bytes = std::fs::read(&path).unwrap();
    let cut_path = dir.path().join("cut.mcap");
    let mut max_seen = 0;
    let mut cuts: Vec<usize> = (1..20).map(|k| bytes.len() * k / 20).collect();
    cuts.extend([9, 30, bytes.len() - 1, bytes.len() - 8]);
    for cut in cuts {
        std::fs::write(&cut_path, &bytes[..cut]).unwrap();
        let (frames, err) = replay_all(&cut_path);
        for (i, f) in frames.iter().enumerate() {
            assert_eq!(f, &frame(i as u64, 64, 48), "cut {cut}: frame {i}");
        }
        let err = err.unwrap_or_else(|| panic!("cut at {cut}/{} gave no error", bytes.len()));
        let msg = err.to_string();
        match err {
            CaptureError::Truncated { frames: n, .. } => {
                assert_eq!(n as usize, frames.len());
                assert!(msg.contains("truncated"), "{msg}");
            }
            // The tail (index / summary) is cut: all frames were already read.
            CaptureError::Corrupt { .. } => assert!(cut < 16 || frames.len() == 10, "cut {cut}: {msg}"),
            other => panic!("cut {cut}: unexpected {other}"),
        }
        max_seen = max_seen.max(frames.len());
    }
    // Flushing every frame: a cut near the end keeps (nearly) everything.
    assert!(max_seen >= 9, "max frames recovered {max_seen}");
}

/// Flipped bytes anywhere: refused or reported, never a panic, never a wrong frame.
#[test]
fn corrupt_recording_is_refused_without_crash() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ok.mcap");
    record(&path, 6, RecorderOptions::default());
    let bytes = std::fs::read(&path).unwrap();
    let bad_path = dir.path().join("bad.mcap");
    let mut errors = 0;
    for k in 0..97 {
        let pos = (bytes.len() - 1) * k / 96;
        let mut bad = bytes.clone();
        bad[pos] ^= 0x5A;
        std::fs::write(&bad_path, &bad).unwrap();
        let (frames, err) = replay_all(&bad_path);
        for (i, f) in frames.iter().enumerate() {
            assert_eq!(f, &frame(i as u64, 64, 48), "flip at {pos}: frame {i} differs");
        }
        if err.is_some() {
            errors += 1;
        } else {
            assert_eq!(frames.len(), 6, "flip at {pos}: frames lost without an error");
        }
    }
    // Nearly every byte is covered by a CRC or a magic.
    assert!(errors >= 90, "only {errors}/97 flips detected");
    // Not an MCAP at all.
    std::fs::write(&bad_path, b"hello, this is not a recording").unwrap();
    let err = McapSource::open(&bad_path, McapSourceOptions::default()).unwrap_err();
    assert!(matches!(err, CaptureError::Corrupt { .. }), "{err}");
    let err = McapSource::open(dir.path().join("missing.mcap"), McapSourceOptions::default()).unwrap_err();
    assert!(err.to_string().contains("missing.mcap"), "{err}");
}

/// A sink that fails with ENOSPC after `limit` bytes.
struct FullDisk {
    inner: std::io::Cursor<Vec<u8>>,
    limit: u64,
}

impl Write for FullDisk {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.inner.position() + buf.len() as u64 > self.limit {
            return Err(std::io::Error::from_raw_os_error(libc::ENOSPC));
        }
        self.inner.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Seek for FullDisk {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.inner.seek(pos)
    }
}

#[test]
fn disk_full_is_reported_once_then_recorder_stops() {
    let opts = RecorderOptions {
        flush: FlushPolicy {
            every_frames: Some(1),
            every_ns: None,
        },
        ..Default::default()
    };
    let sink = FullDisk {
        inner: std::io::Cursor::new(Vec::new()),
        limit: 20_000,
    };
    let mut rec = McapRecorder::from_writer(Box::new(sink), opts).unwrap();
    let mut first_error = None;
    let mut after = 0;
    for i in 0..50 {
        match rec.write_frame(&frame(i, 64, 48)) {
            Ok(()) => assert!(first_error.is_none()),
            Err(e @ RecordError::Write { .. }) => {
                assert!(first_error.is_none(), "Write reported twice");
                assert!(e.to_string().contains("No space left"), "{e}");
                first_error = Some(i);
            }
            Err(RecordError::Stopped { first }) => {
                assert!(first.contains("No space left"));
                after += 1;
            }
            Err(e) => panic!("unexpected {e}"),
        }
    }
    assert!(first_error.is_some() && after > 0);
    assert!(rec.is_failed());
    // A caller-provided writer has no next file: no resume, no new file.
    assert!(!rec.can_resume() && !rec.resume());
    assert!(matches!(rec.start_new_file(), Ok(false)));
    assert!(matches!(rec.finish(), Err(RecordError::Stopped { .. })));
    assert!(matches!(
        rec.write_detections(0, 0, 1, 1, &[]),
        Err(RecordError::Stopped { .. })
    ));
}

/// The real thing: /dev/full answers every write with ENOSPC.
#[test]
fn dev_full_is_a_clean_error() {
    if !Path::new("/dev/full").exists() {
        panic!("/dev/full missing: this test needs a Linux /dev/full");
    }
    let mut rec = match McapRecorder::create("/dev/full", RecorderOptions::default()) {
        Ok(r) => r,
        Err(e) => {
            assert!(matches!(e, RecordError::Write { .. }), "{e}");
            assert!(e.to_string().contains("No space left"), "{e}");
            return;
        }
    };
    let mut saw_write_error = false;
    for i in 0..40 {
        if let Err(e) = rec.write_frame(&frame(i, 64, 48)) {
            saw_write_error |= matches!(e, RecordError::Write { .. });
        }
    }
    let fin = rec.finish();
    assert!(saw_write_error || fin.is_err(), "ENOSPC was never reported");
}

#[test]
fn rotation_by_size_and_time_splits_into_readable_files() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("rot.mcap");
    let opts = RecorderOptions {
        flush: FlushPolicy {
            every_frames: Some(1),
            every_ns: None,
        },
        rotate: RotatePolicy {
            bytes: Some(12_000),
            duration_ns: None,
        },
        ..Default::default()
    };
    let s = record(&base, 12, opts);
    assert!(s.files.len() >= 3, "{:?}", s.files);
    assert_eq!(s.files[0], dir.path().join("rot-0001.mcap"));
    assert_eq!(s.files[1], dir.path().join("rot-0002.mcap"));
    let mut all = Vec::new();
    for f in &s.files {
        let (frames, err) = replay_all(f);
        assert!(err.is_none(), "{f:?}: {err:?}");
        all.extend(frames.into_iter().map(|f| f.meta.timestamp_ns));
    }
    let want: Vec<u64> = (0..12).map(|i| 5_000_000_000 + i * FRAME_NS).collect();
    assert_eq!(all, want);

    let base = dir.path().join("time.mcap");
    let opts = RecorderOptions {
        rotate: RotatePolicy {
            bytes: None,
            duration_ns: Some(4 * FRAME_NS),
        },
        ..Default::default()
    };
    let s = record(&base, 12, opts);
    assert_eq!(s.files.len(), 3, "{:?}", s.files);
    for f in &s.files {
        assert_eq!(RecordingInfo::read(f).unwrap().count("/camera/raw"), 4);
    }
}

#[test]
fn keep_existing_never_overwrites_and_max_files_keeps_a_ring() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("cam.mcap");
    let keep = RecorderOptions {
        keep_existing: true,
        ..Default::default()
    };
    // The first run takes the plain path; a second run (a restart) must not truncate it.
    let first = record(&base, 3, keep.clone());
    assert_eq!(first.files, vec![base.clone()]);
    let before = std::fs::read(&base).unwrap();
    let second = record(&base, 2, keep.clone());
    assert_eq!(second.files, vec![dir.path().join("cam-0001.mcap")]);
    assert_eq!(
        std::fs::read(&base).unwrap(),
        before,
        "the earlier run is untouched"
    );
    assert_eq!(replay_all(&second.files[0]).0.len(), 2);
    // Rotating, it numbers after the highest file already there (an unrelated name is ignored).
    std::fs::write(dir.path().join("cam-notes.mcap"), b"x").unwrap();
    let ring = RecorderOptions {
        rotate: RotatePolicy {
            bytes: None,
            duration_ns: Some(2 * FRAME_NS),
        },
        max_files: Some(3),
        ..keep
    };
    let third = record(&base, 8, ring.clone());
    let names = |files: &[std::path::PathBuf]| -> Vec<String> {
        files
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect()
    };
    assert_eq!(
        names(&third.files),
        ["cam-0002.mcap", "cam-0003.mcap", "cam-0004.mcap", "cam-0005.mcap"]
    );
    // At most three numbered files remain, the newest; the plain path and other names stay.
    let listing = || -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    assert_eq!(
        listing(),
        [
            "cam-0003.mcap",
            "cam-0004.mcap",
            "cam-0005.mcap",
            "cam-notes.mcap",
            "cam.mcap"
        ]
    );
    for f in &third.files[1..] {
        assert!(replay_all(f).1.is_none(), "{f:?} reads back whole");
    }
    // A restart never deletes by starting (only a rotation prunes), and numbers across a gap.
    std::fs::write(dir.path().join("cam-0009.mcap"), b"not ours to judge").unwrap();
    let fourth = record(&base, 1, ring.clone());
    assert_eq!(names(&fourth.files), ["cam-0010.mcap"]);
    assert_eq!(
        listing(),
        [
            "cam-0003.mcap",
            "cam-0004.mcap",
            "cam-0005.mcap",
            "cam-0009.mcap",
            "cam-0010.mcap",
            "cam-notes.mcap",
            "cam.mcap"
        ]
    );
    // max_files needs at least 1, rotation, and keep_existing (else a new run's files would be
    // the lowest numbers, the first deleted).
    for (max_files, rotate, keep_existing) in [
        (Some(0), ring.rotate, true),
        (Some(2), RotatePolicy::default(), true),
        (Some(2), ring.rotate, false),
    ] {
        let opts = RecorderOptions {
            max_files,
            rotate,
            keep_existing,
            ..Default::default()
        };
        let e = McapRecorder::create(dir.path().join("y.mcap"), opts).unwrap_err();
        assert!(e.to_string().contains("max_files"), "{e}");
    }
}

#[test]
fn bad_options_name_the_option() {
    let dir = tempfile::tempdir().unwrap();
    let opts = RecorderOptions {
        preview: Some(mosaicd::record::PreviewOptions { decimation: 0 }),
        ..Default::default()
    };
    let e = McapRecorder::create(dir.path().join("x.mcap"), opts).unwrap_err();
    assert!(e.to_string().contains("preview.decimation"), "{e}");
    let e =
        McapRecorder::create(dir.path().join("no/such/dir/x.mcap"), RecorderOptions::default()).unwrap_err();
    assert!(matches!(e, RecordError::Create { .. }), "{e}");
}

#[test]
fn replay_paces_loops_and_starts_late() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.mcap");
    record(&path, 5, RecorderOptions::default());
    let clock = Arc::new(FakeClock::new(0));
    let opts = McapSourceOptions {
        pacing: Pacing::Recorded { speed: 2.0 },
        looped: true,
        start_offset_ns: 2 * FRAME_NS,
        clock: clock.clone(),
        ..Default::default()
    };
    let mut src = McapSource::open(&path, opts).unwrap();
    assert_eq!(src.topic(), Some("/camera/raw"));
    let mut ts = Vec::new();
    for i in 0..7 {
        let f = src.next_frame().unwrap().unwrap();
        assert_eq!(f.meta.sequence, i);
        ts.push(f.meta.timestamp_ns);
    }
    let t0 = 5_000_000_000 + 2 * FRAME_NS;
    // Pass 1: frames 2,3,4; then frames 0..4 of pass 2 shifted by span (4 frames) + 1 interval.
    let shift = 5 * FRAME_NS;
    let want = vec![
        t0,
        t0 + FRAME_NS,
        t0 + 2 * FRAME_NS,
        5_000_000_000 + shift,
        5_000_000_000 + shift + FRAME_NS,
        5_000_000_000 + shift + 2 * FRAME_NS,
        5_000_000_000 + shift + 3 * FRAME_NS,
    ];
    assert_eq!(ts, want);
    // At speed 2 the paced clock advanced half the recorded span.
    assert_eq!(clock.now_ns(), (ts[6] - ts[0]) / 2);
    assert!(!src.is_finished());
    // A start past the last frame names the option, not a missing channel.
    let opts = McapSourceOptions {
        start_offset_ns: 60_000_000_000,
        ..Default::default()
    };
    let e = McapSource::open(&path, opts).unwrap().next_frame().unwrap_err();
    assert!(
        matches!(
            e,
            CaptureError::Option {
                name: "start_offset_ns",
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("all 5 raw frames are before it"), "{e}");
}

/// Foxglove compatibility: the JSON messages use exactly the property names and types of the
/// published `foxglove.RawImage` / `foxglove.ImageAnnotations` schemas (as embedded in the file).
#[test]
fn foxglove_messages_match_their_schemas() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.mcap");
    let opts = RecorderOptions {
        keypoints: true,
        ..RecorderOptions::default()
    };
    record(&path, 3, opts);
    let mut checked = 0;
    let mut keypoint_points = Vec::new();
    mosaicd::wire::for_each_message(&path, |m| {
        let Some(schema) = &m.channel.schema else {
            return Ok(());
        };
        if schema.encoding != "jsonschema" {
            return Ok(());
        }
        let s: serde_json::Value = serde_json::from_slice(&schema.data).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        check_against(&s, &v, &m.channel.topic);
        if schema.name == "foxglove.RawImage" {
            assert_eq!(v["encoding"], "bayer_gbrg8");
            assert_eq!(
                (v["width"].as_u64(), v["height"].as_u64(), v["step"].as_u64()),
                (Some(32), Some(24), Some(32))
            );
            let data = mosaicd::wire::schema::base64_decode(v["data"].as_str().unwrap()).unwrap();
            assert_eq!(data.len(), 32 * 24);
        }
        if m.channel.topic == "/camera/keypoints" {
            assert_eq!(schema.name, "foxglove.ImageAnnotations");
            let pts = v["points"].as_array().unwrap();
            keypoint_points.push(pts.first().map_or(0, |p| p["points"].as_array().unwrap().len()));
            if let Some(p) = pts.first() {
                assert_eq!(p["type"], 1, "POINTS");
                // Preview coordinates (decimation 2): x = (10 + k) / 2.
                assert_eq!(p["points"][0]["x"], 5.0);
            }
        }
        checked += 1;
        Ok(())
    })
    .unwrap();
    assert!(checked >= 15);
    assert_eq!(
        keypoint_points,
        vec![0, 1, 2],
        "one annotation per frame, i % 4 points"
    );
}

/// `/<camera>/sift` round trip: full-frame keypoints in the order given, and the descriptors,
/// base64 in the file, decode to the bytes written (none on frames written without them).
#[test]
fn sift_features_round_trip_with_and_without_descriptors() {
    use mosaicd::wire::schema::{SiftFeaturesMessage, SIFT_FEATURES_SCHEMA};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.mcap");
    let opts = RecorderOptions {
        keypoints: true,
        ..RecorderOptions::default()
    };
    record(&path, 6, opts);
    let topic = mosaicd::record::Topics::new("camera").sift;
    let info = RecordingInfo::read(&path).unwrap();
    assert_eq!(info.count(&topic), 6);
    let msgs = mosaicd::wire::read_json_topic::<SiftFeaturesMessage>(&path, &topic).unwrap();
    for (i, m) in msgs.iter().enumerate() {
        let i = i as u64;
        let t = frame(i, 64, 48).meta.timestamp_ns;
        assert_eq!(m.log_time, t);
        let s = &m.message;
        assert_eq!(
            (s.sequence, s.timestamp_ns, s.frame_width, s.frame_height),
            (i, t, 64, 48)
        );
        assert_eq!(s.keypoints, kps(i), "full-frame coordinates, not preview");
        let want = if i % 2 == 1 { descs(i) } else { Vec::new() };
        assert_eq!(s.decoded_descriptors().unwrap(), want, "frame {i}");
    }
    let mut schemas = 0;
    mosaicd::wire::for_each_message(&path, |m| {
        if m.channel.topic == topic {
            assert_eq!(m.channel.schema.as_ref().unwrap().name, SIFT_FEATURES_SCHEMA);
            schemas += 1;
        }
        Ok(())
    })
    .unwrap();
    assert_eq!(schemas, 6);
}

#[test]
fn keypoints_need_the_keypoints_channel() {
    let dir = tempfile::tempdir().unwrap();
    let mut rec = McapRecorder::create(dir.path().join("k.mcap"), RecorderOptions::default()).unwrap();
    let e = rec.write_keypoints(0, &kps(1)).unwrap_err();
    assert!(e.to_string().contains("keypoints"), "{e}");
    let e = rec.write_sift(0, 0, 64, 48, &kps(1), None).unwrap_err();
    assert!(e.to_string().contains("keypoints"), "{e}");
    // The recorder is not stopped by the refusal.
    rec.write_detections(0, 0, 64, 48, &det(1)).unwrap();
    rec.finish().unwrap();
}

#[test]
fn sift_features_refuse_descriptors_that_do_not_pair_with_the_keypoints() {
    let dir = tempfile::tempdir().unwrap();
    let opts = RecorderOptions {
        keypoints: true,
        ..RecorderOptions::default()
    };
    let path = dir.path().join("m.mcap");
    let mut rec = McapRecorder::create(&path, opts).unwrap();
    let e = rec
        .write_sift(0, 0, 64, 48, &kps(3), Some(&descs(2)))
        .unwrap_err();
    assert!(e.to_string().contains("2 for 3 keypoints"), "{e}");
    // Refused before anything was written; the recorder goes on.
    rec.write_sift(0, 0, 64, 48, &kps(3), Some(&descs(3))).unwrap();
    rec.finish().unwrap();
    let topic = mosaicd::record::Topics::new("camera").sift;
    assert_eq!(RecordingInfo::read(&path).unwrap().count(&topic), 1);
}

/// Every property of `v` is declared in `schema` with a matching JSON type.
fn check_against(schema: &serde_json::Value, v: &serde_json::Value, at: &str) {
    use serde_json::Value;
    if let Some(one_of) = schema.get("oneOf") {
        let consts: Vec<&Value> = one_of.as_array().unwrap().iter().map(|c| &c["const"]).collect();
        assert!(consts.contains(&v), "{at}: {v} not in {consts:?}");
        return;
    }
    let ty = schema.get("type").and_then(Value::as_str);
    match (ty, v) {
        (Some("object"), Value::Object(map)) => {
            if let Some(props) = schema.get("properties").and_then(Value::as_object) {
                for (k, val) in map {
                    let p = props
                        .get(k)
                        .unwrap_or_else(|| panic!("{at}: property {k} not in schema"));
                    check_against(p, val, &format!("{at}.{k}"));
                }
            }
        }
        (Some("array"), Value::Array(items)) => {
            for (i, it) in items.iter().enumerate() {
                check_against(&schema["items"], it, &format!("{at}[{i}]"));
            }
        }
        (Some("integer"), Value::Number(n)) => assert!(n.is_u64() || n.is_i64(), "{at}: {n} not an integer"),
        (Some("number"), Value::Number(_)) | (Some("string"), Value::String(_)) => {}
        (t, v) => panic!("{at}: {v} does not match type {t:?}"),
    }
}

/// A crash (no `finish`, no drop: as after SIGKILL) keeps every flushed frame: flushing every 3
/// frames and crashing after 10 leaves 9 readable frames, then a clear truncation error.
#[test]
fn crash_without_finish_keeps_flushed_frames() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("crash.mcap");
    let opts = RecorderOptions {
        flush: FlushPolicy {
            every_frames: Some(3),
            every_ns: None,
        },
        ..Default::default()
    };
    let mut rec = McapRecorder::create(&path, opts).unwrap();
    for i in 0..10 {
        rec.write_frame(&frame(i, 64, 48)).unwrap();
    }
    std::mem::forget(rec); // no summary, no final chunk: what SIGKILL leaves
    let (frames, err) = replay_all(&path);
    assert_eq!(frames.len(), 9);
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(f, &frame(i as u64, 64, 48));
    }
    assert!(
        matches!(err, Some(CaptureError::Truncated { frames: 9, .. })),
        "{err:?}"
    );
    // The summary reader refuses it clearly; a new recording at the same path starts cleanly.
    assert!(RecordingInfo::read(&path).is_err());
    record(&path, 2, RecorderOptions::default());
    assert_eq!(RecordingInfo::read(&path).unwrap().count("/camera/raw"), 2);
}

/// `start_new_file` (the daemon's SIGHUP) finishes the open file and the next write starts the
/// next numbered one; without `keep_existing` or rotation it is refused (it would truncate).
#[test]
fn start_new_file_finishes_this_file_and_numbers_the_next() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cam.mcap");
    let keep = RecorderOptions {
        keep_existing: true,
        ..Default::default()
    };
    let mut rec = McapRecorder::create(&path, keep).unwrap();
    rec.write_frame(&frame(0, 64, 48)).unwrap();
    assert!(matches!(rec.start_new_file(), Ok(true)));
    // Finished: complete with its summary, before anything else is written.
    let info = RecordingInfo::read(&path).unwrap();
    assert_eq!(info.count("/camera/raw"), 1);
    // Copied off the box and removed: the plain name is not used again.
    std::fs::remove_file(&path).unwrap();
    rec.write_frame(&frame(1, 64, 48)).unwrap();
    rec.finish().unwrap();
    assert_eq!(rec.files(), [path.clone(), dir.path().join("cam-0002.mcap")]);
    let (frames, err) = replay_all(&rec.files()[1]);
    assert!(err.is_none());
    assert_eq!(frames.len(), 1);

    // Overwriting, not rotating: refused, the file goes on.
    let mut rec = McapRecorder::create(dir.path().join("ow.mcap"), RecorderOptions::default()).unwrap();
    rec.write_frame(&frame(0, 64, 48)).unwrap();
    assert!(matches!(rec.start_new_file(), Ok(false)));
    assert!(!rec.can_resume());
    rec.write_frame(&frame(1, 64, 48)).unwrap();
    assert_eq!(rec.finish().unwrap().frames, 2);
}

/// A frame holding a value above its bit depth (a RawFrame may; a sensor's must not): the
/// recorder's preview shows it as the brightest value instead of indexing past its table, and
/// replay refuses the message as corrupt, naming the value, after delivering the frames before it.
#[test]
fn a_value_above_the_bit_depth_is_recorded_safely_and_refused_on_replay() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hot.mcap");
    let mut rec = McapRecorder::create(&path, RecorderOptions::default()).unwrap();
    for i in 0..2 {
        rec.write_frame(&frame(i, 64, 48)).unwrap();
    }
    let good = frame(2, 64, 48);
    let mut px = good.to_u16_vec();
    px[64 * 3 + 5] = 4096;
    let hot = RawFrame::from_u16(64, 48, px, Cfa::Gbrg, 12, *good.levels())
        .unwrap()
        .with_meta(good.meta.clone());
    rec.write_frame(&hot).unwrap();
    rec.finish().unwrap();
    let (frames, err) = replay_all(&path);
    assert_eq!(frames.len(), 2);
    let e = err.expect("the hot frame is refused");
    let msg = e.to_string();
    assert!(matches!(e, CaptureError::Corrupt { frames: 2, .. }), "{e:?}");
    assert!(msg.contains("4096 at (5, 3)") && msg.contains("12-bit"), "{msg}");
}

/// A file whose timestamps go backwards (not one of ours: the recorder writes capture times):
/// every frame is delivered, none is taken for one before the start, and a looped replay does not
/// overflow (this runs in debug builds, where it would panic); the second pass carries on from an
/// offset, not a wrap.
#[test]
fn looping_a_recording_whose_time_goes_backwards_does_not_overflow() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("back.mcap");
    let mut rec = McapRecorder::create(&path, RecorderOptions::default()).unwrap();
    for i in 0..3u64 {
        let mut f = frame(i, 64, 48);
        f.meta.timestamp_ns = 9_000_000_000 - i * FRAME_NS;
        rec.write_frame(&f).unwrap();
    }
    rec.finish().unwrap();
    let opts = McapSourceOptions {
        looped: true,
        ..Default::default()
    };
    let mut src = McapSource::open(&path, opts).unwrap();
    let ts: Vec<u64> = (0..6)
        .map(|_| src.next_frame().unwrap().unwrap().meta.timestamp_ns)
        .collect();
    assert_eq!(
        &ts[..3],
        &[
            9_000_000_000,
            9_000_000_000 - FRAME_NS,
            9_000_000_000 - 2 * FRAME_NS
        ]
    );
    for (a, b) in ts[..3].iter().zip(&ts[3..]) {
        assert!(b > a && b - a < 10 * FRAME_NS, "pass 2 {ts:?}");
    }
}

/// A recorder of frames only (`results: false`, what `mosaicd record` uses) declares no result
/// channel, so no channel in its file is empty, and refuses results with the option's name.
#[test]
fn a_frames_only_recording_declares_no_result_channels() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("frames.mcap");
    let opts = RecorderOptions {
        results: false,
        ..RecorderOptions::default()
    };
    let mut rec = McapRecorder::create(&p, opts).unwrap();
    for i in 0..3 {
        rec.write_frame(&frame(i, 64, 48)).unwrap();
    }
    for e in [
        rec.write_detections(0, 0, 64, 48, &det(0)).unwrap_err(),
        rec.write_stats(0, &serde_json::json!({})).unwrap_err(),
    ] {
        assert!(e.to_string().contains("results = false"), "{e}");
    }
    rec.finish().unwrap();
    let info = RecordingInfo::read(&p).unwrap();
    let got: Vec<(&str, u64)> = info
        .channels
        .values()
        .map(|c| (c.topic.as_str(), c.messages))
        .collect();
    assert_eq!(got, [("/camera/preview", 3), ("/camera/raw", 3)]);
}

/// With a wall-clock source every file (rotated ones too) starts with its `mosaicd.clock` record;
/// without one (the default: replays, recipes) there is none.
#[test]
fn the_wall_clock_record_is_written_per_file_only_when_asked() {
    use mosaicd::clock::{WallClock, WallClockSource};
    use mosaicd::record::WALL_CLOCK_METADATA;
    let dir = tempfile::tempdir().unwrap();
    let reading = WallClock {
        realtime_ns: 1_795_737_600_123_456_789,
        monotonic_ns: 5_000_000_000,
    };
    let meta = |p: &Path| {
        let buf = std::fs::read(p).unwrap();
        let s = mcap::Summary::read(&buf).unwrap().unwrap();
        s.metadata_indexes
            .iter()
            .map(|i| mcap::read::metadata(&buf, i).unwrap())
            .collect::<Vec<_>>()
    };
    let p = dir.path().join("clock.mcap");
    let s = record(
        &p,
        4,
        RecorderOptions {
            wall_clock: Some(WallClockSource::Fixed(reading)),
            rotate: RotatePolicy {
                bytes: None,
                duration_ns: Some(60_000_000),
            },
            ..RecorderOptions::default()
        },
    );
    assert!(s.files.len() > 1, "{:?}", s.files);
    for f in &s.files {
        let m = meta(f);
        assert_eq!(m.len(), 1, "{}", f.display());
        assert_eq!(m[0].name, WALL_CLOCK_METADATA);
        let kv = &m[0].metadata;
        assert_eq!(kv["timestamps"], "CLOCK_MONOTONIC");
        assert_eq!(kv["realtime_minus_monotonic_ns"], "1795737595123456789");
        assert_eq!(kv["realtime_ns"], "1795737600123456789");
        assert_eq!(kv["monotonic_ns"], "5000000000");
        assert_eq!(kv["realtime_utc"], "2026-11-27T00:00:00.123456789Z");
    }
    let plain = dir.path().join("plain.mcap");
    record(&plain, 2, RecorderOptions::default());
    assert!(meta(&plain).is_empty());
}
