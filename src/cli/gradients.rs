//! `mosaicd gradients` (in progress).

/// Arguments of `mosaicd gradients`.
#[derive(clap::Args, Debug)]
pub struct GradientsArgs {}

/// Run `mosaicd gradients`.
pub fn run(_args: GradientsArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd gradients` is not built yet")
}
