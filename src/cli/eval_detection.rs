//! `mosaicd eval detection`: pedestrian detection quality of one or more models in one or more
//! input domains.
//!
//! - Default: the Dalal–Triggs window protocol (miss rate at FPPW, DET curves) on the held-out split
//!   `mosaicd train` used, for each input pipeline of `--inputs` (training-style sampling, or the
//!   reverse ISP clean and with the paper's three noise levels).
//! - `--usc` or `--boxes CSV`: full-image average precision (PASCAL, IoU ≥ 0.5) on images with
//!   ground-truth boxes, with raw and shrunk detections, plus detections of other detectors read
//!   from CSV files (`--external NAME=CSV`, e.g. OpenCV's own `detectMultiScale` written by
//!   `benches/opencv_detect_boxes.py`).
//!
//! Tables go to stdout (markdown), progress to stderr, PNG plots and `detection.md` to `--out`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use mosaicd::detect::train::{evaluate_windows_via, split_data, InputPipeline, WindowEval};
use mosaicd::detect::{Detector, Domain, ScorePrecision};
use mosaicd::eval::common::{fmt, Progress, Report, Table};
use mosaicd::eval::detection::{
    ap_summary, det_plot, detect_images, external_detections, load_box_csv, load_usc, parse_detections_csv,
    pr_plot, subsample, usc_root, ApSummary, Shrink,
};
use mosaicd::metrics::detection::{ImageDetections, PASCAL_IOU};
use mosaicd::raw::Cfa;

use super::detect::{load_model, DetectorArgs, DomainArg};

/// Pipeline column of detections read with `--external`.
const EXTERNAL: &str = "external";

/// Arguments of `mosaicd eval detection`.
#[derive(clap::Args, Debug)]
pub struct EvalDetectionArgs {
    /// Models to evaluate (files or `opencv-default`), each as MODEL=DOMAIN, e.g.
    /// `models/mosaic.json=mosaic opencv-default=colour models/colour.json=mosaic`.
    #[arg(required = true)]
    pub runs: Vec<String>,
    /// Input pipelines, comma-separated: `sampled` (sRGB sampled through the CFA / OpenCV grey /
    /// RGB, as the shipped models were trained), `clean` (reverse ISP to raw, no noise), `low`,
    /// `medium`, `high` (reverse ISP with the paper's eq. 24 noise; seeded by --seed). The mosaic
    /// domain reads the raw frame directly, colour and grey see it through the forward ISP.
    #[arg(long, value_delimiter = ',', default_value = "sampled")]
    pub inputs: Vec<String>,
    /// Split seed (must equal the training seed for a held-out evaluation); also seeds the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Held-out fraction (as in training).
    #[arg(long, default_value_t = 0.2)]
    pub val_fraction: f64,
    /// Use at most this many validation negative images (0 = all).
    #[arg(long, default_value_t = 0)]
    pub max_neg_images: usize,
    /// Use at most this many validation positives (0 = all).
    #[arg(long, default_value_t = 0)]
    pub max_pos: usize,
    /// CFA used to make mosaics.
    #[arg(long, default_value = "RGGB")]
    pub cfa: Cfa,
    /// Full-image AP on the USC Pedestrian Sets A, B, C ($MOSAICD_DATA/pedestrian/usc).
    #[arg(long, conflicts_with = "boxes")]
    pub usc: bool,
    /// Full-image AP on the images of a box CSV (header with image,x,y,w,h and optionally set; the
    /// image is DIR/set/image or DIR/image, DIR = --images or the CSV's directory).
    #[arg(long)]
    pub boxes: Option<PathBuf>,
    /// Image directory for --boxes.
    #[arg(long, requires = "boxes")]
    pub images: Option<PathBuf>,
    /// AP: use every N-th image (sorted by set/name).
    #[arg(long, default_value_t = 1)]
    pub every: usize,
    /// AP: then at most this many images (0 = all).
    #[arg(long, default_value_t = 0)]
    pub limit: usize,
    /// AP: the shrunk-box map x,y,w,h (fractions of the detection's size) applied to every
    /// detection in the "shrunk" columns; USC boxes are tight while windows have margins.
    #[arg(long, value_delimiter = ',', num_args = 4, default_value = "0.2,0.1,0.6,0.8")]
    pub shrink: Vec<f32>,
    /// AP: detections of another detector, NAME=CSV (columns image,x,y,w,h,score; image = set/name).
    #[arg(long)]
    pub external: Vec<String>,
    #[command(flatten)]
    pub det: DetectorArgs,
    /// Directory for the PNG plots and detection.md.
    #[arg(long, default_value = "out/eval-detection")]
    pub out: PathBuf,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// No progress on stderr.
    #[arg(long)]
    pub quiet: bool,
}

fn parse_run(r: &str) -> anyhow::Result<(String, Domain, String)> {
    let (m, d) = r
        .rsplit_once('=')
        .ok_or_else(|| anyhow::anyhow!("{r}: expected MODEL=DOMAIN (e.g. models/mosaic.json=mosaic)"))?;
    let domain: Domain = <DomainArg as clap::ValueEnum>::from_str(d, true)
        .map_err(|e| anyhow::anyhow!("{r}: {e}"))?
        .into();
    Ok((m.to_string(), domain, d.to_string()))
}

fn parse_pipeline(s: &str, seed: u64) -> anyhow::Result<InputPipeline> {
    InputPipeline::parse(s, seed).map_err(|e| anyhow::anyhow!("--inputs {e}"))
}

/// Run `mosaicd eval detection`.
pub fn run(a: EvalDetectionArgs) -> anyhow::Result<()> {
    let runs = a
        .runs
        .iter()
        .map(|r| parse_run(r))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let pipelines = a
        .inputs
        .iter()
        .map(|s| parse_pipeline(s, a.seed))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?;
    let report = if a.usc || a.boxes.is_some() {
        pool.install(|| run_ap(&a, &runs, &pipelines))?
    } else {
        pool.install(|| run_windows(&a, &runs, &pipelines))?
    };
    for t in &report.tables {
        println!("{}", t.to_markdown());
    }
    let md = report.write(&a.out)?;
    for p in &report.plots {
        eprintln!("plot: {}", p.display());
    }
    eprintln!("report: {}", md.display());
    Ok(())
}

fn run_windows(
    a: &EvalDetectionArgs,
    runs: &[(String, Domain, String)],
    pipelines: &[InputPipeline],
) -> anyhow::Result<Report> {
    let root = mosaicd::data::data_root();
    let mut split = split_data(&root, a.seed, a.val_fraction)
        .with_context(|| format!("set {} to the shared data directory", mosaicd::data::DATA_ENV))?;
    if a.max_neg_images > 0 {
        split.val_neg.truncate(a.max_neg_images);
    }
    if a.max_pos > 0 {
        split.val_pos.truncate(a.max_pos);
    }
    let mut table = Table::new(
        format!(
            "Window protocol (held-out split, seed {}, {} positives, {} negative images, svm {})",
            a.seed,
            split.val_pos.len(),
            split.val_neg.len(),
            ScorePrecision::from(a.det.svm)
        ),
        &[
            "model (trained on)",
            "input",
            "pipeline",
            "negative windows",
            "MR@1e-2",
            "MR@1e-3",
            "MR@1e-4",
        ],
    );
    let mut curves: Vec<(String, InputPipeline, WindowEval)> = Vec::new();
    let total = runs.len() * pipelines.len();
    for (k, (pipe, (m, domain, d))) in pipelines
        .iter()
        .flat_map(|p| runs.iter().map(move |r| (p, r)))
        .enumerate()
    {
        let model = load_model(m, Domain::Colour)?;
        let label = format!("{m} on {d}");
        let quiet = a.quiet;
        let mut progress = |s: &str| {
            if !quiet {
                eprintln!("[{}/{total}] {label}, {}: {s}", k + 1, pipe.name())
            }
        };
        let ev = evaluate_windows_via(
            &model,
            &split,
            *domain,
            a.cfa,
            pipe,
            a.det.svm.into(),
            &mut progress,
        )?;
        let mut row = vec![
            format!("{m} ({:?})", model.domain),
            d.clone(),
            pipe.name(),
            ev.negative_windows.to_string(),
        ];
        row.extend(ev.miss_rate_at.iter().map(|(_, mr)| fmt(*mr, 3)));
        table.row(row);
        curves.push((label, *pipe, ev));
    }
    // One DET plot per input pipeline (a plot with every run is unreadable).
    let mut plots = Vec::new();
    for pipe in pipelines {
        let named: Vec<(String, &[_])> = curves
            .iter()
            .filter(|(_, p, _)| p == pipe)
            .map(|(n, _, e)| (n.clone(), e.det.as_slice()))
            .collect();
        let path = a.out.join(format!("det_{}.png", pipe.name()));
        det_plot(
            &format!("DET, held-out windows, {} inputs", pipe.name()),
            &named,
            &path,
        )?;
        plots.push(path);
    }
    Ok(Report {
        name: "detection".into(),
        heading: "Pedestrian detection: window protocol".into(),
        tables: vec![table],
        plots,
        notes: vec![format!(
            "command: mosaicd {}",
            std::env::args().skip(1).collect::<Vec<_>>().join(" ")
        )],
    })
}

fn run_ap(
    a: &EvalDetectionArgs,
    runs: &[(String, Domain, String)],
    pipelines: &[InputPipeline],
) -> anyhow::Result<Report> {
    let (all, what) = match &a.boxes {
        Some(csv) => (load_box_csv(csv, a.images.as_deref())?, csv.display().to_string()),
        None => {
            let root = usc_root()?;
            (load_usc(&root)?, "USC Sets A, B, C".to_string())
        }
    };
    let n_all = all.len();
    let images = subsample(all, a.every, a.limit)?;
    let n_boxes: usize = images.iter().map(|g| g.boxes.len()).sum();
    let shrink = Shrink {
        x: a.shrink[0],
        y: a.shrink[1],
        width: a.shrink[2],
        height: a.shrink[3],
    };
    let opts = a.det.options()?;
    let mut table =
        Table::new(
            format!(
            "Full-image AP, {what}: {} of {n_all} images (every {}{}), {n_boxes} boxes, IoU ≥ {PASCAL_IOU}, \
             upsample {}, hit threshold {}, approx {}, svm {}",
            images.len(),
            a.every.max(1),
            if a.limit > 0 { format!(", limit {}", a.limit) } else { String::new() },
            opts.upsample,
            opts.hit_threshold,
            opts.approx_levels,
            opts.svm
        ),
            &[
                "detector",
                "input",
                "pipeline",
                "detections",
                "AP (raw boxes)",
                "recall (raw)",
                "AP (shrunk)",
                "recall (shrunk)",
            ],
        );
    let mut results: Vec<(String, ApSummary, ApSummary)> = Vec::new();
    let mut add = |name: String, d: &str, pipe: &str, dets: &[ImageDetections]| -> anyhow::Result<()> {
        let raw = ap_summary(dets, None, PASCAL_IOU)?;
        let shr = ap_summary(dets, Some(shrink), PASCAL_IOU)?;
        table.row(vec![
            name.clone(),
            d.to_string(),
            pipe.to_string(),
            raw.detections.to_string(),
            fmt(raw.ap, 3),
            fmt(raw.recall, 3),
            fmt(shr.ap, 3),
            fmt(shr.recall, 3),
        ]);
        let label = if pipe == EXTERNAL {
            name
        } else {
            format!("{name} on {d}, {pipe}")
        };
        results.push((label, raw, shr));
        Ok(())
    };
    let total = runs.len() * pipelines.len();
    for (k, (pipe, (m, domain, d))) in pipelines
        .iter()
        .flat_map(|p| runs.iter().map(move |r| (p, r)))
        .enumerate()
    {
        let model = load_model(m, Domain::Grey)?;
        let name = format!("{m} ({:?})", model.domain);
        let det = Detector::new(model, &opts)?;
        let progress = Progress::new(
            &format!("[{}/{total}] {m}={d} {}", k + 1, pipe.name()),
            images.len(),
            !a.quiet,
        );
        let dets = detect_images(&det, &images, *domain, a.cfa, pipe, &mut |i, key| {
            progress.step(i, key)
        })?;
        progress.done();
        add(name, d, &pipe.name(), &dets)?;
    }
    for e in &a.external {
        let (name, file) = e
            .split_once('=')
            .ok_or_else(|| anyhow::anyhow!("--external {e}: expected NAME=CSV"))?;
        let path = Path::new(file);
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let dets = external_detections(&images, &parse_detections_csv(&text, path)?, path)?;
        add(name.to_string(), "(its own)", EXTERNAL, &dets)?;
    }
    let mut plots = Vec::new();
    for (suffix, shrunk) in [("raw", false), ("shrunk", true)] {
        let p = a.out.join(format!("pr_{suffix}.png"));
        let curves: Vec<(String, &ApSummary)> = results
            .iter()
            .map(|(n, r, s)| (n.clone(), if shrunk { s } else { r }))
            .collect();
        pr_plot(&format!("Precision/recall, {suffix} detections"), &curves, &p)?;
        plots.push(p);
    }
    Ok(Report {
        name: "detection".into(),
        heading: "Pedestrian detection: full-image AP".into(),
        tables: vec![table],
        plots,
        notes: vec![
            format!(
                "command: mosaicd {}",
                std::env::args().skip(1).collect::<Vec<_>>().join(" ")
            ),
            format!(
                "shrunk: every detection (x, y, w, h) → (x + {}w, y + {}h, {}w, {}h) before matching",
                shrink.x, shrink.y, shrink.width, shrink.height
            ),
        ],
    })
}
