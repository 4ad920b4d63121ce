//! The MCAP recorder ([`crate::record::McapRecorder`]) as a pipeline sink, on its own thread.
//!
//! Per processed frame: the detections as `foxglove.ImageAnnotations` and `mosaicd.Detections`
//! (log time = the frame's capture timestamp), the mosaic SIFT keypoints when `compute.keypoints`
//! is on (Foxglove points on `/<camera>/keypoints`, and full-frame keypoints with their
//! descriptors, when computed, as `mosaicd.SiftFeatures` on `/<camera>/sift`), optionally the raw frame (lossless) and an 8-bit preview; stats as JSON on `/<camera>/stats` with wall-clock values grouped under `"wall"`
//! ([`super::jsonl::stats_json`]; with `daemon.deterministic_outputs` only the final stats,
//! without that group: [`super::jsonl::stats_record`]). Chunks are flushed every `record.flush_frames` frames, so a crash
//! loses at most that many; [`Sink::finish`] writes the summary and index.
//!
//! A write error (disk full, I/O error) never stops detection or publishing. With
//! `record.retry_ms > 0` (default 30 s) and without `record.overwrite`, it pauses the recording:
//! the error is counted (`failed_sink`, once per outage) and logged, the frames that arrive
//! meanwhile are not recorded (counted in `sink_frames_lost`, with those of the chunk the error
//! cut, and in the log), and every `retry_ms` the sink tries again in a
//! new numbered file ([`McapRecorder::resume`]), until a write succeeds. The file that failed
//! stays as it was, cut at the failure. Otherwise the first error stops this sink for the run.

use std::time::{Duration, Instant};

use crate::clock::WallClockSource;
use crate::config::{CameraConfig, Config, SourceType};
use crate::record::{FlushPolicy, McapRecorder, PreviewOptions, RecorderOptions, RotatePolicy};
use crate::wire::messages::StatsMsg;

use super::jsonl::stats_record;
use super::{FrameResult, Sink, SinkError, SinkFactory};
use crate::pipeline::daemon::DaemonError;

/// The recorder sink.
pub(crate) struct McapSink {
    camera: String,
    recorder: McapRecorder,
    frames: bool,
    flush_every: u32,
    since_flush: u32,
    deterministic: bool,
    /// `record.retry_ms`, when the recorder can resume (`None`: the first error stops the sink).
    retry: Option<Duration>,
    /// While paused by a write error.
    outage: Option<Outage>,
    /// Frames not written in this run (every outage, and a stop): [`Sink::frames_not_written`].
    not_written: u64,
}

/// A recording paused by a write error.
#[derive(Debug)]
struct Outage {
    /// Next attempt.
    retry_at: Instant,
    /// Frames not recorded so far.
    frames_lost: u64,
    /// Attempts that failed again.
    failed_attempts: u64,
}

/// The camera's frames carry `CLOCK_MONOTONIC` timestamps: a V4L2 device, or a live synthetic
/// stream (recordings and files carry recorded time).
fn monotonic_timestamps(cam: &CameraConfig) -> bool {
    match cam.source {
        SourceType::V4l2 => true,
        SourceType::Synthetic => cam.live,
        SourceType::Mcap | SourceType::Files => false,
    }
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
        // A live camera's frames carry CLOCK_MONOTONIC time: each file records the wall clock.
        wall_clock: monotonic_timestamps(cam).then_some(WallClockSource::System),
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
    let retry_ms = cfg.record.retry_ms;
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
        let retry = (retry_ms > 0 && recorder.can_resume()).then(|| Duration::from_millis(retry_ms));
        Ok(Box::new(McapSink {
            camera,
            recorder,
            frames,
            flush_every,
            since_flush: 0,
            deterministic,
            retry,
            outage: None,
            not_written: 0,
        }) as Box<dyn Sink>)
    }))
}

impl McapSink {
    /// After a successful write: end the outage, if any.
    fn written(&mut self) {
        if let Some(o) = self.outage.take() {
            tracing::info!(
                camera = %self.camera,
                file = %self.recorder.files().last().map(|p| p.display().to_string()).unwrap_or_default(),
                frames_not_recorded = o.frames_lost,
                failed_attempts = o.failed_attempts,
                "recording resumed in a new file"
            );
        }
    }

    /// A write failed: stop (no retry), start an outage (counted once, by the engine), or note
    /// a failed attempt.
    fn failed(&mut self, e: impl std::fmt::Display) -> Result<(), SinkError> {
        // Only a write error (the recorder stopped) pauses; anything else stops the sink.
        let Some(retry) = self.retry.filter(|_| self.recorder.is_failed()) else {
            return Err(SinkError::Write {
                sink: self.name(),
                message: e.to_string(),
            });
        };
        let retry_at = Instant::now() + retry;
        match &mut self.outage {
            Some(o) => {
                o.retry_at = retry_at;
                o.failed_attempts += 1;
                tracing::warn!(
                    camera = %self.camera,
                    frames_not_recorded = o.frames_lost,
                    "recording: still failing ({e}); next attempt in {} ms",
                    retry.as_millis()
                );
                Ok(())
            }
            None => {
                self.outage = Some(Outage {
                    retry_at,
                    frames_lost: 0,
                    failed_attempts: 0,
                });
                Err(SinkError::Interrupted {
                    sink: self.name(),
                    message: format!(
                        "{e}; recording paused (detection and publishing go on), trying a new file every {} ms",
                        retry.as_millis()
                    ),
                })
            }
        }
    }

    /// [`McapSink::failed`], counting the frames not flushed before the error (the one being
    /// written included) as not written: they are lost with their chunk. An upper bound: MCAP
    /// also closes a chunk on its own once it reaches 8 MiB (with raw frames recorded, every few
    /// frames), and such a chunk may have reached the disk whole.
    fn failed_unflushed(&mut self, e: impl std::fmt::Display) -> Result<(), SinkError> {
        let unflushed = std::mem::take(&mut self.since_flush) as u64;
        self.not_written += unflushed;
        let r = self.failed(e);
        if let Some(o) = &mut self.outage {
            o.frames_lost += unflushed;
        }
        r
    }

    fn write_frame(&mut self, r: &FrameResult) -> Result<(), crate::record::RecordError> {
        // Unflushed from here on: an error before the next flush loses it.
        self.since_flush += 1;
        // (the recorder's file list only grows while it writes, so its length tells a rotation
        // without cloning a path per frame)
        let files = self.recorder.files().len();
        let written = self.write_frame_results(r);
        if self.recorder.files().len() != files {
            // the recorder rotated to a new file: the frames before this one went with the old
            // file, finished and complete
            self.since_flush = 1;
        }
        written?;
        // Flushed after the frame's results (the recorder has no cadence of its own here), so a
        // crash loses at most `record.flush_frames` frames, each with its results.
        if self.since_flush >= self.flush_every {
            self.flush()?;
        }
        Ok(())
    }

    /// The records of one frame (raw frame and preview if recorded, detections, keypoints).
    fn write_frame_results(&mut self, r: &FrameResult) -> Result<(), crate::record::RecordError> {
        if self.frames {
            if let Some(f) = &r.frame {
                self.recorder.write_frame(f)?;
            }
        }
        self.recorder.write_detections(
            r.meta.sequence,
            r.meta.timestamp_ns,
            r.width as u32,
            r.height as u32,
            &r.output.detections,
        )?;
        if let Some(k) = &r.output.keypoints {
            // The SIFT message first: its one refusal (descriptors that do not pair with the
            // keypoints, which the stage never produces) then leaves no keypoint channel written.
            self.recorder.write_sift(
                r.meta.sequence,
                r.meta.timestamp_ns,
                r.width as u32,
                r.height as u32,
                k,
                r.output.descriptors.as_deref(),
            )?;
            self.recorder.write_keypoints(r.meta.timestamp_ns, k)?;
        }
        Ok(())
    }

    /// Close the chunk and write it out; nothing is unflushed after it.
    fn flush(&mut self) -> Result<(), crate::record::RecordError> {
        self.recorder.flush()?;
        self.since_flush = 0;
        Ok(())
    }
}

impl Sink for McapSink {
    fn name(&self) -> String {
        format!("mcap {:?}", self.recorder.files().last())
    }

    fn frame(&mut self, r: &FrameResult) -> Result<(), SinkError> {
        let attempt = match &mut self.outage {
            None => false,
            Some(o) if Instant::now() < o.retry_at => {
                o.frames_lost += 1;
                self.not_written += 1;
                return Ok(());
            }
            Some(_) => self.recorder.resume(),
        };
        let mut written = self.write_frame(r);
        if attempt && written.is_ok() {
            // Buffers take writes on a full disk too: only a flush that reached the new file
            // ends the outage.
            written = self.flush();
        }
        match written {
            Ok(()) => {
                self.written();
                Ok(())
            }
            // this frame and those not flushed before it are not (readably) in any file
            Err(e) => self.failed_unflushed(e),
        }
    }

    fn frames_not_written(&self) -> u64 {
        self.not_written
    }

    fn recorder_state(&self) -> Option<crate::pipeline::stats::RecorderState> {
        use crate::pipeline::stats::RecorderState;
        Some(if self.outage.is_some() {
            RecorderState::Paused
        } else {
            RecorderState::Recording
        })
    }

    fn stats(&mut self, s: &StatsMsg) -> Result<(), SinkError> {
        if self.outage.is_some() {
            return Ok(()); // frames make the attempts (a flush tells whether one worked)
        }
        let Some(v) = stats_record(&self.camera, s, self.deterministic) else {
            return Ok(());
        };
        match self.recorder.write_stats(s.timestamp_ns, &v) {
            Ok(()) => {
                self.written();
                Ok(())
            }
            Err(e) => self.failed_unflushed(e),
        }
    }

    fn reopen(&mut self) -> Result<(), SinkError> {
        if self.outage.is_some() {
            return Ok(()); // the next attempt opens a new file anyway
        }
        let closed = self.recorder.files().last().cloned();
        match self.recorder.start_new_file() {
            Ok(true) => {
                // the file was finished with everything written to it
                self.since_flush = 0;
                tracing::info!(
                    camera = %self.camera,
                    file = %closed.map(|p| p.display().to_string()).unwrap_or_default(),
                    "recording file finished; the next frame starts a new one"
                );
                Ok(())
            }
            Ok(false) => {
                tracing::info!(
                    camera = %self.camera,
                    "no new recording file: none is open (the next frame starts one), or \
                     record.overwrite without rotation would truncate it"
                );
                Ok(())
            }
            Err(e) => self.failed_unflushed(e),
        }
    }

    fn finish(&mut self) -> Result<(), SinkError> {
        if let Some(o) = &self.outage {
            // Still paused at the end: the files written are complete up to the failure; a
            // last attempt's file that holds nothing goes.
            self.recorder.discard_empty_failed_file();
            tracing::warn!(
                camera = %self.camera,
                frames_not_recorded = o.frames_lost,
                "recording was still paused by a write error at the end"
            );
            return Ok(());
        }
        self.recorder.finish().map(|_| ()).map_err(|e| {
            // the frames of the last, unflushed chunk are not (readably) in the file
            self.not_written += std::mem::take(&mut self.since_flush) as u64;
            SinkError::Write {
                sink: self.name(),
                message: e.to_string(),
            }
        })
    }
}
