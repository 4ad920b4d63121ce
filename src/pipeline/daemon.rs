//! The daemon: pipelines for every configured camera under a tokio runtime that handles signals,
//! timers, sd_notify and shutdown.
//!
//! * **Start-up**: build the compute pool (`daemon.threads`), open every source and sink (an error
//!   here names the camera and the key; nothing runs half-started), then `READY=1`.
//! * **Running**: every `daemon.stats_interval_ms` each pipeline publishes a stats snapshot, the
//!   daemon sends `STATUS=` (fps, drops, latency), rewrites the metrics textfile when
//!   `metrics.textfile` is set ([`super::textfile`]; once more after the drain) and pets the
//!   watchdog (`WATCHDOG=1`) **only if frames progressed** since the last pet (a stuck pipeline
//!   lets systemd restart the service).
//! * **Shutdown** (SIGTERM/SIGINT, or every source ended): capture stops, queued and in-flight frames
//!   are drained, final stats are published, sinks finish (MCAP summary + index), iceoryx2 ports and
//!   nodes are dropped (shared memory released).
//! * **Shutdown always ends within `daemon.shutdown_timeout_ms`** (measured from the signal, or
//!   from the end of the input). Sources wake from any wait on the stop flag at once. If the drain
//!   has not finished when [`abort_grace`] of the timeout is left, it is cut short
//!   ([`AbortHandle::abort`]: frames still queued or computing are abandoned, every sink skips what
//!   it still has queued and finishes, so recordings are closed with their summary); at the timeout
//!   the daemon returns [`DaemonError::ShutdownTimeout`] whatever is still running (a sink stuck in
//!   one write is left behind: the process exits). The drain runs on a plain thread, so nothing
//!   waits for it when the runtime is dropped.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::Serialize;

use super::engine::{AbortHandle, Pipeline, PipelineReport, PipelineSpec, SinkError, SinkFactory};
use super::pool::BufferPool;
use super::sinks::JsonlSink;
use super::sources::{open_source, SourceOpenError};
use super::stage::{Stage, StageSpec};
use super::stats::StatsSnapshot;
use super::textfile::Textfile;
use crate::capture::SourceKind;
use crate::clock::{Clock, MonotonicClock, ReplayClock};
use crate::config::{CameraConfig, Config};
use crate::detect::acf::AcfOptions;
use crate::detect::people::{PeopleDetector, PeopleModel};
use crate::detect::{DetectorOptions, Domain};

/// How often the daemon checks whether every pipeline has finished.
const FINISH_POLL: Duration = Duration::from_millis(10);
/// The most of the shutdown timeout kept for the sinks to finish after a drain is cut short.
const ABORT_GRACE_MAX: Duration = Duration::from_secs(1);

/// How long before the shutdown timeout a drain still running is cut short: a quarter of the
/// timeout, at most 1 s (the sinks' time to finish their files).
pub(crate) fn abort_grace(timeout: Duration) -> Duration {
    (timeout / 4).min(ABORT_GRACE_MAX)
}

/// Errors that stop the daemon.
#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    /// A source could not be opened.
    #[error(transparent)]
    Source(#[from] SourceOpenError),
    /// A sink could not be started (the cause is the sink's error: printed once, by its own
    /// `Display`, not again as a source).
    #[error("camera {camera:?}: {error}")]
    Sink {
        /// Camera.
        camera: String,
        /// Cause.
        error: SinkError,
    },
    /// The compute pool or runtime could not be built.
    #[error("cannot start {what}: {message}")]
    Start {
        /// What.
        what: &'static str,
        /// Cause.
        message: String,
    },
    /// The detector model could not be loaded.
    #[error("detector: {message}")]
    Model {
        /// What went wrong, naming the config key.
        message: String,
    },
    /// The stage refused its parameters.
    #[error("compute: {0}")]
    Stage(#[from] super::stage::StageError),
    /// A config value the daemon needs is invalid.
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// The drain took longer than the stop timeout.
    #[error("shutdown did not finish within daemon.shutdown_timeout_ms = {timeout_ms} ms")]
    ShutdownTimeout {
        /// The timeout.
        timeout_ms: u64,
    },
}

/// Builds extra sinks for a camera (publishers, recorders) — supplied by the caller so this module
/// does not depend on every sink kind.
pub type SinkBuilder<'a> = &'a dyn Fn(&CameraConfig) -> Result<Vec<SinkFactory>, DaemonError>;

/// Options of one run besides the config.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Write each camera's results as JSON lines here (`{camera}` substituted).
    pub results_out: Option<PathBuf>,
}

/// What a run did.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// Per camera.
    pub cameras: Vec<CameraSummary>,
    /// Wall time, seconds.
    pub elapsed_s: f64,
    /// Stopped by a signal.
    pub interrupted: bool,
}

/// One camera's summary.
#[derive(Debug, Clone, Serialize)]
pub struct CameraSummary {
    /// Name.
    pub camera: String,
    /// Counters.
    pub stats: StatsSnapshot,
    /// Processed frames per second of wall time, from the start to the last frame handed to the
    /// sinks (equal to the final stats message's `fps`).
    pub throughput_fps: f64,
    /// The source's last error (a skipped frame or file, or what the input ended on).
    pub source_error: Option<String>,
    /// The input ended on `source_error` (truncated recording, lost device) instead of going on.
    pub source_ended_on_error: bool,
    /// Sink errors (each stopped its sink).
    pub sink_errors: Vec<String>,
    /// Errors a sink went on after (the recorder paused by a full disk, then tried again).
    pub sink_interruptions: Vec<String>,
}

impl RunSummary {
    /// Human-readable lines.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        for c in &self.cameras {
            let s = &c.stats;
            out.push(format!(
                "camera {}: {} frames processed of {} captured, {} detections, {:.1} frames/s, latency p50 {:.2} ms p99 {:.2} ms",
                c.camera,
                s.processed,
                s.captured,
                s.detections,
                c.throughput_fps,
                s.latency_p50_us / 1e3,
                s.latency_p99_us / 1e3
            ));
            out.push(format!(
                "  dropped: queue_full {} driver {}; failed: source {} compute {} sink {}; frames sinks lost {}",
                s.dropped_queue_full,
                s.dropped_driver,
                s.failed_source,
                s.failed_compute,
                s.failed_sink,
                s.sink_frames_lost
            ));
            if let Some(e) = &c.source_error {
                out.push(format!("  source error: {e}"));
            }
            for e in &c.sink_errors {
                out.push(format!("  sink error: {e}"));
            }
            for e in &c.sink_interruptions {
                out.push(format!("  sink interrupted: {e}"));
            }
        }
        out.push(format!(
            "elapsed {:.2} s{}",
            self.elapsed_s,
            if self.interrupted {
                " (stopped by signal)"
            } else {
                ""
            }
        ));
        out
    }
}

/// The pipeline stage spec of a config.
pub fn stage_spec(cfg: &Config) -> StageSpec {
    StageSpec {
        orientation_bins: cfg.compute.orientation_bins,
        strip_rows: cfg.compute.strip_rows,
        detect: cfg.compute.detect,
        keypoints: cfg.compute.keypoints,
        keypoint_descriptors: cfg.compute.keypoint_descriptors,
        keypoints_double: cfg.compute.keypoints_double,
        wb_gains: cfg.compute.wb_gains,
    }
}

#[cfg(test)]
use crate::detect::OPENCV_DEFAULT_MODEL;

/// Load the detector a config asks for (once; shared by every camera and task): the HOG model
/// of `compute.model`, or with `compute.detector = "acf"` the ACF model of `compute.acf_model`.
/// A model of the other kind, or one that does not load, is an error naming the key.
pub fn load_detector(cfg: &Config) -> Result<Option<Arc<PeopleDetector>>, DaemonError> {
    let c = &cfg.compute;
    if !c.detect {
        return Ok(None);
    }
    let (key, name) = c.model_key();
    let model = PeopleModel::load_as(name, c.detector, Domain::Mosaic)
        .map_err(|e| DaemonError::Model {
            message: format!(
                "{key} = {name:?} (compute.detector = {:?}): {e}",
                c.detector.name()
            ),
        })?
        .with_overrides(c.mosaic_taps, c.mosaic_tone);
    let hog = DetectorOptions {
        scale_step: c.scale_step,
        max_levels: c.max_levels,
        upsample: c.upsample,
        hit_threshold: c.hit_threshold,
        approx_levels: c.approx_levels,
        svm: c.svm.precision(),
        ..DetectorOptions::default()
    };
    let det = model
        .build(&hog, &acf_options(cfg))
        .map_err(|e| DaemonError::Model {
            message: format!("compute: {e}"),
        })?;
    Ok(Some(Arc::new(det)))
}

/// The ACF detector's options of a config: `compute.upsample`, `compute.max_levels` and
/// `compute.hit_threshold`; the model's own pyramid approximation; greedy suppression at IoU 0.5
/// (the ACF detector's default, as in `mosaicd detect` and `eval detection`).
pub(crate) fn acf_options(cfg: &Config) -> AcfOptions {
    let c = &cfg.compute;
    AcfOptions {
        upsample: c.upsample,
        max_levels: c.max_levels,
        hit_threshold: c.hit_threshold,
        ..AcfOptions::default()
    }
}

/// Run the daemon until every source ends or a signal arrives.
pub fn run(
    cfg: &Config,
    opts: &RunOptions,
    sink_builder: SinkBuilder<'_>,
) -> Result<RunSummary, DaemonError> {
    let started = Instant::now();
    // A file-size limit (systemd `LimitFSIZE=`, `ulimit -f`) would kill the process with
    // SIGXFSZ at the recorder's first write past it; ignored, the write fails with EFBIG and is
    // handled as any write error (the recording pauses, detection and publishing go on).
    // SAFETY: setting a signal's disposition to SIG_IGN has no handler to race with.
    unsafe { libc::signal(libc::SIGXFSZ, libc::SIG_IGN) };
    let pool = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(cfg.daemon.threads)
            .thread_name(|i| format!("mosaicd-compute-{i}"))
            .build()
            .map_err(|e| DaemonError::Start {
                what: "compute pool",
                message: e.to_string(),
            })?,
    );
    let stage = Stage::new(stage_spec(cfg), load_detector(cfg)?)?;
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| DaemonError::Start {
            what: "tokio runtime",
            message: e.to_string(),
        })?;
    // Handlers before the first frame: a signal while the pipelines start waits for them.
    let signals = {
        let _rt = rt.enter();
        Signals::new()?
    };
    let mut pipelines = Vec::new();
    for cam in &cfg.cameras {
        let frame_pool = BufferPool::new(cfg.daemon.queue_depth + cfg.daemon.max_in_flight + 2);
        let source = open_source(cam, &frame_pool)?;
        tracing::info!(camera = %cam.name, "source: {}", source.describe());
        let clock: Arc<dyn Clock> = match source.kind() {
            SourceKind::Live => Arc::new(MonotonicClock),
            SourceKind::Replay => Arc::new(ReplayClock::default()),
        };
        let mut sinks = sink_builder(cam)?;
        if let Some(p) = &opts.results_out {
            let path = PathBuf::from(p.to_string_lossy().replace("{camera}", &cam.name));
            sinks.push(JsonlSink::factory(
                &cam.name,
                path,
                cfg.daemon.deterministic_outputs,
            ));
        }
        let spec = PipelineSpec {
            camera: cam.name.clone(),
            queue_depth: cfg.daemon.queue_depth,
            max_in_flight: cfg.daemon.max_in_flight,
            stage: stage.clone(),
            keep_frames: (cfg.record.enabled && (cfg.record.frames || cfg.record.preview_decimation > 0))
                || cfg.foxglove.enabled(),
        };
        let p = Pipeline::start(spec, source, pool.clone(), clock, sinks, frame_pool).map_err(|e| {
            DaemonError::Sink {
                camera: cam.name.clone(),
                error: e,
            }
        })?;
        pipelines.push(p);
    }

    let stats_every = Duration::from_millis(cfg.daemon.stats_interval_ms);
    let timeout = Duration::from_millis(cfg.daemon.shutdown_timeout_ms);
    let mut textfile = cfg.metrics.textfile.clone().map(|path| {
        Textfile::new(
            path,
            pipelines
                .iter()
                .map(|p| (p.camera().to_string(), p.shared_stats()))
                .collect(),
        )
    });
    let supervised = rt.block_on(supervise(
        pipelines,
        signals,
        stats_every,
        timeout,
        textfile.as_mut(),
    ));
    // The final counters (and the recorders' final state), also after a shutdown timeout.
    if let Some(t) = &mut textfile {
        t.write();
    }
    let (reports, interrupted) = supervised?;
    let elapsed = started.elapsed().as_secs_f64();
    Ok(RunSummary {
        cameras: reports
            .into_iter()
            .map(|r| CameraSummary {
                // The same division as the final stats message's fps.
                throughput_fps: r.stats.processed as f64 / r.active.as_secs_f64().max(1e-9),
                camera: r.camera,
                stats: r.stats,
                source_error: r.source_error,
                source_ended_on_error: r.source_ended_on_error,
                sink_errors: r.sink_errors,
                sink_interruptions: r.sink_interruptions,
            })
            .collect(),
        elapsed_s: elapsed,
        interrupted,
    })
}

fn notify(states: &[sd_notify::NotifyState]) {
    // No-op outside systemd (no NOTIFY_SOCKET); an error here must never stop the daemon.
    if let Err(e) = sd_notify::notify(states) {
        tracing::debug!("sd_notify: {e}");
    }
}

fn status_line(pipelines: &[Pipeline], fps: f64) -> String {
    let parts: Vec<String> = pipelines
        .iter()
        .map(|p| camera_status(p.camera(), fps, &p.stats()))
        .collect();
    parts.join("; ")
}

/// One camera's part of the `STATUS=` line (also logged every stats interval); sink failures
/// and the frames they lost are shown once there are any.
fn camera_status(camera: &str, fps: f64, s: &super::stats::StatsSnapshot) -> String {
    let mut line = format!(
        "{camera}: {fps:.1} fps, {} frames, dropped {}, failed {}, p50 {:.1} ms, p99 {:.1} ms",
        s.processed,
        s.dropped_queue_full + s.dropped_driver,
        s.failed_source + s.failed_compute,
        s.latency_p50_us / 1e3,
        s.latency_p99_us / 1e3
    );
    if s.failed_sink > 0 || s.sink_frames_lost > 0 {
        line += &format!(
            ", sink failures {} ({} frames not written)",
            s.failed_sink, s.sink_frames_lost
        );
    }
    line
}

/// The signals the daemon handles.
struct Signals {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
    /// SIGHUP (`systemctl reload`): new recording files, nothing else changes. Without a
    /// handler it would end the process without a drain.
    hup: tokio::signal::unix::Signal,
}

impl Signals {
    /// Install the handlers (inside a tokio runtime context).
    fn new() -> Result<Self, DaemonError> {
        use tokio::signal::unix::{signal, SignalKind};
        let sig = |k| {
            signal(k).map_err(|e| DaemonError::Start {
                what: "signal handlers",
                message: e.to_string(),
            })
        };
        Ok(Self {
            term: sig(SignalKind::terminate())?,
            int: sig(SignalKind::interrupt())?,
            hup: sig(SignalKind::hangup())?,
        })
    }
}

async fn supervise(
    pipelines: Vec<Pipeline>,
    signals: Signals,
    stats_every: Duration,
    timeout: Duration,
    mut textfile: Option<&mut Textfile>,
) -> Result<(Vec<PipelineReport>, bool), DaemonError> {
    let Signals {
        mut term,
        mut int,
        mut hup,
    } = signals;
    let watchdog = sd_notify::watchdog_enabled();
    notify(&[
        sd_notify::NotifyState::Ready,
        sd_notify::NotifyState::Status("running"),
    ]);
    tracing::info!(cameras = pipelines.len(), "ready");

    // The first tick one interval after the start (tokio's `interval` ticks at once, which made the
    // first stats line and message all zeros).
    let mut stats_tick = tokio::time::interval_at(tokio::time::Instant::now() + stats_every, stats_every);
    stats_tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    // Pet at half the watchdog period, but only when frames progressed.
    let mut dog_tick = tokio::time::interval(watchdog.map(|d| d / 2).unwrap_or(Duration::from_secs(3600)));
    let mut finish_tick = tokio::time::interval(FINISH_POLL);
    let processed = |ps: &[Pipeline]| {
        ps.iter()
            .map(|p| p.stats().processed + p.stats().failed_compute)
            .sum::<u64>()
    };
    let mut last_dog = 0u64;
    let mut last_stats = (Instant::now(), 0u64);
    let mut interrupted = false;
    loop {
        tokio::select! {
            _ = term.recv() => { tracing::info!("SIGTERM: draining"); interrupted = true; break; }
            _ = int.recv() => { tracing::info!("SIGINT: draining"); interrupted = true; break; }
            _ = hup.recv() => {
                tracing::info!("SIGHUP: starting new recording files (the config is read only at start: restart to change it)");
                for p in &pipelines { p.reopen(); }
            }
            _ = stats_tick.tick() => {
                for p in &pipelines { p.publish_stats(); }
                let n = processed(&pipelines);
                let fps = (n - last_stats.1) as f64 / last_stats.0.elapsed().as_secs_f64().max(1e-9);
                last_stats = (Instant::now(), n);
                let line = status_line(&pipelines, fps);
                tracing::info!("{line}");
                notify(&[sd_notify::NotifyState::Status(&line)]);
                if let Some(t) = textfile.as_deref_mut() { t.write(); }
            }
            _ = dog_tick.tick(), if watchdog.is_some() => {
                let n = processed(&pipelines);
                if n > last_dog || pipelines.iter().all(|p| p.is_finished()) {
                    notify(&[sd_notify::NotifyState::Watchdog]);
                    last_dog = n;
                } else {
                    tracing::warn!("no frame progress since the last watchdog period: not petting the watchdog");
                }
            }
            _ = finish_tick.tick() => {
                if pipelines.iter().all(|p| p.is_finished()) { break; }
            }
        }
    }
    notify(&[
        sd_notify::NotifyState::Stopping,
        sd_notify::NotifyState::Status("draining"),
    ]);
    for p in &pipelines {
        p.stop();
    }
    let aborts: Vec<AbortHandle> = pipelines.iter().map(Pipeline::abort_handle).collect();
    let (tx, mut rx) = tokio::sync::oneshot::channel();
    // A plain thread, not `spawn_blocking`: dropping the runtime waits for blocking tasks, and a
    // drain that overran the timeout must not hold the process.
    std::thread::Builder::new()
        .name("mosaicd-drain".into())
        .spawn(move || {
            let _ = tx.send(pipelines.into_iter().map(Pipeline::join).collect::<Vec<_>>());
        })
        .map_err(|e| DaemonError::Start {
            what: "drain thread",
            message: e.to_string(),
        })?;
    // A second signal during the drain does not cut it short: the timeout bounds it.
    let grace = abort_grace(timeout);
    let timed_out = || DaemonError::ShutdownTimeout {
        timeout_ms: timeout.as_millis() as u64,
    };
    let lost = |_| DaemonError::Start {
        what: "drain",
        message: "the drain thread ended without a report".into(),
    };
    match tokio::time::timeout(timeout - grace, &mut rx).await {
        Ok(reports) => return reports.map(|r| (r, interrupted)).map_err(lost),
        Err(_) => {
            tracing::error!(
                "the drain did not finish within {} ms of daemon.shutdown_timeout_ms = {} ms: cutting it short; sinks get {} ms to finish",
                (timeout - grace).as_millis(),
                timeout.as_millis(),
                grace.as_millis()
            );
            for a in &aborts {
                a.abort();
            }
        }
    }
    match tokio::time::timeout(grace, &mut rx).await {
        Ok(Ok(_)) => {
            tracing::warn!("the sinks finished after the drain was cut short");
            Err(timed_out())
        }
        Ok(Err(e)) => Err(lost(e)),
        Err(_) => {
            tracing::error!("a sink is still busy at the shutdown timeout: leaving it behind");
            Err(timed_out())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::hog::MosaicTaps;

    #[test]
    fn a_drain_is_cut_short_a_quarter_of_the_timeout_before_it_at_most_1_s() {
        assert_eq!(
            abort_grace(Duration::from_millis(2000)),
            Duration::from_millis(500)
        );
        assert_eq!(abort_grace(Duration::from_secs(10)), Duration::from_secs(1));
        assert_eq!(abort_grace(Duration::from_millis(1)), Duration::from_micros(250));
    }

    #[test]
    fn a_sink_error_is_printed_once_in_the_error_chain() {
        let e = DaemonError::Sink {
            camera: "c".into(),
            error: SinkError::Start {
                sink: "iceoryx2 p/c".into(),
                message: "iceoryx2 root /x: exists and is not a directory".into(),
            },
        };
        let chain = format!("{:#}", anyhow::Error::from(e));
        assert_eq!(chain.matches("not a directory").count(), 1, "{chain}");
    }

    #[test]
    fn the_first_stats_come_one_interval_in_and_the_final_fps_is_the_summarys() {
        // A live synthetic camera at 100 fps for 0.4 s, stats every 50 ms.
        let cfg = Config::from_toml_str(
            "[daemon]\nstats_interval_ms = 50\n[publish]\nenabled = false\n[compute]\ndetect = false\n\
             [[camera]]\nname = \"a\"\nsource = \"synthetic\"\nwidth = 64\nheight = 48\n\
             fps = 100\nframes = 40\nlive = true\n",
        )
        .unwrap();
        let sink = crate::pipeline::sinks::CollectSink::default();
        let builder = |cam: &CameraConfig| Ok(vec![sink.factory(&cam.name)]);
        let summary = run(&cfg, &RunOptions::default(), &builder).unwrap();
        let records = sink.take();
        let stats: Vec<_> = records.iter().filter(|r| r["type"] == "stats").collect();
        let first = stats.first().expect("periodic stats in 0.4 s at 50 ms");
        assert!(
            first["captured"].as_u64().unwrap() > 0,
            "the first stats message is not all zeros: {first}"
        );
        let last = records.last().unwrap();
        assert_eq!(last["type"], "final_stats");
        let c = &summary.cameras[0];
        assert_eq!(c.stats.processed, 40);
        // Over the whole run, not the last partial interval: the summary's figure exactly.
        assert_eq!(
            last["wall"]["fps"].as_f64().unwrap() as f32,
            c.throughput_fps as f32,
            "{last}"
        );
        assert!((20.0..=150.0).contains(&c.throughput_fps), "{}", c.throughput_fps);
    }

    #[test]
    fn the_status_line_shows_sink_losses_once_there_are_any() {
        let mut s = super::super::stats::StatsSnapshot {
            processed: 120,
            dropped_queue_full: 2,
            dropped_driver: 1,
            failed_compute: 1,
            latency_p50_us: 12_345.0,
            latency_p99_us: 45_678.0,
            ..Default::default()
        };
        assert_eq!(
            camera_status("cam", 14.96, &s),
            "cam: 15.0 fps, 120 frames, dropped 3, failed 1, p50 12.3 ms, p99 45.7 ms"
        );
        s.failed_sink = 1;
        s.sink_frames_lost = 37;
        assert!(
            camera_status("cam", 14.96, &s).ends_with(", sink failures 1 (37 frames not written)"),
            "{}",
            camera_status("cam", 14.96, &s)
        );
    }

    #[test]
    fn compute_detector_acf_loads_its_model_and_refuses_the_other_kind() {
        use crate::detect::people::DetectorKind;
        use crate::features::hog::MosaicTone;
        let acf = concat!(env!("CARGO_MANIFEST_DIR"), "/models/acf-mosaic.json");
        let hog = concat!(env!("CARGO_MANIFEST_DIR"), "/models/mosaic.json");
        let load = |lines: &str| {
            let cfg = Config::from_toml_str(&format!(
                "[compute]\n{lines}\n[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n"
            ))
            .unwrap();
            load_detector(&cfg).map(|d| d.expect("compute.detect is on"))
        };
        let det = load(&format!("detector = \"acf\"\nacf_model = {acf:?}")).unwrap();
        assert_eq!(det.kind(), DetectorKind::Acf);
        assert_eq!(
            det.mosaic_tone(),
            MosaicTone::Srgb,
            "the shipped ACF model's tone"
        );
        let det = load(&format!(
            "detector = \"acf\"\nacf_model = {acf:?}\nmosaic_tone = \"linear\""
        ))
        .unwrap();
        assert_eq!(det.mosaic_tone(), MosaicTone::Linear);
        // compute.model is HOG's: an ACF file there is refused, and a HOG file in acf_model
        for (lines, key, what) in [
            (
                format!("detector = \"acf\"\nacf_model = {hog:?}"),
                "compute.acf_model",
                "is a HOG model, not an ACF model",
            ),
            (
                format!("model = {acf:?}"),
                "compute.model",
                "is an ACF model, not a HOG model",
            ),
            (
                "detector = \"acf\"\nacf_model = \"/no/such/acf.json\"".to_string(),
                "compute.acf_model",
                "/no/such/acf.json",
            ),
        ] {
            let e = load(&lines).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains(what), "{lines}: {e}");
        }
        // the ACF options: the config's, greedy suppression, the model's pyramid
        let cfg = Config::from_toml_str(
            "[compute]\nupsample = 2.0\nmax_levels = 9\nhit_threshold = -3.5\n[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n",
        )
        .unwrap();
        let o = acf_options(&cfg);
        assert_eq!(
            (o.upsample, o.max_levels, o.hit_threshold, o.approx),
            (2.0, 9, -3.5, None)
        );
        assert_eq!(o.nms, crate::detect::NmsMethod::Greedy { iou: 0.5 });
    }

    #[test]
    fn compute_mosaic_taps_reaches_the_detector() {
        crate::data::require(OPENCV_DEFAULT_MODEL);
        let taps = |line: &str| {
            let cfg = Config::from_toml_str(&format!(
                "[compute]\n{line}\n[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n"
            ))
            .unwrap();
            match &*load_detector(&cfg).unwrap().unwrap() {
                PeopleDetector::Hog(d) => d.model().mosaic_taps,
                PeopleDetector::Acf(_) => panic!("an ACF detector for a HOG model"),
            }
        };
        assert_eq!(taps(""), MosaicTaps::SameSite, "OpenCV's weights: same-site");
        assert_eq!(taps("mosaic_taps = \"model\""), MosaicTaps::SameSite);
        assert_eq!(taps("mosaic_taps = \"paper\""), MosaicTaps::Paper);
    }

    #[test]
    fn compute_mosaic_tone_and_wb_gains_reach_the_detector_and_the_stage() {
        use crate::features::hog::MosaicTone;
        use crate::raw::levels::Gains;
        crate::data::require(OPENCV_DEFAULT_MODEL);
        let cfg = |line: &str| {
            Config::from_toml_str(&format!(
                "[compute]\n{line}\n[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n"
            ))
            .unwrap()
        };
        let tone = |line: &str| load_detector(&cfg(line)).unwrap().unwrap().mosaic_tone();
        assert_eq!(tone(""), MosaicTone::Srgb, "the default built-in model: srgb");
        let opencv = "model = \"opencv-default\"";
        assert_eq!(tone(opencv), MosaicTone::Linear, "OpenCV's weights: linear");
        assert_eq!(
            tone(&format!("{opencv}\nmosaic_tone = \"srgb\"")),
            MosaicTone::Srgb
        );
        // the shipped srgb model says so itself
        let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/models/mosaic_raw_srgb.json");
        assert_eq!(tone(&format!("model = {shipped:?}")), MosaicTone::Srgb);
        assert_eq!(
            tone(&format!("model = {shipped:?}\nmosaic_tone = \"linear\"")),
            MosaicTone::Linear
        );
        assert_eq!(stage_spec(&cfg("")).wb_gains, Gains::Auto);
        assert_eq!(
            stage_spec(&cfg("wb_gains = \"2,1,1.5\"")).wb_gains,
            Gains::Fixed([2.0, 1.0, 1.5])
        );
    }
}
