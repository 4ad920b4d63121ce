//! Typed daemon configuration, validated once at start-up.
//!
//! The daemon reads one TOML file (`config/mosaicd.toml` by default; every key is documented
//! there). Parsing is strict: an unknown key is refused, a value of the wrong type is refused with
//! its key, a key written as a string that names something typed (`camera.cfa`,
//! `camera.fourcc`, `compute.detector`, `compute.svm`, `compute.mosaic_taps`,
//! `compute.mosaic_tone`, `compute.wb_gains`, `foxglove.listen`) is parsed into its type once,
//! when the file is read, and [`Config::validate`] checks every range and every rule between
//! keys once, at start-up. Each error NAMES the key, the value and what is allowed
//! ([`ConfigError`]). Nothing downstream re-checks or re-parses: the fields hold typed values.
//!
//! **Relative paths in a file** ([`Config::load`], [`Config::resolve_paths`]) never depend on the
//! working directory for inputs: a model file (`compute.model`) is looked for in the config
//! file's directory, then in [`SYSTEM_MODEL_DIR`] (`/usr/share/mosaicd/models`, where the Debian
//! package installs the model files); a camera's recording or raw files (`camera.path`) and
//! `camera.sidecar` resolve against the config file's directory. Outputs (`record.path`,
//! `metrics.textfile`) stay relative to the working directory, which the systemd units set to
//! the state directory (`/var/lib/mosaicd`). Built-in model names are not paths.
//!
//! ```
//! use mosaicd::config::Config;
//! let cfg = Config::from_toml_str(r#"
//!     [daemon]
//!     threads = 2
//!     [[camera]]
//!     name = "front"
//!     source = "synthetic"
//!     width = 64
//!     height = 48
//!     frames = 4
//! "#).unwrap();
//! assert_eq!(cfg.daemon.threads, 2);
//! assert_eq!(cfg.cameras[0].name, "front");
//!
//! let err = Config::from_toml_str("[daemon]\nthreads = 0\n[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n")
//!     .unwrap_err();
//! assert!(err.to_string().contains("daemon.threads"));
//! ```
//!
//! # Layout
//!
//! This file holds [`Config`], loading, path resolution and [`Config::validate`]; one file per
//! section below it, importing nothing from it: `daemon` (`[daemon]`, `[limits]`, `[metrics]`),
//! `publish` (`[publish]`, `[foxglove]`), `record`, `compute`, `camera`, `error`
//! ([`ConfigError`]), and `value` (how the typed string keys are read and written, and how a
//! refused one's error finds its key).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::detect::people::DetectorKind;

mod camera;
mod compute;
mod daemon;
mod error;
mod publish;
mod record;
mod value;

pub use camera::{CameraConfig, SourceType};
pub use compute::{ComputeConfig, DEFAULT_ACF_MODEL};
pub use daemon::{DaemonConfig, LimitsConfig, MetricsConfig};
pub use error::ConfigError;
pub use publish::{FoxgloveConfig, Iox2Root, PublishConfig, AUTO_ROOT};
pub use record::RecordConfig;
pub use value::SvmSetting;

/// Largest worker pool we accept (a sanity bound, not a tuning hint).
const MAX_THREADS: usize = 256;
/// Largest number of frames computed concurrently.
const MAX_IN_FLIGHT: usize = 64;
/// Largest capture queue depth.
const MAX_QUEUE_DEPTH: usize = 1024;
/// Longest stop timeout we accept, in milliseconds (systemd's default `TimeoutStopSec` is 90 s).
const MAX_SHUTDOWN_TIMEOUT_MS: u64 = 90_000;
/// Shortest stats interval, in milliseconds.
const MIN_STATS_INTERVAL_MS: u64 = 50;
/// Largest subscriber buffer (samples held per subscriber before the oldest is overwritten).
const MAX_SUBSCRIBER_BUFFER: usize = 4096;
/// Largest frame side we accept from a config (16 k pixels: the frame-size limit's side).
const MAX_SIDE: usize = crate::raw::limits::MAX_SIDE;
/// Allowed characters in a camera name (it becomes part of iceoryx2 service names).
const NAME_CHARS: &str = "a-z, A-Z, 0-9, '_', '-'";

/// Where a relative model file is looked for after the config file's directory: the model
/// files the Debian package installs.
pub const SYSTEM_MODEL_DIR: &str = "/usr/share/mosaicd/models";

/// The whole configuration.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Scheduling and process settings (`[daemon]`).
    #[serde(default)]
    pub daemon: DaemonConfig,
    /// iceoryx2 publishing (`[publish]`).
    #[serde(default)]
    pub publish: PublishConfig,
    /// MCAP recording of results (`[record]`).
    #[serde(default)]
    pub record: RecordConfig,
    /// Per-frame compute (`[compute]`).
    #[serde(default)]
    pub compute: ComputeConfig,
    /// Limits on what inputs may claim (`[limits]`).
    #[serde(default)]
    pub limits: LimitsConfig,
    /// Prometheus metrics through node_exporter's textfile collector (`[metrics]`).
    #[serde(default)]
    pub metrics: MetricsConfig,
    /// Live view in Foxglove over a WebSocket (`[foxglove]`, off by default).
    #[serde(default)]
    pub foxglove: FoxgloveConfig,
    /// One entry per camera (`[[camera]]`); at least one.
    #[serde(default, rename = "camera")]
    pub cameras: Vec<CameraConfig>,
}

/// One relative input path of a config file and where it was resolved ([`Config::resolve_paths`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ResolvedPath {
    /// Dotted key, e.g. `compute.model` or `camera[0].path`.
    pub key: String,
    /// The value in the file.
    pub given: PathBuf,
    /// The absolute path used.
    pub resolved: PathBuf,
    /// Every place looked at, in order (`resolved` is the first that exists, else the first).
    pub tried: Vec<PathBuf>,
}

impl ResolvedPath {
    /// Whether `resolved` exists.
    pub fn exists(&self) -> bool {
        self.resolved.exists()
    }
}

fn range<T: PartialOrd + std::fmt::Display>(key: &str, v: T, lo: T, hi: T) -> Result<(), ConfigError> {
    if v < lo || v > hi {
        return Err(ConfigError::OutOfRange {
            key: key.into(),
            value: v.to_string(),
            allowed: format!("{lo}..={hi}"),
        });
    }
    Ok(())
}

impl Config {
    /// Parse and validate a TOML string.
    pub fn from_toml_str(s: &str) -> Result<Self, ConfigError> {
        Self::parse(s, "<string>")
    }

    /// Read, parse and validate a file, then resolve its relative input paths
    /// ([`Config::resolve_paths`] against the file's directory and [`SYSTEM_MODEL_DIR`]).
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        Self::load_resolved(path).map(|(cfg, _)| cfg)
    }

    /// [`Config::load`], also returning how each relative input path was resolved.
    pub fn load_resolved(path: &Path) -> Result<(Self, Vec<ResolvedPath>), ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let mut cfg = Self::parse(&text, &path.display().to_string())?;
        let dir = std::path::absolute(path)
            .map_err(|source| ConfigError::Read {
                path: path.to_path_buf(),
                source,
            })?
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("/"));
        let resolved = cfg.resolve_paths(&dir, &[PathBuf::from(SYSTEM_MODEL_DIR)]);
        Ok((cfg, resolved))
    }

    /// Makes the relative input paths absolute: the detector's model (`compute.model` when it is
    /// a file, not a built-in name; `compute.acf_model` with `compute.detector = "acf"`) becomes
    /// the first of `config_dir/model`, `model_dirs[i]/model` that is a file (or
    /// `config_dir/model` when none is, so that the error names it), `camera.path` and
    /// `camera.sidecar` become `config_dir/path`. Returns what it changed, in key order.
    pub fn resolve_paths(&mut self, config_dir: &Path, model_dirs: &[PathBuf]) -> Vec<ResolvedPath> {
        let mut out = Vec::new();
        let acf = self.compute.detector == DetectorKind::Acf;
        let (key, model) = if acf {
            ("compute.acf_model", &mut self.compute.acf_model)
        } else {
            ("compute.model", &mut self.compute.model)
        };
        let is_name = !acf
            && (crate::detect::shipped::shipped(model).is_some() || model == crate::detect::OPENCV_DEFAULT);
        if !is_name && Path::new(model.as_str()).is_relative() && !model.is_empty() {
            let tried: Vec<PathBuf> = std::iter::once(config_dir)
                .chain(model_dirs.iter().map(PathBuf::as_path))
                .map(|d| d.join(model.as_str()))
                .collect();
            let found = tried.iter().find(|p| p.is_file()).cloned();
            let resolved = found.clone().unwrap_or_else(|| tried[0].clone());
            out.push(ResolvedPath {
                key: key.into(),
                given: PathBuf::from(model.as_str()),
                resolved: resolved.clone(),
                tried,
            });
            *model = resolved.to_string_lossy().into_owned();
        }
        for (i, cam) in self.cameras.iter_mut().enumerate() {
            for (k, slot) in [("path", &mut cam.path), ("sidecar", &mut cam.sidecar)] {
                if let Some(p) = slot.as_mut().filter(|p| p.is_relative()) {
                    let resolved = config_dir.join(&*p);
                    out.push(ResolvedPath {
                        key: format!("camera[{i}].{k}"),
                        given: std::mem::replace(p, resolved.clone()),
                        tried: vec![resolved.clone()],
                        resolved,
                    });
                }
            }
        }
        out
    }

    fn parse(s: &str, origin: &str) -> Result<Self, ConfigError> {
        let cfg: Config = toml::from_str(s).map_err(|e| ConfigError::from_toml(s, origin, &e))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Check every value once. Call again after applying CLI overrides.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let d = &self.daemon;
        range("daemon.threads", d.threads, 1, MAX_THREADS)?;
        range("daemon.max_in_flight", d.max_in_flight, 1, MAX_IN_FLIGHT)?;
        range("daemon.queue_depth", d.queue_depth, 1, MAX_QUEUE_DEPTH)?;
        range(
            "daemon.stats_interval_ms",
            d.stats_interval_ms,
            MIN_STATS_INTERVAL_MS,
            3_600_000,
        )?;
        range(
            "daemon.shutdown_timeout_ms",
            d.shutdown_timeout_ms,
            1,
            MAX_SHUTDOWN_TIMEOUT_MS,
        )?;
        range(
            "limits.max_frame_pixels",
            self.limits.max_frame_pixels,
            4,
            crate::raw::limits::MAX_MAX_PIXELS,
        )?;
        let p = &self.publish;
        range(
            "publish.subscriber_buffer",
            p.subscriber_buffer,
            1,
            MAX_SUBSCRIBER_BUFFER,
        )?;
        range("publish.gradients_decimation", p.gradients_decimation, 1, 64)?;
        if !valid_name(&p.service_prefix) {
            return Err(ConfigError::OutOfRange {
                key: "publish.service_prefix".into(),
                value: format!("{:?}", p.service_prefix),
                allowed: format!("1..=64 characters from {NAME_CHARS}"),
            });
        }
        if let Iox2Root::Path(root) = &p.root {
            if !root.is_absolute() {
                return Err(ConfigError::OutOfRange {
                    key: "publish.root".into(),
                    value: format!("{root:?}"),
                    allowed: format!("{AUTO_ROOT:?} or an absolute path"),
                });
            }
        }
        range("record.preview_decimation", self.record.preview_decimation, 0, 16)?;
        range("record.flush_frames", self.record.flush_frames, 1, 10_000)?;
        range("record.rotate_mb", self.record.rotate_mb, 0, 1 << 20)?;
        range("record.rotate_secs", self.record.rotate_secs, 0, 31_536_000)?;
        range("record.max_files", self.record.max_files, 0, 1_000_000)?;
        range("record.retry_ms", self.record.retry_ms, 0, 86_400_000)?;
        range(
            "foxglove.preview_decimation",
            self.foxglove.preview_decimation,
            1,
            16,
        )?;
        range("foxglove.client_backlog", self.foxglove.client_backlog, 4, 4096)?;
        if self.record.max_files > 0
            && (self.record.overwrite || self.record.rotate_mb == 0 && self.record.rotate_secs == 0)
        {
            return Err(ConfigError::OutOfRange {
                key: "record.max_files".into(),
                value: self.record.max_files.to_string(),
                allowed:
                    "0 unless record.rotate_mb or record.rotate_secs is set, and not with record.overwrite"
                        .into(),
            });
        }
        if self.record.enabled
            && self.cameras.len() > 1
            && !self.record.path.to_string_lossy().contains("{camera}")
        {
            return Err(ConfigError::OutOfRange {
                key: "record.path".into(),
                value: format!("{:?}", self.record.path.display().to_string()),
                allowed: "a path containing {camera} when more than one camera records".into(),
            });
        }
        if let Some(t) = &self.metrics.textfile {
            if t.extension().is_none_or(|e| e != "prom") || t.file_stem().is_none_or(|s| s.is_empty()) {
                return Err(ConfigError::OutOfRange {
                    key: "metrics.textfile".into(),
                    value: format!("{:?}", t.display().to_string()),
                    allowed:
                        "a file name ending in .prom (node_exporter's textfile collector reads only those)"
                            .into(),
                });
            }
        }
        let c = &self.compute;
        range("compute.orientation_bins", c.orientation_bins, 1, 36)?;
        range("compute.strip_rows", c.strip_rows, 2, 4096)?;
        // ACF scores are sums over up to thousands of trees: a wider scale than the SVM's.
        let hit = match c.detector {
            DetectorKind::Hog => 10.0,
            DetectorKind::Acf => 100.0,
        };
        range("compute.hit_threshold", c.hit_threshold, -hit, hit)?;
        range("compute.scale_step", c.scale_step, 1.01, 2.0)?;
        range("compute.max_levels", c.max_levels, 1, 64)?;
        range("compute.upsample", c.upsample, 1.0, 4.0)?;
        range("compute.approx_levels", c.approx_levels, 1, 64)?;
        let (model_key, model) = c.model_key();
        for (key, on) in [
            ("compute.keypoint_descriptors", c.keypoint_descriptors),
            ("compute.keypoints_double", c.keypoints_double),
        ] {
            if on && !c.keypoints {
                return Err(ConfigError::OutOfRange {
                    key: key.into(),
                    value: "true".into(),
                    allowed: "false unless compute.keypoints = true (it qualifies the keypoint stage)".into(),
                });
            }
        }
        if model.is_empty() {
            return Err(ConfigError::Missing {
                key: model_key.into(),
                when: format!(
                    "compute.detect = true and compute.detector = {:?}",
                    c.detector.name()
                ),
            });
        }
        if !c.strip_rows.is_multiple_of(2) {
            return Err(ConfigError::OutOfRange {
                key: "compute.strip_rows".into(),
                value: c.strip_rows.to_string(),
                allowed: "an even number in 2..=4096 (strips keep the 2x2 phase)".into(),
            });
        }
        if self.cameras.is_empty() {
            return Err(ConfigError::Missing {
                key: "camera".into(),
                when: "the daemon starts (add at least one [[camera]] table)".into(),
            });
        }
        for (i, cam) in self.cameras.iter().enumerate() {
            let key = |k: &str| format!("camera[{i}].{k}");
            if !valid_name(&cam.name) {
                return Err(ConfigError::OutOfRange {
                    key: key("name"),
                    value: format!("{:?}", cam.name),
                    allowed: format!("1..=64 characters from {NAME_CHARS}"),
                });
            }
            if self.cameras[..i].iter().any(|c| c.name == cam.name) {
                return Err(ConfigError::DuplicateCamera {
                    index: i,
                    name: cam.name.clone(),
                });
            }
            for (k, v) in [("width", cam.width), ("height", cam.height)] {
                range(&key(k), v, 2, MAX_SIDE)?;
                if v % 2 != 0 {
                    return Err(ConfigError::OutOfRange {
                        key: key(k),
                        value: v.to_string(),
                        allowed: format!("an even number in 2..={MAX_SIDE} (whole 2x2 tiles)"),
                    });
                }
            }
            let pixels = (cam.width as u64).saturating_mul(cam.height as u64);
            if pixels > self.limits.max_frame_pixels {
                return Err(ConfigError::OutOfRange {
                    key: key("width"),
                    value: format!("{} (x height {} = {pixels} pixels)", cam.width, cam.height),
                    allowed: format!(
                        "at most limits.max_frame_pixels = {} pixels in all",
                        self.limits.max_frame_pixels
                    ),
                });
            }
            range(&key("bit_depth"), cam.bit_depth, 8, 16)?;
            if !(cam.fps > 0.0 && cam.fps <= 1000.0) {
                return Err(ConfigError::OutOfRange {
                    key: key("fps"),
                    value: cam.fps.to_string(),
                    allowed: "0 < fps <= 1000".into(),
                });
            }
            match cam.source {
                SourceType::Mcap | SourceType::Files if cam.path.is_none() => {
                    return Err(ConfigError::Missing {
                        key: key("path"),
                        when: format!("source = {:?}", cam.source.name()),
                    })
                }
                SourceType::V4l2 if cam.device.is_none() => {
                    return Err(ConfigError::Missing {
                        key: key("device"),
                        when: "source = \"v4l2\"".into(),
                    })
                }
                _ => {}
            }
            let v4l2_only = [
                (
                    "fourcc",
                    cam.fourcc.map(|f| format!("{:?}", value::fourcc_text(f))),
                ),
                ("black", cam.black.map(|v| v.to_string())),
                ("white", cam.white.map(|v| v.to_string())),
            ];
            if cam.source != SourceType::V4l2 {
                if let Some((k, Some(v))) = v4l2_only.iter().find(|(_, v)| v.is_some()) {
                    return Err(ConfigError::OutOfRange {
                        key: key(k),
                        value: v.clone(),
                        allowed:
                            "only with source = \"v4l2\" (recordings and synthetic streams carry their own)"
                                .into(),
                    });
                }
            }
            if let (Some(s), true) = (&cam.sidecar, cam.source != SourceType::Files) {
                return Err(ConfigError::OutOfRange {
                    key: key("sidecar"),
                    value: format!("{:?}", s.display().to_string()),
                    allowed: "only with source = \"files\"".into(),
                });
            }
            match (cam.black, cam.white) {
                (Some(_), None) => {
                    return Err(ConfigError::Missing {
                        key: key("white"),
                        when: format!("{} is set", key("black")),
                    })
                }
                (b, Some(w)) if w == 0 || b.is_some_and(|b| b >= w) => {
                    return Err(ConfigError::OutOfRange {
                        key: key("white"),
                        value: w.to_string(),
                        allowed: format!("1..=65535, above black ({})", b.unwrap_or(0)),
                    })
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// The recording path for a camera (`{camera}` substituted).
    pub fn record_path(&self, camera: &str) -> PathBuf {
        PathBuf::from(self.record.path.to_string_lossy().replace("{camera}", camera))
    }
}

fn valid_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 64
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::ScorePrecision;
    use crate::features::hog::{MosaicTaps, MosaicTone};
    use crate::raw::levels::Gains;
    use crate::raw::Cfa;

    const MIN: &str = "[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n";

    #[test]
    fn v4l2_cameras_take_a_fourcc_and_sensor_levels_and_others_refuse_them() {
        let v4l2 = "[[camera]]\nname = \"a\"\nsource = \"v4l2\"\ndevice = \"/dev/video0\"\n";
        let c =
            Config::from_toml_str(&format!("{v4l2}fourcc = \"pRAA\"\nblack = 64\nwhite = 1023\n")).unwrap();
        let cam = &c.cameras[0];
        assert_eq!(cam.fourcc, Some(*b"pRAA"));
        assert_eq!(cam.levels(), Some(crate::raw::Levels::uniform(64, 1023)));
        let c = Config::from_toml_str(&format!("{v4l2}white = 4095\n")).unwrap();
        assert_eq!(c.cameras[0].levels(), Some(crate::raw::Levels::uniform(0, 4095)));
        let c = Config::from_toml_str(v4l2).unwrap();
        assert_eq!((c.cameras[0].levels(), c.cameras[0].fourcc), (None, None));
        for (extra, key, says) in [
            ("fourcc = \"RGB\"\n", "camera[0].fourcc", "4 ASCII characters"),
            ("black = 64\n", "camera[0].white", "camera[0].black is set"),
            ("black = 64\nwhite = 64\n", "camera[0].white", "above black (64)"),
            ("white = 0\n", "camera[0].white", "1..=65535"),
        ] {
            let msg = Config::from_toml_str(&format!("{v4l2}{extra}"))
                .unwrap_err()
                .to_string();
            assert!(msg.contains(key) && msg.contains(says), "{extra}: {msg}");
        }
        let files = "[[camera]]\nname = \"a\"\nsource = \"files\"\n";
        let msg = Config::from_toml_str(files).unwrap_err().to_string();
        assert!(
            msg.contains("camera[0].path") && msg.contains("source = \"files\""),
            "{msg}"
        );
        let c = Config::from_toml_str(&format!("{files}path = \"raw\"\nsidecar = \"raw.toml\"\n")).unwrap();
        assert_eq!(c.cameras[0].source, SourceType::Files);
        let msg = Config::from_toml_str(&format!("{MIN}sidecar = \"raw.toml\"\n"))
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("camera[0].sidecar") && msg.contains("only with source = \"files\""),
            "{msg}"
        );
        for extra in ["fourcc = \"pRAA\"\n", "black = 1\nwhite = 2\n"] {
            let msg = Config::from_toml_str(&format!("{MIN}{extra}"))
                .unwrap_err()
                .to_string();
            assert!(msg.contains("only with source = \"v4l2\""), "{extra}: {msg}");
        }
    }

    #[test]
    fn frame_size_limit_is_one_key_with_a_default_and_bounds_cameras() {
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.limits.max_frame_pixels, crate::raw::limits::DEFAULT_MAX_PIXELS);
        assert_eq!(c.limits.frame_limits(), crate::raw::FrameLimits::DEFAULT);
        let c = Config::from_toml_str(&format!("[limits]\nmax_frame_pixels = 1000000\n{MIN}")).unwrap();
        assert_eq!(c.limits.frame_limits().max_pixels(), 1_000_000);
        for bad in ["0", "268435457"] {
            let msg = Config::from_toml_str(&format!("[limits]\nmax_frame_pixels = {bad}\n{MIN}"))
                .unwrap_err()
                .to_string();
            assert!(msg.contains("limits.max_frame_pixels"), "{msg}");
        }
        let msg = Config::from_toml_str(&format!(
            "[limits]\nmax_frame_pixels = 1000000\n{MIN}width = 2000\nheight = 1000\n"
        ))
        .unwrap_err()
        .to_string();
        assert!(
            msg.contains("camera[0].width") && msg.contains("max_frame_pixels"),
            "{msg}"
        );
    }

    #[test]
    fn defaults_fill_missing_sections() {
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.daemon, DaemonConfig::default());
        assert_eq!(c.compute.orientation_bins, 9);
        assert_eq!(c.cameras[0].cfa, Cfa::Rggb);
    }

    #[test]
    fn publish_root_is_auto_by_default_or_an_absolute_path() {
        assert_eq!(Config::from_toml_str(MIN).unwrap().publish.root, Iox2Root::Auto);
        let with = |v: &str| Config::from_toml_str(&format!("[publish]\nroot = {v:?}\n{MIN}"));
        assert_eq!(with("auto").unwrap().publish.root, Iox2Root::Auto);
        assert_eq!(
            with("/srv/iox").unwrap().publish.root,
            Iox2Root::Path(PathBuf::from("/srv/iox"))
        );
        let msg = with("iox").unwrap_err().to_string();
        assert!(
            msg.contains("publish.root") && msg.contains("\"auto\" or an absolute path"),
            "{msg}"
        );
        // Written back as it was read.
        let c = with("auto").unwrap();
        let text = toml::to_string(&c.publish).unwrap();
        assert!(text.contains("root = \"auto\""), "{text}");
    }

    #[test]
    fn every_range_error_names_its_key() {
        let cases = [
            ("[daemon]\nthreads = 0\n", "daemon.threads"),
            ("[daemon]\nthreads = 1000\n", "daemon.threads"),
            ("[daemon]\nmax_in_flight = 0\n", "daemon.max_in_flight"),
            ("[daemon]\nqueue_depth = 0\n", "daemon.queue_depth"),
            ("[daemon]\nstats_interval_ms = 1\n", "daemon.stats_interval_ms"),
            (
                "[daemon]\nshutdown_timeout_ms = 0\n",
                "daemon.shutdown_timeout_ms",
            ),
            ("[publish]\nsubscriber_buffer = 0\n", "publish.subscriber_buffer"),
            ("[publish]\nservice_prefix = \"a/b\"\n", "publish.service_prefix"),
            ("[compute]\nstrip_rows = 3\n", "compute.strip_rows"),
            ("[compute]\norientation_bins = 0\n", "compute.orientation_bins"),
            ("[compute]\nscale_step = 1.0\n", "compute.scale_step"),
            ("[compute]\nupsample = 9.0\n", "compute.upsample"),
            ("[compute]\nupsample = 0.5\n", "compute.upsample"),
            ("[compute]\napprox_levels = 0\n", "compute.approx_levels"),
            ("[compute]\napprox_levels = 65\n", "compute.approx_levels"),
            ("[compute]\nsvm = \"f16\"\n", "compute.svm"),
            ("[compute]\nmosaic_taps = \"diagonal\"\n", "compute.mosaic_taps"),
            ("[compute]\nmosaic_tone = \"gamma\"\n", "compute.mosaic_tone"),
            (
                "[compute]\nkeypoint_descriptors = true\n",
                "compute.keypoint_descriptors",
            ),
            ("[compute]\nkeypoints_double = true\n", "compute.keypoints_double"),
            ("[compute]\nwb_gains = \"warm\"\n", "compute.wb_gains"),
            ("[compute]\nwb_gains = \"2,1\"\n", "compute.wb_gains"),
            ("[compute]\nwb_gains = \"2,0,1\"\n", "compute.wb_gains"),
            ("[compute]\nwb_gains = \"20,1,1\"\n", "compute.wb_gains"),
            ("[record]\nflush_frames = 0\n", "record.flush_frames"),
            ("[record]\nrotate_secs = 31536001\n", "record.rotate_secs"),
            ("[record]\nmax_files = 3\n", "record.max_files"),
            ("[record]\nretry_ms = 86400001\n", "record.retry_ms"),
            (
                "[record]\nrotate_mb = 1\nmax_files = 3\noverwrite = true\n",
                "record.max_files",
            ),
            ("[metrics]\ntextfile = \"mosaicd.txt\"\n", "metrics.textfile"),
            ("[metrics]\ntextfile = \"/var/lib/x/.prom\"\n", "metrics.textfile"),
        ];
        for (extra, key) in cases {
            let err = Config::from_toml_str(&format!("{extra}{MIN}")).unwrap_err();
            let msg = err.to_string();
            assert!(msg.contains(key), "{msg} should name {key}");
            assert!(msg.contains("allowed"), "{msg} should give the range");
        }
        let cam_cases = [
            ("width = 3\n", "camera[0].width"),
            ("height = 0\n", "camera[0].height"),
            ("bit_depth = 17\n", "camera[0].bit_depth"),
            ("cfa = \"RGBW\"\n", "camera[0].cfa"),
            ("fps = 0.0\n", "camera[0].fps"),
        ];
        for (extra, key) in cam_cases {
            let msg = Config::from_toml_str(&format!("{MIN}{extra}"))
                .unwrap_err()
                .to_string();
            assert!(msg.contains(key), "{msg} should name {key}");
        }
    }

    #[test]
    fn mosaic_tone_and_gains_default_to_the_model_and_auto_and_parse() {
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.compute.mosaic_tone, None);
        assert_eq!(c.compute.wb_gains, Gains::Auto);
        let c = Config::from_toml_str(&format!(
            "[compute]\nmosaic_tone = \"linear\"\nwb_gains = \"1.9, 1, 1.6\"\n{MIN}"
        ))
        .unwrap();
        assert_eq!(c.compute.mosaic_tone, Some(MosaicTone::Linear));
        assert_eq!(c.compute.wb_gains, Gains::Fixed([1.9, 1.0, 1.6]));
        for (text, g) in [
            ("file", Gains::FromFile),
            ("grey-world", Gains::GreyWorld),
            ("none", Gains::None),
        ] {
            let c = Config::from_toml_str(&format!("[compute]\nwb_gains = \"{text}\"\n{MIN}")).unwrap();
            assert_eq!(c.compute.wb_gains, g);
        }
    }

    #[test]
    fn mosaic_taps_default_to_the_model_and_parse() {
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.compute.mosaic_taps, None);
        let c = Config::from_toml_str(&format!("[compute]\nmosaic_taps = \"paper\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.mosaic_taps, Some(MosaicTaps::Paper));
        let c = Config::from_toml_str(&format!("[compute]\nmosaic_taps = \"same-site\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.mosaic_taps, Some(MosaicTaps::SameSite));
    }

    #[test]
    fn a_refused_typed_value_names_its_key_the_value_and_what_is_allowed() {
        let v4l2 = "[[camera]]\nname = \"v\"\nsource = \"v4l2\"\ndevice = \"/dev/video0\"\n";
        let cases = [
            (
                format!("{MIN}cfa = \"RGBW\"\n"),
                "`camera[0].cfa` = \"RGBW\" is out of range: allowed one of RGGB, BGGR, GRBG, GBRG",
            ),
            // the key carries the camera's index, in an inline table too
            (
                format!("{MIN}{v4l2}cfa = \"rggbx\"\n"),
                "`camera[1].cfa` = \"rggbx\" is out of range: allowed one of RGGB, BGGR, GRBG, GBRG",
            ),
            (
                "camera = [{ name = \"a\", source = \"synthetic\" }, { name = \"b\", source = \"synthetic\", cfa = \"X\" }]\n"
                    .to_string(),
                "`camera[1].cfa` = \"X\" is out of range: allowed one of RGGB, BGGR, GRBG, GBRG",
            ),
            (
                format!("{MIN}{v4l2}fourcc = \"RGB\"\n"),
                "`camera[1].fourcc` = \"RGB\" is out of range: allowed 4 ASCII characters, e.g. \"pRAA\" or \"RGGB\"",
            ),
            (
                format!("{v4l2}fourcc = \"RGé\"\n"),
                "`camera[0].fourcc` = \"RGé\" is out of range: allowed 4 ASCII characters, e.g. \"pRAA\" or \"RGGB\"",
            ),
            (
                format!("[compute]\ndetector = \"ACF\"\n{MIN}"),
                "`compute.detector` = \"ACF\" is out of range: allowed one of \"hog\", \"acf\"",
            ),
            (
                format!("[compute]\nsvm = \"f16\"\n{MIN}"),
                "`compute.svm` = \"f16\" is out of range: allowed one of \"f32\", \"i8\", \"auto\"",
            ),
            (
                format!("[compute]\nmosaic_taps = \"Paper\"\n{MIN}"),
                "`compute.mosaic_taps` = \"Paper\" is out of range: allowed one of \"model\", \"same-site\", \"paper\"",
            ),
            (
                format!("[compute]\nmosaic_tone = \"gamma\"\n{MIN}"),
                "`compute.mosaic_tone` = \"gamma\" is out of range: allowed one of \"model\", \"linear\", \"srgb\"",
            ),
            // a dotted key outside its table
            (
                format!("compute.wb_gains = \"2,0,1\"\n{MIN}"),
                "`compute.wb_gains` = \"2,0,1\" is out of range: allowed \"auto\", \"file\", \"grey-world\", \"none\" or \"R,G,B\" (each finite, > 0 and < 16)",
            ),
            (
                format!("[foxglove]\nlisten = \"localhost\"\n{MIN}"),
                "`foxglove.listen` = \"localhost\" is out of range: allowed an IP address and port, e.g. \"127.0.0.1:8765\" or \"[::1]:8765\"",
            ),
            // a refused value that reads like the message itself
            (
                format!("[compute]\nsvm = \"x is out of range: allowed y\"\n{MIN}"),
                "`compute.svm` = \"x is out of range: allowed y\" is out of range: allowed one of \"f32\", \"i8\", \"auto\"",
            ),
        ];
        for (text, want) in cases {
            let err = Config::from_toml_str(&text).unwrap_err();
            assert!(matches!(err, ConfigError::OutOfRange { .. }), "{text}: {err:?}");
            assert_eq!(err.to_string(), format!("config key {want}"), "{text}");
        }
        // A value of the wrong type is the parser's error, naming the key and the line.
        let msg = Config::from_toml_str(&format!("{MIN}cfa = 3\n"))
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("config <string>: TOML parse error at line 4") && msg.contains("cfa = 3"),
            "{msg}"
        );
    }

    #[test]
    fn typed_values_are_written_back_as_their_names() {
        let c = Config::from_toml_str(MIN).unwrap();
        let text = toml::to_string(&c).unwrap();
        for line in [
            "detector = \"hog\"",
            "svm = \"auto\"",
            "mosaic_taps = \"model\"",
            "mosaic_tone = \"model\"",
            "wb_gains = \"auto\"",
            "cfa = \"RGGB\"",
        ] {
            assert!(text.contains(line), "{line} not in {text}");
        }
        assert_eq!(Config::from_toml_str(&text).unwrap(), c);
        let set = "[compute]\ndetector = \"acf\"\nsvm = \"i8\"\nmosaic_taps = \"paper\"\nmosaic_tone = \"srgb\"\n\
             wb_gains = \"1.9,1,1.6\"\n[foxglove]\nlisten = \"[::1]:8765\"\n\
             [[camera]]\nname = \"v\"\nsource = \"v4l2\"\ndevice = \"/dev/video0\"\ncfa = \"GBRG\"\nfourcc = \"pRAA\"\n";
        let c = Config::from_toml_str(set).unwrap();
        assert_eq!(
            (
                c.compute.detector,
                c.compute.svm,
                c.compute.mosaic_taps,
                c.compute.mosaic_tone
            ),
            (
                DetectorKind::Acf,
                SvmSetting::Fixed(ScorePrecision::I8),
                Some(MosaicTaps::Paper),
                Some(MosaicTone::Srgb)
            )
        );
        assert_eq!(
            (c.cameras[0].cfa, c.cameras[0].fourcc),
            (Cfa::Gbrg, Some(*b"pRAA"))
        );
        assert_eq!(c.foxglove.listen, Some("[::1]:8765".parse().unwrap()));
        let text = toml::to_string(&c).unwrap();
        for line in [
            "detector = \"acf\"",
            "svm = \"i8\"",
            "mosaic_taps = \"paper\"",
            "mosaic_tone = \"srgb\"",
            "wb_gains = \"1.9,1,1.6\"",
            "listen = \"[::1]:8765\"",
            "cfa = \"GBRG\"",
            "fourcc = \"pRAA\"",
        ] {
            assert!(text.contains(line), "{line} not in {text}");
        }
        assert_eq!(Config::from_toml_str(&text).unwrap(), c);
        for g in ["file", "grey-world", "none"] {
            let c = Config::from_toml_str(&format!("[compute]\nwb_gains = {g:?}\n{MIN}")).unwrap();
            assert!(toml::to_string(&c)
                .unwrap()
                .contains(&format!("wb_gains = {g:?}")));
        }
    }

    #[test]
    fn svm_precision_is_f32_i8_or_auto() {
        // The defaults: the SVM this CPU runs fastest, the approximate pyramid, the built-in model.
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.compute.svm.precision(), ScorePrecision::auto());
        assert_eq!(c.compute.approx_levels, crate::detect::DEFAULT_APPROX_LEVELS);
        assert_eq!(c.compute.model, crate::detect::DEFAULT_MODEL);
        let c = Config::from_toml_str(&format!("[compute]\nsvm = \"f32\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.svm.precision(), ScorePrecision::F32);
        let c = Config::from_toml_str(&format!("[compute]\nsvm = \"i8\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.svm.precision(), ScorePrecision::I8);
        let c = Config::from_toml_str(&format!("[compute]\nsvm = \"auto\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.svm.precision(), ScorePrecision::auto());
        let msg = Config::from_toml_str(&format!("[compute]\nsvm = \"int8\"\n{MIN}"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            msg,
            "config key `compute.svm` = \"int8\" is out of range: allowed one of \"f32\", \"i8\", \"auto\""
        );
    }

    #[test]
    fn unknown_and_mistyped_keys_are_refused_by_name() {
        let msg = Config::from_toml_str(&format!("[daemon]\nthreadz = 2\n{MIN}"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("threadz"), "{msg}");
        let msg = Config::from_toml_str(&format!("[daemon]\nthreads = \"two\"\n{MIN}"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("threads"), "{msg}");
    }

    #[test]
    fn source_specific_keys_are_required() {
        let msg = Config::from_toml_str("[[camera]]\nname = \"a\"\nsource = \"mcap\"\n")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("camera[0].path"), "{msg}");
        let msg = Config::from_toml_str("[[camera]]\nname = \"a\"\nsource = \"v4l2\"\n")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("camera[0].device"), "{msg}");
        let msg = Config::from_toml_str("").unwrap_err().to_string();
        assert!(msg.contains("`camera`"), "{msg}");
        let msg = Config::from_toml_str(&format!("{MIN}{MIN}"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("camera[1].name"), "{msg}");
    }

    #[test]
    fn metrics_textfile_is_off_by_default_and_a_prom_file() {
        assert_eq!(Config::from_toml_str(MIN).unwrap().metrics.textfile, None);
        let c = Config::from_toml_str(&format!("[metrics]\ntextfile = \"m/mosaicd.prom\"\n{MIN}")).unwrap();
        assert_eq!(c.metrics.textfile, Some(PathBuf::from("m/mosaicd.prom")));
    }

    #[test]
    fn the_detector_is_hog_or_acf_and_acf_reads_its_own_model_key() {
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.compute.detector, DetectorKind::Hog);
        assert_eq!(c.compute.acf_model, DEFAULT_ACF_MODEL);
        assert_eq!(
            c.compute.model_key(),
            ("compute.model", crate::detect::DEFAULT_MODEL)
        );
        let c = Config::from_toml_str(&format!("[compute]\ndetector = \"acf\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.detector, DetectorKind::Acf);
        assert_eq!(c.compute.model_key(), ("compute.acf_model", DEFAULT_ACF_MODEL));
        for bad in ["ACF", "svm", ""] {
            let msg = Config::from_toml_str(&format!("[compute]\ndetector = {bad:?}\n{MIN}"))
                .unwrap_err()
                .to_string();
            assert!(
                msg.contains("compute.detector") && msg.contains("\"hog\", \"acf\""),
                "{msg}"
            );
        }
        let msg = Config::from_toml_str(&format!("[compute]\ndetector = 1\n{MIN}"))
            .unwrap_err()
            .to_string();
        assert!(msg.contains("detector"), "{msg}");
        // The empty model of the detector in use is missing; the other one's is not read.
        let msg = Config::from_toml_str(&format!("[compute]\ndetector = \"acf\"\nacf_model = \"\"\n{MIN}"))
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("compute.acf_model") && msg.contains("compute.detector = \"acf\""),
            "{msg}"
        );
        Config::from_toml_str(&format!("[compute]\nacf_model = \"\"\n{MIN}")).unwrap();
        // ACF scores are on a wider scale than the SVM's
        let hit = |lines: &str| Config::from_toml_str(&format!("[compute]\n{lines}\n{MIN}"));
        hit("detector = \"acf\"\nhit_threshold = 40.0").unwrap();
        let msg = hit("hit_threshold = 40.0").unwrap_err().to_string();
        assert!(
            msg.contains("compute.hit_threshold") && msg.contains("-10..=10"),
            "{msg}"
        );
        let msg = hit("detector = \"acf\"\nhit_threshold = -101.0")
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("compute.hit_threshold") && msg.contains("-100..=100"),
            "{msg}"
        );
        Config::from_toml_str(&format!("[compute]\ndetector = \"acf\"\nmodel = \"\"\n{MIN}")).unwrap();
    }

    #[test]
    fn the_acf_model_resolves_like_the_hog_model_when_the_detector_is_acf() {
        let dir = tempfile::tempdir().unwrap();
        let (conf, models) = (dir.path().join("etc"), dir.path().join("share"));
        std::fs::create_dir_all(&conf).unwrap();
        std::fs::create_dir_all(&models).unwrap();
        std::fs::write(models.join(DEFAULT_ACF_MODEL), "{}").unwrap();
        std::fs::write(conf.join("mine.json"), "{}").unwrap();
        let resolve = |lines: &str| {
            let mut c = Config::from_toml_str(&format!("[compute]\n{lines}\n{MIN}")).unwrap();
            let r = c.resolve_paths(&conf, std::slice::from_ref(&models));
            (c, r)
        };
        // The default file: not in the config's directory, found in the model directory.
        let (c, r) = resolve("detector = \"acf\"");
        assert_eq!(
            c.compute.acf_model,
            models.join(DEFAULT_ACF_MODEL).to_string_lossy()
        );
        assert_eq!(r[0].key, "compute.acf_model");
        assert_eq!(
            r[0].tried,
            vec![conf.join(DEFAULT_ACF_MODEL), models.join(DEFAULT_ACF_MODEL)]
        );
        // The config's directory first; HOG's key untouched.
        let (c, r) = resolve("detector = \"acf\"\nacf_model = \"mine.json\"\nmodel = \"mine.json\"");
        assert_eq!(c.compute.acf_model, conf.join("mine.json").to_string_lossy());
        assert_eq!(c.compute.model, "mine.json");
        assert_eq!(r.len(), 1, "{r:?}");
        // An ACF model is never a built-in name: a name is a file like any other.
        let (c, _) = resolve(&format!(
            "detector = \"acf\"\nacf_model = {:?}",
            crate::detect::DEFAULT_MODEL
        ));
        assert_eq!(
            c.compute.acf_model,
            conf.join(crate::detect::DEFAULT_MODEL).to_string_lossy()
        );
        // With the HOG detector the ACF key is not resolved.
        let (c, r) = resolve("acf_model = \"mine.json\"");
        assert_eq!(c.compute.acf_model, "mine.json");
        assert!(r.is_empty(), "{r:?}");
    }

    #[test]
    fn relative_inputs_resolve_against_the_config_dir_then_the_model_dirs() {
        let dir = tempfile::tempdir().unwrap();
        let (conf, models) = (dir.path().join("etc"), dir.path().join("share"));
        std::fs::create_dir_all(conf.join("local")).unwrap();
        std::fs::create_dir_all(&models).unwrap();
        std::fs::write(conf.join("local/mine.json"), "{}").unwrap();
        std::fs::write(models.join("theirs.json"), "{}").unwrap();
        let cam = "[[camera]]\nname = \"a\"\nsource = \"mcap\"\npath = \"rec/a.mcap\"\n";
        let resolve = |model: &str| {
            let mut c = Config::from_toml_str(&format!("[compute]\nmodel = {model:?}\n{cam}")).unwrap();
            let r = c.resolve_paths(&conf, std::slice::from_ref(&models));
            (c, r)
        };
        // The config's directory first, then the model directories.
        let (c, r) = resolve("local/mine.json");
        assert_eq!(c.compute.model, conf.join("local/mine.json").to_string_lossy());
        assert_eq!(r[0].key, "compute.model");
        assert_eq!(
            r[0].tried,
            vec![conf.join("local/mine.json"), models.join("local/mine.json")]
        );
        let (c, _) = resolve("theirs.json");
        assert_eq!(c.compute.model, models.join("theirs.json").to_string_lossy());
        // Found nowhere: the config's directory, so that the error names it; every place tried.
        let (c, r) = resolve("none.json");
        assert_eq!(c.compute.model, conf.join("none.json").to_string_lossy());
        assert!(!r[0].exists() && r[0].tried.len() == 2);
        // Built-in names and absolute paths are left alone; camera paths join the config's dir.
        for model in [
            crate::detect::DEFAULT_MODEL,
            crate::detect::OPENCV_DEFAULT,
            "/abs/m.json",
        ] {
            let (c, r) = resolve(model);
            assert_eq!(c.compute.model, model);
            assert_eq!(r.len(), 1, "{r:?}");
            assert_eq!(r[0].key, "camera[0].path");
            assert_eq!(
                c.cameras[0].path.as_deref(),
                Some(conf.join("rec/a.mcap").as_path())
            );
        }
        // Outputs stay relative (to the working directory: the units' state directory).
        let (c, _) = resolve("theirs.json");
        assert_eq!(c.record.path, PathBuf::from("out/{camera}.mcap"));
    }

    #[test]
    fn record_path_substitutes_camera() {
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.record_path("front"), PathBuf::from("out/front.mcap"));
        // Two recording cameras on one path would share (and prune) one ring of files.
        let two = format!("{MIN}[[camera]]\nname = \"b\"\nsource = \"synthetic\"\n");
        let err = Config::from_toml_str(&format!("[record]\nenabled = true\npath = \"x.mcap\"\n{two}"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("record.path") && err.contains("{camera}"), "{err}");
        assert!(Config::from_toml_str(&format!("[record]\nenabled = true\n{two}")).is_ok());
        assert!(Config::from_toml_str(&format!("[record]\npath = \"x.mcap\"\n{two}")).is_ok());
    }
}
