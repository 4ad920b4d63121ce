//! The ACF paths of `mosaicd train --detector acf` and `mosaicd detect` with an ACF model.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use mosaicd::detect::acf::{AcfDetector, AcfModel, AcfOptions};
use mosaicd::detect::boost::{BoostOptions, TraceOptions, TreeOptions};
use mosaicd::detect::channels::{ChannelInput, PyramidOptions};
use mosaicd::detect::train::acf::{
    calibrate_cascade, evaluate_acf_windows, positive_windows, set_trace, train_acf, AcfTrainOptions,
};
use mosaicd::detect::train::{
    inner_split, inner_val_fraction, list_negative_dirs, split_data, InputPipeline,
};
use mosaicd::detect::NmsMethod;
use mosaicd::raw::levels::Gains;

use super::detect::{load_frame, print_boxes, save_preview, DetectArgs, Frame};
use super::train::TrainArgs;

/// Options of `mosaicd train` that only the ACF detector reads.
#[derive(clap::Args, Debug, Clone)]
pub struct AcfTrainArgs {
    /// ACF: trees after each stage (stage 0 on random negatives, then one hard-negative mining
    /// round per further entry; Dollár's 32,128,512,2048).
    #[arg(long, value_delimiter = ',', default_value = "32,128,512,2048")]
    pub acf_stages: Vec<usize>,
    /// ACF: depth of the boosted trees.
    #[arg(long, default_value_t = 2)]
    pub acf_depth: usize,
    /// ACF: fraction of the features tried at each tree node (Dollár's INRIA detector: 1/16).
    #[arg(long, default_value_t = 1.0 / 16.0)]
    pub acf_frac_features: f64,
    /// ACF: Real AdaBoost instead of discrete (Dollár's and our default).
    #[arg(long)]
    pub acf_real: bool,
    /// ACF: negative windows sampled per stage (nNeg).
    #[arg(long, default_value_t = 5000)]
    pub acf_neg: usize,
    /// ACF: negative windows per image and stage (nPerNeg).
    #[arg(long, default_value_t = 25)]
    pub acf_per_neg: usize,
    /// ACF: negative windows kept over all stages (nAccNeg).
    #[arg(long, default_value_t = 10000)]
    pub acf_acc_neg: usize,
    /// ACF: do not train; evaluate this ACF model on the held-out split (window protocol, the
    /// split of --seed, --val-fraction, --fold; --out is not written).
    #[arg(long, value_name = "MODEL")]
    pub acf_evaluate: Option<std::path::PathBuf>,
    /// ACF: soft-cascade threshold written into a trained model (default Dollár's −1), or with
    /// --acf-evaluate the threshold the model is evaluated with (a very negative value scores
    /// every window with every tree).
    #[arg(long, allow_hyphen_values = true)]
    pub acf_casc_thr: Option<f32>,
    /// ACF: the pyramid's power-law exponents λ (colour, magnitude, orientations) instead of
    /// measuring them on the training positives (Dollár's INRIA values: 0,0.11,0.11).
    #[arg(long, value_delimiter = ',')]
    pub acf_lambdas: Option<Vec<f32>>,
    /// ACF: train and validate on the inner split of the training files (the held-out files are
    /// not touched): for choosing settings such as the cascade threshold.
    #[arg(long)]
    pub acf_inner: bool,
    /// ACF: the calibrated per-tree rejection trace (floor, loss fraction, margin; see
    /// docs/acf.md), calibrated on the training positives after training or with
    /// --acf-calibrate; `none` keeps only the constant --acf-casc-thr.
    #[arg(long, value_name = "FLOOR,LOSS,MARGIN|none", allow_hyphen_values = true)]
    pub acf_trace: Option<String>,
    /// ACF: do not train; calibrate a rejection trace (--acf-trace) with this model, trained on
    /// the inner split of the training files (--acf-inner), on the inner held-out positives, and
    /// write it into --acf-calibrate-into (default: this model) as --out.
    #[arg(long, value_name = "INNER_MODEL")]
    pub acf_calibrate: Option<std::path::PathBuf>,
    /// ACF: the model (trained on all training files) that receives the trace of --acf-calibrate.
    #[arg(long, value_name = "MODEL")]
    pub acf_calibrate_into: Option<std::path::PathBuf>,
}

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
        pipeline: InputPipeline::parse(&a.input, a.seed ^ super::train::TRAIN_NOISE_SALT)
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
        n_neg: x.acf_neg,
        per_neg: x.acf_per_neg,
        acc_neg: x.acf_acc_neg,
        max_neg_images: a.max_neg_images,
        measure_lambdas: x.acf_lambdas.is_none(),
        casc_thr: x.acf_casc_thr.unwrap_or(mosaicd::detect::acf::CASC_THR),
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

/// The channel input of a decoded frame.
fn channel_input(f: &Frame) -> ChannelInput<'_> {
    match f {
        Frame::Mosaic(m, cfa) => ChannelInput::Mosaic {
            image: m.view(),
            cfa: *cfa,
        },
        Frame::Grey(g) => ChannelInput::GreyU8(g.view()),
        Frame::Colour(c) => ChannelInput::Rgb8(c.view()),
    }
}

/// `mosaicd detect` with an ACF model file.
pub fn detect(args: &DetectArgs) -> anyhow::Result<()> {
    let model = AcfModel::load(Path::new(&args.model))?;
    let tone = args.det.mosaic_tone.unwrap_or(model.mosaic_tone);
    let wb = args.det.wb_gains;
    let frame = load_frame(&args.input, args.as_domain, &|f| {
        mosaicd::detect::input::MosaicPrep { tone, gains: wb }
            .mosaic(f)
            .context("--wb-gains")
    })?;
    if args.as_domain.is_none() && model.domain != frame.domain() {
        eprintln!(
            "warning: {} was trained on {} input, but {} is read as {} (a transfer case)",
            args.model,
            model.domain.name(),
            args.input.input.display(),
            frame.domain().name()
        );
    }
    let d = &args.det;
    let nms = match d.nms {
        super::detect::NmsArg::Group => NmsMethod::Group {
            threshold: 2,
            eps: 0.2,
        },
        super::detect::NmsArg::Greedy => NmsMethod::Greedy { iou: 0.5 },
        super::detect::NmsArg::None => NmsMethod::None,
    };
    let opts = AcfOptions {
        upsample: d.upsample,
        approx: d.approx.map(|a| a.saturating_sub(1)),
        max_levels: d.max_levels,
        hit_threshold: d.threshold,
        nms,
    };
    let det = AcfDetector::new(model, &opts)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    let input = channel_input(&frame);
    let (boxes, st) = pool.install(|| det.detect(&input))?;
    let ms = |t: std::time::Duration| t.as_secs_f64() * 1e3;
    let per_window = st.trees_evaluated as f64 / st.windows.max(1) as f64;
    if args.json {
        let out = serde_json::json!({
            "input": args.input.input.display().to_string(),
            "detector": "acf",
            "domain": frame.domain(),
            "cfa": frame.cfa().map(|c| c.name()),
            "model": args.model,
            "model_domain": det.model().domain,
            "detections": boxes,
            "stats": {
                "levels": st.levels, "windows": st.windows, "hits": st.hits,
                "trees_per_window": per_window,
                "total_ms": ms(st.total), "channels_ms": ms(st.channels), "score_ms": ms(st.score), "nms_ms": ms(st.nms),
            }
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{}: {} detections (acf; {} levels, {} windows, {:.1} trees per window, {} hits, {:.1} ms: channels {:.1}, scoring {:.1})",
            args.input.input.display(),
            boxes.len(),
            st.levels,
            st.windows,
            per_window,
            st.hits,
            ms(st.total),
            ms(st.channels),
            ms(st.score)
        );
        print_boxes(&boxes);
    }
    save_preview(&frame, &boxes, args.preview.as_deref())
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::super::train::{DetectorArg, TrainArgs};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        train: TrainArgs,
    }

    #[test]
    fn train_parses_the_acf_options_and_keeps_hog_the_default() {
        let c = Cli::try_parse_from(["x", "--domain", "mosaic", "--out", "m.json"]).unwrap();
        assert_eq!(c.train.detector, DetectorArg::Hog);
        assert_eq!(c.train.acf.acf_stages, vec![32, 128, 512, 2048]);
        let c = Cli::try_parse_from([
            "x",
            "--detector",
            "acf",
            "--domain",
            "mosaic",
            "--out",
            "m.json",
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
    }
}
