//! `mosaicd bench detect` (in progress).

/// Arguments of `mosaicd bench detect`.
#[derive(clap::Args, Debug)]
pub struct BenchDetectArgs {}

/// Run `mosaicd bench detect`.
pub fn run(_args: BenchDetectArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd bench detect` is not built yet")
}
