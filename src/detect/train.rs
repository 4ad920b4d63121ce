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
//! paper's: every sRGB image goes through the reverse ISP ([`crate::isp::reverse`], default camera
//! profile, the chosen CFA) to a raw frame, optionally with the paper's eq. 24 noise at one of the
//! three levels (seeded per image, so runs are deterministic), then the mosaic domain reads the raw
//! frame directly in the model's tone ([`MosaicPrep`]: [`MosaicTone::Linear`], the raw frame as
//! it is, or [`MosaicTone::Srgb`], each site white balanced and sRGB-encoded with the frame's own
//! gains, which are the profile's) while the colour and grey domains see it through the forward ISP
//! ([`crate::isp::forward`], Malvar demosaicing). A sampled mosaic is already white balanced and
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

use std::path::{Path, PathBuf};

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};

use super::detector::{Detector, DetectorOptions};
use super::model::{Domain, LinearModel};
use super::pyramid::{resize_bilinear, resize_mosaic};
use super::score::ScorePrecision;
use super::svm::{fit_linear_svm, SvmFit, SvmOptions};
use crate::eval::common::{load_raw_frame, raw_profile, RawInput, INFINITE_ISP_SCENES};
use crate::eval::detection::Interval;
use crate::features::hog::{
    block_grid, mosaic_from_raw_with, BlockGrid, Exec, HogInput, HogOptions, HogSpec, MosaicTaps, MosaicTone,
    CELL_SIZE,
};
use crate::image::Image;
use crate::isp::grey::grey_from_rgb_u8;
use crate::isp::{
    raw_from_srgb, srgb_from_raw, CameraProfile, ForwardIspOptions, NoiseLevel, ReverseIspOptions,
};
use crate::metrics::detection::{det_curve, DetPoint};
use crate::raw::levels::Gains;
use crate::raw::{Cfa, Colour, RawFrame};

/// Kodak images that show people (never negatives).
pub const KODAK_WITH_PEOPLE: [u32; 6] = [4, 5, 12, 14, 15, 18];
/// Hard-negative candidates kept per image and round (highest scores).
const HARD_PER_IMAGE: usize = 30;
/// Offset of the 64x128 window inside the 96x160 INRIA crops, in cells.
const POS_WINDOW_CELL: usize = 16 / CELL_SIZE;
/// Noise-seed offset of negative images, so they never share a seed with a positive.
const NEG_SEED_OFFSET: u64 = 1 << 32;
/// Added to a negative image's noise index for its mirror.
const MIRROR_SEED_OFFSET: u64 = 1 << 31;
/// Mixed into the seed of [`inner_split`].
const INNER_SPLIT_SALT: u64 = 0x696e_6e65_725f_7631;
/// Added to [`NEG_SEED_OFFSET`] for the raw scenes.
const RAW_SCENE_SEED_OFFSET: u64 = 1 << 30;
/// Added to [`NEG_SEED_OFFSET`] for the training-only negatives of [`Split::extra_train_neg`].
const EXTRA_NEG_SEED_OFFSET: u64 = 1 << 29;
/// Most points kept of a DET curve in [`WindowEval::det`] (enough for a plot).
const DET_PLOT_POINTS: usize = 400;

/// Errors of training.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// A file could not be listed or decoded.
    #[error("training data {path}: {what}")]
    Data {
        /// File or directory.
        path: PathBuf,
        /// What failed.
        what: String,
    },
    /// Detector failure.
    #[error(transparent)]
    Detect(#[from] super::DetectError),
    /// The mosaic's white balance could not be applied (bad or missing gains).
    #[error("mosaic white balance: {0}")]
    Gains(#[from] crate::raw::RawError),
    /// HOG failure.
    #[error(transparent)]
    Hog(#[from] crate::features::hog::HogError),
    /// Reverse or forward ISP failure.
    #[error(transparent)]
    Isp(#[from] crate::isp::IspError),
    /// DET curve failure (no samples).
    #[error(transparent)]
    Metrics(#[from] crate::metrics::MetricsError),
    /// A training option out of range.
    #[error("training option {what} = {value} is out of range ({allowed})")]
    BadOption {
        /// Option name.
        what: &'static str,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
}

/// How an sRGB data image becomes a model's input (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum InputPipeline {
    /// sRGB sampled through the CFA (mosaic), OpenCV's grey, or the RGB itself: how the shipped
    /// models were trained.
    Sampled,
    /// Reverse ISP to a raw frame with optional eq. 24 noise; mosaic = the raw frame, colour and grey =
    /// the forward ISP's output.
    ReverseIsp {
        /// Noise level (`None`: clean raw).
        noise: Option<NoiseLevel>,
        /// Base seed of the noise; image `i` uses a seed derived from it and `i`.
        seed: u64,
    },
}

impl InputPipeline {
    /// Parse `sampled`, `clean`, `low`, `medium` or `high` (case-insensitive; `raw-` prefix
    /// allowed, so every [`InputPipeline::name`] parses back); `seed` is the noise base seed.
    pub fn parse(s: &str, seed: u64) -> Result<Self, String> {
        let t = s.trim().to_ascii_lowercase();
        let t = t.strip_prefix("raw-").unwrap_or(&t);
        Ok(match t {
            "sampled" => InputPipeline::Sampled,
            "clean" => InputPipeline::ReverseIsp { noise: None, seed },
            other => InputPipeline::ReverseIsp {
                noise: Some(
                    other
                        .parse::<NoiseLevel>()
                        .map_err(|_| format!("{s:?}: expected sampled, clean, low, medium or high"))?,
                ),
                seed,
            },
        })
    }

    /// Short name: `sampled`, `raw-clean`, `raw-low`, `raw-medium`, `raw-high`.
    pub fn name(&self) -> String {
        match self {
            InputPipeline::Sampled => "sampled".into(),
            InputPipeline::ReverseIsp { noise: None, .. } => "raw-clean".into(),
            InputPipeline::ReverseIsp { noise: Some(n), .. } => format!("raw-{}", n.name()),
        }
    }
}

/// The noise seed of image `index` under base seed `seed` (splitmix-style mixing, so neighbouring
/// indices get unrelated streams).
fn image_seed(seed: u64, index: u64) -> u64 {
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

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

/// How a raw frame becomes a mosaic input ([`DomainImage::from_rgb_via`] with the reverse ISP):
/// the tone and, for [`MosaicTone::Srgb`], where the white-balance gains come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MosaicPrep {
    /// The tone.
    pub tone: MosaicTone,
    /// The gains (the reverse ISP's frames carry the profile's gains: [`Gains::FromFile`] is the
    /// true white balance, [`Gains::GreyWorld`] an estimate from the image).
    pub gains: Gains,
}

impl Default for MosaicPrep {
    /// Linear (the raw frame as it is).
    fn default() -> Self {
        Self {
            tone: MosaicTone::Linear,
            gains: Gains::FromFile,
        }
    }
}

impl MosaicPrep {
    /// `tone` with the frame's own gains (how training prepares mosaics).
    pub fn with_tone(tone: MosaicTone) -> Self {
        Self {
            tone,
            ..Self::default()
        }
    }

    /// The mosaic of `raw` in this tone.
    pub fn mosaic(&self, raw: &RawFrame) -> Result<Image<f32>, TrainError> {
        Ok(mosaic_from_raw_with(raw, self.tone, self.gains)?)
    }
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

/// Files of a train/validation split.
#[derive(Debug, Clone, Default)]
pub struct Split {
    /// Training positives.
    pub train_pos: Vec<PathBuf>,
    /// Validation positives (photos disjoint from training).
    pub val_pos: Vec<PathBuf>,
    /// Training negative images.
    pub train_neg: Vec<PathBuf>,
    /// Validation negative images.
    pub val_neg: Vec<PathBuf>,
    /// Training-only negative images (`mosaicd train --negatives-dir`, e.g. scikit-image's
    /// person-free photographs): never split, never held out, so the validation files stay those of
    /// [`split_data`] with or without them. [`inner_split`] keeps them on its training side.
    pub extra_train_neg: Vec<PathBuf>,
}

/// Photo prefix of an INRIA crop file name: the stem without its trailing letter.
pub fn photo_prefix(name: &str) -> &str {
    let stem = name.rsplit_once('.').map_or(name, |(s, _)| s);
    stem.trim_end_matches(|c: char| c.is_ascii_alphabetic())
}

/// The PNG and JPEG files of `dirs`, each directory's sorted by name, in the order of `dirs`: the
/// training-only negatives of [`Split::extra_train_neg`]. A directory that cannot be read or holds
/// no image is an error.
pub fn list_negative_dirs(dirs: &[PathBuf]) -> Result<Vec<PathBuf>, TrainError> {
    let mut out = Vec::new();
    for dir in dirs {
        let v = list(dir)?;
        if v.is_empty() {
            return Err(TrainError::Data {
                path: dir.clone(),
                what: "no PNG or JPEG images in this directory".into(),
            });
        }
        out.extend(v);
    }
    Ok(out)
}

fn list(dir: &Path) -> Result<Vec<PathBuf>, TrainError> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| TrainError::Data {
            path: dir.into(),
            what: e.to_string(),
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("png" | "jpg" | "jpeg" | "PNG" | "JPG")
            )
        })
        .collect();
    v.sort();
    Ok(v)
}

/// The seeded split of the shared data (`data_root`: the directory holding `pedestrian/`, `kodak/`).
///
/// Photo prefixes and negative images are shuffled with `seed`; fold `k` holds out the `k`-th
/// block of `val_fraction` of each, `[round(k·f·n), round((k+1)·f·n))`. Folds `0 .. ⌊1/f⌋` are
/// disjoint, so at `f = 0.2` folds 0–4 are a 5-fold cross-validation in which every photo and
/// every negative image is held out once; fold 0 is the split the shipped models use.
pub fn split_data(data_root: &Path, seed: u64, val_fraction: f64, fold: usize) -> Result<Split, TrainError> {
    check_fold(val_fraction, fold)?;
    let pos = list(&data_root.join("pedestrian/inria_pos_96x160"))?;
    let mut neg = list(&data_root.join("pedestrian/neg_inria"))?;
    neg.extend(list(&data_root.join("pedestrian/neg"))?);
    for k in 1..=24u32 {
        if !KODAK_WITH_PEOPLE.contains(&k) {
            neg.push(data_root.join(format!("kodak/kodim{k:02}.png")));
        }
    }
    Ok(split_lists(pos, neg, seed, val_fraction, fold))
}

/// Number of disjoint folds at held-out fraction `val_fraction`: `⌊1/f⌋` (with a little slack for
/// `f` like 0.2 that is not exact in binary), 1 at `f = 0` (nothing held out: train on
/// everything), 0 outside `[0, 1)`.
pub fn fold_count(val_fraction: f64) -> usize {
    if val_fraction == 0.0 {
        1
    } else if val_fraction > 0.0 && val_fraction < 1.0 {
        (1.0 / val_fraction + 1e-9).floor() as usize
    } else {
        0
    }
}

fn check_fold(val_fraction: f64, fold: usize) -> Result<(), TrainError> {
    if !(0.0..1.0).contains(&val_fraction) {
        return Err(TrainError::BadOption {
            what: "val_fraction",
            value: val_fraction.to_string(),
            allowed: "0 <= fraction < 1",
        });
    }
    if fold >= fold_count(val_fraction) {
        return Err(TrainError::BadOption {
            what: "fold",
            value: format!(
                "{fold} (held-out fraction {val_fraction}: folds 0..{})",
                fold_count(val_fraction)
            ),
            allowed: "0 <= fold < floor(1 / held-out fraction)",
        });
    }
    Ok(())
}

/// Split the *training* part of `split` once more, the same way (positives by photo prefix,
/// negatives by image), for model selection; `split`'s own validation files are not used, and its
/// training-only negatives stay training-only.
pub fn inner_split(split: &Split, seed: u64, val_fraction: f64) -> Split {
    Split {
        extra_train_neg: split.extra_train_neg.clone(),
        ..split_lists(
            split.train_pos.clone(),
            split.train_neg.clone(),
            seed ^ INNER_SPLIT_SALT,
            val_fraction,
            0,
        )
    }
}

/// The fraction [`select_c`] holds out of the training files: the outer `val_fraction`, or 0.2
/// (the default split) when nothing is held out outside (`val_fraction` 0: a model trained on
/// every file still chooses its C on an inner split).
pub fn inner_val_fraction(val_fraction: f64) -> f64 {
    if val_fraction > 0.0 {
        val_fraction
    } else {
        0.2
    }
}

/// The held-out block `[round(k·f·n), round((k+1)·f·n))` of `n` shuffled items.
fn fold_range(n: usize, val_fraction: f64, fold: usize) -> std::ops::Range<usize> {
    let at = |k: usize| ((n as f64 * val_fraction * k as f64).round() as usize).min(n);
    at(fold)..at(fold + 1)
}

/// Seeded split of positives (`pos` sorted by name, grouped by photo prefix) and negatives; fold
/// `fold` of [`split_data`].
fn split_lists(pos: Vec<PathBuf>, mut neg: Vec<PathBuf>, seed: u64, val_fraction: f64, fold: usize) -> Split {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut prefixes: Vec<String> = pos
        .iter()
        .filter_map(|p| p.file_name()?.to_str().map(|n| photo_prefix(n).to_string()))
        .collect();
    prefixes.dedup();
    prefixes.shuffle(&mut rng);
    let val: std::collections::HashSet<&str> = prefixes[fold_range(prefixes.len(), val_fraction, fold)]
        .iter()
        .map(|s| s.as_str())
        .collect();
    let mut s = Split::default();
    for p in pos {
        let n = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if val.contains(photo_prefix(n)) {
            s.val_pos.push(p);
        } else {
            s.train_pos.push(p);
        }
    }
    neg.shuffle(&mut rng);
    let r = fold_range(neg.len(), val_fraction, fold);
    s.val_neg = neg[r.clone()].to_vec();
    s.train_neg = neg[..r.start].iter().chain(&neg[r.end..]).cloned().collect();
    s
}

/// An image in a model's input domain.
#[derive(Debug, Clone)]
pub enum DomainImage {
    /// RGB.
    Colour(Image<[u8; 3]>),
    /// Grey.
    Grey(Image<u8>),
    /// Mosaic in 8-bit units.
    Mosaic(Image<f32>),
}

impl DomainImage {
    /// From an RGB image (mosaics are cropped to even size and sampled through `cfa`).
    pub fn from_rgb(img: &Image<[u8; 3]>, domain: Domain, cfa: Cfa) -> Self {
        match domain {
            Domain::Colour => DomainImage::Colour(img.clone()),
            Domain::Grey => DomainImage::Grey(img.map(|p| {
                ((p[0] as u32 * 4899 + p[1] as u32 * 9617 + p[2] as u32 * 1868 + (1 << 13)) >> 14) as u8
            })),
            Domain::Mosaic => {
                let (w, h) = (img.width() & !1, img.height() & !1);
                DomainImage::Mosaic(Image::from_fn(w, h, |x, y| {
                    let p = img.get(x, y);
                    match cfa.colour_at(x, y) {
                        Colour::Red => p[0] as f32,
                        Colour::Green => p[1] as f32,
                        Colour::Blue => p[2] as f32,
                    }
                }))
            }
        }
    }
    /// From an RGB image through `pipeline`; `index` picks the image's noise stream (deterministic);
    /// `prep` makes the mosaic of a reverse-ISP raw frame.
    pub fn from_rgb_via(
        img: &Image<[u8; 3]>,
        domain: Domain,
        cfa: Cfa,
        pipeline: &InputPipeline,
        index: u64,
        prep: &MosaicPrep,
    ) -> Result<Self, TrainError> {
        let (noise, seed) = match *pipeline {
            InputPipeline::Sampled => return Ok(Self::from_rgb(img, domain, cfa)),
            InputPipeline::ReverseIsp { noise, seed } => (noise, seed),
        };
        let (w, h) = (img.width() & !1, img.height() & !1);
        let even = if (w, h) == img.dimensions() {
            img.clone()
        } else {
            Image::from_fn(w, h, |x, y| img.get(x, y))
        };
        let profile = CameraProfile::default();
        let opts = ReverseIspOptions {
            cfa,
            noise: noise.map(|n| n.params()),
            seed: image_seed(seed, index),
            ..ReverseIspOptions::for_profile(&profile)
        };
        let raw = raw_from_srgb(even.view(), &profile, &opts)?;
        Ok(match domain {
            Domain::Mosaic => DomainImage::Mosaic(prep.mosaic(&raw)?),
            Domain::Colour => {
                DomainImage::Colour(srgb_from_raw(&raw, &profile, &ForwardIspOptions::default())?)
            }
            Domain::Grey => DomainImage::Grey(grey_from_rgb_u8(
                &srgb_from_raw(&raw, &profile, &ForwardIspOptions::default())?.view(),
            )),
        })
    }
    /// HOG input view.
    pub fn input(&self) -> HogInput<'_> {
        match self {
            DomainImage::Colour(c) => HogInput::Rgb8(c.view()),
            DomainImage::Grey(g) => HogInput::GreyU8(g.view()),
            DomainImage::Mosaic(m) => HogInput::Mosaic(m.view()),
        }
    }
    /// (width, height).
    pub fn dimensions(&self) -> (usize, usize) {
        self.input().dimensions()
    }
    /// Resized copy (mosaic: CFA-preserving; sizes rounded to even).
    pub fn resized(&self, w: usize, h: usize) -> Self {
        let mut d = Image::new(0, 0);
        match self {
            DomainImage::Colour(c) => {
                let planes: Vec<Image<f32>> = (0..3)
                    .map(|k| {
                        let mut o = Image::new(0, 0);
                        resize_bilinear(c.map(|p| p[k] as f32).view(), w, h, &mut o).expect("non-empty");
                        o
                    })
                    .collect();
                DomainImage::Colour(Image::from_fn(w, h, |x, y| {
                    [0, 1, 2].map(|k| planes[k].get(x, y).round().clamp(0.0, 255.0) as u8)
                }))
            }
            DomainImage::Grey(g) => {
                resize_bilinear(g.map(|p| p as f32).view(), w, h, &mut d).expect("non-empty");
                DomainImage::Grey(d.map(|v| v.round().clamp(0.0, 255.0) as u8))
            }
            DomainImage::Mosaic(m) => {
                resize_mosaic(m.view(), w & !1, h & !1, &mut d).expect("even, non-empty");
                DomainImage::Mosaic(d)
            }
        }
    }
}

/// A raw scene of the shared data rendered to sRGB by the forward ISP with its sensor's profile.
pub fn raw_scene_srgb(scene: &RawInput) -> Result<Image<[u8; 3]>, TrainError> {
    let data_err = |what: String| TrainError::Data {
        path: scene.rel.into(),
        what,
    };
    let frame = load_raw_frame(scene).map_err(|e| data_err(e.to_string()))?;
    Ok(srgb_from_raw(
        &frame,
        &raw_profile(scene),
        &ForwardIspOptions::default(),
    )?)
}

/// Load an RGB image.
pub fn load_rgb(path: &Path) -> Result<Image<[u8; 3]>, TrainError> {
    let img = crate::raw::load::decode_image(path)
        .map_err(|e| TrainError::Data {
            path: path.into(),
            what: e.to_string(),
        })?
        .to_rgb8();
    Image::from_vec(
        img.width() as usize,
        img.height() as usize,
        img.pixels().map(|p| p.0).collect(),
    )
    .map_err(|e| TrainError::Data {
        path: path.into(),
        what: e.to_string(),
    })
}

/// Descriptor of the 64x128 window of a 96x160 INRIA crop.
pub fn positive_descriptor(spec: &HogSpec, img: &DomainImage) -> Result<Vec<f32>, TrainError> {
    let mut g = BlockGrid::empty();
    block_grid(spec, &img.input(), Exec::Parallel, &mut g)?;
    Ok(g.window_descriptor(spec, POS_WINDOW_CELL, POS_WINDOW_CELL)?)
}

/// `n` random windows at random scales of a negative image.
pub fn random_negatives(
    spec: &HogSpec,
    img: &DomainImage,
    n: usize,
    rng: &mut impl Rng,
) -> Result<Vec<Vec<f32>>, TrainError> {
    let (w, h) = img.dimensions();
    let max_s = (w as f64 / spec.win_width() as f64).min(h as f64 / spec.win_height() as f64);
    let mut out = Vec::new();
    if max_s < 1.0 {
        return Ok(out);
    }
    let mut g = BlockGrid::empty();
    // Two scales per image, half the windows each.
    for part in [n / 2, n - n / 2] {
        let s = rng.random_range(1.0..=max_s);
        let (lw, lh) = (
            ((w as f64 / s).round() as usize).max(spec.win_width()),
            ((h as f64 / s).round() as usize).max(spec.win_height()),
        );
        let lvl = if (lw, lh) == (w, h) {
            img.clone()
        } else {
            img.resized(lw, lh)
        };
        block_grid(spec, &lvl.input(), Exec::Parallel, &mut g)?;
        let (nwx, nwy) = g.windows(spec);
        if nwx == 0 || nwy == 0 {
            continue;
        }
        for _ in 0..part {
            let (wx, wy) = (rng.random_range(0..nwx), rng.random_range(0..nwy));
            out.push(g.window_descriptor(spec, wx, wy)?);
        }
    }
    Ok(out)
}

/// Window-level result on the validation split.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WindowEval {
    /// Validation positives.
    pub positives: usize,
    /// Negative windows scored (all windows at all levels of the validation negatives).
    pub negative_windows: usize,
    /// (FPPW, miss rate) at FPPW 1e-2, 1e-3, 1e-4.
    pub miss_rate_at: Vec<(f64, f64)>,
    /// The DET curve (miss rate vs FPPW), thinned to at most a few hundred points for plotting;
    /// the first and last points and every point where the miss rate changes by a plot-visible
    /// step are kept.
    pub det: Vec<DetPoint>,
    /// The scores behind the numbers, kept for [`window_bootstrap`] (not serialized).
    #[serde(skip)]
    pub scores: WindowScores,
}

/// Per-window scores of one [`evaluate_windows_via`] run, enough to recompute the miss rate at
/// FPPW up to [`BOOTSTRAP_MAX_FPPW`] on any resample of the held-out photos and negative images.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WindowScores {
    /// Score of each held-out positive, in `Split::val_pos` order.
    pub positives: Vec<f32>,
    /// Photo of each positive (an index into the distinct [`photo_prefix`]es, in order of first
    /// appearance): the bootstrap draws photos, so a crop and its mirror stay together.
    pub positive_photo: Vec<u32>,
    /// Windows scored in each negative image, in `Split::val_neg` order.
    pub windows_per_image: Vec<usize>,
    /// The highest negative scores, descending (ties by image index), each with its image index;
    /// all scores down to the one at rank `2 · BOOTSTRAP_MAX_FPPW · windows + 64`, and every score
    /// tied with that one.
    pub top_negatives: Vec<(f32, u32)>,
}

/// Highest FPPW [`window_bootstrap`] can evaluate.
pub const BOOTSTRAP_MAX_FPPW: f64 = 1e-2;

/// Thin a DET curve to at most about `max_points` points: the positive-FPPW range is cut into
/// `max_points` equal steps in log FPPW and the last point of each step (lowest miss rate there) is
/// kept, after the last point with FPPW 0.
pub fn thin_det_curve(curve: &[DetPoint], max_points: usize) -> Vec<DetPoint> {
    let mut out: Vec<DetPoint> = curve
        .iter()
        .rfind(|p| p.fppw == 0.0)
        .copied()
        .into_iter()
        .collect();
    let positive: Vec<&DetPoint> = curve.iter().filter(|p| p.fppw > 0.0).collect();
    let (Some(first), Some(last)) = (positive.first(), positive.last()) else {
        return out;
    };
    let lo = first.fppw.log10();
    let step = ((last.fppw.log10() - lo) / max_points.max(1) as f64).max(f64::MIN_POSITIVE);
    let mut last_bucket = None;
    for p in positive {
        let b = ((p.fppw.log10() - lo) / step).floor() as i64;
        match out.last_mut() {
            Some(q) if last_bucket == Some(b) => *q = *p,
            _ => out.push(*p),
        }
        last_bucket = Some(b);
    }
    out
}

/// Miss rate at a given FPPW from positive and negative scores: the threshold lets through
/// `floor(fppw · N)` negatives (ties counted as false positives).
pub fn miss_rate_at_fppw(pos: &[f32], neg_sorted_desc: &[f32], fppw: f64) -> f64 {
    if pos.is_empty() {
        return f64::NAN;
    }
    let k = (fppw * neg_sorted_desc.len() as f64).floor() as usize;
    // Threshold strictly above the (k+1)-th highest negative.
    let thr = neg_sorted_desc.get(k).copied().unwrap_or(f32::NEG_INFINITY);
    pos.iter().filter(|&&s| s <= thr).count() as f64 / pos.len() as f64
}

/// Evaluate a model on validation images in `domain` (Dalal–Triggs window protocol), the images
/// brought into `domain` through `pipeline` (as in training, or e.g. the reverse ISP with one of
/// the paper's noise levels). Positives and negatives are scored with `svm`'s arithmetic. Mosaics
/// made through the reverse ISP are in the model's tone with white-balance gains from `wb`
/// ([`Gains::FromFile`]: the profile's, the true white balance).
#[allow(clippy::too_many_arguments)]
pub fn evaluate_windows_via(
    model: &LinearModel,
    split: &Split,
    domain: Domain,
    cfa: Cfa,
    pipeline: &InputPipeline,
    svm: ScorePrecision,
    wb: Gains,
    progress: &mut dyn FnMut(&str),
) -> Result<WindowEval, TrainError> {
    let prep = MosaicPrep {
        tone: model.mosaic_tone,
        gains: wb,
    };
    let opts = DetectorOptions {
        svm,
        ..DetectorOptions::default()
    };
    let det = Detector::new(model.clone(), &opts)?;
    let spec = det.hog_spec().clone();
    let mut pos = Vec::new();
    let mut positive_photo = Vec::new();
    let mut photos: Vec<&str> = Vec::new();
    for (i, p) in split.val_pos.iter().enumerate() {
        let img = DomainImage::from_rgb_via(&load_rgb(p)?, domain, cfa, pipeline, i as u64, &prep)?;
        pos.push(det.score_descriptor(&positive_descriptor(&spec, &img)?));
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let photo = photo_prefix(name);
        let k = photos.iter().position(|&q| q == photo).unwrap_or_else(|| {
            photos.push(photo);
            photos.len() - 1
        });
        positive_photo.push(k as u32);
    }
    let mut neg = Vec::new();
    let mut windows_per_image = Vec::with_capacity(split.val_neg.len());
    for (i, p) in split.val_neg.iter().enumerate() {
        let img = DomainImage::from_rgb_via(
            &load_rgb(p)?,
            domain,
            cfa,
            pipeline,
            NEG_SEED_OFFSET + i as u64,
            &prep,
        )?;
        let before = neg.len();
        det.for_each_window(&img.input(), |_, _, _, _, s| neg.push(s))?;
        windows_per_image.push(neg.len() - before);
        if i % 10 == 0 {
            progress(&format!(
                "eval: negatives {}/{} ({} windows)",
                i + 1,
                split.val_neg.len(),
                neg.len()
            ));
        }
    }
    let (neg, top_negatives) = rank_negatives(&neg, &windows_per_image);
    let miss_rate_at = [1e-2, 1e-3, 1e-4]
        .iter()
        .map(|&f| (f, miss_rate_at_fppw(&pos, &neg, f)))
        .collect();
    let det = thin_det_curve(&det_curve(&pos, &neg)?, DET_PLOT_POINTS);
    Ok(WindowEval {
        positives: pos.len(),
        negative_windows: neg.len(),
        miss_rate_at,
        det,
        scores: WindowScores {
            positives: pos,
            positive_photo,
            windows_per_image,
            top_negatives,
        },
    })
}

/// Every negative score, descending, and the top ones with their image index (see
/// [`WindowScores::top_negatives`]), from one sort; `neg` holds each image's windows in turn,
/// `windows_per_image[i]` of image `i`.
fn rank_negatives(neg: &[f32], windows_per_image: &[usize]) -> (Vec<f32>, Vec<(f32, u32)>) {
    let mut all: Vec<(f32, u32)> = Vec::with_capacity(neg.len());
    let mut start = 0;
    for (i, &n) in windows_per_image.iter().enumerate() {
        all.extend(neg[start..start + n].iter().map(|&s| (s, i as u32)));
        start += n;
    }
    all.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let sorted = all.iter().map(|x| x.0).collect();
    let keep = (2.0 * BOOTSTRAP_MAX_FPPW * neg.len() as f64).ceil() as usize + 64;
    if keep < all.len() {
        let last = all[keep - 1].0;
        let end = keep + all[keep..].iter().take_while(|x| x.0 == last).count();
        all.truncate(end);
    }
    (sorted, all)
}

impl WindowScores {
    /// Number of held-out photos (what the bootstrap resamples on the positive side).
    pub fn photos(&self) -> usize {
        self.positive_photo.iter().max().map_or(0, |&m| m as usize + 1)
    }

    /// Miss rate at `fppw` with photo `p` counted `photo_w[p]` times and negative image `i`
    /// counted `image_w[i]` times, as [`miss_rate_at_fppw`] computes it on that multiset (with
    /// every weight 1, equal to it). An error if the threshold lies below the kept scores.
    pub fn weighted_miss_rate(&self, photo_w: &[u32], image_w: &[u32], fppw: f64) -> Result<f64, TrainError> {
        let windows: u64 = self
            .windows_per_image
            .iter()
            .zip(image_w)
            .map(|(&n, &w)| n as u64 * w as u64)
            .sum();
        let k = (fppw * windows as f64).floor() as u64;
        // The (k + 1)-th highest drawn negative: walk down the kept scores, each counted as often
        // as its image was drawn.
        let mut seen = 0u64;
        let mut thr = None;
        for &(s, i) in &self.top_negatives {
            seen += image_w[i as usize] as u64;
            if seen > k {
                thr = Some(s);
                break;
            }
        }
        let thr = match thr {
            Some(t) => t,
            None if self.top_negatives.len() == self.windows_per_image.iter().sum::<usize>() => {
                f32::NEG_INFINITY
            }
            None => {
                return Err(TrainError::BadOption {
                    what: "window bootstrap",
                    value: format!("FPPW {fppw} on a draw of {windows} windows"),
                    allowed: "a draw within the kept negative scores",
                })
            }
        };
        let (mut missed, mut total) = (0u64, 0u64);
        for (&s, &p) in self.positives.iter().zip(&self.positive_photo) {
            let w = photo_w[p as usize] as u64;
            total += w;
            if s <= thr {
                missed += w;
            }
        }
        Ok(if total == 0 {
            f64::NAN
        } else {
            missed as f64 / total as f64
        })
    }
}

/// One row of [`window_bootstrap`]: 95 % intervals (2.5–97.5 % percentiles of the draws).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WindowBootstrapRow {
    /// Per FPPW of the call: the interval of the miss rate.
    pub miss_rate: Vec<Interval>,
    /// Per FPPW: the interval of the miss rate minus the reference row's on the same draw.
    pub diff: Vec<Interval>,
    /// Per FPPW: the share of draws in which this row misses no more than the reference row.
    pub not_worse: Vec<f64>,
}

/// Paired bootstrap of the window protocol: every draw (seeded `ChaCha8`, reproducible) takes the
/// held-out *photos* (a crop and its mirror together) and the negative *images* with replacement,
/// the same draw for every row, and recomputes each row's miss rate at each `fppw` as
/// [`miss_rate_at_fppw`] does on the drawn multiset: the threshold is the `(floor(fppw · N) + 1)`-th
/// highest negative score, `N` the drawn images' window count. The rows must come from the same
/// split (any models, domains or pipelines); `reference` indexes `rows`.
pub fn window_bootstrap(
    rows: &[&WindowScores],
    reference: usize,
    fppw: &[f64],
    resamples: usize,
    seed: u64,
) -> Result<Vec<WindowBootstrapRow>, TrainError> {
    let bad = |value: String, allowed: &'static str| TrainError::BadOption {
        what: "window bootstrap",
        value,
        allowed,
    };
    let first = rows.get(reference).ok_or_else(|| {
        bad(
            format!("reference row {reference} of {} rows", rows.len()),
            "a row of the table",
        )
    })?;
    if resamples == 0 || first.positives.is_empty() || first.windows_per_image.is_empty() {
        return Err(bad(
            format!(
                "{resamples} resamples, {} positives, {} negative images",
                first.positives.len(),
                first.windows_per_image.len()
            ),
            "at least one resample, positive and negative image",
        ));
    }
    if rows.iter().any(|r| {
        r.positive_photo != first.positive_photo || r.windows_per_image.len() != first.windows_per_image.len()
    }) {
        return Err(bad(
            "rows over different held-out files".into(),
            "rows of the same split",
        ));
    }
    if let Some(f) = fppw.iter().find(|f| !(0.0..=BOOTSTRAP_MAX_FPPW).contains(*f)) {
        return Err(bad(f.to_string(), "FPPW in 0 ..= 1e-2"));
    }
    use rand::{Rng, SeedableRng};
    let photos = first.photos();
    let images = first.windows_per_image.len();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut photo_w = vec![0u32; photos];
    let mut image_w = vec![0u32; images];
    // draws[row][f] = miss rates over the resamples.
    let mut draws = vec![vec![Vec::with_capacity(resamples); fppw.len()]; rows.len()];
    for _ in 0..resamples {
        photo_w.iter_mut().for_each(|w| *w = 0);
        image_w.iter_mut().for_each(|w| *w = 0);
        for _ in 0..photos {
            photo_w[rng.random_range(0..photos)] += 1;
        }
        for _ in 0..images {
            image_w[rng.random_range(0..images)] += 1;
        }
        for (r, row) in rows.iter().enumerate() {
            for (j, &f) in fppw.iter().enumerate() {
                draws[r][j].push(row.weighted_miss_rate(&photo_w, &image_w, f)?);
            }
        }
    }
    Ok(draws
        .iter()
        .map(|d| WindowBootstrapRow {
            miss_rate: d.iter().map(|v| Interval::of(v.clone())).collect(),
            diff: d
                .iter()
                .zip(&draws[reference])
                .map(|(v, w)| Interval::of(v.iter().zip(w).map(|(x, y)| x - y).collect()))
                .collect(),
            not_worse: d
                .iter()
                .zip(&draws[reference])
                .map(|(v, w)| v.iter().zip(w).filter(|(x, y)| x <= y).count() as f64 / resamples as f64)
                .collect(),
        })
        .collect())
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Scores of `images` negative images with `per` windows each and `photos` photos of two crops
    /// each, from a fixed generator.
    fn window_scores(
        images: usize,
        per: usize,
        photos: usize,
        shift: f32,
        seed: u64,
    ) -> (WindowScores, Vec<f32>) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let neg: Vec<f32> = (0..images * per)
            .map(|_| (rng.random::<f32>() * 4.0 - 2.0).round() / 2.0)
            .collect();
        let positives: Vec<f32> = (0..2 * photos)
            .map(|_| rng.random::<f32>() * 3.0 - 1.0 + shift)
            .collect();
        let windows_per_image = vec![per; images];
        let scores = WindowScores {
            positive_photo: (0..2 * photos as u32).map(|i| i / 2).collect(),
            positives,
            top_negatives: rank_negatives(&neg, &windows_per_image).1,
            windows_per_image,
        };
        (scores, neg)
    }

    #[test]
    fn weighted_miss_rate_equals_the_plain_one_and_duplicated_files() {
        // 20 000 windows, scores on a coarse grid so that ties cross the kept cut.
        let (w, neg) = window_scores(40, 500, 30, 0.0, 3);
        assert!(w.top_negatives.len() < neg.len(), "the cut keeps a part");
        let mut sorted = neg.clone();
        sorted.sort_by(|a, b| b.total_cmp(a));
        assert_eq!(rank_negatives(&neg, &[500; 40]).0, sorted);
        let ones_p = vec![1; 30];
        let ones_i = vec![1; 40];
        for f in [0.0, 1e-4, 1e-3, 5e-3, 1e-2] {
            assert_eq!(
                w.weighted_miss_rate(&ones_p, &ones_i, f).unwrap(),
                miss_rate_at_fppw(&w.positives, &sorted, f),
                "fppw {f}"
            );
        }
        // Weights equal duplicating the files (and 0 dropping them).
        let mut photo_w = vec![1u32; 30];
        photo_w[3] = 3;
        photo_w[7] = 0;
        let mut image_w = vec![1u32; 40];
        image_w[0] = 2;
        image_w[5] = 0;
        let mut pos = Vec::new();
        for (i, &s) in w.positives.iter().enumerate() {
            for _ in 0..photo_w[i / 2] {
                pos.push(s);
            }
        }
        let mut dup = Vec::new();
        for (i, chunk) in neg.chunks(500).enumerate() {
            for _ in 0..image_w[i] {
                dup.extend_from_slice(chunk);
            }
        }
        dup.sort_by(|a, b| b.total_cmp(a));
        for f in [1e-4, 1e-3, 1e-2] {
            assert_eq!(
                w.weighted_miss_rate(&photo_w, &image_w, f).unwrap(),
                miss_rate_at_fppw(&pos, &dup, f),
                "fppw {f}"
            );
        }
    }

    #[test]
    fn window_bootstrap_is_paired_reproducible_and_checks_its_input() {
        let (a, _) = window_scores(30, 400, 40, 0.0, 5);
        let (b, _) = window_scores(30, 400, 40, 0.8, 6);
        let rows = [&a, &b];
        let f = [1e-3, 1e-2];
        let r1 = window_bootstrap(&rows, 0, &f, 200, 9).unwrap();
        assert_eq!(r1, window_bootstrap(&rows, 0, &f, 200, 9).unwrap());
        assert_ne!(r1, window_bootstrap(&rows, 0, &f, 200, 10).unwrap());
        // The reference against itself: a zero difference on every draw.
        assert_eq!(r1[0].diff, vec![Interval { lo: 0.0, hi: 0.0 }; 2]);
        assert_eq!(r1[0].not_worse, vec![1.0; 2]);
        // Row b's positives score 0.8 higher: it misses less on every draw.
        for (j, &fj) in f.iter().enumerate() {
            assert!(r1[1].diff[j].hi < 0.0, "{:?}", r1[1].diff);
            assert_eq!(r1[1].not_worse[j], 1.0);
            let plain = a.weighted_miss_rate(&[1; 40], &[1; 30], fj).unwrap();
            assert!(r1[0].miss_rate[j].lo <= plain && plain <= r1[0].miss_rate[j].hi);
        }
        // Bad input: no resamples, a reference past the rows, an FPPW above the kept range, rows
        // over different files.
        assert!(window_bootstrap(&rows, 0, &f, 0, 9).is_err());
        assert!(window_bootstrap(&rows, 2, &f, 10, 9).is_err());
        assert!(window_bootstrap(&rows, 0, &[0.05], 10, 9).is_err());
        let (c, _) = window_scores(31, 400, 40, 0.0, 5);
        assert!(window_bootstrap(&[&a, &c], 0, &f, 10, 9).is_err());
    }

    #[test]
    fn miss_rate_by_hand() {
        let neg = [5.0, 4.0, 3.0, 2.0, 1.0, 0.0, -1.0, -2.0, -3.0, -4.0];
        let pos = [4.5, 3.5, 2.5, 0.5];
        // FPPW 0.1 → 1 false positive allowed → threshold at 4.0: positives > 4.0: one.
        assert_eq!(miss_rate_at_fppw(&pos, &neg, 0.1), 0.75);
        assert_eq!(miss_rate_at_fppw(&pos, &neg, 0.3), 0.25);
    }

    #[test]
    fn thinned_det_curve_keeps_ends_and_shape() {
        let pos: Vec<f32> = (0..100).map(|i| i as f32 / 10.0).collect();
        let neg: Vec<f32> = (0..10_000).map(|i| -(i as f32) / 1000.0).collect();
        let full = det_curve(&pos, &neg).unwrap();
        let thin = thin_det_curve(&full, 50);
        assert!(thin.len() <= 52 && thin.len() > 10, "{}", thin.len());
        assert_eq!(thin.first().map(|p| p.fppw), Some(0.0));
        assert_eq!(thin.last(), full.last());
        // Monotone like the full curve, and every kept point is a point of the full curve.
        assert!(thin
            .windows(2)
            .all(|w| w[1].fppw > w[0].fppw && w[1].miss_rate <= w[0].miss_rate));
        assert!(thin.iter().all(|p| full.contains(p)));
    }

    #[test]
    fn reverse_isp_inputs_are_seeded_and_noisy() {
        let rgb = Image::from_fn(32, 24, |x, y| [(x * 7) as u8, (y * 9) as u8, 128]);
        let noisy = |seed, index| {
            let p = InputPipeline::ReverseIsp {
                noise: Some(NoiseLevel::High),
                seed,
            };
            DomainImage::from_rgb_via(&rgb, Domain::Mosaic, Cfa::Rggb, &p, index, &MosaicPrep::default())
                .unwrap()
        };
        let clean = DomainImage::from_rgb_via(
            &rgb,
            Domain::Mosaic,
            Cfa::Rggb,
            &InputPipeline::ReverseIsp { noise: None, seed: 1 },
            0,
            &MosaicPrep::default(),
        )
        .unwrap();
        let px = |d: &DomainImage| match d {
            DomainImage::Mosaic(m) => m.as_slice().to_vec(),
            _ => unreachable!(),
        };
        assert_eq!(
            px(&noisy(1, 0)),
            px(&noisy(1, 0)),
            "same seed and index: same image"
        );
        assert_ne!(
            px(&noisy(1, 0)),
            px(&noisy(1, 1)),
            "another image index: another noise"
        );
        assert_ne!(px(&noisy(1, 0)), px(&clean));
        // Colour through the forward ISP keeps the size (cropped to even).
        let c = DomainImage::from_rgb_via(
            &rgb,
            Domain::Colour,
            Cfa::Rggb,
            &InputPipeline::ReverseIsp { noise: None, seed: 1 },
            0,
            &MosaicPrep::default(),
        )
        .unwrap();
        assert_eq!(c.dimensions(), (32, 24));
    }

    #[test]
    fn srgb_tone_undoes_the_raw_frames_white_balance_and_curve_per_site() {
        // mid grey through the reverse ISP: the raw R and B sites are darker than G (no white
        // balance) and linear; the srgb tone brings every site back to the grey's code
        let rgb = Image::from_fn(32, 24, |_, _| [128u8; 3]);
        let pipe = InputPipeline::ReverseIsp { noise: None, seed: 1 };
        let mosaic = |prep: MosaicPrep| match DomainImage::from_rgb_via(
            &rgb,
            Domain::Mosaic,
            Cfa::Rggb,
            &pipe,
            0,
            &prep,
        )
        .unwrap()
        {
            DomainImage::Mosaic(m) => m,
            _ => unreachable!(),
        };
        let lin = mosaic(MosaicPrep::default());
        let (r, g, b) = (lin.get(0, 0), lin.get(1, 0), lin.get(1, 1));
        assert!(
            r < 0.8 * g && b < 0.5 * g && g < 0.3 * 255.0,
            "linear R {r} G {g} B {b}"
        );
        for gains in [Gains::FromFile, Gains::Auto, Gains::GreyWorld] {
            let s = mosaic(MosaicPrep {
                tone: MosaicTone::Srgb,
                gains,
            });
            for &v in s.as_slice() {
                assert!((v - 128.0).abs() < 1.5, "{gains:?}: {v}");
            }
        }
        // a sampled mosaic is already sRGB: the tone does not apply
        let sampled = |prep| {
            DomainImage::from_rgb_via(&rgb, Domain::Mosaic, Cfa::Rggb, &InputPipeline::Sampled, 0, &prep)
                .unwrap()
        };
        let px = |d: DomainImage| match d {
            DomainImage::Mosaic(m) => m.into_vec(),
            _ => unreachable!(),
        };
        assert_eq!(
            px(sampled(MosaicPrep::with_tone(MosaicTone::Srgb))),
            px(sampled(MosaicPrep::default()))
        );
    }

    #[test]
    fn input_pipeline_names_parse_back() {
        for p in [
            InputPipeline::Sampled,
            InputPipeline::ReverseIsp { noise: None, seed: 3 },
            InputPipeline::ReverseIsp {
                noise: Some(NoiseLevel::High),
                seed: 3,
            },
        ] {
            assert_eq!(InputPipeline::parse(&p.name(), 3), Ok(p));
        }
        assert_eq!(
            InputPipeline::parse(" Medium ", 9),
            Ok(InputPipeline::ReverseIsp {
                noise: Some(NoiseLevel::Medium),
                seed: 9
            })
        );
        let e = InputPipeline::parse("raw-foggy", 1).unwrap_err();
        assert!(e.contains("raw-foggy") && e.contains("expected sampled"), "{e}");
    }

    /// 40 photos of two crops each (a crop and its mirror share the prefix) and 30 negative
    /// images, by name only.
    fn toy_files() -> (Vec<PathBuf>, Vec<PathBuf>) {
        let pos = (0..40)
            .flat_map(|k| ["a", "b"].map(|m| PathBuf::from(format!("crop{k:03}{m}.png"))))
            .collect();
        let neg = (0..30).map(|k| PathBuf::from(format!("neg{k}.jpg"))).collect();
        (pos, neg)
    }

    #[test]
    fn inner_split_regroups_only_the_training_files() {
        let (pos, neg) = toy_files();
        let outer = Split {
            extra_train_neg: vec![PathBuf::from("extra.png")],
            ..split_lists(pos, neg, 1, 0.2, 0)
        };
        let inner = inner_split(&outer, 1, 0.2);
        // Training-only negatives stay on the training side.
        assert_eq!(inner.extra_train_neg, outer.extra_train_neg);
        let sorted = |v: &[PathBuf]| {
            let mut v = v.to_vec();
            v.sort();
            v
        };
        // Inner train + inner validation = outer train; nothing of the outer validation.
        let mut all_pos = inner.train_pos.clone();
        all_pos.extend(inner.val_pos.clone());
        assert_eq!(sorted(&all_pos), sorted(&outer.train_pos));
        let mut all_neg = inner.train_neg.clone();
        all_neg.extend(inner.val_neg.clone());
        assert_eq!(sorted(&all_neg), sorted(&outer.train_neg));
        assert!(!inner.val_pos.is_empty() && !inner.val_neg.is_empty());
        // Mirrors stay together.
        for p in &inner.val_pos {
            let pre = photo_prefix(p.to_str().unwrap());
            assert!(inner
                .train_pos
                .iter()
                .all(|q| photo_prefix(q.to_str().unwrap()) != pre));
        }
        // Deterministic.
        assert_eq!(inner_split(&outer, 1, 0.2).val_pos, inner.val_pos);
    }

    #[test]
    fn training_on_every_file_still_selects_c_on_an_inner_split() {
        let (pos, neg) = toy_files();
        let all = split_lists(pos, neg, 1, 0.0, 0);
        assert!(all.val_pos.is_empty() && all.val_neg.is_empty());
        assert_eq!((all.train_pos.len(), all.train_neg.len()), (80, 30));
        assert_eq!(inner_val_fraction(0.0), 0.2);
        assert_eq!(inner_val_fraction(0.25), 0.25);
        let inner = inner_split(&all, 1, inner_val_fraction(0.0));
        assert_eq!((inner.val_pos.len(), inner.val_neg.len()), (16, 6));
    }

    #[test]
    fn folds_are_disjoint_cover_everything_and_fold_zero_is_the_shipped_split() {
        // 23 photos of 1–3 crops each (mirrors share the prefix), 41 negative images.
        let pos: Vec<PathBuf> = (0..23)
            .flat_map(|i| {
                (0..1 + i % 3)
                    .map(move |j| PathBuf::from(format!("crop{i:03}00{}.png", (b'a' + j as u8) as char)))
            })
            .collect();
        let neg: Vec<PathBuf> = (0..41).map(|i| PathBuf::from(format!("n{i:02}.jpg"))).collect();
        assert_eq!(fold_count(0.2), 5);
        assert_eq!(fold_count(0.25), 4);
        assert_eq!(fold_count(0.3), 3);
        let folds: Vec<Split> = (0..5)
            .map(|k| split_lists(pos.clone(), neg.clone(), 7, 0.2, k))
            .collect();
        // Fold 0 is what the split was before folds existed: the first round(f·n) of the shuffle.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut prefixes: Vec<String> = pos
            .iter()
            .map(|p| photo_prefix(p.to_str().unwrap()).to_string())
            .collect();
        prefixes.dedup();
        prefixes.shuffle(&mut rng);
        let mut shuffled = neg.clone();
        shuffled.shuffle(&mut rng);
        assert_eq!(folds[0].val_neg, shuffled[..8].to_vec());
        assert_eq!(folds[0].train_neg, shuffled[8..].to_vec());
        let first: std::collections::HashSet<&str> = prefixes[..5].iter().map(|s| s.as_str()).collect();
        assert!(folds[0]
            .val_pos
            .iter()
            .all(|p| first.contains(photo_prefix(p.to_str().unwrap()))));
        let mut seen_pos: Vec<PathBuf> = Vec::new();
        let mut seen_neg: Vec<PathBuf> = Vec::new();
        for f in &folds {
            assert_eq!(f.val_pos.len() + f.train_pos.len(), pos.len());
            assert_eq!(f.val_neg.len() + f.train_neg.len(), neg.len());
            assert!(!f.val_pos.is_empty() && !f.val_neg.is_empty());
            for p in &f.val_pos {
                let pre = photo_prefix(p.to_str().unwrap());
                assert!(f
                    .train_pos
                    .iter()
                    .all(|q| photo_prefix(q.to_str().unwrap()) != pre));
            }
            seen_pos.extend(f.val_pos.iter().cloned());
            seen_neg.extend(f.val_neg.iter().cloned());
        }
        // Every photo and every negative image is held out exactly once.
        seen_pos.sort();
        seen_neg.sort();
        let (mut all_pos, mut all_neg) = (pos.clone(), neg.clone());
        all_pos.sort();
        all_neg.sort();
        assert_eq!(seen_pos, all_pos);
        assert_eq!(seen_neg, all_neg);
        // Out of range: a clear error naming the fold, before any file is read.
        let missing = Path::new("/nonexistent/mosaicd-data");
        match split_data(missing, 1, 0.2, 5) {
            Err(TrainError::BadOption { what, value, .. }) => {
                assert_eq!(what, "fold");
                assert!(value.starts_with('5'), "{value}");
            }
            other => panic!("{other:?}"),
        }
        for bad in [1.0, -0.1, f64::NAN] {
            assert!(matches!(
                split_data(missing, 1, bad, 0),
                Err(TrainError::BadOption {
                    what: "val_fraction",
                    ..
                })
            ));
        }
        // Nothing held out (train on everything) is fold 0 only.
        assert!(matches!(
            split_data(missing, 1, 0.0, 1),
            Err(TrainError::BadOption { what: "fold", .. })
        ));
        let all = split_lists(pos.clone(), neg.clone(), 7, 0.0, 0);
        assert!(all.val_pos.is_empty() && all.val_neg.is_empty());
        assert_eq!((all.train_pos.len(), all.train_neg.len()), (pos.len(), neg.len()));
        assert!(matches!(
            split_data(missing, 1, 0.0, 0),
            Err(TrainError::Data { .. })
        ));
        assert!(matches!(
            split_data(missing, 1, 0.2, 4),
            Err(TrainError::Data { .. })
        ));
    }

    #[test]
    fn select_c_rejects_empty_and_non_positive_candidates_before_training() {
        // The files do not exist: a candidate list that got past the check would fail on them.
        let split = split_lists(
            vec![PathBuf::from("crop001a.png")],
            vec![PathBuf::from("neg.jpg")],
            1,
            0.2,
            0,
        );
        let o = TrainOptions::default();
        for (cands, shown) in [(&[][..], "[]"), (&[0.1, 0.0][..], "0"), (&[f64::NAN][..], "NaN")] {
            match select_c(&split, &o, cands, &mut |_| {}) {
                Err(TrainError::BadOption { what, value, .. }) => {
                    assert_eq!(what, "C candidates");
                    assert_eq!(value, shown);
                }
                other => panic!("{cands:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn negative_dirs_list_images_in_order_and_reject_empty_ones() {
        let dir = tempfile::tempdir().unwrap();
        let (d1, d2, empty) = (dir.path().join("1"), dir.path().join("2"), dir.path().join("e"));
        for d in [&d1, &d2, &empty] {
            std::fs::create_dir(d).unwrap();
        }
        for f in [
            d1.join("b.png"),
            d1.join("a.jpg"),
            d2.join("c.png"),
            d1.join("x.txt"),
        ] {
            std::fs::write(f, b"").unwrap();
        }
        let names: Vec<PathBuf> = list_negative_dirs(&[d2.clone(), d1.clone()]).unwrap();
        assert_eq!(names, [d2.join("c.png"), d1.join("a.jpg"), d1.join("b.png")]);
        let e = list_negative_dirs(&[d1.clone(), empty.clone()])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no PNG or JPEG") && e.contains(empty.to_str().unwrap()),
            "{e}"
        );
        let e = list_negative_dirs(&[dir.path().join("missing")])
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing"), "{e}");
    }

    #[test]
    fn a_bad_bias_scale_is_refused_before_training() {
        for b in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let o = TrainOptions {
                bias_scale: b,
                ..TrainOptions::default()
            };
            let e = train_on(&Split::default(), &o, &mut |_| {}).unwrap_err();
            assert!(e.to_string().contains("bias_scale"), "{b}: {e}");
        }
    }

    #[test]
    fn prefixes_group_mirrors() {
        assert_eq!(photo_prefix("crop001001a.png"), photo_prefix("crop001001b.png"));
        assert_ne!(photo_prefix("crop001001a.png"), photo_prefix("crop001002a.png"));
    }
}
