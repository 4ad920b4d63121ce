//! `mosaicd listen` (in progress).

/// Arguments of `mosaicd listen`.
#[derive(clap::Args, Debug)]
pub struct ListenArgs {}

/// Run `mosaicd listen`.
pub fn run(_args: ListenArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd listen` is not built yet")
}
