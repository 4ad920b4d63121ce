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

use std::path::PathBuf;

use mosaicd::detect::train::{split_data, InputPipeline, TrainError};
use mosaicd::detect::Domain;
use mosaicd::eval::Shrink;
use mosaicd::eval::{
    ap_protocol, ap_rows, window_protocol, ApImages, ApProtocol, DetEvalSettings, DetRun, WindowProtocol,
};
use mosaicd::raw::Cfa;

use super::detect_common::{DetectorArgs, DomainArg, SvmArg};

/// Arguments of `mosaicd eval detection`.
#[derive(clap::Args, Debug)]
pub struct EvalDetectionArgs {
    /// Models to evaluate (HOG or ACF files, built-in names or `opencv-default`), each as
    /// MODEL=DOMAIN, e.g. `models/mosaic.json=mosaic opencv-default=colour
    /// models/acf-mosaic.json=mosaic`. ACF models run with the ACF options of `mosaicd detect`
    /// (greedy suppression, their own pyramid) and, in the window protocol, their own scan.
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

fn parse_run(r: &str) -> anyhow::Result<DetRun> {
    let (m, d) = r
        .rsplit_once('=')
        .ok_or_else(|| anyhow::anyhow!("{r}: expected MODEL=DOMAIN (e.g. models/mosaic.json=mosaic)"))?;
    let domain: Domain = <DomainArg as clap::ValueEnum>::from_str(d, true)
        .map_err(|e| anyhow::anyhow!("{r}: {e}"))?
        .into();
    Ok(DetRun {
        name: m.to_string(),
        domain,
        domain_name: d.to_string(),
    })
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
    let settings = DetEvalSettings {
        cfa: a.cfa,
        wb_gains: a.det.wb_gains,
        seed: a.seed,
        bootstrap: a.bootstrap,
        reference: a.reference.saturating_sub(1),
        out: a.out.clone(),
        quiet: a.quiet,
        mosaic_taps: a.det.mosaic_taps,
        mosaic_tone: a.det.mosaic_tone,
    };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?;
    let mut report = if a.usc || a.boxes.is_some() {
        let p = ap_args(&a)?;
        check_reference(&a, ap_rows(&runs, &pipelines, &p))?;
        pool.install(|| ap_protocol(&runs, &pipelines, &p, &settings))?
    } else {
        let p = window_args(&a)?;
        check_reference(&a, runs.len() * pipelines.len())?;
        pool.install(|| window_protocol(&runs, &pipelines, &p, &settings))?
    };
    report.notes.insert(
        0,
        format!(
            "command: mosaicd {}",
            std::env::args().skip(1).collect::<Vec<_>>().join(" ")
        ),
    );
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

/// With `--bootstrap`, `--reference` names one of the table's `rows`.
fn check_reference(a: &EvalDetectionArgs, rows: usize) -> anyhow::Result<()> {
    if a.bootstrap > 0 && rows > 0 {
        anyhow::ensure!(
            (1..=rows).contains(&a.reference),
            "--reference {}: the table has rows 1..={}",
            a.reference,
            rows
        );
    }
    Ok(())
}

/// The window protocol's inputs: the held-out split of `--seed`, `--val-fraction` and `--fold`.
fn window_args(a: &EvalDetectionArgs) -> anyhow::Result<WindowProtocol> {
    anyhow::ensure!(
        a.val_fraction != 0.0,
        "--val-fraction 0 holds nothing out: there is nothing to evaluate"
    );
    let root = mosaicd::data::data_root()?;
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
    Ok(WindowProtocol {
        split,
        fold: a.fold,
        svm: a.det.svm.unwrap_or(SvmArg::F32).into(),
    })
}

/// Full-image AP's inputs: the images, `--shrink`, the detector options and `--upsample-phases`,
/// `--external`.
fn ap_args(a: &EvalDetectionArgs) -> anyhow::Result<ApProtocol> {
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
    let opts = a.det.options_with(1, SvmArg::F32)?;
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
    let external = a
        .external
        .iter()
        .map(|e| {
            e.split_once('=')
                .map(|(n, f)| (n.to_string(), f.to_string()))
                .ok_or_else(|| anyhow::anyhow!("--external {e}: expected NAME=CSV"))
        })
        .collect::<anyhow::Result<_>>()?;
    Ok(ApProtocol {
        images: match &a.boxes {
            Some(csv) => ApImages::Boxes {
                csv: csv.clone(),
                images: a.images.clone(),
            },
            None => ApImages::Usc,
        },
        every: a.every,
        limit: a.limit,
        shrink,
        opts,
        acf: a.det.acf_options(),
        phases,
        external,
    })
}
