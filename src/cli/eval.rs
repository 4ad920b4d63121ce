//! `mosaicd eval ...`: the paper's experiments, one subcommand each.

/// Arguments of `mosaicd eval`.
#[derive(clap::Args, Debug)]
pub struct EvalArgs {
    #[command(subcommand)]
    command: EvalCommand,
}

#[derive(clap::Subcommand, Debug)]
enum EvalCommand {
    #[command(flatten)]
    Isp(super::eval_isp::IspEval),
    /// Pedestrian detection: DET curves (miss rate vs FPPW) and full-image AP.
    Detection(Box<super::eval_detection::EvalDetectionArgs>),
    /// SIFT repeatability under blur, scale and rotation (paper Fig. 12).
    Sift(super::eval_sift::EvalSiftArgs),
}

/// Run `mosaicd eval`.
pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    match args.command {
        EvalCommand::Isp(c) => super::eval_isp::run(c),
        EvalCommand::Detection(a) => super::eval_detection::run(*a),
        EvalCommand::Sift(a) => super::eval_sift::run(a),
    }
}
