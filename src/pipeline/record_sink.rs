//! The MCAP recorder (`crate::record`) as a pipeline sink: frames' detections as
//! `foxglove.ImageAnnotations` + `mosaicd.Detections`, and stats, on the sink's own thread.

use crate::config::{CameraConfig, Config};

use super::daemon::DaemonError;
use super::engine::{SinkError, SinkFactory};

/// The recorder sink of a camera (`record.path`, `{camera}` substituted).
pub fn recorder_sink(cfg: &Config, cam: &CameraConfig) -> Result<SinkFactory, DaemonError> {
    let path = cfg.record_path(&cam.name);
    Err(DaemonError::Sink {
        camera: cam.name.clone(),
        source: SinkError::Start {
            sink: format!("mcap {}", path.display()),
            message: "MCAP recording is not available in this build yet (set record.enabled = false)".into(),
        },
    })
}
