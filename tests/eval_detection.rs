//! `mosaicd eval detection` on small subsets of the real data: the USC ground-truth readers agree
//! with the derived CSV; the AP mode (USC and the generic box-CSV form, with external detections)
//! and the window protocol with a noise level write their tables and PNG plots; runs are
//! deterministic; bad inputs give clear errors. The full runs are in docs/detection.md "Quality".

use std::path::Path;
use std::process::{Command, Output};

use mosaicd::eval::{load_box_csv, load_usc};

fn data() -> std::path::PathBuf {
    // Fails with a message naming MOSAICD_DATA when the shared data is missing.
    mosaicd::data::require("pedestrian/usc/usc_boxes_derived.csv");
    mosaicd::data::require_root()
}

fn mosaicd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(args)
        .env(mosaicd::data::DATA_ENV, data())
        .output()
        .expect("run mosaicd")
}

fn ok(args: &[&str]) -> String {
    let o = mosaicd(args);
    assert!(
        o.status.success(),
        "mosaicd {args:?} failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// `eval detection opencv-default=grey --usc --limit N`: the start of every USC run below.
const USC_GREY: [&str; 4] = ["eval", "detection", "opencv-default=grey", "--usc"];

fn assert_png(p: &Path) {
    let b = std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    assert_eq!(&b[1..4], b"PNG", "{} is not a PNG", p.display());
}

/// Markdown table rows (after the header and separator) as cells.
fn rows(md: &str) -> Vec<Vec<String>> {
    md.lines()
        .filter(|l| l.starts_with('|') && !l.starts_with("|---"))
        .skip(1)
        .map(|l| {
            l.trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

#[test]
fn usc_xml_and_human_gt_agree_with_the_derived_csv() {
    let root = data().join("pedestrian/usc");
    let from_gt = load_usc(&root).unwrap();
    let from_csv = load_box_csv(&root.join("usc_boxes_derived.csv"), None).unwrap();
    // The counts the data README documents: 359 images, 816 boxes.
    assert_eq!(from_gt.len(), 359);
    assert_eq!(from_gt.iter().map(|g| g.boxes.len()).sum::<usize>(), 816);
    assert_eq!(from_gt.len(), from_csv.len());
    for (a, b) in from_gt.iter().zip(&from_csv) {
        assert_eq!(a.key, b.key);
        assert_eq!(a.path, b.path);
        assert_eq!(a.boxes, b.boxes, "{}", a.key);
    }
    // Set C comes from human_GT.txt; its BMP is decodable (the `bmp` feature).
    let c = from_gt.iter().find(|g| g.key.ends_with("WALK_107.BMP")).unwrap();
    assert_eq!(c.boxes.len(), 5);
    let img = mosaicd::eval::load_image_rgb(&c.path).unwrap();
    assert_eq!(img.dimensions(), (300, 225));
}

#[test]
fn ap_on_usc_subset_and_box_csv_form_write_tables_and_pr_plots() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ap");
    let usc = data().join("pedestrian/usc");
    // External "detector" = the ground truth of the first two images with falling scores, plus one
    // box where nobody stands: AP must be exactly 1 (the false positive ranks last), recall 1.
    let imgs = load_usc(&usc).unwrap();
    let mut ext = String::from("image,x,y,w,h,score\n");
    let mut csv = String::from("set,image,x,y,w,h\n");
    let mut score = 10.0;
    for g in &imgs[..2] {
        let (set, name) = g.key.split_once('/').unwrap();
        for b in &g.boxes {
            ext.push_str(&format!(
                "{},{},{},{},{},{score}\n",
                g.key, b.x, b.y, b.width, b.height
            ));
            csv.push_str(&format!(
                "{set},{name},{},{},{},{}\n",
                b.x, b.y, b.width, b.height
            ));
            score -= 1.0;
        }
    }
    ext.push_str(&format!("{},0,0,5,5,-100\n", imgs[0].key));
    let ext_path = dir.path().join("ext.csv");
    let csv_path = dir.path().join("boxes.csv");
    std::fs::write(&ext_path, ext).unwrap();
    std::fs::write(&csv_path, csv).unwrap();
    let ext_arg = format!("truth={}", ext_path.display());

    // Detector options shared by both forms below (the images and the output directory differ).
    let common = [
        "--upsample",
        "2",
        "--threshold",
        "-0.5",
        "--threads",
        "2",
        "--quiet",
        "--external",
        &ext_arg,
    ];
    let md = ok(&[
        &USC_GREY[..],
        &["--limit", "2"],
        &common,
        &["--out", out.to_str().unwrap()],
    ]
    .concat());
    let r = rows(&md);
    assert_eq!(r.len(), 2, "{md}");
    assert!(md.contains("2 of 359 images"), "{md}");
    for row in &r {
        for c in 4..8 {
            let v: f64 = row[c].parse().unwrap();
            assert!((0.0..=1.0).contains(&v), "{row:?}");
        }
    }
    assert_eq!(r[1][0], "truth");
    assert_eq!((r[1][4].as_str(), r[1][5].as_str()), ("1.000", "1.000"), "{md}");
    for p in ["pr_raw.png", "pr_shrunk.png"] {
        assert_png(&out.join(p));
    }
    assert!(std::fs::read_to_string(out.join("detection.md"))
        .unwrap()
        .contains("full-image AP"));

    // The generic form on the same two images gives the same numbers (with the default shrink
    // written out, in its comma form).
    let out2 = dir.path().join("csv");
    let md2 = ok(&[
        &[
            "eval",
            "detection",
            "opencv-default=grey",
            "--boxes",
            csv_path.to_str().unwrap(),
            "--images",
            usc.to_str().unwrap(),
            "--shrink",
            "0.2,0.1,0.6,0.8",
        ][..],
        &common,
        &["--out", out2.to_str().unwrap()],
    ]
    .concat());
    let r2 = rows(&md2);
    assert_eq!(
        r2.iter().map(|r| &r[3..]).collect::<Vec<_>>(),
        r.iter().map(|r| &r[3..]).collect::<Vec<_>>()
    );
    assert_png(&out2.join("pr_shrunk.png"));
}

#[test]
fn window_protocol_noise_rows_are_deterministic_and_plot_det() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("win");
    let args = [
        "eval",
        "detection",
        "opencv-default=mosaic",
        "--inputs",
        "sampled,high",
        "--max-neg-images",
        "1",
        "--max-pos",
        "12",
        "--threads",
        "2",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    let md = ok(&args);
    let r = rows(&md);
    assert_eq!(r.len(), 2, "{md}");
    assert_eq!((r[0][2].as_str(), r[1][2].as_str()), ("sampled", "raw-high"));
    assert_eq!(r[0][3], r[1][3], "same negative windows in both pipelines");
    assert_png(&out.join("det_sampled.png"));
    assert_png(&out.join("det_raw-high.png"));
    // Seeded: the noisy run repeats exactly.
    assert_eq!(ok(&args), md);
}

#[test]
fn window_protocol_bootstrap_table() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("winboot");
    let args = |reference: &str| -> Vec<String> {
        [
            "eval",
            "detection",
            "opencv-default=colour",
            "opencv-default=mosaic",
            "--max-neg-images",
            "2",
            "--max-pos",
            "16",
            "--bootstrap",
            "40",
            "--reference",
            reference,
            "--threads",
            "2",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let a2 = args("2");
    let md = ok(&a2.iter().map(String::as_str).collect::<Vec<_>>());
    let r = rows(&md);
    // The window table (2 rows), then the bootstrap table (its header and 2 rows).
    assert_eq!(r.len(), 5, "{md}");
    assert!(
        md.contains("Paired bootstrap over the 3 held-out photos and 2 negative images (40 resamples")
            && md.contains("Δ = row − opencv-default on mosaic, sampled"),
        "{md}"
    );
    let boot = &r[3..];
    assert_eq!(boot[1][3], "[0.000, 0.000]", "the reference against itself: {md}");
    assert_eq!(boot[1][5], "[0.000, 0.000]", "{md}");
    assert_eq!(boot[1][6], "1.000", "{md}");
    // The interval holds the plain miss rate of the table above.
    let iv = |c: &str| -> (f64, f64) {
        let (lo, hi) = c.trim_matches(['[', ']']).split_once(", ").unwrap();
        (lo.parse().unwrap(), hi.parse().unwrap())
    };
    for k in 0..2 {
        let plain: f64 = r[k][6].parse().unwrap();
        let (lo, hi) = iv(&boot[k][4]);
        assert!(lo <= plain && plain <= hi, "row {k}: {md}");
    }
    // Seeded: the same table again.
    assert_eq!(ok(&a2.iter().map(String::as_str).collect::<Vec<_>>()), md);
    let a3 = args("3");
    let o = mosaicd(&a3.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--reference 3"));
}

#[test]
fn mosaic_taps_override_the_models() {
    let img = data().join("kodak/kodim09.png");
    let scores = |extra: &[&str]| -> Vec<f64> {
        let out = ok(&[
            &[
                "detect",
                img.to_str().unwrap(),
                "--as",
                "mosaic",
                "--threshold",
                "-1e9",
                "--nms",
                "none",
                "--max-levels",
                "2",
                "--threads",
                "2",
                "--json",
            ][..],
            extra,
        ]
        .concat());
        detection_scores(out.as_bytes())
    };
    let default = scores(&[]);
    assert!(!default.is_empty());
    assert_eq!(
        scores(&["--mosaic-taps", "same-site"]),
        default,
        "OpenCV's weights read as same-site"
    );
    let paper = scores(&["--mosaic-taps", "paper"]);
    assert_eq!(paper.len(), default.len());
    assert_ne!(paper, default);
    let o = mosaicd(&["detect", img.to_str().unwrap(), "--mosaic-taps", "sideways"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("paper, same-site"));
}

#[test]
fn detect_warns_when_a_models_domain_differs_from_the_inputs() {
    let img = data().join("kodak/kodim09.png");
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/mosaic.json");
    let run = |extra: &[&str]| {
        let mut a = vec![
            "detect",
            img.to_str().unwrap(),
            "--model",
            model.to_str().unwrap(),
            "--max-levels",
            "1",
        ];
        a.extend_from_slice(extra);
        let o = mosaicd(&a);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    // A colour photo is read as colour unless told otherwise: a transfer case, said so.
    let e = run(&[]);
    assert!(
        e.contains("trained on mosaic input") && e.contains("read as colour") && e.contains("--as mosaic"),
        "{e}"
    );
    assert!(!run(&["--as", "mosaic"]).contains("warning"));
}

#[test]
fn bad_inputs_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "image,x,y,w,h\na.png,1,2,3,4\nb.png,1,2,x,4\n").unwrap();
    let o = mosaicd(&[
        "eval",
        "detection",
        "opencv-default=grey",
        "--boxes",
        bad.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(e.contains("bad.csv:3") && e.contains("not a number"), "{e}");

    let o = Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(["eval", "detection", "opencv-default=grey", "--usc"])
        .env(mosaicd::data::DATA_ENV, dir.path().join("nowhere"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(e.contains("MOSAICD_DATA") && e.contains("pedestrian/usc"), "{e}");

    let o = mosaicd(&["eval", "detection", "opencv-default", "--usc"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("expected MODEL=DOMAIN"));

    let o = mosaicd(&[
        "eval",
        "detection",
        "opencv-default=grey",
        "--usc",
        "--shrink",
        "0.2,0.1",
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(e.contains("--shrink takes four numbers"), "{e}");

    let o = mosaicd(&["eval", "detection", "opencv-default=grey", "--fold", "5"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        e.contains("fold = 5") && e.contains("floor(1 / held-out fraction)") && !e.contains("MOSAICD_DATA"),
        "{e}"
    );
    let o = mosaicd(&["eval", "detection", "opencv-default=grey", "--val-fraction", "0"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(e.contains("nothing to evaluate"), "{e}");
}

#[test]
fn phases_bootstrap_and_detection_csvs() {
    let dir = tempfile::tempdir().unwrap();
    let usc = data().join("pedestrian/usc");
    let imgs = load_usc(&usc).unwrap();
    // An external detector perfect on shrunk boxes (each window is the box the default shrink
    // maps onto the ground truth), one file per phase (`{upsample}` in the path).
    let mut ext = String::from("image,x,y,w,h,score\n");
    for g in &imgs[..3] {
        for b in &g.boxes {
            let (w, h) = (b.width / 0.6, b.height / 0.8);
            let (x, y) = (b.x - 0.2 * w, b.y - 0.1 * h);
            ext.push_str(&format!("{},{x},{y},{w},{h},1\n", g.key));
        }
    }
    for u in ["1.9", "2.0"] {
        std::fs::write(dir.path().join(format!("truth_{u}.csv")), &ext).unwrap();
    }
    let ext_arg = format!("truth={}", dir.path().join("truth_{upsample}.csv").display());
    let run = |extra: &[&str], out: &str| {
        let out = dir.path().join(out);
        let md = ok(&[
            &USC_GREY[..],
            &[
                "--limit",
                "3",
                "--threshold",
                "-0.5",
                "--threads",
                "2",
                "--quiet",
                "--out",
                out.to_str().unwrap(),
            ][..],
            extra,
        ]
        .concat());
        (md, out)
    };
    let phases = [
        "--upsample-phases",
        "1.9,2.0",
        "--bootstrap",
        "50",
        "--external",
        &ext_arg,
    ];
    let (md, out) = run(&phases, "phases");
    assert!(md.contains("upsample 2 phases (1.9, 2.0)"), "{md}");
    let r = rows(&md);
    // Two tables: the AP table (2 rows) and the bootstrap table (2 rows).
    assert_eq!(r.len(), 5, "{md}");
    assert_eq!(r[1][0], "truth");
    assert_eq!(r[1][6], "1.000");
    assert_eq!(r[1][7], "1.000–1.000");
    let boot = &r[3..];
    assert_eq!(boot[0][4], "[0.000, 0.000]", "the reference against itself: {md}");
    assert_eq!(boot[1][3], "[1.000, 1.000]", "{md}");
    // Another reference row: the differences are taken from it.
    let (mr, _) = run(&[&phases[..], &["--reference", "2"]].concat(), "reference");
    let br = rows(&mr);
    assert!(mr.contains("Δ = row − truth"), "{mr}");
    assert_eq!(br[4][4], "[0.000, 0.000]", "{mr}");
    assert_eq!(
        br[3][3], boot[0][3],
        "the intervals of AP itself do not depend on the reference"
    );
    let o = mosaicd(
        &[
            &USC_GREY[..],
            &[
                "--limit",
                "1",
                "--upsample",
                "2",
                "--bootstrap",
                "5",
                "--reference",
                "3",
            ],
        ]
        .concat(),
    );
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--reference 3"));
    // The mean over phases is the mean of the single-phase runs.
    let single = |u: &str| -> f64 {
        let (m, _) = run(&["--upsample", u], &format!("u{u}"));
        rows(&m)[0][6].parse().unwrap()
    };
    let mean: f64 = r[0][6].parse().unwrap();
    assert!(
        (mean - (single("1.9") + single("2.0")) / 2.0).abs() <= 0.0011,
        "{md}"
    );
    // Every row's detections are written per phase and read back as --external: same AP.
    let det_csv = out.join("detections/opencv-default_Grey_on_grey_sampled_u2.0.csv");
    assert!(out.join("detections/truth_u1.9.csv").exists());
    let back = format!("again={}", det_csv.display());
    let (m2, _) = run(&["--upsample", "2.0", "--external", &back], "back");
    let r2 = rows(&m2);
    assert_eq!(r2[0][3..], r2[1][3..], "{m2}");
    // A detector listed twice writes two sets of files.
    let (_, twice) = run(&["--upsample", "2.0", "opencv-default=grey"], "twice");
    for f in [
        "opencv-default_Grey_on_grey_sampled.csv",
        "opencv-default_Grey_on_grey_sampled_2.csv",
    ] {
        assert!(twice.join("detections").join(f).exists(), "{f}");
    }
    // A phase that is not a number is a clear error.
    let o = mosaicd(&[
        "eval",
        "detection",
        "opencv-default=grey",
        "--usc",
        "--upsample-phases",
        "2,x",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--upsample-phases x"));
}

#[test]
fn mosaic_tone_and_wb_gains_on_a_raw_frame() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("frame.raw");
    // a 12-bit RGGB frame, dark like raw, textured
    let bytes: Vec<u8> = (0..160u32 * 192)
        .flat_map(|i| (64 + ((i.wrapping_mul(2654435761) >> 22) & 1023) as u16).to_le_bytes())
        .collect();
    std::fs::write(&raw, bytes).unwrap();
    let run = |extra: &[&str]| {
        let mut a = vec![
            "detect",
            raw.to_str().unwrap(),
            "--width",
            "192",
            "--height",
            "160",
            "--cfa",
            "RGGB",
            "--bit-depth",
            "12",
            // OpenCV's linear-tone weights and f32 scores (detect's defaults are the built-in srgb
            // model and the 8-bit SVM, whose quantised scores can hide a small change of tone)
            "--svm",
            "f32",
            "--threshold",
            "-1e9",
            "--nms",
            "none",
            "--max-levels",
            "1",
            "--json",
        ];
        if !extra.contains(&"--model") {
            a.extend_from_slice(&["--model", "opencv-default"]);
        }
        a.extend_from_slice(extra);
        mosaicd(&a)
    };
    let scores = |extra: &[&str]| -> Vec<f64> {
        let o = run(extra);
        assert!(
            o.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        detection_scores(&o.stdout)
    };
    let linear = scores(&[]);
    assert!(!linear.is_empty());
    assert_eq!(
        scores(&["--mosaic-tone", "linear", "--wb-gains", "file"]),
        linear,
        "linear ignores the gains"
    );
    let srgb = scores(&["--mosaic-tone", "srgb"]);
    assert_eq!(srgb.len(), linear.len());
    assert_ne!(srgb, linear);
    assert_eq!(
        scores(&["--mosaic-tone", "srgb", "--wb-gains", "grey-world"]),
        srgb,
        "auto = grey world here"
    );
    assert_ne!(scores(&["--mosaic-tone", "srgb", "--wb-gains", "1,1,1"]), srgb);
    // the model file's own tone
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/mosaic_raw_srgb.json");
    let m = model.to_str().unwrap();
    assert_eq!(
        scores(&["--model", m]),
        scores(&["--model", m, "--mosaic-tone", "srgb"])
    );
    // a headerless raw has no gains of its own; bad names and gains are refused
    for (extra, want) in [
        (&["--mosaic-tone", "srgb", "--wb-gains", "file"][..], "has none"),
        (
            &["--mosaic-tone", "srgb", "--wb-gains", "0,1,1"][..],
            "gains must be finite",
        ),
        (&["--mosaic-tone", "log"][..], "linear, srgb"),
        (&["--wb-gains", "warm"][..], "grey-world"),
    ] {
        let o = run(extra);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains(want), "{extra:?}: {e}");
    }
}

/// The scores of `mosaicd detect --json` output, in its order.
fn detection_scores(json: &[u8]) -> Vec<f64> {
    let v: serde_json::Value = serde_json::from_slice(json).unwrap();
    v["detections"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["score"].as_f64().unwrap())
        .collect()
}

/// `detect` reads every input `gradients` reads, with the same flags and the same loader: a Kodak
/// KDC (our RADC decoder), and a headerless big-endian 12-bit file with padded rows, four black
/// levels and an explicit container; without `--bit-depth` both refuse it with the same words.
#[test]
fn detect_reads_what_gradients_reads_with_the_same_flags() {
    let dir = tempfile::tempdir().unwrap();
    let kdc = data().join("raw/rawpy_kodak_dc50/RAW_KODAK_DC50.KDC");
    let out = ok(&["detect", kdc.to_str().unwrap(), "--max-levels", "1", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(
        (v["domain"].as_str(), v["cfa"].as_str()),
        (Some("mosaic"), Some("GRBG")),
        "{v}"
    );

    // 64x128, 12-bit big-endian u16, 160-byte rows (32 bytes of padding).
    let raw = dir.path().join("frame.raw");
    let mut bytes = Vec::new();
    for y in 0..128u32 {
        for x in 0..64u32 {
            let v = 64 + ((x * 37 + y * 11) % 3000) as u16;
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        bytes.extend_from_slice(&[0; 32]);
    }
    std::fs::write(&raw, bytes).unwrap();
    let grad_out = dir.path().join("grad");
    let format = [
        "--width",
        "64",
        "--height",
        "128",
        "--cfa",
        "RGGB",
        "--black",
        "60,61,62,63",
        "--white",
        "4095",
        "--endian",
        "big",
        "--stride",
        "160",
        "--container",
        "u16",
    ];
    let with_depth = |cmd: &[&str]| -> Vec<String> {
        let mut a: Vec<String> = cmd.iter().map(|s| s.to_string()).collect();
        a.extend(format.iter().map(|s| s.to_string()));
        a
    };
    let mut d = with_depth(&["detect", raw.to_str().unwrap(), "--max-levels", "1", "--json"]);
    d.extend(["--bit-depth".into(), "12".into()]);
    let v: serde_json::Value =
        serde_json::from_str(&ok(&d.iter().map(String::as_str).collect::<Vec<_>>())).unwrap();
    assert_eq!(v["cfa"].as_str(), Some("RGGB"), "{v}");
    let mut g = with_depth(&[
        "gradients",
        raw.to_str().unwrap(),
        "--out",
        grad_out.to_str().unwrap(),
    ]);
    g.extend(["--bit-depth".into(), "12".into()]);
    ok(&g.iter().map(String::as_str).collect::<Vec<_>>());
    // The same default (none) and the same refusal for both.
    for a in [
        with_depth(&["detect", raw.to_str().unwrap()]),
        with_depth(&[
            "gradients",
            raw.to_str().unwrap(),
            "--out",
            grad_out.to_str().unwrap(),
        ]),
    ] {
        let o = mosaicd(&a.iter().map(String::as_str).collect::<Vec<_>>());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{a:?}: {err}");
        assert!(err.contains("needs --bit-depth"), "{a:?}: {err}");
    }
}
