//! One file per subcommand. Each defines its clap `Args` and a `run` function.

pub mod acf;
pub mod bench;
pub mod bench_detect;
pub mod bench_gradients;
pub mod bench_pipeline;
pub mod bench_sift;
pub mod check;
pub mod detect;
pub mod detect_common;
pub mod eval;
pub mod eval_detection;
pub mod eval_isp;
pub mod eval_sift;
pub mod gradients;
pub mod input;
pub mod listen;
pub mod record;
pub mod run;
pub mod sift;
pub mod train;
