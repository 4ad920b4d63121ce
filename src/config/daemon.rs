//! `[daemon]`, `[limits]` and `[metrics]`: scheduling, input limits and the metrics textfile.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// `[limits]`: bounds on what inputs may claim, checked before anything is allocated for them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LimitsConfig {
    /// Largest frame in pixels (`4..=268435456`, default 2^26 = 67108864, "64 MP"), from any
    /// source: recordings, files, cameras ([`FrameLimits`](crate::raw::FrameLimits); a side is at most 16384).
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
    /// The frame-size limit (valid after [`Config::validate`](super::Config::validate); out-of-range values give the
    /// default).
    pub fn frame_limits(&self) -> crate::raw::FrameLimits {
        crate::raw::FrameLimits::new(self.max_frame_pixels).unwrap_or(crate::raw::FrameLimits::DEFAULT)
    }
}

/// `[metrics]`: fleet metrics without opening a port. With `textfile` set, the daemon writes
/// its counters in Prometheus's text format to that file every `daemon.stats_interval_ms`
/// (written to a temporary file beside it, then renamed over it), for node_exporter's textfile
/// collector ([`render_textfile`](crate::pipeline::render_textfile)).
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
