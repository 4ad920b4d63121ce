//! `mosaicd bench pipeline`: replay throughput (frames/s) and capture→publish latency p50/p99 of
//! the daemon pipeline on a synthetic stream (default 1920x1080 12-bit RGGB, 2 threads), with the
//! iceoryx2 publishers on. The stream cycles [`PRERENDERED`] frames rendered before the run and
//! copied into pooled buffers per frame, as a camera's frames are copied out of its DMA buffers
//! (rendering one costs ≈ 10 ms of CPU, which a camera does not spend; `--render-each-frame`
//! counts it as before); then the same run with a subscriber that never reads, and the ratio (a
//! stalled subscriber must not slow the daemon). Not a test: numbers for docs/daemon.md. The
//! output names the kernel path and the CPU's features ([`mosaicd::kernels::describe`];
//! `MOSAICD_KERNELS` forces a path), as does the JSON line (`kernels`).

use std::sync::Arc;

use serde_json::json;

use mosaicd::capture::{SyntheticSource, SyntheticSpec};
use mosaicd::clock::ReplayClock;
use mosaicd::config::PublishConfig;
use mosaicd::config::{Config, SvmSetting};
use mosaicd::detect::people::DetectorKind;
use mosaicd::detect::ScorePrecision;
use mosaicd::pipeline::IceoryxSink;
use mosaicd::pipeline::Stage;
use mosaicd::pipeline::{load_detector, stage_spec};
use mosaicd::pipeline::{Pipeline, PipelineSpec};
use mosaicd::pool::BufferPool;
use mosaicd::publish::{create_node, detections_service, subscriber};

use super::detect_common::SvmArg;

/// Arguments of `mosaicd bench pipeline`.
#[derive(clap::Args, Debug)]
pub struct BenchPipelineArgs {
    /// Frame width.
    #[arg(long, default_value_t = 1920)]
    width: usize,
    /// Frame height.
    #[arg(long, default_value_t = 1080)]
    height: usize,
    /// Bit depth.
    #[arg(long, default_value_t = 12)]
    bit_depth: u8,
    /// Frames per run.
    #[arg(long, default_value_t = 120)]
    frames: u64,
    /// Compute threads.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Frames in flight.
    #[arg(long, default_value_t = 4)]
    max_in_flight: usize,
    /// Gradients only (no pedestrian detection).
    #[arg(long)]
    no_detect: bool,
    /// Detect with this ACF model file instead of HOG (`compute.detector = "acf"` with
    /// `compute.acf_model`, e.g. models/acf-mosaic.json; the HOG options below do not apply).
    #[arg(long, conflicts_with = "no_detect")]
    acf_model: Option<String>,
    /// Detector feature-pyramid approximation (`compute.approx_levels`; 1 = exact; default the
    /// daemon's).
    #[arg(long, default_value_t = mosaicd::detect::DEFAULT_APPROX_LEVELS)]
    approx_levels: usize,
    /// SVM precision (`compute.svm`: `f32`, `i8` or `auto`; default the daemon's, `auto`).
    #[arg(long, value_enum, default_value_t = SvmArg::Auto)]
    svm: SvmArg,
    /// Also compute mosaic SIFT keypoints (`compute.keypoints`).
    #[arg(long)]
    keypoints: bool,
    /// With `--keypoints`: their descriptors too, published on the descriptors service
    /// (`compute.keypoint_descriptors`).
    #[arg(long, requires = "keypoints")]
    descriptors: bool,
    /// With `--keypoints`: double the colour planes first (`compute.keypoints_double`).
    #[arg(long, requires = "keypoints")]
    keypoints_double: bool,
    /// Skip the stalled-subscriber run.
    #[arg(long)]
    no_stalled: bool,
    /// Render every frame in the capture thread during the run (≈ 10 ms of CPU per 1080p frame,
    /// competing with the pipeline) instead of cycling frames rendered before it.
    #[arg(long)]
    render_each_frame: bool,
}

/// Distinct frames the stream cycles through (each rendered once, before the timed run).
const PRERENDERED: u64 = 8;

fn one_run(a: &BenchPipelineArgs, camera: &str, stage: &Stage) -> anyhow::Result<(f64, f64, f64)> {
    let pool = Arc::new(rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?);
    let frames = BufferPool::new(16);
    let mut src = SyntheticSource::with_pool(
        SyntheticSpec {
            width: a.width,
            height: a.height,
            bit_depth: a.bit_depth,
            frames: a.frames,
            ..Default::default()
        },
        frames.clone(),
    );
    if !a.render_each_frame {
        src.prerender(PRERENDERED.min(a.frames))?;
    }
    let publish = PublishConfig {
        service_prefix: "mosaicd-bench".into(),
        ..PublishConfig::default()
    };
    let p = Pipeline::start(
        PipelineSpec {
            camera: camera.into(),
            queue_depth: 4,
            max_in_flight: a.max_in_flight,
            stage: stage.clone(),
            keep_frames: false,
        },
        Box::new(src),
        pool,
        Arc::new(ReplayClock::default()),
        // No linger at the end: the second run's subscriber never reads, and the timed run
        // would include the wait for it.
        vec![IceoryxSink::factory_with_linger(
            camera,
            &publish,
            stage.spec().keypoints,
            stage.spec().keypoint_descriptors,
            std::time::Duration::ZERO,
        )],
        frames,
    )?;
    let r = p.join();
    anyhow::ensure!(
        r.stats.processed == a.frames,
        "processed {} of {}",
        r.stats.processed,
        a.frames
    );
    Ok((
        r.stats.processed as f64 / r.elapsed.as_secs_f64(),
        r.stats.latency_p50_us / 1e3,
        r.stats.latency_p99_us / 1e3,
    ))
}

/// The keypoint stage's setting, as the summary line says it.
fn keypoint_mode(a: &BenchPipelineArgs) -> String {
    if !a.keypoints {
        return "off".into();
    }
    let mut s = String::from("on");
    if a.descriptors {
        s.push_str(" with descriptors");
    }
    if a.keypoints_double {
        s.push_str(", doubled planes");
    }
    s
}

/// Run `mosaicd bench pipeline`.
pub fn run(a: BenchPipelineArgs) -> anyhow::Result<()> {
    let mut cfg = Config::default();
    cfg.compute.detect = !a.no_detect;
    if let Some(m) = &a.acf_model {
        cfg.compute.detector = DetectorKind::Acf;
        cfg.compute.acf_model = m.clone();
    }
    let detector = match &a.acf_model {
        Some(m) => format!("acf {m}"),
        None => "hog".into(),
    };
    let svm = ScorePrecision::from(a.svm);
    let detection = match (&a.acf_model, a.no_detect) {
        (_, true) => "off".to_string(),
        (Some(_), false) => format!("on ({detector})"),
        (None, false) => format!("on (hog, approx {}, svm {})", a.approx_levels, svm),
    };
    cfg.compute.approx_levels = a.approx_levels;
    cfg.compute.svm = SvmSetting::Fixed(svm);
    cfg.compute.keypoints = a.keypoints;
    cfg.compute.keypoint_descriptors = a.descriptors;
    cfg.compute.keypoints_double = a.keypoints_double;
    let stage = Stage::new(stage_spec(&cfg), load_detector(&cfg)?)?;
    let cam = format!("bench{}", std::process::id());
    let (fps, p50, p99) = one_run(&a, &cam, &stage)?;
    println!(
        "pipeline {}x{} {}-bit, detection {detection}, keypoints {}, {} threads, {} in flight, {} frames ({}): {:.2} frames/s, capture->publish latency p50 {:.2} ms p99 {:.2} ms",
        a.width, a.height, a.bit_depth, keypoint_mode(&a), a.threads, a.max_in_flight, a.frames,
        if a.render_each_frame { "each rendered during the run".to_string() } else { format!("{PRERENDERED} rendered before the run, cycled") }, fps, p50, p99
    );
    println!("{}", mosaicd::kernels::describe());
    let mut stalled = None;
    if !a.no_stalled {
        // A subscriber that never reads, held for the whole second run.
        let cam2 = format!("{cam}s");
        let node = create_node(
            &format!("mosaicd-bench-stall-{}", std::process::id()),
            true,
            &mosaicd::publish::root_dir(&PublishConfig::default().root)?,
        )?;
        let svc = detections_service(
            &node,
            "mosaicd-bench",
            &cam2,
            PublishConfig::default().subscriber_buffer,
        )?;
        let _sub = subscriber(&svc, PublishConfig::default().subscriber_buffer, "stalled")?;
        let (fps2, p50b, p99b) = one_run(&a, &cam2, &stage)?;
        println!(
            "with a subscriber that never reads: {:.1} frames/s ({:+.1} %), latency p50 {:.2} ms p99 {:.2} ms",
            fps2,
            (fps2 / fps - 1.0) * 100.0,
            p50b,
            p99b
        );
        stalled = Some(fps2);
    }
    let commit = option_env!("MOSAICD_COMMIT").unwrap_or("see git log");
    println!(
        "{}",
        json!({"detect": !a.no_detect, "detector": detector, "approx_levels": a.approx_levels, "svm": svm.name(), "keypoints": a.keypoints,
               "descriptors": a.descriptors, "keypoints_double": a.keypoints_double, "width": a.width, "height": a.height, "bit_depth": a.bit_depth, "threads": a.threads,
               "frames": a.frames, "rendered_each_frame": a.render_each_frame, "fps": fps, "latency_p50_ms": p50, "latency_p99_ms": p99,
               "fps_with_stalled_subscriber": stalled, "commit": commit, "kernels": super::bench_gradients::kernels_json()})
    );
    Ok(())
}
