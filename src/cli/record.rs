//! `mosaicd record` (in progress).

/// Arguments of `mosaicd record`.
#[derive(clap::Args, Debug)]
pub struct RecordArgs {}

/// Run `mosaicd record`.
pub fn run(_args: RecordArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd record` is not built yet")
}
