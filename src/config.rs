//! Typed daemon configuration, validated once at start-up.
//!
//! The daemon reads one TOML file (`config/mosaicd.toml` by default; every key is documented
//! there). Parsing is strict: an unknown key is refused, a value of the wrong type is refused with
//! its key, and [`Config::validate`] checks every range once, at start-up, with an error that NAMES
//! the key and the allowed range ([`ConfigError`]). Nothing downstream re-checks.
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

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::detect::people::DetectorKind;
use crate::detect::ScorePrecision;
use crate::features::hog::{MosaicTaps, MosaicTone};
use crate::raw::levels::{Compression, Gains, NormaliseOptions};
use crate::raw::Cfa;

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

/// The default `compute.acf_model`: the shipped raw-mosaic ACF model (`models/acf-mosaic.json`,
/// installed into [`SYSTEM_MODEL_DIR`]).
pub const DEFAULT_ACF_MODEL: &str = "acf-mosaic.json";

/// Errors from loading or validating a configuration. Each names the offending key.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The TOML did not parse or a key is unknown or of the wrong type (the message names the key).
    #[error("config {origin}: {message}")]
    Parse {
        /// File name or `<string>`.
        origin: String,
        /// The parser's message (names the key and line).
        message: String,
    },
    /// A value is outside its allowed range.
    #[error("config key `{key}` = {value} is out of range: allowed {allowed}")]
    OutOfRange {
        /// Dotted key, e.g. `daemon.threads` or `camera[0].width`.
        key: String,
        /// The value found.
        value: String,
        /// The allowed range, in words.
        allowed: String,
    },
    /// A key the chosen source needs is missing.
    #[error("config key `{key}` is required when {when}")]
    Missing {
        /// Dotted key.
        key: String,
        /// The condition that makes it required.
        when: String,
    },
    /// Two cameras share a name.
    #[error("config key `camera[{index}].name` = {name:?} is used twice: camera names must be unique")]
    DuplicateCamera {
        /// Index of the second camera with the name.
        index: usize,
        /// The name.
        name: String,
    },
}

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

/// `[limits]`: bounds on what inputs may claim, checked before anything is allocated for them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Largest frame in pixels (`4..=268435456`, default 2^26 = 67108864, "64 MP"), from any
    /// source: recordings, files, cameras ([`crate::raw::limits`]; a side is at most 16384).
    pub max_frame_pixels: u64,
}

impl Default for LimitsConfig {
    fn default() -> Self {
        Self {
            max_frame_pixels: crate::raw::limits::DEFAULT_MAX_PIXELS,
        }
    }
}

impl LimitsConfig {
    /// The frame-size limit (valid after [`Config::validate`]; out-of-range values give the
    /// default).
    pub fn frame_limits(&self) -> crate::raw::FrameLimits {
        crate::raw::FrameLimits::new(self.max_frame_pixels).unwrap_or(crate::raw::FrameLimits::DEFAULT)
    }
}

/// `[metrics]`: fleet metrics without opening a port. With `textfile` set, the daemon writes
/// its counters in Prometheus's text format to that file every `daemon.stats_interval_ms`
/// (written to a temporary file beside it, then renamed over it), for node_exporter's textfile
/// collector ([`crate::pipeline::textfile`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricsConfig {
    /// The file, ending in `.prom` (what the collector reads), in a directory that exists;
    /// relative to the working directory. Default: none (no metrics file).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub textfile: Option<PathBuf>,
}

/// `[daemon]`: scheduling and process settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DaemonConfig {
    /// Size of the dedicated compute pool (`1..=256`).
    pub threads: usize,
    /// Frames computed concurrently per camera (`1..=64`).
    pub max_in_flight: usize,
    /// Capture queue depth per camera (`1..=1024`).
    pub queue_depth: usize,
    /// Stats period in milliseconds (`>= 50`): stats message, sd_notify STATUS, log line.
    pub stats_interval_ms: u64,
    /// Time allowed for draining at shutdown, in milliseconds (`1..=90000`).
    pub shutdown_timeout_ms: u64,
    /// Output files (the MCAP recording and the results file) leave out what depends on the wall
    /// clock: timer-driven stats records and the `"wall"` group. A replay then writes the same
    /// bytes for any thread count. `mosaicd replay` turns it on (`--wall-clock` keeps them).
    pub deterministic_outputs: bool,
}

impl Default for DaemonConfig {
    fn default() -> Self {
        Self {
            threads: 2,
            max_in_flight: 4,
            queue_depth: 4,
            stats_interval_ms: 1000,
            shutdown_timeout_ms: 10_000,
            deterministic_outputs: false,
        }
    }
}

/// `[publish]`: iceoryx2 services `<prefix>/<camera>/{detections,gradients,stats}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PublishConfig {
    /// Publish at all.
    pub enabled: bool,
    /// First component of every service name.
    pub service_prefix: String,
    /// Samples each subscriber buffers before the oldest is overwritten (`1..=4096`).
    pub subscriber_buffer: usize,
    /// Publish the gradient maps too (dynamic slices).
    pub gradients: bool,
    /// Keep every n-th gradient pixel in x and y (`1..=64`).
    pub gradients_decimation: usize,
    /// The directory iceoryx2 keeps its files in: `"auto"` (the default: resolved per process by
    /// [`crate::publish::service::resolve_root`], so that it works under systemd, as root and as an
    /// ordinary user alike) or an absolute path. Created `0750` when missing; one of another user
    /// is refused. Subscribers (`mosaicd listen`, the Python client) of the same user resolve
    /// `"auto"` to the same directory; with a path, pass them the same `--root`.
    pub root: Iox2Root,
}

/// `publish.root`: [`Iox2Root::Auto`] (written `"auto"`) or a directory.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(from = "PathBuf", into = "PathBuf")]
pub enum Iox2Root {
    /// Chosen from the process's environment and user ([`crate::publish::service::resolve_root`]).
    #[default]
    Auto,
    /// This directory (must be absolute: [`Config::validate`] refuses a relative one).
    Path(PathBuf),
}

/// How `publish.root = "auto"` and the subscribers' `--root auto` are written.
pub const AUTO_ROOT: &str = "auto";

impl From<PathBuf> for Iox2Root {
    fn from(p: PathBuf) -> Self {
        if p.as_os_str() == AUTO_ROOT {
            Self::Auto
        } else {
            Self::Path(p)
        }
    }
}

impl From<Iox2Root> for PathBuf {
    fn from(r: Iox2Root) -> Self {
        match r {
            Iox2Root::Auto => PathBuf::from(AUTO_ROOT),
            Iox2Root::Path(p) => p,
        }
    }
}

impl Default for PublishConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            service_prefix: "mosaicd".into(),
            subscriber_buffer: 64,
            gradients: false,
            gradients_decimation: 4,
            root: Iox2Root::Auto,
        }
    }
}

/// `[record]`: results (and frames) to MCAP.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RecordConfig {
    /// Record at all.
    pub enabled: bool,
    /// Output file; `{camera}` is replaced by the camera name.
    pub path: PathBuf,
    /// Also record the raw frames (lossless, full bit depth), not only results.
    pub frames: bool,
    /// Also record an 8-bit `foxglove.RawImage` preview, keeping every n-th 2x2 tile (`0` = no
    /// preview, `1..=16`).
    pub preview_decimation: u32,
    /// Flush (close the chunk) every n frames: what a crash can lose (`1..=10000`).
    pub flush_frames: u32,
    /// Start a new file after this many MiB (`0` = never, `0..=1048576`).
    pub rotate_mb: u64,
    /// Start a new file after this many seconds of recorded time (`0` = never, `0..=31536000`).
    pub rotate_secs: u64,
    /// With rotation, keep at most this many files of this path, deleting the oldest (`0` = keep
    /// all, `0..=1000000`; not with `overwrite`).
    pub max_files: u32,
    /// Overwrite an existing file at `path` instead of numbering the new recording after it
    /// (`mosaicd replay --out` sets it: a command-line output).
    pub overwrite: bool,
    /// After a write error (disk full, I/O error), try again in a new file this many
    /// milliseconds later, and then as often, until a write succeeds (`0` = stop recording for
    /// the rest of the run, `0..=86400000`). Only without `overwrite`: resuming must not
    /// truncate the file that failed.
    pub retry_ms: u64,
}

impl Default for RecordConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            path: PathBuf::from("out/{camera}.mcap"),
            frames: false,
            preview_decimation: 0,
            flush_frames: 30,
            rotate_mb: 0,
            rotate_secs: 0,
            max_files: 0,
            overwrite: false,
            retry_ms: 30_000,
        }
    }
}

/// `[foxglove]`: the live view, a WebSocket server speaking Foxglove's protocol (the `foxglove`
/// crate's), off unless `listen` is set. See `docs/daemon.md`, "Live view in Foxglove".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FoxgloveConfig {
    /// Address to listen on, `"host:port"` (e.g. `"127.0.0.1:8765"`, Foxglove's default; port 0
    /// picks a free one, logged at start). Unset: no live view, no socket.
    pub listen: Option<String>,
    /// The live preview keeps every n-th 2x2 tile of the mosaic (`1..=16`; 2 makes a 1080p frame
    /// a 960x540 `foxglove.RawImage`, 518 kB).
    pub preview_decimation: u32,
    /// Messages queued per client before its oldest are dropped (`4..=4096`): a slow or
    /// vanished client holds at most this many (an image, its boxes, keypoints, stats: about
    /// 3 per frame), and only it loses them.
    pub client_backlog: usize,
}

impl Default for FoxgloveConfig {
    fn default() -> Self {
        Self {
            listen: None,
            preview_decimation: 2,
            client_backlog: 32,
        }
    }
}

impl FoxgloveConfig {
    /// The validated listen address (`None`: live view off).
    pub fn listen_addr(&self) -> Result<Option<std::net::SocketAddr>, ConfigError> {
        self.listen
            .as_deref()
            .map(|l| {
                l.parse().map_err(|_| ConfigError::OutOfRange {
                    key: "foxglove.listen".into(),
                    value: format!("{l:?}"),
                    allowed: "an IP address and port, e.g. \"127.0.0.1:8765\" or \"[::1]:8765\"".into(),
                })
            })
            .transpose()
    }

    /// Whether the live view is on.
    pub fn enabled(&self) -> bool {
        self.listen.is_some()
    }
}

/// `[compute]`: the per-frame stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ComputeConfig {
    /// Run pedestrian detection on the mosaic (the detector of `detector`).
    pub detect: bool,
    /// Which detector: `"hog"` (multi-scale HOG + linear SVM with the model of `model`; the
    /// default) or `"acf"` (aggregated channel features, boosted trees with a soft cascade, with
    /// the model file of `acf_model`; docs/acf.md). [`ComputeConfig::detector_kind`] parses it.
    pub detector: String,
    /// With `detector = "acf"`: the ACF model file (`mosaicd train --detector acf`; default
    /// `acf-mosaic.json`, the shipped raw-mosaic model `models/acf-mosaic.json`). A relative path
    /// is looked for like `model`'s: in the config file's directory, then in [`SYSTEM_MODEL_DIR`].
    /// The HOG-only keys (`model`, `scale_step`, `approx_levels`, `svm`, `mosaic_taps`) do not
    /// apply to it; `hit_threshold`, `max_levels`, `upsample`, `mosaic_tone` and `wb_gains` do.
    pub acf_model: String,
    /// Detector model: a built-in name ([`crate::detect::shipped::SHIPPED`]; default
    /// [`crate::detect::DEFAULT_MODEL`], compiled into the binary), `opencv-default` (OpenCV's
    /// people detector from the shared data directory,
    /// `opencv_hog/default_people_detector_64x128.npy`) or a model file (`.json` ours; `.npy`,
    /// `.yml`, text: OpenCV vectors).
    pub model: String,
    /// Score a window needs: the SVM's (OpenCV `hitThreshold`, `-10..=10`), or with
    /// `detector = "acf"` the trees' sum (`-100..=100`; a window the soft cascade rejects is never
    /// a hit).
    pub hit_threshold: f32,
    /// Scale factor between pyramid levels (`1.01..=2.0`, OpenCV 1.05).
    pub scale_step: f64,
    /// Maximum pyramid levels (`1..=64`).
    pub max_levels: usize,
    /// Start the pyramid magnified (`1.0..=4.0`; 2 finds people ~64 px tall; below 1 would drop
    /// the full-resolution level).
    pub upsample: f64,
    /// Feature-pyramid approximation (Dollár et al. 2014): every n-th level is computed exactly,
    /// the levels between are approximated from its micro-cells (`1..=64`; 1 = exact, 14 ≈ one
    /// exact level per octave; default [`crate::detect::DEFAULT_APPROX_LEVELS`]).
    pub approx_levels: usize,
    /// SVM arithmetic: `"f32"` (OpenCV's scores within 1e-6), `"i8"` (8-bit blocks and weights,
    /// exact integer sums, scores within ≈0.04 of f32: measured faster than f32 on x86-64, most
    /// with AVX-512 VNNI or AVX-VNNI; on aarch64 without the dot product it is not, which is
    /// warned about at start-up) or `"auto"` (`"i8"` where it was measured faster, `"f32"`
    /// elsewhere: [`ScorePrecision::auto_for`]; the default).
    pub svm: String,
    /// Derivative of the detector's mosaic features: `"model"` (what the model file says; OpenCV
    /// weights and files without the field: same-site), `"same-site"` (`(I(x+2) − I(x−2))/2`) or
    /// `"paper"` (`I(x+1) − I(x−1)`, the paper's `[-1, 0, 1]` on the mosaic: better on clean
    /// frames, worse under noise; docs/detection.md, "The mosaic derivative").
    pub mosaic_taps: String,
    /// How raw values become the detector's mosaic: `"model"` (what the model file says; OpenCV's
    /// weights and files without the field: `linear`), `"linear"` (black-subtracted and
    /// scaled, the paper's raw mosaic) or `"srgb"` (each site white balanced, clipped and
    /// sRGB-encoded; no demosaicing: docs/detection.md, "The mosaic's tone").
    pub mosaic_tone: String,
    /// White-balance gains of the `srgb` tone: `"auto"` (the frame's own when its source has them,
    /// otherwise a grey-world estimate from each frame), `"file"` (the frame's own; a frame
    /// without them is an error), `"grey-world"`, `"none"` or `"R,G,B"` (fixed, e.g. the
    /// camera's daylight gains).
    pub wb_gains: String,
    /// Orientation bins over 0..180 degrees (`1..=36`, the paper uses 9).
    pub orientation_bins: usize,
    /// Rows per parallel strip (`2..=4096`, even).
    pub strip_rows: usize,
    /// Also compute mosaic SIFT keypoints (super-pixel DoG, 5x5 extrema) and publish them on
    /// `<prefix>/<camera>/keypoints` and record them on `/<camera>/keypoints` (Foxglove points)
    /// and `/<camera>/sift` (full-frame keypoints, with descriptors when computed).
    pub keypoints: bool,
    /// With `keypoints`: also compute each keypoint's 128-byte SIFT descriptor (on the mosaic
    /// gradient) and publish and record it beside the keypoint.
    pub keypoint_descriptors: bool,
    /// With `keypoints`: double the colour planes first (the mosaic's analogue of OpenCV's
    /// `firstOctave = -1`): finer keypoints, at 4-5x the cost of the stage.
    pub keypoints_double: bool,
}

impl Default for ComputeConfig {
    fn default() -> Self {
        Self {
            detect: true,
            detector: DetectorKind::Hog.name().into(),
            acf_model: DEFAULT_ACF_MODEL.into(),
            model: crate::detect::DEFAULT_MODEL.into(),
            hit_threshold: 0.0,
            scale_step: 1.05,
            max_levels: 64,
            upsample: 1.0,
            approx_levels: crate::detect::DEFAULT_APPROX_LEVELS,
            svm: "auto".into(),
            mosaic_taps: "model".into(),
            mosaic_tone: "model".into(),
            wb_gains: "auto".into(),
            orientation_bins: 9,
            strip_rows: 64,
            keypoints: false,
            keypoint_descriptors: false,
            keypoints_double: false,
        }
    }
}

/// Which kind of source a camera reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SourceType {
    /// An MCAP recording in our format (`path`).
    Mcap,
    /// A V4L2 device (`device`).
    V4l2,
    /// A deterministic synthetic stream generated in process (`width`, `height`, `bit_depth`,
    /// `cfa`, `frames`).
    Synthetic,
    /// Raw files played as a stream (`path`: a file or a directory of files in name order; camera
    /// raws through rawloader, mosaic PNG/PGM, RGB images sampled to a mosaic, headerless raws
    /// described by a TOML sidecar, see [`crate::capture::files`]); timestamps at `fps`.
    Files,
}

impl SourceType {
    /// The name in config files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Mcap => "mcap",
            Self::V4l2 => "v4l2",
            Self::Synthetic => "synthetic",
            Self::Files => "files",
        }
    }
}

/// `[[camera]]`: one source.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// Unique name; part of the service names (`a-z A-Z 0-9 _ -`, 1..=64 chars).
    pub name: String,
    /// Source kind: `mcap`, `v4l2`, `synthetic`.
    pub source: SourceType,
    /// MCAP recording to replay (`source = "mcap"`), or a raw file or directory of raw files
    /// (`source = "files"`).
    #[serde(default)]
    pub path: Option<PathBuf>,
    /// `source = "files"` only: a sidecar (TOML) describing every headerless file, instead of the
    /// per-file `<file>.toml` / directory `mosaicd-raw.toml` ones.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sidecar: Option<PathBuf>,
    /// V4L2 device (`source = "v4l2"`).
    #[serde(default)]
    pub device: Option<PathBuf>,
    /// Replay at the recorded rate instead of as fast as possible.
    #[serde(default)]
    pub realtime: bool,
    /// Replay in a loop.
    #[serde(default, rename = "loop")]
    pub looped: bool,
    /// Frame width (synthetic, V4L2 request) (`2..=16384`, even).
    #[serde(default = "default_width")]
    pub width: usize,
    /// Frame height (`2..=16384`, even).
    #[serde(default = "default_height")]
    pub height: usize,
    /// Bit depth (synthetic) (`8..=16`).
    #[serde(default = "default_bit_depth")]
    pub bit_depth: u8,
    /// CFA pattern (synthetic): `RGGB`, `BGGR`, `GRBG`, `GBRG`.
    #[serde(default = "default_cfa")]
    pub cfa: String,
    /// Frame rate (synthetic when live, V4L2 request) (`0 < fps <= 1000`).
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Number of frames (synthetic); 0 = endless.
    #[serde(default)]
    pub frames: u64,
    /// Treat the synthetic stream as a live camera (drop-oldest) instead of a replay.
    #[serde(default)]
    pub live: bool,
    /// V4L2 only: the preferred FourCC (4 characters, e.g. `"pRAA"`); default: the first Bayer
    /// format the driver offers, in our preference order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fourcc: Option<String>,
    /// V4L2 only: the sensor's black level in raw units (V4L2 does not report it); needs `white`.
    /// Default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub black: Option<u16>,
    /// V4L2 only: the sensor's white level in raw units. Default: full scale of the negotiated
    /// format's bit depth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub white: Option<u16>,
}

fn default_width() -> usize {
    640
}
fn default_height() -> usize {
    480
}
fn default_bit_depth() -> u8 {
    12
}
fn default_cfa() -> String {
    "RGGB".into()
}
fn default_fps() -> f64 {
    30.0
}

impl CameraConfig {
    /// A synthetic camera with the given name and size (tests, benches).
    pub fn synthetic(name: &str, width: usize, height: usize, frames: u64) -> Self {
        Self {
            name: name.into(),
            source: SourceType::Synthetic,
            path: None,
            sidecar: None,
            device: None,
            realtime: false,
            looped: false,
            width,
            height,
            bit_depth: default_bit_depth(),
            cfa: default_cfa(),
            fps: default_fps(),
            frames,
            live: false,
            fourcc: None,
            black: None,
            white: None,
        }
    }

    /// The sensor levels for a V4L2 camera (`None`: 0 / full scale of the negotiated format).
    pub fn levels(&self) -> Option<crate::raw::Levels> {
        self.white
            .map(|w| crate::raw::Levels::uniform(self.black.unwrap_or(0), w))
    }

    /// The preferred FourCC for a V4L2 camera (validated by [`Config::validate`]).
    pub fn fourcc_bytes(&self) -> Option<[u8; 4]> {
        self.fourcc
            .as_deref()
            .and_then(crate::capture::v4l2_formats::parse_fourcc)
    }

    /// The parsed CFA pattern (validated by [`Config::validate`]).
    pub fn cfa(&self) -> Result<Cfa, ConfigError> {
        parse_cfa(&self.cfa).ok_or_else(|| ConfigError::OutOfRange {
            key: "camera.cfa".into(),
            value: format!("{:?}", self.cfa),
            allowed: "one of RGGB, BGGR, GRBG, GBRG".into(),
        })
    }
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

/// A `"model"`-or-value key: `None` for `"model"` (the model file's own), else `value` parsed.
fn model_override<T: std::str::FromStr>(
    key: &str,
    value: &str,
    allowed: &str,
) -> Result<Option<T>, ConfigError> {
    match value {
        "model" => Ok(None),
        s => s.parse().map(Some).map_err(|_| ConfigError::OutOfRange {
            key: key.into(),
            value: format!("{value:?}"),
            allowed: allowed.into(),
        }),
    }
}

impl ComputeConfig {
    /// `detector` parsed.
    pub fn detector_kind(&self) -> Result<DetectorKind, ConfigError> {
        self.detector.parse().map_err(|_| ConfigError::OutOfRange {
            key: "compute.detector".into(),
            value: format!("{:?}", self.detector),
            allowed: "one of \"hog\", \"acf\"".into(),
        })
    }

    /// The model file or name the configured detector reads, and its key: `acf_model` for
    /// `detector = "acf"`, else `model`.
    pub fn model_key(&self) -> Result<(&'static str, &str), ConfigError> {
        Ok(match self.detector_kind()? {
            DetectorKind::Hog => ("compute.model", &self.model),
            DetectorKind::Acf => ("compute.acf_model", &self.acf_model),
        })
    }

    /// `mosaic_taps` parsed: `None` = the model's own.
    pub fn mosaic_taps_override(&self) -> Result<Option<MosaicTaps>, ConfigError> {
        model_override(
            "compute.mosaic_taps",
            &self.mosaic_taps,
            "one of \"model\", \"same-site\", \"paper\"",
        )
    }

    /// `mosaic_tone` parsed: `None` = the model's own.
    pub fn mosaic_tone_override(&self) -> Result<Option<MosaicTone>, ConfigError> {
        model_override(
            "compute.mosaic_tone",
            &self.mosaic_tone,
            "one of \"model\", \"linear\", \"srgb\"",
        )
    }

    /// `wb_gains` parsed (fixed gains checked: finite, > 0 and < 16).
    pub fn wb_gains(&self) -> Result<Gains, ConfigError> {
        let bad = || ConfigError::OutOfRange {
            key: "compute.wb_gains".into(),
            value: format!("{:?}", self.wb_gains),
            allowed: "\"auto\", \"file\", \"grey-world\", \"none\" or \"R,G,B\" (each finite, > 0 and < 16)"
                .into(),
        };
        let g: Gains = self.wb_gains.parse().map_err(|_| bad())?;
        NormaliseOptions {
            gains: g,
            compression: Compression::None,
        }
        .build()
        .map_err(|_| bad())?;
        Ok(g)
    }

    /// `svm` parsed (`"auto"` resolved for this CPU's kernel path).
    pub fn svm_precision(&self) -> Result<ScorePrecision, ConfigError> {
        self.svm.parse().map_err(|_| ConfigError::OutOfRange {
            key: "compute.svm".into(),
            value: format!("{:?}", self.svm),
            allowed: "one of \"f32\", \"i8\", \"auto\"".into(),
        })
    }
}

fn parse_cfa(s: &str) -> Option<Cfa> {
    match s.to_ascii_uppercase().as_str() {
        "RGGB" => Some(Cfa::Rggb),
        "BGGR" => Some(Cfa::Bggr),
        "GRBG" => Some(Cfa::Grbg),
        "GBRG" => Some(Cfa::Gbrg),
        _ => None,
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
        let acf = matches!(self.compute.detector_kind(), Ok(DetectorKind::Acf));
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
        let cfg: Config = toml::from_str(s).map_err(|e| ConfigError::Parse {
            origin: origin.into(),
            message: e.to_string().trim().replace('\n', " "),
        })?;
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
        self.foxglove.listen_addr()?;
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
        let hit = match c.detector_kind()? {
            DetectorKind::Hog => 10.0,
            DetectorKind::Acf => 100.0,
        };
        range("compute.hit_threshold", c.hit_threshold, -hit, hit)?;
        range("compute.scale_step", c.scale_step, 1.01, 2.0)?;
        range("compute.max_levels", c.max_levels, 1, 64)?;
        range("compute.upsample", c.upsample, 1.0, 4.0)?;
        range("compute.approx_levels", c.approx_levels, 1, 64)?;
        c.svm_precision()?;
        let (model_key, model) = c.model_key()?;
        c.mosaic_taps_override()?;
        c.mosaic_tone_override()?;
        c.wb_gains()?;
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
                when: format!("compute.detect = true and compute.detector = {:?}", c.detector),
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
            if parse_cfa(&cam.cfa).is_none() {
                return Err(ConfigError::OutOfRange {
                    key: key("cfa"),
                    value: format!("{:?}", cam.cfa),
                    allowed: "one of RGGB, BGGR, GRBG, GBRG".into(),
                });
            }
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
                ("fourcc", cam.fourcc.as_ref().map(|f| format!("{f:?}"))),
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
            if let Some(f) = &cam.fourcc {
                if !f.is_ascii() || crate::capture::v4l2_formats::parse_fourcc(f).is_none() {
                    return Err(ConfigError::OutOfRange {
                        key: key("fourcc"),
                        value: format!("{f:?}"),
                        allowed: "4 ASCII characters, e.g. \"pRAA\" or \"RGGB\"".into(),
                    });
                }
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

    const MIN: &str = "[[camera]]\nname = \"a\"\nsource = \"synthetic\"\n";

    #[test]
    fn v4l2_cameras_take_a_fourcc_and_sensor_levels_and_others_refuse_them() {
        let v4l2 = "[[camera]]\nname = \"a\"\nsource = \"v4l2\"\ndevice = \"/dev/video0\"\n";
        let c =
            Config::from_toml_str(&format!("{v4l2}fourcc = \"pRAA\"\nblack = 64\nwhite = 1023\n")).unwrap();
        let cam = &c.cameras[0];
        assert_eq!(cam.fourcc_bytes(), Some(*b"pRAA"));
        assert_eq!(cam.levels(), Some(crate::raw::Levels::uniform(64, 1023)));
        let c = Config::from_toml_str(&format!("{v4l2}white = 4095\n")).unwrap();
        assert_eq!(c.cameras[0].levels(), Some(crate::raw::Levels::uniform(0, 4095)));
        let c = Config::from_toml_str(v4l2).unwrap();
        assert_eq!((c.cameras[0].levels(), c.cameras[0].fourcc_bytes()), (None, None));
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
        assert_eq!(c.cameras[0].cfa().unwrap(), Cfa::Rggb);
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
        assert_eq!(c.compute.mosaic_tone_override().unwrap(), None);
        assert_eq!(c.compute.wb_gains().unwrap(), Gains::Auto);
        let c = Config::from_toml_str(&format!(
            "[compute]\nmosaic_tone = \"linear\"\nwb_gains = \"1.9, 1, 1.6\"\n{MIN}"
        ))
        .unwrap();
        assert_eq!(
            c.compute.mosaic_tone_override().unwrap(),
            Some(MosaicTone::Linear)
        );
        assert_eq!(c.compute.wb_gains().unwrap(), Gains::Fixed([1.9, 1.0, 1.6]));
        for (text, g) in [
            ("file", Gains::FromFile),
            ("grey-world", Gains::GreyWorld),
            ("none", Gains::None),
        ] {
            let c = Config::from_toml_str(&format!("[compute]\nwb_gains = \"{text}\"\n{MIN}")).unwrap();
            assert_eq!(c.compute.wb_gains().unwrap(), g);
        }
    }

    #[test]
    fn mosaic_taps_default_to_the_model_and_parse() {
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.compute.mosaic_taps_override().unwrap(), None);
        let c = Config::from_toml_str(&format!("[compute]\nmosaic_taps = \"paper\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.mosaic_taps_override().unwrap(), Some(MosaicTaps::Paper));
        let c = Config::from_toml_str(&format!("[compute]\nmosaic_taps = \"same-site\"\n{MIN}")).unwrap();
        assert_eq!(
            c.compute.mosaic_taps_override().unwrap(),
            Some(MosaicTaps::SameSite)
        );
    }

    #[test]
    fn svm_precision_is_f32_i8_or_auto() {
        // The defaults: the SVM this CPU runs fastest, the approximate pyramid, the built-in model.
        let c = Config::from_toml_str(MIN).unwrap();
        assert_eq!(c.compute.svm_precision().unwrap(), ScorePrecision::auto());
        assert_eq!(c.compute.approx_levels, crate::detect::DEFAULT_APPROX_LEVELS);
        assert_eq!(c.compute.model, crate::detect::DEFAULT_MODEL);
        let c = Config::from_toml_str(&format!("[compute]\nsvm = \"f32\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.svm_precision().unwrap(), ScorePrecision::F32);
        let c = Config::from_toml_str(&format!("[compute]\nsvm = \"i8\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.svm_precision().unwrap(), ScorePrecision::I8);
        let c = Config::from_toml_str(&format!("[compute]\nsvm = \"auto\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.svm_precision().unwrap(), ScorePrecision::auto());
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
        assert_eq!(c.compute.detector_kind().unwrap(), DetectorKind::Hog);
        assert_eq!(c.compute.acf_model, DEFAULT_ACF_MODEL);
        assert_eq!(
            c.compute.model_key().unwrap(),
            ("compute.model", crate::detect::DEFAULT_MODEL)
        );
        let c = Config::from_toml_str(&format!("[compute]\ndetector = \"acf\"\n{MIN}")).unwrap();
        assert_eq!(c.compute.detector_kind().unwrap(), DetectorKind::Acf);
        assert_eq!(
            c.compute.model_key().unwrap(),
            ("compute.acf_model", DEFAULT_ACF_MODEL)
        );
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
