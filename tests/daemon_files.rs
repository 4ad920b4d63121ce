//! `source = "files"`: the daemon plays a directory of raw files as a stream (DESIGN's "raw files"
//! capture). Headerless frames described by a directory sidecar, a broken file counted as a source
//! failure without losing the others, and results identical for any thread count.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::frame_results;

/// Three 160x128 8-bit GRBG frames, a directory sidecar, and a truncated frame that sorts first.
fn frames(dir: &Path) {
    for i in 0..3usize {
        let data: Vec<u8> = (0..128usize)
            .flat_map(|y| (0..160usize).map(move |x| ((x * 7 + y * 3 + i * 11) % 256) as u8))
            .collect();
        std::fs::write(dir.join(format!("f{i}.raw")), data).unwrap();
    }
    std::fs::write(
        dir.join("mosaicd-raw.toml"),
        "width = 160\nheight = 128\nbit_depth = 8\ncfa = \"GRBG\"\nblack = 4\nwhite = 255\n",
    )
    .unwrap();
    std::fs::write(dir.join("broken.raw"), [0u8; 100]).unwrap();
}

fn run(cfg: &Path, threads: &str, results: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args([
            "run",
            "--config",
            cfg.to_str().unwrap(),
            "--no-publish",
            "--threads",
            threads,
        ])
        .args(["--results", results.to_str().unwrap()])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

#[test]
fn a_directory_of_raw_files_plays_as_a_stream_and_a_broken_file_is_counted() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("raw");
    std::fs::create_dir(&raw).unwrap();
    frames(&raw);
    let cfg = dir.path().join("files.toml");
    std::fs::write(
        &cfg,
        format!(
            "[compute]\nmodel = \"mosaic\"\n[[camera]]\nname = \"files\"\nsource = \"files\"\n\
             path = {:?}\nfps = 10.0\n",
            raw.to_str().unwrap()
        ),
    )
    .unwrap();
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let results = dir.path().join(format!("results-{threads}.jsonl"));
        let o = run(&cfg, threads, &results);
        let err = String::from_utf8_lossy(&o.stderr);
        let text = format!("{}{err}", String::from_utf8_lossy(&o.stdout));
        assert!(text.contains("3 frames processed of 3 captured"), "{text}");
        assert!(text.contains("failed: source 1"), "{text}");
        // The input went on after the broken file, which is reported, named and counted, and
        // the exit status of a run that reached the end of its input says so.
        assert!(!o.status.success(), "{text}");
        assert!(err.contains("broken.raw") && err.contains("needs 20480"), "{err}");
        assert!(
            err.contains("1 frame(s) of the input could not be read and were skipped")
                && !err.contains("input ended"),
            "{err}"
        );
        // Frame results without their wall-clock fields (latency) are deterministic.
        let frames = frame_results(&results);
        assert_eq!(frames.len(), 3, "{frames:?}");
        assert_eq!(
            frames[2]["capture_timestamp_ns"], 200_000_000,
            "timestamps at fps 10"
        );
        outputs.push(frames);
    }
    assert_eq!(outputs[0], outputs[1], "results differ between 1 and 2 threads");
}

/// The srgb mosaic tone (`models/mosaic_raw_srgb.json`) on headerless frames, which carry no
/// white-balance gains: `wb_gains = "file"` fails every frame with a clear error and the daemon
/// goes on to the end of its input; the default `auto` white balances each frame by grey world,
/// with results identical for any thread count.
#[test]
fn the_srgb_tone_needs_gains_file_gains_fail_clearly_and_auto_uses_grey_world() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("raw");
    std::fs::create_dir(&raw).unwrap();
    frames(&raw);
    let config = |gains: &str| {
        let cfg = dir.path().join(format!("srgb-{gains}.toml"));
        std::fs::write(
            &cfg,
            format!(
                "[compute]\nmodel = \"mosaic-raw-srgb\"\nhit_threshold = -10.0\nwb_gains = {gains:?}\n\
                 [[camera]]\nname = \"files\"\nsource = \"files\"\npath = {:?}\nfps = 10.0\n",
                raw.to_str().unwrap()
            ),
        )
        .unwrap();
        cfg
    };
    let results = dir.path().join("file.jsonl");
    let o = run(&config("file"), "2", &results);
    let err = String::from_utf8_lossy(&o.stderr);
    let text = format!("{}{err}", String::from_utf8_lossy(&o.stdout));
    assert!(text.contains("failed: source 1 compute 3"), "{text}");
    assert!(err.contains("white balance") && err.contains("has none"), "{err}");
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let results = dir.path().join(format!("auto-{threads}.jsonl"));
        let o = run(&config("auto"), threads, &results);
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(text.contains("3 frames processed of 3 captured"), "{text}");
        assert!(text.contains("failed: source 1 compute 0"), "{text}");
        let frames = frame_results(&results);
        assert_eq!(frames.len(), 3, "{frames:?}");
        outputs.push(frames);
    }
    assert_eq!(outputs[0], outputs[1], "results differ between 1 and 2 threads");
    // with a hit threshold this low the model fires somewhere: the tone path ran the detector
    let hits: usize = outputs[0]
        .iter()
        .map(|f| f["detections"].as_array().map_or(0, |d| d.len()))
        .sum();
    assert!(hits > 0, "{:?}", outputs[0]);
}
