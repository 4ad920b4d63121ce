//! The optional keypoint stage (`compute.keypoints = true`) as real processes: `mosaicd run`
//! replaying the committed synthetic recording (recordings/synthetic_pan.mcap, 12 frames of
//! 160x120 10-bit GRBG made by our own code) computes mosaic SIFT keypoints per frame, publishes them on
//! `<prefix>/<camera>/keypoints` to a `mosaicd listen --keypoints` process over real iceoryx2 shared
//! memory, writes them to the results file, and records them in MCAP as `foxglove.ImageAnnotations`
//! points and as `mosaicd.SiftFeatures` (full-frame keypoints). With `compute.keypoint_descriptors`
//! every keypoint carries its 128-byte descriptor through all three, the same bytes everywhere and
//! for any thread count. With the stage off (the default) none of these appear.

use std::path::{Path, PathBuf};
use std::process::Command;

use mosaicd::features::sift::Keypoint;

use mosaicd::record::Topics;
use mosaicd::wire::schema::{base64_decode, ImageAnnotations, SiftFeaturesMessage, POINTS_POINTS};
use mosaicd::wire::{read_json_topic, RecordingInfo};

mod common;

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");
const FRAMES: u64 = 12;
const WIDTH: f64 = 160.0;
const HEIGHT: f64 = 120.0;

fn recording() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("recordings/synthetic_pan.mcap")
}

fn config(dir: &Path, prefix: &str, camera: &str, keypoints: bool) -> PathBuf {
    config_with(dir, prefix, camera, keypoints, "", 2)
}

/// A config; `extra` goes into `[compute]`.
fn config_with(
    dir: &Path,
    prefix: &str,
    camera: &str,
    keypoints: bool,
    extra: &str,
    threads: usize,
) -> PathBuf {
    let p = dir.join(format!("{camera}.toml"));
    let rec = dir.join("{camera}.mcap");
    std::fs::write(
        &p,
        format!(
            "[daemon]\nthreads = {threads}\nstats_interval_ms = 200\n\
             [publish]\nservice_prefix = \"{prefix}\"\nsubscriber_buffer = 64\n\
             [record]\nenabled = true\npath = \"{}\"\n\
             [compute]\ndetect = false\nkeypoints = {keypoints}\n{extra}\
             [[camera]]\nname = \"{camera}\"\nsource = \"mcap\"\npath = \"{}\"\n",
            rec.display(),
            recording().display()
        ),
    )
    .unwrap();
    p
}

/// `mosaicd run --config CFG --results DIR/results.jsonl`, which must succeed; the results path.
fn run_daemon(cfg: &Path, dir: &Path) -> PathBuf {
    let results = dir.join("results.jsonl");
    common::run_daemon_ok(BIN, cfg, Some(&results));
    results
}

/// `got` equals the results file's keypoints `want` (a JSON array), compared as the `f32` values
/// both were written from (JSON text parsed as `f64` can differ in the last digits).
fn assert_same_keypoints(got: &[Keypoint], want: &serde_json::Value) {
    let want = want.as_array().unwrap();
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        let f = |k: &str| w[k].as_f64().unwrap() as f32;
        assert_eq!(
            (g.x, g.y, g.size, g.angle, g.response),
            (f("x"), f("y"), f("size"), f("angle"), f("response")),
            "{w}"
        );
        assert_eq!(
            (g.octave as i64, g.layer as u64),
            (w["octave"].as_i64().unwrap(), w["layer"].as_u64().unwrap())
        );
    }
}

/// Run the daemon with `cfg` while a `mosaicd listen --keypoints` process subscribes: the
/// results path, its frame records (one per recorded frame, checked) and the listener's messages.
fn run_with_listener(
    cfg: &Path,
    dir: &Path,
    prefix: &str,
    camera: &str,
    extra: &[&str],
) -> (PathBuf, Vec<serde_json::Value>, Vec<serde_json::Value>) {
    let mut args = vec![
        "--camera",
        camera,
        "--prefix",
        prefix,
        "--keypoints",
        "--until-final",
        "--timeout-s",
        "60",
    ];
    args.extend_from_slice(extra);
    let listener = common::spawn_listener(BIN, &args);
    let results = run_daemon(cfg, dir);
    let frames: Vec<serde_json::Value> = json_lines(&std::fs::read_to_string(&results).unwrap())
        .into_iter()
        .filter(|r| r["type"] == "frame")
        .collect();
    assert_eq!(frames.len() as u64, FRAMES);
    let lout = listener.wait_with_output().unwrap();
    assert!(lout.status.success(), "{}", String::from_utf8_lossy(&lout.stderr));
    let msgs = json_lines(&String::from_utf8_lossy(&lout.stdout));
    (results, frames, msgs)
}

fn json_lines(text: &str) -> Vec<serde_json::Value> {
    text.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

#[test]
fn keypoints_reach_a_listen_process_the_results_file_and_the_mcap() {
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (format!("t{}kp", std::process::id()), "kpcam");
    let cfg = config(dir.path(), &prefix, camera, true);
    let (_, frames, msgs) = run_with_listener(&cfg, dir.path(), &prefix, camera, &[]);

    // Results file: every frame carries its keypoints, strongest first.
    let mut total = 0;
    for f in &frames {
        let k = f["keypoints"].as_array().expect("keypoints array in every frame");
        total += k.len();
        let resp: Vec<f64> = k.iter().map(|p| p["response"].as_f64().unwrap().abs()).collect();
        assert!(resp.windows(2).all(|w| w[0] >= w[1]), "not strongest first");
        for p in k {
            let (x, y) = (p["x"].as_f64().unwrap(), p["y"].as_f64().unwrap());
            assert!((0.0..WIDTH).contains(&x) && (0.0..HEIGHT).contains(&y), "{p}");
        }
    }
    // The panned scene gives 6-10 keypoints a frame.
    assert!(
        total >= FRAMES as usize,
        "only {total} keypoints in {FRAMES} frames"
    );

    // Listener: one keypoints message per frame, before that frame's detections, same content.
    let kmsgs: Vec<&serde_json::Value> = msgs.iter().filter(|m| m["topic"] == "keypoints").collect();
    let idx: Vec<u64> = kmsgs.iter().map(|m| m["index"].as_u64().unwrap()).collect();
    assert_eq!(idx, (0..FRAMES).collect::<Vec<_>>());
    for (m, f) in kmsgs.iter().zip(&frames) {
        let want = f["keypoints"].as_array().unwrap();
        assert_eq!(
            m["keypoint_count"].as_u64().unwrap() as usize,
            want.len().min(512)
        );
        let got = m["keypoints"].as_array().unwrap();
        for (g, w) in got.iter().zip(want) {
            for key in ["x", "y", "size", "angle", "response"] {
                assert_eq!(g[key], w[key], "frame {} {key}", m["index"]);
            }
        }
    }
    let first_det = msgs.iter().position(|m| m["topic"] == "detections").unwrap();
    let first_kp = msgs.iter().position(|m| m["topic"] == "keypoints").unwrap();
    assert!(
        first_kp < first_det,
        "keypoints are published before the frame's detections"
    );

    // MCAP: one POINTS annotation per frame on /<camera>/keypoints, as many points as keypoints.
    let rec = dir.path().join(format!("{camera}.mcap"));
    let topic = Topics::new(camera).keypoints;
    let info = RecordingInfo::read(&rec).unwrap();
    assert_eq!(info.count(&topic), FRAMES);
    let anns = read_json_topic::<ImageAnnotations>(&rec, &topic).unwrap();
    for (a, f) in anns.iter().zip(&frames) {
        assert_eq!(a.log_time, f["capture_timestamp_ns"].as_u64().unwrap());
        let n = f["keypoints"].as_array().unwrap().len();
        let pts: usize = a.message.points.iter().map(|p| p.points.len()).sum();
        assert_eq!(pts, n);
        assert!(a.message.points.iter().all(|p| p.kind == POINTS_POINTS));
    }
    // And as mosaicd.SiftFeatures: the results file's keypoints, full-frame, without descriptors.
    let sift = read_json_topic::<SiftFeaturesMessage>(&rec, &Topics::new(camera).sift).unwrap();
    assert_eq!(sift.len() as u64, FRAMES);
    for (s, f) in sift.iter().zip(&frames) {
        assert_same_keypoints(&s.message.keypoints, &f["keypoints"]);
        assert!(s.message.descriptors.is_empty());
        assert_eq!(s.message.sequence, f["sequence"].as_u64().unwrap());
    }
    assert!(frames.iter().all(|f| f.get("descriptors").is_none()));
}

/// Descriptors on: the listener, the results file and the MCAP carry the same bytes per keypoint,
/// and a replay with one thread writes the same results file as with two.
#[test]
fn descriptors_reach_every_output_with_their_keypoints() {
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (format!("t{}kd", std::process::id()), "kdcam");
    let extra = "keypoint_descriptors = true\n";
    let cfg = config_with(dir.path(), &prefix, camera, true, extra, 2);
    let (results, frames, msgs) = run_with_listener(&cfg, dir.path(), &prefix, camera, &["--descriptors"]);
    let decode = |v: &serde_json::Value| -> Vec<Vec<u8>> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|s| base64_decode(s.as_str().unwrap()).unwrap())
            .collect()
    };
    let mut total = 0;
    for f in &frames {
        let d = decode(&f["descriptors"]);
        assert_eq!(d.len(), f["keypoints"].as_array().unwrap().len());
        assert!(d.iter().all(|x| x.len() == 128 && x.iter().any(|&b| b > 0)));
        total += d.len();
    }
    assert!(total >= FRAMES as usize, "only {total} descriptors");

    // The listener: one descriptors message per frame, with the results file's bytes (it drains
    // each service in turn, so lines of neighbouring frames may interleave by topic).
    let dmsgs: Vec<&serde_json::Value> = msgs.iter().filter(|m| m["topic"] == "descriptors").collect();
    assert_eq!(dmsgs.len() as u64, FRAMES);
    for (m, f) in dmsgs.iter().zip(&frames) {
        assert_eq!(m["index"], f["index"]);
        assert_eq!(
            m["descriptor_count"].as_u64().unwrap() as usize,
            f["keypoints"].as_array().unwrap().len()
        );
        assert_eq!(m["descriptors"], f["descriptors"], "frame {}", m["index"]);
    }

    let rec = dir.path().join(format!("{camera}.mcap"));
    let sift = read_json_topic::<SiftFeaturesMessage>(&rec, &Topics::new(camera).sift).unwrap();
    assert_eq!(sift.len() as u64, FRAMES);
    for (s, f) in sift.iter().zip(&frames) {
        assert_same_keypoints(&s.message.keypoints, &f["keypoints"]);
        let got: Vec<Vec<u8>> = s
            .message
            .decoded_descriptors()
            .unwrap()
            .iter()
            .map(|d| d.to_vec())
            .collect();
        assert_eq!(got, decode(&f["descriptors"]));
    }

    // One thread: the same results, byte for byte (wall-clock fields removed).
    let one = tempfile::tempdir().unwrap();
    let cfg1 = config_with(one.path(), &format!("{prefix}1"), camera, true, extra, 1);
    let results1 = run_daemon(&cfg1, one.path());
    let strip = |p: &Path| -> Vec<serde_json::Value> {
        json_lines(&std::fs::read_to_string(p).unwrap())
            .into_iter()
            .filter(|r| r["type"] == "frame")
            .map(|mut r| {
                r.as_object_mut().unwrap().remove("wall");
                r
            })
            .collect()
    };
    assert_eq!(strip(&results), strip(&results1));
}

#[test]
fn descriptors_or_doubling_without_the_keypoint_stage_are_refused_at_start_up() {
    let dir = tempfile::tempdir().unwrap();
    for key in ["keypoint_descriptors", "keypoints_double"] {
        let cfg = config_with(dir.path(), "tkr", "kr", false, &format!("{key} = true\n"), 2);
        let out = Command::new(BIN)
            .args(["run", "--config"])
            .arg(&cfg)
            .env("RUST_LOG", "warn")
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(&format!("compute.{key}")), "{err}");
    }
}

#[test]
fn keypoints_are_absent_when_the_stage_is_off() {
    let dir = tempfile::tempdir().unwrap();
    let (prefix, camera) = (format!("t{}kq", std::process::id()), "kpoff");
    let cfg = config(dir.path(), &prefix, camera, false);
    let results = run_daemon(&cfg, dir.path());
    let text = std::fs::read_to_string(&results).unwrap();
    assert!(json_lines(&text).iter().all(|r| r.get("keypoints").is_none()));
    let rec = dir.path().join(format!("{camera}.mcap"));
    let info = RecordingInfo::read(&rec).unwrap();
    assert_eq!(info.count(&Topics::new(camera).keypoints), 0);
    assert_eq!(info.count(&Topics::new(camera).sift), 0);
    assert_eq!(info.count(&Topics::new(camera).detections), FRAMES);
}
