//! The detection experiments of `mosaicd eval detection`, as reports: the Dalal–Triggs window
//! protocol on a held-out split ([`window_protocol`]) and full-image average precision on images
//! with ground-truth boxes ([`ap_protocol`]), each with an optional paired bootstrap.
//!
//! The command line parses and checks its flags, loads the models and calls one of these; the
//! tables, plots and detection files are made here.

use std::path::{Path, PathBuf};

use super::common::{fmt, Progress, Report, Table};
use super::detection::{
    ap_summary, det_plot, detect_images, detections_csv, external_detections, load_box_csv, load_usc,
    paired_bootstrap, parse_detections_csv, pr_plot, subsample, usc_root, ApSummary, DetEvalError, Interval,
    PerImageMatches, Result, Shrink,
};
use crate::detect::acf::AcfOptions;
use crate::detect::people::PeopleModel;
use crate::detect::train::acf::evaluate_acf_windows;
use crate::detect::train::{evaluate_windows_via, window_bootstrap, InputPipeline, Split, WindowEval};
use crate::detect::{DetectorOptions, Domain, ScorePrecision};
use crate::features::hog::MosaicTaps;
use crate::metrics::detection::{ImageDetections, PASCAL_IOU};
use crate::raw::levels::Gains;
use crate::raw::tone::MosaicTone;
use crate::raw::Cfa;

/// Pipeline column of detections read from a file.
const EXTERNAL: &str = "external";

/// One model to evaluate in one input domain.
#[derive(Debug, Clone)]
pub struct DetRun {
    /// The model as named (a HOG file or built-in name, `opencv-default`, or an ACF model file).
    pub name: String,
    /// The input domain it is run in.
    pub domain: Domain,
    /// The domain as written.
    pub domain_name: String,
}

impl DetRun {
    /// The model ([`PeopleModel::load`]: an ACF model file, else [`crate::detect::load_named`],
    /// OpenCV's weights read as `opencv_domain`) with the settings' tap and tone overrides applied.
    fn model(&self, opencv_domain: Domain, s: &DetEvalSettings) -> Result<PeopleModel> {
        use crate::detect::people::PeopleError;
        use crate::detect::NamedModelError;
        let model = PeopleModel::load(&self.name, opencv_domain).map_err(|e| match e {
            PeopleError::Named(NamedModelError::Model(m)) => DetEvalError::Model(m),
            PeopleError::Named(NamedModelError::DataMissing(d)) => DetEvalError::Data(d),
            e => DetEvalError::People(e),
        })?;
        Ok(model.with_overrides(s.mosaic_taps, s.mosaic_tone))
    }
}

/// What the two protocols share.
#[derive(Debug, Clone)]
pub struct DetEvalSettings {
    /// CFA used to make mosaics.
    pub cfa: Cfa,
    /// White-balance gains of mosaic inputs in the `srgb` tone.
    pub wb_gains: Gains,
    /// Seed of the split, the noise and the bootstrap.
    pub seed: u64,
    /// Paired-bootstrap resamples (0: none).
    pub bootstrap: usize,
    /// The bootstrap's reference row, counted from 0 in the table's order (checked by the caller).
    pub reference: usize,
    /// Directory of the plots (and, for AP, the detection files).
    pub out: PathBuf,
    /// No progress on stderr.
    pub quiet: bool,
    /// Overrides the models' mosaic derivative.
    pub mosaic_taps: Option<MosaicTaps>,
    /// Overrides the models' mosaic tone.
    pub mosaic_tone: Option<MosaicTone>,
}

/// The window protocol's own inputs.
#[derive(Debug, Clone)]
pub struct WindowProtocol {
    /// The held-out split (already truncated as wanted).
    pub split: Split,
    /// Which fold is held out (for the title).
    pub fold: usize,
    /// The detector's score precision.
    pub svm: ScorePrecision,
}

/// The window protocol: miss rate at 1e-2, 1e-3 and 1e-4 FPPW of every run on every input
/// pipeline (pipelines outer), DET plots per pipeline, and with `bootstrap > 0` a paired bootstrap
/// over held-out photos and negative images.
pub fn window_protocol(
    runs: &[DetRun],
    pipelines: &[InputPipeline],
    p: &WindowProtocol,
    s: &DetEvalSettings,
) -> Result<Report> {
    let split = &p.split;
    let mut table = Table::new(
        format!(
            "Window protocol (held-out split, seed {}{}, {} positives, {} negative images, svm {})",
            s.seed,
            if p.fold == 0 {
                String::new()
            } else {
                format!(" fold {}", p.fold)
            },
            split.val_pos.len(),
            split.val_neg.len(),
            p.svm
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
    for (k, (pipe, run)) in pipelines
        .iter()
        .flat_map(|p| runs.iter().map(move |r| (p, r)))
        .enumerate()
    {
        let model = run.model(Domain::Colour, s)?;
        let (m, d) = (&run.name, &run.domain_name);
        let label = format!("{m} on {d}");
        let quiet = s.quiet;
        let mut progress = |t: &str| {
            if !quiet {
                eprintln!("[{}/{total}] {label}, {}: {t}", k + 1, pipe.name())
            }
        };
        let ev = match &model {
            PeopleModel::Hog(model) => evaluate_windows_via(
                model,
                split,
                run.domain,
                s.cfa,
                pipe,
                p.svm,
                s.wb_gains,
                &mut progress,
            )?,
            // The ACF scan (stride 4 px, its own pyramid): FPPW per window of that scan.
            PeopleModel::Acf(model) => {
                evaluate_acf_windows(model, split, run.domain, s.cfa, pipe, s.wb_gains, &mut progress)?
            }
        };
        let mut row = vec![
            format!("{m} ({:?})", model.domain()),
            d.clone(),
            pipe.name(),
            ev.negative_windows.to_string(),
        ];
        row.extend(ev.miss_rate_at.iter().map(|(_, mr)| fmt(*mr, 3)));
        table.row(row);
        curves.push((label, *pipe, ev));
    }
    let mut tables = vec![table];
    if s.bootstrap > 0 && !curves.is_empty() {
        tables.push(window_bootstrap_table(&curves, s)?);
    }
    // One DET plot per input pipeline (a plot with every run is unreadable).
    let mut plots = Vec::new();
    for pipe in pipelines {
        let named: Vec<(String, &[_])> = curves
            .iter()
            .filter(|(_, p, _)| p == pipe)
            .map(|(n, _, e)| (n.clone(), e.det.as_slice()))
            .collect();
        let path = s.out.join(format!("det_{}.png", pipe.name()));
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
        notes: Vec::new(),
    })
}

fn interval(i: &Interval) -> String {
    format!("[{}, {}]", fmt(i.lo, 3), fmt(i.hi, 3))
}

/// The window protocol's paired-bootstrap table.
fn window_bootstrap_table(
    curves: &[(String, InputPipeline, WindowEval)],
    s: &DetEvalSettings,
) -> Result<Table> {
    const FPPW: [f64; 2] = [1e-3, 1e-4];
    let scores: Vec<_> = curves.iter().map(|(_, _, e)| &e.scores).collect();
    let b = window_bootstrap(&scores, s.reference, &FPPW, s.bootstrap, s.seed)?;
    let (rl, rp, _) = &curves[s.reference];
    let mut t = Table::new(
        format!(
            "Paired bootstrap over the {} held-out photos and {} negative images ({} resamples, \
             seed {}): 95 % intervals; Δ = row − {rl}, {}",
            scores[0].photos(),
            scores[0].windows_per_image.len(),
            s.bootstrap,
            s.seed,
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
            interval(&b.miss_rate[0]),
            interval(&b.diff[0]),
            interval(&b.miss_rate[1]),
            interval(&b.diff[1]),
            fmt(b.not_worse[1], 3),
        ]);
    }
    Ok(t)
}

/// Where the ground-truth images of [`ap_protocol`] come from.
#[derive(Debug, Clone)]
pub enum ApImages {
    /// USC Pedestrian Sets A, B, C under the shared data.
    Usc,
    /// The images of a box CSV, found under `images` (default: the CSV's directory).
    Boxes {
        /// The CSV.
        csv: PathBuf,
        /// Image directory.
        images: Option<PathBuf>,
    },
}

/// Full-image AP's own inputs.
#[derive(Debug, Clone)]
pub struct ApProtocol {
    /// The images.
    pub images: ApImages,
    /// Use every N-th image (sorted by set/name).
    pub every: usize,
    /// Then at most this many (0: all).
    pub limit: usize,
    /// The shrunk-box map of the "shrunk" columns.
    pub shrink: Shrink,
    /// HOG detector options (each phase sets its own `upsample`).
    pub opts: DetectorOptions,
    /// ACF detector options (each phase sets its own `upsample`).
    pub acf: AcfOptions,
    /// Pyramid phases as (text as given, upsample factor); one for a single run.
    pub phases: Vec<(String, f64)>,
    /// Detections of other detectors, (name, CSV file; `{upsample}` replaced by each phase's text).
    pub external: Vec<(String, String)>,
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

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> DetEvalError + '_ {
    move |source| DetEvalError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The number of rows of [`ap_protocol`]'s table for these inputs (for checking the reference).
pub fn ap_rows(runs: &[DetRun], pipelines: &[InputPipeline], p: &ApProtocol) -> usize {
    runs.len() * pipelines.len() + p.external.len()
}

/// Full-image AP (PASCAL, IoU ≥ 0.5) of every run on every input pipeline at every phase, and of
/// the external detections, with raw and shrunk boxes; precision/recall plots; every row's
/// detections written to `out/detections/` in the external format; with `bootstrap > 0` a paired
/// bootstrap over images.
pub fn ap_protocol(
    runs: &[DetRun],
    pipelines: &[InputPipeline],
    p: &ApProtocol,
    s: &DetEvalSettings,
) -> Result<Report> {
    let (all, what) = match &p.images {
        ApImages::Boxes { csv, images } => (load_box_csv(csv, images.as_deref())?, csv.display().to_string()),
        ApImages::Usc => {
            let root = usc_root()?;
            (load_usc(&root)?, "USC Sets A, B, C".to_string())
        }
    };
    let n_all = all.len();
    let images = subsample(all, p.every, p.limit)?;
    let n_boxes: usize = images.iter().map(|g| g.boxes.len()).sum();
    let opts = p.opts;
    let phases = &p.phases;
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
        p.every.max(1),
        if p.limit > 0 {
            format!(", limit {}", p.limit)
        } else {
            String::new()
        },
        opts.hit_threshold,
        opts.approx_levels,
        opts.svm
    );
    let rows = ap_detect(runs, pipelines, p, s, &images)?;
    // Every row's detections, per phase, in the external format.
    let dir = s.out.join("detections");
    std::fs::create_dir_all(&dir).map_err(io_err(&dir))?;
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
            let path = dir.join(format!("{name}{suffix}.csv"));
            std::fs::write(&path, detections_csv(&images, dets)).map_err(io_err(&path))?;
        }
    }
    let (table, curves) = ap_table(&rows, p, title)?;
    let mut tables = vec![table];
    if s.bootstrap > 0 && !rows.is_empty() {
        tables.push(ap_bootstrap_table(&rows, p, s, images.len())?);
    }
    let mut plots = Vec::new();
    for (suffix, shrunk) in [("raw", false), ("shrunk", true)] {
        let path = s.out.join(format!("pr_{suffix}.png"));
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
            &path,
        )?;
        plots.push(path);
    }
    let shrink = p.shrink;
    Ok(Report {
        name: "detection".into(),
        heading: "Pedestrian detection: full-image AP".into(),
        tables,
        plots,
        notes: vec![
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

/// The detections of every row at every phase: the runs (pipelines outer), then the external files.
fn ap_detect(
    runs: &[DetRun],
    pipelines: &[InputPipeline],
    p: &ApProtocol,
    s: &DetEvalSettings,
    images: &[super::detection::GtImage],
) -> Result<Vec<ApRow>> {
    let phases = &p.phases;
    let multi = phases.len() > 1;
    let mut rows: Vec<ApRow> = Vec::new();
    let total = runs.len() * pipelines.len() * phases.len();
    let mut k = 0;
    for pipe in pipelines {
        for run in runs {
            let model = run.model(Domain::Grey, s)?;
            let (m, d) = (&run.name, &run.domain_name);
            let name = format!("{m} ({:?})", model.domain());
            let mut per_phase = Vec::with_capacity(phases.len());
            for (text, u) in phases {
                k += 1;
                let mut o = p.opts;
                o.upsample = *u;
                let mut acf = p.acf;
                acf.upsample = *u;
                let det = model.clone().build(&o, &acf)?;
                let phase = if multi {
                    format!(" upsample {text}")
                } else {
                    String::new()
                };
                let progress = Progress::new(
                    &format!("[{k}/{total}] {m}={d} {}{phase}", pipe.name()),
                    images.len(),
                    !s.quiet,
                );
                let dets = detect_images(
                    &det,
                    images,
                    run.domain,
                    s.cfa,
                    pipe,
                    s.wb_gains,
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
    for (name, file) in &p.external {
        let mut per_phase = Vec::with_capacity(phases.len());
        for (text, _) in phases {
            let file = file.replace("{upsample}", text);
            let path = Path::new(&file);
            let text = std::fs::read_to_string(path).map_err(io_err(path))?;
            per_phase.push(external_detections(
                images,
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
    Ok(rows)
}

/// The AP table and each row's first-phase summaries (raw, shrunk) for the plots.
#[allow(clippy::type_complexity)]
fn ap_table(
    rows: &[ApRow],
    p: &ApProtocol,
    title: String,
) -> Result<(Table, Vec<(String, ApSummary, ApSummary)>)> {
    let multi = p.phases.len() > 1;
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
    for r in rows {
        let mut raw = Vec::new();
        let mut shr = Vec::new();
        for dets in &r.phases {
            raw.push(ap_summary(dets, None, PASCAL_IOU)?);
            shr.push(ap_summary(dets, Some(p.shrink), PASCAL_IOU)?);
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
    Ok((table, curves))
}

/// Full-image AP's paired-bootstrap table (shrunk boxes, means over the phases).
fn ap_bootstrap_table(rows: &[ApRow], p: &ApProtocol, s: &DetEvalSettings, n_images: usize) -> Result<Table> {
    let multi = p.phases.len() > 1;
    let matched = rows
        .iter()
        .map(|r| {
            r.phases
                .iter()
                .map(|d| PerImageMatches::new(d, Some(p.shrink), PASCAL_IOU))
                .collect::<Result<Vec<_>>>()
        })
        .collect::<Result<Vec<_>>>()?;
    let b = paired_bootstrap(&matched, s.reference, s.bootstrap, s.seed)?;
    let mut t = Table::new(
        format!(
            "Paired bootstrap over the {} images ({} resamples, seed {}; shrunk boxes{}): 95 % intervals; \
             Δ = row − {}",
            n_images,
            s.bootstrap,
            s.seed,
            if multi { ", means over the phases" } else { "" },
            rows[s.reference].label()
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
            interval(&b.ap),
            interval(&b.ap_diff),
            fmt(b.ap_not_worse, 3),
            interval(&b.lamr),
            interval(&b.lamr_diff),
        ]);
    }
    Ok(t)
}
