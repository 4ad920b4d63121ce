//! `mosaicd eval sift` end to end on one Kodak image: it writes its tables and figures, the
//! output is identical for 1 and 2 threads, the mosaic's quarter turn is exact on keypoints
//! away from the new borders, and bad options or directories give clear errors. The full
//! 24-image runs are in docs/sift.md.

use std::path::Path;
use std::process::{Command, Output};

fn kodak() -> std::path::PathBuf {
    // Fails with a message naming MOSAICD_DATA when the shared data is missing.
    mosaicd::data::require("kodak/kodim01.png")
        .parent()
        .unwrap()
        .to_path_buf()
}

fn mosaicd(args: &[&str], threads: usize) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(args)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .expect("run mosaicd")
}

/// One image, grey SIFT undoubled (the like-for-like peer of the undoubled mosaic, and 10x
/// cheaper than OpenCV's doubled default).
fn run(out: &Path, threads: usize) -> String {
    let kodak = kodak();
    let o = mosaicd(
        &[
            "eval",
            "sift",
            "--kodak",
            kodak.to_str().unwrap(),
            "--limit",
            "1",
            "--grey-double",
            "false",
            "--out",
            out.to_str().unwrap(),
        ],
        threads,
    );
    assert!(
        o.status.success(),
        "eval sift failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn one_image_writes_every_output_and_is_the_same_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("t1"), dir.path().join("t2"));
    let table = run(&a, 1);
    run(&b, 2);
    assert!(
        table.contains(
            "grey doubled: false; mosaic doubled: false; mosaic octaves: centred; plane warp: lattice"
        ),
        "{table}"
    );
    for f in [
        "rows.json",
        "summary.json",
        "summary.md",
        "fig12a.png",
        "fig12b.png",
        "fig10.png",
    ] {
        let len = std::fs::metadata(a.join(f)).map(|m| m.len()).unwrap_or(0);
        assert!(len > 100, "{f} missing or empty ({len} bytes)");
    }
    for f in ["rows.json", "summary.json", "summary.md"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f} differs between 1 and 2 threads"
        );
    }

    let rows: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("rows.json")).unwrap()).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 15, "4 blur + 5 scale + 6 rotation levels");
    for r in rows {
        assert_eq!(r["image"], "kodim01");
        for m in ["grey", "mosaic"] {
            let s = &r[m];
            let rep = s["repeatability"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&rep), "{r}");
            assert!(
                s["correct"].as_u64().unwrap() <= s["matches"].as_u64().unwrap(),
                "{r}"
            );
            assert!(s["n1"].as_u64().unwrap() > 20, "too few keypoints: {r}");
        }
    }
    // A quarter turn under the default `lattice` warp permutes the mosaic exactly and centred
    // octaves turn with it, so every keypoint whose descriptor window misses the new borders is
    // found and matched again (1.000 on all 24 images, docs/sift.md).
    let turn = rows
        .iter()
        .find(|r| r["family"] == "rotation" && r["level"].as_f64() == Some(90.0))
        .expect("a 90° row");
    let interior = &turn["mosaic"]["interior"];
    assert!(interior["n1"].as_u64().unwrap() > 20, "{turn}");
    assert_eq!(interior["repeatability"].as_f64(), Some(1.0), "{turn}");
}

#[test]
fn bad_options_and_directories_are_clear_errors() {
    let kodak = kodak();
    let out = tempfile::tempdir().unwrap();
    let out = out.path().to_str().unwrap();
    let empty = tempfile::tempdir().unwrap();
    let cases: [(Vec<&str>, &str); 4] = [
        (
            vec!["--kodak", kodak.to_str().unwrap(), "--mosaic-sigma", "0"],
            "sigma",
        ),
        (vec!["--kodak", "/nonexistent/kodak"], "/nonexistent/kodak"),
        (vec!["--kodak", empty.path().to_str().unwrap()], "no PNG images"),
        (
            vec!["--kodak", kodak.to_str().unwrap(), "--grey-double", "maybe"],
            "--grey-double",
        ),
    ];
    for (extra, want) in cases {
        let mut args = vec!["eval", "sift", "--out", out];
        args.extend(extra.iter().copied());
        let o = mosaicd(&args, 1);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(
            err.contains(want),
            "{args:?}: error does not name {want:?}:\n{err}"
        );
    }
}
