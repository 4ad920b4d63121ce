//! `mosaicd detect`: pedestrian detection on one frame (raw mosaic, grey or colour image), with a
//! HOG or an ACF model (one code path: [`mosaicd::detect::people`]).

use std::path::{Path, PathBuf};

use super::detect_common::{
    json_report, load_frame, print_boxes, save_preview, text_summary, DetectorArgs, DomainArg,
};
use super::input::InputArgs;
use mosaicd::detect::DetectorKind;
use mosaicd::detect::Domain;

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
    /// file (.json ours, HOG or ACF (`mosaicd train --detector acf`, e.g. models/acf-mosaic.json;
    /// recognised by its format); .npy / .yml / text = OpenCV vectors) or `opencv-default`
    /// (OpenCV's people detector from $MOSAICD_DATA/opencv_hog).
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

/// Run `mosaicd detect`.
pub fn run(args: DetectArgs) -> anyhow::Result<()> {
    let model = args.det.model(&args.model, Domain::Grey)?;
    let frame = load_frame(&args.input, args.as_domain, &|f| args.det.mosaic(&model, f))?;
    let det = args.det.detector(model)?;
    // Our model files say which domain they were trained on (ACF models are always ours).
    let ours =
        det.kind() == DetectorKind::Acf || Path::new(&args.model).extension().is_some_and(|e| e == "json");
    // An unasked-for transfer case (the user did not choose the domain with --as).
    if ours && args.as_domain.is_none() && det.domain() != frame.domain() {
        let (md, fd) = (det.domain().name(), frame.domain().name());
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
    let input = &args.input.input;
    if args.json {
        let out = json_report(input, &frame, &args.model, &det, &boxes, &stats);
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!("{}", text_summary(input, boxes.len(), &stats));
        print_boxes(&boxes);
    }
    save_preview(&frame, &boxes, args.preview.as_deref())
}
