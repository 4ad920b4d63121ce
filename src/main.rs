//! `mosaicd`: a thin CLI over the library. Every subcommand lives in `src/cli/<name>.rs`.

mod cli;

use clap::{Parser, Subcommand};

/// Gradient features and pedestrian detections straight from raw Bayer frames, no ISP.
#[derive(Parser, Debug)]
#[command(name = "mosaicd", version, about, long_about = None)]
struct Cli {
    /// Log filter (tracing `EnvFilter` syntax), overrides `RUST_LOG`.
    #[arg(long, global = true)]
    log: Option<String>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the daemon from a config file.
    Run(cli::run::RunArgs),
    /// Check a config file without opening anything (no camera, no shared memory): exit 0 or 1.
    Check(cli::check::CheckArgs),
    /// Replay an MCAP recording through the daemon pipeline as fast as possible (or at recorded rate).
    Replay(cli::run::ReplayArgs),
    /// Make a recording: from a V4L2 device, or from raw files / RGB images with a camera motion.
    Record(cli::record::RecordArgs),
    /// Subscribe to a running daemon's iceoryx2 services and print JSON lines.
    Listen(cli::listen::ListenArgs),
    /// Detect pedestrians in one frame; boxes as JSON, optional preview PNG.
    Detect(cli::detect::DetectArgs),
    /// Compute gradient maps of one input and write them as PNG.
    Gradients(cli::gradients::GradientsArgs),
    /// SIFT keypoints of one input (JSON and a picture).
    Sift(cli::sift::SiftArgs),
    /// Train a linear SVM pedestrian model.
    Train(cli::detect_common::TrainArgs),
    /// The paper's experiments.
    Eval(cli::eval::EvalArgs),
    /// Benchmarks against OpenCV run in the same process run; prints ratios.
    Bench(cli::bench::BenchArgs),
}

/// Colour (ANSI escapes) in log lines only on a terminal, and never when `NO_COLOR` is set to a
/// non-empty value (<https://no-color.org>): journald, pipes and CI logs get plain text.
fn log_colour(stderr_is_terminal: bool, no_color: Option<&std::ffi::OsStr>) -> bool {
    stderr_is_terminal && no_color.is_none_or(|v| v.is_empty())
}

fn init_tracing(filter: Option<&str>) {
    use std::io::IsTerminal;
    use tracing_subscriber::EnvFilter;
    let filter = match filter {
        Some(f) => EnvFilter::new(f),
        None => EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info")),
    };
    let colour = log_colour(
        std::io::stderr().is_terminal(),
        std::env::var_os("NO_COLOR").as_deref(),
    );
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(colour)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Keep memory that `free` returns for the next frame, instead of handing it back to the kernel.
///
/// glibc's malloc gives freed memory at the top of a heap back to the kernel once more than
/// `M_TRIM_THRESHOLD` is free there (the rayon workers' heaps with `MADV_DONTNEED`), and serves
/// large requests with fresh `mmap`s until a free raises its threshold. Every frame allocates and
/// frees the same buffers (levels, cell rows, window sums), so each frame paid page faults and
/// zeroing for them again: 2.4 % of the daemon's CPU in `clear_page` at 1080p (perf, `bench
/// pipeline`), 0.5 % with this. Memory stays at the high-water mark of the frames in flight, which
/// the daemon holds anyway. Called before any thread starts; `false` if glibc refused a value.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() -> bool {
    // SAFETY: mallopt only sets allocator parameters (values within glibc's documented ranges:
    // the mmap threshold at its 64-bit maximum, 32 MiB); no allocation is in flight.
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 30) == 1
            && libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20) == 1
    }
}

fn main() -> std::process::ExitCode {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    let kept = keep_freed_memory();
    let cli = Cli::parse();
    init_tracing(cli.log.as_deref());
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    if !kept {
        tracing::warn!(
            "malloc kept its defaults (mallopt refused): frames may page-fault their buffers again"
        );
    }
    let result = match cli.command {
        Command::Run(a) => cli::run::run(a),
        Command::Check(a) => cli::check::run(a),
        Command::Replay(a) => cli::run::replay(a),
        Command::Record(a) => cli::record::run(a),
        Command::Listen(a) => cli::listen::run(a),
        Command::Detect(a) => cli::detect::run(a),
        Command::Gradients(a) => cli::gradients::run(a),
        Command::Sift(a) => cli::sift::run(a),
        Command::Train(a) => cli::train::run(a),
        Command::Eval(a) => cli::eval::run(a),
        Command::Bench(a) => cli::bench::run(a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // One clear line (with its causes), non-zero exit.
            eprintln!("mosaicd: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(std::iter::once("mosaicd").chain(args.iter().copied()))
    }

    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn malloc_accepts_the_values_that_keep_freed_memory() {
        assert!(keep_freed_memory());
    }

    #[test]
    fn log_colour_only_on_a_terminal_without_no_color() {
        use std::ffi::OsStr;
        assert!(log_colour(true, None));
        assert!(!log_colour(false, None), "journald and pipes get no escapes");
        assert!(!log_colour(true, Some(OsStr::new("1"))));
        // NO_COLOR set but empty does not count (no-color.org).
        assert!(log_colour(true, Some(OsStr::new(""))));
        assert!(!log_colour(false, Some(OsStr::new(""))));
    }

    #[test]
    fn svm_precision_parses_on_detect_bench_and_eval() {
        use cli::detect_common::SvmArg;
        let Command::Detect(d) = parse(&["detect", "f.raw", "--svm", "i8"]).unwrap().command else {
            panic!("detect")
        };
        assert_eq!(d.det.svm, Some(SvmArg::I8));
        let Command::Detect(d) = parse(&["detect", "f.raw"]).unwrap().command else {
            panic!("detect")
        };
        // detect's defaults are the daemon's: the approximate pyramid and the SVM this CPU runs
        // fastest; eval's are the exact pyramid and f32.
        let o = d.det.options().unwrap();
        assert_eq!(o.svm, mosaicd::detect::ScorePrecision::auto());
        assert_eq!(o.approx_levels, mosaicd::detect::DEFAULT_APPROX_LEVELS);
        let e = d.det.options_with(1, SvmArg::F32).unwrap();
        assert_eq!(
            (e.svm, e.approx_levels),
            (mosaicd::detect::ScorePrecision::F32, 1)
        );
        assert!(parse(&["bench", "detect", "--svm", "i8"]).is_ok());
        assert!(parse(&["eval", "detection", "m=mosaic", "--svm", "f32"]).is_ok());
        for bad in [
            &["detect", "f.raw", "--svm", "f16"][..],
            &["bench", "detect", "--svm", "int8"],
            &["eval", "detection", "m=mosaic", "--svm", "u8"],
        ] {
            let e = parse(bad).unwrap_err().to_string();
            assert!(
                e.contains("--svm") && e.contains("f32") && e.contains("i8"),
                "{e}"
            );
        }
    }
}
