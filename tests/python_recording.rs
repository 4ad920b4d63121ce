//! `clients/python/read_recording.py` (the `mcap` package from PyPI) reads our recordings: the raw
//! frames it returns are, pixel for pixel and field for field, the frames our own reader decodes;
//! a recording cut short yields the frames before the cut and then a clear error; a corrupt frame
//! message is a `ValueError` naming what is wrong. Needs the packages of
//! `clients/python/requirements.txt` (`make setup`).

use std::path::{Path, PathBuf};
use std::process::Command;

use mosaicd::npy::NpyArray;
use mosaicd::raw::RawFrame;
use mosaicd::wire::for_each_message;
use mosaicd::wire::schema::{decode_raw_frame, RAW_FRAME_ENCODING};

fn client_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("clients/python")
}

fn recording() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/synthetic_pan.mcap")
}

fn read_recording(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new("python3")
        .arg(client_dir().join("read_recording.py"))
        .args(args)
        .output()
        .expect("python3 runs")
}

/// The raw frames of `path` as our reader decodes them.
fn rust_frames(path: &Path) -> Vec<RawFrame> {
    let mut out = Vec::new();
    for_each_message(path, |m| {
        if m.channel.message_encoding == RAW_FRAME_ENCODING {
            out.push(decode_raw_frame(&m.data).unwrap());
        }
        Ok(())
    })
    .unwrap();
    out
}

/// Python's JSON line of a frame matches the frame.
fn assert_same_header(line: &serde_json::Value, f: &RawFrame) {
    assert_eq!(line["sequence"].as_u64(), Some(f.meta.sequence));
    assert_eq!(line["timestamp_ns"].as_u64(), Some(f.meta.timestamp_ns));
    assert_eq!(
        (line["width"].as_u64(), line["height"].as_u64()),
        (Some(f.width() as u64), Some(f.height() as u64))
    );
    assert_eq!(line["cfa"].as_str(), Some(f.cfa().to_string().as_str()));
    assert_eq!(line["bit_depth"].as_u64(), Some(u64::from(f.bit_depth())));
    assert_eq!(line["white"].as_u64(), Some(u64::from(f.levels().white)));
    let black: Vec<u64> = f.levels().black.iter().map(|&b| u64::from(b)).collect();
    assert_eq!(line["black"], serde_json::json!(black));
    let px = f.to_u16_vec();
    assert_eq!(line["max"].as_u64(), px.iter().max().map(|&v| u64::from(v)));
}

#[test]
fn python_reads_the_raw_frames_our_reader_decodes() {
    let dir = tempfile::tempdir().unwrap();
    let npy = dir.path().join("npy");
    let out = read_recording(&[recording().as_os_str(), "--npy".as_ref(), npy.as_os_str()]);
    assert!(
        out.status.success(),
        "read_recording failed (run `make setup`): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let frames = rust_frames(&recording());
    assert_eq!((lines.len(), frames.len()), (12, 12));
    for (line, f) in lines.iter().zip(&frames) {
        assert_same_header(line, f);
        let a = NpyArray::read(npy.join(format!("{}.npy", f.meta.sequence))).unwrap();
        assert_eq!(a.shape, vec![f.height(), f.width()]);
        let want: Vec<f64> = f.to_u16_vec().into_iter().map(f64::from).collect();
        assert_eq!(a.data, want, "frame {}", f.meta.sequence);
    }
}

#[test]
fn a_cut_recording_gives_the_frames_before_the_cut_and_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let cut = dir.path().join("cut.mcap");
    let bytes = std::fs::read(recording()).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() * 3 / 8]).unwrap();
    let out = read_recording(&[cut.as_os_str()]);
    assert_eq!(
        out.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cut short after") && err.contains("complete messages"),
        "{err}"
    );
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let frames = rust_frames(&recording());
    assert!(
        !lines.is_empty() && lines.len() < frames.len(),
        "{} frames",
        lines.len()
    );
    for (line, f) in lines.iter().zip(&frames) {
        assert_same_header(line, f);
    }
}

/// A recording of bare (unchunked) Message records cut inside a Message's record header (in its
/// opcode and length) or inside its fixed fields (channel id, sequence, times): a cut like any
/// other, exit 3, not exit 2 for an unreadable file (the reader used to unpack the short bytes and
/// fail with `struct.error`).
#[test]
fn a_bare_message_cut_inside_its_header_is_a_cut() {
    let mut buf = std::io::Cursor::new(Vec::new());
    {
        let mut w = mcap::WriteOptions::new()
            .use_chunks(false)
            .create(&mut buf)
            .unwrap();
        let schema = w.add_schema("note", "jsonschema", b"{}").unwrap();
        let channel = w
            .add_channel(schema, "/notes", "json", &Default::default())
            .unwrap();
        for sequence in 0..2 {
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence,
                log_time: u64::from(sequence),
                publish_time: u64::from(sequence),
            };
            w.write_to_known_channel(&header, br#"{"n":1}"#).unwrap();
        }
        w.finish().unwrap();
    }
    let bytes = buf.into_inner();
    // The records after the magic: opcode (1 byte), length (8), body. The second Message.
    let mut at = 8;
    let mut messages = Vec::new();
    while at + 9 <= bytes.len() {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        if bytes[at] == 0x05 {
            messages.push(at);
        }
        at += 9 + len;
    }
    assert_eq!(messages.len(), 2, "two bare Message records");
    let second = messages[1];
    let dir = tempfile::tempdir().unwrap();
    let cut = dir.path().join("cut.mcap");
    // In the length, in the channel id, in the sequence, in the publish time.
    for into in [5, 10, 12, 30] {
        std::fs::write(&cut, &bytes[..second + into]).unwrap();
        let out = read_recording(&[cut.as_os_str(), "--topic".as_ref(), "/notes".as_ref()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(
            out.status.code(),
            Some(3),
            "cut {into} bytes into the record: {err}"
        );
        assert!(
            err.contains("cut short after 1 complete messages"),
            "cut {into} bytes into the record: {err}"
        );
        assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 1);
    }
}

#[test]
fn a_corrupt_frame_message_is_a_value_error_naming_it() {
    let script = r#"
import sys
sys.path.insert(0, sys.argv[1])
from read_recording import decode_raw_frame
import json, struct
head = json.dumps({"width": 4, "height": 2, "container_bits": 16}).encode()
good = b"MRF1" + struct.pack("<I", len(head)) + head + bytes(16)
h, m = decode_raw_frame(good)
assert m.shape == (2, 4), m.shape
for bad in [b"RIFF" + good[4:], good[:-2], b"MRF1" + struct.pack("<I", 999) + head,
            b"MRF1" + struct.pack("<I", 2) + b"{]" + bytes(16)]:
    try:
        decode_raw_frame(bad, "frame 7")
    except ValueError as e:
        assert "frame 7" in str(e), e
        print(e)
    else:
        raise SystemExit(f"accepted {bad[:12]!r}")
"#;
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(client_dir())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    for says in [
        "not a mosaicd.RawFrame",
        "pixel bytes",
        "runs past",
        "bad frame header",
    ] {
        assert!(text.contains(says), "{says}: {text}");
    }
}

/// A recording with damaged bytes fails its CRC check and a file that is not MCAP at all is
/// refused: both exit 2 with one line naming the file, never data read past the damage.
#[test]
fn damaged_and_foreign_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = std::fs::read(recording()).unwrap();
    let at = bytes.len() / 2;
    for b in &mut bytes[at..at + 16] {
        *b ^= 0xff;
    }
    let damaged = dir.path().join("damaged.mcap");
    std::fs::write(&damaged, &bytes).unwrap();
    let readme = Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    for (file, says) in [(&damaged, "crc validation failed"), (&readme, "invalid magic")] {
        let out = read_recording(&[file.as_os_str()]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&*file.display().to_string()) && err.contains(says),
            "{err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    // What the damaged file did yield is the frames before the damaged chunk, unchanged.
    let out = read_recording(&[damaged.as_os_str()]);
    let frames = rust_frames(&recording());
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(lines.len() < frames.len());
    for (line, f) in lines.iter().zip(&frames) {
        assert_same_header(line, f);
    }
}

/// A recording without a raw channel (results only) or a topic it does not hold: the script says
/// so, lists the channels the file holds, and exits 1 instead of printing nothing and exiting 0.
#[test]
fn a_recording_without_raw_frames_or_the_topic_is_said_and_exits_1() {
    use mosaicd::record::{McapRecorder, RecorderOptions};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("results.mcap");
    let mut rec = McapRecorder::create(
        &path,
        RecorderOptions {
            camera: "cam".into(),
            raw: false,
            preview: None,
            ..RecorderOptions::default()
        },
    )
    .unwrap();
    rec.write_detections(0, 0, 64, 48, &[]).unwrap();
    rec.finish().unwrap();
    for (args, says) in [
        (vec![path.as_os_str()], "no raw frame"),
        (
            vec![path.as_os_str(), "--topic".as_ref(), "/cam/nothing".as_ref()],
            "no message on /cam/nothing",
        ),
    ] {
        let out = read_recording(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(out.stdout.is_empty());
        assert!(
            err.contains(says) && err.contains("/cam/detections (json)"),
            "{err}"
        );
    }
    // The topic it does hold prints and exits 0.
    let out = read_recording(&[path.as_os_str(), "--topic".as_ref(), "/cam/detections".as_ref()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 1);
}
