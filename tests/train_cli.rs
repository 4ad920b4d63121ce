//! `mosaicd train` on the real INRIA positives and a few real negative images: training through
//! the paper's reverse ISP is deterministic for any thread count, records its input pipeline in
//! the model's provenance, yields a model that loads and scores, and bad options are clear errors.
//! The full training runs that rebuilt `models/` are in docs/detection.md "Models".

use std::path::Path;
use std::process::{Command, Output};

use mosaicd::detect::model::{Domain, LinearModel};

fn mosaicd(args: &[&str]) -> Output {
    mosaicd::data::require("pedestrian/inria_pos_96x160");
    Command::new(env!("CARGO_BIN_EXE_mosaicd"))
        .args(args)
        .env(mosaicd::data::DATA_ENV, mosaicd::data::data_root())
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
}
