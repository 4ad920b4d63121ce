//! `mosaicd detect` (in progress).

/// Arguments of `mosaicd detect`.
#[derive(clap::Args, Debug)]
pub struct DetectArgs {}

/// Run `mosaicd detect`.
pub fn run(_args: DetectArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd detect` is not built yet")
}
