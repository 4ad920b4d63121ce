//! `[publish]` (iceoryx2) and `[foxglove]` (the live view).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::value;

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
    /// [`crate::publish::resolve_root`], so that it works under systemd, as root and as an
    /// ordinary user alike) or an absolute path. Created `0750` when missing; one of another user
    /// is refused. Subscribers (`mosaicd listen`, the Python client) of the same user resolve
    /// `"auto"` to the same directory; with a path, pass them the same `--root`.
    pub root: Iox2Root,
}

/// `publish.root`: [`Iox2Root::Auto`] (written `"auto"`) or a directory.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(from = "PathBuf", into = "PathBuf")]
pub enum Iox2Root {
    /// Chosen from the process's environment and user ([`crate::publish::resolve_root`]).
    #[default]
    Auto,
    /// This directory (must be absolute: [`Config::validate`](super::Config::validate) refuses a relative one).
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

/// `[foxglove]`: the live view, a WebSocket server speaking Foxglove's protocol (the `foxglove`
/// crate's), off unless `listen` is set. See `docs/daemon.md`, "Live view in Foxglove".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FoxgloveConfig {
    /// Address to listen on, `"host:port"` (e.g. `"127.0.0.1:8765"`, Foxglove's default; port 0
    /// picks a free one, logged at start). Unset: no live view, no socket.
    #[serde(deserialize_with = "value::listen_de", serialize_with = "value::listen_ser")]
    pub listen: Option<std::net::SocketAddr>,
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
    /// Whether the live view is on.
    pub fn enabled(&self) -> bool {
        self.listen.is_some()
    }
}
