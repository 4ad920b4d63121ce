//! `mosaicd train`: train a HOG + linear SVM people detector in one input domain, or with
//! `--detector acf` an ACF detector ([`super::acf`]).

use std::time::Instant;

use mosaicd::detect::train::{
    evaluate_windows_via, list_negative_dirs, select_c, split_data, train_on, InputPipeline, TrainOptions,
};
use mosaicd::detect::ScorePrecision;
use mosaicd::progress::Progress;
use mosaicd::raw::Gains;

use super::detect_common::{DetectorArg, TrainArgs, TRAIN_NOISE_SALT};

/// Run `mosaicd train`.
pub fn run(a: TrainArgs) -> anyhow::Result<()> {
    if a.detector == DetectorArg::Acf {
        return super::acf::train(&a);
    }
    let mut o = TrainOptions {
        domain: a.domain.into(),
        cfa: a.cfa,
        seed: a.seed,
        c: a.c,
        neg_per_image: a.neg_per_image,
        mining_rounds: a.rounds,
        max_hard_per_round: a.max_hard,
        val_fraction: a.val_fraction,
        fold: a.fold,
        max_neg_images: a.max_neg_images,
        // Training noise streams differ from `eval detection`'s (which uses `--seed` directly).
        pipeline: InputPipeline::parse(&a.input, a.seed ^ TRAIN_NOISE_SALT)
            .map_err(|e| anyhow::anyhow!("--input {e}"))?,
        mirror_negatives: a.mirror_negatives,
        jitter_positives: a.jitter_positives,
        raw_negatives: a.raw_negatives,
        mosaic_taps: a.mosaic_taps,
        mosaic_tone: a.mosaic_tone,
        bias_scale: a.bias_scale,
    };
    anyhow::ensure!(
        a.bias_scale.is_finite() && a.bias_scale > 0.0,
        "--bias-scale: a positive number (1 = liblinear's -B 1), got {}",
        a.bias_scale
    );
    mosaicd::data::data_path("pedestrian/inria_pos_96x160")?;
    let root = mosaicd::data::data_root()?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?;
    let t0 = Instant::now();
    // Each stage is a log line (above a spinner on a terminal, showing the stage and the time).
    let spinner = Progress::new("train", None);
    let mut progress = |s: &str| {
        spinner.println(&format!("[{:7.1} s] {s}", t0.elapsed().as_secs_f64()));
        spinner.message(s);
    };
    let mut split = split_data(&root, o.seed, o.val_fraction, o.fold)?;
    split.extra_train_neg =
        list_negative_dirs(&a.negatives_dir).map_err(|e| anyhow::anyhow!("--negatives-dir: {e}"))?;
    let mut selection = None;
    if !a.select_c.is_empty() {
        anyhow::ensure!(
            a.select_c.iter().all(|c| c.is_finite() && *c > 0.0),
            "--select-c: every C must be a positive number, got {:?}",
            a.select_c
        );
        let (c, results) = pool.install(|| select_c(&split, &o, &a.select_c, &mut progress))?;
        spinner.println(&format!("select C: chose C = {c}"));
        o.c = c;
        selection = Some(results);
    }
    let mut model = pool.install(|| train_on(&split, &o, &mut progress))?;
    if let Some(results) = selection {
        model.provenance["c_selection"] = serde_json::json!({
            "how": "each candidate trained on an inner split of the training files, scored on its inner validation part (lowest MR at 1e-4 FPPW)",
            "candidates": results,
        });
        if o.val_fraction == 0.0 {
            // the inner split's fraction differs from the outer one only then; other models'
            // provenance stays as it was
            model.provenance["c_selection"]["inner_val_fraction"] =
                serde_json::json!(mosaicd::detect::train::inner_val_fraction(o.val_fraction));
        }
    }
    let cmd: Vec<String> = std::env::args().collect();
    model.provenance["command"] = serde_json::json!(cmd.join(" "));
    if !a.negatives_dir.is_empty() {
        model.provenance["negatives_dirs"] = serde_json::json!(a.negatives_dir);
    }
    model.provenance["train_seconds"] = serde_json::json!(t0.elapsed().as_secs_f64());
    let held_out = !split.val_pos.is_empty() && !split.val_neg.is_empty();
    if !a.no_eval && !held_out {
        spinner.println(&format!(
            "validation: skipped, nothing is held out (--val-fraction {})",
            o.val_fraction
        ));
    } else if !a.no_eval {
        let ev = pool.install(|| {
            evaluate_windows_via(
                &model,
                &split,
                o.domain,
                o.cfa,
                &o.pipeline,
                ScorePrecision::F32,
                Gains::FromFile,
                &mut progress,
            )
        })?;
        spinner.println(&format!(
            "validation: {} positives, {} negative windows, miss rate at FPPW {:?}",
            ev.positives, ev.negative_windows, ev.miss_rate_at
        ));
        model.provenance["validation"] = serde_json::to_value(&ev)?;
    }
    spinner.finish();
    model.save(&a.out)?;
    eprintln!("wrote {}", a.out.display());
    Ok(())
}
