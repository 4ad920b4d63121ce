//! `mosaicd eval sift` (in progress).

/// Arguments of `mosaicd eval sift`.
#[derive(clap::Args, Debug)]
pub struct EvalSiftArgs {}

/// Run `mosaicd eval sift`.
pub fn run(_args: EvalSiftArgs) -> anyhow::Result<()> {
    anyhow::bail!("`mosaicd eval sift` is not built yet")
}
