//! What `mosaicd detect`, `train`, `eval detection` and `bench detect` share, below all of them:
//! the detector and training argument structs, the one-frame loader in the detector's domain,
//! the box printer, the preview and the `--json` report of one frame's detections.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};

use super::input::InputArgs;
use mosaicd::detect::AcfOptions;
use mosaicd::detect::MosaicPrep;
use mosaicd::detect::{DetectorOptions, Domain, NmsMethod, ScorePrecision};
use mosaicd::detect::{PeopleDetector, PeopleInput, PeopleModel, PeopleStats};
use mosaicd::eval::draw_boxes;
use mosaicd::features::hog::{MosaicTaps, MosaicTone};
use mosaicd::image::Image;
use mosaicd::isp::grey_from_rgb_u8;
use mosaicd::raw::Gains;
use mosaicd::raw::{Cfa, RawFrame};

/// Detector options on the command line.
#[derive(clap::Args, Debug, Clone)]
pub struct DetectorArgs {
    /// Hit threshold on the score (HOG: the SVM's; ACF: the trees' sum, which must also stay
    /// above the model's soft-cascade threshold).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub threshold: f32,
    /// Scale step between pyramid levels (HOG; an ACF model's pyramid has its own levels per
    /// octave).
    #[arg(long, default_value_t = 1.05)]
    pub scale_step: f64,
    /// Maximum pyramid levels.
    #[arg(long, default_value_t = 64)]
    pub max_levels: usize,
    /// Start the pyramid magnified (2 finds people ~64 px tall).
    #[arg(long, default_value_t = 1.0)]
    pub upsample: f64,
    /// Suppression: `group` (OpenCV groupRectangles, threshold 2, eps 0.2), `greedy` (IoU 0.5), `none`.
    /// Default: `group` for HOG models, `greedy` for ACF models (as the daemon runs them).
    #[arg(long, value_enum)]
    pub nms: Option<NmsArg>,
    /// Feature-pyramid approximation: compute every N-th level exactly and approximate the levels
    /// in between from its 2x2-pixel micro-cells (1 = exact, OpenCV-equivalent; 14 ≈ one exact
    /// level per octave at step 1.05). Default: 14 for `mosaicd detect` (the daemon's default:
    /// measured faster than exact on every path at unchanged quality, docs/detection.md,
    /// "Defaults"), 1 for `mosaicd eval detection`. ACF models: N − 1 approximated levels between
    /// exact ones (default the model's own, in every command).
    #[arg(long)]
    pub approx: Option<usize>,
    /// SVM arithmetic: `f32` (OpenCV's scores within 1e-6), `i8` (8-bit blocks and weights, exact
    /// integer sums, scores within ≈0.04 of f32: measured faster than f32 on x86-64, 2.6–4x with
    /// AVX-512 VNNI or AVX-VNNI) or `auto` (`i8` where it was measured faster, else `f32`;
    /// docs/detection.md, "8-bit SVM"). Default: `auto` for `mosaicd detect` (the daemon's
    /// default), `f32` for `mosaicd eval detection`.
    #[arg(long, value_enum)]
    pub svm: Option<SvmArg>,
    /// Derivative of mosaic features, overriding the model's: `same-site` (`(I(x+2) −
    /// I(x−2))/2`; OpenCV's weights and the shipped models) or `paper` (`I(x+1) − I(x−1)`, the
    /// paper's `[-1, 0, 1]` on the mosaic).
    #[arg(long)]
    pub mosaic_taps: Option<MosaicTaps>,
    /// How raw values become the mosaic, overriding the model's `mosaic_tone`: `linear`
    /// (black-subtracted and scaled, the paper's raw mosaic) or `srgb` (each site white balanced,
    /// clipped and sRGB-encoded: the ISP's per-pixel stages without demosaicing; what models
    /// trained with `--mosaic-tone srgb` read). Raw input only: a mosaic sampled from an image is
    /// already sRGB.
    #[arg(long)]
    pub mosaic_tone: Option<MosaicTone>,
    /// White-balance gains of the `srgb` tone: `auto` (the frame's own, else grey world), `file`,
    /// `grey-world`, `none` or `R,G,B`.
    #[arg(long, default_value = "auto")]
    pub wb_gains: Gains,
}

/// `--svm` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SvmArg {
    /// f32 products and sums.
    F32,
    /// u8 blocks, i8 weights, exact i32 sums.
    I8,
    /// `i8` on the CPUs where it is measured faster, `f32` elsewhere.
    Auto,
}

impl From<SvmArg> for ScorePrecision {
    fn from(s: SvmArg) -> Self {
        match s {
            SvmArg::F32 => ScorePrecision::F32,
            SvmArg::I8 => ScorePrecision::I8,
            SvmArg::Auto => ScorePrecision::auto(),
        }
    }
}

/// `--nms` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum NmsArg {
    /// OpenCV groupRectangles (threshold 2, eps 0.2).
    Group,
    /// Greedy IoU 0.5.
    Greedy,
    /// Keep every hit.
    None,
}

/// `--as` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum DomainArg {
    /// Raw Bayer mosaic.
    Mosaic,
    /// Grey.
    Grey,
    /// Colour.
    Colour,
}

impl From<DomainArg> for Domain {
    fn from(d: DomainArg) -> Self {
        match d {
            DomainArg::Mosaic => Domain::Mosaic,
            DomainArg::Grey => Domain::Grey,
            DomainArg::Colour => Domain::Colour,
        }
    }
}

impl NmsArg {
    /// The library's method.
    pub fn method(self) -> NmsMethod {
        match self {
            NmsArg::Group => NmsMethod::Group {
                threshold: 2,
                eps: 0.2,
            },
            NmsArg::Greedy => NmsMethod::Greedy { iou: 0.5 },
            NmsArg::None => NmsMethod::None,
        }
    }
}

impl DetectorArgs {
    /// The model `name` (HOG: a built-in name, `opencv-default` or a file; or an ACF model file)
    /// with `--mosaic-taps` and `--mosaic-tone` applied.
    pub fn model(&self, name: &str, domain_for_opencv: Domain) -> anyhow::Result<PeopleModel> {
        Ok(PeopleModel::load(name, domain_for_opencv)?.with_overrides(self.mosaic_taps, self.mosaic_tone))
    }

    /// The mosaic of a raw frame for `model` (its tone, `--wb-gains`).
    pub fn mosaic(&self, model: &PeopleModel, frame: &RawFrame) -> anyhow::Result<Image<f32>> {
        MosaicPrep {
            tone: model.mosaic_tone(),
            gains: self.wb_gains,
        }
        .mosaic(frame)
        .context("--wb-gains")
    }

    /// The detector of `model` with [`DetectorArgs::options`] (HOG) or
    /// [`DetectorArgs::acf_options`] (ACF): what `mosaicd detect` runs.
    pub fn detector(&self, model: PeopleModel) -> anyhow::Result<PeopleDetector> {
        Ok(model.build(&self.options()?, &self.acf_options())?)
    }

    /// To library options, with `--approx` and `--svm` defaulting to the daemon's defaults (what
    /// `mosaicd detect` runs).
    pub fn options(&self) -> anyhow::Result<DetectorOptions> {
        self.options_with(mosaicd::detect::DEFAULT_APPROX_LEVELS, SvmArg::Auto)
    }

    /// To library options, with `--approx` and `--svm` defaulting to `approx` and `svm` (the
    /// experiments' exact pyramid and f32 SVM, for `eval detection`).
    pub fn options_with(&self, approx: usize, svm: SvmArg) -> anyhow::Result<DetectorOptions> {
        Ok(DetectorOptions {
            scale_step: self.scale_step,
            max_levels: self.max_levels,
            upsample: self.upsample,
            hit_threshold: self.threshold,
            nms: self.nms.unwrap_or(NmsArg::Group).method(),
            approx_levels: self.approx.unwrap_or(approx),
            svm: self.svm.unwrap_or(svm).into(),
        })
    }

    /// The ACF detector's options (every command alike, and as the daemon's
    /// `acf_options` in `pipeline/daemon.rs` for the same settings): `--upsample`,
    /// `--max-levels`, `--threshold`, `--nms` (default greedy), `--approx N` as N − 1
    /// approximated levels between exact ones (default the model's).
    pub fn acf_options(&self) -> AcfOptions {
        AcfOptions {
            upsample: self.upsample,
            approx: self.approx.map(|a| a.saturating_sub(1)),
            max_levels: self.max_levels,
            hit_threshold: self.threshold,
            nms: self.nms.unwrap_or(NmsArg::Greedy).method(),
        }
    }
}

/// A decoded input frame in the domain it will be detected in.
pub enum Frame {
    /// Normalised mosaic (8-bit units) and its pattern.
    Mosaic(Image<f32>, Cfa),
    /// Grey.
    Grey(Image<u8>),
    /// Colour (RGB).
    Colour(Image<[u8; 3]>),
}

impl Frame {
    /// The detector's input view.
    pub fn input(&self) -> PeopleInput<'_> {
        match self {
            Frame::Mosaic(m, cfa) => PeopleInput::Mosaic {
                image: m.view(),
                cfa: *cfa,
            },
            Frame::Grey(g) => PeopleInput::Grey(g.view()),
            Frame::Colour(c) => PeopleInput::Colour(c.view()),
        }
    }
    /// CFA pattern of a mosaic frame.
    pub fn cfa(&self) -> Option<Cfa> {
        match self {
            Frame::Mosaic(_, c) => Some(*c),
            _ => None,
        }
    }
    /// Domain.
    pub fn domain(&self) -> Domain {
        match self {
            Frame::Mosaic(..) => Domain::Mosaic,
            Frame::Grey(_) => Domain::Grey,
            Frame::Colour(_) => Domain::Colour,
        }
    }
    /// An RGB preview (mosaic shown as grey values).
    pub fn preview(&self) -> Image<[u8; 3]> {
        match self {
            Frame::Mosaic(m, _) => m.map(|v| {
                let g = v.clamp(0.0, 255.0) as u8;
                [g, g, g]
            }),
            Frame::Grey(g) => g.map(|v| [v, v, v]),
            Frame::Colour(c) => c.clone(),
        }
    }
}

/// Load the input through the one loader ([`InputArgs::load`]) as a frame in the domain it will
/// be detected in; `mosaic` turns a raw frame into the detector's mosaic (e.g.
/// [`DetectorArgs::mosaic`] for the model).
pub fn load_frame(
    input: &InputArgs,
    as_domain: Option<DomainArg>,
    mosaic: &dyn Fn(&RawFrame) -> anyhow::Result<Image<f32>>,
) -> anyhow::Result<Frame> {
    let want: Option<Domain> = as_domain.map(Domain::from);
    let path = &input.input;
    let loaded = input.load()?;
    let f = &loaded.frame;
    let (w, h) = (f.width(), f.height());
    let even = || -> anyhow::Result<()> {
        if w % 2 != 0 || h % 2 != 0 {
            bail!("{}: mosaic size {w}x{h} must be even", path.display());
        }
        Ok(())
    };
    let Some(colour) = loaded.rgb else {
        // Raw, camera raw, or a grey PNG/PGM mosaic.
        return match want.unwrap_or(Domain::Mosaic) {
            Domain::Mosaic => {
                even()?;
                Ok(Frame::Mosaic(mosaic(f)?, f.cfa()))
            }
            d => bail!(
                "{}: a raw mosaic can only be detected as mosaic, not {}",
                path.display(),
                d.name()
            ),
        };
    };
    let is_grey = colour.as_slice().iter().all(|&[r, g, b]| r == g && g == b);
    match want.unwrap_or(if is_grey { Domain::Grey } else { Domain::Colour }) {
        Domain::Colour => Ok(Frame::Colour(colour)),
        Domain::Grey => Ok(Frame::Grey(grey_from_rgb_u8(&colour.view()))),
        Domain::Mosaic => {
            even()?;
            // The loader sampled the image through --cfa: already sRGB values, used as they are
            // (the model's tone applies to raw values only).
            let px = f.to_u16_vec();
            Ok(Frame::Mosaic(
                Image::from_fn(w, h, |x, y| px[y * w + x] as f32),
                f.cfa(),
            ))
        }
    }
}

/// Save an RGB image as PNG.
pub fn save_png(img: &Image<[u8; 3]>, path: &Path) -> anyhow::Result<()> {
    let (w, h) = img.dimensions();
    let buf: Vec<u8> = img.as_slice().iter().flat_map(|p| p.iter().copied()).collect();
    image::save_buffer(path, &buf, w as u32, h as u32, image::ColorType::Rgb8)
        .with_context(|| format!("writing {}", path.display()))
}

/// One line per box (the text output of `mosaicd detect`).
pub fn print_boxes(boxes: &[mosaicd::detect::Detection]) {
    for b in boxes {
        println!(
            "  x {:6.0} y {:6.0} w {:5.0} h {:5.0} score {:.3}",
            b.x, b.y, b.width, b.height, b.score
        );
    }
}

/// The frame with `boxes` drawn, as a PNG at `path` (if any).
pub fn save_preview(
    frame: &Frame,
    boxes: &[mosaicd::detect::Detection],
    path: Option<&Path>,
) -> anyhow::Result<()> {
    if let Some(p) = path {
        let mut img = frame.preview();
        draw_boxes(&mut img, boxes);
        save_png(&img, p)?;
    }
    Ok(())
}

/// The `--json` report of one frame's detections: input, detector, domains, model, boxes and the
/// detector's own statistics (times in ms).
pub fn json_report(
    input: &Path,
    frame: &Frame,
    model: &str,
    det: &PeopleDetector,
    boxes: &[mosaicd::detect::Detection],
    stats: &PeopleStats,
) -> serde_json::Value {
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    let stats = match stats {
        PeopleStats::Hog(s) => serde_json::json!({
            "levels": s.levels, "windows": s.windows, "hits": s.hits,
            "total_ms": ms(s.total), "resize_cpu_ms": ms(s.resize), "gamma_cpu_ms": ms(s.hog.gamma),
            "cells_cpu_ms": ms(s.hog.cells), "blocks_cpu_ms": ms(s.hog.blocks),
            "svm_cpu_ms": ms(s.svm), "nms_ms": ms(s.nms),
        }),
        PeopleStats::Acf(s) => serde_json::json!({
            "levels": s.levels, "windows": s.windows, "hits": s.hits,
            "trees_per_window": s.trees_evaluated as f64 / s.windows.max(1) as f64,
            "total_ms": ms(s.total), "channels_ms": ms(s.channels), "score_ms": ms(s.score), "nms_ms": ms(s.nms),
        }),
    };
    serde_json::json!({
        "input": input.display().to_string(),
        "detector": det.kind().name(),
        "domain": frame.domain(),
        "cfa": frame.cfa().map(|c| c.name()),
        "model": model,
        "model_domain": det.domain(),
        "detections": boxes,
        "stats": stats,
    })
}

/// The text summary line of one frame's detections.
pub fn text_summary(input: &Path, boxes: usize, stats: &PeopleStats) -> String {
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    match stats {
        PeopleStats::Hog(s) => format!(
            "{}: {boxes} detections ({} levels, {} windows, {} hits, {:.1} ms)",
            input.display(),
            s.levels,
            s.windows,
            s.hits,
            ms(s.total)
        ),
        PeopleStats::Acf(s) => format!(
            "{}: {boxes} detections (acf; {} levels, {} windows, {:.1} trees per window, {} hits, {:.1} ms: channels {:.1}, scoring {:.1})",
            input.display(),
            s.levels,
            s.windows,
            s.trees_evaluated as f64 / s.windows.max(1) as f64,
            s.hits,
            ms(s.total),
            ms(s.channels),
            ms(s.score)
        ),
    }
}

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
    pub acf: AcfTrainArgs,
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
    /// ACF: the channels the trees may read, written into the model: `all` (Dollár's) or
    /// `gradient` (magnitude and orientations, no colour channel: a channel ablation).
    #[arg(long, default_value = "all", value_parser = ["all", "gradient"])]
    pub acf_features: String,
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
