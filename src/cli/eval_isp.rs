//! `mosaicd eval <experiment>`: the conventional-path measurements of the paper (Tables III–VI,
//! Fig. 9, noise). Each prints a table with the paper's number beside ours, writes PNG plots and a
//! markdown section into `--out`, and takes `--limit N` to run on the first N images only.

use mosaicd::eval::{EvalOptions, Report};
use std::path::PathBuf;

/// Options shared by the experiments.
#[derive(clap::Args, Debug, Clone)]
pub struct ExperimentArgs {
    /// Use at most N Kodak images (default: all 24).
    #[arg(long, value_name = "N")]
    pub limit: Option<usize>,
    /// Use at most N real raw frames (default: the value of --limit, else all).
    #[arg(long, value_name = "N")]
    pub raw_limit: Option<usize>,
    /// Output directory for plots and the markdown report.
    #[arg(long, default_value = "out/eval")]
    pub out: PathBuf,
    /// No progress on stderr.
    #[arg(long)]
    pub quiet: bool,
}

impl ExperimentArgs {
    fn options(&self) -> EvalOptions {
        EvalOptions {
            limit: self.limit,
            raw_limit: self.raw_limit.or(self.limit),
            out: self.out.clone(),
            progress: !self.quiet,
        }
    }
}

/// Options of `mosaicd eval all`.
#[derive(clap::Args, Debug, Clone)]
pub struct AllArgs {
    /// Options passed to every experiment.
    #[command(flatten)]
    pub common: ExperimentArgs,
    /// Also write the combined report to this markdown file (e.g. docs/REPRODUCTION.md).
    #[arg(long, value_name = "FILE")]
    pub write_doc: Option<PathBuf>,
}

/// The ISP / gradient-similarity experiments (paper Tables III–VI, Fig. 9, noise).
#[derive(clap::Subcommand, Debug)]
pub enum IspEval {
    /// Table III: gradient maps from the mosaic vs from the grey image (Kodak, real raw frames).
    Gradients(ExperimentArgs),
    /// Fig. 9: GMSD of the mosaic gradient vs grey / R / G / B / colour-max gradients.
    Channels(ExperimentArgs),
    /// Table IV: each demosaicing method vs true colour (Kodak).
    Demosaic(ExperimentArgs),
    /// Table V / Fig. 13: super-pixel blur and resize vs colour blur and resize.
    ScaleSpace(ExperimentArgs),
    /// Table VI: time and memory of pipeline 1 (mosaic) vs pipeline 2 (demosaic first).
    Pipeline(ExperimentArgs),
    /// Gradient and HOG-input degradation under the paper's three noise levels.
    Noise(ExperimentArgs),
    /// Every experiment above, one after the other; optionally writes docs/REPRODUCTION.md.
    All(AllArgs),
}

fn print_and_write(r: &Report, out: &std::path::Path) -> anyhow::Result<()> {
    print!("{}", r.to_text());
    let p = r.write(out)?;
    println!("report: {}", p.display());
    Ok(())
}

/// Run one of the experiments.
pub fn run(cmd: IspEval) -> anyhow::Result<()> {
    use mosaicd::eval::{
        run_channels, run_demosaic, run_gradients, run_noise, run_pipeline, run_scale_space,
    };
    type Runner = fn(&EvalOptions) -> mosaicd::eval::Result<Report>;
    let all: [Runner; 6] = [
        run_gradients,
        run_demosaic,
        run_scale_space,
        run_pipeline,
        run_channels,
        run_noise,
    ];
    match cmd {
        IspEval::Gradients(a) => print_and_write(&run_gradients(&a.options())?, &a.out),
        IspEval::Channels(a) => print_and_write(&run_channels(&a.options())?, &a.out),
        IspEval::Demosaic(a) => print_and_write(&run_demosaic(&a.options())?, &a.out),
        IspEval::ScaleSpace(a) => print_and_write(&run_scale_space(&a.options())?, &a.out),
        IspEval::Pipeline(a) => print_and_write(&run_pipeline(&a.options())?, &a.out),
        IspEval::Noise(a) => print_and_write(&run_noise(&a.options())?, &a.out),
        IspEval::All(a) => {
            let opts = a.common.options();
            let mut reports = Vec::new();
            for f in all {
                let r = f(&opts)?;
                print_and_write(&r, &opts.out)?;
                reports.push(r);
            }
            if let Some(doc) = a.write_doc {
                let text = mosaicd::eval::reproduction_doc(&reports, &opts);
                if let Some(dir) = doc.parent().filter(|d| !d.as_os_str().is_empty()) {
                    std::fs::create_dir_all(dir)?;
                }
                std::fs::write(&doc, text)?;
                println!("wrote {}", doc.display());
            }
            Ok(())
        }
    }
}
