//! `mosaicd run` (the daemon, from a config) and `mosaicd replay FILE.mcap`.
//!
//! Both load a config (`run`: default `config/mosaicd.toml`; `replay`: default the built-in
//! defaults), apply command-line overrides, validate once,
//! run until the sources end or SIGTERM/SIGINT, and print a summary (frames, detections,
//! throughput, latency p50/p99, drops and failures by reason). Exit status is non-zero when a
//! source ended with an error (truncated or corrupt recording, lost device), when a run that
//! reached the end of its input skipped frames it could not read, or when a sink failed — after
//! everything already captured has been processed and written.

use std::path::PathBuf;

use anyhow::Context;

use mosaicd::config::{CameraConfig, Config, SourceType};
use mosaicd::pipeline::IceoryxSink;
use mosaicd::pipeline::LiveView;
use mosaicd::pipeline::SinkFactory;
use mosaicd::pipeline::{DaemonError, RunOptions, RunSummary};

/// Default config file.
const DEFAULT_CONFIG: &str = "config/mosaicd.toml";

/// Overrides shared by `run` and `replay`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct Overrides {
    /// Compute threads (`daemon.threads`).
    #[arg(long)]
    threads: Option<usize>,
    /// Frames in flight per camera (`daemon.max_in_flight`).
    #[arg(long)]
    max_in_flight: Option<usize>,
    /// Service name prefix (`publish.service_prefix`).
    #[arg(long)]
    service_prefix: Option<String>,
    /// Do not publish over iceoryx2.
    #[arg(long)]
    no_publish: bool,
    /// Also publish gradient maps (`publish.gradients`).
    #[arg(long)]
    publish_gradients: bool,
    /// Write results as JSON lines (`{camera}` is replaced by the camera name).
    #[arg(long, value_name = "FILE")]
    results: Option<PathBuf>,
    /// Print the summary as one JSON object on stdout instead of text.
    #[arg(long)]
    json_summary: bool,
}

/// Arguments of `mosaicd run`.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// Config file.
    #[arg(long, short, default_value = DEFAULT_CONFIG)]
    config: PathBuf,
    #[command(flatten)]
    overrides: Overrides,
}

/// Arguments of `mosaicd replay`.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// The recording.
    file: PathBuf,
    /// Config file for everything but the source. Default: the built-in defaults (the values
    /// config/mosaicd.toml spells out); no file is read from the working directory.
    #[arg(long, short)]
    config: Option<PathBuf>,
    /// Camera name used in service names and outputs.
    #[arg(long, default_value = "replay")]
    camera: String,
    /// Replay at the recorded rate instead of as fast as possible.
    #[arg(long)]
    realtime: bool,
    /// Loop the recording.
    #[arg(long = "loop")]
    looped: bool,
    /// Record results (detections as foxglove.ImageAnnotations and mosaicd.Detections, stats) and
    /// the frames `--out-frames` names to this MCAP file (overwritten).
    #[arg(long, value_name = "OUT.mcap")]
    out: Option<PathBuf>,
    /// Frames recorded with `--out`: `preview` (an 8-bit foxglove.RawImage of every frame, which
    /// Foxglove's image panel draws the boxes on; every n-th 2x2 tile, n = the config's
    /// `record.preview_decimation`, 2 when that is 0), `raw` (the lossless frames at full bit
    /// depth: large, and replayable), `both`, or `none` (results only). Replaces the config's
    /// `record.frames` and `record.preview_decimation`.
    #[arg(long, value_enum, default_value_t = OutFrames::Preview, requires = "out")]
    out_frames: OutFrames,
    /// Keep wall-clock values (timer-driven stats, latency, frames/s) in the output files. Without
    /// it a replay's files are byte-identical for any thread count
    /// (`daemon.deterministic_outputs`).
    #[arg(long)]
    wall_clock: bool,
    #[command(flatten)]
    overrides: Overrides,
}

/// `replay --out-frames` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutFrames {
    /// The 8-bit Foxglove preview.
    Preview,
    /// The lossless raw frames.
    Raw,
    /// Both.
    Both,
    /// Results only.
    None,
}

/// Preview decimation of `replay --out` when the config records no preview.
const OUT_PREVIEW_DECIMATION: u32 = 2;

impl OutFrames {
    /// Set `record.frames` and `record.preview_decimation` of `cfg`.
    fn apply(self, cfg: &mut Config) {
        let preview = matches!(self, OutFrames::Preview | OutFrames::Both);
        cfg.record.frames = matches!(self, OutFrames::Raw | OutFrames::Both);
        cfg.record.preview_decimation = match cfg.record.preview_decimation {
            _ if !preview => 0,
            0 => OUT_PREVIEW_DECIMATION,
            n => n,
        };
    }
}

fn apply(cfg: &mut Config, o: &Overrides) -> anyhow::Result<()> {
    if let Some(t) = o.threads {
        cfg.daemon.threads = t;
    }
    if let Some(m) = o.max_in_flight {
        cfg.daemon.max_in_flight = m;
    }
    if let Some(p) = &o.service_prefix {
        cfg.publish.service_prefix = p.clone();
    }
    if o.no_publish {
        cfg.publish.enabled = false;
    }
    if o.publish_gradients {
        cfg.publish.gradients = true;
    }
    cfg.validate().context("after command-line overrides")?;
    Ok(())
}

fn sinks_for<'a>(
    cfg: &'a Config,
    live: Option<&'a LiveView>,
) -> impl Fn(&CameraConfig) -> Result<Vec<SinkFactory>, DaemonError> + 'a {
    move |cam: &CameraConfig| {
        let mut v = Vec::new();
        if cfg.publish.enabled {
            v.push(IceoryxSink::factory(
                &cam.name,
                &cfg.publish,
                cfg.compute.keypoints,
                cfg.compute.keypoint_descriptors,
            ));
        }
        if cfg.record.enabled {
            v.push(mosaicd::pipeline::recorder_sink(cfg, cam)?);
        }
        if let Some(l) = live {
            v.push(l.sink_factory(&cam.name, cfg.compute.keypoints));
        }
        Ok(v)
    }
}

fn execute(cfg: &Config, o: &Overrides) -> anyhow::Result<()> {
    // The one frame-size limit, for every source and loader of this process.
    cfg.limits.frame_limits().set_process();
    // Once at start-up: the kernel path every kernel family runs and the CPU's features.
    mosaicd::kernels::log_choice();
    let opts = RunOptions {
        results_out: o.results.clone(),
    };
    // The live view's server, one for every camera, up before the first frame and down after
    // the last.
    let live = LiveView::start(&cfg.foxglove)?;
    let builder = sinks_for(cfg, live.as_ref());
    let summary = mosaicd::pipeline::run(cfg, &opts, &builder);
    drop(builder);
    if let Some(l) = live {
        l.stop();
    }
    report(&summary?, o.json_summary)
}

fn report(summary: &RunSummary, json: bool) -> anyhow::Result<()> {
    if json {
        println!("{}", serde_json::to_string(summary)?);
    } else {
        for l in summary.lines() {
            println!("{l}");
        }
    }
    let mut problems = Vec::new();
    for c in &summary.cameras {
        match &c.source_error {
            Some(e) if c.source_ended_on_error => {
                problems.push(format!("camera {}: input ended with an error: {e}", c.camera))
            }
            // Frames or files the source skipped and went on after: logged and counted. A run
            // that reached the end of its input reports them through the exit status; a service
            // stopped by a signal does not fail its stop for them.
            Some(e) if !summary.interrupted => problems.push(format!(
                "camera {}: {} frame(s) of the input could not be read and were skipped (last: {e})",
                c.camera, c.stats.failed_source
            )),
            _ => {}
        }
        for e in &c.sink_errors {
            problems.push(format!("camera {}: {e}", c.camera));
        }
        // A recording paused by a write error and resumed: as skipped input, a failure at the
        // end of the input, not for a service stopped by a signal.
        if !summary.interrupted {
            for e in &c.sink_interruptions {
                problems.push(format!("camera {}: {e}", c.camera));
            }
        }
    }
    if !problems.is_empty() {
        anyhow::bail!(
            "{} (everything captured before it was processed and written)",
            problems.join("; ")
        );
    }
    Ok(())
}

/// Run `mosaicd run`.
pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let mut cfg = Config::load(&args.config)?;
    apply(&mut cfg, &args.overrides)?;
    execute(&cfg, &args.overrides)
}

/// Run `mosaicd replay`.
pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let mut cfg = match &args.config {
        Some(p) => Config::load(p)?,
        None => Config::default(),
    };
    let mut cam = CameraConfig::synthetic(&args.camera, 2, 2, 0);
    cam.source = SourceType::Mcap;
    cam.path = Some(args.file.clone());
    cam.realtime = args.realtime;
    cam.looped = args.looped;
    cfg.cameras = vec![cam];
    if let Some(out) = &args.out {
        cfg.record.enabled = true;
        cfg.record.path = out.clone();
        // A command-line output is overwritten, as `record -o` and `--results` are.
        cfg.record.overwrite = true;
        cfg.record.max_files = 0;
        args.out_frames.apply(&mut cfg);
    }
    cfg.daemon.deterministic_outputs = !args.wall_clock;
    apply(&mut cfg, &args.overrides)?;
    execute(&cfg, &args.overrides)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_frames_decide_what_replay_out_records() {
        let rec = |f: OutFrames, decimation: u32, frames: bool| {
            let mut c = Config::default();
            c.record.preview_decimation = decimation;
            c.record.frames = frames;
            f.apply(&mut c);
            (c.record.frames, c.record.preview_decimation)
        };
        // The default: a preview for Foxglove's image panel, even when the config records none.
        assert_eq!(rec(OutFrames::Preview, 0, false), (false, OUT_PREVIEW_DECIMATION));
        assert_eq!(
            rec(OutFrames::Preview, 4, true),
            (false, 4),
            "the config's decimation"
        );
        assert_eq!(rec(OutFrames::Raw, 4, false), (true, 0));
        assert_eq!(rec(OutFrames::Both, 0, false), (true, OUT_PREVIEW_DECIMATION));
        assert_eq!(rec(OutFrames::None, 4, true), (false, 0));
    }
}
