//! Helpers shared by integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

use mosaicd::image::Image;
use mosaicd::npy::NpyArray;

/// Directory of the oracle fixtures (`$MOSAICD_ORACLE`, default `target/oracle`).
pub fn oracle_dir() -> PathBuf {
    std::env::var_os("MOSAICD_ORACLE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/oracle"))
}

/// Read an oracle fixture; fails with instructions when it is missing.
pub fn oracle(name: &str) -> NpyArray {
    let p = oracle_dir().join(name);
    if !p.exists() {
        panic!(
            "oracle fixture {} is missing: run `make oracle` (python3 tests/oracle/generate.py --out target/oracle) first",
            p.display()
        );
    }
    NpyArray::read(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// A 2-D fixture as an f32 image.
pub fn oracle_image(name: &str) -> Image<f32> {
    let a = oracle(name);
    assert_eq!(
        a.shape.len(),
        2,
        "{name}: expected a 2-D array, got shape {:?}",
        a.shape
    );
    Image::from_vec(a.shape[1], a.shape[0], a.data.iter().map(|&v| v as f32).collect()).unwrap()
}

/// Largest absolute difference between two equally sized images.
pub fn max_abs_diff(a: &Image<f32>, b: &Image<f32>) -> f32 {
    assert_eq!(a.dimensions(), b.dimensions(), "size mismatch");
    a.as_slice()
        .iter()
        .zip(b.as_slice())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// Start `mosaicd listen` with `args` (stdout piped) and return once it says it is subscribed, so a
/// daemon started afterwards cannot publish before the subscriber exists.
pub fn spawn_listener(bin: &str, args: &[&str]) -> std::process::Child {
    spawn_listener_with_stderr(bin, args).0
}

/// As [`spawn_listener`], with the reader of the listener's stderr after its "subscribed" line
/// (dropping it closes the pipe).
pub fn spawn_listener_with_stderr(
    bin: &str,
    args: &[&str],
) -> (std::process::Child, std::io::BufReader<std::process::ChildStderr>) {
    use std::io::{BufRead, BufReader};
    let mut listener = std::process::Command::new(bin)
        .arg("listen")
        .args(args)
        .env("RUST_LOG", "warn")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(listener.stderr.take().unwrap());
    let mut line = String::new();
    while err.read_line(&mut line).unwrap() > 0 && !line.contains("subscribed") {
        line.clear();
    }
    assert!(line.contains("subscribed"), "listener did not start: {line}");
    assert_says_what_it_subscribed_to(&line, args);
    (listener, err)
}

/// A subscriber's "subscribed to …/{…}" line names every service its flags asked for.
pub fn assert_says_what_it_subscribed_to(line: &str, args: &[&str]) {
    for service in ["keypoints", "descriptors", "gradients"] {
        if args.contains(&format!("--{service}").as_str()) {
            assert!(line.contains(service), "--{service}: {line}");
        }
    }
}

/// Run `mosaicd run --config CFG` (with `--results RESULTS` when given) to completion; it must
/// succeed. Its output.
pub fn run_daemon_ok(
    bin: &str,
    cfg: &std::path::Path,
    results: Option<&std::path::Path>,
) -> std::process::Output {
    let mut c = std::process::Command::new(bin);
    c.args(["run", "--config"]).arg(cfg).env("RUST_LOG", "warn");
    if let Some(r) = results {
        c.arg("--results").arg(r);
    }
    let out = c.output().unwrap();
    assert!(
        out.status.success(),
        "daemon failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The frame records of a daemon `--results` file without their wall-clock group (`"wall"`:
/// latency), which are the deterministic part.
pub fn frame_results(results: &std::path::Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(results)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v["type"] == "frame")
        .map(|mut v| {
            v.as_object_mut().unwrap().remove("wall");
            v
        })
        .collect()
}
