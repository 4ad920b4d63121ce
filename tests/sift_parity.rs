//! Grey SIFT against OpenCV's `cv2.SIFT_create()` on the same 8-bit Kodak grey images.
//! Fixtures come from `tests/oracle/gen_sift.py` (run `make oracle`).

use std::path::PathBuf;

use mosaicd::features::sift::{detect_and_compute, Keypoint, SiftSpec};
use mosaicd::image::Image;
use mosaicd::npy::NpyArray;

/// A keypoint of OpenCV's counts as found when ours is within this distance (input pixels)...
const POS_TOL: f32 = 1.0;
/// ...and this relative size difference.
const SIZE_TOL: f32 = 0.10;
/// Required fraction of OpenCV's keypoints found (the issue asks for 0.90; we measure 0.9997-1.0).
const MIN_RECALL: f64 = 0.98;
/// Orientation agreement (degrees) for comparing descriptors of a found pair.
const ANGLE_TOL: f32 = 5.0;
/// Bound on the median Euclidean distance between our and OpenCV's descriptor of the same
/// keypoint, on the 512-norm integer scale (two unrelated descriptors are ~400-500 apart).
const MAX_MEDIAN_DESC_DIST: f64 = 4.0;

fn oracle(name: &str) -> NpyArray {
    let dir = std::env::var_os("MOSAICD_ORACLE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/oracle"));
    let p = dir.join(name);
    NpyArray::read(&p)
        .unwrap_or_else(|e| panic!("missing oracle fixture {} ({e}): run `make oracle`", p.display()))
}

fn angle_diff(a: f32, b: f32) -> f32 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

fn check(name: &str) {
    let g = oracle(&format!("sift_{name}_grey.npy"));
    let (h, w) = (g.shape[0], g.shape[1]);
    let img = Image::from_vec(w, h, g.data.iter().map(|&v| v as u8).collect()).unwrap();
    let kp = oracle(&format!("sift_{name}_kp.npy"));
    let desc = oracle(&format!("sift_{name}_desc.npy"));
    let n = kp.shape[0];
    let ours = detect_and_compute(img.view(), &SiftSpec::grey()).unwrap();
    let mut found = 0usize;
    let mut dists = Vec::new();
    for i in 0..n {
        let r = &kp.data[i * 6..i * 6 + 6];
        let (x, y, size, angle) = (r[0] as f32, r[1] as f32, r[2] as f32, r[3] as f32);
        let near =
            |k: &Keypoint| (k.x - x).hypot(k.y - y) <= POS_TOL && ((k.size - size) / size).abs() <= SIZE_TOL;
        let cands: Vec<usize> = (0..ours.keypoints.len())
            .filter(|&j| near(&ours.keypoints[j]))
            .collect();
        if cands.is_empty() {
            continue;
        }
        found += 1;
        let best = cands
            .iter()
            .copied()
            .min_by(|&a, &b| {
                angle_diff(ours.keypoints[a].angle, angle)
                    .total_cmp(&angle_diff(ours.keypoints[b].angle, angle))
            })
            .unwrap();
        if angle_diff(ours.keypoints[best].angle, angle) <= ANGLE_TOL {
            let d: f64 = (0..128)
                .map(|k| (desc.data[i * 128 + k] - ours.descriptors[best][k] as f64).powi(2))
                .sum::<f64>()
                .sqrt();
            dists.push(d);
        }
    }
    dists.sort_by(f64::total_cmp);
    let recall = found as f64 / n as f64;
    let med = dists[dists.len() / 2];
    let p90 = dists[dists.len() * 9 / 10];
    eprintln!(
        "{name}: OpenCV {n}, ours {}, found {found} ({:.1} %), descriptor distance median {med:.1}, p90 {p90:.1} over {} pairs",
        ours.keypoints.len(),
        100.0 * recall,
        dists.len()
    );
    assert!(
        recall >= MIN_RECALL,
        "{name}: only {:.1} % of OpenCV's keypoints found",
        100.0 * recall
    );
    assert!(
        med <= MAX_MEDIAN_DESC_DIST,
        "{name}: median descriptor distance {med}"
    );
    let ratio = ours.keypoints.len() as f64 / n as f64;
    assert!(
        (0.98..1.02).contains(&ratio),
        "{name}: {} keypoints vs OpenCV's {n}",
        ours.keypoints.len()
    );
}

#[test]
fn grey_sift_matches_opencv_kodim01() {
    check("kodim01");
}

#[test]
fn grey_sift_matches_opencv_kodim09() {
    check("kodim09");
}

#[test]
fn grey_sift_matches_opencv_kodim23() {
    check("kodim23");
}
