//! Recipes under recordings/: the committed synthetic recording is rebuilt byte for byte (golden;
//! `REGENERATE=1` rewrites it), the demo recipe over a real sensor frame records exactly the crops
//! of that frame (lossless, re-phased at odd offsets), and `mosaicd record` runs end to end.

use std::path::{Path, PathBuf};

use mosaicd::capture::{McapSource, McapSourceOptions, Source};
use mosaicd::raw::Cfa;
use mosaicd::record::{build_recording, crop_origin, Recipe};
use mosaicd::wire::RecordingInfo;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn frames_of(path: &Path) -> Vec<mosaicd::raw::RawFrame> {
    let mut src = McapSource::open(path, McapSourceOptions::default()).unwrap();
    let mut v = Vec::new();
    while let Some(f) = src.next_frame().unwrap() {
        v.push(f);
    }
    v
}

#[test]
fn synthetic_recording_matches_its_recipe_byte_for_byte() {
    let recipe = Recipe::load(root().join("recordings/synthetic_pan.toml")).unwrap();
    let golden = root().join(&recipe.output);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("synthetic_pan.mcap");
    build_recording(&recipe, Path::new("/nonexistent-data"), Some(&out), |_, _| {}).unwrap();
    if std::env::var_os("REGENERATE").is_some() {
        std::fs::copy(&out, &golden).unwrap();
    }
    let want = std::fs::read(&golden).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (rebuild with `mosaicd record --recipe recordings/synthetic_pan.toml`)",
            golden.display()
        )
    });
    assert!(want.len() < 5 * 1024 * 1024, "committed recording too large");
    assert_eq!(
        std::fs::read(&out).unwrap(),
        want,
        "recipe output differs from {}; REGENERATE=1 to accept",
        golden.display()
    );

    // A recording of frames declares no channel that holds no message (results channels are
    // the daemon's, not `mosaicd record`'s).
    let info = RecordingInfo::read(&golden).unwrap();
    let topics: Vec<(&str, u64)> = info
        .channels
        .values()
        .map(|c| (c.topic.as_str(), c.messages))
        .collect();
    assert_eq!(
        topics,
        [("/camera/preview", recipe.frames), ("/camera/raw", recipe.frames)],
        "channels and their messages"
    );

    let frames = frames_of(&golden);
    assert_eq!(frames.len() as u64, recipe.frames);
    let mut phases = std::collections::BTreeSet::new();
    for (i, f) in frames.iter().enumerate() {
        let (x, y) = crop_origin(
            &recipe.motion.waypoints,
            i as u64,
            recipe.frames,
            recipe.motion.align,
        );
        assert_eq!(f.cfa(), Cfa::Grbg.shifted(x, y), "frame {i} at ({x},{y})");
        assert_eq!((f.width(), f.height(), f.bit_depth()), (160, 120, 10));
        phases.insert(f.cfa().name());
    }
    assert!(
        phases.len() >= 3,
        "odd offsets should visit several phases: {phases:?}"
    );
    let info = RecordingInfo::read(&golden).unwrap();
    assert_eq!(info.count("/camera/raw"), 12);
    assert_eq!(info.count("/camera/preview"), 12);
}

#[test]
fn park_recipe_records_exact_crops_of_the_real_frame() {
    let data_file = mosaicd::data::require("raw/infinite_isp_8bit/Outdoor1_2592x1536_8bit_GRBG.raw");
    let data_root = data_file.ancestors().nth(3).unwrap().to_path_buf();
    let mut recipe = Recipe::load(root().join("recordings/park.toml")).unwrap();
    recipe.frames = 7; // the same path, sampled more coarsely, keeps the test quick
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("park.mcap");
    build_recording(&recipe, &data_root, Some(&out), |_, _| {}).unwrap();
    let still = std::fs::read(&data_file).unwrap();
    let frames = frames_of(&out);
    assert_eq!(frames.len(), 7);
    for (i, f) in frames.iter().enumerate() {
        let (x0, y0) = crop_origin(&recipe.motion.waypoints, i as u64, 7, recipe.motion.align);
        assert_eq!(f.cfa(), Cfa::Grbg.shifted(x0, y0));
        assert_eq!(f.levels().black, [12; 4]);
        for (y, x) in [(0, 0), (1, 1), (719, 1279), (300, 641)] {
            assert_eq!(
                f.value(x, y),
                still[(y0 + y) * 2592 + x0 + x] as u16,
                "frame {i} ({x},{y})"
            );
        }
    }
    // The last frame sits at the far waypoint (odd offsets 1311, 815: GRBG seen from (1,1) is GBRG).
    assert_eq!(frames[6].cfa(), Cfa::Gbrg);
}

/// The quick-start recipe: a sequence of 20 USC frames through the reverse ISP, each scaled 2.5x;
/// frame `i` shows file `i mod 20`, so the scene moves and the sequence repeats exactly.
#[test]
fn demo_recipe_plays_its_image_sequence_through_the_reverse_isp() {
    let first = mosaicd::data::require("pedestrian/usc/USCPedestrianSetB/OSME1cor_0.bmp");
    let data_root = first.ancestors().nth(4).unwrap().to_path_buf();
    let mut recipe = Recipe::load(root().join("recordings/demo.toml")).unwrap();
    assert_eq!(recipe.source.files.len(), 20);
    assert_eq!(recipe.frames % 20, 0, "whole passes of the sequence");
    // Two images only, three frames: the third shows the first image again.
    recipe.source.files.truncate(2);
    recipe.frames = 3;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo.mcap");
    build_recording(&recipe, &data_root, Some(&out), |_, _| {}).unwrap();
    let frames = frames_of(&out);
    assert_eq!(frames.len(), 3);
    for f in &frames {
        assert_eq!(
            (f.width(), f.height(), f.cfa(), f.bit_depth()),
            (960, 720, Cfa::Grbg, 12)
        );
    }
    assert_ne!(frames[0].to_u16_vec(), frames[1].to_u16_vec(), "the scene moves");
    assert_eq!(
        frames[0].to_u16_vec(),
        frames[2].to_u16_vec(),
        "and the sequence repeats"
    );
    assert_eq!(frames[2].meta.timestamp_ns, 400_000_000, "5 fps");
    // `files` is for RGB sources, without `file`.
    let mut bad = recipe.clone();
    bad.source.kind = "raw".into();
    assert!(bad.validate().unwrap_err().to_string().contains("source.files"));
    let mut bad = recipe;
    bad.source.scale = Some(0.0);
    assert!(bad.validate().unwrap_err().to_string().contains("source.scale"));
}

#[test]
fn cli_records_files_and_motion_and_reports_bad_input() {
    let exe = env!("CARGO_BIN_EXE_mosaicd");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (i, name) in ["f0.raw", "f1.raw", "f2.raw"].iter().enumerate() {
        std::fs::write(d.join(name), vec![i as u8 * 40 + 5; 8 * 6]).unwrap();
    }
    std::fs::write(
        d.join("mosaicd-raw.toml"),
        "width = 8\nheight = 6\nbit_depth = 8\ncfa = \"BGGR\"\n",
    )
    .unwrap();
    let out = d.join("files.mcap");
    let st = std::process::Command::new(exe)
        .args(["record", d.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    // stderr is a pipe here (as in CI): no progress bar and no progress lines, only the log.
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(
        !err.contains('\r') && !err.contains('\x1b') && !err.contains("3 frames"),
        "{err:?}"
    );
    let frames = frames_of(&out);
    assert_eq!(frames.len(), 3);
    assert_eq!(frames[2].value(3, 3), 85);
    assert_eq!(frames[1].meta.timestamp_ns, 33_333_333);

    // Motion recordings: 4x4 crops of f0.raw moved as the flags say.
    let motion = |out: &Path, extra: &[&str]| {
        let st = std::process::Command::new(exe)
            .args(["record", d.join("f0.raw").to_str().unwrap(), "--sidecar"])
            .arg(d.join("mosaicd-raw.toml"))
            .args(["--crop", "4x4"])
            .args(extra)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap();
        assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
        String::from_utf8_lossy(&st.stdout).into_owned()
    };
    // Motion over one raw still with odd offsets.
    let out2 = d.join("motion.mcap");
    motion(&out2, &["--path", "0,0:3,1", "--frames", "4", "--noise", "low"]);
    let frames = frames_of(&out2);
    assert_eq!(frames.last().map(|f| f.cfa()), Some(Cfa::Bggr.shifted(3, 1)));
    // Rotation applies to a motion recording too: 4 frames at 2 fps, a new file after 1 s.
    let stdout = motion(
        &d.join("rot.mcap"),
        &["--frames", "4", "--fps", "2", "--rotate-secs", "1"],
    );
    let parts = [d.join("rot-0001.mcap"), d.join("rot-0002.mcap")];
    for p in &parts {
        assert!(stdout.contains(&*p.display().to_string()), "{stdout}");
    }
    assert_eq!(frames_of(&parts[0]).len() + frames_of(&parts[1]).len(), 4);
    assert_eq!(frames_of(&parts[1])[0].meta.timestamp_ns, 1_000_000_000);
    // 0 means never, as in the daemon's [record] keys: one file, the plain path.
    let out4 = d.join("norot.mcap");
    motion(
        &out4,
        &["--frames", "3", "--rotate-mb", "0", "--rotate-secs", "0"],
    );
    assert_eq!(frames_of(&out4).len(), 3);
    assert!(!d.join("norot-0001.mcap").exists());

    // A recipe carries its own settings: other flags are refused, not ignored.
    let st = std::process::Command::new(exe)
        .args([
            "record",
            "--recipe",
            "recordings/synthetic_pan.toml",
            "--camera",
            "foo",
            "-o",
        ])
        .arg(d.join("r.mcap"))
        .current_dir(root())
        .output()
        .unwrap();
    assert!(!st.status.success());
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(err.contains("--recipe") && err.contains("--camera"), "{err}");
    assert!(!d.join("r.mcap").exists());

    let st = std::process::Command::new(exe)
        .args([
            "record",
            "--device",
            "/dev/video-mosaicd-absent",
            "--frames",
            "3",
            "-o",
        ])
        .arg(d.join("x.mcap"))
        .output()
        .unwrap();
    assert!(!st.status.success());
    let err = String::from_utf8_lossy(&st.stderr);
    assert!(err.contains("does not exist"), "{err}");
}
