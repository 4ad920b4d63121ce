//! The MCAP recorder ([`crate::record::McapRecorder`]) as a pipeline sink, on its own thread.
//!
//! Per processed frame: the detections as `foxglove.ImageAnnotations` and `mosaicd.Detections`
//! (log time = the frame's capture timestamp), the mosaic SIFT keypoints when `compute.keypoints`
//! is on, optionally the raw frame (lossless) and an 8-bit preview; stats as JSON on `/<camera>/stats` with wall-clock values grouped under `"wall"`
//! ([`super::sinks::stats_json`]; with `daemon.deterministic_outputs` only the final stats,
//! without that group: [`super::sinks::stats_record`]). Chunks are flushed every `record.flush_frames` frames, so a crash
//! loses at most that many; [`Sink::finish`] writes the summary and index. A write error (disk full)
//! stops this sink and is reported; detection and publishing go on.

use crate::config::{CameraConfig, Config};
use crate::publish::messages::StatsMsg;
use crate::record::{FlushPolicy, McapRecorder, PreviewOptions, RecorderOptions, RotatePolicy};

use super::daemon::DaemonError;
use super::engine::{FrameResult, Sink, SinkError, SinkFactory};
use super::sinks::stats_record;

/// The recorder sink.
pub struct McapSink {
    camera: String,
    recorder: McapRecorder,
    frames: bool,
    flush_every: u32,
    since_flush: u32,
    deterministic: bool,
}

/// The recorder sink of a camera (`record.path`, `{camera}` substituted). The file is created in
/// the sink thread at start-up, so a bad path stops the start with an error naming it.
pub fn recorder_sink(cfg: &Config, cam: &CameraConfig) -> Result<SinkFactory, DaemonError> {
    let path = cfg.record_path(&cam.name);
    let opts = RecorderOptions {
        camera: cam.name.clone(),
        // The sink flushes after each frame's results (below), so a chunk never ends between a
        // frame and its detections; the recorder's own cadence would cut after the raw frame.
        flush: FlushPolicy {
            every_frames: None,
            every_ns: None,
        },
        raw: cfg.record.frames,
        preview: (cfg.record.preview_decimation > 0).then_some(PreviewOptions {
            decimation: cfg.record.preview_decimation,
        }),
        keypoints: cfg.compute.keypoints,
        rotate: RotatePolicy::from_limits(Some(cfg.record.rotate_mb), Some(cfg.record.rotate_secs)),
        max_files: (cfg.record.max_files > 0).then_some(cfg.record.max_files),
        // A restart (systemd, crash) must not truncate the run before it.
        keep_existing: !cfg.record.overwrite,
        ..RecorderOptions::default()
    };
    let (camera, frames) = (
        cam.name.clone(),
        cfg.record.frames || cfg.record.preview_decimation > 0,
    );
    let flush_every = cfg.record.flush_frames;
    let deterministic = cfg.daemon.deterministic_outputs;
    Ok(Box::new(move || {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| SinkError::Start {
                sink: format!("mcap {}", path.display()),
                message: e.to_string(),
            })?;
        }
        let recorder = McapRecorder::create(&path, opts).map_err(|e| SinkError::Start {
            sink: format!("mcap {}", path.display()),
            message: e.to_string(),
        })?;
        Ok(Box::new(McapSink {
            camera,
            recorder,
            frames,
            flush_every,
            since_flush: 0,
            deterministic,
        }) as Box<dyn Sink>)
    }))
}

impl McapSink {
    fn err(&self, e: impl std::fmt::Display) -> SinkError {
        SinkError::Write {
            sink: self.name(),
            message: e.to_string(),
        }
    }
}

impl Sink for McapSink {
    fn name(&self) -> String {
        format!("mcap {:?}", self.recorder.files().last())
    }

    fn frame(&mut self, r: &FrameResult) -> Result<(), SinkError> {
        if self.frames {
            if let Some(f) = &r.frame {
                self.recorder.write_frame(f).map_err(|e| self.err(e))?;
            }
        }
        self.recorder
            .write_detections(
                r.meta.sequence,
                r.meta.timestamp_ns,
                r.width as u32,
                r.height as u32,
                &r.output.detections,
            )
            .map_err(|e| self.err(e))?;
        if let Some(k) = &r.output.keypoints {
            self.recorder
                .write_keypoints(r.meta.timestamp_ns, k)
                .map_err(|e| self.err(e))?;
        }
        // Flushed after the frame's results (the recorder has no cadence of its own here), so a
        // crash loses at most `record.flush_frames` frames, each with its results.
        self.since_flush += 1;
        if self.since_flush >= self.flush_every {
            self.since_flush = 0;
            self.recorder.flush().map_err(|e| self.err(e))?;
        }
        Ok(())
    }

    fn stats(&mut self, s: &StatsMsg) -> Result<(), SinkError> {
        let Some(v) = stats_record(&self.camera, s, self.deterministic) else {
            return Ok(());
        };
        self.recorder
            .write_stats(s.timestamp_ns, &v)
            .map_err(|e| self.err(e))
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        self.recorder.finish().map(|_| ()).map_err(|e| self.err(e))
    }
}
