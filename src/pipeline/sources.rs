//! Opening the configured source of a camera.
//!
//! `synthetic` is built here; `mcap` and `v4l2` are `crate::capture`'s [`McapSource`] (as fast as
//! possible or at the recorded rate, looped) and [`V4l2Source`]. Errors name the camera and say
//! what is wrong (missing file or device, a recording or device that refuses to open).

use std::path::PathBuf;

use crate::capture::files::{FileSource, FileSourceOptions};
use crate::capture::synthetic::{SyntheticSource, SyntheticSpec};
use crate::capture::v4l2::{V4l2Options, V4l2Source};
use crate::capture::{McapSource, McapSourceOptions, Pacing, Source};
use crate::config::{CameraConfig, ConfigError, SourceType};
use crate::pool::BufferPool;
use crate::raw::RawPixels;

/// Errors opening a source.
#[derive(Debug, thiserror::Error)]
pub enum SourceOpenError {
    /// The recording does not exist.
    #[error("camera {camera:?}: recording {path} not found (config key `path`; build the default one with `make recording`)")]
    RecordingMissing {
        /// Camera name.
        camera: String,
        /// Path.
        path: PathBuf,
    },
    /// The device does not exist.
    #[error(
        "camera {camera:?}: device {path} does not exist (is the camera plugged in? config key `device`)"
    )]
    DeviceMissing {
        /// Camera name.
        camera: String,
        /// Path.
        path: PathBuf,
    },
    /// The source kind is not available in this build.
    #[error("camera {camera:?}: source {kind:?} is not available in this build")]
    Unsupported {
        /// Camera name.
        camera: String,
        /// The kind.
        kind: SourceType,
    },
    /// The source refused to open.
    #[error("camera {camera:?}: {message}")]
    Open {
        /// Camera name.
        camera: String,
        /// Cause.
        message: String,
    },
    /// Config problem found late.
    #[error(transparent)]
    Config(#[from] ConfigError),
}

/// Open the source a camera config describes. `replay_overrides` (realtime, loop) already applied.
pub(crate) fn open_source(
    cam: &CameraConfig,
    frame_pool: &BufferPool<RawPixels>,
) -> Result<Box<dyn Source>, SourceOpenError> {
    match cam.source {
        SourceType::Synthetic => Ok(Box::new(SyntheticSource::with_pool(
            SyntheticSpec {
                width: cam.width,
                height: cam.height,
                bit_depth: cam.bit_depth,
                cfa: cam.cfa,
                frames: cam.frames,
                fps: cam.fps,
                live: cam.live,
                wrong_size_at: None,
                name: cam.name.clone(),
            },
            frame_pool.clone(),
        ))),
        SourceType::Mcap => {
            let path = cam.path.clone().unwrap_or_default();
            if !path.exists() {
                return Err(SourceOpenError::RecordingMissing {
                    camera: cam.name.clone(),
                    path,
                });
            }
            let opts = McapSourceOptions {
                pacing: if cam.realtime {
                    Pacing::Recorded { speed: 1.0 }
                } else {
                    Pacing::AsFastAsPossible
                },
                looped: cam.looped,
                ..McapSourceOptions::default()
            };
            let src = McapSource::open(&path, opts).map_err(|e| SourceOpenError::Open {
                camera: cam.name.clone(),
                message: format!("recording {}: {e}", path.display()),
            })?;
            Ok(Box::new(src))
        }
        SourceType::Files => {
            let path = cam.path.clone().unwrap_or_default();
            let opts = FileSourceOptions {
                fps: cam.fps,
                pace: cam.realtime,
                looped: cam.looped,
                sidecar: cam.sidecar.clone(),
                ..FileSourceOptions::default()
            };
            let src =
                FileSource::open(std::slice::from_ref(&path), opts).map_err(|e| SourceOpenError::Open {
                    camera: cam.name.clone(),
                    message: format!("files {}: {e}", path.display()),
                })?;
            Ok(Box::new(src))
        }
        SourceType::V4l2 => {
            let path = cam.device.clone().unwrap_or_default();
            if !path.exists() {
                return Err(SourceOpenError::DeviceMissing {
                    camera: cam.name.clone(),
                    path,
                });
            }
            let opts = v4l2_options(cam);
            let src = V4l2Source::open(&path, opts).map_err(|e| SourceOpenError::Open {
                camera: cam.name.clone(),
                message: format!("device {}: {e}", path.display()),
            })?;
            Ok(Box::new(src))
        }
    }
}

/// The V4L2 request of a `[[camera]]`: size, rate, preferred FourCC and sensor levels.
pub(crate) fn v4l2_options(cam: &CameraConfig) -> V4l2Options {
    V4l2Options {
        width: Some(cam.width as u32),
        height: Some(cam.height as u32),
        fps: Some(cam.fps.round() as u32),
        fourcc: cam.fourcc,
        levels: cam.levels(),
        ..V4l2Options::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    #[test]
    fn a_v4l2_camera_s_fourcc_and_levels_reach_the_driver_request() {
        let c = Config::from_toml_str(
            "[[camera]]\nname = \"a\"\nsource = \"v4l2\"\ndevice = \"/dev/video0\"\nwidth = 1920\n\
             height = 1080\nfps = 29.97\nfourcc = \"pRAA\"\nblack = 64\nwhite = 1023\n",
        )
        .unwrap();
        let o = v4l2_options(&c.cameras[0]);
        assert_eq!((o.width, o.height, o.fps), (Some(1920), Some(1080), Some(30)));
        assert_eq!(o.fourcc, Some(*b"pRAA"));
        assert_eq!(o.levels, Some(crate::raw::Levels::uniform(64, 1023)));
    }
}
