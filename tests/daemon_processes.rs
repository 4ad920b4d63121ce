//! The daemon as real processes: `mosaicd run` publishing over real iceoryx2 shared memory to a
//! `mosaicd listen` process, results files, signals, crashes and bad inputs.
//!
//! Every test uses its own service prefix and camera name (tests run in parallel) and a synthetic
//! source (`source = "synthetic"`), so no data files are needed.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use mosaicd::pipeline::strip_wall_clock;

mod common;

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");

fn unique(tag: &str) -> String {
    format!("t{}{tag}", std::process::id())
}

fn config(dir: &Path, prefix: &str, camera: &str, extra_camera: &str, publish: bool) -> PathBuf {
    let p = dir.join(format!("{camera}.toml"));
    let size = if extra_camera.contains("width") {
        ""
    } else {
        "width = 96\nheight = 64\n"
    };
    std::fs::write(
        &p,
        format!(
            "[daemon]\nthreads = 2\nstats_interval_ms = 200\nshutdown_timeout_ms = 20000\n\
             [publish]\nenabled = {publish}\nservice_prefix = \"{prefix}\"\nsubscriber_buffer = 256\n\
             [[camera]]\nname = \"{camera}\"\nsource = \"synthetic\"\n{size}{extra_camera}\n"
        ),
    )
    .unwrap();
    p
}

fn daemon(cfg: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.arg("run")
        .arg("--config")
        .arg(cfg)
        .args(args)
        .env("RUST_LOG", "warn");
    c
}

fn wait_timeout(child: &mut Child, limit: Duration) -> Option<std::process::ExitStatus> {
    let start = Instant::now();
    while start.elapsed() < limit {
        if let Some(s) = child.try_wait().unwrap() {
            return Some(s);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let _ = child.kill();
    None
}

fn lines(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn frames(records: &[serde_json::Value]) -> Vec<u64> {
    records
        .iter()
        .filter(|r| r["type"] == "frame")
        .map(|r| r["index"].as_u64().unwrap())
        .collect()
}

fn stderr_of(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn every_frame_yields_one_detections_message_received_by_a_listen_process() {
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (unique("lp"), unique("lc"));
    let n = 40;
    let cfg = config(dir.path(), &prefix, &camera, &format!("frames = {n}"), true);
    let listener = common::spawn_listener(
        BIN,
        &[
            "--camera",
            &camera,
            "--prefix",
            &prefix,
            "--buffer",
            "256",
            "--until-final",
            "--timeout-s",
            "60",
        ],
    );
    let out = daemon(&cfg, &[]).output().unwrap();
    assert!(out.status.success(), "daemon failed: {}", stderr_of(&out));
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(
        summary.contains(&format!("{n} frames processed of {n} captured")),
        "{summary}"
    );
    assert!(summary.contains("latency p50"), "{summary}");
    let lout = listener.wait_with_output().unwrap();
    assert!(lout.status.success());
    let text = String::from_utf8_lossy(&lout.stdout);
    let msgs: Vec<serde_json::Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let idx: Vec<u64> = msgs
        .iter()
        .filter(|m| m["topic"] == "detections")
        .map(|m| m["index"].as_u64().unwrap())
        .collect();
    assert_eq!(
        idx,
        (0..n).collect::<Vec<_>>(),
        "exactly one message per frame, in order"
    );
    let finals: Vec<_> = msgs
        .iter()
        .filter(|m| m["topic"] == "stats" && m["is_final"] == 1)
        .collect();
    assert_eq!(finals.len(), 1);
    assert_eq!(finals[0]["processed"], n);
    assert!(msgs
        .iter()
        .filter(|m| m["topic"] == "detections")
        .all(|m| m["frame_width"] == 96));
}

/// Golden results of the synthetic replay, compared byte for byte after removing wall-clock
/// fields; `REGENERATE=1` rewrites the golden file.
#[test]
fn replay_results_are_byte_identical_for_1_2_4_threads_twice_and_match_the_golden() {
    let dir = tempfile::tempdir().unwrap();
    let camera = "golden";
    let cfg = config(
        dir.path(),
        &unique("gp"),
        camera,
        "frames = 12\nwidth = 160\nheight = 128",
        false,
    );
    let mut texts = Vec::new();
    for round in 0..2 {
        for threads in ["1", "2", "4"] {
            let out_path = dir.path().join(format!("r{round}-{threads}.jsonl"));
            let out = daemon(
                &cfg,
                &["--threads", threads, "--max-in-flight", threads, "--results"],
            )
            .arg(&out_path)
            .output()
            .unwrap();
            assert!(out.status.success(), "{}", stderr_of(&out));
            let text = strip_wall_clock(&std::fs::read_to_string(&out_path).unwrap());
            assert_eq!(frames(&lines(&out_path)), (0..12).collect::<Vec<_>>());
            texts.push((format!("round {round}, {threads} threads"), text));
        }
    }
    for (name, t) in &texts[1..] {
        assert_eq!(t, &texts[0].1, "{name} differs from round 0, 1 thread");
    }
    let golden =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/golden/daemon-synthetic-160x128.jsonl");
    if std::env::var_os("REGENERATE").is_some() {
        std::fs::create_dir_all(golden.parent().unwrap()).unwrap();
        std::fs::write(&golden, &texts[0].1).unwrap();
    }
    let want = std::fs::read_to_string(&golden)
        .unwrap_or_else(|e| panic!("{}: {e} (run with REGENERATE=1 to create it)", golden.display()));
    assert_eq!(texts[0].1, want, "results differ from {}", golden.display());
}

#[test]
fn sigterm_mid_run_drains_and_exits_zero_with_complete_results() {
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (unique("sp"), unique("sc"));
    // Endless stream (frames = 0): only a signal ends it.
    let cfg = config(dir.path(), &prefix, &camera, "frames = 0", true);
    let results = dir.path().join("r.jsonl");
    let mut child = daemon(&cfg, &["--results"])
        .arg(&results)
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    // Let it process some frames.
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(30) {
        if std::fs::metadata(&results)
            .map(|m| m.len() > 20_000)
            .unwrap_or(false)
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: plain kill(2) on our own child's pid.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let status = wait_timeout(&mut child, Duration::from_secs(20)).expect("exited within the stop timeout");
    assert!(status.success(), "{status:?}");
    let records = lines(&results);
    let last = records.last().unwrap();
    assert_eq!(last["type"], "final_stats", "final stats written last");
    let idx = frames(&records);
    assert!(!idx.is_empty());
    assert_eq!(
        idx,
        (0..idx.len() as u64).collect::<Vec<_>>(),
        "no gap: every captured frame drained"
    );
    assert_eq!(last["processed"], idx.len() as u64);
    assert_eq!(
        last["captured"],
        idx.len() as u64,
        "everything captured was processed"
    );
}

#[test]
fn sigkill_leaves_stale_shared_memory_that_the_next_start_cleans() {
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (unique("kp"), unique("kc"));
    let cfg = config(dir.path(), &prefix, &camera, "frames = 0", true);
    let mut child = daemon(&cfg, &[]).stdout(Stdio::null()).spawn().unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    // Same names again: must start, run and exit cleanly.
    let cfg2 = config(dir.path(), &prefix, &camera, "frames = 10", true);
    let out = daemon(&cfg2, &[]).output().unwrap();
    assert!(
        out.status.success(),
        "restart after SIGKILL failed: {}",
        stderr_of(&out)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("10 frames processed"));
}

#[test]
fn bad_config_value_is_refused_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), "p", "c", "bit_depth = 20", false);
    let out = daemon(&cfg, &[]).output().unwrap();
    assert!(!out.status.success());
    let err = stderr_of(&out);
    assert!(
        err.contains("camera[0].bit_depth") && err.contains("8..=16"),
        "{err}"
    );
    let out = daemon(&config(dir.path(), "p", "c2", "", false), &["--threads", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(stderr_of(&out).contains("daemon.threads"), "{}", stderr_of(&out));
}

#[test]
fn missing_device_and_missing_recording_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cam.toml");
    std::fs::write(
        &p,
        "[[camera]]\nname = \"front\"\nsource = \"v4l2\"\ndevice = \"/dev/video-does-not-exist\"\n",
    )
    .unwrap();
    let out = daemon(&p, &["--no-publish"]).output().unwrap();
    assert!(!out.status.success());
    let err = stderr_of(&out);
    assert!(
        err.contains("/dev/video-does-not-exist") && err.contains("does not exist"),
        "{err}"
    );

    let out = Command::new(BIN)
        .args(["replay", "/nonexistent/rec.mcap", "--no-publish"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = stderr_of(&out);
    assert!(
        err.contains("/nonexistent/rec.mcap") && err.contains("not found"),
        "{err}"
    );
}

#[test]
fn gradient_maps_are_published_as_decimated_slices() {
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (unique("gp2"), unique("gc2"));
    // Paced (live, 100 fps): a dynamic-slice subscriber maps the publisher's data segment on its
    // first receive, which must happen while the publisher still exists (iceoryx2 "lost chunk").
    let cfg = config(
        dir.path(),
        &prefix,
        &camera,
        "frames = 20\nlive = true\nfps = 100.0",
        true,
    );
    let listener = common::spawn_listener(
        BIN,
        &[
            "--camera",
            &camera,
            "--prefix",
            &prefix,
            "--buffer",
            "256",
            "--until-final",
            "--gradients",
            "--timeout-s",
            "60",
        ],
    );
    let out = daemon(&cfg, &["--publish-gradients"]).output().unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let lout = listener.wait_with_output().unwrap();
    assert!(lout.status.success());
    let msgs: Vec<serde_json::Value> = String::from_utf8_lossy(&lout.stdout)
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .collect();
    let grads: Vec<&serde_json::Value> = msgs.iter().filter(|m| m["topic"] == "gradients").collect();
    let dets = msgs.iter().filter(|m| m["topic"] == "detections").count();
    assert!(!grads.is_empty() && dets > 0);
    // one gradients sample per detections message, except at most the first (segment mapping)
    assert!(
        grads.len() + 1 >= dets && grads.len() <= dets,
        "{} gradients, {dets} detections",
        grads.len()
    );
    // 96x64 decimated by 4 = 24x16; u16 magnitude + u8 bin per pixel.
    for g in &grads {
        assert_eq!((g["width"].as_u64(), g["height"].as_u64()), (Some(24), Some(16)));
        assert_eq!(g["payload_bytes"], 24 * 16 * 3);
        assert_eq!(g["orientation_bins"], 9);
    }
}
