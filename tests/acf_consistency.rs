//! The shipped ACF model (`models/acf-mosaic.json`) scores the same boxes with the same scores in
//! the daemon (an MCAP recording replayed with `compute.detector = "acf"`), in `mosaicd detect`
//! and in `mosaicd eval detection`, and the daemon's results are byte-identical for 1 and 2
//! threads. `mosaicd replay` of the same recording writes the same boxes to its MCAP output: the
//! `mosaicd.Detections` channel, and the `foxglove.ImageAnnotations` drawn on the preview. One 8-bit frame serves all three: its RGB image read as a mosaic (`detect --as
//! mosaic`, `eval --inputs sampled`: the image sampled through RGGB, values as they are) and the
//! same RGGB mosaic as raw files recorded into an MCAP (the daemon reads it in the linear tone,
//! black 0, white 255: the same values). No shared data is read.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

mod common;
use common::frame_results;
use mosaicd::wire::schema::annotations_from_detections;
use mosaicd::wire::{read_annotations, read_detections, RecordingInfo};

const EXE: &str = env!("CARGO_BIN_EXE_mosaicd");
/// Low enough that the textured frame has boxes (the model's cascade threshold is below it).
const THRESHOLD: &str = "-7.9";
/// The frame size.
const W: usize = 320;
const H: usize = 320;

fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models/acf-mosaic.json")
}

fn ok(o: Output, what: &str) -> String {
    assert!(
        o.status.success(),
        "{what}: {}\n{}",
        String::from_utf8_lossy(&o.stderr),
        String::from_utf8_lossy(&o.stdout)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// A 320x320 RGB frame with structure at several scales: three dark upright figures of different
/// sizes on a textured, lit background.
fn image() -> Vec<[u8; 3]> {
    let (w, h) = (W, H);
    let figures = [(64.0f32, 1.0f32), (170.0, 0.8), (262.0, 0.65)];
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let bg = 120.0 + 60.0 * (x / 23.0).sin() * (y / 31.0).cos() + 0.2 * y;
            let on = figures.iter().any(|&(cx, s)| {
                let (top, bottom) = (300.0 - 250.0 * s, 300.0);
                let (head_y, r) = (top + 18.0 * s, 15.0 * s);
                let body_y = (head_y + r + bottom) / 2.0;
                let body = ((x - cx) / (22.0 * s)).powi(2)
                    + ((y - body_y) / ((bottom - head_y - r) / 2.0)).powi(2)
                    < 1.0;
                body || (x - cx).powi(2) + (y - head_y).powi(2) < r * r
            });
            let v = if on { 40.0 + 10.0 * (y / 9.0).sin() } else { bg };
            let v = v.clamp(0.0, 255.0);
            [v as u8, (v * 0.9) as u8, (v * 0.8 + 20.0).min(255.0) as u8]
        })
        .collect()
}

/// A box as (x, y, width, height, score), compared exactly.
type Box5 = [f32; 5];

fn from_json(d: &serde_json::Value) -> Box5 {
    let f = |k: &str| d[k].as_f64().unwrap() as f32;
    [f("x"), f("y"), f("width"), f("height"), f("score")]
}

fn sorted(mut v: Vec<Box5>) -> Vec<Box5> {
    v.sort_by(|a, b| {
        b[4].total_cmp(&a[4])
            .then(a[0].total_cmp(&b[0]))
            .then(a[1].total_cmp(&b[1]))
    });
    v
}

#[test]
fn the_acf_model_scores_the_same_in_the_daemon_detect_and_eval() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (w, h) = (W, H);
    let rgb = image();
    // the image, and its RGGB mosaic as a raw file with a sidecar
    let flat: Vec<u8> = rgb.iter().flatten().copied().collect();
    let png = d.join("img.png");
    image::save_buffer(&png, &flat, w as u32, h as u32, image::ColorType::Rgb8).unwrap();
    let raw_dir = d.join("raw");
    std::fs::create_dir(&raw_dir).unwrap();
    let mosaic: Vec<u8> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            rgb[i][match (x % 2, y % 2) {
                (0, 0) => 0,
                (1, 1) => 2,
                _ => 1,
            }]
        })
        .collect();
    std::fs::write(raw_dir.join("f0.raw"), &mosaic).unwrap();
    std::fs::write(
        raw_dir.join("mosaicd-raw.toml"),
        format!("width = {w}\nheight = {h}\nbit_depth = 8\ncfa = \"RGGB\"\nblack = 0\nwhite = 255\n"),
    )
    .unwrap();

    // mosaicd detect on the image read as a mosaic
    let m = model();
    let out = ok(
        Command::new(EXE)
            .args(["detect", png.to_str().unwrap(), "--as", "mosaic", "--json"])
            .args(["--model", m.to_str().unwrap(), "--threshold", THRESHOLD])
            .output()
            .unwrap(),
        "detect",
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["detector"], "acf");
    let detect = sorted(
        v["detections"]
            .as_array()
            .unwrap()
            .iter()
            .map(from_json)
            .collect(),
    );
    assert!(detect.len() >= 3, "few boxes at threshold {THRESHOLD}: {out}");

    // mosaicd eval detection on the same image (one ground-truth box), sampled inputs
    std::fs::write(d.join("gt.csv"), "image,x,y,w,h\nimg.png,70,40,52,220\n").unwrap();
    let eval_out = d.join("eval");
    ok(
        Command::new(EXE)
            .args(["eval", "detection", &format!("{}=mosaic", m.display())])
            .args(["--boxes", d.join("gt.csv").to_str().unwrap()])
            .args([
                "--inputs",
                "sampled",
                "--threshold",
                THRESHOLD,
                "--quiet",
                "--out",
            ])
            .arg(&eval_out)
            .output()
            .unwrap(),
        "eval detection",
    );
    let csvs: Vec<PathBuf> = std::fs::read_dir(eval_out.join("detections"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(csvs.len(), 1, "{csvs:?}");
    let eval = sorted(
        std::fs::read_to_string(&csvs[0])
            .unwrap()
            .lines()
            .skip(1)
            .map(|l| {
                let f: Vec<f32> = l.split(',').skip(1).map(|x| x.parse().unwrap()).collect();
                [f[0], f[1], f[2], f[3], f[4]]
            })
            .collect(),
    );
    assert_eq!(eval, detect, "eval detection and detect differ");

    // the daemon replaying a recording of the raw frame, with 1 and 2 threads
    let rec = d.join("rec.mcap");
    ok(
        Command::new(EXE)
            .args(["record", raw_dir.to_str().unwrap(), "-o", rec.to_str().unwrap()])
            .output()
            .unwrap(),
        "record",
    );
    let cfg = d.join("acf.toml");
    std::fs::write(
        &cfg,
        format!(
            "[daemon]\ndeterministic_outputs = true\n[compute]\ndetector = \"acf\"\nacf_model = {:?}\n\
             mosaic_tone = \"linear\"\nhit_threshold = {THRESHOLD}\n\
             [[camera]]\nname = \"a\"\nsource = \"mcap\"\npath = {:?}\n",
            m.to_str().unwrap(),
            rec.to_str().unwrap()
        ),
    )
    .unwrap();
    let mut files = Vec::new();
    for threads in ["1", "2"] {
        let results = d.join(format!("results-{threads}.jsonl"));
        ok(
            Command::new(EXE)
                .args(["run", "--config", cfg.to_str().unwrap(), "--no-publish"])
                .args(["--threads", threads, "--results", results.to_str().unwrap()])
                .output()
                .unwrap(),
            "run",
        );
        files.push(results);
    }
    // frame records without their wall-clock group are the deterministic part
    let (one, two) = (frame_results(&files[0]), frame_results(&files[1]));
    assert_eq!(one.len(), 1);
    assert_eq!(
        serde_json::to_string(&one).unwrap(),
        serde_json::to_string(&two).unwrap(),
        "results differ between 1 and 2 threads"
    );
    let daemon = sorted(
        one[0]["detections"]
            .as_array()
            .unwrap()
            .iter()
            .map(from_json)
            .collect(),
    );
    assert_eq!(daemon, detect, "the daemon and detect differ");

    // the same boxes in the daemon's MCAP output: the detections channel, and the Foxglove
    // annotations drawn on the preview (decimation 2 halves the coordinates)
    let replay_cfg = d.join("acf-replay.toml");
    let text = std::fs::read_to_string(&cfg).unwrap();
    std::fs::write(&replay_cfg, format!("[record]\npreview_decimation = 2\n{text}")).unwrap();
    let out_mcap = d.join("out.mcap");
    ok(
        Command::new(EXE)
            .args([
                "replay",
                rec.to_str().unwrap(),
                "--config",
                replay_cfg.to_str().unwrap(),
            ])
            .args(["--out", out_mcap.to_str().unwrap(), "--no-publish"])
            .output()
            .unwrap(),
        "replay",
    );
    let msgs = read_detections(&out_mcap, "replay").unwrap();
    let topics = || {
        format!(
            "{:?}",
            RecordingInfo::read(&out_mcap).map(|i| i.channels.into_keys().collect::<Vec<_>>())
        )
    };
    assert_eq!(msgs.len(), 1, "one frame's detections; channels {}", topics());
    let recorded = sorted(
        msgs[0]
            .detections
            .iter()
            .map(|b| [b.x, b.y, b.width, b.height, b.score])
            .collect(),
    );
    assert_eq!(
        recorded, daemon,
        "the MCAP detections and the results file differ"
    );
    let ann = read_annotations(&out_mcap, "replay").unwrap();
    assert_eq!(ann.len(), 1, "one frame's annotations");
    assert_eq!(ann[0].message.points.len(), daemon.len());
    assert_eq!(
        ann[0].message,
        annotations_from_detections(msgs[0].timestamp_ns, &msgs[0].detections, 2.0),
        "the annotations are not the detections' boxes on the preview"
    );
}
