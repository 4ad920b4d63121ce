//! `mosaicd bench pipeline` (in progress).

/// Arguments of `mosaicd bench pipeline`.
#[derive(clap::Args, Debug)]
pub struct BenchPipelineArgs {}

/// Run `mosaicd bench pipeline`.
pub fn run(_args: BenchPipelineArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd bench pipeline` is not built yet")
}
