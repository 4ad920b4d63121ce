//! `mosaicd eval detection` (in progress).

/// Arguments of `mosaicd eval detection`.
#[derive(clap::Args, Debug)]
pub struct EvalDetectionArgs {}

/// Run `mosaicd eval detection`.
pub fn run(_args: EvalDetectionArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd eval detection` is not built yet")
}
