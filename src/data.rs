//! Locating the shared real data (`MOSAICD_DATA`).
//!
//! Tests, benches and evaluation read the real data sets by path and never copy them into the
//! repository. The data directory is `$MOSAICD_DATA` and nothing else: no path is compiled into
//! the binary, so an installed daemon never looks for a checkout's `../shared`. In a checkout,
//! cargo (`.cargo/config.toml`, `[env]`) and the Makefile set it to `../shared/data` beside the
//! repository unless it is already set. When the data is missing, [`data_path`] returns an error
//! that says where to put it, so a test that needs it fails loudly instead of passing silently.

use crate::raw::Cfa;
use std::path::PathBuf;

/// Environment variable naming the data directory.
pub const DATA_ENV: &str = "MOSAICD_DATA";

/// What the data directory holds, for messages.
const DATA_HOLDS: &str = "kodak/, raw/, pedestrian/, opencv_hog/";

/// Error when the shared data cannot be found.
#[derive(Debug, thiserror::Error)]
pub enum DataMissing {
    /// `$MOSAICD_DATA` is not set.
    #[error("shared data wanted ({wanted}) but {DATA_ENV} is not set: set it to the directory holding {DATA_HOLDS} (in a checkout, cargo and make set it to the shared data beside the repository)")]
    Unset {
        /// The entry that was wanted.
        wanted: String,
    },
    /// The entry is not in the data directory.
    #[error("shared data not found at {path} (looked for {wanted}): set {DATA_ENV} to the directory holding {DATA_HOLDS}")]
    NotFound {
        /// The directory that was searched.
        path: PathBuf,
        /// The entry that was wanted.
        wanted: String,
    },
}

/// The data directory, `$MOSAICD_DATA` (`wanted` names what it is needed for, in the error).
pub fn data_root_for(wanted: &str) -> Result<PathBuf, DataMissing> {
    match std::env::var_os(DATA_ENV) {
        Some(p) if !p.is_empty() => Ok(PathBuf::from(p)),
        _ => Err(DataMissing::Unset {
            wanted: wanted.to_string(),
        }),
    }
}

/// The data directory, `$MOSAICD_DATA`.
pub fn data_root() -> Result<PathBuf, DataMissing> {
    data_root_for("the data directory")
}

/// `data_root()/rel`, checked to exist.
pub fn data_path(rel: &str) -> Result<PathBuf, DataMissing> {
    let root = data_root_for(rel)?;
    let p = root.join(rel);
    if p.exists() {
        Ok(p)
    } else {
        Err(DataMissing::NotFound {
            path: root,
            wanted: rel.to_string(),
        })
    }
}

/// A raw scene of the shared data could not be found or loaded.
#[derive(Debug, thiserror::Error)]
pub enum RawSceneError {
    /// The file is not in the data directory.
    #[error(transparent)]
    Missing(#[from] DataMissing),
    /// The file does not load as the format the catalogue states.
    #[error(transparent)]
    Raw(#[from] crate::raw::RawError),
}

/// A real raw frame of the shared data set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawInput {
    /// Short name.
    pub name: &'static str,
    /// Path under the data root.
    pub rel: &'static str,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Pattern.
    pub cfa: Cfa,
    /// Significant bits (8 → `u8` container, else little-endian `u16`).
    pub bit_depth: u8,
    /// Black level.
    pub black: u16,
    /// White level.
    pub white: u16,
    /// The sensor's tuning (white balance, colour matrix) is the shipped Infinite-ISP profile;
    /// otherwise the forward ISP uses unit gains and an identity matrix (no tuning is known).
    pub infinite_isp_profile: bool,
}

/// One of the Infinite-ISP sensor's 2592x1536 8-bit GRBG scenes.
const fn infinite_isp(name: &'static str, rel: &'static str) -> RawInput {
    RawInput {
        name,
        rel,
        width: 2592,
        height: 1536,
        cfa: Cfa::Grbg,
        bit_depth: 8,
        // 50/1023 of the 10-bit original, cut to 8 bits.
        black: 12,
        white: 255,
        infinite_isp_profile: true,
    }
}

/// The five Infinite-ISP scenes (indoor, park, playground, wall, car park); none shows a person,
/// so they are real-sensor negatives for the detector (`mosaicd train --raw-negatives`).
pub const INFINITE_ISP_SCENES: [RawInput; 5] = [
    infinite_isp(
        "infinite_indoor1",
        "raw/infinite_isp_8bit/Indoor1_2592x1536_8bit_GRBG.raw",
    ),
    infinite_isp(
        "infinite_outdoor1",
        "raw/infinite_isp_8bit/Outdoor1_2592x1536_8bit_GRBG.raw",
    ),
    infinite_isp(
        "infinite_outdoor2",
        "raw/infinite_isp_8bit/Outdoor2_2592x1536_8bit_GRBG.raw",
    ),
    infinite_isp(
        "infinite_outdoor3",
        "raw/infinite_isp_8bit/Outdoor3_2592x1536_8bit_GRBG.raw",
    ),
    infinite_isp(
        "infinite_outdoor4",
        "raw/infinite_isp_8bit/Outdoor4_2592x1536_8bit_GRBG.raw",
    ),
];

/// OpenISP's 1920x1080 10-bit RGGB test chart (`raw/openisp/test.RAW`): the benchmarks' frame,
/// which they promote to a 12-bit container ([`crate::raw::RawFrame::promoted`]).
pub const OPENISP_TEST: RawInput = RawInput {
    name: "openisp_test",
    rel: "raw/openisp/test.RAW",
    width: 1920,
    height: 1080,
    cfa: Cfa::Rggb,
    bit_depth: 10,
    black: 0,
    white: 1023,
    infinite_isp_profile: false,
};

/// The real raw frames used by the experiments (see the data directory's `README.md`).
pub const RAW_INPUTS: [RawInput; 3] = [
    RawInput {
        name: "nikon_rose",
        rel: "raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw",
        width: 768,
        height: 512,
        cfa: Cfa::Rggb,
        bit_depth: 14,
        black: 600,
        white: 15520,
        infinite_isp_profile: false,
    },
    INFINITE_ISP_SCENES[1],
    INFINITE_ISP_SCENES[0],
];

/// The first `limit` raw inputs (all when `None`).
pub fn raw_inputs(limit: Option<usize>) -> &'static [RawInput] {
    &RAW_INPUTS[..limit.unwrap_or(RAW_INPUTS.len()).min(RAW_INPUTS.len())]
}

/// Loads a raw input as a [`RawFrame`](crate::raw::RawFrame) with `raw::load::load_headerless`.
pub fn load_raw_frame(input: &RawInput) -> Result<crate::raw::RawFrame, RawSceneError> {
    use crate::raw::{Container, Endian, Levels, RawFormat};
    let path = crate::data::data_path(input.rel)?;
    let container = if input.bit_depth == 8 {
        Container::U8
    } else {
        Container::U16
    };
    let fmt = RawFormat::new(
        input.width,
        input.height,
        input.bit_depth,
        input.cfa,
        container,
        Endian::Little,
        Levels::uniform(input.black, input.white),
    );
    Ok(crate::raw::load::load_headerless(&path, &fmt)?)
}

/// The camera profile the forward ISP uses for a raw input.
pub fn raw_profile(input: &RawInput) -> crate::isp::CameraProfile {
    let mut p = crate::isp::CameraProfile::default();
    if !input.infinite_isp_profile {
        p.name = format!("{}-untuned", input.name);
        p.wb_gains = [1.0; 3];
        p.ccm = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    p.black_level = input.black;
    p.white_level = input.white;
    p.bit_depth = input.bit_depth;
    p.cfa = input.cfa;
    p
}

/// Like [`data_root`] but panics with the explanatory message; for tests and benches.
pub fn require_root() -> PathBuf {
    data_root().unwrap_or_else(|e| panic!("{e}"))
}

/// Like [`data_path`] but panics with the explanatory message; for tests and benches.
pub fn require(rel: &str) -> PathBuf {
    data_path(rel).unwrap_or_else(|e| panic!("{e}"))
}
