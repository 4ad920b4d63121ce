//! `mosaicd train` (in progress).

/// Arguments of `mosaicd train`.
#[derive(clap::Args, Debug)]
pub struct TrainArgs {}

/// Run `mosaicd train`.
pub fn run(_args: TrainArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd train` is not built yet")
}
