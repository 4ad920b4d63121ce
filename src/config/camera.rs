//! `[[camera]]`: one camera's source and sensor. Its string keys `cfa` and `fourcc` are typed,
//! parsed when the file is read ([`super::value`]).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::value;
use crate::raw::Cfa;

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
    /// described by a TOML sidecar, see [`FileSource`](crate::capture::FileSource)); timestamps at `fps`.
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
    #[serde(
        default = "default_cfa",
        deserialize_with = "value::cfa_de",
        serialize_with = "value::cfa_ser"
    )]
    pub cfa: Cfa,
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
    /// format the driver offers, in our preference order. The code's bytes (ASCII).
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "value::fourcc_de",
        serialize_with = "value::fourcc_ser"
    )]
    pub fourcc: Option<[u8; 4]>,
    /// V4L2 only: the sensor's black level in raw units (V4L2 does not report it); needs `white`.
    /// Default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub black: Option<u16>,
    /// V4L2 only: the sensor's white level in raw units. Default: full scale of the negotiated
    /// format's bit depth.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub white: Option<u16>,
}

pub(super) fn default_width() -> usize {
    640
}

pub(super) fn default_height() -> usize {
    480
}

pub(super) fn default_bit_depth() -> u8 {
    12
}

pub(super) fn default_cfa() -> Cfa {
    Cfa::Rggb
}

pub(super) fn default_fps() -> f64 {
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
}
