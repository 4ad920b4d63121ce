//! `mosaicd bench ...`: benchmarks that run the peer (OpenCV) in the same run and print the ratio.

/// Arguments of `mosaicd bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    command: BenchCommand,
}

#[derive(clap::Subcommand, Debug)]
enum BenchCommand {
    /// Raw mosaic → gradient magnitude + orientation vs OpenCV demosaic → grey → gradient.
    Gradients(super::bench_gradients::BenchGradientsArgs),
    /// Multi-scale pedestrian detection vs OpenCV's cvtColor + HOGDescriptor.detectMultiScale.
    Detect(super::bench_detect::BenchDetectArgs),
    /// Mosaic SIFT vs OpenCV demosaic + grey + SIFT detectAndCompute.
    Sift(super::bench_sift::BenchSiftArgs),
    /// Daemon replay throughput and capture→publish latency.
    Pipeline(super::bench_pipeline::BenchPipelineArgs),
}

/// Run `mosaicd bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    match args.command {
        BenchCommand::Gradients(a) => super::bench_gradients::run(a),
        BenchCommand::Detect(a) => super::bench_detect::run(a),
        BenchCommand::Sift(a) => super::bench_sift::run(a),
        BenchCommand::Pipeline(a) => super::bench_pipeline::run(a),
    }
}
