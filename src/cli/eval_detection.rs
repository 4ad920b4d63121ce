//! `mosaicd eval detection`: Dalal–Triggs window-level evaluation (miss rate at FPPW) of one or
//! more models in one or more input domains, on the held-out split `mosaicd train` used.

use mosaicd::detect::train::{evaluate_windows, split_data};
use mosaicd::detect::Domain;
use mosaicd::raw::Cfa;

use super::detect::{load_model, DomainArg};

/// Arguments of `mosaicd eval detection`.
#[derive(clap::Args, Debug)]
pub struct EvalDetectionArgs {
    /// Models to evaluate (files or `opencv-default`), each as MODEL=DOMAIN, e.g.
    /// `models/mosaic.json=mosaic opencv-default=colour models/colour.json=mosaic`.
    #[arg(required = true)]
    pub runs: Vec<String>,
    /// Split seed (must equal the training seed for a held-out evaluation).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Held-out fraction (as in training).
    #[arg(long, default_value_t = 0.2)]
    pub val_fraction: f64,
    /// Use at most this many validation negative images (0 = all).
    #[arg(long, default_value_t = 0)]
    pub max_neg_images: usize,
    /// CFA used to sample mosaics.
    #[arg(long, default_value = "RGGB")]
    pub cfa: Cfa,
    /// Threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

/// Run `mosaicd eval detection`.
pub fn run(a: EvalDetectionArgs) -> anyhow::Result<()> {
    let root = mosaicd::data::data_root();
    let mut split = split_data(&root, a.seed, a.val_fraction)?;
    if a.max_neg_images > 0 {
        split.val_neg.truncate(a.max_neg_images);
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?;
    println!("| model | input | positives | negative windows | MR@1e-2 | MR@1e-3 | MR@1e-4 |");
    println!("|---|---|---|---|---|---|---|");
    for r in &a.runs {
        let (m, d) = r
            .rsplit_once('=')
            .ok_or_else(|| anyhow::anyhow!("{r}: expected MODEL=DOMAIN"))?;
        let domain: Domain = <DomainArg as clap::ValueEnum>::from_str(d, true)
            .map_err(anyhow::Error::msg)?
            .into();
        let model = load_model(m, Domain::Colour)?;
        let ev = pool
            .install(|| evaluate_windows(&model, &split, domain, a.cfa, &mut |s: &str| eprintln!("{s}")))?;
        let mr: Vec<String> = ev.miss_rate_at.iter().map(|(_, m)| format!("{:.3}", m)).collect();
        println!(
            "| {m} ({:?}) | {d} | {} | {} | {} |",
            model.domain,
            ev.positives,
            ev.negative_windows,
            mr.join(" | ")
        );
    }
    Ok(())
}
