//! `mosaicd bench gradients` (in progress).

/// Arguments of `mosaicd bench gradients`.
#[derive(clap::Args, Debug)]
pub struct BenchGradientsArgs {}

/// Run `mosaicd bench gradients`.
pub fn run(_args: BenchGradientsArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd bench gradients` is not built yet")
}
