//! `mosaicd eval` subcommands for the conventional-path measurements (in progress).

/// The ISP / gradient-similarity experiments (paper Tables III–VI, Fig. 9, noise).
#[derive(clap::Subcommand, Debug)]
pub enum IspEval {
    /// Table III: gradient maps from the mosaic vs the grey image (in progress).
    Gradients,
}

/// Run one of the experiments.
pub fn run(_cmd: IspEval) -> anyhow::Result<()> {
    anyhow::bail!("this `mosaicd eval` experiment is not built yet")
}
