//! Training the ACF detector (Dollár's `acfTrain`): positives from the INRIA crops, random
//! negative windows, then rounds of hard-negative mining, each followed by boosting a new
//! classifier from scratch with more trees (Dollár's schedule 32, 128, 512, 2048); and its
//! window-level evaluation with the HOG detector's protocol ([`super::evaluate_windows_via`]).
//!
//! # Data
//! The same files and input pipelines as the HOG trainer ([`super`]): a positive is the 64x128
//! window at (16, 16) of a 96x160 crop, its features read from the channels of the whole crop
//! (as the detector reads windows); the crops already include their left-right mirrors (file
//! suffixes, [`super::photo_prefix`]), so none are added. Stage 0 takes `per_neg` random windows
//! per negative image, drawn uniformly over every window of every level of its channel pyramid,
//! at most `n_neg` in all (a seeded subsample). Each later stage runs the current detector over
//! every training negative image, keeps per image the `per_neg` highest-scoring windows above
//! the soft-cascade threshold after greedy suppression (IoU 0.5), at most `n_neg` in all, and
//! adds them to a random subset of the earlier negatives so that at most
//! `max(n_neg, acc_neg)` are kept (Dollár's `nAccNeg`).
//!
//! # Channel ablation
//! With [`FeatureSet::Gradient`] boosting sees each window's features without those of the
//! colour channels (the first three planes of the channel-major window), and the trees' feature
//! indices are shifted back after boosting: the model reads the same windows of the same
//! pyramid, never a colour feature. The default ([`FeatureSet::All`]) trains as before.
//!
//! # Where we differ from Dollár
//! * Negative windows' features are read from the detector's pyramid (approximated levels
//!   included), not recomputed from a crop resized to the window: what the detector sees.
//! * Stage 0 draws windows over all scales, not on a grid at the image's own scale.
//!
//! # Determinism
//! Every random choice comes from a ChaCha8 stream seeded by the seed and the image's index;
//! images are processed in parallel but collected in order, and boosting is deterministic
//! ([`crate::detect::boost`]): the model is the same for any thread count.

use std::path::PathBuf;
use std::time::Instant;

use rand::seq::index::sample;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use super::domain::{image_seed, load_rgb, DomainImage, InputPipeline, NEG_SEED_OFFSET};
use super::error::TrainError;
use super::split::{inner_split, Split};
use super::windows::{held_out_negative, photo_indices, window_eval, WindowEval};
use crate::detect::acf::{
    AcfDetector, AcfError, AcfModel, AcfOptions, FeatureSet, CASC_CAL, CASC_THR, FORMAT, VERSION,
};
use crate::detect::boost::{calibrate_trace, train_adaboost, BoostOptions, TraceOptions};
use crate::detect::channels::{
    channels, measure_lambdas, pyramid, ChannelInput, ChannelOptions, ChannelSpec, PyramidOptions, SHRINK,
};
use crate::detect::detector::NmsMethod;
use crate::detect::input::MosaicPrep;
use crate::detect::model::Domain;
use crate::detect::nms::greedy_nms;
use crate::geometry::Detection;
use crate::raw::levels::Gains;
use crate::raw::tone::MosaicTone;
use crate::raw::Cfa;

/// Offset of the 64x128 window inside the 96x160 INRIA crops, in blocks.
const POS_WINDOW_BLOCK: usize = 16 / SHRINK;
/// Salt of the negative-window streams.
const NEG_STREAM_SALT: u64 = 0x6163_665f_6e65_6773;
/// IoU of the suppression among one image's hard negatives.
const MINING_NMS_IOU: f32 = 0.5;
/// Fraction of the training files held out by the inner split that calibrates the trace.
pub(crate) const INNER_FRACTION: f64 = 0.2;

/// ACF training options; defaults are Dollár's INRIA detector (`acfDemoInria`).
#[derive(Debug, Clone, PartialEq)]
pub struct AcfTrainOptions {
    /// Input domain.
    pub domain: Domain,
    /// CFA used to sample mosaics.
    pub cfa: Cfa,
    /// Seed of every random choice.
    pub seed: u64,
    /// How the sRGB images become inputs ([`InputPipeline`]).
    pub pipeline: InputPipeline,
    /// The tone of reverse-ISP mosaics (written into the model).
    pub mosaic_tone: MosaicTone,
    /// Trees after each stage (`nWeak`): stage 0 on random negatives, then one mining round per
    /// further entry.
    pub stages: Vec<usize>,
    /// Boosting options (`n_weak` is taken from `stages`).
    pub boost: BoostOptions,
    /// Channel options.
    pub channels: ChannelOptions,
    /// The channels the trees may read (written into the model): all, or a channel ablation
    /// ([`FeatureSet::Gradient`]: boosting sees only the features of the gradient channels).
    pub features: FeatureSet,
    /// Pyramid options (for the negatives and written into the model).
    pub pyramid: PyramidOptions,
    /// Negative windows sampled per stage (`nNeg`).
    pub n_neg: usize,
    /// Negative windows per image and stage (`nPerNeg`).
    pub per_neg: usize,
    /// Negative windows kept over all stages (`nAccNeg`).
    pub acc_neg: usize,
    /// Use at most this many training negative images (0 = all).
    pub max_neg_images: usize,
    /// Measure the pyramid's λ on the training positives (`measure_lambdas`, as Dollár's
    /// `acfTrain` does when none are given) instead of using `pyramid.lambdas`.
    pub measure_lambdas: bool,
    /// Soft-cascade threshold written into the model (Dollár's −1; used when `trace` is `None`).
    pub casc_thr: f32,
    /// Calibrate a per-tree rejection trace ([`calibrate_cascade`]): a model is first trained on
    /// the inner split of the training files (fraction `INNER_FRACTION` held out), its trace
    /// calibrated on the inner held-out positives, and the trace stored in the model trained on
    /// all training files. Doubles the training time. `None`: the constant `casc_thr` only.
    pub trace: Option<TraceOptions>,
}

impl Default for AcfTrainOptions {
    fn default() -> Self {
        Self {
            domain: Domain::Mosaic,
            cfa: Cfa::Rggb,
            seed: 1,
            pipeline: InputPipeline::Sampled,
            mosaic_tone: MosaicTone::Linear,
            stages: vec![32, 128, 512, 2048],
            boost: BoostOptions::default(),
            channels: ChannelOptions::default(),
            features: FeatureSet::All,
            pyramid: PyramidOptions::default(),
            n_neg: 5000,
            per_neg: 25,
            acc_neg: 10000,
            max_neg_images: 0,
            measure_lambdas: true,
            casc_thr: CASC_THR,
            trace: Some(TraceOptions::default()),
        }
    }
}

/// The channel input of a domain image.
pub(crate) fn channel_input(img: &DomainImage, cfa: Cfa) -> ChannelInput<'_> {
    match img {
        DomainImage::Colour(c) => ChannelInput::Rgb8(c.view()),
        DomainImage::Grey(g) => ChannelInput::GreyU8(g.view()),
        DomainImage::Mosaic(m) => ChannelInput::Mosaic { image: m.view(), cfa },
    }
}

/// Features of the positive window of a 96x160 crop.
fn positive_features(
    spec: &ChannelSpec,
    img: &DomainImage,
    cfa: Cfa,
    win: (usize, usize),
) -> Result<Vec<f32>, TrainError> {
    let ch = channels(&channel_input(img, cfa), spec).map_err(AcfError::from)?;
    ch.window(POS_WINDOW_BLOCK, POS_WINDOW_BLOCK, win.0, win.1)
        .ok_or_else(|| TrainError::BadOption {
            what: "positive crop",
            value: format!("{}x{} blocks", ch.width(), ch.height()),
            allowed: "at least the window plus 16 pixels on each side (96x160 crops)",
        })
}

fn model_of(
    o: &AcfTrainOptions,
    pyr: PyramidOptions,
    boost: BoostOptions,
    classifier: crate::detect::boost::BoostedTrees,
) -> AcfModel {
    AcfModel {
        format: FORMAT.into(),
        version: VERSION,
        domain: o.domain,
        win_width: o.pyramid.min_size.0,
        win_height: o.pyramid.min_size.1,
        channels: o.channels,
        features: o.features,
        pyramid: pyr,
        casc_thr: o.casc_thr,
        casc_cal: CASC_CAL,
        casc_trace: None,
        mosaic_tone: o.mosaic_tone,
        boost,
        classifier,
        provenance: serde_json::Value::Null,
    }
}

fn check(o: &AcfTrainOptions) -> Result<(), TrainError> {
    let bad = |what, value: String, allowed| Err(TrainError::BadOption { what, value, allowed });
    if o.stages.is_empty() || o.stages.contains(&0) {
        return bad(
            "stages",
            format!("{:?}", o.stages),
            "one or more tree counts, each > 0",
        );
    }
    if o.n_neg == 0 || o.per_neg == 0 {
        return bad(
            "n_neg / per_neg",
            format!("{} / {}", o.n_neg, o.per_neg),
            "both > 0",
        );
    }
    if o.pyramid.min_size != (64, 128) {
        return bad(
            "window",
            format!("{:?}", o.pyramid.min_size),
            "64x128 (the INRIA crops' window)",
        );
    }
    ChannelSpec::new(o.channels).map_err(AcfError::from)?;
    Ok(())
}

/// Train an ACF model on `split`'s training files; `progress` receives one line per step.
pub fn train_acf(
    split: &Split,
    o: &AcfTrainOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<AcfModel, TrainError> {
    check(o)?;
    let t0 = Instant::now();
    let inner_trace = match &o.trace {
        Some(t) => {
            let inner = inner_split(split, o.seed, INNER_FRACTION);
            progress(&format!(
                "acf: training on the inner split ({} positives, {} negative images) to calibrate the rejection trace",
                inner.train_pos.len(),
                inner.train_neg.len()
            ));
            let mut prog = |s: &str| progress(&format!("inner: {s}"));
            let im = train_acf(
                &inner,
                &AcfTrainOptions {
                    trace: None,
                    ..o.clone()
                },
                &mut prog,
            )?;
            let xs = positive_windows(&inner.val_pos, &im, o.domain, o.cfa, &o.pipeline, Gains::FromFile)?;
            let trace = calibrate_cascade(&im, &xs, t)?;
            progress(&format!(
                "acf: rejection trace calibrated on {} inner held-out positives ({:.1} s)",
                xs.len(),
                t0.elapsed().as_secs_f64()
            ));
            Some((trace, xs.len()))
        }
        None => None,
    };
    let spec = ChannelSpec::new(o.channels).map_err(AcfError::from)?;
    let prep = MosaicPrep::with_tone(o.mosaic_tone);
    let win = (o.pyramid.min_size.0 / SHRINK, o.pyramid.min_size.1 / SHRINK);
    let pos_imgs: Vec<DomainImage> = split
        .train_pos
        .par_iter()
        .enumerate()
        .map(|(i, p)| DomainImage::from_rgb_via(&load_rgb(p)?, o.domain, o.cfa, &o.pipeline, i as u64, &prep))
        .collect::<Result<_, _>>()?;
    // Boosting sees the features from the first readable channel on (the window's features are
    // channel-major): `skip` features are dropped from every sample, and added back to the trees'
    // feature indices after boosting.
    let skip = o.features.first_channel() * win.0 * win.1;
    let readable = |mut x: Vec<f32>| {
        x.drain(..skip);
        x
    };
    let x1: Vec<Vec<f32>> = pos_imgs
        .par_iter()
        .map(|img| positive_features(&spec, img, o.cfa, win).map(readable))
        .collect::<Result<_, _>>()?;
    progress(&format!(
        "acf: {} positive windows ({:.1} s)",
        x1.len(),
        t0.elapsed().as_secs_f64()
    ));
    let mut pyr = o.pyramid;
    if o.measure_lambdas {
        let inputs: Vec<ChannelInput> = pos_imgs.iter().map(|i| channel_input(i, o.cfa)).collect();
        pyr.lambdas = measure_lambdas(&inputs, &spec, pyr.per_octave, 3).map_err(AcfError::from)?;
        progress(&format!(
            "acf: λ measured on the positives: colour {:.4}, magnitude {:.4}, orientations {:.4}",
            pyr.lambdas[0], pyr.lambdas[1], pyr.lambdas[2]
        ));
    }
    drop(pos_imgs);
    let neg_files: Vec<PathBuf> = split
        .train_neg
        .iter()
        .take(if o.max_neg_images > 0 {
            o.max_neg_images
        } else {
            usize::MAX
        })
        .chain(&split.extra_train_neg)
        .cloned()
        .collect();
    let negs: Vec<DomainImage> = neg_files
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            DomainImage::from_rgb_via(
                &load_rgb(p)?,
                o.domain,
                o.cfa,
                &o.pipeline,
                NEG_SEED_OFFSET + i as u64,
                &prep,
            )
        })
        .collect::<Result<_, _>>()?;
    progress(&format!(
        "acf: {} negative images loaded ({:.1} s)",
        negs.len(),
        t0.elapsed().as_secs_f64()
    ));
    let mut x0: Vec<Vec<f32>> = Vec::new();
    let mut model: Option<AcfModel> = None;
    let mut stages_log = Vec::new();
    for (stage, &n_weak) in o.stages.iter().enumerate() {
        let ts = Instant::now();
        let stream = |i: usize| {
            rand_chacha::ChaCha8Rng::seed_from_u64(image_seed(
                o.seed ^ NEG_STREAM_SALT,
                (stage << 24 | i) as u64,
            ))
        };
        let fresh: Vec<Vec<Vec<f32>>> = match &model {
            None => negs
                .par_iter()
                .enumerate()
                .map(|(i, img)| {
                    let p = pyramid(&channel_input(img, o.cfa), &spec, &pyr).map_err(AcfError::from)?;
                    let counts: Vec<usize> = p
                        .levels
                        .iter()
                        .map(|l| {
                            (l.channels.width() + 1).saturating_sub(win.0)
                                * (l.channels.height() + 1).saturating_sub(win.1)
                        })
                        .collect();
                    let total: usize = counts.iter().sum();
                    let mut rng = stream(i);
                    let picks = sorted_sample(&mut rng, total, o.per_neg);
                    let mut out = Vec::with_capacity(picks.len());
                    for mut k in picks {
                        let mut li = 0;
                        while k >= counts[li] {
                            k -= counts[li];
                            li += 1;
                        }
                        let ch = &p.levels[li].channels;
                        let nx = ch.width() + 1 - win.0;
                        out.push(
                            ch.window(k % nx, k / nx, win.0, win.1)
                                .expect("window inside its level"),
                        );
                    }
                    Ok(out)
                })
                .collect::<Result<_, TrainError>>()?,
            Some(m) => {
                let det = AcfDetector::new(
                    m.clone(),
                    &AcfOptions {
                        hit_threshold: f32::NEG_INFINITY,
                        nms: NmsMethod::None,
                        ..AcfOptions::default()
                    },
                )?;
                negs.par_iter()
                    .map(|img| {
                        let input = channel_input(img, o.cfa);
                        let p = det.pyramid(&input)?;
                        let mut cands: Vec<(Detection, usize)> = Vec::new();
                        for (li, l) in p.levels.iter().enumerate() {
                            let (scores, _) = det.score_level(&l.channels);
                            for (bx, by, s) in scores {
                                if s > m.casc_thr {
                                    let d = Detection {
                                        x: (bx * SHRINK) as f32 / l.scale_x as f32,
                                        y: (by * SHRINK) as f32 / l.scale_y as f32,
                                        width: m.win_width as f32 / l.scale_x as f32,
                                        height: m.win_height as f32 / l.scale_y as f32,
                                        score: s,
                                    };
                                    cands.push((d, li));
                                }
                            }
                        }
                        // greedy suppression by score, then the top `per_neg`
                        cands.sort_by(|a, b| b.0.score.total_cmp(&a.0.score));
                        let kept = greedy_nms(&cands.iter().map(|c| c.0).collect::<Vec<_>>(), MINING_NMS_IOU);
                        let mut out = Vec::new();
                        for d in kept.iter().take(o.per_neg) {
                            let &(_, li) = cands
                                .iter()
                                .find(|c| c.0 == *d)
                                .expect("a kept box is a candidate");
                            let l = &p.levels[li];
                            let bx = (d.x * l.scale_x as f32 / SHRINK as f32).round() as usize;
                            let by = (d.y * l.scale_y as f32 / SHRINK as f32).round() as usize;
                            if let Some(f) = l.channels.window(bx, by, win.0, win.1) {
                                out.push(f);
                            }
                        }
                        Ok(out)
                    })
                    .collect::<Result<_, TrainError>>()?
            }
        };
        let mut new: Vec<Vec<f32>> = fresh.into_iter().flatten().map(readable).collect();
        let mut rng = stream(usize::MAX >> 40);
        if new.len() > o.n_neg {
            let keep = sorted_sample(&mut rng, new.len(), o.n_neg);
            new = keep.into_iter().map(|k| std::mem::take(&mut new[k])).collect();
        }
        let found = new.len();
        let room = o.n_neg.max(o.acc_neg).saturating_sub(new.len());
        if x0.len() > room {
            let keep = sorted_sample(&mut rng, x0.len(), room);
            x0 = keep.into_iter().map(|k| std::mem::take(&mut x0[k])).collect();
        }
        new.append(&mut x0);
        x0 = new;
        progress(&format!(
            "acf stage {stage}: {found} new negative windows, {} in all ({:.1} s)",
            x0.len(),
            t0.elapsed().as_secs_f64()
        ));
        if found == 0 && model.is_some() {
            progress(&format!("acf stage {stage}: no hard negatives left, stopping"));
            break;
        }
        let boost = BoostOptions {
            n_weak,
            seed: o.seed.wrapping_add(stage as u64),
            ..o.boost
        };
        let mut prog = |s: &str| progress(&format!("acf stage {stage}: {s}"));
        let mut clf = train_adaboost(&x0, &x1, &boost, &mut prog)?;
        clf.calibrate(CASC_CAL);
        shift_features(&mut clf, skip);
        let trees = clf.trees.len();
        model = Some(model_of(o, pyr, boost, clf));
        let secs = ts.elapsed().as_secs_f64();
        progress(&format!(
            "acf stage {stage}: {trees} trees ({secs:.1} s this stage, {:.1} s in all)",
            t0.elapsed().as_secs_f64()
        ));
        stages_log.push(serde_json::json!({
            "stage": stage, "trees": trees, "new_negatives": found, "negatives": x0.len(), "seconds": secs,
        }));
    }
    let mut m = model.expect("at least one stage ran");
    m.provenance = serde_json::json!({
        "trainer": "mosaicd train --detector acf (discrete AdaBoost over depth-2 trees, Dollár's acfTrain)",
        "seed": o.seed, "domain": o.domain, "cfa": o.cfa.name(),
        "input_pipeline": o.pipeline.name(), "mosaic_tone": o.mosaic_tone,
        "stages": o.stages, "n_neg": o.n_neg, "per_neg": o.per_neg, "acc_neg": o.acc_neg,
        "max_neg_images": o.max_neg_images, "lambdas_measured": o.measure_lambdas,
        "features": o.features.name(),
        "train_positives": split.train_pos.len(), "train_negative_images": negs.len(),
        "positive_windows": x1.len(),
        "stage_log": stages_log,
    });
    if let InputPipeline::ReverseIsp { seed, .. } = o.pipeline {
        m.provenance["noise_seed"] = serde_json::json!(seed);
    }
    if let (Some((trace, n)), Some(t)) = (inner_trace, &o.trace) {
        let src = format!(
            "{n} held-out positives of the inner split ({INNER_FRACTION} of the training files) scored by a model trained on the rest"
        );
        set_trace(&mut m, &trace, t, &src);
    }
    Ok(m)
}

/// The trees of `clf`, boosted on features without the first `skip` of each window, read the
/// whole window: `skip` is added to every split's feature index and to the feature count.
fn shift_features(clf: &mut crate::detect::boost::BoostedTrees, skip: usize) {
    clf.n_features += skip;
    for t in &mut clf.trees {
        for k in 0..t.fid.len() {
            if t.child[k] != 0 {
                t.fid[k] += skip as u32;
            }
        }
    }
}

/// A per-tree rejection trace (`calibrate_trace`) from the running scores, under `model`, of
/// calibration positives that `model` was not trained on (a model's own training positives run
/// far higher than new ones: docs/acf.md).
pub fn calibrate_cascade(
    model: &AcfModel,
    positives: &[Vec<f32>],
    o: &TraceOptions,
) -> Result<Vec<f32>, TrainError> {
    let runs: Vec<Vec<f32>> = positives
        .par_iter()
        .map(|x| model.classifier.running_scores(x))
        .collect();
    Ok(calibrate_trace(&runs, o)?)
}

/// Store `trace` (calibrated with another model of the same training recipe) in `model`: cut to
/// its trees, or extended by its last value; the options and `source` go into the provenance.
pub fn set_trace(model: &mut AcfModel, trace: &[f32], o: &TraceOptions, source: &str) {
    let n = model.classifier.trees.len();
    let last = trace.last().copied().unwrap_or(f32::NEG_INFINITY);
    model.casc_trace = Some((0..n).map(|k| trace.get(k).copied().unwrap_or(last)).collect());
    if !model.provenance.is_object() {
        model.provenance = serde_json::json!({});
    }
    model.provenance["casc_trace"] = serde_json::json!({
        "calibration": source, "floor": o.floor, "loss": o.loss, "margin": o.margin,
    });
}

/// The features of the positive windows of the 96x160 crops `files` for `model` (image `i` on
/// the noise stream `i`, as the evaluation reads them).
pub fn positive_windows(
    files: &[PathBuf],
    model: &AcfModel,
    domain: Domain,
    cfa: Cfa,
    pipeline: &InputPipeline,
    wb: Gains,
) -> Result<Vec<Vec<f32>>, TrainError> {
    let prep = MosaicPrep {
        tone: model.mosaic_tone,
        gains: wb,
    };
    let spec = ChannelSpec::new(model.channels).map_err(AcfError::from)?;
    let win = model.window_blocks();
    files
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let img = DomainImage::from_rgb_via(&load_rgb(p)?, domain, cfa, pipeline, i as u64, &prep)?;
            positive_features(&spec, &img, cfa, win)
        })
        .collect()
}

/// Window-level evaluation of an ACF model on `split`'s held-out files (the HOG detector's
/// protocol: every held-out positive window, every window of every pyramid level of the held-out
/// negative images). A window the soft cascade rejects is no detection at any threshold (score
/// `acf::REJECTED`).
#[allow(clippy::too_many_arguments)]
pub fn evaluate_acf_windows(
    model: &AcfModel,
    split: &Split,
    domain: Domain,
    cfa: Cfa,
    pipeline: &InputPipeline,
    wb: Gains,
    progress: &mut dyn FnMut(&str),
) -> Result<WindowEval, TrainError> {
    let prep = MosaicPrep {
        tone: model.mosaic_tone,
        gains: wb,
    };
    let det = AcfDetector::new(model.clone(), &AcfOptions::default())?;
    let pos: Vec<f32> = positive_windows(&split.val_pos, model, domain, cfa, pipeline, wb)?
        .iter()
        .map(|x| det.score_features(x))
        .collect();
    progress(&format!("eval: {} positives scored", pos.len()));
    let per_image: Vec<(Vec<f32>, u64)> = split
        .val_neg
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let img = held_out_negative(p, i, domain, cfa, pipeline, &prep)?;
            let pyr = det.pyramid(&channel_input(&img, cfa))?;
            let mut v = Vec::new();
            let mut trees = 0;
            for l in &pyr.levels {
                let (s, t) = det.score_level(&l.channels);
                v.extend(s.into_iter().map(|w| w.2));
                trees += t;
            }
            Ok((v, trees))
        })
        .collect::<Result<_, TrainError>>()?;
    let windows_per_image: Vec<usize> = per_image.iter().map(|v| v.0.len()).collect();
    let trees: u64 = per_image.iter().map(|v| v.1).sum();
    let neg: Vec<f32> = per_image.into_iter().flat_map(|v| v.0).collect();
    progress(&format!(
        "eval: {} negative windows in {} images, {:.2} trees per window",
        neg.len(),
        windows_per_image.len(),
        trees as f64 / neg.len().max(1) as f64
    ));
    let ev = window_eval(pos, photo_indices(&split.val_pos), &neg, windows_per_image)?;
    let mut sorted = neg;
    sorted.sort_unstable_by(|a, b| b.total_cmp(a));
    let at = |f: f64| sorted.get((f * sorted.len() as f64) as usize).copied();
    progress(&format!(
        "eval: negative score at FPPW 1e-2 {:?}, 1e-3 {:?}, 1e-4 {:?}",
        at(1e-2),
        at(1e-3),
        at(1e-4)
    ));
    Ok(ev)
}

/// A random subset of `n` of `0..len` (all if `n ≥ len`) in increasing order.
fn sorted_sample(rng: &mut impl Rng, len: usize, n: usize) -> Vec<usize> {
    let mut v = sample(rng, len, n.min(len)).into_vec();
    v.sort_unstable();
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::channels::MAG_CHANNEL;

    /// Fold 0's first 40 training positives and 4 negative images, for small runs on the shared
    /// INRIA crops and negatives (fails with the data directory named when $MOSAICD_DATA is
    /// missing, like every data test).
    fn small_split() -> Split {
        crate::data::data_path("pedestrian/inria_pos_96x160").unwrap_or_else(|e| panic!("{e}"));
        let mut split = super::super::split_data(
            &crate::data::data_root().unwrap_or_else(|e| panic!("{e}")),
            1,
            0.2,
            0,
        )
        .unwrap();
        split.train_pos.truncate(40);
        split.train_neg.truncate(4);
        split
    }

    /// Two stages of 2 and 4 trees on at most 60 negative windows per stage.
    fn small_options() -> AcfTrainOptions {
        AcfTrainOptions {
            stages: vec![2, 4],
            n_neg: 60,
            per_neg: 15,
            acc_neg: 100,
            ..AcfTrainOptions::default()
        }
    }

    /// The features of `split`'s training positives for `m`, and how many of them `m` scores
    /// above its cascade threshold.
    fn training_positives_above(split: &Split, m: &AcfModel) -> (Vec<Vec<f32>>, usize) {
        let det = AcfDetector::new(m.clone(), &AcfOptions::default()).unwrap();
        let xs = positive_windows(
            &split.train_pos,
            m,
            m.domain,
            Cfa::Rggb,
            &InputPipeline::Sampled,
            Gains::FromFile,
        )
        .unwrap();
        let above = xs.iter().filter(|x| det.score_features(x) > m.casc_thr).count();
        (xs, above)
    }

    #[test]
    fn training_on_shared_data_is_the_same_for_1_and_2_threads() {
        let split = small_split();
        let o = small_options();
        let run = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| train_acf(&split, &o, &mut |_| {}).unwrap())
        };
        let (a, b) = (run(1), run(2));
        // everything but the stages' wall times
        assert_eq!(
            (&a.classifier, &a.pyramid, a.boost),
            (&b.classifier, &b.pyramid, b.boost)
        );
        assert_eq!(a.classifier.trees.len(), 4);
        assert_eq!(a.provenance["positive_windows"], 40);
        assert!(a.pyramid.lambdas[1] > 0.0, "{:?}", a.pyramid.lambdas);
        // the trained model scores its own training positives above the cascade threshold
        let (xs, above) = training_positives_above(&split, &a);
        assert!(above * 2 > xs.len(), "{above} of {}", xs.len());
    }

    #[test]
    fn a_gradient_model_never_reads_a_colour_feature() {
        // the channel ablation: boosting on the gradient channels' features only; the trees'
        // indices point into the whole window, past the colour planes
        let split = small_split();
        let o = AcfTrainOptions {
            stages: vec![2, 8],
            trace: None,
            features: FeatureSet::Gradient,
            ..small_options()
        };
        let m = train_acf(&split, &o, &mut |_| {}).unwrap();
        assert_eq!(m.features, FeatureSet::Gradient);
        assert_eq!(m.provenance["features"], "gradient");
        assert_eq!(m.classifier.n_features, m.n_features());
        m.validate("trained").unwrap();
        let colour = MAG_CHANNEL * 16 * 32;
        let splits: Vec<u32> = m
            .classifier
            .trees
            .iter()
            .flat_map(|t| (0..t.fid.len()).filter(|&k| t.child[k] != 0).map(|k| t.fid[k]))
            .collect();
        assert!(
            !splits.is_empty() && splits.iter().all(|&f| f as usize >= colour),
            "{splits:?}"
        );
        // it learned something on the gradients, and the colour features do not change a score
        let (xs, above) = training_positives_above(&split, &m);
        assert!(above * 2 > xs.len(), "{above} of {}", xs.len());
        let det = AcfDetector::new(m.clone(), &AcfOptions::default()).unwrap();
        for x in &xs {
            let mut z = x.clone();
            z[..colour].fill(0.0);
            assert_eq!(det.score_features(&z).to_bits(), det.score_features(x).to_bits());
        }
    }

    #[test]
    fn options_are_checked() {
        let split = Split::default();
        for (o, what) in [
            (
                AcfTrainOptions {
                    stages: vec![],
                    ..AcfTrainOptions::default()
                },
                "stages",
            ),
            (
                AcfTrainOptions {
                    per_neg: 0,
                    ..AcfTrainOptions::default()
                },
                "n_neg / per_neg",
            ),
        ] {
            match train_acf(&split, &o, &mut |_| {}) {
                Err(TrainError::BadOption { what: w, .. }) => assert_eq!(w, what),
                other => panic!("{other:?}"),
            }
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let s = sorted_sample(&mut rng, 10, 4);
        assert!(s.windows(2).all(|w| w[0] < w[1]) && s.len() == 4);
    }
}
