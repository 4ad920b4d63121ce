//! `mosaicd sift` (in progress).

/// Arguments of `mosaicd sift`.
#[derive(clap::Args, Debug)]
pub struct SiftArgs {}

/// Run `mosaicd sift`.
pub fn run(_args: SiftArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd sift` is not built yet")
}
