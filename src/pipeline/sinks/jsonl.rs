//! Sinks that live in the pipeline module: a deterministic JSON-lines results file and an
//! in-memory collector for tests.
//!
//! The results file has one line per processed frame (index, sequence, timestamps, size, mean
//! gradient magnitude, boxes, keypoints when `compute.keypoints` is on and their descriptors when
//! `compute.keypoint_descriptors` is) and the final stats. Wall-clock fields are grouped under the key
//! `"wall"` so a comparison can drop them; everything else is a function of the input alone, so
//! replaying a recording gives a byte-identical file for any thread count once `"wall"` is removed
//! ([`strip_wall_clock`]), or at once with `daemon.deterministic_outputs` (the default of
//! `mosaicd replay`), which leaves the group and the timer-driven stats records out of the file.

use std::io::Write;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use serde_json::json;

use super::{FrameResult, Sink, SinkError, SinkFactory};
use crate::wire::messages::StatsMsg;

/// Key under which wall-clock (non-deterministic) values are grouped.
pub(crate) const WALL_KEY: &str = "wall";

/// The JSON record of one frame (`"keypoints"` only when the stage computes them, `"descriptors"`
/// only when it computes those: base64, one per keypoint, same order).
pub(crate) fn frame_json(r: &FrameResult) -> serde_json::Value {
    let mut v = json!({
        "type": "frame",
        "camera": &*r.camera,
        "index": r.index,
        "sequence": r.meta.sequence,
        "sensor_sequence": r.meta.sensor_sequence,
        "capture_timestamp_ns": r.meta.timestamp_ns,
        "publish_timestamp_ns": r.publish_timestamp_ns,
        "width": r.width,
        "height": r.height,
        "mean_magnitude": r.output.mean_magnitude,
        "detections": r.output.detections,
        WALL_KEY: { "latency_ns": r.latency_ns },
    });
    if let Some(k) = &r.output.keypoints {
        v["keypoints"] = json!(k);
    }
    if let Some(d) = &r.output.descriptors {
        v["descriptors"] = descriptors_json(d);
    }
    v
}

/// SIFT descriptors as a JSON array of base64 strings (128 bytes each, standard padded base64:
/// the encoding Foxglove's JSON schemas use for bytes), one per keypoint.
pub fn descriptors_json(d: &[[u8; crate::features::sift::DESCRIPTOR_LEN]]) -> serde_json::Value {
    json!(crate::wire::schema::descriptors_base64(d))
}

/// The JSON record of a stats message.
pub(crate) fn stats_json(camera: &str, s: &StatsMsg) -> serde_json::Value {
    json!({
        "type": if s.is_final != 0 { "final_stats" } else { "stats" },
        "camera": camera,
        "timestamp_ns": s.timestamp_ns,
        "captured": s.captured,
        "processed": s.processed,
        "dropped_queue_full": s.dropped_queue_full,
        "dropped_driver": s.dropped_driver,
        "failed_source": s.failed_source,
        "failed_compute": s.failed_compute,
        "failed_sink": s.failed_sink,
        "sink_frames_lost": s.sink_frames_lost,
        "detections": s.detections,
        "box_overflow": s.box_overflow,
        WALL_KEY: { "fps": s.fps, "latency_p50_us": s.latency_p50_us, "latency_p99_us": s.latency_p99_us },
    })
}

/// A stats record as an output file stores it: `None` for a timer-driven (periodic) record when
/// `deterministic`, and the final record without its `"wall"` group.
pub(crate) fn stats_record(camera: &str, s: &StatsMsg, deterministic: bool) -> Option<serde_json::Value> {
    if deterministic && s.is_final == 0 {
        return None;
    }
    let mut v = stats_json(camera, s);
    if deterministic {
        drop_wall(&mut v);
    }
    Some(v)
}

/// Remove a record's wall-clock group.
fn drop_wall(v: &mut serde_json::Value) {
    if let Some(o) = v.as_object_mut() {
        o.remove(WALL_KEY);
    }
}

/// Remove the wall-clock group from a JSON-lines text, and periodic (timer-driven) stats lines,
/// leaving only what must be deterministic.
pub fn strip_wall_clock(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let Ok(mut v) = serde_json::from_str::<serde_json::Value>(line) else {
            out.push_str(line);
            out.push('\n');
            continue;
        };
        if v["type"] == "stats" {
            continue;
        }
        drop_wall(&mut v);
        out.push_str(&v.to_string());
        out.push('\n');
    }
    out
}

/// Writes results as JSON lines to a file.
pub(crate) struct JsonlSink {
    camera: String,
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    deterministic: bool,
}

impl JsonlSink {
    /// A factory for the pipeline (the file is created in the sink thread). `deterministic`
    /// leaves wall-clock values out (`daemon.deterministic_outputs`).
    pub(crate) fn factory(camera: &str, path: PathBuf, deterministic: bool) -> SinkFactory {
        let camera = camera.to_string();
        Box::new(move || {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| start_err(&path, e))?;
            }
            let f = std::fs::File::create(&path).map_err(|e| start_err(&path, e))?;
            Ok(Box::new(JsonlSink {
                camera,
                path,
                out: std::io::BufWriter::new(f),
                deterministic,
            }) as Box<dyn Sink>)
        })
    }

    fn write(&mut self, v: serde_json::Value) -> Result<(), SinkError> {
        writeln!(self.out, "{v}").map_err(|e| SinkError::Write {
            sink: self.name(),
            message: e.to_string(),
        })
    }
}

fn start_err(path: &std::path::Path, e: std::io::Error) -> SinkError {
    SinkError::Start {
        sink: format!("jsonl {}", path.display()),
        message: e.to_string(),
    }
}

impl Sink for JsonlSink {
    fn name(&self) -> String {
        format!("jsonl {}", self.path.display())
    }
    fn frame(&mut self, r: &FrameResult) -> Result<(), SinkError> {
        let mut v = frame_json(r);
        if self.deterministic {
            drop_wall(&mut v);
        }
        self.write(v)
    }
    fn stats(&mut self, s: &StatsMsg) -> Result<(), SinkError> {
        match stats_record(&self.camera, s, self.deterministic) {
            Some(v) => self.write(v),
            None => Ok(()),
        }
    }
    fn finish(&mut self) -> Result<(), SinkError> {
        self.out.flush().map_err(|e| SinkError::Write {
            sink: self.name(),
            message: e.to_string(),
        })
    }
}

/// Collects JSON records in memory (tests).
#[derive(Clone, Default)]
pub struct CollectSink {
    /// The records, in arrival order.
    pub records: Arc<Mutex<Vec<serde_json::Value>>>,
}

impl CollectSink {
    /// A factory that appends to `self.records`.
    pub fn factory(&self, camera: &str) -> SinkFactory {
        let (me, camera) = (self.clone(), camera.to_string());
        Box::new(move || Ok(Box::new(Collector { me, camera }) as Box<dyn Sink>))
    }

    /// The records so far.
    pub fn take(&self) -> Vec<serde_json::Value> {
        std::mem::take(&mut *self.records.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

struct Collector {
    me: CollectSink,
    camera: String,
}

impl Sink for Collector {
    fn name(&self) -> String {
        "collect".into()
    }
    fn frame(&mut self, r: &FrameResult) -> Result<(), SinkError> {
        self.me
            .records
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(frame_json(r));
        Ok(())
    }
    fn stats(&mut self, s: &StatsMsg) -> Result<(), SinkError> {
        let v = stats_json(&self.camera, s);
        self.me.records.lock().unwrap_or_else(|e| e.into_inner()).push(v);
        Ok(())
    }
    fn finish(&mut self) -> Result<(), SinkError> {
        Ok(())
    }
}
