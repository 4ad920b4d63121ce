//! `mosaicd train`: train a HOG + linear SVM people detector in one input domain, or with
//! `--detector acf` an ACF detector ([`super::acf`]).

use std::path::PathBuf;
use std::time::Instant;

use mosaicd::detect::train::{
    evaluate_windows_via, list_negative_dirs, select_c, split_data, train_on, InputPipeline, TrainOptions,
};
use mosaicd::detect::ScorePrecision;
use mosaicd::features::hog::{MosaicTaps, MosaicTone};
use mosaicd::progress::Progress;
use mosaicd::raw::levels::Gains;
use mosaicd::raw::Cfa;

use super::detect::DomainArg;

/// Mixed into `--seed` for the training images' noise streams.
pub(super) const TRAIN_NOISE_SALT: u64 = 0x7261_775f_7472_6169;

/// `--detector` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum DetectorArg {
    /// HOG + linear SVM (Dalal & Triggs).
    Hog,
    /// Aggregated channel features + boosted trees (Dollár et al.).
    Acf,
}

/// Arguments of `mosaicd train`.
#[derive(clap::Args, Debug)]
pub struct TrainArgs {
    /// Detector to train: `hog` (HOG + linear SVM) or `acf` (aggregated channel features,
    /// boosted depth-2 trees, soft cascade; reads the `--acf-*` options, the split, input and
    /// negative options, and ignores the SVM's).
    #[arg(long, value_enum, default_value_t = DetectorArg::Hog)]
    pub detector: DetectorArg,
    #[command(flatten)]
    pub acf: super::acf::AcfTrainArgs,
    /// Input domain: mosaic, grey or colour.
    #[arg(long, value_enum)]
    pub domain: DomainArg,
    /// Output model (.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Seed for the split, the negatives and the SVM.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// SVM cost C.
    #[arg(long, default_value_t = 0.01)]
    pub c: f64,
    /// Random negative windows per negative image.
    #[arg(long, default_value_t = 10)]
    pub neg_per_image: usize,
    /// Hard-negative mining rounds.
    #[arg(long, default_value_t = 1)]
    pub rounds: usize,
    /// Hard negatives kept per round (highest scores).
    #[arg(long, default_value_t = 5000)]
    pub max_hard: usize,
    /// Use at most this many training negative images (0 = all).
    #[arg(long, default_value_t = 0)]
    pub max_neg_images: usize,
    /// Held-out fraction (photos and negative images). 0 trains on every file (no validation
    /// after training; `--select-c` still holds out 0.2 of them for its inner split).
    #[arg(long, default_value_t = 0.2)]
    pub val_fraction: f64,
    /// Which block of the seeded shuffle is held out: 0 is the split the shipped models
    /// use; folds 0 .. 1/val-fraction are disjoint (0–4 at 0.2: a 5-fold cross-validation,
    /// `scripts/detection_cv.sh`).
    #[arg(long, default_value_t = 0)]
    pub fold: usize,
    /// CFA used to sample mosaics.
    #[arg(long, default_value = "RGGB")]
    pub cfa: Cfa,
    /// How the sRGB training images become model inputs: `sampled` (through the CFA / OpenCV
    /// grey / the RGB itself, no ISP) or the paper's reverse ISP to raw: `clean`, or with eq. 24
    /// noise at `low`, `medium` or `high`. The validation after training uses the same pipeline.
    #[arg(long, default_value = "sampled")]
    pub input: String,
    /// Also train on every negative image mirrored left-right.
    #[arg(long)]
    pub mirror_negatives: bool,
    /// Also train on every positive crop shifted by this many pixels left, right, up and down
    /// (edges replicated; 0 = off).
    #[arg(long, default_value_t = 0)]
    pub jitter_positives: usize,
    /// Also train on the five person-free Infinite-ISP raw scenes (rendered by the forward ISP).
    #[arg(long)]
    pub raw_negatives: bool,
    /// Derivative of mosaic features: `same-site` (`(I(x+2) − I(x−2))/2`, the centre's own
    /// colour; the shipped mosaic models) or `paper` (`I(x+1) − I(x−1)`, the paper's central
    /// difference on the mosaic). Written into the model file.
    #[arg(long, default_value = "same-site")]
    pub mosaic_taps: MosaicTaps,
    /// How the reverse ISP's raw frames become mosaics (`--input clean|low|medium|high`):
    /// `linear` (the raw frame as it is; the paper's way) or `srgb` (each site white balanced with
    /// the profile's gains and sRGB-encoded: 3.8 points fewer misses cross-validated,
    /// docs/detection.md "The mosaic's tone"). Written into the model file; a sampled mosaic is
    /// already sRGB, so with `--input sampled` it only labels the file.
    #[arg(long, default_value = "linear")]
    pub mosaic_tone: MosaicTone,
    /// The SVM's bias feature B: the bias is regularised as b²/2B², so a larger B leaves it
    /// freer (Dalal & Triggs's SVMLight does not regularise it at all). 1 = liblinear's `-B 1`,
    /// which every model trained before 2026-11-25 used (a model file without `bias_scale` in its
    /// provenance); 10 missed 3 (mosaic) to 7 (colour) points fewer on the inner split
    /// (docs/detection.md, "The SVM's bias").
    #[arg(long, default_value_t = 10.0)]
    pub bias_scale: f64,
    /// Also train on the PNG/JPEG images of this directory (repeatable), e.g. scikit-image's
    /// person-free photographs written by `scripts/skimage_negatives.py`. Training only: never
    /// held out, so the validation split is the same with or without them.
    #[arg(long, value_name = "DIR")]
    pub negatives_dir: Vec<PathBuf>,
    /// Choose C among these values (comma-separated) on an inner split of the training files
    /// (the held-out validation split is not looked at), then train with it; overrides `--c`.
    #[arg(long, value_delimiter = ',')]
    pub select_c: Vec<f64>,
    /// Skip the validation (window-level DET) after training.
    #[arg(long)]
    pub no_eval: bool,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

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
