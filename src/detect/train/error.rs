//! The training error.

use std::path::PathBuf;

/// Errors of training.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// A file could not be listed or decoded.
    #[error("training data {path}: {what}")]
    Data {
        /// File or directory.
        path: PathBuf,
        /// What failed.
        what: String,
    },
    /// Detector failure.
    #[error(transparent)]
    Detect(#[from] crate::detect::DetectError),
    /// The mosaic's white balance could not be applied (bad or missing gains).
    #[error("mosaic white balance: {0}")]
    Gains(#[from] crate::raw::RawError),
    /// ACF detector or channel failure.
    #[error(transparent)]
    Acf(#[from] crate::detect::acf::AcfError),
    /// Boosting failure.
    #[error(transparent)]
    Boost(#[from] crate::detect::boost::BoostError),
    /// HOG failure.
    #[error(transparent)]
    Hog(#[from] crate::features::hog::HogError),
    /// Reverse or forward ISP failure.
    #[error(transparent)]
    Isp(#[from] crate::isp::IspError),
    /// DET curve failure (no samples).
    #[error(transparent)]
    Metrics(#[from] crate::metrics::MetricsError),
    /// A training option out of range.
    #[error("training option {what} = {value} is out of range ({allowed})")]
    BadOption {
        /// Option name.
        what: &'static str,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: &'static str,
    },
}
