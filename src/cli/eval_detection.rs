//! `mosaicd eval detection`: pedestrian detection quality of one or more models in one or more
//! input domains.
//!
//! - Default: the Dalal–Triggs window protocol (miss rate at FPPW, DET curves) on the held-out split
//!   `mosaicd train` used, for each input pipeline of `--inputs` (training-style sampling, or the
//!   reverse ISP clean and with the paper's three noise levels); `--bootstrap N` adds a paired
//!   bootstrap over held-out photos and negative images.
//! - `--usc` or `--boxes CSV`: full-image average precision (PASCAL, IoU ≥ 0.5) on images with
//!   ground-truth boxes, with raw and shrunk detections, plus detections of other detectors read
//!   from CSV files (`--external NAME=CSV`, e.g. OpenCV's own `detectMultiScale` written by
//!   `benches/opencv_detect_boxes.py`).
//!
//! Tables go to stdout (markdown), progress to stderr, PNG plots and `detection.md` to `--out`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use mosaicd::detect::train::{
    evaluate_windows_via, split_data, window_bootstrap, InputPipeline, TrainError, WindowEval,
};
use mosaicd::detect::{Detector, Domain, ScorePrecision};
use mosaicd::eval::common::{fmt, Progress, Report, Table};
use mosaicd::eval::detection::{
    ap_summary, det_plot, detect_images, detections_csv, external_detections, load_box_csv, load_usc,
    paired_bootstrap, parse_detections_csv, pr_plot, subsample, usc_root, ApSummary, Interval,
    PerImageMatches, Shrink,
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
    /// Which block of the seeded shuffle is held out (as in training): 0 is the split the shipped models
    /// use; folds 0 .. 1/val-fraction are disjoint (0–4 at 0.2: a 5-fold cross-validation,
    /// `scripts/detection_cv.sh`).
    #[arg(long, default_value_t = 0)]
    pub fold: usize,
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
    #[arg(long, value_delimiter = ',', default_value = "0.2,0.1,0.6,0.8")]
    pub shrink: Vec<f32>,
    /// AP: detections of another detector, NAME=CSV (columns image,x,y,w,h,score; image = set/name).
    /// With --upsample-phases, `{upsample}` in CSV is replaced by each factor as written there
    /// (one file per phase, e.g. from `benches/opencv_detect_boxes.py --upsample U`).
    #[arg(long)]
    pub external: Vec<String>,
    /// AP: run every detector at each of these upsample factors (pyramid phases, e.g.
    /// `1.95,1.975,1.99,2.0,2.01,2.025,2.05`) and report the mean over them, with the range of AP;
    /// replaces --upsample. One factor alone can move AP by several points.
    #[arg(long, value_delimiter = ',')]
    pub upsample_phases: Vec<String>,
    /// Paired bootstrap with this many resamples (0 = off; e.g. 1000), seeded by --seed. AP: over
    /// images; 95 % intervals of each row's AP and log-average miss rate and of their differences
    /// from the --reference row, and how often the row's AP is at least the reference's. Window
    /// protocol: over held-out photos (a crop with its mirror) and negative images; 95 % intervals
    /// of each row's miss rate at 1e-3 and 1e-4 FPPW and of its difference from the reference
    /// row's, and how often the row misses no more than the reference.
    #[arg(long, default_value_t = 0)]
    pub bootstrap: usize,
    /// The bootstrap's reference row, counted from 1 in the table's order (AP: detectors, then
    /// --external files, e.g. an --external OpenCV run; window protocol: the models in the order
    /// given, for each input pipeline in turn).
    #[arg(long, default_value_t = 1)]
    pub reference: usize,
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
    anyhow::ensure!(
        a.val_fraction != 0.0,
        "--val-fraction 0 holds nothing out: there is nothing to evaluate"
    );
    let root = mosaicd::data::data_root();
    let mut split = split_data(&root, a.seed, a.val_fraction, a.fold).map_err(|e| match e {
        // Only missing or unreadable data needs the hint; a bad --fold or --val-fraction says so.
        TrainError::Data { .. } => anyhow::Error::new(e).context(format!(
            "set {} to the shared data directory",
            mosaicd::data::DATA_ENV
        )),
        e => anyhow::Error::new(e),
    })?;
    if a.max_neg_images > 0 {
        split.val_neg.truncate(a.max_neg_images);
    }
    if a.max_pos > 0 {
        split.val_pos.truncate(a.max_pos);
    }
    let mut table = Table::new(
        format!(
            "Window protocol (held-out split, seed {}{}, {} positives, {} negative images, svm {})",
            a.seed,
            if a.fold == 0 {
                String::new()
            } else {
                format!(" fold {}", a.fold)
            },
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
        let model = a.det.model(load_model(m, Domain::Colour)?);
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
            a.det.wb_gains,
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
    let mut tables = vec![table];
    if a.bootstrap > 0 && !curves.is_empty() {
        anyhow::ensure!(
            (1..=curves.len()).contains(&a.reference),
            "--reference {}: the table has rows 1..={}",
            a.reference,
            curves.len()
        );
        const FPPW: [f64; 2] = [1e-3, 1e-4];
        let scores: Vec<_> = curves.iter().map(|(_, _, e)| &e.scores).collect();
        let b = window_bootstrap(&scores, a.reference - 1, &FPPW, a.bootstrap, a.seed)?;
        let iv = |i: Interval| format!("[{}, {}]", fmt(i.lo, 3), fmt(i.hi, 3));
        let (rl, rp, _) = &curves[a.reference - 1];
        let mut t = Table::new(
            format!(
                "Paired bootstrap over the {} held-out photos and {} negative images ({} resamples, \
                 seed {}): 95 % intervals; Δ = row − {rl}, {}",
                scores[0].photos(),
                scores[0].windows_per_image.len(),
                a.bootstrap,
                a.seed,
                rp.name()
            ),
            &[
                "model on input",
                "pipeline",
                "MR@1e-3",
                "Δ MR@1e-3",
                "MR@1e-4",
                "Δ MR@1e-4",
                "share of resamples with Δ MR@1e-4 ≤ 0",
            ],
        );
        for ((label, pipe, _), b) in curves.iter().zip(&b) {
            t.row(vec![
                label.clone(),
                pipe.name(),
                iv(b.miss_rate[0]),
                iv(b.diff[0]),
                iv(b.miss_rate[1]),
                iv(b.diff[1]),
                fmt(b.not_worse[1], 3),
            ]);
        }
        tables.push(t);
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
        tables,
        plots,
        notes: vec![format!(
            "command: mosaicd {}",
            std::env::args().skip(1).collect::<Vec<_>>().join(" ")
        )],
    })
}

/// One row of the AP table: a detector on one input at every phase.
struct ApRow {
    name: String,
    input: String,
    pipeline: String,
    /// Detections per phase.
    phases: Vec<Vec<ImageDetections>>,
}

impl ApRow {
    fn label(&self) -> String {
        if self.pipeline == EXTERNAL {
            self.name.clone()
        } else {
            format!("{} on {}, {}", self.name, self.input, self.pipeline)
        }
    }
}

/// A file-name-safe form of a row label.
fn slug(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if c.is_ascii_alphanumeric() || c == '.' || c == '-' {
            out.push(c);
        } else if !out.ends_with('_') {
            out.push('_');
        }
    }
    out.trim_matches('_').to_string()
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
    anyhow::ensure!(
        a.shrink.len() == 4 && a.shrink.iter().all(|v| v.is_finite()),
        "--shrink takes four numbers x,y,w,h (fractions of a detection's size), got {:?}",
        a.shrink
    );
    let shrink = Shrink {
        x: a.shrink[0],
        y: a.shrink[1],
        width: a.shrink[2],
        height: a.shrink[3],
    };
    let opts = a.det.options()?;
    // Phases: (text as given, factor).
    let phases: Vec<(String, f64)> = if a.upsample_phases.is_empty() {
        vec![(opts.upsample.to_string(), opts.upsample)]
    } else {
        a.upsample_phases
            .iter()
            .map(|t| {
                let u: f64 = t
                    .trim()
                    .parse()
                    .map_err(|_| anyhow::anyhow!("--upsample-phases {t}: not a number"))?;
                anyhow::ensure!(
                    u.is_finite() && u > 0.0,
                    "--upsample-phases {t}: must be a positive factor"
                );
                Ok((t.trim().to_string(), u))
            })
            .collect::<anyhow::Result<_>>()?
    };
    let multi = phases.len() > 1;
    let upsample_text = if multi {
        format!(
            "upsample {} phases ({})",
            phases.len(),
            phases.iter().map(|p| p.0.as_str()).collect::<Vec<_>>().join(", ")
        )
    } else {
        format!("upsample {}", opts.upsample)
    };
    let title = format!(
        "Full-image AP, {what}: {} of {n_all} images (every {}{}), {n_boxes} boxes, IoU ≥ {PASCAL_IOU}, \
         {upsample_text}, hit threshold {}, approx {}, svm {}",
        images.len(),
        a.every.max(1),
        if a.limit > 0 {
            format!(", limit {}", a.limit)
        } else {
            String::new()
        },
        opts.hit_threshold,
        opts.approx_levels,
        opts.svm
    );
    let mut rows: Vec<ApRow> = Vec::new();
    let total = runs.len() * pipelines.len() * phases.len();
    let mut k = 0;
    for pipe in pipelines {
        for (m, domain, d) in runs {
            let model = a.det.model(load_model(m, Domain::Grey)?);
            let name = format!("{m} ({:?})", model.domain);
            let mut per_phase = Vec::with_capacity(phases.len());
            for (text, u) in &phases {
                k += 1;
                let mut o = opts;
                o.upsample = *u;
                let det = Detector::new(model.clone(), &o)?;
                let phase = if multi {
                    format!(" upsample {text}")
                } else {
                    String::new()
                };
                let progress = Progress::new(
                    &format!("[{k}/{total}] {m}={d} {}{phase}", pipe.name()),
                    images.len(),
                    !a.quiet,
                );
                let dets = detect_images(
                    &det,
                    &images,
                    *domain,
                    a.cfa,
                    pipe,
                    a.det.wb_gains,
                    &mut |i, key| progress.step(i, key),
                )?;
                progress.done();
                per_phase.push(dets);
            }
            rows.push(ApRow {
                name,
                input: d.clone(),
                pipeline: pipe.name(),
                phases: per_phase,
            });
        }
    }
    for e in &a.external {
        let (name, file) = e
            .split_once('=')
            .ok_or_else(|| anyhow::anyhow!("--external {e}: expected NAME=CSV"))?;
        let mut per_phase = Vec::with_capacity(phases.len());
        for (text, _) in &phases {
            let file = file.replace("{upsample}", text);
            let path = Path::new(&file);
            let text =
                std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
            per_phase.push(external_detections(
                &images,
                &parse_detections_csv(&text, path)?,
                path,
            )?);
        }
        rows.push(ApRow {
            name: name.to_string(),
            input: "(its own)".into(),
            pipeline: EXTERNAL.into(),
            phases: per_phase,
        });
    }
    // Every row's detections, per phase, in the --external format.
    let dir = a.out.join("detections");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut used = std::collections::HashSet::new();
    for r in &rows {
        // A row listed twice gets `_2`, `_3`, … rather than overwriting the first one's files.
        let mut name = slug(&r.label());
        let mut k = 1;
        while !used.insert(name.clone()) {
            k += 1;
            name = format!("{}_{k}", slug(&r.label()));
        }
        for ((text, _), dets) in phases.iter().zip(&r.phases) {
            let suffix = if multi { format!("_u{text}") } else { String::new() };
            let p = dir.join(format!("{name}{suffix}.csv"));
            std::fs::write(&p, detections_csv(&images, dets))
                .with_context(|| format!("writing {}", p.display()))?;
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let mut headers = vec![
        "detector",
        "input",
        "pipeline",
        "detections",
        "AP (raw boxes)",
        "recall (raw)",
        "AP (shrunk)",
    ];
    if multi {
        headers.push("AP (shrunk) min–max");
    }
    headers.extend(["recall (shrunk)", "LAMR (shrunk)"]);
    let mut table = Table::new(title, &headers);
    let mut curves: Vec<(String, ApSummary, ApSummary)> = Vec::new();
    for r in &rows {
        let mut raw = Vec::new();
        let mut shr = Vec::new();
        for dets in &r.phases {
            raw.push(ap_summary(dets, None, PASCAL_IOU)?);
            shr.push(ap_summary(dets, Some(shrink), PASCAL_IOU)?);
        }
        let ap_s: Vec<f64> = shr.iter().map(|s| s.ap).collect();
        let dets_mean = mean(&raw.iter().map(|s| s.detections as f64).collect::<Vec<_>>());
        let mut row = vec![
            r.name.clone(),
            r.input.clone(),
            r.pipeline.clone(),
            if multi {
                fmt(dets_mean, 1)
            } else {
                raw[0].detections.to_string()
            },
            fmt(mean(&raw.iter().map(|s| s.ap).collect::<Vec<_>>()), 3),
            fmt(mean(&raw.iter().map(|s| s.recall).collect::<Vec<_>>()), 3),
            fmt(mean(&ap_s), 3),
        ];
        if multi {
            let lo = ap_s.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ap_s.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            row.push(format!("{}–{}", fmt(lo, 3), fmt(hi, 3)));
        }
        row.push(fmt(mean(&shr.iter().map(|s| s.recall).collect::<Vec<_>>()), 3));
        row.push(fmt(mean(&shr.iter().map(|s| s.lamr).collect::<Vec<_>>()), 3));
        table.row(row);
        curves.push((r.label(), raw.swap_remove(0), shr.swap_remove(0)));
    }
    let mut tables = vec![table];
    if a.bootstrap > 0 && !rows.is_empty() {
        let matched = rows
            .iter()
            .map(|r| {
                r.phases
                    .iter()
                    .map(|d| PerImageMatches::new(d, Some(shrink), PASCAL_IOU))
                    .collect::<Result<Vec<_>, _>>()
            })
            .collect::<Result<Vec<_>, _>>()?;
        anyhow::ensure!(
            (1..=rows.len()).contains(&a.reference),
            "--reference {}: the table has rows 1..={}",
            a.reference,
            rows.len()
        );
        let b = paired_bootstrap(&matched, a.reference - 1, a.bootstrap, a.seed)?;
        let iv = |i: &Interval| format!("[{}, {}]", fmt(i.lo, 3), fmt(i.hi, 3));
        let mut t = Table::new(
            format!(
                "Paired bootstrap over the {} images ({} resamples, seed {}; shrunk boxes{}): 95 % intervals; \
                 Δ = row − {}",
                images.len(),
                a.bootstrap,
                a.seed,
                if multi { ", means over the phases" } else { "" },
                rows[a.reference - 1].label()
            ),
            &[
                "detector",
                "input",
                "pipeline",
                "AP (shrunk)",
                "Δ AP",
                "share of resamples with Δ AP ≥ 0",
                "LAMR (shrunk)",
                "Δ LAMR",
            ],
        );
        for (r, b) in rows.iter().zip(&b) {
            t.row(vec![
                r.name.clone(),
                r.input.clone(),
                r.pipeline.clone(),
                iv(&b.ap),
                iv(&b.ap_diff),
                fmt(b.ap_not_worse, 3),
                iv(&b.lamr),
                iv(&b.lamr_diff),
            ]);
        }
        tables.push(t);
    }
    let mut plots = Vec::new();
    for (suffix, shrunk) in [("raw", false), ("shrunk", true)] {
        let p = a.out.join(format!("pr_{suffix}.png"));
        let named: Vec<(String, &ApSummary)> = curves
            .iter()
            .map(|(n, r, s)| (n.clone(), if shrunk { s } else { r }))
            .collect();
        let which = if multi {
            format!(", upsample {}", phases[0].0)
        } else {
            String::new()
        };
        pr_plot(
            &format!("Precision/recall, {suffix} detections{which}"),
            &named,
            &p,
        )?;
        plots.push(p);
    }
    Ok(Report {
        name: "detection".into(),
        heading: "Pedestrian detection: full-image AP".into(),
        tables,
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
            "LAMR: log-average miss rate over FPPI 10^-2 … 10^0 (Dollár et al.), shrunk boxes".into(),
            format!(
                "detections of every row: {} (the --external format)",
                dir.display()
            ),
        ],
    })
}
