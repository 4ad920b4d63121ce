//! `mosaicd run` and `mosaicd replay` (in progress).

/// Arguments of `mosaicd run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {}

/// Arguments of `mosaicd replay`.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {}

/// Run `mosaicd run`.
pub fn run(_args: RunArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd run` is not built yet")
}

/// Run `mosaicd replay`.
pub fn replay(_args: ReplayArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd replay` is not built yet")
}
