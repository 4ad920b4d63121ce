//! `mosaicd detect`: pedestrian detection on one frame (raw mosaic, grey or colour image).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};

use super::input::InputArgs;
use mosaicd::detect::input::{with_overrides, MosaicPrep};
use mosaicd::detect::{Detector, DetectorOptions, Domain, LinearModel, NmsMethod, ScorePrecision};
use mosaicd::eval::draw::draw_boxes;
use mosaicd::features::hog::{HogInput, MosaicTaps, MosaicTone};
use mosaicd::image::Image;
use mosaicd::isp::grey::grey_from_rgb_u8;
use mosaicd::raw::levels::Gains;
use mosaicd::raw::{Cfa, RawFrame};

/// Arguments of `mosaicd detect`.
#[derive(clap::Args, Debug)]
pub struct DetectArgs {
    /// The input frame and how to read it (shared with `gradients` and `sift`: one loader).
    #[command(flatten)]
    pub input: InputArgs,
    /// Interpret an RGB image as `colour`, `grey`, or `mosaic` (sampled through --cfa into a
    /// mosaic, no ISP). Default: grey for an image whose pixels are all grey, else colour. A
    /// mosaic input (raw, camera raw, grey PNG/PGM mosaic) is detected as a mosaic only.
    #[arg(long = "as", value_enum)]
    pub as_domain: Option<DomainArg>,
    /// Model: a built-in name (`mosaic-raw-srgb`, the default; `mosaic-raw-srgb-low`,
    /// `mosaic-raw`, `mosaic`, `colour`, `colour-raw`: the files under models/, compiled in), a
    /// file (.json ours; .npy / .yml / text = OpenCV vectors) or `opencv-default` (OpenCV's people
    /// detector from $MOSAICD_DATA/opencv_hog).
    #[arg(long, default_value = mosaicd::detect::DEFAULT_MODEL)]
    pub model: String,
    #[command(flatten)]
    pub det: DetectorArgs,
    /// Print JSON (boxes, scores, stage times) instead of text.
    #[arg(long)]
    pub json: bool,
    /// Draw the boxes on a preview PNG.
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Worker threads (own rayon pool; 0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

/// Detector options on the command line.
#[derive(clap::Args, Debug, Clone)]
pub struct DetectorArgs {
    /// Hit threshold on the SVM score.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub threshold: f32,
    /// Scale step between pyramid levels.
    #[arg(long, default_value_t = 1.05)]
    pub scale_step: f64,
    /// Maximum pyramid levels.
    #[arg(long, default_value_t = 64)]
    pub max_levels: usize,
    /// Start the pyramid magnified (2 finds people ~64 px tall).
    #[arg(long, default_value_t = 1.0)]
    pub upsample: f64,
    /// Suppression: `group` (OpenCV groupRectangles, threshold 2, eps 0.2), `greedy` (IoU 0.5), `none`.
    #[arg(long, value_enum, default_value_t = NmsArg::Group)]
    pub nms: NmsArg,
    /// Feature-pyramid approximation: compute every N-th level exactly and approximate the levels
    /// in between from its 2x2-pixel micro-cells (1 = exact, OpenCV-equivalent; 14 ≈ one exact
    /// level per octave at step 1.05). Default: 14 for `mosaicd detect` (the daemon's default:
    /// measured faster than exact on every path at unchanged quality, docs/detection.md,
    /// "Defaults"), 1 for `mosaicd eval detection`.
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

impl DetectorArgs {
    /// `model` with `--mosaic-taps` and `--mosaic-tone` applied.
    pub fn model(&self, model: LinearModel) -> LinearModel {
        with_overrides(model, self.mosaic_taps, self.mosaic_tone)
    }

    /// The mosaic of a raw frame for `model` (its tone, `--wb-gains`).
    pub fn mosaic(&self, model: &LinearModel, frame: &RawFrame) -> anyhow::Result<Image<f32>> {
        MosaicPrep::for_model(model, self.wb_gains)
            .mosaic(frame)
            .context("--wb-gains")
    }

    /// To library options, with `--approx` and `--svm` defaulting to the daemon's defaults (what
    /// `mosaicd detect` runs).
    pub fn options(&self) -> anyhow::Result<DetectorOptions> {
        self.options_with(mosaicd::detect::DEFAULT_APPROX_LEVELS, SvmArg::Auto)
    }

    /// To library options, with `--approx` and `--svm` defaulting to `approx` and `svm` (the
    /// experiments' exact pyramid and f32 SVM, for `eval detection`).
    pub fn options_with(&self, approx: usize, svm: SvmArg) -> anyhow::Result<DetectorOptions> {
        let nms = match self.nms {
            NmsArg::Group => NmsMethod::Group {
                threshold: 2,
                eps: 0.2,
            },
            NmsArg::Greedy => NmsMethod::Greedy { iou: 0.5 },
            NmsArg::None => NmsMethod::None,
        };
        Ok(DetectorOptions {
            scale_step: self.scale_step,
            max_levels: self.max_levels,
            upsample: self.upsample,
            hit_threshold: self.threshold,
            nms,
            approx_levels: self.approx.unwrap_or(approx),
            svm: self.svm.unwrap_or(svm).into(),
        })
    }
}

/// Load a model by name: a built-in name (`mosaic-raw-srgb`, …), `opencv-default` or a path.
pub fn load_model(name: &str, domain_for_opencv: Domain) -> anyhow::Result<LinearModel> {
    Ok(mosaicd::detect::load_named(name, domain_for_opencv)?)
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
    /// The HOG input view.
    pub fn input(&self) -> HogInput<'_> {
        match self {
            Frame::Mosaic(m, _) => HogInput::Mosaic(m.view()),
            Frame::Grey(g) => HogInput::GreyU8(g.view()),
            Frame::Colour(c) => HogInput::Rgb8(c.view()),
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

/// Run `mosaicd detect`.
pub fn run(args: DetectArgs) -> anyhow::Result<()> {
    let model = args.det.model(load_model(&args.model, Domain::Grey)?);
    let frame = load_frame(&args.input, args.as_domain, &|f| args.det.mosaic(&model, f))?;
    let det = Detector::new(model, &args.det.options()?)?;
    let ours = Path::new(&args.model).extension().is_some_and(|e| e == "json");
    // An unasked-for transfer case (the user did not choose the domain with --as).
    if ours && args.as_domain.is_none() && det.model().domain != frame.domain() {
        let (md, fd) = (det.model().domain.name(), frame.domain().name());
        // Raw input is read as a mosaic only; an image can be read the model's way.
        let hint = match frame.cfa() {
            Some(_) => String::new(),
            None => format!("; `--as {md}` reads it the way the model expects"),
        };
        eprintln!(
            "warning: {} was trained on {md} input, but {} is read as {fd} (a transfer case{hint})",
            args.model,
            args.input.input.display()
        );
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    let (boxes, stats) = pool.install(|| det.detect(&frame.input()))?;
    if args.json {
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        let out = serde_json::json!({
            "input": args.input.input.display().to_string(),
            "domain": frame.domain(),
            "cfa": frame.cfa().map(|c| c.name()),
            "model": args.model,
            "model_domain": det.model().domain,
            "detections": boxes,
            "stats": {
                "levels": stats.levels, "windows": stats.windows, "hits": stats.hits,
                "total_ms": ms(stats.total), "resize_cpu_ms": ms(stats.resize), "gamma_cpu_ms": ms(stats.hog.gamma),
                "cells_cpu_ms": ms(stats.hog.cells), "blocks_cpu_ms": ms(stats.hog.blocks),
                "svm_cpu_ms": ms(stats.svm), "nms_ms": ms(stats.nms),
            }
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{}: {} detections ({} levels, {} windows, {} hits, {:.1} ms)",
            args.input.input.display(),
            boxes.len(),
            stats.levels,
            stats.windows,
            stats.hits,
            stats.total.as_secs_f64() * 1e3
        );
        for b in &boxes {
            println!(
                "  x {:6.0} y {:6.0} w {:5.0} h {:5.0} score {:.3}",
                b.x, b.y, b.width, b.height, b.score
            );
        }
    }
    if let Some(p) = &args.preview {
        let mut img = frame.preview();
        draw_boxes(&mut img, &boxes);
        save_png(&img, p)?;
    }
    Ok(())
}
