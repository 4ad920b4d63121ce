//! `mosaicd train` on the real INRIA positives and a few real negative images: training through
//! the paper's reverse ISP is deterministic for any thread count, records its input pipeline in
//! the model's provenance, yields a model that loads and scores, extra negatives (mirrored, raw
//! scenes, `--negatives-dir`) join the training set and are recorded, and bad options are clear
//! errors.
//! The full training runs that rebuilt `models/` are in docs/detection.md "Models".

use std::path::Path;
use std::process::{Command, Output};

use mosaicd::detect::split_data;
use mosaicd::detect::{Domain, LinearModel};

fn mosaicd(args: &[&str]) -> Output {
    mosaicd::data::require("pedestrian/inria_pos_96x160");
    Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(args)
        .env(mosaicd::data::DATA_ENV, mosaicd::data::require_root())
        .output()
        .expect("run mosaicd")
}

/// A small but real run: every training positive, 4 negative images, one mining round.
fn train(out: &Path, input: &str, threads: &str) -> LinearModel {
    train_with(out, input, threads, &[]).0
}

fn train_with(out: &Path, input: &str, threads: &str, extra: &[&str]) -> (LinearModel, String) {
    let mut args = vec![
        "train",
        "--domain",
        "mosaic",
        "--input",
        input,
        "--max-neg-images",
        "4",
        "--rounds",
        "1",
        "--no-eval",
        "--threads",
        threads,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = mosaicd(&args);
    assert!(
        o.status.success(),
        "train failed:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        stderr.contains("positives") && stderr.contains("mining round 1"),
        "no progress shown:\n{stderr}"
    );
    (LinearModel::load(out, Domain::Mosaic).unwrap(), stderr)
}

#[test]
fn reverse_isp_training_is_deterministic_and_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let a = train(&dir.path().join("a.json"), "clean", "1");
    let b = train(&dir.path().join("b.json"), "raw-clean", "2");
    assert_eq!(a.domain, Domain::Mosaic);
    assert_eq!(a.weights.len(), 3780);
    assert!(a.weights.iter().all(|w| w.is_finite()) && a.weights.iter().any(|&w| w != 0.0));
    // Bit-identical for 1 and 2 threads ("clean" and "raw-clean" name the same pipeline).
    assert_eq!(a.weights, b.weights);
    assert_eq!(a.bias, b.bias);
    assert_eq!(a.provenance["input_pipeline"], "raw-clean");
    assert_eq!(a.provenance["training_vectors"], b.provenance["training_vectors"]);
    assert!(a.provenance["noise_seed"].is_u64());
    // One solve before the mining round and one after it, each with how it ended.
    let solves = a.provenance["svm_solves"]
        .as_array()
        .expect("svm_solves recorded");
    assert_eq!(solves.len(), 2, "{solves:?}");
    assert_eq!(solves, b.provenance["svm_solves"].as_array().unwrap());
    for s in solves {
        assert!(s["epochs"].as_u64().unwrap() >= 1, "{s}");
        assert!(s["converged"].is_boolean() && s["pg_spread"].is_f64(), "{s}");
    }
    assert!(
        solves[1]["vectors"].as_u64().unwrap() > solves[0]["vectors"].as_u64().unwrap(),
        "the second solve has the hard negatives: {solves:?}"
    );
}

#[test]
fn mirrored_and_raw_scene_negatives_join_the_training_set() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, plain_log) = train_with(&dir.path().join("p.json"), "sampled", "2", &[]);
    let (more, log) = train_with(
        &dir.path().join("m.json"),
        "sampled",
        "2",
        &["--mirror-negatives", "--raw-negatives"],
    );
    assert!(log.contains("5 raw scenes"), "{log}");
    assert_eq!(more.provenance["mirror_negatives"], true);
    assert_eq!(more.provenance["raw_negatives"], true);
    assert_eq!(plain.provenance["mirror_negatives"], false);
    // Random windows before mining (10 per image): 4 images → 40; mirrored → 80, plus the 5 raw
    // scenes → 130.
    let random_negatives = |log: &str| -> usize {
        let line = log
            .lines()
            .find(|l| l.contains("svm:"))
            .expect("svm progress line");
        let n = line.rsplit_once(", ").unwrap().1.trim_end_matches(" negatives");
        n.parse().unwrap()
    };
    assert_eq!(random_negatives(&plain_log), 40);
    assert_eq!(random_negatives(&log), 130);
    assert_ne!(plain.weights, more.weights);
}

#[test]
fn jittered_positives_join_the_training_set() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, _) = train_with(&dir.path().join("p.json"), "sampled", "2", &[]);
    let (jit, _) = train_with(
        &dir.path().join("j.json"),
        "sampled",
        "2",
        &["--jitter-positives", "2"],
    );
    assert_eq!(plain.provenance["jitter_positives"], 0);
    assert_eq!(jit.provenance["jitter_positives"], 2);
    // Four shifted copies of every training positive.
    let n = |m: &LinearModel, k: &str| m.provenance[k].as_u64().unwrap();
    assert_eq!(n(&plain, "train_positives"), n(&jit, "train_positives"));
    assert_eq!(n(&plain, "positive_windows"), n(&plain, "train_positives"));
    assert_eq!(n(&jit, "positive_windows"), 5 * n(&jit, "train_positives"));
    assert_ne!(plain.weights, jit.weights);
}

#[test]
fn the_bias_scale_is_recorded_and_a_freer_bias_is_more_negative() {
    let dir = tempfile::tempdir().unwrap();
    let (freer, _) = train_with(&dir.path().join("b10.json"), "sampled", "2", &[]);
    let (old, _) = train_with(
        &dir.path().join("b1.json"),
        "sampled",
        "2",
        &["--bias-scale", "1"],
    );
    assert_eq!(freer.provenance["bias_scale"], 10.0, "the default");
    assert_eq!(old.provenance["bias_scale"], 1.0);
    // Windows with people are rare: the bias is negative, and a regularised one is pulled
    // towards zero.
    assert!(
        freer.bias < old.bias && old.bias < 0.0,
        "{} vs {}",
        freer.bias,
        old.bias
    );
}

#[test]
fn mosaic_taps_are_chosen_and_written_into_the_model() {
    use mosaicd::features::hog::MosaicTaps;
    let dir = tempfile::tempdir().unwrap();
    let (site, _) = train_with(&dir.path().join("s.json"), "sampled", "2", &[]);
    let (paper, _) = train_with(
        &dir.path().join("p.json"),
        "sampled",
        "2",
        &["--mosaic-taps", "paper"],
    );
    assert_eq!(paper.mosaic_taps, MosaicTaps::Paper);
    assert_eq!(site.mosaic_taps, MosaicTaps::SameSite);
    assert_ne!(paper.weights, site.weights);
    let o = mosaicd(&["train", "--domain", "mosaic", "--mosaic-taps", "diagonal"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("diagonal") && e.contains("paper, same-site"), "{e}");
}

#[test]
fn folds_hold_out_other_photos_and_are_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let (f0, _) = train_with(&dir.path().join("f0.json"), "sampled", "2", &[]);
    let (f3, _) = train_with(&dir.path().join("f3.json"), "sampled", "2", &["--fold", "3"]);
    assert_eq!(f3.provenance["fold"], 3);
    assert!(f0.provenance.get("fold").is_none(), "fold 0 files stay as before");
    assert_ne!(f0.provenance["train_positives"], f3.provenance["train_positives"]);
    assert_ne!(f0.weights, f3.weights);
    let out = dir.path().join("bad.json");
    let o = mosaicd(&[
        "train",
        "--domain",
        "mosaic",
        "--fold",
        "5",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("fold") && err.contains('5') && err.contains("floor(1 / held-out fraction)"),
        "{err}"
    );
    assert!(!out.exists(), "no model may be written on error");
}

/// Two synthetic 160x256 PNGs (a seeded texture with a few edges) in `dir`.
fn write_negatives(dir: &Path) {
    for (k, name) in ["b.png", "a.png"].iter().enumerate() {
        let mut state = 0x9e37_79b9_u32.wrapping_mul(k as u32 + 1);
        let img = image::RgbImage::from_fn(160, 256, |x, y| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let n = (state >> 26) as u8;
            let v = if (x / 24 + y / 40 + k as u32).is_multiple_of(2) {
                60
            } else {
                170
            };
            image::Rgb([v + n, v / 2 + n, 255 - v - n])
        });
        img.save(dir.join(name)).unwrap();
    }
    std::fs::write(dir.join("notes.txt"), "not an image").unwrap();
}

#[test]
fn negatives_dir_images_are_training_only_recorded_and_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let negs = dir.path().join("negs");
    std::fs::create_dir(&negs).unwrap();
    write_negatives(&negs);
    let extra = ["--negatives-dir", negs.to_str().unwrap(), "--mirror-negatives"];
    let (a, log) = train_with(&dir.path().join("a.json"), "sampled", "1", &extra);
    let (b, _) = train_with(&dir.path().join("b.json"), "sampled", "2", &extra);
    assert!(log.contains("2 training-only images"), "{log}");
    // Bit-identical for 1 and 2 threads.
    assert_eq!(a.weights, b.weights);
    assert_eq!(a.bias, b.bias);
    // 4 split images + 2 training-only ones, each mirrored, 10 random windows each: 120.
    let svm_line = log
        .lines()
        .find(|l| l.contains("svm:"))
        .expect("svm progress line");
    assert!(svm_line.ends_with(", 120 negatives"), "{svm_line}");
    let p = &a.provenance;
    assert_eq!(p["training_only_negative_images"], 2);
    assert_eq!(p["negatives_dirs"][0], negs.to_str().unwrap());
    let files = p["training_only_negatives"].as_array().unwrap();
    // Sorted by name, each with its size, pixel digest and random windows (20: mirror included).
    assert_eq!(files[0]["file"], "a.png");
    assert_eq!(files[1]["file"], "b.png");
    assert!(files.iter().all(|f| f["width"] == 160 && f["height"] == 256));
    assert!(files.iter().all(|f| f["random_windows"] == 20));
    assert_ne!(files[0]["rgb_fnv1a64"], files[1]["rgb_fnv1a64"]);
    assert_eq!(
        p["training_only_negatives"],
        b.provenance["training_only_negatives"]
    );
    // The split's own negatives are those of the plain split (nothing of the new ones held out).
    let split = split_data(&mosaicd::data::require_root(), 1, 0.2, 0).unwrap();
    assert_eq!(p["train_negative_images"], split.train_neg.len());
}

#[test]
fn bad_negatives_dirs_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let missing = dir.path().join("missing");
    for (bad, what) in [(&missing, "No such file"), (&empty, "no PNG or JPEG images")] {
        let o = mosaicd(&[
            "train",
            "--domain",
            "mosaic",
            "--negatives-dir",
            bad.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("--negatives-dir") && err.contains(bad.to_str().unwrap()) && err.contains(what),
            "{err}"
        );
        assert!(!out.exists(), "no model may be written on error");
    }
}

#[test]
fn c_is_selected_on_an_inner_split() {
    let dir = tempfile::tempdir().unwrap();
    let (m, log) = train_with(
        &dir.path().join("s.json"),
        "sampled",
        "2",
        &["--select-c", "0.01,0.1"],
    );
    assert!(log.contains("select C: chose C ="), "{log}");
    let cands = m.provenance["c_selection"]["candidates"].as_array().unwrap();
    assert_eq!(cands.len(), 2);
    let chosen = m.provenance["c"].as_f64().unwrap();
    assert!(chosen == 0.01 || chosen == 0.1, "{chosen}");
}

#[test]
fn val_fraction_zero_trains_on_every_file_and_still_selects_c() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("all.json");
    let o = mosaicd(&[
        "train",
        "--domain",
        "mosaic",
        "--max-neg-images",
        "4",
        "--rounds",
        "1",
        "--val-fraction",
        "0",
        "--select-c",
        "0.01,0.1",
        "--mosaic-tone",
        "srgb",
        "--input",
        "clean",
        "--threads",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    let log = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "train failed:\n{log}");
    assert!(log.contains("select C: chose C ="), "{log}");
    assert!(log.contains("validation: skipped, nothing is held out"), "{log}");
    let m = LinearModel::load(&out, Domain::Mosaic).unwrap();
    let split = mosaicd::detect::split_data(&mosaicd::data::require_root(), 1, 0.2, 0).unwrap();
    let every = split.train_pos.len() + split.val_pos.len();
    assert_eq!(m.provenance["train_positives"].as_u64().unwrap() as usize, every);
    assert!(m.provenance.get("validation").is_none());
    assert_eq!(
        m.provenance["c_selection"]["candidates"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
    assert_eq!(
        m.provenance["c_selection"]["inner_val_fraction"].as_f64(),
        Some(0.2)
    );
    // the provenance says what the srgb mosaic is
    let note = m.provenance["input_note"].as_str().unwrap();
    assert!(note.contains("white balanced") && note.contains("srgb"), "{note}");
}

#[test]
fn bad_training_options_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let o = mosaicd(&[
        "train",
        "--domain",
        "mosaic",
        "--input",
        "foggy",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--input") && err.contains("foggy") && err.contains("sampled, clean"),
        "{err}"
    );
    assert!(!out.exists(), "no model may be written on error");
    let o = mosaicd(&[
        "train",
        "--domain",
        "grey",
        "--select-c",
        "0.1,-1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--select-c") && err.contains("-1"), "{err}");
    assert!(!out.exists(), "no model may be written on error");
    let o = mosaicd(&[
        "train",
        "--domain",
        "grey",
        "--bias-scale",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--bias-scale") && err.contains('0'), "{err}");
    assert!(!out.exists(), "no model may be written on error");
    // a held-out fraction too small for C selection's inner split: refused before any training
    let o = mosaicd(&[
        "train",
        "--domain",
        "grey",
        "--val-fraction",
        "0.001",
        "--select-c",
        "0.1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("val_fraction") && err.contains("0.001"), "{err}");
    assert!(!err.contains("mining round"), "trained before refusing:\n{err}");
    assert!(!out.exists(), "no model may be written on error");
}
