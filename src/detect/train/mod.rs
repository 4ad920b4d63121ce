//! Training a HOG + linear SVM people detector (Dalal & Triggs 2005): positives, random negative
//! windows, SVM, hard-negative mining rounds; plus the window-level evaluation (DET: miss rate at a
//! false-positives-per-window rate) on a held-out split.
//!
//! ```
//! use mosaicd::detect::train::photo_prefix;
//! assert_eq!(photo_prefix("crop001001a.png"), "crop001001");
//! assert_eq!(photo_prefix("person_017b.png"), "person_017");
//! ```
//!
//! # Data and domains
//! Positives: `pedestrian/inria_pos_96x160` (the 64x128 window at (16, 16)); the validation split
//! holds out whole photos (file prefix without the trailing letter, which also groups the
//! mirrors). Negatives: person-free photos (`neg_inria/`, `neg/`, Kodak without 04 05 12 14 15 18),
//! split by a seeded shuffle; optionally also training-only negatives that are never held out (the
//! five Infinite-ISP raw scenes, [`TrainOptions::raw_negatives`]; the images of
//! [`Split::extra_train_neg`], e.g. scikit-image's person-free photographs written by
//! `scripts/skimage_negatives.py`), so the held-out split is the same with or without them. Every
//! image is brought into the model's input domain: colour (RGB), grey (OpenCV's RGB→grey), or
//! mosaic, through [`TrainOptions::pipeline`]: either sampled straight from the sRGB image
//! ([`InputPipeline::Sampled`]: through the CFA for the mosaic, no linearisation or white balance;
//! `models/mosaic.json` and `models/colour.json`) or the paper's way through the reverse ISP to
//! raw ([`InputPipeline::ReverseIsp`], optionally noisy; `models/mosaic_raw.json`,
//! `models/colour_raw.json`). Training images use noise streams of their own (the pipeline's seed
//! and the image's index), never those of the evaluation.
//!
//! # Input pipelines of the evaluation
//! [`InputPipeline::Sampled`] is the training convention above. [`InputPipeline::ReverseIsp`] is the
//! paper's: every sRGB image goes through the reverse ISP ([`raw_from_srgb`](crate::isp::raw_from_srgb), default camera
//! profile, the chosen CFA) to a raw frame, optionally with the paper's eq. 24 noise at one of the
//! three levels (seeded per image, so runs are deterministic), then the mosaic domain reads the raw
//! frame directly in the model's tone ([`MosaicPrep`]: [`MosaicTone::Linear`], the raw frame as
//! it is, or [`MosaicTone::Srgb`], each site white balanced and sRGB-encoded with the frame's own
//! gains, which are the profile's) while the colour and grey domains see it through the forward ISP
//! ([`srgb_from_raw`](crate::isp::srgb_from_raw), Malvar demosaicing). A sampled mosaic is already white balanced and
//! sRGB-encoded, so the tone does not change it.
//!
//! Descriptors are read from the block grid of the whole image (positives: window (2, 2) of the
//! 96x160 crop), exactly as the detector sees windows, so training and detection agree at borders.
//!
//! # The SVM
//! [`crate::detect::svm`] with the bias nearly free ([`TrainOptions::bias_scale`] 10, close to
//! Dalal & Triggs's SVMLight, which does not regularise it). Models trained before 2026-11-25 used
//! 1, liblinear's `-B 1`, which regularises the bias like a weight and cost about 4 points of miss
//! rate at 1e-4 FPPW (docs/detection.md, "The SVM's bias").

pub mod acf;
mod domain;
mod error;
mod split;
#[cfg(test)]
mod tests;
mod windows;

use std::path::PathBuf;

use rand::SeedableRng;

use crate::data::INFINITE_ISP_SCENES;
use crate::detect::detector::{Detector, DetectorOptions};
/// Re-exported from [`crate::detect::input`], where it lives.
pub use crate::detect::input::MosaicPrep;
use crate::detect::model::{Domain, LinearModel};
use crate::detect::score::ScorePrecision;
use crate::detect::svm::{fit_linear_svm, SvmFit, SvmOptions};
use crate::features::hog::{HogOptions, HogSpec, MosaicTaps, MosaicTone};
use crate::image::Image;
use crate::raw::levels::Gains;
use crate::raw::Cfa;

pub use domain::{
    load_rgb, positive_descriptor, random_negatives, raw_scene_srgb, DomainImage, InputPipeline,
};
use domain::{EXTRA_NEG_SEED_OFFSET, MIRROR_SEED_OFFSET, NEG_SEED_OFFSET, RAW_SCENE_SEED_OFFSET};
pub use error::TrainError;
pub use split::{
    fold_count, inner_split, inner_val_fraction, list_negative_dirs, photo_prefix, split_data, Split,
    KODAK_WITH_PEOPLE,
};
pub use windows::{
    evaluate_windows_via, miss_rate_at_fppw, thin_det_curve, window_bootstrap, WindowBootstrapRow,
    WindowEval, WindowScores, BOOTSTRAP_MAX_FPPW,
};

/// Hard-negative candidates kept per image and round (highest scores).
const HARD_PER_IMAGE: usize = 30;

/// 64-bit FNV-1a of `bytes`: a digest of a training image's decoded pixels for the provenance
/// (not cryptographic; it tells whether two runs trained on the same pixels).
fn fnv1a64(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Training options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainOptions {
    /// Input domain of the model.
    pub domain: Domain,
    /// CFA used to sample mosaics.
    pub cfa: Cfa,
    /// Seed of every random choice (split, negatives, SVM order).
    pub seed: u64,
    /// SVM cost.
    pub c: f64,
    /// Random negative windows per training negative image.
    pub neg_per_image: usize,
    /// Hard-negative mining rounds.
    pub mining_rounds: usize,
    /// Cap on hard negatives added per round.
    pub max_hard_per_round: usize,
    /// Fraction of photos (positives) and negative images held out for validation.
    pub val_fraction: f64,
    /// Which block of the seeded shuffle is held out ([`split_data`]; 0 = the split the shipped
    /// models use). Recorded in the model's provenance when not 0.
    pub fold: usize,
    /// Use at most this many of the split's training negative images (0 = all) — a speed knob;
    /// the raw scenes and [`Split::extra_train_neg`] are always used in full.
    pub max_neg_images: usize,
    /// How the sRGB training images become inputs: sampled through the CFA (the shipped
    /// models), or the paper's reverse ISP to raw (optionally with noise).
    pub pipeline: InputPipeline,
    /// Also use every training negative image mirrored left-right.
    pub mirror_negatives: bool,
    /// Also use every training positive shifted by this many pixels left, right, up and down
    /// (edges replicated; 0 = off): five windows per crop instead of one.
    pub jitter_positives: usize,
    /// Also use the five person-free Infinite-ISP raw scenes (2592x1536), rendered to sRGB by the
    /// forward ISP with the sensor's tuning, as training negatives (never held out).
    pub raw_negatives: bool,
    /// The derivative of mosaic features (written into the model; see [`MosaicTaps`]).
    pub mosaic_taps: MosaicTaps,
    /// The tone of mosaic inputs made through the reverse ISP (written into the model; see
    /// [`MosaicTone`]); the white balance is the raw frame's own (the profile's gains).
    pub mosaic_tone: MosaicTone,
    /// The SVM's bias feature ([`SvmOptions::bias_scale`]). Default 10: the bias nearly free,
    /// as in Dalal & Triggs's SVMLight. Models trained before 2026-11-25 used 1, which
    /// regularised it like a weight.
    pub bias_scale: f64,
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            domain: Domain::Colour,
            cfa: Cfa::Rggb,
            seed: 1,
            c: 0.01,
            neg_per_image: 10,
            mining_rounds: 1,
            max_hard_per_round: 5000,
            val_fraction: 0.2,
            fold: 0,
            max_neg_images: 0,
            pipeline: InputPipeline::Sampled,
            mirror_negatives: false,
            jitter_positives: 0,
            raw_negatives: false,
            mosaic_taps: MosaicTaps::SameSite,
            mosaic_tone: MosaicTone::Linear,
            bias_scale: 10.0,
        }
    }
}

/// One candidate of [`select_c`]: the cost and its inner-validation result.
#[derive(Debug, Clone, serde::Serialize)]
pub struct CCandidate {
    /// SVM cost.
    pub c: f64,
    /// Miss rate at FPPW 1e-2, 1e-3, 1e-4 on the inner validation split.
    pub miss_rate_at: Vec<(f64, f64)>,
}

/// Choose the SVM cost among `candidates` without touching `split`'s validation files: each is
/// trained on an [`inner_split`] of the training files and scored on its inner validation part
/// (lowest miss rate at 1e-4 FPPW, then at 1e-3, then the smaller C). Returns the chosen C and
/// every candidate's result.
pub fn select_c(
    split: &Split,
    o: &TrainOptions,
    candidates: &[f64],
    progress: &mut dyn FnMut(&str),
) -> Result<(f64, Vec<CCandidate>), TrainError> {
    let bad = |value: String, allowed| TrainError::BadOption {
        what: "C candidates",
        value,
        allowed,
    };
    if candidates.is_empty() {
        return Err(bad("[]".into(), "at least one"));
    }
    if let Some(c) = candidates.iter().find(|c| !(c.is_finite() && **c > 0.0)) {
        return Err(bad(c.to_string(), "finite and > 0"));
    }
    let inner = inner_split(split, o.seed, inner_val_fraction(o.val_fraction));
    if inner.val_pos.is_empty() || inner.val_neg.is_empty() {
        // before any training, not after the first candidate
        return Err(TrainError::BadOption {
            what: "val_fraction",
            value: o.val_fraction.to_string(),
            allowed: "large enough that C selection's inner split holds out positives and negatives",
        });
    }
    let mut results = Vec::new();
    for &c in candidates {
        let oc = TrainOptions { c, ..*o };
        let model = train_on(&inner, &oc, progress)?;
        let ev = evaluate_windows_via(
            &model,
            &inner,
            o.domain,
            o.cfa,
            &o.pipeline,
            ScorePrecision::F32,
            Gains::FromFile,
            progress,
        )?;
        progress(&format!(
            "select C: C = {c}: inner miss rate {:?}",
            ev.miss_rate_at
        ));
        results.push(CCandidate {
            c,
            miss_rate_at: ev.miss_rate_at,
        });
    }
    let key = |r: &CCandidate| {
        let at = |f: f64| r.miss_rate_at.iter().find(|(x, _)| *x == f).map_or(1.0, |m| m.1);
        (at(1e-4), at(1e-3), r.c)
    };
    let best = results
        .iter()
        .min_by(|a, b| {
            let (ka, kb) = (key(a), key(b));
            ka.0.total_cmp(&kb.0)
                .then(ka.1.total_cmp(&kb.1))
                .then(ka.2.total_cmp(&kb.2))
        })
        .map(|r| r.c)
        .expect("at least one candidate, checked above");
    Ok((best, results))
}

/// Train a model on `split`'s training files (e.g. [`split_data`]'s); `progress` receives one
/// line per step.
pub fn train_on(
    split: &Split,
    o: &TrainOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<LinearModel, TrainError> {
    if !(o.bias_scale.is_finite() && o.bias_scale > 0.0) {
        return Err(TrainError::BadOption {
            what: "bias_scale",
            value: o.bias_scale.to_string(),
            allowed: "finite and > 0",
        });
    }
    let spec = HogSpec::new(&HogOptions {
        mosaic_taps: o.mosaic_taps,
        ..HogOptions::default()
    })?;
    let prep = MosaicPrep::with_tone(o.mosaic_tone);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(o.seed ^ 0x5eed);
    let mut x: Vec<Vec<f32>> = Vec::new();
    let mut y: Vec<i8> = Vec::new();
    for (i, p) in split.train_pos.iter().enumerate() {
        let rgb = load_rgb(p)?;
        let img = DomainImage::from_rgb_via(&rgb, o.domain, o.cfa, &o.pipeline, i as u64, &prep)?;
        x.push(positive_descriptor(&spec, &img)?);
        y.push(1);
        if o.jitter_positives > 0 {
            let j = o.jitter_positives as isize;
            let (w, h) = (rgb.width() as isize, rgb.height() as isize);
            for (dx, dy) in [(j, 0), (-j, 0), (0, j), (0, -j)] {
                let shifted = Image::from_fn(rgb.width(), rgb.height(), |xx, yy| {
                    rgb.get(
                        (xx as isize + dx).clamp(0, w - 1) as usize,
                        (yy as isize + dy).clamp(0, h - 1) as usize,
                    )
                });
                let img = DomainImage::from_rgb_via(&shifted, o.domain, o.cfa, &o.pipeline, i as u64, &prep)?;
                x.push(positive_descriptor(&spec, &img)?);
                y.push(1);
            }
        }
        if i % 200 == 0 {
            progress(&format!("positives {}/{}", i + 1, split.train_pos.len()));
        }
    }
    let negs: Vec<PathBuf> = if o.max_neg_images > 0 {
        split.train_neg.iter().take(o.max_neg_images).cloned().collect()
    } else {
        split.train_neg.clone()
    };
    // Training negatives in a fixed order: each image (and its mirror), then the raw scenes, then
    // the training-only images (and their mirrors). Noise-stream indices: image i →
    // NEG_SEED_OFFSET + i, its mirror + MIRROR_SEED_OFFSET, raw scene k → NEG_SEED_OFFSET +
    // RAW_SCENE_SEED_OFFSET + k, training-only image j → NEG_SEED_OFFSET + EXTRA_NEG_SEED_OFFSET + j
    // (its mirror + MIRROR_SEED_OFFSET). Without training-only images the order (and so the random
    // windows) is that of earlier versions.
    let mut neg_imgs = Vec::new();
    // `mirror`: also add the image mirrored left-right if `o.mirror_negatives`.
    let mut add_negative = |rgb: &Image<[u8; 3]>,
                            index: u64,
                            mirror: bool,
                            x: &mut Vec<Vec<f32>>,
                            y: &mut Vec<i8>|
     -> Result<(), TrainError> {
        let (w, h) = rgb.dimensions();
        let mirrored =
            (mirror && o.mirror_negatives).then(|| Image::from_fn(w, h, |xx, yy| rgb.get(w - 1 - xx, yy)));
        for (img, index) in
            std::iter::once((rgb, index)).chain(mirrored.as_ref().map(|m| (m, index + MIRROR_SEED_OFFSET)))
        {
            let img = DomainImage::from_rgb_via(img, o.domain, o.cfa, &o.pipeline, index, &prep)?;
            for d in random_negatives(&spec, &img, o.neg_per_image, &mut rng)? {
                x.push(d);
                y.push(-1);
            }
            neg_imgs.push(img);
        }
        Ok(())
    };
    for (i, p) in negs.iter().enumerate() {
        add_negative(&load_rgb(p)?, NEG_SEED_OFFSET + i as u64, true, &mut x, &mut y)?;
        if i % 50 == 0 {
            progress(&format!(
                "random negatives: image {}/{} ({} windows)",
                i + 1,
                negs.len(),
                y.iter().filter(|&&v| v < 0).count()
            ));
        }
    }
    if o.raw_negatives {
        for (k, scene) in INFINITE_ISP_SCENES.iter().enumerate() {
            let rgb = raw_scene_srgb(scene)?;
            add_negative(
                &rgb,
                NEG_SEED_OFFSET + RAW_SCENE_SEED_OFFSET + k as u64,
                false,
                &mut x,
                &mut y,
            )?;
        }
        progress(&format!(
            "random negatives: {} raw scenes ({} windows)",
            INFINITE_ISP_SCENES.len(),
            y.iter().filter(|&&v| v < 0).count()
        ));
    }
    // What the training-only images were, for the provenance: name, size, pixel digest.
    let mut extra = Vec::new();
    for (j, p) in split.extra_train_neg.iter().enumerate() {
        let rgb = load_rgb(p)?;
        let before = y.len();
        add_negative(
            &rgb,
            NEG_SEED_OFFSET + EXTRA_NEG_SEED_OFFSET + j as u64,
            true,
            &mut x,
            &mut y,
        )?;
        extra.push(serde_json::json!({
            "file": p.file_name().map(|n| n.to_string_lossy()),
            "width": rgb.width(), "height": rgb.height(),
            "rgb_fnv1a64": format!("{:016x}", fnv1a64(rgb.as_slice().iter().flatten().copied())),
            "random_windows": y.len() - before,
        }));
    }
    if !split.extra_train_neg.is_empty() {
        progress(&format!(
            "random negatives: {} training-only images ({} windows)",
            split.extra_train_neg.len(),
            y.iter().filter(|&&v| v < 0).count()
        ));
    }
    let svm = SvmOptions {
        c: o.c,
        seed: o.seed,
        bias_scale: o.bias_scale,
        ..Default::default()
    };
    let npos = y.iter().filter(|&&v| v > 0).count();
    progress(&format!("svm: {npos} positives, {} negatives", y.len() - npos));
    // How each solve ended, for the log and the provenance: one that stops at the epoch limit
    // gives an approximate model, which the caller should hear about.
    let mut solves: Vec<serde_json::Value> = Vec::new();
    let mut solve = |x: &[Vec<f32>], y: &[i8], progress: &mut dyn FnMut(&str)| {
        let SvmFit {
            weights,
            bias,
            epochs,
            converged,
            pg_spread,
        } = fit_linear_svm(x, y, &svm);
        if converged {
            progress(&format!("svm: converged in {epochs} epochs"));
        } else {
            let msg = format!(
                "svm: stopped at the epoch limit ({epochs} epochs) with projected-gradient spread {pg_spread:.3} > eps {}; the model is approximate (a smaller --bias-scale or C converges faster)",
                svm.eps
            );
            tracing::warn!("{msg}");
            progress(&msg);
        }
        solves.push(serde_json::json!({
            "vectors": y.len(), "epochs": epochs, "converged": converged, "pg_spread": pg_spread,
        }));
        (weights, bias)
    };
    let (mut w, mut b) = solve(&x, &y, progress);
    for round in 1..=o.mining_rounds {
        let model = model_from(w.clone(), b, o, split, &y);
        let det = Detector::new(model, &DetectorOptions::default())?;
        // Bounded memory: per image at most HARD_PER_IMAGE (highest scores), overall at most
        // `max_hard_per_round`.
        let keep_top = |v: &mut Vec<(f32, Vec<f32>)>, k: usize| {
            v.sort_by(|a, b| b.0.total_cmp(&a.0));
            v.truncate(k);
        };
        let mut hard: Vec<(f32, Vec<f32>)> = Vec::new();
        for (i, img) in neg_imgs.iter().enumerate() {
            let mut local: Vec<(f32, Vec<f32>)> = Vec::new();
            det.for_each_window(&img.input(), |_, grid, wx, wy, s| {
                if s >= 0.0 {
                    if let Ok(d) = grid.window_descriptor(&spec, wx, wy) {
                        local.push((s, d));
                        if local.len() >= 4 * HARD_PER_IMAGE {
                            keep_top(&mut local, HARD_PER_IMAGE);
                        }
                    }
                }
            })?;
            keep_top(&mut local, HARD_PER_IMAGE);
            hard.extend(local);
            if hard.len() >= 2 * o.max_hard_per_round {
                keep_top(&mut hard, o.max_hard_per_round);
            }
            if i % 50 == 0 {
                progress(&format!(
                    "mining round {round}: image {}/{} ({} hard)",
                    i + 1,
                    neg_imgs.len(),
                    hard.len()
                ));
            }
        }
        // Keep the hardest (highest-scoring) ones, deterministic order.
        hard.sort_by(|a, b| b.0.total_cmp(&a.0));
        hard.truncate(o.max_hard_per_round);
        progress(&format!(
            "mining round {round}: {} hard negatives added",
            hard.len()
        ));
        if hard.is_empty() {
            break;
        }
        for (_, d) in hard {
            x.push(d);
            y.push(-1);
        }
        (w, b) = solve(&x, &y, progress);
    }
    let mut m = model_from(w, b, o, split, &y);
    m.provenance["svm_solves"] = serde_json::Value::Array(solves);
    if !extra.is_empty() {
        m.provenance["training_only_negatives"] = serde_json::json!(extra);
    }
    Ok(m)
}

fn model_from(w: Vec<f32>, b: f32, o: &TrainOptions, split: &Split, y: &[i8]) -> LinearModel {
    let mut m = LinearModel::from_opencv_vector(&w, o.domain, "mosaicd train").expect("3780 weights");
    m.bias = b;
    m.mosaic_taps = o.mosaic_taps;
    m.mosaic_tone = o.mosaic_tone;
    m.provenance = serde_json::json!({
        "trainer": "mosaicd train (dual coordinate descent, hinge loss, L2)",
        "seed": o.seed, "c": o.c, "domain": o.domain, "cfa": o.cfa.name(),
        "neg_per_image": o.neg_per_image, "mining_rounds": o.mining_rounds,
        "max_hard_per_round": o.max_hard_per_round, "val_fraction": o.val_fraction,
        "max_neg_images": o.max_neg_images,
        "mirror_negatives": o.mirror_negatives, "raw_negatives": o.raw_negatives,
        "jitter_positives": o.jitter_positives,
        "train_positives": split.train_pos.len(), "train_negative_images": split.train_neg.len(),
        "training_only_negative_images": split.extra_train_neg.len(),
        "training_vectors": y.len(),
        "positive_windows": y.iter().filter(|&&v| v > 0).count(),
        "input_pipeline": o.pipeline.name(),
        "input_note": match o.pipeline {
            InputPipeline::Sampled => "sRGB sampled through the CFA (mosaic), OpenCV grey or the RGB itself; no reverse ISP",
            InputPipeline::ReverseIsp { .. } => match o.mosaic_tone {
                MosaicTone::Linear => "sRGB through the reverse ISP (default camera profile) to raw; mosaic = the raw frame, colour/grey = the forward ISP's output",
                MosaicTone::Srgb => "sRGB through the reverse ISP (default camera profile) to raw; mosaic = the raw frame with each site white balanced (the frame's gains), clipped and sRGB-encoded (mosaic_tone srgb), colour/grey = the forward ISP's output",
            },
        },
    });
    if let InputPipeline::ReverseIsp { seed, .. } = o.pipeline {
        m.provenance["noise_seed"] = serde_json::json!(seed);
    }
    if o.fold != 0 {
        m.provenance["fold"] = serde_json::json!(o.fold);
    }
    // absent in the files trained before the option existed, which used 1
    m.provenance["bias_scale"] = serde_json::json!(o.bias_scale);
    m
}
