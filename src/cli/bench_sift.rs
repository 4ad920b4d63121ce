//! `mosaicd bench sift` (in progress).

/// Arguments of `mosaicd bench sift`.
#[derive(clap::Args, Debug)]
pub struct BenchSiftArgs {}

/// Run `mosaicd bench sift`.
pub fn run(_args: BenchSiftArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd bench sift` is not built yet")
}
