//! `mosaicd sift A --match B`: two frames registered on their mosaics (no demosaicing). Crops of a
//! real Kodak photograph sampled to RGGB mosaics, offset by a known shift, give that shift back;
//! a frame matched with itself is the identity; a flat frame gives no transform (reported, not an
//! error); a missing second input and match options without `--match` are clear errors.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_mosaicd");

fn sift(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(BIN)
        .arg("sift")
        .args(args)
        .args(["--log", "warn", "--threads", "2"])
        .output()
        .unwrap()
}

/// kodim09 (512x768) cropped to 480x400 at (x, y), saved as PNG in `dir`.
fn crop(dir: &Path, x: u32, y: u32) -> PathBuf {
    let img = image::open(mosaicd::data::require("kodak/kodim09.png"))
        .unwrap()
        .to_rgb8();
    let p = dir.join(format!("crop_{x}_{y}.png"));
    image::imageops::crop_imm(&img, x, y, 480, 400)
        .to_image()
        .save(&p)
        .unwrap();
    p
}

fn report(out: &Output, json: &Path) -> serde_json::Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

#[test]
fn a_known_shift_between_two_mosaics_comes_back() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (crop(dir.path(), 0, 0), crop(dir.path(), 32, 24));
    let (json, pic) = (dir.path().join("ab.json"), dir.path().join("ab.png"));
    let out = sift(&[
        a.as_os_str(),
        "--match".as_ref(),
        b.as_os_str(),
        "--match-json".as_ref(),
        json.as_os_str(),
        "--match-picture".as_ref(),
        pic.as_os_str(),
    ]);
    let r = report(&out, &json);
    let m = r["affine"].as_array().expect("a transform");
    let v = |i: usize, j: usize| m[i][j].as_f64().unwrap();
    // x' = x - 32, y' = y - 24: linear part the identity, translation the shift.
    for (i, j, want, tol) in [
        (0, 0, 1.0, 0.005),
        (1, 1, 1.0, 0.005),
        (0, 1, 0.0, 0.005),
        (1, 0, 0.0, 0.005),
        (2, 0, -32.0, 0.5),
        (2, 1, -24.0, 0.5),
    ] {
        assert!(
            (v(i, j) - want).abs() < tol,
            "affine[{i}][{j}] = {} (want {want}): {r}",
            v(i, j)
        );
    }
    let inliers = r["inliers"].as_u64().unwrap();
    assert!(inliers >= 10, "{r}");
    assert!(r["inlier_rms_px"].as_f64().unwrap() < 0.5, "{r}");
    let matches = r["matches"].as_array().unwrap();
    assert_eq!(
        matches.iter().filter(|m| m["inlier"] == true).count() as u64,
        inliers
    );
    for m in matches.iter().filter(|m| m["inlier"] == true) {
        let d = |k: usize| m["a_xy"][k].as_f64().unwrap() - m["b_xy"][k].as_f64().unwrap();
        assert!((d(0) - 32.0).abs() < 1.5 && (d(1) - 24.0).abs() < 1.5, "{m}");
    }
    let picture = image::open(&pic).unwrap();
    assert_eq!((picture.width(), picture.height()), (960, 400));
    assert!(String::from_utf8_lossy(&out.stderr).contains("inliers"));
}

#[test]
fn a_frame_matched_with_itself_is_the_identity_and_a_flat_one_gives_no_transform() {
    let dir = tempfile::tempdir().unwrap();
    let a = crop(dir.path(), 0, 0);
    let json = dir.path().join("aa.json");
    let r = report(
        &sift(&[
            a.as_os_str(),
            "--match".as_ref(),
            a.as_os_str(),
            "--match-json".as_ref(),
            json.as_os_str(),
        ]),
        &json,
    );
    let n = r["keypoints"][0].as_u64().unwrap();
    assert_eq!(
        (r["keypoints"][1].as_u64(), r["inliers"].as_u64()),
        (Some(n), Some(n))
    );
    assert!(r["inlier_rms_px"].as_f64().unwrap() < 1e-6, "{r}");

    let flat = dir.path().join("flat.png");
    image::RgbImage::from_pixel(480, 400, image::Rgb([90, 90, 90]))
        .save(&flat)
        .unwrap();
    let out = sift(&[
        a.as_os_str(),
        "--match".as_ref(),
        flat.as_os_str(),
        "--match-json".as_ref(),
        json.as_os_str(),
    ]);
    let r = report(&out, &json);
    assert!(r["affine"].is_null() && r["inliers"] == 0, "{r}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("no transform"));
}

#[test]
fn a_missing_second_input_and_match_options_alone_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let a = crop(dir.path(), 0, 0);
    let missing = dir.path().join("missing.png");
    let out = sift(&[a.as_os_str(), "--match".as_ref(), missing.as_os_str()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.png"));
    let json = dir.path().join("x.json");
    let out = sift(&[a.as_os_str(), "--match-json".as_ref(), json.as_os_str()]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--match"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
