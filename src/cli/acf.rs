//! `mosaicd train --detector acf` (training and `--acf-evaluate`). `mosaicd detect`, `eval
//! detection` and `bench detect` run ACF models through [`mosaicd::detect::PeopleDetector`].

use std::time::Instant;

use anyhow::Context;
use mosaicd::detect::PyramidOptions;
use mosaicd::detect::{
    calibrate_cascade, evaluate_acf_windows, positive_windows, set_trace, train_acf, AcfTrainOptions,
};
use mosaicd::detect::{inner_split, inner_val_fraction, list_negative_dirs, split_data, InputPipeline};
use mosaicd::detect::{AcfModel, FeatureSet};
use mosaicd::detect::{BoostOptions, TraceOptions, TreeOptions};
use mosaicd::raw::Gains;

use super::detect_common::{TrainArgs, TRAIN_NOISE_SALT};

/// `--acf-trace`: `floor,loss,margin` or `none` (absent: the default trace).
fn parse_trace(s: Option<&str>) -> anyhow::Result<Option<TraceOptions>> {
    let Some(s) = s else {
        return Ok(Some(TraceOptions::default()));
    };
    if s.trim() == "none" {
        return Ok(None);
    }
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--acf-trace {s}: floor,loss,margin or none"))?;
    anyhow::ensure!(
        v.len() == 3,
        "--acf-trace {s}: three values floor,loss,margin or none"
    );
    Ok(Some(TraceOptions {
        floor: v[0] as f32,
        loss: v[1],
        margin: v[2] as f32,
    }))
}

/// `mosaicd train --detector acf`.
pub fn train(a: &TrainArgs) -> anyhow::Result<()> {
    let x = &a.acf;
    if let Some(l) = &x.acf_lambdas {
        anyhow::ensure!(
            l.len() == 3,
            "--acf-lambdas: three values (colour, magnitude, orientations), got {l:?}"
        );
    }
    let o = AcfTrainOptions {
        domain: a.domain.into(),
        cfa: a.cfa,
        seed: a.seed,
        pipeline: InputPipeline::parse(&a.input, a.seed ^ TRAIN_NOISE_SALT)
            .map_err(|e| anyhow::anyhow!("--input {e}"))?,
        mosaic_tone: a.mosaic_tone,
        stages: x.acf_stages.clone(),
        boost: BoostOptions {
            tree: TreeOptions {
                max_depth: x.acf_depth,
                frac_features: x.acf_frac_features,
                ..TreeOptions::default()
            },
            discrete: !x.acf_real,
            ..BoostOptions::default()
        },
        features: FeatureSet::ALL
            .into_iter()
            .find(|f| f.name() == x.acf_features)
            .context("--acf-features: all or gradient")?,
        n_neg: x.acf_neg,
        per_neg: x.acf_per_neg,
        acc_neg: x.acf_acc_neg,
        max_neg_images: a.max_neg_images,
        measure_lambdas: x.acf_lambdas.is_none(),
        casc_thr: x.acf_casc_thr.unwrap_or(mosaicd::detect::CASC_THR),
        trace: parse_trace(x.acf_trace.as_deref())?,
        pyramid: PyramidOptions {
            lambdas: match &x.acf_lambdas {
                Some(l) => [l[0], l[1], l[2]],
                None => PyramidOptions::default().lambdas,
            },
            ..PyramidOptions::default()
        },
        ..AcfTrainOptions::default()
    };
    let root = mosaicd::data::data_root()?;
    mosaicd::data::data_path("pedestrian/inria_pos_96x160")?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?;
    let t0 = Instant::now();
    let mut progress = |s: &str| eprintln!("[{:7.1} s] {s}", t0.elapsed().as_secs_f64());
    let mut split = split_data(&root, o.seed, a.val_fraction, a.fold)?;
    split.extra_train_neg =
        list_negative_dirs(&a.negatives_dir).map_err(|e| anyhow::anyhow!("--negatives-dir: {e}"))?;
    if x.acf_inner {
        split = inner_split(&split, o.seed, inner_val_fraction(a.val_fraction));
    }
    let validate = |model: &AcfModel, progress: &mut (dyn FnMut(&str) + Send)| {
        pool.install(|| {
            evaluate_acf_windows(
                model,
                &split,
                o.domain,
                o.cfa,
                &o.pipeline,
                Gains::FromFile,
                progress,
            )
        })
    };
    if let Some(path) = &x.acf_evaluate {
        let mut model = AcfModel::load(path)?;
        if let Some(t) = x.acf_casc_thr {
            model.casc_thr = t;
            model.casc_trace = None;
        }
        let ev = validate(&model, &mut progress)?;
        println!(
            "{}: {} positives, {} negative windows, miss rate at FPPW {:?}",
            path.display(),
            ev.positives,
            ev.negative_windows,
            ev.miss_rate_at
        );
        let mut p = ev.scores.positives.clone();
        p.sort_by(f32::total_cmp);
        let q = |f: f64| p[((p.len() - 1) as f64 * f) as usize];
        println!(
            "positive scores: min {:.3}, 10% {:.3}, 25% {:.3}, median {:.3}, max {:.3}",
            q(0.0),
            q(0.1),
            q(0.25),
            q(0.5),
            q(1.0)
        );
        // The running score of the held-out positives along the trees (the soft cascade rejects
        // a window the first time it is at most the threshold).
        let xs = pool.install(|| {
            positive_windows(
                &split.val_pos,
                &model,
                o.domain,
                o.cfa,
                &o.pipeline,
                Gains::FromFile,
            )
        })?;
        let trees = &model.classifier.trees;
        let mut run = vec![0.0f32; xs.len()];
        let mut low = vec![f32::INFINITY; xs.len()];
        let mut k = 1;
        for (t, tree) in trees.iter().enumerate() {
            for ((r, l), x) in run.iter_mut().zip(low.iter_mut()).zip(&xs) {
                *r += tree.apply(|f| x[f]);
                *l = l.min(*r);
            }
            if t + 1 == k || t + 1 == trees.len() {
                let mut v = run.clone();
                v.sort_by(f32::total_cmp);
                let below = low.iter().filter(|&&l| l <= model.casc_thr).count();
                println!(
                    "after {:4} trees: positives' running score 10% {:8.3}, median {:8.3}; {} of {} were at most the cascade threshold {} so far",
                    t + 1,
                    v[v.len() / 10],
                    v[v.len() / 2],
                    below,
                    v.len(),
                    model.casc_thr
                );
                k *= 2;
            }
        }
        return Ok(());
    }
    if let Some(path) = &x.acf_calibrate {
        let inner_model = AcfModel::load(path)?;
        let t = o
            .trace
            .context("--acf-calibrate needs a trace (--acf-trace floor,loss,margin)")?;
        anyhow::ensure!(
            x.acf_inner,
            "--acf-calibrate: pass --acf-inner (the trace is calibrated on the inner held-out positives)"
        );
        let xs = pool.install(|| {
            positive_windows(
                &split.val_pos,
                &inner_model,
                o.domain,
                o.cfa,
                &o.pipeline,
                Gains::FromFile,
            )
        })?;
        let trace = pool.install(|| calibrate_cascade(&inner_model, &xs, &t))?;
        let into = x.acf_calibrate_into.as_ref().unwrap_or(path);
        let mut model = AcfModel::load(into)?;
        let src = format!(
            "{} held-out positives of the inner split scored by {}",
            xs.len(),
            path.display()
        );
        set_trace(&mut model, &trace, &t, &src);
        model.save(&a.out)?;
        eprintln!(
            "rejection trace calibrated with {} on {} inner held-out positives, stored in {}: wrote {}",
            path.display(),
            xs.len(),
            into.display(),
            a.out.display()
        );
        return Ok(());
    }
    let mut model = pool.install(|| train_acf(&split, &o, &mut progress))?;
    let train_seconds = t0.elapsed().as_secs_f64();
    let cmd: Vec<String> = std::env::args().collect();
    model.provenance["command"] = serde_json::json!(cmd.join(" "));
    model.provenance["train_seconds"] = serde_json::json!(train_seconds);
    model.provenance["threads"] = serde_json::json!(pool.current_num_threads());
    model.provenance["val_fraction"] = serde_json::json!(a.val_fraction);
    if a.fold != 0 {
        model.provenance["fold"] = serde_json::json!(a.fold);
    }
    if x.acf_inner {
        model.provenance["inner_split"] = serde_json::json!(true);
    }
    eprintln!(
        "training took {train_seconds:.1} s on {} threads",
        pool.current_num_threads()
    );
    let held_out = !split.val_pos.is_empty() && !split.val_neg.is_empty();
    if !a.no_eval && held_out {
        let ev = validate(&model, &mut progress)?;
        eprintln!(
            "validation: {} positives, {} negative windows, miss rate at FPPW {:?}",
            ev.positives, ev.negative_windows, ev.miss_rate_at
        );
        model.provenance["validation"] = serde_json::to_value(&ev)?;
    } else if !a.no_eval {
        eprintln!(
            "validation: skipped, nothing is held out (--val-fraction {})",
            a.val_fraction
        );
    }
    model.save(&a.out)?;
    eprintln!("wrote {}", a.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::super::detect_common::{DetectorArg, TrainArgs};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        train: TrainArgs,
    }

    /// `mosaicd train --detector acf --domain mosaic --out m.json` followed by `extra`.
    fn acf(extra: &[&str]) -> Result<Cli, clap::Error> {
        let base = ["x", "--detector", "acf", "--domain", "mosaic", "--out", "m.json"];
        Cli::try_parse_from(base.iter().chain(extra))
    }

    #[test]
    fn train_parses_the_acf_options_and_keeps_hog_the_default() {
        let c = Cli::try_parse_from(["x", "--domain", "mosaic", "--out", "m.json"]).unwrap();
        assert_eq!(c.train.detector, DetectorArg::Hog);
        assert_eq!(c.train.acf.acf_stages, vec![32, 128, 512, 2048]);
        let c = acf(&[
            "--acf-stages",
            "4,8",
            "--acf-lambdas",
            "0,0.1,0.1",
            "--acf-casc-thr",
            "-8",
        ])
        .unwrap();
        assert_eq!(c.train.detector, DetectorArg::Acf);
        assert_eq!(c.train.acf.acf_stages, vec![4, 8]);
        assert_eq!(c.train.acf.acf_lambdas, Some(vec![0.0, 0.1, 0.1]));
        assert_eq!(c.train.acf.acf_casc_thr, Some(-8.0));
        assert_eq!(c.train.acf.acf_features, "all");
        let c = acf(&["--acf-features", "gradient"]).unwrap();
        assert_eq!(c.train.acf.acf_features, "gradient");
        assert!(acf(&["--acf-features", "luv"]).is_err());
    }
}
