//! Locating the shared real data (`MOSAICD_DATA`, default `../shared/data`).
//!
//! Tests, benches and evaluation read the real data sets by path and never copy them into the
//! repository. When the data is missing, [`data_path`] returns an error that says where to put it,
//! so a test that needs it fails loudly instead of passing silently.

use std::path::{Path, PathBuf};

/// Environment variable naming the data directory.
pub const DATA_ENV: &str = "MOSAICD_DATA";

/// Error when the shared data cannot be found.
#[derive(Debug, thiserror::Error)]
#[error("shared data not found at {path} (looked for {wanted}): set {DATA_ENV} to the directory holding kodak/, raw/, pedestrian/, opencv_hog/ (default ../shared/data relative to the repository)")]
pub struct DataMissing {
    /// The directory that was searched.
    pub path: PathBuf,
    /// The entry that was wanted.
    pub wanted: String,
}

/// The data directory: `$MOSAICD_DATA`, else `../shared/data` next to the crate root.
pub fn data_root() -> PathBuf {
    match std::env::var_os(DATA_ENV) {
        Some(p) => PathBuf::from(p),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data"),
    }
}

/// `data_root()/rel`, checked to exist.
pub fn data_path(rel: &str) -> Result<PathBuf, DataMissing> {
    let root = data_root();
    let p = root.join(rel);
    if p.exists() {
        Ok(p)
    } else {
        Err(DataMissing {
            path: root,
            wanted: rel.to_string(),
        })
    }
}

/// Like [`data_path`] but panics with the explanatory message; for tests and benches.
pub fn require(rel: &str) -> PathBuf {
    data_path(rel).unwrap_or_else(|e| panic!("{e}"))
}
